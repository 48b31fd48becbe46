#include "following_errors.hpp"

#include <algorithm>
#include <cmath>
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
  commanded_.push_back(kinematics::forward_kinematics(machine_, q_cmd, tool_length_m_).tip_W_m);
  Pending sample;
  sample.t_s = t_s;
  sample.cutting = cutting;
  if (cutting) {
    sample.q_cmd = q_cmd;
    sample.q_actual = q_actual;
    if (elastic_) sample.q_motor = q_motor;
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
  const Eigen::Vector3d tip = kinematics::forward_kinematics(machine_, sample.q_actual, tool_length_m_).tip_W_m;
  lag_peak_ = std::max(lag_peak_, (tip - commanded(k)).norm());
  // The contour error: the distance from the actual tip to the commanded tip's path (its
  // segments within 0.1 s either side), not to where the command is at that instant (the
  // drives follow with a delay along the path, which leaves no mark).
  double deviation = (tip - commanded(k)).norm();
  for (std::size_t i = k > window_ ? k - window_ : 0; i + 1 < samples_ && i < k + window_; ++i) {
    const Eigen::Vector3d segment = commanded(i + 1) - commanded(i);
    const double length2 = segment.squaredNorm();
    const double f = length2 > 0.0 ? std::clamp((tip - commanded(i)).dot(segment) / length2, 0.0, 1.0) : 0.0;
    deviation = std::min(deviation, (tip - commanded(i) - f * segment).norm());
  }
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
