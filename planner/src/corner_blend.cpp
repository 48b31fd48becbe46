// Corner blending by symmetric quintic Bezier curves (see corner_blend.hpp).
#include "vmsim/planner/corner_blend.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <optional>

#include "vmsim/common/errors.hpp"
#include "vmsim/common/files.hpp"

namespace vmsim::planner {
namespace {

/// A tip that moves less than this between two points does not move [m] (as in
/// path_kinematics.cpp).
constexpr double kStationaryChord_m = 1e-12;
/// Shape of the blend: control points at alpha L and beta L from the corner.
constexpr double kAlpha = 0.6;
/// Parameter intervals are not split below this (a guard; never reached on a regular curve).
constexpr int kMaxSplitDepth = 40;

double beta_for(double theta_rad) {
  const double x = (theta_rad - std::numbers::pi / 6.0) / (2.0 * std::numbers::pi / 3.0);
  return 0.15 + 0.35 * std::clamp(x, 0.0, 1.0);
}

/// 1 + 5 alpha + 10 beta: 32 times the weight of the legs' directions at t = 1/2.
double middle_weight(double beta) { return 1.0 + 5.0 * kAlpha + 10.0 * beta; }

double angle_between(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b));
}

constexpr std::array<double, 6> kBinomial5{1, 5, 10, 10, 5, 1};
constexpr std::array<double, 5> kBinomial4{1, 4, 6, 4, 1};

template <std::size_t N>
Eigen::Vector3d bernstein_sum(const std::array<Eigen::Vector3d, N>& points,
                              const std::array<double, N>& binomial, double t) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  const int n = static_cast<int>(N) - 1;
  for (int i = 0; i <= n; ++i) {
    sum += binomial[static_cast<std::size_t>(i)] * std::pow(t, i) * std::pow(1.0 - t, n - i) *
           points[static_cast<std::size_t>(i)];
  }
  return sum;
}

/// Rotation vector r (perpendicular to a) with exp_a(r) = b; nullopt when b is opposite a.
std::optional<Eigen::Vector3d> axis_log(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  const Eigen::Vector3d n = a.cross(b);
  const double sin_angle = n.norm();
  const double angle = std::atan2(sin_angle, a.dot(b));
  if (sin_angle < 1e-15) {
    if (a.dot(b) > 0.0) return Eigen::Vector3d::Zero();
    return std::nullopt;
  }
  return Eigen::Vector3d(n / sin_angle * angle);
}

/// a rotated about r / |r| by |r| (r perpendicular to a).
Eigen::Vector3d axis_exp(const Eigen::Vector3d& a, const Eigen::Vector3d& r) {
  const double angle = r.norm();
  if (angle < 1e-300) return a;
  return (std::cos(angle) * a + std::sin(angle) * (r / angle).cross(a)).normalized();
}

/// Turning angle at point i between the secants to the points about `baseline` before (not
/// before point `first`) and after it: path_kinematics.cpp's secant_angle on the tips.
double secant_angle(const std::vector<PathPoint>& points, std::size_t i, std::size_t first,
                    double baseline) {
  const Eigen::Vector3d& p = points[i].tip_W_m;
  std::size_t before = i - 1;
  while (before > first && (p - points[before].tip_W_m).norm() < baseline) --before;
  std::size_t after = i + 1;
  while (after + 1 < points.size() && (points[after].tip_W_m - p).norm() < baseline &&
         (points[after + 1].tip_W_m - points[after].tip_W_m).norm() >= kStationaryChord_m) {
    ++after;
  }
  return angle_between(p - points[before].tip_W_m, points[after].tip_W_m - p);
}

double distance_to_segment(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                           const Eigen::Vector3d& b) {
  const Eigen::Vector3d d = b - a;
  const double length2 = d.squaredNorm();
  const double u = length2 > 0.0 ? std::clamp((p - a).dot(d) / length2, 0.0, 1.0) : 0.0;
  return (p - (a + u * d)).norm();
}

