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
// that never holds the whole run's samples cuts the same surface.
#include <cstddef>
#include <deque>
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
  bool within(std::size_t candidate) const;

  double tool_length_m_, tolerance_m_;
  std::function<void(std::size_t, const Pose&)> on_kept_;
  std::deque<Pose> window_;  // samples anchor_ .. end_ (end_ the farthest accepted so far)
  std::size_t anchor_ = 0, next_ = 0;
};

/// The indices of the samples to keep (first and last included), as described above.
std::vector<std::size_t> thin_trajectory(const std::vector<Pose>& poses, double tool_length_m,
                                         double tolerance_m);

}  // namespace vmsim::removal
