#include "vmsim/removal/trajectory.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

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

// The drift [m] up to which sample k, checked at a deviation of deviation_m, stays within the
// tolerance less `margin_m`.
double recheck_drift(double checked_drift_m, double deviation_m, double tolerance_m, double margin_m, std::size_t k) {
  return checked_drift_m + (tolerance_m - deviation_m - margin_m) / static_cast<double>(k);
}

void TrajectoryThinner::new_anchor() {
  const Pose& a = window_.front();
  anchor_top_W_m_ = a.tip_W_m + tool_length_m_ * a.axis_W;
  drift_m_ = 0.0;
  recheck_drift_m_ = std::numeric_limits<double>::infinity();
}

bool TrajectoryThinner::check(std::size_t k, std::size_t candidate) {
  const double f = static_cast<double>(k) / static_cast<double>(candidate);
  const double d = deviation(window_.front(), window_[candidate], f, window_[k], tool_length_m_);
  deviation_m_[k] = d;
  checked_drift_m_[k] = drift_m_;
  return d <= tolerance_m_;
}

// True when every sample strictly between the anchor and `candidate` (window offsets) lies
// within the tolerance of the interpolation between them. The samples before candidate - 1 were
// within it for candidate - 1: each is checked again only when the drift may have taken it out.
bool TrajectoryThinner::within(std::size_t candidate) {
  // Rounding of the deviations and of the drift: far below this margin.
  const double margin_m = 1e-9 * coordinate_scale_m_;
  if (deviation_m_.size() <= candidate) {
    deviation_m_.resize(candidate + 1);
    checked_drift_m_.resize(candidate + 1);
  }
  if (!check(candidate - 1, candidate)) return false;
  double recheck = recheck_drift(drift_m_, deviation_m_[candidate - 1], tolerance_m_, margin_m, candidate - 1);
  if (drift_m_ <= recheck_drift_m_) {
    recheck_drift_m_ = std::min(recheck_drift_m_, recheck);
    return true;
  }
  for (std::size_t k = 1; k + 1 < candidate; ++k) {
    const double bound = static_cast<double>(k) * (drift_m_ - checked_drift_m_[k]);
    if (!(bound <= tolerance_m_ - deviation_m_[k] - margin_m) && !check(k, candidate)) return false;
    recheck = std::min(recheck, recheck_drift(checked_drift_m_[k], deviation_m_[k], tolerance_m_, margin_m, k));
  }
  recheck_drift_m_ = recheck;
  return true;
}

void TrajectoryThinner::push(const Pose& pose) {
  const std::size_t index = next_++;
  // The margin's scale: a power of two, so that it changes seldom (every recheck bound is then
  // found again with the larger margin).
  const Eigen::Vector3d top = pose.tip_W_m + tool_length_m_ * pose.axis_W;
  const double coordinate_m = std::max(pose.tip_W_m.cwiseAbs().maxCoeff(), top.cwiseAbs().maxCoeff());
  if (coordinate_m > coordinate_scale_m_) {
    while (coordinate_scale_m_ < coordinate_m && std::isfinite(coordinate_scale_m_)) coordinate_scale_m_ *= 2;
    recheck_drift_m_ = -std::numeric_limits<double>::infinity();
  }
  if (index == 0) {
    window_.push_back(pose);
    anchor_ = 0;
    new_anchor();
    on_kept_(0, pose);
    return;
  }
  window_.push_back(pose);
  const std::size_t candidate = index - anchor_;  // its offset in the window
  // The mean step to the candidate, and the drift it adds to the interpolation.
  const double steps = static_cast<double>(candidate);
  const Eigen::Vector3d step_tip = (pose.tip_W_m - window_.front().tip_W_m) / steps;
  const Eigen::Vector3d step_top = (top - anchor_top_W_m_) / steps;
  if (candidate > 1) drift_m_ += std::max((step_tip - step_tip_m_).norm(), (step_top - step_top_m_).norm());
  step_tip_m_ = step_tip;
  step_top_m_ = step_top;
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
  new_anchor();
  window_.push_back(pose);
  step_tip_m_ = pose.tip_W_m - window_.front().tip_W_m;
  step_top_m_ = top - anchor_top_W_m_;
}

void TrajectoryThinner::finish() {
  if (next_ < 2 || next_ - 1 == anchor_) return;
  on_kept_(next_ - 1, window_.back());
  window_.erase(window_.begin(), window_.end() - 1);
  anchor_ = next_ - 1;
  new_anchor();
}

void TrajectoryThinner::restart_from(const Pose& anchor) {
  if (next_ == 0) return;
  finish();  // the last sample is kept; the window holds it alone
  window_.front() = anchor;
  new_anchor();
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
