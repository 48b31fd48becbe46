#pragma once
// Thinning of a sampled tool trajectory before the removal: a sample is dropped when the tool
// it stands for (its tip, and the point `tool_length_m` up its axis) lies within a tolerance of
// the straight interpolation between the kept neighbours (the removal interpolates linearly
// between poses, removal/README.md "Motion between samples").
//
// Greedy from the last kept sample (the anchor): the next kept sample is the farthest one such
// that every sample between lies within the tolerance, looking at most kMaxWindow samples ahead
// (this bounds the cost on long straight stretches). The first and the last samples are kept.
//
// TrajectoryThinner does the same on a stream (samples given one at a time, as the direct
// kinematics produces them): it holds at most kMaxWindow + 1 poses and keeps exactly the samples
// thin_trajectory keeps on the whole trajectory (tests/removal/test_trajectory.cpp), so a chain
// that never holds the whole run's samples cuts the same surface. It does not recompute every
// sample's deviation for each candidate: moving the candidate from b to b' moves the
// interpolation at window offset k by k (v' - v), v = (b - a) / candidate the mean step (tip and
// top alike), so a sample checked once stays within the tolerance while k times the steps'
// summed change (the drift) stays below its slack; only then is it checked again. The slack
// keeps a margin far above the rounding of the deviations (1e-9 m per metre of coordinates), so
// the decisions are those of checking every sample every time, exactly.
#include <cstddef>
#include <functional>
#include <vector>

#include "vmsim/removal/tool.hpp"

namespace vmsim::removal {

class TrajectoryThinner {
 public:
  static constexpr std::size_t kMaxWindow = 256;

  /// `on_kept(index, pose)` is called once per kept sample, in order (index from 0 over all
  /// samples pushed).
  TrajectoryThinner(double tool_length_m, double tolerance_m,
                    std::function<void(std::size_t, const Pose&)> on_kept);

  /// The next sample of the trajectory.
  void push(const Pose& pose);
  /// After the last sample: keeps it (when more than one sample was pushed).
  void finish();
  /// The tool changes after the last sample pushed (another tool length: the same axis
  /// positions put another tip): keeps that sample, and thins the samples that follow from
  /// `anchor`, the same sample with the new tool (not reported again: on_kept gave its index).
  /// No sample is ever interpolated across the change.
  void restart_from(const Pose& anchor);
  std::size_t samples() const { return next_; }

 private:
  bool within(std::size_t candidate);
  bool check(std::size_t k, std::size_t candidate);  // sample k's deviation, noted
  void new_anchor();  // window_ holds the anchor alone: the drift starts over

  double tool_length_m_, tolerance_m_;
  std::function<void(std::size_t, const Pose&)> on_kept_;
  std::vector<Pose> window_;  // samples anchor_ .. end_ (end_ the farthest accepted so far)
  std::size_t anchor_ = 0, next_ = 0;
  // Per window offset: the deviation when last checked and the drift then.
  std::vector<double> deviation_m_, checked_drift_m_;
  Eigen::Vector3d anchor_top_W_m_ = Eigen::Vector3d::Zero();  ///< the anchor's tool top
  Eigen::Vector3d step_tip_m_ = Eigen::Vector3d::Zero(), step_top_m_ = Eigen::Vector3d::Zero();  ///< v of the last candidate
  double drift_m_ = 0.0;  ///< summed |v' - v| (the larger of tip and top) since the anchor
  double recheck_drift_m_ = 0.0;  ///< below it no checked sample needs a new check
  double coordinate_scale_m_ = 1.0;  ///< a power of two above every coordinate seen (the margin's scale)
};

/// The indices of the samples to keep (first and last included), as described above.
std::vector<std::size_t> thin_trajectory(const std::vector<Pose>& poses, double tool_length_m,
                                         double tolerance_m);

}  // namespace vmsim::removal