/// Appends parameters in (t0, t1] so that every chord meets the sagitta and turn bounds.
void sample(const CornerBlendCurve& curve, double t0, double t1, double sagitta_m,
            double max_turn_rad, int depth, std::vector<double>& out) {
  const Eigen::Vector3d a = curve.tip(t0);
  const Eigen::Vector3d b = curve.tip(t1);
  double sagitta = 0.0;
  for (const double f : {0.25, 0.5, 0.75}) {
    sagitta = std::max(sagitta, distance_to_segment(curve.tip(t0 + f * (t1 - t0)), a, b));
  }
  const double turn = angle_between(curve.tip_derivative(t0), curve.tip_derivative(t1));
  if (depth < kMaxSplitDepth && (sagitta > sagitta_m || turn > max_turn_rad)) {
    const double tm = 0.5 * (t0 + t1);
    sample(curve, t0, tm, sagitta_m, max_turn_rad, depth + 1, out);
    sample(curve, tm, t1, sagitta_m, max_turn_rad, depth + 1, out);
    return;
  }
  out.push_back(t1);
}

bool uses_inverse_time(const PathPoint& point) { return point.inverse_time_feed_per_s > 0.0; }

}  // namespace

void CornerBlendOptions::validate() const {
  auto fail = [](const std::string& field, double value, const std::string& rule) {
    throw InputError("corner blending: " + field + " = " + format_double(value) + ": " + rule);
  };
  if (program_tolerances ? !(tolerance_m >= 0.0) : !(tolerance_m > 0.0)) {
    fail("tolerance_m", tolerance_m, program_tolerances ? "must be >= 0" : "must be > 0");
  }
  if (!std::isfinite(tolerance_m)) fail("tolerance_m", tolerance_m, "must be finite");
  if (!(axis_tolerance_rad > 0.0) || !std::isfinite(axis_tolerance_rad)) {
    fail("axis_tolerance_rad", axis_tolerance_rad, "must be > 0");
  }
  if (!(corner_angle_rad > 0.0 && corner_angle_rad < std::numbers::pi)) {
    fail("corner_angle_rad", corner_angle_rad, "must be in (0, pi)");
  }
  if (!(corner_baseline_m >= 0.0) || !std::isfinite(corner_baseline_m)) {
    fail("corner_baseline_m", corner_baseline_m, "must be >= 0");
  }
  if (!(max_turn_angle_rad > 0.0 && max_turn_angle_rad < std::numbers::pi)) {
    fail("max_turn_angle_rad", max_turn_angle_rad, "must be in (0, pi)");
  }
  if (!(chord_error_fraction > 0.0 && chord_error_fraction <= 0.5)) {
    fail("chord_error_fraction", chord_error_fraction, "must be in (0, 0.5]");
  }
  if (!(max_chord_turn_rad > 0.0 && max_chord_turn_rad < corner_angle_rad)) {
    fail("max_chord_turn_rad", max_chord_turn_rad, "must be in (0, corner_angle_rad)");
  }
}

Eigen::Vector3d CornerBlendCurve::tip(double t) const {
  return bernstein_sum(control_W_m, kBinomial5, t);
}

Eigen::Vector3d CornerBlendCurve::tip_derivative(double t) const {
  std::array<Eigen::Vector3d, 5> differences;
  for (std::size_t i = 0; i < 5; ++i) differences[i] = 5.0 * (control_W_m[i + 1] - control_W_m[i]);
  return bernstein_sum(differences, kBinomial4, t);
}

Eigen::Vector3d CornerBlendCurve::axis(double t) const {
  return axis_exp(corner_axis_W, bernstein_sum(axis_control_rad, kBinomial5, t));
}

double CornerBlendResult::fit_half_window_m(double default_m) const {
  double window = default_m;
  for (const BlendedCorner& blend : blended) window = std::min(window, 0.25 * blend.leg_length_m);
  return window;
}

