#include "vmsim/kinematics/redundancy.hpp"

#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <vector>

namespace vmsim::kinematics {
namespace {

Eigen::Matrix3d spindle_rotation_W(const MachineModel& model, const Eigen::VectorXd& q) {
  return (workpiece_frame_B(model, q).inverse() * spindle_frame_B(model, q)).linear();
}

Eigen::Matrix3d target_rotation(const Eigen::Vector3d& axis_W, double roll) {
  const Eigen::Vector3d z = axis_W.normalized();
  Eigen::Vector3d reference = Eigen::Vector3d::UnitX() - z.x() * z;
  if (reference.norm() < 1e-6) reference = Eigen::Vector3d::UnitY() - z.y() * z;
  reference.normalize();
  const Eigen::Vector3d x = Eigen::AngleAxisd(roll, z) * reference;
  Eigen::Matrix3d R;
  R.col(0) = x;
  R.col(1) = z.cross(x);
  R.col(2) = z;
  return R;
}

double roll_of(const Eigen::Matrix3d& R) {
  const Eigen::Vector3d z = R.col(2);
  const Eigen::Matrix3d R0 = target_rotation(z, 0.0);
  return std::atan2(R.col(0).dot(R0.col(1)), R.col(0).dot(R0.col(0)));
}

// Damped least-squares Newton on the full frame (tip position and rotation).
std::optional<Eigen::VectorXd> solve_frame(const MachineModel& model, const Eigen::Vector3d& tip_W,
                                           const Eigen::Matrix3d& R_target, Eigen::VectorXd q,
                                           double tool_length_m) {
  Eigen::Matrix3Xd Jp, Jr;
  for (int iteration = 0; iteration < 200; ++iteration) {
    const ToolPose now = forward_kinematics(model, q, tool_length_m);
    const Eigen::Matrix3d R = spindle_rotation_W(model, q);
    Eigen::Matrix<double, 6, 1> e;
    e.head<3>() = tip_W - now.tip_W_m;
    Eigen::Vector3d er = Eigen::Vector3d::Zero();
    for (int i = 0; i < 3; ++i) er += 0.5 * R.col(i).cross(R_target.col(i));
    e.tail<3>() = er;
    if (e.head<3>().norm() < 1e-11 && er.norm() < 1e-11) return q;
    // Limit the task step (0.05 m, 0.2 rad) so that the self-motion is followed.
    const double scale = std::min({1.0, 0.05 / std::max(e.head<3>().norm(), 1e-300), 0.2 / std::max(er.norm(), 1e-300)});
    tool_jacobian_W(model, q, tool_length_m, Jp, Jr);
    Eigen::MatrixXd J(6, q.size());
    J.topRows(3) = Jp;
    J.bottomRows(3) = Jr;
    const double lambda2 = 1e-8;
    const Eigen::MatrixXd A = J * J.transpose() + lambda2 * Eigen::MatrixXd::Identity(6, 6);
    q += J.transpose() * A.ldlt().solve(scale * e);
  }
  return std::nullopt;
}

}  // namespace

RedundancyMargins redundancy_margins(const MachineModel& model, const Eigen::VectorXd& q, double tool_length_m) {
  RedundancyMargins m;
  m.travel_margin = 0.5;
  for (std::size_t i = 0; i < model.axes.size(); ++i) {
    const Axis& axis = model.axes[i];
    if (axis.type == AxisType::rotary && axis.continuous) continue;
    const double range = axis.travel_max - axis.travel_min;
    if (!(range > 0.0)) continue;
    const double qi = q[static_cast<Eigen::Index>(i)];
    m.travel_margin = std::min(m.travel_margin, std::min(qi - axis.travel_min, axis.travel_max - qi) / range);
  }
  Eigen::Matrix3Xd Jp, Jr;
  tool_jacobian_W(model, q, tool_length_m, Jp, Jr);
  Eigen::MatrixXd J(6, q.size());
  J.topRows(3) = Jp;
  J.bottomRows(3) = Jr;
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(J);
  const auto& s = svd.singularValues();
  m.inverse_condition = s.size() >= 6 && s(0) > 0.0 ? s(5) / s(0) : 0.0;
  return m;
}

std::optional<ToolRollChoice> choose_tool_roll(const MachineModel& model, const ToolPose& pose,
                                               const Eigen::VectorXd& q_seed, double tool_length_m,
                                               double step_rad) {
  if (model.axes.size() < 6 || !(step_rad > 0.0)) return std::nullopt;
  const auto start = inverse_kinematics(model, pose, q_seed, tool_length_m);
  if (!start) return std::nullopt;
  ToolRollChoice best;
  best.q = start->q;
  best.seed_margins = redundancy_margins(model, start->q, tool_length_m);
  best.margins = best.seed_margins;
  best.roll_rad = roll_of(spindle_rotation_W(model, start->q));
  const double roll0 = best.roll_rad;
  const int count = static_cast<int>(std::ceil(2.0 * std::numbers::pi / step_rad - 1e-9));
  // Both ways round from the seed's roll, each roll solved from its neighbour.
  for (const double direction : {1.0, -1.0}) {
    Eigen::VectorXd q = start->q;
    for (int k = 1; k <= count / 2; ++k) {
      ++best.rolls_tried;
      const double roll = roll0 + direction * k * step_rad;
      const auto solved = solve_frame(model, pose.tip_W_m, target_rotation(pose.axis_W, roll), q, tool_length_m);
      if (!solved) break;  // the self-motion ends (a singularity or out of reach): stop this way
      q = *solved;
      if (!within_travel(model, q)) continue;
      ++best.rolls_solved;
      const RedundancyMargins m = redundancy_margins(model, q, tool_length_m);
      if (m.score() > best.margins.score()) {
        best.margins = m;
        best.q = q;
        best.roll_rad = std::remainder(roll, 2.0 * std::numbers::pi);
      }
    }
  }
  return best;
}

}  // namespace vmsim::kinematics

