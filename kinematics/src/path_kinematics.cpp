#include "vmsim/kinematics/path_kinematics.hpp"

#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "vmsim/common/errors.hpp"
#include "vmsim/kinematics/redundancy.hpp"

namespace vmsim::kinematics {
namespace {

/// A tip that moves less than this between two points does not move [m].
constexpr double kStationaryChord_m = 1e-12;
/// Rotary axes that move less than this (Euclidean, rad) between two points do not move.
constexpr double kStationaryAngle_rad = 1e-12;

std::string block_label(const PathPose& pose, const std::vector<std::string>& block_names) {
  if (pose.block >= 0 && static_cast<std::size_t>(pose.block) < block_names.size()) {
    return "block '" + block_names[static_cast<std::size_t>(pose.block)] + "'";
  }
  if (pose.block >= 0) return "block #" + std::to_string(pose.block);
  return "no block";
}

double angle_between(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b));
}

/// Turning angle at point i between the secants to the points about `baseline` before (not
/// before point `first`) and after it. On a dense polyline whose coordinates are rounded, the
/// chords' directions are noisy (1 um over a 20 um chord: 3 degrees); the secants over the fit
/// window are not, and a true corner turns them as much as the chords.
double secant_angle(const std::vector<PathPose>& path, std::size_t i, std::size_t first,
                    double baseline) {
  const Eigen::Vector3d& p = path[i].pose.tip_W_m;
  std::size_t before = i - 1;
  while (before > first && (p - path[before].pose.tip_W_m).norm() < baseline) --before;
  std::size_t after = i + 1;
  while (after + 1 < path.size() && (path[after].pose.tip_W_m - p).norm() < baseline &&
         (path[after + 1].pose.tip_W_m - path[after].pose.tip_W_m).norm() >= kStationaryChord_m) {
    ++after;
  }
  return angle_between(p - path[before].pose.tip_W_m, path[after].pose.tip_W_m - p);
}

struct Stretch {
  std::size_t first = 0;
  std::size_t last = 0;
};

/// Derivatives of q(s) at every point of one stretch, by local least-squares polynomials.
void fit_stretch(const Stretch& stretch, const std::vector<double>& s, const Eigen::MatrixXd& q,
                 const PathKinematicsOptions& options, PathKinematics& out) {
  const auto a = static_cast<long>(stretch.first);
  const auto b = static_cast<long>(stretch.last);
  const long k = std::max(options.fit_half_window_points, 1);
  const double L = std::max(options.fit_half_window_m, 0.0);
  const long wanted = 2 * k + 1;
  const Eigen::Index axes = q.rows();
  for (long i = a; i <= b; ++i) {
    const auto ui = static_cast<std::size_t>(i);
    long lo = i;
    long hi = i;
    while (lo > a && (i - lo < k || s[ui] - s[static_cast<std::size_t>(lo)] < L)) --lo;
    while (hi < b && (hi - i < k || s[static_cast<std::size_t>(hi)] - s[ui] < L)) ++hi;
    // Near a corner or a path end the window is one-sided: widen the other side instead, so
    // that the fit keeps its number of points and its length.
    while ((hi - lo + 1 < wanted ||
            s[static_cast<std::size_t>(hi)] - s[static_cast<std::size_t>(lo)] < 2.0 * L) &&
           (lo > a || hi < b)) {
      if (hi < b) {
        ++hi;
      } else {
        --lo;
      }
    }
    const long count = hi - lo + 1;
    const auto col = static_cast<Eigen::Index>(i);
    out.q_s.col(col).setZero();
    out.q_ss.col(col).setZero();
    out.q_sss.col(col).setZero();
    if (count < 2) continue;
    const long degree = std::min<long>(std::max(options.fit_degree, 1), count - 1);
    double scale = 0.0;
    for (long j = lo; j <= hi; ++j) {
      scale = std::max(scale, std::abs(s[static_cast<std::size_t>(j)] - s[ui]));
    }
    // Scaled abscissa t in [-1, 1] keeps the Vandermonde matrix well conditioned.
    Eigen::MatrixXd V(count, degree + 1);
    Eigen::MatrixXd Y(count, axes);
    for (long j = lo; j <= hi; ++j) {
      const double t = (s[static_cast<std::size_t>(j)] - s[ui]) / scale;
      double power = 1.0;
      for (long d = 0; d <= degree; ++d) {
        V(j - lo, d) = power;
        power *= t;
      }
      Y.row(j - lo) = q.col(static_cast<Eigen::Index>(j)).transpose();
    }
    const Eigen::MatrixXd c = V.colPivHouseholderQr().solve(Y);
    out.q_s.col(col) = c.row(1).transpose() / scale;
    if (degree >= 2) out.q_ss.col(col) = 2.0 * c.row(2).transpose() / (scale * scale);
    if (degree >= 3) out.q_sss.col(col) = 6.0 * c.row(3).transpose() / (scale * scale * scale);
  }
}

}  // namespace

