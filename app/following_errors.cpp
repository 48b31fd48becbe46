#include "following_errors.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "vmsim/kinematics/kinematics.hpp"

namespace vmsim::app {

FollowingErrorSummary::FollowingErrorSummary(const kinematics::MachineModel& machine, double tool_length_m,
                                             bool tool_tip, bool motor_side)
    : machine_(machine),
      tool_length_m_(tool_length_m),
      tool_tip_(tool_tip),
      motor_side_(motor_side),
      peak_(machine.axes.size(), 0.0),
      cutting_peak_(machine.axes.size(), 0.0),
      cutting_sum_squares_(machine.axes.size(), 0.0),
      cutting_peak_t_s_(machine.axes.size(), 0.0),
      motor_(machine.axes.size(), false),
      compensated_(machine.axes.size()) {}

void FollowingErrorSummary::add(double t_s, const Eigen::Ref<const Eigen::VectorXd>& q_cmd,
                                const Eigen::Ref<const Eigen::VectorXd>& q_actual,
                                const Eigen::Ref<const Eigen::VectorXd>& q_motor, bool cutting) {
  if (!tool_tip_) {
    add(t_s, q_cmd, q_actual, q_motor, cutting, Eigen::Isometry3d::Identity(), Eigen::Isometry3d::Identity());
    return;
  }
  add(t_s, q_cmd, q_actual, q_motor, cutting, spindle_frame_W(machine_, q_cmd), spindle_frame_W(machine_, q_actual));
}

void FollowingErrorSummary::add(double t_s, const Eigen::Ref<const Eigen::VectorXd>& q_cmd,
                                const Eigen::Ref<const Eigen::VectorXd>& q_actual,
                                const Eigen::Ref<const Eigen::VectorXd>& q_motor, bool cutting,
                                const Eigen::Isometry3d& spindle_cmd_W, const Eigen::Isometry3d& spindle_actual_W) {
  const std::size_t axes = machine_.axes.size();
  if (samples_ == 0) {
    first_t_s_ = t_s;
    // The place reported when nothing is cutting: the first sample.
    std::fill(cutting_peak_t_s_.begin(), cutting_peak_t_s_.end(), t_s);
    tip_peak_t_s_ = deflection_t_s_ = t_s;
    if (tool_tip_) {
      // Where the controller compensates the static deflection under gravity, the motor stands
      // ahead of the set point by it on purpose: the servo's own gravity model gives it.
      std::vector<double> reference(q_cmd.data(), q_cmd.data() + q_cmd.size());
      for (std::size_t j = 0; j < axes; ++j) {
        const auto& compliance = machine_.axes[j].effects.compliance;
        if (compliance.enabled && motor_side_) {
          motor_[j] = true;
          elastic_ = true;
          if (compliance.compensate_gravity_deflection) {
            compensated_[j] = servo::make_axis_servo_model(machine_, static_cast<int>(j), reference, true);
          }
        }
      }
    }
  } else if (samples_ == 1) {
    second_t_s_ = t_s;
    window_ = static_cast<std::size_t>(std::ceil(0.1 / (second_t_s_ - first_t_s_)));
  }
  for (std::size_t j = 0; j < axes; ++j) {
    const auto i = static_cast<Eigen::Index>(j);
    const double error = std::abs(q_cmd[i] - q_actual[i]);
    peak_[j] = std::max(peak_[j], error);
    if (!cutting) continue;
    if (error > cutting_peak_[j]) cutting_peak_[j] = error, cutting_peak_t_s_[j] = t_s;
    cutting_sum_squares_[j] += error * error;
  }
  if (cutting) ++cutting_count_;
  ++samples_;
  if (!tool_tip_) return;
  commanded_.push_back(tool_tip_W_m(spindle_cmd_W, tool_length_m_));
  Pending sample;
  sample.t_s = t_s;
  sample.cutting = cutting;
  if (cutting) {
    sample.tip_W_m = tool_tip_W_m(spindle_actual_W, tool_length_m_);
    if (elastic_) {
      sample.q_cmd = q_cmd;
      sample.q_actual = q_actual;
      sample.q_motor = q_motor;
    }
  }
  pending_.push_back(std::move(sample));
  if (samples_ >= 2) process_ready(false);
}

void FollowingErrorSummary::process_ready(bool all) {
  // Sample k reads the commanded tips up to k + window (the last one at the end).
  while (!pending_.empty() && (all || pending_first_ + window_ < samples_ - 1)) {
    tip_sample(pending_first_);
    pending_.pop_front();
    ++pending_first_;
    // The tips no later sample reads (it reads from k - window on).
    while (window_first_ + window_ < pending_first_ && commanded_dropped_ < commanded_.size()) {
      ++commanded_dropped_;
      ++window_first_;
    }
    if (commanded_dropped_ > 4096 && commanded_dropped_ > commanded_.size() / 2) {
      commanded_.erase(commanded_.begin(), commanded_.begin() + static_cast<std::ptrdiff_t>(commanded_dropped_));
      commanded_dropped_ = 0;
    }
  }
}

void FollowingErrorSummary::tip_sample(std::size_t k) {
  const Pending& sample = pending_.front();
  if (!sample.cutting) return;
  const Eigen::Vector3d* tips = commanded_.data() + commanded_dropped_;
  const auto commanded = [&](std::size_t i) -> const Eigen::Vector3d& { return tips[i - window_first_]; };
  const Eigen::Vector3d& tip = sample.tip_W_m;
  lag_peak_ = std::max(lag_peak_, (tip - commanded(k)).norm());
  // The contour error: the distance from the actual tip to the commanded tip's path (its
  // segments within 0.1 s either side), not to where the command is at that instant (the
  // drives follow with a delay along the path, which leaves no mark).
  const double deviation = contour_error(tip, k);
  if (deviation > tip_peak_) tip_peak_ = deviation, tip_peak_t_s_ = sample.t_s;
  tip_sum_squares_ += deviation * deviation;
  ++tip_count_;
  if (!elastic_) return;
  Eigen::VectorXd q_motor = sample.q_actual;
  for (std::size_t j = 0; j < machine_.axes.size(); ++j) {
    if (!motor_[j]) continue;
    double q = sample.q_motor[static_cast<Eigen::Index>(j)];
    if (compensated_[j]) {
      const servo::AxisServoModel& m = *compensated_[j];
      const double q_set = sample.q_cmd[static_cast<Eigen::Index>(j)];
      double tau = m.gravity_constant_N_m;
      if (machine_.axes[j].type == kinematics::AxisType::rotary) {
        tau += m.gravity_cos_N_m * std::cos(q_set) + m.gravity_sin_N_m * std::sin(q_set);
      }
      q -= tau / (m.axis.effects.compliance.stiffness * m.axis.drive.ratio);
    }
    q_motor[static_cast<Eigen::Index>(j)] = q;
  }
  const double deflection = (tip - kinematics::forward_kinematics(machine_, q_motor, tool_length_m_).tip_W_m).norm();
  if (deflection > deflection_peak_) deflection_peak_ = deflection, deflection_t_s_ = sample.t_s;
}

double FollowingErrorSummary::segment_distance_squared(const Eigen::Vector3d& tip, std::size_t i) const {
  const Eigen::Vector3d* tips = commanded_.data() + commanded_dropped_;
  const Eigen::Vector3d& start = tips[i - window_first_];
  const Eigen::Vector3d segment = tips[i + 1 - window_first_] - start;
  const double length2 = segment.squaredNorm();
  const double f = length2 > 0.0 ? std::clamp((tip - start).dot(segment) / length2, 0.0, 1.0) : 0.0;
  return (tip - start - f * segment).squaredNorm();
}

void FollowingErrorSummary::add_blocks() {
  // A block's points: kBlockSegments + 1 commanded tips from its first segment on, all known.
  while ((blocks_first_ + blocks_.size() + 1) * kBlockSegments < samples_) {
    const std::size_t first = (blocks_first_ + blocks_.size()) * kBlockSegments;
    if (first < window_first_) {  // its first tips no longer held: a sphere that skips nothing
      blocks_.push_back({Eigen::Vector3d::Zero(), std::numeric_limits<double>::infinity()});
      continue;
    }
    const Eigen::Vector3d* tips = commanded_.data() + commanded_dropped_ + (first - window_first_);
    Eigen::Vector3d low = tips[0], high = tips[0];
    for (std::size_t i = 1; i <= kBlockSegments; ++i) {
      low = low.cwiseMin(tips[i]);
      high = high.cwiseMax(tips[i]);
    }
    const Eigen::Vector3d centre = (low + high) / 2;
    double radius = 0.0;
    for (std::size_t i = 0; i <= kBlockSegments; ++i) radius = std::max(radius, (tips[i] - centre).norm());
    blocks_.push_back({centre, radius});
  }
  // Blocks before the first segment any later sample reads.
  const std::size_t unused = window_first_ / kBlockSegments;
  if (unused > blocks_first_ + 1024 && unused - blocks_first_ > blocks_.size() / 2) {
    blocks_.erase(blocks_.begin(), blocks_.begin() + static_cast<std::ptrdiff_t>(unused - blocks_first_));
    blocks_first_ = unused;
  }
}

double FollowingErrorSummary::contour_error(const Eigen::Vector3d& tip, std::size_t k) {
  // The least distance to segments i = first .. end - 1, as the plain search over all of them
  // gives it, bit for bit: the minimum of the squared distances (sqrt is monotonic and
  // correctly rounded, so sqrt of the least square is the least norm), and whole blocks of
  // segments skipped whose bounding sphere lies farther than the best so far (a skipped
  // segment's distance exceeds the minimum by far more than rounding: it cannot change it).
  const std::size_t first = k > window_ ? k - window_ : 0;
  const std::size_t end = std::min(samples_ - 1, k + window_);
  const Eigen::Vector3d* tips = commanded_.data() + commanded_dropped_;
  double best2 = (tip - tips[k - window_first_]).squaredNorm();
  if (first >= end) return std::sqrt(best2);
  // The segment nearest to the previous sample's tip is near this one's: the best so far small
  // from the start.
  const std::size_t hint = std::clamp(previous_nearest_, first, end - 1);
  best2 = std::min(best2, segment_distance_squared(tip, hint));
  std::size_t nearest = hint;
  const auto try_segment = [&](std::size_t i) {
    const double d2 = segment_distance_squared(tip, i);
    if (d2 < best2) best2 = d2, nearest = i;
  };
  add_blocks();
  // Rounding of the distances (coordinates in metres, well below 1e3 m): far below this.
  const double margin_m = 1e-9 * (1.0 + tip.cwiseAbs().maxCoeff());
  for (std::size_t block = first / kBlockSegments; block * kBlockSegments < end; ++block) {
    const std::size_t from = std::max(first, block * kBlockSegments);
    const std::size_t to = std::min(end, (block + 1) * kBlockSegments);
    if (block >= blocks_first_ && block < blocks_first_ + blocks_.size()) {
      const BlockSphere& sphere = blocks_[block - blocks_first_];
      const double lower_bound_m = (tip - sphere.centre_W_m).norm() - sphere.radius_m - margin_m;
      if (lower_bound_m > 0.0 && lower_bound_m * lower_bound_m > best2) continue;
    }
    for (std::size_t i = from; i < to; ++i) try_segment(i);
  }
  previous_nearest_ = nearest;
  return std::sqrt(best2);
}

nlohmann::json FollowingErrorSummary::finish(const std::function<double(double)>& s_at) {
  using Json = nlohmann::json;
  if (tool_tip_) {
    if (samples_ < 2) window_ = static_cast<std::size_t>(std::ceil(0.1 / 1.0));
    process_ready(true);
  }
  Json summary;
  Json axes = Json::array();
  for (std::size_t j = 0; j < machine_.axes.size(); ++j) {
    const auto& axis = machine_.axes[j];
    Json entry{{"axis", axis.name}};
    if (axis.type == kinematics::AxisType::linear) {
      entry["following_error_peak_um"] = peak_[j] * 1e6;
    } else {
      entry["following_error_peak_mdeg"] = peak_[j] * 180.0 / std::numbers::pi * 1e3;
    }
    axes.push_back(entry);
  }
  summary["axes"] = axes;
  // The same peaks over the cutting moves only (rapids run at the axes' limits, identically in
  // both runs): what the feed does to the follow-up (second paper, part 3: rotary axes).
  Json cutting = Json::array();
  for (std::size_t j = 0; j < machine_.axes.size(); ++j) {
    const double peak = cutting_peak_[j];
    const double rms = cutting_count_ > 0 ? std::sqrt(cutting_sum_squares_[j] / static_cast<double>(cutting_count_)) : 0.0;
    const auto& axis = machine_.axes[j];
    Json entry{{"axis", axis.name}, {"at_time_s", samples_ == 0 ? 0.0 : cutting_peak_t_s_[j]},
               {"at_s_mm", samples_ == 0 ? 0.0 : s_at(cutting_peak_t_s_[j]) * 1e3}};
    if (axis.type == kinematics::AxisType::linear) {
      entry["following_error_peak_um"] = peak * 1e6;
      entry["following_error_rms_um"] = rms * 1e6;
    } else {
      entry["following_error_peak_deg"] = peak * 180.0 / std::numbers::pi;
      entry["following_error_rms_deg"] = rms * 180.0 / std::numbers::pi;
    }
    cutting.push_back(entry);
  }
  summary["axes_while_cutting"] = cutting;
  // The tool tip's Cartesian deviation while cutting: the direct kinematics of the actual (load)
  // positions against that of the commanded ones, and the part of it that the joints' elastic
  // deflection makes (load against motor side, where the servo tells them apart).
  if (tool_tip_) {
    Json tip{{"contour_error_peak_um", tip_peak_ * 1e6},
             {"contour_error_rms_um", tip_count_ > 0 ? std::sqrt(tip_sum_squares_ / static_cast<double>(tip_count_)) * 1e6 : 0.0},
             {"at_s_mm", samples_ == 0 ? 0.0 : s_at(tip_peak_t_s_) * 1e3},
             {"behind_the_command_peak_um", lag_peak_ * 1e6}};
    if (elastic_) {
      tip["joint_deflection_peak_um"] = deflection_peak_ * 1e6;
      tip["joint_deflection_at_s_mm"] = s_at(deflection_t_s_) * 1e3;
    }
    summary["tool_tip_while_cutting"] = tip;
  }
  return summary;
}

}  // namespace vmsim::app
