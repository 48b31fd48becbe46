#pragma once
// The following errors of a run (report.json's run_summary "axes", "axes_while_cutting" and
// "tool_tip_while_cutting"), summarised sample by sample as the servo's records come, so that a
// run streamed in windows needs no trace: the same figures as over the whole run at once.
#include <nlohmann/json.hpp>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <deque>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "vmsim/kinematics/kinematics.hpp"
#include "vmsim/kinematics/machine_model.hpp"
#include "vmsim/servo/servo.hpp"

namespace vmsim::app {

/// The spindle frame in the workpiece frame W at joint positions q: kinematics::forward_kinematics
/// before the tool length, so that one chain serves every tool length at a sample
/// (tool_tip_W_m(frame, L) equals forward_kinematics(model, q, L).tip_W_m bit for bit: the same
/// operations).
inline Eigen::Isometry3d spindle_frame_W(const kinematics::MachineModel& machine, const Eigen::VectorXd& q) {
  return kinematics::workpiece_frame_B(machine, q).inverse(Eigen::Isometry) * kinematics::spindle_frame_B(machine, q);
}
inline Eigen::Vector3d tool_tip_W_m(const Eigen::Isometry3d& spindle_W, double tool_length_m) {
  return spindle_W * Eigen::Vector3d(0.0, 0.0, -tool_length_m);
}

class FollowingErrorSummary {
 public:
  /// `tool_tip`: summarise the tool tip's contour error (not with perfect drives); `motor_side`:
  /// the samples carry the motor-side positions (the servo distinguishes load and motor on an
  /// axis), for the share of the joints' elastic deflection.
  FollowingErrorSummary(const kinematics::MachineModel& machine, double tool_length_m, bool tool_tip,
                        bool motor_side);

  /// The next sample: time [s], commanded and actual (load) positions, the motor side (when
  /// motor_side; else ignored), SI joint units, and whether its motion is a cutting move.
  void add(double t_s, const Eigen::Ref<const Eigen::VectorXd>& q_cmd, const Eigen::Ref<const Eigen::VectorXd>& q_actual,
           const Eigen::Ref<const Eigen::VectorXd>& q_motor, bool cutting);
  /// The same with the spindle frames of q_cmd and q_actual known (spindle_frame_W): no direct
  /// kinematics of its own but for the motor side.
  void add(double t_s, const Eigen::Ref<const Eigen::VectorXd>& q_cmd, const Eigen::Ref<const Eigen::VectorXd>& q_actual,
           const Eigen::Ref<const Eigen::VectorXd>& q_motor, bool cutting, const Eigen::Isometry3d& spindle_cmd_W,
           const Eigen::Isometry3d& spindle_actual_W);
  /// After the last sample: the summary; `s_at(t)` is the path length [m] planned at time t.
  nlohmann::json finish(const std::function<double(double)>& s_at);

 private:
  struct Pending {
    double t_s = 0.0;
    Eigen::VectorXd q_cmd, q_actual, q_motor;  ///< cutting samples with elastic joints only
    Eigen::Vector3d tip_W_m = Eigen::Vector3d::Zero();  ///< the actual tip (cutting samples)
    bool cutting = false;
  };
  void tip_sample(std::size_t k);  // the contour error of pending sample k (its neighbours known)
  void process_ready(bool all);
  // The distance from `tip` to the commanded tips' path within 0.1 s of sample k.
  double contour_error(const Eigen::Vector3d& tip, std::size_t k);
  double segment_distance_squared(const Eigen::Vector3d& tip, std::size_t i) const;  // to segment i -> i + 1
  void add_blocks();  // the bounding spheres of the blocks whose tips are all known

  const kinematics::MachineModel& machine_;
  double tool_length_m_;
  bool tool_tip_, motor_side_;
  std::size_t samples_ = 0;
  double first_t_s_ = 0.0, second_t_s_ = 0.0;
  // Per axis: the peak over all samples; while cutting the peak, its time, the sum of squares.
  std::vector<double> peak_, cutting_peak_, cutting_sum_squares_;
  std::vector<double> cutting_peak_t_s_;
  std::size_t cutting_count_ = 0;
  // The tool tip: commanded tips of the samples from `window_first_` on, the samples whose
  // contour error is still to be found (their commanded neighbours 0.1 s ahead not yet known).
  // (A vector whose consumed front is dropped now and then: the contour error reads 2 x 0.1 s of
  // tips per sample, contiguous access matters.)
  std::vector<Eigen::Vector3d> commanded_;
  std::size_t commanded_dropped_ = 0;  ///< entries of commanded_ before window_first_
  std::size_t window_first_ = 0;
  // Bounding spheres of blocks of kBlockSegments commanded segments (block b: segments from
  // b * kBlockSegments on), from block blocks_first_ on: the contour error skips far blocks.
  static constexpr std::size_t kBlockSegments = 8;
  struct BlockSphere {
    Eigen::Vector3d centre_W_m;
    double radius_m;
  };
  std::vector<BlockSphere> blocks_;
  std::size_t blocks_first_ = 0;
  std::size_t previous_nearest_ = 0;  ///< the segment nearest to the last sample's tip
  std::deque<Pending> pending_;
  std::size_t pending_first_ = 0;
  std::size_t window_ = 0;  ///< samples in 0.1 s (known after the second sample)
  std::vector<bool> motor_;
  std::vector<std::optional<servo::AxisServoModel>> compensated_;
  bool elastic_ = false;
  double tip_peak_ = 0.0, tip_sum_squares_ = 0.0, deflection_peak_ = 0.0, lag_peak_ = 0.0;
  double tip_peak_t_s_ = 0.0, deflection_t_s_ = 0.0;
  std::size_t tip_count_ = 0;
};

}  // namespace vmsim::app