namespace vmsim::kinematics {
namespace {

// A pose on the programmed segment between two path poses: the tip on the chord, the tool axis
// on the great circle, at fraction f.
ToolPose pose_between(const ToolPose& a, const ToolPose& b, double f) {
  ToolPose pose;
  pose.tip_W_m = (1.0 - f) * a.tip_W_m + f * b.tip_W_m;
  const Eigen::Vector3d u = a.axis_W.normalized(), v = b.axis_W.normalized();
  const double angle = std::acos(std::clamp(u.dot(v), -1.0, 1.0));
  if (angle < 1e-12) {
    pose.axis_W = u;
  } else {
    pose.axis_W = (std::sin((1.0 - f) * angle) * u + std::sin(f * angle) * v) / std::sin(angle);
  }
  return pose;
}

double largest_joint_step(const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
  return (a - b).cwiseAbs().maxCoeff();
}

double score_of(const MachineModel& model, const Eigen::VectorXd& q, double tool_length_m) {
  if (!within_travel(model, q, 1e-9)) return -1.0;
  return redundancy_margins(model, q, tool_length_m).score();
}

// Follows the 6-dof solution from (pose a, roll a, q_a) to (pose b, roll b): one solve, or
// halves of the step (down to 1/16) where one solve moves a joint by more than max_step (near a
// singularity the wrist turns fast but continuously); nullopt where even the 1/16 step jumps (a
// change of branch) or the solver fails.
std::optional<Eigen::VectorXd> follow(const MachineModel& model, const ToolPose& a, double roll_a, const ToolPose& b,
                                      double roll_b, const Eigen::VectorXd& q_a, double tool_length_m,
                                      double max_step, int depth = 0) {
  const auto direct = solve_frame(model, b.tip_W_m, target_rotation(b.axis_W, roll_b), q_a, tool_length_m);
  if (direct && largest_joint_step(*direct, q_a) <= max_step) return direct;
  if (depth >= 4) return std::nullopt;
  const ToolPose half = pose_between(a, b, 0.5);
  const double roll_half = 0.5 * (roll_a + roll_b);
  const auto middle = follow(model, a, roll_a, half, roll_half, q_a, tool_length_m, max_step, depth + 1);
  if (!middle) return std::nullopt;
  return follow(model, half, roll_half, b, roll_b, *middle, tool_length_m, max_step, depth + 1);
}

struct Sample {
  ToolPose pose;
  double s_m = 0.0;
  long point = -1;  // the path point this sample is, -1 between points
};

// The Gaussian-smoothed value at s of the piecewise-linear function through (xs, ys), constant
// beyond its ends, in closed form per piece.
double smoothed(const std::vector<double>& xs, const std::vector<double>& ys, double s, double sigma) {
  const std::size_t n = xs.size();
  if (n == 1 || !(sigma > 0.0)) {
    if (n == 1 || s <= xs.front()) return ys.front();
    if (s >= xs.back()) return ys.back();
    const auto it = std::upper_bound(xs.begin(), xs.end(), s);
    const std::size_t k = static_cast<std::size_t>(it - xs.begin());
    const double f = (s - xs[k - 1]) / std::max(xs[k] - xs[k - 1], 1e-300);
    return ys[k - 1] + f * (ys[k] - ys[k - 1]);
  }
  const double c = 1.0 / (sigma * std::sqrt(2.0));
  const double g = sigma / std::sqrt(2.0 * std::numbers::pi);
  // Mass of the Gaussian centred at s over [a, b]: 0.5 (erf((b - s) c) - erf((a - s) c)).
  auto mass = [&](double a, double b) { return 0.5 * (std::erf((b - s) * c) - std::erf((a - s) * c)); };
  auto first_moment = [&](double a, double b) {  // int over [a, b] of (x - s) G(s - x) dx
    return g * (std::exp(-(a - s) * (a - s) * c * c) - std::exp(-(b - s) * (b - s) * c * c));
  };
  const double reach = 8.0 * sigma;
  double value = ys.front() * mass(-std::numeric_limits<double>::infinity(), xs.front());
  value += ys.back() * mass(xs.back(), std::numeric_limits<double>::infinity());
  std::size_t k = static_cast<std::size_t>(std::lower_bound(xs.begin(), xs.end(), s - reach) - xs.begin());
  if (k > 0) --k;
  for (; k + 1 < n && xs[k] <= s + reach; ++k) {
    const double a = xs[k], b = xs[k + 1];
    if (!(b > a)) continue;
    const double slope = (ys[k + 1] - ys[k]) / (b - a);
    // y(x) = y_k + slope (x - a) = (y_k + slope (s - a)) + slope (x - s)
    value += (ys[k] + slope * (s - a)) * mass(a, b) + slope * first_moment(a, b);
  }
  return value;
}

}  // namespace

double tool_roll_of(const MachineModel& model, const Eigen::VectorXd& q) {
  return roll_of(spindle_rotation_W(model, q));
}

std::optional<Eigen::VectorXd> inverse_kinematics_with_roll(const MachineModel& model, const ToolPose& pose,
                                                            double roll_rad, const Eigen::VectorXd& q_previous,
                                                            double tool_length_m) {
  return solve_frame(model, pose.tip_W_m, target_rotation(pose.axis_W, roll_rad), q_previous, tool_length_m);
}

std::optional<RollProfile> choose_tool_roll_along_path(const MachineModel& model, const std::vector<PathPose>& path,
                                                       const Eigen::VectorXd& q_seed, double tool_length_m,
                                                       const RollProfileOptions& options) {
  if (model.axes.size() < 6 || path.empty() || !(options.grid_step_rad > 0.0)) return std::nullopt;
  for (const PathPose& p : path) {
    if (p.q_given.size() > 0) return std::nullopt;
  }
  // 1. Samples.
  std::vector<double> segment_length(path.size(), 0.0);
  double total = 0.0;
  for (std::size_t i = 1; i < path.size(); ++i) {
    const ToolPose& a = path[i - 1].pose;
    const ToolPose& b = path[i].pose;
    const double turn = std::acos(std::clamp(a.axis_W.normalized().dot(b.axis_W.normalized()), -1.0, 1.0));
    const double chord = (b.tip_W_m - a.tip_W_m).norm();
    segment_length[i] = chord > 1e-12 ? chord : kReorientationLever_m * turn;
    total += segment_length[i];
  }
  const double spacing = std::max(options.sample_spacing_m, total / std::max(options.max_samples, 1));
  std::vector<Sample> samples;
  samples.push_back({path.front().pose, 0.0, 0});
  for (std::size_t i = 1; i < path.size(); ++i) {
    const int pieces = std::max(1, static_cast<int>(std::ceil(segment_length[i] / spacing - 1e-9)));
    const double s0 = samples.back().s_m;
    for (int k = 1; k <= pieces; ++k) {
      const double f = static_cast<double>(k) / pieces;
      samples.push_back({k == pieces ? path[i].pose : pose_between(path[i - 1].pose, path[i].pose, f),
                         s0 + f * segment_length[i], k == pieces ? static_cast<long>(i) : -1});
    }
  }
  const std::size_t m_count = samples.size();

  // The path without the choice: the first pose's roll, then least joint motion.
  RollProfile profile;
  profile.samples = m_count;
  const auto first = choose_tool_roll(model, samples.front().pose, q_seed, tool_length_m);
  if (!first) return std::nullopt;
  {
    profile.min_score_free = std::numeric_limits<double>::infinity();
    Eigen::VectorXd q = first->q;
    for (std::size_t m = 0; m < m_count; ++m) {
      const auto r = inverse_kinematics(model, samples[m].pose, q, tool_length_m);
      double score = -1.0;
      if (r) {
        score = score_of(model, r->q, tool_length_m);
        q = r->q;
      }
      if (score < profile.min_score_free) {
        profile.min_score_free = score;
        profile.min_score_free_s_m = samples[m].s_m;
      }
      if (!r) break;
    }
  }

  // 2. Lanes: rolls over a full turn at the first sample, along the self-motion from the seed.
  const auto start = inverse_kinematics(model, samples.front().pose, q_seed, tool_length_m);
  if (!start) return std::nullopt;
  const int half = static_cast<int>(std::ceil(std::numbers::pi / options.grid_step_rad - 1e-9));
  const int lanes = 2 * half;  // k = -half + 1 ... half
  profile.rolls = lanes;
  const double roll0 = tool_roll_of(model, start->q);
  auto lane_roll = [&](int lane) { return roll0 + (lane - half + 1) * options.grid_step_rad; };
  std::vector<std::vector<Eigen::VectorXd>> q(m_count, std::vector<Eigen::VectorXd>(static_cast<std::size_t>(lanes)));
  std::vector<std::vector<char>> alive(m_count, std::vector<char>(static_cast<std::size_t>(lanes), 0));
  std::vector<std::vector<double>> score(m_count, std::vector<double>(static_cast<std::size_t>(lanes), -1.0));
  const int centre = half - 1;  // the lane of roll0
  {
    const auto c = inverse_kinematics_with_roll(model, samples.front().pose, roll0, start->q, tool_length_m);
    if (!c) return std::nullopt;
    q[0][static_cast<std::size_t>(centre)] = *c;
    alive[0][static_cast<std::size_t>(centre)] = 1;
    for (const int direction : {1, -1}) {
      Eigen::VectorXd from = *c;
      for (int lane = centre + direction; lane >= 0 && lane < lanes; lane += direction) {
        const ToolPose& first_pose = samples.front().pose;
        const auto solved = follow(model, first_pose, lane_roll(lane - direction), first_pose, lane_roll(lane), from,
                                   tool_length_m, options.max_joint_step_rad);
        if (!solved) break;
        from = *solved;
        q[0][static_cast<std::size_t>(lane)] = from;
        alive[0][static_cast<std::size_t>(lane)] = 1;
      }
    }
  }
  for (std::size_t m = 0; m < m_count; ++m) {
    for (int lane = 0; lane < lanes; ++lane) {
      const auto l = static_cast<std::size_t>(lane);
      if (m > 0) {
        if (!alive[m - 1][l]) continue;
        const auto solved = follow(model, samples[m - 1].pose, lane_roll(lane), samples[m].pose, lane_roll(lane),
                                   q[m - 1][l], tool_length_m, options.max_joint_step_rad);
        if (!solved) continue;
        q[m][l] = *solved;
        alive[m][l] = 1;
      }
      if (alive[m][l]) score[m][l] = score_of(model, q[m][l], tool_length_m);
    }
  }

  // 3-4. Dynamic programming.
  const double lowest = -std::numeric_limits<double>::infinity();
  auto allowed = [&](std::size_t m, int from, int to) {
    const auto f = static_cast<std::size_t>(from), t = static_cast<std::size_t>(to);
    return alive[m - 1][f] && alive[m][t] &&
           largest_joint_step(q[m][t], q[m - 1][f]) <= options.max_joint_step_rad;
  };
  // The roll changes only at stations, at least grid_step / max_roll_rate apart (samples may be
  // closer than one grid step allows): between stations each lane keeps its roll.
  const double station_spacing = options.grid_step_rad / options.max_roll_rate_rad_per_m;
  std::vector<double> since_station(m_count, 0.0);  // path length back to the previous station; 0: not a station
  {
    double last = samples.front().s_m;
    for (std::size_t m = 1; m < m_count; ++m) {
      const double gap = samples[m].s_m - last;
      if (gap >= station_spacing * (1.0 - 1e-9) || m + 1 == m_count) {
        since_station[m] = gap;
        last = samples[m].s_m;
      }
    }
  }
  auto reach = [&](std::size_t m) {
    return static_cast<int>(std::floor(options.max_roll_rate_rad_per_m * since_station[m] / options.grid_step_rad + 1e-9));
  };
  std::vector<double> best(static_cast<std::size_t>(lanes)), next(static_cast<std::size_t>(lanes));
  for (int lane = 0; lane < lanes; ++lane) {
    const auto l = static_cast<std::size_t>(lane);
    best[l] = score[0][l] >= 0.0 ? score[0][l] : lowest;
  }
  for (std::size_t m = 1; m < m_count; ++m) {
    const int r = reach(m);
    for (int to = 0; to < lanes; ++to) {
      double value = lowest;
      const auto t = static_cast<std::size_t>(to);
      if (score[m][t] >= 0.0) {
        for (int from = std::max(0, to - r); from <= std::min(lanes - 1, to + r); ++from) {
          if (best[static_cast<std::size_t>(from)] > value && allowed(m, from, to)) {
            value = best[static_cast<std::size_t>(from)];
          }
        }
        value = std::min(value, score[m][t]);
      }
      next[t] = value;
    }
    best.swap(next);
  }
  const double bottleneck = *std::max_element(best.begin(), best.end());
  if (!(bottleneck >= 0.0)) return std::nullopt;
  const double target = std::min(bottleneck, options.comfortable_score) * (1.0 - 1e-9);
  const double infinite = std::numeric_limits<double>::infinity();
  std::vector<std::vector<double>> cost(m_count, std::vector<double>(static_cast<std::size_t>(lanes), infinite));
  std::vector<std::vector<int>> previous(m_count, std::vector<int>(static_cast<std::size_t>(lanes), -1));
  auto shortfall = [&](double value) { return std::max(0.0, 1.0 - value / options.comfortable_score); };
  for (int lane = 0; lane < lanes; ++lane) {
    const auto l = static_cast<std::size_t>(lane);
    if (score[0][l] >= target) cost[0][l] = 0.0;
  }
  for (std::size_t m = 1; m < m_count; ++m) {
    const double ds = samples[m].s_m - samples[m - 1].s_m;
    const int r = reach(m);
    for (int to = 0; to < lanes; ++to) {
      const auto t = static_cast<std::size_t>(to);
      if (!(score[m][t] >= target)) continue;
      for (int from = std::max(0, to - r); from <= std::min(lanes - 1, to + r); ++from) {
        const auto f = static_cast<std::size_t>(from);
        if (cost[m - 1][f] == infinite || !allowed(m, from, to)) continue;
        const double turn = (to - from) * options.grid_step_rad;
        const double c = cost[m - 1][f] + ds * shortfall(score[m][t]) +
                         (turn != 0.0 ? options.roll_motion_weight_m_per_rad2 * turn * turn / since_station[m] : 0.0);
        if (c < cost[m][t]) {
          cost[m][t] = c;
          previous[m][t] = from;
        }
      }
    }
  }
  int lane = static_cast<int>(std::min_element(cost.back().begin(), cost.back().end()) - cost.back().begin());
  if (cost.back()[static_cast<std::size_t>(lane)] == infinite) return std::nullopt;
  // The roll at the stations (and the ends), linear in s between them: its slope stays within
  // the rate bound.
  std::vector<double> xs, ys;
  for (std::size_t m = m_count; m-- > 0;) {
    if (m == 0 || since_station[m] > 0.0) {
      xs.push_back(samples[m].s_m);
      ys.push_back(lane_roll(lane));
    }
    if (m > 0) lane = previous[m][static_cast<std::size_t>(lane)];
  }
  std::reverse(xs.begin(), xs.end());
  std::reverse(ys.begin(), ys.end());

  // 5-6. Smooth, then check every sample from its predecessor.
  const double sigma = options.smoothing_length_m;
  profile.min_score = infinite;
  profile.roll_min_rad = infinite;
  profile.roll_max_rad = -infinite;
  profile.roll_rad.assign(path.size(), 0.0);
  Eigen::VectorXd q_now = q[0][static_cast<std::size_t>(lane)];
  double roll_before = 0.0;
  for (std::size_t m = 0; m < m_count; ++m) {
    const double roll = smoothed(xs, ys, samples[m].s_m, sigma);
    const auto solved = m == 0 ? inverse_kinematics_with_roll(model, samples[m].pose, roll, q_now, tool_length_m)
                               : follow(model, samples[m - 1].pose, roll_before, samples[m].pose, roll, q_now,
                                        tool_length_m, options.max_joint_step_rad);
    if (!solved || (m == 0 && largest_joint_step(*solved, q_now) > options.max_joint_step_rad)) return std::nullopt;
    const double value = score_of(model, *solved, tool_length_m);
    if (value < 0.0) return std::nullopt;
    q_now = *solved;
    if (m == 0) profile.q_start = q_now;
    if (value < profile.min_score) {
      profile.min_score = value;
      profile.min_score_s_m = samples[m].s_m;
    }
    profile.roll_min_rad = std::min(profile.roll_min_rad, roll);
    profile.roll_max_rad = std::max(profile.roll_max_rad, roll);
    if (m > 0) {
      const double ds = samples[m].s_m - samples[m - 1].s_m;
      if (ds > 0.0) profile.max_rate_rad_per_m = std::max(profile.max_rate_rad_per_m, std::abs(roll - roll_before) / ds);
    }
    roll_before = roll;
    if (samples[m].point >= 0) profile.roll_rad[static_cast<std::size_t>(samples[m].point)] = roll;
  }
  return profile;
}

}  // namespace vmsim::kinematics
