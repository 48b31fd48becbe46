#include "vmsim/removal/trajectory.hpp"

#include <algorithm>

namespace vmsim::removal {
namespace {

// Distance of sample k's tool (tip and top) from the interpolation between samples a and b.
double deviation(const Pose& a, const Pose& b, double f, const Pose& k, double tool_length_m) {
  const Eigen::Vector3d tip = (1 - f) * a.tip_W_m + f * b.tip_W_m;
  const Eigen::Vector3d top = tip + tool_length_m * ((1 - f) * a.axis_W + f * b.axis_W);
  const Eigen::Vector3d top_k = k.tip_W_m + tool_length_m * k.axis_W;
  return std::max((k.tip_W_m - tip).norm(), (top_k - top).norm());
}

}  // namespace

TrajectoryThinner::TrajectoryThinner(double tool_length_m, double tolerance_m,
                                     std::function<void(std::size_t, const Pose&)> on_kept)
    : tool_length_m_(tool_length_m), tolerance_m_(tolerance_m), on_kept_(std::move(on_kept)) {}

// True when every sample strictly between the anchor and `candidate` (window offsets) lies
// within the tolerance of the interpolation between them.
bool TrajectoryThinner::within(std::size_t candidate) const {
  for (std::size_t k = 1; k < candidate; ++k) {
    const double f = static_cast<double>(k) / static_cast<double>(candidate);
    if (!(deviation(window_.front(), window_[candidate], f, window_[k], tool_length_m_) <= tolerance_m_)) {
      return false;
    }
  }
  return true;
}

void TrajectoryThinner::push(const Pose& pose) {
  const std::size_t index = next_++;
  if (index == 0) {
    window_.push_back(pose);
    anchor_ = 0;
    on_kept_(0, pose);
    return;
  }
  window_.push_back(pose);
  const std::size_t candidate = index - anchor_;  // its offset in the window
  // The first sample after the anchor is always accepted; a later one when the window allows
  // it and every sample between stays within the tolerance.
  if (candidate == 1 || (candidate <= kMaxWindow && within(candidate))) return;
  // Rejected: the sample before it (the farthest accepted) is kept and becomes the anchor; the
  // new sample is then the first after it, accepted.
  const std::size_t end = index - 1;
  window_.pop_back();
  on_kept_(end, window_.back());
  window_.erase(window_.begin(), window_.end() - 1);
  anchor_ = end;
  window_.push_back(pose);
}

void TrajectoryThinner::finish() {
  if (next_ < 2 || next_ - 1 == anchor_) return;
  on_kept_(next_ - 1, window_.back());
  window_.erase(window_.begin(), window_.end() - 1);
  anchor_ = next_ - 1;
}

void TrajectoryThinner::restart_from(const Pose& anchor) {
  if (next_ == 0) return;
  finish();  // the last sample is kept; the window holds it alone
  window_.front() = anchor;
}

std::vector<std::size_t> thin_trajectory(const std::vector<Pose>& poses, double tool_length_m,
                                         double tolerance_m) {
  std::vector<std::size_t> kept;
  TrajectoryThinner thinner(tool_length_m, tolerance_m,
                            [&](std::size_t index, const Pose&) { kept.push_back(index); });
  for (const Pose& pose : poses) thinner.push(pose);
  thinner.finish();
  return kept;
}

}  // namespace vmsim::removal
