// Path fidelity: points added on the programmed path until PathSpline follows it (see
// path_fidelity.hpp).
#include "vmsim/planner/path_fidelity.hpp"

#include <algorithm>
#include <cmath>
#include <memory>
#include <numeric>
#include <string>
#include <utility>

#include "vmsim/common/errors.hpp"
#include "vmsim/common/files.hpp"
#include "vmsim/kinematics/kinematics.hpp"
#include "vmsim/planner/feedrate.hpp"

namespace vmsim::planner {

namespace {

using Eigen::Index;
using Eigen::Vector3d;

Index idx(std::size_t i) { return static_cast<Index>(i); }

/// A segment is graded when it is longer than this many times the size field at its ends.
constexpr double kGradingTrigger = 4.0;

double angle_between(const Vector3d& a, const Vector3d& b) { return std::atan2(a.cross(b).norm(), a.dot(b)); }

/// Above this angle [rad] between its ends' tool axes a segment turns the tool (the turning
/// tolerance applies); below it is the IKT's rounding.
constexpr double kAxisTurnsRad = 1e-9;

/// The unit vector at fraction f of the great circle from a to b (unit vectors).
Vector3d slerp(const Vector3d& a, const Vector3d& b, double f) {
  const double omega = angle_between(a, b);
  if (omega < 1e-9 || omega > 3.14159) return ((1.0 - f) * a + f * b).normalized();
  return (std::sin((1.0 - f) * omega) * a + std::sin(f * omega) * b) / std::sin(omega);
}

double distance_to_segment(const Vector3d& p, const Vector3d& a, const Vector3d& b) {
  const Vector3d ab = b - a;
  const double len2 = ab.squaredNorm();
  const double t = len2 > 0.0 ? std::clamp((p - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
  return (p - (a + t * ab)).norm();
}

/// The programmed polyline: tips and tool axes at the points (direct kinematics of q, which the
/// IKT solved from the programmed poses), each with the tool of the motion that ends there;
/// start_tip[i]: where segment i (to point i + 1) starts, the tip of its own tool at q of point
/// i (tip[i] unless the tool changes there: PathKinematics::point_tool_length_m).
}  // namespace

struct detail::ProgrammedPolyline {
  std::vector<Vector3d> tip, axis, start_tip;
};

namespace {

using Polyline = detail::ProgrammedPolyline;

Polyline programmed_polyline(const kinematics::MachineModel& machine, const kinematics::PathKinematics& path) {
  Polyline out;
  const auto n = static_cast<std::size_t>(path.q.cols());
  out.tip.resize(n);
  out.axis.resize(n);
  out.start_tip.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const kinematics::ToolPose pose = kinematics::forward_kinematics(machine, path.q.col(idx(i)), path.length_into(i));
    out.tip[i] = pose.tip_W_m;
    out.axis[i] = pose.axis_W.normalized();
    out.start_tip[i] = i + 1 < n ? kinematics::tip_with_tool_length(out.tip[i], out.axis[i], path.length_into(i),
                                                                     path.length_into(i + 1))
                                 : out.tip[i];
  }
  return out;
}

/// The path being refined, with its programmed geometry and where each point came from.
struct Working {
  kinematics::PathKinematics path;
  Polyline programmed;
  std::vector<std::size_t> source_point;
  std::vector<bool> singular;  ///< per point: inside a singular zone
  std::vector<bool> free_end;  ///< per point: the segment ending here is free (a rapid)
  std::vector<double> input_tolerance_m;  ///< per input point: the allowance of its segment
  /// The allowance of segment i (between points i and i + 1): that of the input segment it is
  /// part of (an added point's source is the end of the input segment it splits).
  double tolerance_m(std::size_t i, double default_m) const {
    if (input_tolerance_m.empty() || i + 1 >= source_point.size()) return default_m;
    return std::max(default_m, input_tolerance_m[source_point[i + 1]]);
  }
  /// A rapid is free, except a turn of the tool about its fixed tip (under tool-centre-point
  /// control the NC holds the tip on rapids too).
  bool free_segment(std::size_t i) const {
    const bool turns_in_place = i + 1 < path.turns_in_place.size() && path.turns_in_place[i + 1];
    return i + 1 < free_end.size() && free_end[i + 1] && !turns_in_place;
  }
};

/// Whether the tool axis turns between path points i and i + 1 (direct kinematics of q).
bool tool_axis_turns(const kinematics::MachineModel& machine, const kinematics::PathKinematics& path, std::size_t i) {
  const Eigen::Vector3d a = kinematics::forward_kinematics(machine, path.q.col(idx(i)), path.tool_length_m).axis_W;
  const Eigen::Vector3d b = kinematics::forward_kinematics(machine, path.q.col(idx(i + 1)), path.tool_length_m).axis_W;
  return std::atan2(a.cross(b).norm(), a.dot(b)) > 1e-7;
}

/// Stretch boundaries (path ends and corners) as a flag per point.
std::vector<bool> stretch_ends(const kinematics::PathKinematics& path) {
  std::vector<bool> end(path.s_m.size(), false);
  end.front() = end.back() = true;
  for (const auto& corner : path.corners) end[corner.point] = true;
  return end;
}

/// q of the programmed pose at fraction f of segment i (IKT seeded by the linear interpolation
/// of the neighbours' q).
/// Where an inserted point's pose sits off the programmed one (the check's insertions, below).
struct PoseOffset {
  Vector3d tip_m = Vector3d::Zero();  ///< added to the programmed tip [m]
  /// The tool axis turned this fraction of the way from the programmed axis to `towards_axis`
  /// (0: the programmed axis).
  Vector3d towards_axis = Vector3d::UnitZ();
  double axis_fraction = 0.0;
};

Eigen::VectorXd programmed_q(const kinematics::MachineModel& machine, const Working& w, std::size_t i, double f,
                             const PoseOffset& offset = {}) {
  const kinematics::PathKinematics& path = w.path;
  const Vector3d tip = (1.0 - f) * w.programmed.start_tip[i] + f * w.programmed.tip[i + 1] + offset.tip_m;
  const Vector3d programmed_axis = slerp(w.programmed.axis[i], w.programmed.axis[i + 1], f);
  const Vector3d axis = offset.axis_fraction > 0.0 ? slerp(programmed_axis, offset.towards_axis, offset.axis_fraction)
                                                   : programmed_axis;
  const Eigen::VectorXd seed = (1.0 - f) * path.q.col(idx(i)) + f * path.q.col(idx(i + 1));
  const auto result = kinematics::inverse_kinematics(machine, kinematics::ToolPose{tip, axis}, seed,
                                                     path.length_into(i + 1), path.inverse);
  if (!result) {
    const double h = path.s_m[i + 1] - path.s_m[i];
    throw InfeasibleError("path fidelity: a point added on the programmed path between path points " +
                          std::to_string(i) + " and " + std::to_string(i + 1) + " (" + path_point_label(path, i + 1) +
                          ", s = " + format_double(path.s_m[i] * 1e3) + " mm + " + format_double(f * h * 1e3) +
                          " mm) has no inverse kinematic solution: " +
                          kinematics::explain_unreachable(machine, {tip, axis}, seed, path.length_into(i + 1),
                                                          path.inverse));
  }
  return result->q;
}

/// The end slopes of every stretch from the programmed motion along its end segments (the
/// fits' slopes smooth over neighbouring points: where a long segment ends a stretch next to
/// dense ones, the fit across the gap gave slopes 200 times too large and the spline a hook).
/// One-sided second-order differences of the IKT at delta and 2 delta from the end. PathSpline
/// takes a stretch's start slope from q_s there and the incoming slope at a corner b from the
/// point before (q_s + q_ss h + q_sss h^2 / 2 at b - 1): q_ss at b - 1 is set so that it gives
/// the programmed slope (q_s, q_ss, q_sss of the other points do not enter a fitted path's
/// spline).
void set_programmed_end_slopes(const kinematics::MachineModel& machine, Working& w) {
  const std::vector<bool> end = stretch_ends(w.path);
  const std::size_t n = w.path.s_m.size();
  auto slope = [&](std::size_t i, bool at_start) {
    const double h = w.path.s_m[i + 1] - w.path.s_m[i];
    // A rapid: the axes' straight line (there is no programmed line in W to follow).
    if (w.free_segment(i)) return Eigen::VectorXd((w.path.q.col(idx(i + 1)) - w.path.q.col(idx(i))) / h);
    const double delta = std::min(0.01 * h, 1e-4);
    const double f1 = delta / h, f2 = 2.0 * delta / h;
    const Eigen::VectorXd q0 = w.path.q.col(idx(at_start ? i : i + 1));
    const Eigen::VectorXd q1 = programmed_q(machine, w, i, at_start ? f1 : 1.0 - f1);
    const Eigen::VectorXd q2 = programmed_q(machine, w, i, at_start ? f2 : 1.0 - f2);
    const Eigen::VectorXd forward = (-3.0 * q0 + 4.0 * q1 - q2) / (2.0 * delta);
    return Eigen::VectorXd(at_start ? forward : Eigen::VectorXd(-forward));
  };
  for (std::size_t i = 0; i + 1 < n; ++i) {
    if (end[i] && w.path.s_m[i + 1] - w.path.s_m[i] > 1e-12) w.path.q_s.col(idx(i)) = slope(i, true);
  }
  for (std::size_t b = 1; b < n; ++b) {
    if (!end[b] || !(w.path.s_m[b] - w.path.s_m[b - 1] > 1e-12)) continue;
    const Eigen::VectorXd incoming = slope(b - 1, false);
    if (b + 1 == n) {
      w.path.q_s.col(idx(b)) = incoming;
    } else {
      const double h = w.path.s_m[b] - w.path.s_m[b - 1];
      w.path.q_ss.col(idx(b - 1)) = (incoming - w.path.q_s.col(idx(b - 1))) / h;
      w.path.q_sss.col(idx(b - 1)).setZero();
    }
  }
}

/// Inserts points at the given fractions (sorted, in (0, 1)) of segments (sorted, distinct);
/// returns per new point whether it was inserted. offsets (optional, one per fraction of each
/// cut): where the inserted pose sits off the programmed one (the check's insertions, below);
/// the programmed geometry of the new point stays on the segment.
std::vector<bool> insert_points(const kinematics::MachineModel& machine, Working& w,
                                const std::vector<std::pair<std::size_t, std::vector<double>>>& cuts,
                                const std::vector<std::vector<PoseOffset>>* offsets = nullptr) {
  const kinematics::PathKinematics& old = w.path;
  const std::size_t n = old.s_m.size();
  std::size_t added = 0;
  for (const auto& c : cuts) added += c.second.size();
  const std::size_t m = n + added;
  const Index axes = old.q.rows();
  kinematics::PathKinematics out;
  out.s_m.resize(m);
  out.q.resize(axes, idx(m));
  out.q_s.resize(axes, idx(m));
  out.q_ss.resize(axes, idx(m));
  out.q_sss.resize(axes, idx(m));
  out.derivatives_fitted = old.derivatives_fitted;
  out.tool_length_m = old.tool_length_m;
  const bool has_lengths = old.point_tool_length_m.size() == n;
  if (has_lengths) out.point_tool_length_m.resize(m);
  out.inverse = old.inverse;
  out.block_names = old.block_names;
  const bool has_blocks = old.block.size() == n;
  if (has_blocks) out.block.resize(m);
  const bool has_turns = old.turns_in_place.size() == n;
  if (has_turns) out.turns_in_place.assign(m, false);
  Working next;
  next.input_tolerance_m = w.input_tolerance_m;  // per input point: unchanged by insertions
  next.programmed.tip.resize(m);
  next.programmed.axis.resize(m);
  next.programmed.start_tip.resize(m);
  next.source_point.resize(m);
  next.singular.resize(m);
  const bool has_free = w.free_end.size() == n;
  if (has_free) next.free_end.assign(m, false);  // points are never added in a free segment
  std::vector<bool> inserted(m, false);
  std::vector<std::size_t> new_index(n);
  std::size_t k = 0;  // next output column
  std::size_t c = 0;  // next cut entry
  auto copy_point = [&](std::size_t i) {
    new_index[i] = k;
    out.s_m[k] = old.s_m[i];
    out.q.col(idx(k)) = old.q.col(idx(i));
    out.q_s.col(idx(k)) = old.q_s.col(idx(i));
    out.q_ss.col(idx(k)) = old.q_ss.col(idx(i));
    out.q_sss.col(idx(k)) = old.q_sss.col(idx(i));
    if (has_blocks) out.block[k] = old.block[i];
    if (has_turns) out.turns_in_place[k] = old.turns_in_place[i];
    if (has_lengths) out.point_tool_length_m[k] = old.point_tool_length_m[i];
    next.programmed.tip[k] = w.programmed.tip[i];
    next.programmed.axis[k] = w.programmed.axis[i];
    next.programmed.start_tip[k] = w.programmed.start_tip[i];
    next.source_point[k] = w.source_point[i];
    next.singular[k] = w.singular[i];
    if (has_free) next.free_end[k] = w.free_end[i];
    ++k;
  };
  for (std::size_t i = 0; i < n; ++i) {
    copy_point(i);
    if (c >= cuts.size() || cuts[c].first != i) continue;
    const double h = old.s_m[i + 1] - old.s_m[i];
    for (std::size_t j = 0; j < cuts[c].second.size(); ++j) {
      const double f = cuts[c].second[j];
      const Vector3d tip = (1.0 - f) * w.programmed.start_tip[i] + f * w.programmed.tip[i + 1];
      const Vector3d axis = slerp(w.programmed.axis[i], w.programmed.axis[i + 1], f);
      out.s_m[k] = old.s_m[i] + f * h;
      out.q.col(idx(k)) = programmed_q(machine, w, i, f, offsets != nullptr ? (*offsets)[c][j] : PoseOffset{});
      // Only the stretch ends' slopes enter the spline of a fitted path; these are never ends.
      out.q_s.col(idx(k)) = (1.0 - f) * old.q_s.col(idx(i)) + f * old.q_s.col(idx(i + 1));
      out.q_ss.col(idx(k)) = (1.0 - f) * old.q_ss.col(idx(i)) + f * old.q_ss.col(idx(i + 1));
      out.q_sss.col(idx(k)) = (1.0 - f) * old.q_sss.col(idx(i)) + f * old.q_sss.col(idx(i + 1));
      if (has_blocks) out.block[k] = old.block[i + 1];
      if (has_turns) out.turns_in_place[k] = old.turns_in_place[i + 1];
      if (has_lengths) out.point_tool_length_m[k] = old.point_tool_length_m[i + 1];  // inside segment i
      next.programmed.tip[k] = tip;
      next.programmed.axis[k] = axis;
      next.programmed.start_tip[k] = tip;
      next.source_point[k] = w.source_point[i + 1];
      next.singular[k] = w.singular[i] && w.singular[i + 1];
      inserted[k] = true;
      ++k;
    }
    ++c;
  }
  for (const auto& corner : old.corners) out.corners.push_back({new_index[corner.point], corner.s_m, corner.angle_rad});
  for (const auto& zone : old.singular_zones) {
    out.singular_zones.push_back({new_index[zone.first_point], new_index[zone.last_point], zone.s_begin_m, zone.s_end_m});
  }
  next.path = std::move(out);
  w = std::move(next);
  return inserted;
}

/// Cuts (fractions of h) that grade a segment of length h from piece sizes size_start and
/// size_end at its ends, each piece at most `ratio` times the one before it.
std::vector<double> graded_cuts(double h, double size_start, double size_end, double ratio) {
  std::vector<double> from_start, from_end;
  const double growth = ratio - 1.0;
  double left = 0.0, right = h;
  for (;;) {
    const double next_left = size_start + growth * left;
    const double next_right = size_end + growth * (h - right);
    const double gap = right - left;
    if (gap <= std::max(next_left, next_right)) break;
    if (gap <= next_left + next_right) {
      from_start.push_back(left + gap * next_left / (next_left + next_right));
      break;
    }
    if (next_left <= next_right) {
      left += next_left;
      from_start.push_back(left);
    } else {
      right -= next_right;
      from_end.push_back(right);
    }
  }
  std::vector<double> out;
  out.reserve(from_start.size() + from_end.size());
  for (const double x : from_start) out.push_back(x / h);
  for (auto it = from_end.rbegin(); it != from_end.rend(); ++it) out.push_back(*it / h);
  return out;
}

struct SegmentDeviation {
  double tip_m = 0.0, tip_sigma_m = 0.0, axis_rad = 0.0, axis_sigma_m = 0.0;
  /// The spline's tip at the segment's middle less the programmed one, across the segment [m].
  Vector3d middle_offset_m = Vector3d::Zero();
  Vector3d middle_axis = Vector3d::UnitZ();  ///< the spline's tool axis at the middle
};

SegmentDeviation segment_deviation(const kinematics::MachineModel& machine, const PathSpline& spline,
                                   const Working& w, std::size_t i, int samples) {
  SegmentDeviation out;
  const double h = w.path.s_m[i + 1] - w.path.s_m[i];
  const bool rotary_turns = w.programmed.axis[i] != w.programmed.axis[i + 1];
  Eigen::VectorXd q;
  for (int k = 1; k <= samples; ++k) {
    const double f = static_cast<double>(k) / static_cast<double>(samples + 1);
    spline.evaluate(i, f * h, &q, nullptr, nullptr, nullptr);
    const kinematics::ToolPose pose = kinematics::forward_kinematics(machine, q, w.path.length_into(i + 1));
    const double d = distance_to_segment(pose.tip_W_m, w.programmed.start_tip[i], w.programmed.tip[i + 1]);
    if (d > out.tip_m) out.tip_m = d, out.tip_sigma_m = f * h;
    const Vector3d programmed_axis =
        rotary_turns ? slerp(w.programmed.axis[i], w.programmed.axis[i + 1], f) : w.programmed.axis[i];
    const double a = angle_between(pose.axis_W, programmed_axis);
    if (a > out.axis_rad) out.axis_rad = a, out.axis_sigma_m = f * h;
  }
  spline.evaluate(i, 0.5 * h, &q, nullptr, nullptr, nullptr);
  const kinematics::ToolPose middle = kinematics::forward_kinematics(machine, q, w.path.length_into(i + 1));
  const Vector3d middle_tip = middle.tip_W_m;
  out.middle_axis = middle.axis_W.normalized();
  const Vector3d chord = w.programmed.tip[i + 1] - w.programmed.start_tip[i];
  Vector3d offset = middle_tip - 0.5 * (w.programmed.start_tip[i] + w.programmed.tip[i + 1]);
  if (chord.squaredNorm() > 0.0) offset -= offset.dot(chord) / chord.squaredNorm() * chord;
  out.middle_offset_m = offset;
  return out;
}

}  // namespace

void PathFidelityOptions::validate() const {
  auto bad = [](const std::string& field, double value, const std::string& what) {
    throw InputError("path fidelity options: " + field + " = " + format_double(value) + ": " + what);
  };
  if (!(tolerance_m > 0.0) || !std::isfinite(tolerance_m)) bad("tolerance_m", tolerance_m, "must be > 0");
  if (!(turning_tolerance_m > 0.0) || !std::isfinite(turning_tolerance_m)) {
    bad("turning_tolerance_m", turning_tolerance_m, "must be > 0");
  }
  if (!(axis_tolerance_rad > 0.0) || !std::isfinite(axis_tolerance_rad)) {
    bad("axis_tolerance_rad", axis_tolerance_rad, "must be > 0");
  }
  if (!(spacing_ratio > 1.0) || !std::isfinite(spacing_ratio)) bad("spacing_ratio", spacing_ratio, "must be > 1");
  if (max_rounds < 0) bad("max_rounds", max_rounds, "must be >= 0");
  if (samples_per_segment < 1) bad("samples_per_segment", samples_per_segment, "must be >= 1");
  for (const double t : segment_tolerance_m) {
    if (!(t >= 0.0) || !std::isfinite(t)) bad("segment_tolerance_m", t, "must be >= 0 and finite");
  }
}

std::string path_point_label(const kinematics::PathKinematics& path, std::size_t point) {
  const int block = point < path.block.size() ? path.block[point] : -1;
  if (block >= 0 && static_cast<std::size_t>(block) < path.block_names.size()) {
    return "block '" + path.block_names[static_cast<std::size_t>(block)] + "'";
  }
  if (block >= 0) return "block #" + std::to_string(block);
  return "no block";
}

RefinedPath refine_path(const kinematics::MachineModel& machine, const kinematics::PathKinematics& path,
                        const PathFidelityOptions& options) {
  options.validate();
  const std::size_t n0 = path.s_m.size();
  Working w;
  w.path = path;
  w.source_point.resize(n0);
  std::iota(w.source_point.begin(), w.source_point.end(), std::size_t{0});
  RefinedPath result;
  // Paths through singular zones are left as they are for now: the IKT swings the free axis
  // there, and refining sample path 2 made it 7 times slower (open item).
  bool rotary_turns_in_singular_zone = false;  // (a 3-axis path along C is singular, and fine)
  for (const auto& zone : path.singular_zones) {
    for (std::size_t j = 0; j < machine.axes.size(); ++j) {
      if (machine.axes[j].type != kinematics::AxisType::rotary) continue;
      for (std::size_t i = zone.first_point; i <= zone.last_point && i < n0; ++i) {
        if (std::abs(path.q(idx(j), idx(i)) - path.q(idx(j), idx(zone.first_point))) > 1e-9) rotary_turns_in_singular_zone = true;
      }
    }
  }
  if (!path.derivatives_fitted || n0 < 3 || rotary_turns_in_singular_zone) {
    result.path = std::move(w.path);
    result.source_point = std::move(w.source_point);
    return result;
  }
  w.programmed = programmed_polyline(machine, path);
  if (options.free_end.size() == n0) w.free_end = options.free_end;
  if (options.segment_tolerance_m.size() == n0) w.input_tolerance_m = options.segment_tolerance_m;
  w.singular.assign(n0, false);
  for (const auto& zone : path.singular_zones) {
    for (std::size_t i = zone.first_point; i <= zone.last_point && i < n0; ++i) w.singular[i] = true;
  }

  // 1. Grading: the size field H at the points, within each stretch the smallest of the point's
  // own shorter segment and its neighbours' H grown by (ratio - 1) per metre.
  {
    const std::vector<bool> end = stretch_ends(w.path);
    const auto& s = w.path.s_m;
    const double growth = options.spacing_ratio - 1.0;
    std::vector<std::pair<std::size_t, std::vector<double>>> cuts;
    std::vector<double> size;
    std::size_t first = 0;
    for (std::size_t last = 1; last < n0; ++last) {
      if (!end[last]) continue;
      // The stretch [first, last]: its own points' sizes, swept both ways.
      size.assign(last - first + 1, 0.0);
      for (std::size_t i = first; i <= last; ++i) {
        const double before = i > first ? s[i] - s[i - 1] : INFINITY;
        const double after = i < last ? s[i + 1] - s[i] : INFINITY;
        size[i - first] = std::min(before, after);
      }
      for (std::size_t i = first + 1; i <= last; ++i) {
        size[i - first] = std::min(size[i - first], size[i - 1 - first] + growth * (s[i] - s[i - 1]));
      }
      for (std::size_t i = last; i-- > first;) {
        size[i - first] = std::min(size[i - first], size[i + 1 - first] + growth * (s[i + 1] - s[i]));
      }
      for (std::size_t i = first; i < last; ++i) {
        // Only where the ratio is large: grading a mildly uneven spacing changed sample part 1's
        // spline (and its duration by 8 %) where it already followed the path within 0.5 um.
        if (s[i + 1] - s[i] <= kGradingTrigger * std::min(size[i - first], size[i + 1 - first])) continue;
        if (w.free_segment(i)) continue;  // a rapid is not held to a line
        std::vector<double> f = graded_cuts(s[i + 1] - s[i], size[i - first], size[i + 1 - first], options.spacing_ratio);
        if (!f.empty()) {
          result.graded_points += f.size();
          cuts.emplace_back(i, std::move(f));
        }
      }
      first = last;
    }
    if (!cuts.empty()) insert_points(machine, w, cuts);
  }

  // 2. Check and refine. After a round only the segments near the added points are checked
  // again (a C2 cubic's response to a changed point decays by about 0.27 per point); a full
  // check closes the loop.
  constexpr double kTargetFraction = 0.95;  // margin for the peaks between the samples
  constexpr double kInsertedFraction = 0.95;  // an inserted tip's largest distance, of the target
  const double singular_axis_rad = std::max(options.axis_tolerance_rad, path.inverse.singular_angle_rad);
  const double target_axis_rad = kTargetFraction * options.axis_tolerance_rad;
  constexpr std::size_t kWindow = 16;
  std::vector<bool> dirty(w.path.s_m.size() - 1, true);
  bool full_check = true;
  for (;;) {
    set_programmed_end_slopes(machine, w);  // the points before the corners may be new
    const PathSpline spline(w.path);
    const std::size_t segments = w.path.s_m.size() - 1;
    std::vector<std::pair<std::size_t, std::vector<double>>> cuts;
    std::vector<std::vector<PoseOffset>> offsets;  // per cut
    PathDeviation worst;
    double worst_excess = 0.0, worst_tip_m = 0.0, worst_axis_rad = 0.0, worst_tolerance_m = 0.0;
    std::size_t worst_segment = 0;
    for (std::size_t i = 0; i < segments; ++i) {
      if (!dirty[i]) continue;  // (paths whose rotary axes turn in a singular zone are not refined)
      if (w.free_segment(i)) continue;  // a rapid: as on an NC, not held to the programmed line
      // In a singular zone where the tool axis turns, the IKT holds the free rotary axis and
      // reaches the tool axis only to within its singular angle: midpoints swing that axis and
      // do not converge (path 2). Where the tool axis stands still (a 3-axis path along C) the
      // midpoints keep the rotary axes, and the segment is refined like any other.
      if ((w.singular[i] || w.singular[i + 1]) && tool_axis_turns(machine, w.path, i)) continue;
      const SegmentDeviation d = segment_deviation(machine, spline, w, i, options.samples_per_segment);
      if (d.tip_m > worst.tip_m) worst.tip_m = d.tip_m, worst.tip_s_m = w.path.s_m[i] + d.tip_sigma_m, worst.tip_point = i + 1;
      if (d.axis_rad > worst.axis_rad) {
        worst.axis_rad = d.axis_rad, worst.axis_s_m = w.path.s_m[i] + d.axis_sigma_m, worst.axis_point = i + 1;
      }
      const bool singular = w.singular[i] || w.singular[i + 1];
      const double axis_target = singular ? singular_axis_rad : target_axis_rad;
      const double segment_tolerance_m =
          w.tolerance_m(i, angle_between(w.programmed.axis[i], w.programmed.axis[i + 1]) > kAxisTurnsRad
                               ? std::max(options.tolerance_m, options.turning_tolerance_m)
                               : options.tolerance_m);
      const double target_m = kTargetFraction * segment_tolerance_m;
      const double excess = std::max(d.tip_m / target_m, d.axis_rad / axis_target);
      if (excess > 1.0) {
        cuts.push_back({i, {0.5}});
        // The point goes where the spline already is, drawn towards the segment only as far as
        // the worst sample must come in: a point inserted on the spline leaves an interpolating
        // spline unchanged, so the spline moves by the excess alone. Points put on the chord
        // instead moved it by the whole sagitta of a tessellated arc (0.27 um on sample part 1's
        // fillet), a curvature swing of 8 x sagitta / spacing^2 that slowed the fillet by 11 %.
        const double tip_pull = d.tip_m > kInsertedFraction * target_m ? kInsertedFraction * target_m / d.tip_m : 1.0;
        const double axis_pull =
            d.axis_rad > kInsertedFraction * axis_target ? kInsertedFraction * axis_target / d.axis_rad : 1.0;
        offsets.push_back({PoseOffset{tip_pull * d.middle_offset_m, d.middle_axis, axis_pull}});
        if (excess > worst_excess) {
          worst_excess = excess, worst_segment = i, worst_tip_m = d.tip_m, worst_axis_rad = d.axis_rad;
          worst_tolerance_m = segment_tolerance_m;
        }
      }
    }
    if (cuts.empty()) {
      if (full_check) {
        result.deviation = worst;
        break;
      }
      dirty.assign(segments, true);
      full_check = true;
      continue;
    }
    // A bound on the work: rounds, and at most 4 added points per input point.
    if (result.rounds >= options.max_rounds || result.refined_points > 4 * n0 + 1000) {
      const std::size_t i = worst_segment;
      const std::string where = 
          "path fidelity: between path points " + std::to_string(i) + " and " + std::to_string(i + 1) + " (" +
          path_point_label(w.path, i + 1) + ", s = " + format_double(w.path.s_m[i] * 1e3) + " mm) the axis "
          "positions still leave the programmed path by " + format_double(worst_excess) +
          " times the allowance (tip " + format_double(worst_tip_m * 1e6) + " um of " +
          format_double(worst_tolerance_m * 1e6) + ", tool axis " +
          format_double(worst_axis_rad * 180.0 / 3.14159265358979323846) + " deg of " +
          format_double(options.axis_tolerance_rad * 180.0 / 3.14159265358979323846) + " deg) after " +
          std::to_string(result.rounds) + " rounds of added points";
      // Within 10 times the allowance: the plan goes on and says so (sample part 3 has one such
      // segment at 1.1 times); beyond: the path cannot be executed as programmed.
      if (worst_excess > 10.0) throw InfeasibleError(where);
      result.unmet = where;
      result.deviation = worst;
      break;
    }
    ++result.rounds;
    for (const auto& c : cuts) result.refined_points += c.second.size();
    const std::vector<bool> inserted = insert_points(machine, w, cuts, &offsets);
    // Dirty: segments within kWindow points of an inserted one.
    const std::size_t m = inserted.size();
    std::vector<std::size_t> count(m + 1, 0);
    for (std::size_t k = 0; k < m; ++k) count[k + 1] = count[k] + (inserted[k] ? 1 : 0);
    dirty.assign(m - 1, false);
    for (std::size_t k = 0; k + 1 < m; ++k) {
      const std::size_t lo = k >= kWindow ? k - kWindow : 0;
      const std::size_t hi = std::min(m, k + 2 + kWindow);
      dirty[k] = count[hi] > count[lo];
    }
    full_check = false;
  }
  result.path = std::move(w.path);
  result.source_point = std::move(w.source_point);
  return result;
}

PoseDeviationTracker::PoseDeviationTracker(const kinematics::MachineModel& machine,
                                           const kinematics::PathKinematics& path, std::vector<bool> free_end)
    : machine_(machine), path_(path), free_end_(std::move(free_end)) {
  if (path.s_m.size() >= 2) programmed_ = std::make_unique<const Polyline>(programmed_polyline(machine, path));
}

PoseDeviationTracker::~PoseDeviationTracker() = default;

void PoseDeviationTracker::add(double s_m, const Eigen::VectorXd& q) {
  if (!programmed_) return;
  const kinematics::PathKinematics& path = path_;
  const Polyline& programmed = *programmed_;
  const auto it = std::upper_bound(path.s_m.begin(), path.s_m.end(), s_m);
  std::size_t i = it == path.s_m.begin() ? 0 : static_cast<std::size_t>(it - path.s_m.begin()) - 1;
  i = std::min(i, path.s_m.size() - 2);
  const bool turns_in_place = i + 1 < path.turns_in_place.size() && path.turns_in_place[i + 1];
  if (i + 1 < free_end_.size() && free_end_[i + 1] && !turns_in_place) return;
  const kinematics::ToolPose pose = kinematics::forward_kinematics(machine_, q, path.length_into(i + 1));
  const double d = distance_to_segment(pose.tip_W_m, programmed.start_tip[i], programmed.tip[i + 1]);
  if (d > out_.tip_m) out_.tip_m = d, out_.tip_s_m = s_m, out_.tip_point = i + 1;
  const double h = path.s_m[i + 1] - path.s_m[i];
  const double f = h > 0.0 ? std::clamp((s_m - path.s_m[i]) / h, 0.0, 1.0) : 0.0;
  const double a = angle_between(pose.axis_W, slerp(programmed.axis[i], programmed.axis[i + 1], f));
  if (a > out_.axis_rad) out_.axis_rad = a, out_.axis_s_m = s_m, out_.axis_point = i + 1;
}

PathDeviation pose_deviation(const kinematics::MachineModel& machine, const kinematics::PathKinematics& path,
                             const std::vector<double>& s_m, const Eigen::MatrixXd& q,
                             const std::vector<bool>& free_end) {
  PoseDeviationTracker tracker(machine, path, free_end);
  Eigen::VectorXd column;
  for (std::size_t k = 0; k < s_m.size(); ++k) {
    column = q.col(idx(k));
    tracker.add(s_m[k], column);
  }
  return tracker.result();
}

}  // namespace vmsim::planner
