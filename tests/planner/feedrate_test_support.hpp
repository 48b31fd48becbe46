#pragma once
// Shared helpers of the feedrate tests: synthetic paths, and an independent check of the set
// points by finite differences (written here, not taken from the planner).
#include <Eigen/Core>
#include <cmath>
#include <functional>
#include <string>
#include <vector>

#include "vmsim/kinematics/dynamics.hpp"
#include "vmsim/kinematics/machine_loader.hpp"
#include "vmsim/kinematics/machine_model.hpp"
#include "vmsim/kinematics/path_kinematics.hpp"
#include "vmsim/planner/feedrate.hpp"
#include "vmsim/toolpath/toolpath.hpp"

namespace vmsim::planner::test {

/// A machine and a path solved on it.
struct Sample {
  kinematics::MachineModel machine;
  kinematics::PathKinematics path;
};

/// Sample path 1's cut (without its rapid approach and retract) on samples/machines/
/// `machine_file`, tool length 60 mm.
inline Sample path1_on(const std::string& machine_file) {
  Sample out;
  const std::string root = VMSIM_SOURCE_DIR;
  out.machine = kinematics::load_machine(root + "/samples/machines/" + machine_file);
  const toolpath::Toolpath tp = toolpath::read_apt(root + "/samples/parts/path1_yz/toolpath.apt");
  std::vector<kinematics::PathPose> poses;
  for (const auto& p : tp.points) {
    if (p.kind == toolpath::MotionKind::rapid) continue;
    if (!poses.empty() && (poses.back().pose.tip_W_m - p.tip_W_m).norm() < 1e-12) continue;
    poses.push_back({{p.tip_W_m, p.axis_W}, p.block});
  }
  poses.erase(poses.begin());  // the first cut point is the end of the approach
  out.path = kinematics::solve_path_kinematics(out.machine, poses, out.machine.home_positions(), 0.060, {});
  return out;
}

/// Path 1 on the Mikron sample, solved once per test program.
inline const Sample& mikron_path1() {
  static const Sample sample = path1_on("mikron_ucp710.yaml");
  return sample;
}

/// q(s) and its first three derivatives for every axis at s.
using PathFunction = std::function<void(double s, Eigen::VectorXd& q, Eigen::VectorXd& q_s,
                                        Eigen::VectorXd& q_ss, Eigen::VectorXd& q_sss)>;

inline kinematics::PathKinematics sample_path(int axes, double length_m, std::size_t points,
                                              const PathFunction& f) {
  kinematics::PathKinematics path;
  path.q = Eigen::MatrixXd::Zero(axes, static_cast<Eigen::Index>(points));
  path.q_s = path.q_ss = path.q_sss = path.q;
  Eigen::VectorXd q(axes), q_s(axes), q_ss(axes), q_sss(axes);
  for (std::size_t i = 0; i < points; ++i) {
    const double s = length_m * static_cast<double>(i) / static_cast<double>(points - 1);
    f(s, q, q_s, q_ss, q_sss);
    path.s_m.push_back(s);
    const auto c = static_cast<Eigen::Index>(i);
    path.q.col(c) = q;
    path.q_s.col(c) = q_s;
    path.q_ss.col(c) = q_ss;
    path.q_sss.col(c) = q_sss;
  }
  return path;
}

/// Largest |derivative| / limit over the set points, per axis, from finite differences at the
/// period with the motion held at rest outside the samples: velocity (q_k - q_{k-1}) / T,
/// acceleration (q_{k+1} - 2 q_k + q_{k-1}) / T^2, jerk (q_{k+1} - 3 q_k + 3 q_{k-1} - q_{k-2}) /
/// T^3. Each is a B-spline-weighted mean of the continuous derivative over 1, 2, 3 periods, so
/// it never exceeds the continuous maximum: the comparison needs no tolerance beyond rounding.
struct FiniteDifferenceRatios {
  double velocity = 0, acceleration = 0, jerk = 0;
};
inline FiniteDifferenceRatios finite_difference_ratios(const SetPoints& sp,
                                                       const std::vector<AxisLimitValues>& limits) {
  FiniteDifferenceRatios out;
  const long n = static_cast<long>(sp.t_s.size());
  const double T = sp.period_s;
  auto q = [&](long k, Eigen::Index j) {
    k = k < 0 ? 0 : (k >= n ? n - 1 : k);
    return sp.q(j, static_cast<Eigen::Index>(k));
  };
  for (Eigen::Index j = 0; j < sp.q.rows(); ++j) {
    const auto& l = limits[static_cast<std::size_t>(j)];
    for (long k = -2; k < n + 2; ++k) {
      const double v = (q(k, j) - q(k - 1, j)) / T;
      const double a = (q(k + 1, j) - 2 * q(k, j) + q(k - 1, j)) / (T * T);
      const double jk = (q(k + 1, j) - 3 * q(k, j) + 3 * q(k - 1, j) - q(k - 2, j)) / (T * T * T);
      if (l.velocity > 0) out.velocity = std::max(out.velocity, std::abs(v) / l.velocity);
      if (l.acceleration > 0) out.acceleration = std::max(out.acceleration, std::abs(a) / l.acceleration);
      if (l.jerk > 0) out.jerk = std::max(out.jerk, std::abs(jk) / l.jerk);
    }
  }
  return out;
}

}  // namespace vmsim::planner::test