CornerBlendResult blend_corners(const Toolpath& path, const CornerBlendOptions& options) {
  options.validate();
  CornerBlendResult result;
  result.toolpath.blocks = path.blocks;
  result.toolpath.warnings = path.warnings;
  result.toolpath.cutter_diameter_m = path.cutter_diameter_m;
  result.toolpath.cutter_corner_radius_m = path.cutter_corner_radius_m;
  result.toolpath.stock_box = path.stock_box;
  const std::vector<PathPoint>& points = path.points;
  std::vector<PathPoint>& out = result.toolpath.points;
  const std::size_t n = points.size();
  // The blend of a corner reaches at most half of each adjacent segment; its start is a new
  // point on the incoming segment and its end one on the outgoing segment.
  auto push = [&out](const PathPoint& point) {
    if (!out.empty() && (out.back().tip_W_m - point.tip_W_m).norm() < kStationaryChord_m &&
        (out.back().axis_W - point.axis_W).norm() < 1e-12 &&
        (out.back().tool_length_m == point.tool_length_m ||
         (std::isnan(out.back().tool_length_m) && std::isnan(point.tool_length_m)))) {
      out.back().dwell_s += point.dwell_s;  // a dwell where the tool already is
      return;
    }
    out.push_back(point);
  };
  // A point made from another (a blend sample, a point on a leg) does not dwell: only the
  // programmed point does, and a corner with a dwell stays an exact stop.
  auto made_from = [](const PathPoint& source) {
    PathPoint point = source;
    point.dwell_s = 0.0;
    return point;
  };
  std::size_t first = 0;  // start of the current stretch, as in solve_path_kinematics
  for (std::size_t i = 0; i < n; ++i) {
    if (i == 0 || i + 1 == n) {
      push(points[i]);
      continue;
    }
    const PathPoint& previous = points[i - 1];
    const PathPoint& corner = points[i];
    const PathPoint& next = points[i + 1];
    const Eigen::Vector3d chord_in = corner.tip_W_m - previous.tip_W_m;
    const Eigen::Vector3d chord_out = next.tip_W_m - corner.tip_W_m;
    if (chord_in.norm() < kStationaryChord_m) {
      result.exact_stops.push_back({i, corner.block, 0.0, "the tip does not move (the tool axis turns on the spot)"});
      first = i;
      push(corner);
      continue;
    }
    if (chord_out.norm() < kStationaryChord_m) {
      push(corner);
      continue;
    }
    const double theta = angle_between(chord_in, chord_out);
    if (corner.tool_length_m != next.tool_length_m &&
        !(std::isnan(corner.tool_length_m) && std::isnan(next.tool_length_m))) {
      // The tool changes here (M6): the new tool's motion starts from rest.
      result.exact_stops.push_back({i, corner.block, theta, "a tool change to a tool of another length"});
      first = i;
      push(corner);
      continue;
    }
    if (!(theta > options.corner_angle_rad &&
          secant_angle(points, i, first, options.corner_baseline_m) > options.corner_angle_rad)) {
      push(corner);
      continue;
    }
    first = i;
    auto keep = [&](const std::string& reason) {
      result.exact_stops.push_back({i, corner.block, theta, reason});
      push(corner);
    };
    if (theta > options.max_turn_angle_rad) {
      keep("turns by more than the largest blended angle (a reversal)");
      continue;
    }
    if (corner.dwell_s > 0.0) {
      keep("a dwell (G4, a cycle's dwell) holds the tool there");
      continue;
    }
    if (corner.kind == MotionKind::rapid || next.kind == MotionKind::rapid) {
      keep("a rapid motion (rapids are not blended)");
      continue;
    }
    // The program's tolerance at this corner where it gives one (G61 / G9: 0, G64 P, G5.1).
    const double tolerance_m = options.program_tolerances && !std::isnan(corner.corner_tolerance_m)
                                   ? corner.corner_tolerance_m
                                   : options.tolerance_m;
    if (!(tolerance_m > 0.0)) {
      keep(options.program_tolerances && !std::isnan(corner.corner_tolerance_m)
               ? "the program asks an exact stop (G61 / G9)"
               : "no corner tolerance (exact stop)");
      continue;
    }
    if (uses_inverse_time(corner) || uses_inverse_time(next)) {
      keep("a G93 inverse-time feed (splitting the motion would change its time)");
      continue;
    }
    const std::optional<Eigen::Vector3d> log_in = axis_log(corner.axis_W, previous.axis_W);
    const std::optional<Eigen::Vector3d> log_out = axis_log(corner.axis_W, next.axis_W);
    if (!log_in || !log_out || log_in->norm() > std::numbers::pi / 2.0 ||
        log_out->norm() > std::numbers::pi / 2.0) {
      keep("the tool axis turns by more than 90 deg over an adjacent segment");
      continue;
    }
    const Eigen::Vector3d u1 = chord_in.normalized();
    const Eigen::Vector3d u2 = chord_out.normalized();
    const Eigen::Vector3d rho1 = *log_in / chord_in.norm();
    const Eigen::Vector3d rho2 = *log_out / chord_out.norm();
    const double beta = beta_for(theta);
    const double weight = middle_weight(beta);
    const double target_m = tolerance_m * (1.0 - options.chord_error_fraction);
    double L = 16.0 * target_m / (weight * std::sin(0.5 * theta));
    L = std::min(L, 0.5 * std::min(chord_in.norm(), chord_out.norm()));
    const double axis_rate = (rho1 + rho2).norm();
    if (axis_rate > 0.0) L = std::min(L, 32.0 * options.axis_tolerance_rad / (weight * axis_rate));

    BlendedCorner blend;
    blend.point = i;
    blend.block = corner.block;
    blend.turn_angle_rad = theta;
    blend.leg_length_m = L;
    blend.deviation_m = L * weight * std::sin(0.5 * theta) / 16.0;
    blend.axis_deviation_rad = L * weight * axis_rate / 32.0;
    CornerBlendCurve& curve = blend.curve;
    curve.corner_W_m = corner.tip_W_m;
    curve.corner_axis_W = corner.axis_W;
    const std::array<double, 3> distance{L, kAlpha * L, beta * L};
    for (std::size_t k = 0; k < 3; ++k) {
      curve.control_W_m[k] = corner.tip_W_m - distance[k] * u1;
      curve.control_W_m[5 - k] = corner.tip_W_m + distance[k] * u2;
      curve.axis_control_rad[k] = distance[k] * rho1;
      curve.axis_control_rad[5 - k] = distance[k] * rho2;
    }
    // Points on the incoming leg at 2^k L before the blend (up to the segment's middle), so
    // that the fits of solve_path_kinematics (a fixed count of neighbours) stay local there.
    const double half_in = 0.5 * chord_in.norm();
    std::vector<double> before;
    for (double d = 2.0 * L; d < half_in; d *= 2.0) before.push_back(d);
    for (auto it = before.rbegin(); it != before.rend(); ++it) {
      PathPoint point = made_from(corner);
      point.tip_W_m = corner.tip_W_m - *it * u1;
      point.axis_W = axis_exp(corner.axis_W, *it * rho1);
      push(point);
    }
    // The middle is always a sample: the blended polyline's closest point to the corner.
    std::vector<double> parameters{0.0};
    const double sagitta_m = options.chord_error_fraction * tolerance_m;
    sample(curve, 0.0, 0.5, sagitta_m, options.max_chord_turn_rad, 0, parameters);
    sample(curve, 0.5, 1.0, sagitta_m, options.max_chord_turn_rad, 0, parameters);
    for (const double t : parameters) {
      PathPoint point = made_from(t <= 0.5 ? corner : next);
      point.tip_W_m = curve.tip(t);
      point.axis_W = curve.axis(t);
      point.block = corner.block;
      push(point);
    }
    // The same on the outgoing leg (the next motion: its block and feed).
    const double half_out = 0.5 * chord_out.norm();
    for (double d = 2.0 * L; d < half_out; d *= 2.0) {
      PathPoint point = made_from(next);
      point.tip_W_m = corner.tip_W_m + d * u2;
      point.axis_W = axis_exp(corner.axis_W, d * rho2);
      push(point);
    }
    blend.samples = parameters.size();
    result.blended.push_back(std::move(blend));
  }
  return result;
}

}  // namespace vmsim::planner