PathKinematics solve_path_kinematics(const MachineModel& model, const std::vector<PathPose>& path,
                                     const Eigen::VectorXd& q_start, double tool_length_m,
                                     const std::vector<std::string>& block_names,
                                     const PathKinematicsOptions& options) {
  const auto axes = static_cast<Eigen::Index>(model.axis_count());
  if (q_start.size() != axes) {
    throw std::invalid_argument("solve_path_kinematics: q_start has " +
                                std::to_string(q_start.size()) + " entries, model '" +
                                model.name + "' has " + std::to_string(axes) + " axes");
  }
  const std::size_t n = path.size();
  const auto cols = static_cast<Eigen::Index>(n);
  PathKinematics out;
  out.s_m.assign(n, 0.0);
  out.q.resize(axes, cols);
  out.q_s.setZero(axes, cols);
  out.q_ss.setZero(axes, cols);
  out.q_sss.setZero(axes, cols);
  if (n == 0) return out;

  // Axis positions, each next to the previous one.
  std::vector<bool> singular(n, false);
  std::vector<double> length_m(n);
  bool lengths_differ = false;
  for (std::size_t i = 0; i < n; ++i) {
    length_m[i] = pose_tool_length_m(path[i], tool_length_m);
    lengths_differ = lengths_differ || length_m[i] != tool_length_m;
  }
  Eigen::VectorXd q_previous = q_start;
  for (std::size_t i = 0; i < n; ++i) {
    const double pose_length_m = length_m[i];  // this pose's tool
    if (path[i].q_given.size() > 0) {
      std::string why;
      const auto given = inverse_kinematics_given_rotary(model, path[i].pose, path[i].q_given,
                                                         q_previous, pose_length_m, 1e-6, &why);
      if (!given) {
        throw InfeasibleError("tool path point " + std::to_string(i) + " (" +
                              block_label(path[i], block_names) +
                              "): the programmed rotary axes: " + why);
      }
      out.q.col(static_cast<Eigen::Index>(i)) = given->q;
      singular[i] = given->singular;
      q_previous = given->q;
      continue;
    }
    if (!std::isnan(path[i].roll_rad)) {
      // The roll chosen along the path (redundancy.hpp): the full frame, next to the previous.
      const auto rolled = inverse_kinematics_with_roll(model, path[i].pose, path[i].roll_rad, q_previous, pose_length_m);
      if (!rolled || !within_travel(model, *rolled, 1e-9)) {
        throw InfeasibleError("tool path point " + std::to_string(i) + " (" + block_label(path[i], block_names) +
                              "): no inverse kinematic solution with the chosen tool roll " +
                              std::to_string(path[i].roll_rad * 180.0 / 3.14159265358979323846) + " deg" +
                              (rolled ? " within the travel" : ""));
      }
      out.q.col(static_cast<Eigen::Index>(i)) = *rolled;
      q_previous = *rolled;
      continue;
    }
    const auto result = inverse_kinematics(model, path[i].pose, q_previous, pose_length_m,
                                           options.inverse);
    if (!result) {
      throw InfeasibleError(
          "tool path point " + std::to_string(i) + " (" + block_label(path[i], block_names) +
          "): no inverse kinematic solution: " +
          explain_unreachable(model, path[i].pose, q_previous, pose_length_m, options.inverse));
    }
    out.q.col(static_cast<Eigen::Index>(i)) = result->q;
    singular[i] = result->singular;
    q_previous = result->q;
  }

  // Arc length and chords. A motion that turns the tool about a fixed tip (a re-orientation)
  // has no tip arc length: it is parametrised by its rotary motion instead (see the header).
  // After a tool change the motion starts where the new tool's tip is at the old position.
  std::vector<Eigen::Vector3d> chord(n, Eigen::Vector3d::Zero());  // chord[i]: point i-1 -> i
  std::vector<bool> turns_in_place(n, false);
  std::vector<bool> tool_changes(n, false);  // per point: the next motion has another length
  for (std::size_t i = 1; i < n; ++i) {
    tool_changes[i - 1] = length_m[i] != length_m[i - 1];
    chord[i] = path[i].pose.tip_W_m - tip_with_tool_length(path[i - 1].pose.tip_W_m, path[i - 1].pose.axis_W,
                                                           length_m[i - 1], length_m[i]);
    double ds = chord[i].norm();
    if (ds < kStationaryChord_m) {
      double rotary2 = 0.0;
      for (std::size_t j = 0; j < model.axis_count(); ++j) {
        if (model.axes[j].type != AxisType::rotary) continue;
        const auto row = static_cast<Eigen::Index>(j);
        const double d = out.q(row, static_cast<Eigen::Index>(i)) -
                         out.q(row, static_cast<Eigen::Index>(i - 1));
        rotary2 += d * d;
      }
      if (std::sqrt(rotary2) > kStationaryAngle_rad) {
        turns_in_place[i] = true;
        ds = kReorientationLever_m * std::sqrt(rotary2);
      }
    }
    out.s_m[i] = out.s_m[i - 1] + ds;
  }
  out.turns_in_place = turns_in_place;

  // Corners cut the path into stretches. A corner point with a turning tangent ends one
  // stretch and starts the next; a stationary tip (zero chord) separates them.
  std::vector<Stretch> stretches;
  std::size_t first = 0;
  auto last_moving_chord_before = [&](std::size_t i) -> const Eigen::Vector3d* {
    for (std::size_t j = i + 1; j-- > 1;) {
      if (chord[j].norm() >= kStationaryChord_m) return &chord[j];
    }
    return nullptr;
  };
  auto next_moving_chord_after = [&](std::size_t i) -> const Eigen::Vector3d* {
    for (std::size_t j = i + 1; j < n; ++j) {
      if (chord[j].norm() >= kStationaryChord_m) return &chord[j];
    }
    return nullptr;
  };
  for (std::size_t i = 1; i < n; ++i) {
    if (turns_in_place[i]) {
      // Its own stretch, from rest to rest: corners at both ends.
      if (i - 1 > first) {
        out.corners.push_back({i - 1, out.s_m[i - 1], 0.0});
        stretches.push_back({first, i - 1});
        first = i - 1;
      }
      out.corners.push_back({i, out.s_m[i], 0.0});
      stretches.push_back({first, i});
      first = i;
      continue;
    }
    if (chord[i].norm() < kStationaryChord_m) {
      const Eigen::Vector3d* before = last_moving_chord_before(i - 1);
      const Eigen::Vector3d* after = next_moving_chord_after(i);
      const double angle =
          before != nullptr && after != nullptr ? angle_between(*before, *after) : 0.0;
      out.corners.push_back({i, out.s_m[i], angle});
      stretches.push_back({first, i - 1});
      first = i;
      continue;
    }
    if (tool_changes[i]) {
      // A tool change ends a stretch: the new tool starts from rest.
      const double angle = i + 1 < n && chord[i + 1].norm() >= kStationaryChord_m ? angle_between(chord[i], chord[i + 1]) : 0.0;
      out.corners.push_back({i, out.s_m[i], angle});
      stretches.push_back({first, i});
      first = i;
      continue;
    }
    if (i + 1 < n && chord[i + 1].norm() >= kStationaryChord_m) {
      const double angle = angle_between(chord[i], chord[i + 1]);
      if (angle > options.corner_angle_rad &&
          secant_angle(path, i, first, options.fit_half_window_m) > options.corner_angle_rad) {
        out.corners.push_back({i, out.s_m[i], angle});
        stretches.push_back({first, i});
        first = i;
      }
    }
  }
  stretches.push_back({first, n - 1});
  // Later stretches overwrite the shared corner point: it keeps the outgoing derivatives.
  for (const Stretch& stretch : stretches) fit_stretch(stretch, out.s_m, out.q, options, out);
  out.derivatives_fitted = true;
  out.tool_length_m = tool_length_m;
  if (lengths_differ) out.point_tool_length_m = length_m;
  out.inverse = options.inverse;
  out.block_names = block_names;
  out.block.resize(n);
  for (std::size_t i = 0; i < n; ++i) out.block[i] = path[i].block;

  // Singular zones: runs of singular points.
  for (std::size_t i = 0; i < n; ++i) {
    if (!singular[i]) continue;
    std::size_t j = i;
    while (j + 1 < n && singular[j + 1]) ++j;
    out.singular_zones.push_back({i, j, out.s_m[i], out.s_m[j]});
    i = j;
  }
  return out;
}

}  // namespace vmsim::kinematics
