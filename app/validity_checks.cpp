#include "validity_checks.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <sstream>

#include "vmsim/common/files.hpp"
#include "vmsim/kinematics/kinematics.hpp"

namespace vmsim::app {
namespace {

/// Floating-point rounding allowed at an end of the travel [m or rad] (as the planner's check).
constexpr double kTravelRoundingSi = 1e-9;

double distance_to_segment(const Eigen::Vector3d& point, const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  const Eigen::Vector3d ab = b - a;
  const double length_squared = ab.squaredNorm();
  const double f = length_squared > 0.0 ? std::clamp((point - a).dot(ab) / length_squared, 0.0, 1.0) : 0.0;
  return (a + f * ab - point).norm();
}

bool has_travel(const kinematics::Axis& axis) {
  return !(axis.type == kinematics::AxisType::rotary && axis.continuous) && std::isfinite(axis.travel_min) &&
         std::isfinite(axis.travel_max);
}

// A joint value in the unit users read: mm for a linear axis, deg for a rotary one.
double user_value(const kinematics::Axis& axis, double joint_value_si) {
  return axis.type == kinematics::AxisType::linear ? joint_value_si * 1e3 : joint_value_si * 180.0 / std::numbers::pi;
}
const char* user_unit(const kinematics::Axis& axis) {
  return axis.type == kinematics::AxisType::linear ? "mm" : "deg";
}

// "block file:line N.. (s = .. mm)" for the path segment that holds s.
std::string where_on_path(const std::vector<kinematics::PathPose>& path, const std::vector<double>& path_s_m,
                          const std::vector<std::string>& block_names, double s_m) {
  const std::size_t i = std::min(path_segment_at(path_s_m, s_m) + 1, path.size() - 1);
  std::string where = "s = " + format_double(std::round(s_m * 1e6) / 1e3) + " mm";
  const int block = path[i].block;
  if (block >= 0 && static_cast<std::size_t>(block) < block_names.size()) {
    where = "block " + block_names[static_cast<std::size_t>(block)] + ", " + where;
  }
  return where;
}

std::string rounded(double value, int digits) {
  std::ostringstream text;
  text.setf(std::ios::fixed);
  text.precision(digits);
  text << value;
  return text.str();
}

// A figure with 3 significant digits (a share of a few samples in millions is not "0.000 %").
std::string significant(double value) {
  std::ostringstream text;
  text.precision(3);
  text << value;
  return text.str();
}

}  // namespace

std::size_t path_segment_at(const std::vector<double>& path_s_m, double s_m) {
  if (path_s_m.size() < 2) return 0;
  const auto it = std::upper_bound(path_s_m.begin(), path_s_m.end(), s_m);
  const std::size_t after = static_cast<std::size_t>(it - path_s_m.begin());
  return std::min(after == 0 ? 0 : after - 1, path_s_m.size() - 2);
}

SetpointsOnPathCheck::SetpointsOnPathCheck(const kinematics::MachineModel& machine,
                                           const std::vector<kinematics::PathPose>& path,
                                           const std::vector<bool>& rapid_end, const std::vector<double>& path_s_m,
                                           double tool_length_m, const std::vector<std::string>& block_names,
                                           std::string run_name, double tolerance_m,
                                           const std::vector<double>& contour_tolerance_m, double turning_tolerance_m)
    : machine_(machine), path_(path), rapid_end_(rapid_end), path_s_m_(path_s_m), tool_length_m_(tool_length_m),
      block_names_(block_names), run_name_(std::move(run_name)), tolerance_m_(tolerance_m),
      contour_tolerance_m_(contour_tolerance_m), turning_tolerance_m_(turning_tolerance_m),
      worst_limit_m_(tolerance_m) {}

void SetpointsOnPathCheck::add(double s, const Eigen::Ref<const Eigen::VectorXd>& q) {
  ++count_;
  if (path_.size() < 2) return;
  const kinematics::ToolPose pose = kinematics::forward_kinematics(machine_, q, tool_length_m_);
  const std::size_t i = path_segment_at(path_s_m_, s);
  if (i + 1 < rapid_end_.size() && rapid_end_[i + 1]) return;
  double distance = std::numeric_limits<double>::infinity();
  // The neighbours too: the set point's s and the polyline's own arc length may differ a little.
  // Each segment with its own tool (PathPose::tool_length_m): after a tool change it starts at
  // the new tool's tip at the old position.
  for (std::size_t j = (i > 0 ? i - 1 : 0); j <= std::min(i + 1, path_.size() - 2); ++j) {
    const double length_m = kinematics::pose_tool_length_m(path_[j + 1], tool_length_m_);
    const Eigen::Vector3d tip = kinematics::tip_with_tool_length(pose.tip_W_m, pose.axis_W, tool_length_m_, length_m);
    const Eigen::Vector3d start = kinematics::tip_with_tool_length(
        path_[j].pose.tip_W_m, path_[j].pose.axis_W, kinematics::pose_tool_length_m(path_[j], tool_length_m_), length_m);
    distance = std::min(distance, distance_to_segment(tip, start, path_[j + 1].pose.tip_W_m));
  }
  const Eigen::Vector3d& axis_a = path_[i].pose.axis_W;
  const Eigen::Vector3d& axis_b = path_[std::min(i + 1, path_.size() - 1)].pose.axis_W;
  const bool turns = std::atan2(axis_a.cross(axis_b).norm(), axis_a.dot(axis_b)) > 1e-9;
  const double base_m = turns ? std::max(tolerance_m_, turning_tolerance_m_) : tolerance_m_;
  const double contour_m = i + 1 < contour_tolerance_m_.size() ? contour_tolerance_m_[i + 1] : 0.0;
  const double limit_m = std::max(base_m, contour_m);
  const double ratio = distance / limit_m;
  if (!(ratio <= worst_ratio_)) {  // NaN counts as the worst
    worst_ratio_ = std::isnan(ratio) ? std::numeric_limits<double>::infinity() : ratio;
    worst_m_ = std::isnan(distance) ? std::numeric_limits<double>::infinity() : distance;
    worst_s_m_ = s;
    worst_limit_m_ = limit_m;
    worst_turns_ = turns && base_m >= contour_m;
  }
  contour_limit_used_ = contour_limit_used_ || limit_m > tolerance_m_;
}

ValidityCheck SetpointsOnPathCheck::result() const {
  ValidityCheck check{"setpoints_on_path." + run_name_,
                      run_name_ + " set points on the programmed path (tool tip to the polyline through the "
                                  "path points)",
                      0.0, tolerance_m_ * 1e6, "um", CheckStatus::passed, ""};
  if (path_.size() < 2 || count_ == 0) return check;
  check.value = worst_m_ * 1e6;
  check.limit = worst_limit_m_ * 1e6;
  check.detail = (contour_limit_used_ ? "nearest its limit" : "largest") + std::string(" at ") +
                 where_on_path(path_, path_s_m_, block_names_, worst_s_m_) +
                 (worst_limit_m_ > tolerance_m_ && worst_turns_
                      ? " (the limit there is that of a segment that turns the tool axis, "
                        "--turning-path-tolerance-um; elsewhere " + rounded(tolerance_m_ * 1e6, 3) + " um)"
                  : worst_limit_m_ > tolerance_m_ ? " (the limit there is the program's contour tolerance, G64 P / "
                                                    "G5.1 / --corner-tolerance-mm; elsewhere " +
                                                        rounded(tolerance_m_ * 1e6, 3) + " um)"
                                                  : std::string()) +
                 " (rapid moves not checked: the axes move on their own there)";
  if (!(worst_m_ <= worst_limit_m_)) check.status = CheckStatus::failed;
  return check;
}

ValidityCheck check_setpoints_on_path(const kinematics::MachineModel& machine,
                                      const std::vector<kinematics::PathPose>& path,
                                      const std::vector<bool>& rapid_end,
                                      const std::vector<double>& path_s_m, double tool_length_m,
                                      const planner::SetPoints& setpoints,
                                      const std::vector<std::string>& block_names,
                                      const std::string& run_name, double tolerance_m,
                                      const std::vector<double>& contour_tolerance_m,
                                      double turning_tolerance_m) {
  SetpointsOnPathCheck check(machine, path, rapid_end, path_s_m, tool_length_m, block_names, run_name, tolerance_m,
                             contour_tolerance_m, turning_tolerance_m);
  for (Eigen::Index k = 0; k < setpoints.q.cols(); ++k) check.add(setpoints.s_m[static_cast<std::size_t>(k)], setpoints.q.col(k));
  return check.result();
}

SetpointsWithinTravelCheck::SetpointsWithinTravelCheck(const kinematics::MachineModel& machine,
                                                       const std::vector<kinematics::PathPose>& path,
                                                       const std::vector<double>& path_s_m,
                                                       const std::vector<std::string>& block_names,
                                                       std::string run_name)
    : machine_(machine), path_(path), path_s_m_(path_s_m), block_names_(block_names), run_name_(std::move(run_name)),
      axes_(machine.axes.size()) {}

void SetpointsWithinTravelCheck::add(double s, const Eigen::Ref<const Eigen::VectorXd>& q) {
  ++count_;
  for (std::size_t j = 0; j < axes_.size(); ++j) {
    const kinematics::Axis& axis = machine_.axes[j];
    if (!has_travel(axis)) continue;
    Axis& a = axes_[j];
    const double value = q[static_cast<Eigen::Index>(j)];
    const double beyond = std::isnan(value) ? std::numeric_limits<double>::infinity()
                                            : std::max(axis.travel_min - value, value - axis.travel_max);
    // A nanometre (nanoradian) of floating-point rounding at an end of the travel is no excess:
    // a G28 return to Z0 = the end of Z's travel lands there within 1e-13 m. The first set point
    // at the axis's largest excess is named.
    if (beyond > kTravelRoundingSi && user_value(axis, beyond) > a.worst_beyond) {
      a.worst_beyond = user_value(axis, beyond);
      a.worst_q = value;
      a.worst_s_m = s;
    }
    a.min = std::min(a.min, value);
    a.max = std::max(a.max, value);
  }
}

ValidityCheck SetpointsWithinTravelCheck::result() const {
  ValidityCheck check{"setpoints_within_travel." + run_name_, run_name_ + " set points within the axes' travel",
                      0.0, 0.0, "mm (deg for a rotary axis) beyond", CheckStatus::passed, ""};
  double worst_beyond = 0.0;  // user units
  std::string smallest_margin;
  double smallest_margin_fraction = std::numeric_limits<double>::infinity();
  for (std::size_t j = 0; j < axes_.size(); ++j) {
    const kinematics::Axis& axis = machine_.axes[j];
    if (!has_travel(axis)) continue;
    const Axis& a = axes_[j];
    // The largest excess over the axes; of equal ones, the first axis's.
    if (a.worst_beyond > worst_beyond) {
      worst_beyond = a.worst_beyond;
      check.status = CheckStatus::failed;
      check.detail = "axis " + axis.name + " at " + format_double(user_value(axis, a.worst_q)) + " " + user_unit(axis) +
                     ", outside its travel [" + format_double(user_value(axis, axis.travel_min)) + ", " +
                     format_double(user_value(axis, axis.travel_max)) + "] " + user_unit(axis) + ", at " +
                     where_on_path(path_, path_s_m_, block_names_, a.worst_s_m);
    }
    if (count_ == 0) continue;
    const double margin = std::min(a.min - axis.travel_min, axis.travel_max - a.max);
    const double fraction = margin / (axis.travel_max - axis.travel_min);
    if (fraction < smallest_margin_fraction) {
      smallest_margin_fraction = fraction;
      smallest_margin = "smallest margin: axis " + axis.name + " " + rounded(user_value(axis, margin), 3) + " " +
                        user_unit(axis) + " from an end of its travel";
    }
  }
  check.value = worst_beyond;
  if (check.status == CheckStatus::passed) check.detail = smallest_margin;
  return check;
}

ValidityCheck check_setpoints_within_travel(const kinematics::MachineModel& machine,
                                            const std::vector<kinematics::PathPose>& path,
                                            const std::vector<double>& path_s_m,
                                            const planner::SetPoints& setpoints,
                                            const std::vector<std::string>& block_names,
                                            const std::string& run_name) {
  SetpointsWithinTravelCheck check(machine, path, path_s_m, block_names, run_name);
  for (Eigen::Index k = 0; k < setpoints.q.cols(); ++k) check.add(setpoints.s_m[static_cast<std::size_t>(k)], setpoints.q.col(k));
  return check.result();
}

ActualTravelCheck::ActualTravelCheck(const kinematics::MachineModel& machine, std::string run_name)
    : machine_(&machine), run_name_(std::move(run_name)), worst_(machine.axes.size(), 0.0),
      worst_t_s_(machine.axes.size(), 0.0) {}

void ActualTravelCheck::add(double t_s, const Eigen::Ref<const Eigen::VectorXd>& q_actual) {
  for (std::size_t j = 0; j < machine_->axes.size(); ++j) {
    const kinematics::Axis& axis = machine_->axes[j];
    if (!has_travel(axis)) continue;
    const double q = q_actual[static_cast<Eigen::Index>(j)];
    const double beyond = std::max(axis.travel_min - q, q - axis.travel_max);
    const double tolerance = axis.type == kinematics::AxisType::linear ? kActualTravelTolerance_m
                                                                       : kActualTravelTolerance_rad;
    beyond_tolerance_ = beyond_tolerance_ || beyond > tolerance;
    // The first sample at the axis's largest overshoot.
    if (beyond > 0.0 && user_value(axis, beyond) > worst_[j]) {
      worst_[j] = user_value(axis, beyond);
      worst_t_s_[j] = t_s;
    }
  }
}

ValidityCheck ActualTravelCheck::result() const {
  ValidityCheck check{"actual_within_travel." + run_name_,
                      run_name_ + " simulated axis positions within the axes' travel", 0.0, 0.0,
                      "mm (deg for a rotary axis) beyond",
                      CheckStatus::passed, ""};
  // The largest overshoot; of equal ones, the first axis's.
  for (std::size_t j = 0; j < machine_->axes.size(); ++j) {
    if (!(worst_[j] > check.value)) continue;
    const kinematics::Axis& axis = machine_->axes[j];
    check.value = worst_[j];
    check.status = CheckStatus::warning;
    check.detail = "axis " + axis.name + " overshoots its travel by " + format_double(check.value) + " " +
                   user_unit(axis) + " at t = " + rounded(worst_t_s_[j], 4) +
                   " s (the set points are within it: the drive overshoots)";
  }
  if (check.status == CheckStatus::warning && !beyond_tolerance_) {
    // A set point at the end of the travel (a G28 return to a reference point there) and the
    // drive settling a few um beyond it: a control raises no alarm (see the header).
    check.status = CheckStatus::passed;
    check.detail += ": within the " + rounded(kActualTravelTolerance_m * 1e3, 1) + " mm (" +
                    rounded(kActualTravelTolerance_rad * 180.0 / std::numbers::pi, 1) +
                    " deg) a control allows the actual position beyond a software limit, no alarm";
  }
  return check;
}

ValidityCheck check_actual_within_travel(const kinematics::MachineModel& machine,
                                         const std::vector<double>& t_s, const Eigen::MatrixXd& q_actual,
                                         const std::string& run_name) {
  ActualTravelCheck check(machine, run_name);
  for (Eigen::Index k = 0; k < q_actual.cols(); ++k) check.add(t_s[static_cast<std::size_t>(k)], q_actual.col(k));
  return check.result();
}

DriveSaturationCheck::DriveSaturationCheck(const kinematics::MachineModel& machine, std::string run_name)
    : machine_(&machine), run_name_(std::move(run_name)), axes_(machine.axes.size()) {}

void DriveSaturationCheck::add(double t_s, const Eigen::Ref<const Eigen::VectorXd>& current_A, bool cutting) {
  if (!cutting) return;
  ++cutting_count_;
  for (std::size_t j = 0; j < axes_.size() && j < static_cast<std::size_t>(current_A.size()); ++j) {
    const double limit = machine_->axes[j].controller.current_max_A;
    if (!(limit > 0.0)) continue;
    Axis& axis = axes_[j];
    const double i = std::abs(current_A[static_cast<Eigen::Index>(j)]);
    axis.peak_A = std::max(axis.peak_A, i);
    // The current loop's first-order lag reaches the clamp only asymptotically: within 0.5 %.
    if (i >= 0.995 * limit) {
      if (axis.at_limit == 0) axis.first_t_s = t_s;
      ++axis.at_limit;
    }
  }
}

ValidityCheck DriveSaturationCheck::result() const {
  ValidityCheck check{"drives_not_saturated." + run_name_,
                      run_name_ + " drive currents below their saturation while cutting", 0.0, 0.0,
                      "% of the cutting samples", CheckStatus::passed, ""};
  std::string peaks;
  for (std::size_t j = 0; j < axes_.size(); ++j) {
    const double limit = machine_->axes[j].controller.current_max_A;
    if (!(limit > 0.0)) continue;
    const Axis& axis = axes_[j];
    peaks += (peaks.empty() ? "" : ", ") + machine_->axes[j].name + " " + rounded(100.0 * axis.peak_A / limit, 3) + " %";
    if (axis.at_limit == 0 || cutting_count_ == 0) continue;
    const double share = 100.0 * static_cast<double>(axis.at_limit) / static_cast<double>(cutting_count_);
    if (share > check.value) {
      check.value = share;
      check.status = CheckStatus::warning;
      check.detail = "axis " + machine_->axes[j].name + " at its current limit " + rounded(limit, 4) + " A in " +
                     std::to_string(axis.at_limit) + " of " + std::to_string(cutting_count_) + " cutting samples (" +
                     significant(share) + " %), first at t = " + rounded(axis.first_t_s, 4) +
                     " s: the drive cannot give what the plan asks there";
    }
  }
  if (check.status == CheckStatus::passed) check.detail = "peak current / saturation while cutting: " + peaks;
  return check;
}

ValidityCheck check_drives_not_saturated(const kinematics::MachineModel& machine,
                                         const std::vector<double>& t_s, const Eigen::MatrixXd& current,
                                         const std::vector<bool>& cutting, const std::string& run_name) {
  DriveSaturationCheck check(machine, run_name);
  // Rows beyond the machine's axes are not read; an axis without a row is not checked.
  const Eigen::Index rows = std::min<Eigen::Index>(current.rows(), static_cast<Eigen::Index>(machine.axes.size()));
  for (std::size_t k = 0; k < cutting.size() && k < static_cast<std::size_t>(current.cols()); ++k) {
    check.add(t_s[k], current.col(static_cast<Eigen::Index>(k)).head(rows), cutting[k]);
  }
  return check.result();
}

ValidityCheck check_reference_against_commanded(double worst_m, const Eigen::Vector3d& where_W_m,
                                                double limit_m) {
  ValidityCheck check{"reference_vs_commanded",
                      "reference surface against the surface of the planned tool path (the set points' geometry)", worst_m * 1e6,
                      limit_m * 1e6, "um", CheckStatus::passed, ""};
  check.detail = "largest at (" + rounded(where_W_m.x() * 1e3, 3) + ", " + rounded(where_W_m.y() * 1e3, 3) + ", " +
                 rounded(where_W_m.z() * 1e3, 3) + ") mm";
  if (!(worst_m <= limit_m)) check.status = CheckStatus::failed;
  return check;
}

double steep_line_factor(double steep_step_per_spacing) {
  return std::sqrt(1.0 + steep_step_per_spacing * steep_step_per_spacing);
}

CommandedPathDeviation::CommandedPathDeviation(double tool_reach_m, double tool_radius_m, double tool_length_m,
                                               const removal::Box& stock, std::size_t window_samples)
    : reach_m_(tool_reach_m),
      radius_m_(tool_radius_m),
      length_m_(tool_length_m),
      stock_(stock),
      window_(std::max<std::size_t>(1, window_samples)) {}

bool CommandedPathDeviation::clear_of_stock(const removal::Pose& pose) const {
  // The box around the cutting body (tip to tip + L axis, widened by the radius) holds the tool.
  const Eigen::Vector3d top = pose.tip_W_m + length_m_ * pose.axis_W;
  const Eigen::Vector3d low = pose.tip_W_m.cwiseMin(top).array() - radius_m_;
  const Eigen::Vector3d high = pose.tip_W_m.cwiseMax(top).array() + radius_m_;
  return (low.array() > stock_.max_W_m.array()).any() || (high.array() < stock_.min_W_m.array()).any();
}

void CommandedPathDeviation::add(double t_s, const removal::Pose& commanded, const removal::Pose& actual) {
  commanded_.push_back({commanded, clear_of_stock(commanded)});
  actual_.push_back({actual, clear_of_stock(actual)});
  t_s_.push_back(t_s);
  ++count_;
  // Sample n is matched once the samples up to n + window are known.
  while (next_ + window_ < count_) process(next_++, count_);
  const std::size_t keep_from = next_ > window_ ? next_ - window_ : 0;
  if (keep_from - dropped_ > 4096 && keep_from - dropped_ > t_s_.size() / 2) {
    const auto drop = static_cast<std::ptrdiff_t>(keep_from - dropped_);
    commanded_.erase(commanded_.begin(), commanded_.begin() + drop);
    actual_.erase(actual_.begin(), actual_.begin() + drop);
    t_s_.erase(t_s_.begin(), t_s_.begin() + drop);
    dropped_ = keep_from;
  }
}

void CommandedPathDeviation::finish() {
  while (next_ < count_) process(next_++, count_);
}

double CommandedPathDeviation::nearest(const removal::Pose& query, const std::vector<Entry>& path, std::size_t first,
                                       std::size_t last, std::size_t& best) const {
  // The nearest tip on the segments; the axis there (interpolated as the removal sweeps it)
  // then adds its turn: the pose distance at a point of the path, so an upper bound of the
  // nearest.
  const auto at = [&](std::size_t i) -> const removal::Pose& { return path[i - dropped_].pose; };
  double best_squared = std::numeric_limits<double>::infinity(), best_f = 0.0;
  best = first;
  for (std::size_t i = first; i < last; ++i) {
    const Eigen::Vector3d segment = at(i + 1).tip_W_m - at(i).tip_W_m;
    const double length_squared = segment.squaredNorm();
    const double f = length_squared > 0.0 ? std::clamp((query.tip_W_m - at(i).tip_W_m).dot(segment) / length_squared, 0.0, 1.0) : 0.0;
    const double squared = (at(i).tip_W_m + f * segment - query.tip_W_m).squaredNorm();
    if (squared < best_squared) best_squared = squared, best_f = f, best = i;
  }
  if (last <= first) best_squared = (at(first).tip_W_m - query.tip_W_m).squaredNorm();  // a single pose
  Eigen::Vector3d axis = at(best).axis_W;
  if (last > first) {
    const Eigen::Vector3d blend = (1.0 - best_f) * at(best).axis_W + best_f * at(best + 1).axis_W;
    if (blend.norm() > 1e-12) axis = blend.normalized();
  }
  const double turn_rad = std::atan2(axis.cross(query.axis_W).norm(), axis.dot(query.axis_W));
  return std::sqrt(best_squared) + turn_rad * reach_m_;
}

void CommandedPathDeviation::process(std::size_t n, std::size_t known) {
  // Segments [i, i + 1] from the previous match (the paths go on together) or n - window, up
  // to n + window.
  const std::size_t last = std::min(n + window_, known - 1);
  const auto first_from = [&](std::size_t previous) {
    std::size_t first = std::min(previous, n);
    first = first >= 2 ? first - 2 : 0;
    first = std::max(first, n > window_ ? n - window_ : std::size_t{0});
    return std::min(first, last > 0 ? last - 1 : 0);
  };
  const auto record = [&](double distance_m, bool from_actual) {
    ++matched_;
    if (distance_m > worst_m_) worst_m_ = distance_m, worst_t_s_ = t_s_[n - dropped_], worst_actual_ = from_actual;
  };
  const Entry& actual = actual_[n - dropped_];
  const Entry& commanded = commanded_[n - dropped_];
  if (!actual.clear) {
    record(nearest(actual.pose, commanded_, first_from(best_commanded_), last, best_commanded_), true);
  }
  if (!commanded.clear) {
    record(nearest(commanded.pose, actual_, first_from(best_actual_), last, best_actual_), false);
  }
}

ValidityCheck check_reference_by_bound(double surface_bound_m, double limit_m, const std::string& detail) {
  ValidityCheck check{"reference_vs_commanded",
                      "reference surface against the surface of the planned tool path (the set points' geometry), "
                      "bounded by the reference run's deviation from that path",
                      surface_bound_m * 1e6, limit_m * 1e6, "um", CheckStatus::passed, detail};
  if (!(surface_bound_m <= limit_m)) check.status = CheckStatus::failed;
  return check;
}

const char* status_name(CheckStatus status) {
  switch (status) {
    case CheckStatus::passed: return "ok";
    case CheckStatus::warning: return "WARNING";
    case CheckStatus::failed: return "FAILED";
    case CheckStatus::not_done: return "not done";
  }
  return "?";
}

std::string check_line(const ValidityCheck& check) {
  std::string line = "check " + std::string(status_name(check.status)) + ": " + check.title;
  // Checks whose limit is zero (nothing beyond the travel) show a figure only when they fail.
  const bool has_figure = check.status != CheckStatus::not_done && (check.limit != 0.0 || check.value != 0.0);
  if (has_figure) {
    // Three decimals, or three significant digits below 0.01 (35 samples in 14 M are not "0.000 %").
    const auto figure = [](double value) {
      return value != 0.0 && std::abs(value) < 0.01 ? significant(value) : rounded(value, 3);
    };
    line += ": " + figure(check.value) + " " + check.unit + " (limit " + figure(check.limit) + ")";
  }
  if (!check.detail.empty()) line += "; " + check.detail;
  return line;
}

nlohmann::json check_json(const ValidityCheck& check) {
  nlohmann::json entry{{"id", check.id}, {"check", check.title}, {"status", status_name(check.status)},
                       {"detail", check.detail}};
  if (check.status != CheckStatus::not_done) {
    entry["value"] = std::isfinite(check.value) ? nlohmann::json(check.value) : nlohmann::json("inf");
    entry["limit"] = check.limit;
    entry["unit"] = check.unit;
  }
  return entry;
}

}  // namespace vmsim::app
