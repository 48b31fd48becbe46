// Axis positions along a path and their derivatives w.r.t. arc length: continuity through the
// table-table singularity, rotary unwrapping over several turns, q_s / q_ss / q_sss against a
// Richardson-extrapolated finite-difference reference of the IKT of the continuous curve,
// corners, stationary tips, dense rounded polylines, unreachable poses naming their block.
#include <gtest/gtest.h>

#include <cmath>
#include <array>
#include <functional>
#include <limits>
#include <numbers>

#include "vmsim/common/errors.hpp"
#include "vmsim/kinematics/path_kinematics.hpp"
#include "vmsim/kinematics/sample_models.hpp"

namespace vk = vmsim::kinematics;

namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kToolLength = 0.1;

using PoseOfArc = std::function<vk::ToolPose(double)>;

double axis_angle(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b));
}

std::vector<vk::PathPose> sample(const PoseOfArc& pose, double length_m, int segments) {
  std::vector<vk::PathPose> path;
  for (int i = 0; i <= segments; ++i) {
    path.push_back({pose(length_m * i / segments), i / 10});
  }
  return path;
}

/// A helix of radius R and lead 2 pi b in W, parameterised by its arc length sigma, with a tool
/// axis whose tilt and azimuth vary smoothly (length scales 30 mm and 50 mm).
PoseOfArc table_table_helix() {
  return [](double sigma) {
    const double R = 0.03, b = 0.01, c = std::hypot(R, b);
    vk::ToolPose p;
    p.tip_W_m = Eigen::Vector3d(R * std::cos(sigma / c), R * std::sin(sigma / c), 0.02 + b * sigma / c);
    const double alpha = 0.35 + 0.15 * std::sin(sigma / 0.03);
    const double beta = 0.6 + sigma / 0.05;
    p.axis_W = Eigen::Vector3d(std::sin(alpha) * std::cos(beta), std::sin(alpha) * std::sin(beta),
                               std::cos(alpha));
    return p;
  };
}

/// The same kind of curve near the robot's home pose.
PoseOfArc robot_helix(const vk::MachineModel& robot) {
  const vk::ToolPose home = vk::forward_kinematics(robot, robot.home_positions(), kToolLength);
  return [home](double sigma) {
    const double R = 0.05, b = 0.015, c = std::hypot(R, b);
    vk::ToolPose p;
    p.tip_W_m = home.tip_W_m +
                Eigen::Vector3d(R * std::cos(sigma / c) - R, R * std::sin(sigma / c), b * sigma / c);
    p.axis_W = Eigen::AngleAxisd(0.2 * std::sin(sigma / 0.04), Eigen::Vector3d::UnitX()) *
               (Eigen::AngleAxisd(1.5 * sigma, Eigen::Vector3d::UnitY()) * home.axis_W);
    return p;
  };
}

struct Reference {
  Eigen::VectorXd q_s, q_ss, q_sss;
};

/// Derivatives of sigma -> IKT(pose(sigma)) at sigma by central differences with step d and
/// d / 2, Richardson-extrapolated (error O(d^4)); IKT seeded with q_seed for continuity.
Reference reference_derivatives(const vk::MachineModel& model, const PoseOfArc& pose, double sigma,
                                const Eigen::VectorXd& q_seed, double d) {
  auto q = [&](double x) {
    const auto r = vk::inverse_kinematics(model, pose(x), q_seed, kToolLength);
    EXPECT_TRUE(r.has_value());
    return r ? r->q : q_seed;
  };
  auto differences = [&](double h) {
    const Eigen::VectorXd m2 = q(sigma - 2 * h), m1 = q(sigma - h), z = q(sigma), p1 = q(sigma + h),
                          p2 = q(sigma + 2 * h);
    return Reference{(p1 - m1) / (2 * h), (p1 - 2 * z + m1) / (h * h),
                     (p2 - 2 * p1 + 2 * m1 - m2) / (2 * h * h * h)};
  };
  const Reference coarse = differences(d);
  const Reference fine = differences(d / 2);
  return {(4 * fine.q_s - coarse.q_s) / 3, (4 * fine.q_ss - coarse.q_ss) / 3,
          (4 * fine.q_sss - coarse.q_sss) / 3};
}

struct DerivativeErrors {
  // Largest error of each derivative over the points, relative to the scale of that axis's
  // derivative along the path: max(max |reference|, max |q_s| / l^(k-1)) with l = 30 mm the
  // curve's length scale (an axis linear in s, like C here, has q_ss = q_sss = 0).
  double interior[3] = {0, 0, 0};
  double ends[3] = {0, 0, 0};
};

DerivativeErrors compare_with_reference(const vk::MachineModel& model, const PoseOfArc& pose,
                                        double length_m, int segments,
                                        const vk::PathKinematicsOptions& options, double d) {
  const auto path = sample(pose, length_m, segments);
  const vk::PathKinematics pk =
      vk::solve_path_kinematics(model, path, model.home_positions(), kToolLength, {}, options);
  EXPECT_TRUE(pk.corners.empty());
  const Eigen::Index axes = pk.q.rows();
  const auto n = static_cast<Eigen::Index>(path.size());
  Eigen::MatrixXd ref[3] = {Eigen::MatrixXd(axes, n), Eigen::MatrixXd(axes, n),
                            Eigen::MatrixXd(axes, n)};
  for (Eigen::Index i = 0; i < n; ++i) {
    const double sigma = length_m * static_cast<double>(i) / segments;
    const Reference r = reference_derivatives(model, pose, sigma, pk.q.col(i), d);
    ref[0].col(i) = r.q_s;
    ref[1].col(i) = r.q_ss;
    ref[2].col(i) = r.q_sss;
  }
  const Eigen::MatrixXd* got[3] = {&pk.q_s, &pk.q_ss, &pk.q_sss};
  DerivativeErrors errors;
  const Eigen::Index edge = 3;  // points whose window is one-sided
  const double l = 0.03;
  for (int k = 0; k < 3; ++k) {
    for (Eigen::Index j = 0; j < axes; ++j) {
      const double magnitude = std::max(ref[k].row(j).cwiseAbs().maxCoeff(),
                                        ref[0].row(j).cwiseAbs().maxCoeff() / std::pow(l, k));
      if (magnitude < 1e-9) continue;  // an axis that does not move
      for (Eigen::Index i = 0; i < n; ++i) {
        const double e = std::abs((*got[k])(j, i) - ref[k](j, i)) / magnitude;
        double& slot = (i < edge || i >= n - edge) ? errors.ends[k] : errors.interior[k];
        slot = std::max(slot, e);
      }
    }
  }
  return errors;
}

}  // namespace

TEST(PathKinematics, SingularSweepKeepsCAndPassesAThroughZero) {
  const vk::MachineModel model = vk::make_table_table_sample();
  const double azimuth = 0.7;
  std::vector<vk::PathPose> path;
  for (int i = -100; i <= 100; ++i) {
    const double t = i / 100.0;
    vk::ToolPose p;
    p.tip_W_m = Eigen::Vector3d(0.02 + 0.05 * t, -0.01, 0.03);
    p.axis_W = Eigen::Vector3d(std::sin(0.3 * t) * std::cos(azimuth),
                               std::sin(0.3 * t) * std::sin(azimuth), std::cos(0.3 * t));
    path.push_back({p, 0});
  }
  const vk::PathKinematics pk =
      vk::solve_path_kinematics(model, path, model.home_positions(), kToolLength, {"N1"});
  const Eigen::Index n = pk.q.cols();
  for (Eigen::Index i = 0; i < n; ++i) {
    EXPECT_NEAR(pk.q(4, i), pk.q(4, 0), 1e-9) << "C moved at point " << i;  // C does not spin
    const vk::ToolPose back = vk::forward_kinematics(model, pk.q.col(i), kToolLength);
    EXPECT_LT((back.tip_W_m - path[static_cast<std::size_t>(i)].pose.tip_W_m).norm(), 1e-9);
    EXPECT_LT(axis_angle(back.axis_W, path[static_cast<std::size_t>(i)].pose.axis_W), 1e-9);
  }
  // A = +-0.3 t: linear in the point index, changing sign at the pole.
  EXPECT_LT(pk.q(3, 0) * pk.q(3, n - 1), 0.0);
  EXPECT_NEAR(std::abs(pk.q(3, 0)), 0.3, 1e-9);
  for (Eigen::Index i = 2; i < n; ++i) {
    EXPECT_NEAR(pk.q(3, i) - 2 * pk.q(3, i - 1) + pk.q(3, i - 2), 0.0, 1e-9) << "point " << i;
  }
  // The zone: only the pole itself (the neighbours are 3 mrad away, beyond 1 mrad).
  ASSERT_EQ(pk.singular_zones.size(), 1u);
  EXPECT_EQ(pk.singular_zones[0].first_point, 100u);
  EXPECT_EQ(pk.singular_zones[0].last_point, 100u);
  EXPECT_DOUBLE_EQ(pk.singular_zones[0].s_begin_m, pk.s_m[100]);
  // The derivatives of A through the pole are those of a straight line.
  EXPECT_NEAR(std::abs(pk.q_s(3, 100)) * 0.05 * 2.0 / 0.6, 1.0, 1e-6);
  EXPECT_NEAR(pk.q_ss(3, 100), 0.0, 1e-6);
}

TEST(PathKinematics, NearMissOfThePoleHoldsCInsideTheZone) {
  const vk::MachineModel model = vk::make_table_table_sample();
  const double miss = 0.5e-3;  // rad, inside the 1 mrad zone
  std::vector<vk::PathPose> path;
  for (int i = -200; i <= 200; ++i) {
    const double t = i / 200.0 * 0.004;  // the tilt sweeps +-4 mrad past the pole
    vk::ToolPose p;
    p.tip_W_m = Eigen::Vector3d(0.01 + t, 0.0, 0.03);
    p.axis_W = Eigen::Vector3d(t, miss, 1.0).normalized();
    path.push_back({p, 0});
  }
  vk::PathKinematicsOptions options;
  const vk::PathKinematics pk =
      vk::solve_path_kinematics(model, path, model.home_positions(), kToolLength, {}, options);
  ASSERT_EQ(pk.singular_zones.size(), 1u);
  const auto& zone = pk.singular_zones[0];
  EXPECT_GT(zone.last_point, zone.first_point + 10);
  for (std::size_t i = zone.first_point; i <= zone.last_point; ++i) {
    const auto c = static_cast<Eigen::Index>(i);
    EXPECT_EQ(pk.q(4, c), pk.q(4, static_cast<Eigen::Index>(zone.first_point) - 1));  // held
    const vk::ToolPose back = vk::forward_kinematics(model, pk.q.col(c), kToolLength);
    EXPECT_LT((back.tip_W_m - path[i].pose.tip_W_m).norm(), 1e-9);
    EXPECT_LT(axis_angle(back.axis_W, path[i].pose.axis_W), 2 * options.inverse.singular_angle_rad);
  }
  for (std::size_t i = 0; i < path.size(); ++i) {  // outside the zone: exact
    if (i >= zone.first_point && i <= zone.last_point) continue;
    const vk::ToolPose back =
        vk::forward_kinematics(model, pk.q.col(static_cast<Eigen::Index>(i)), kToolLength);
    EXPECT_LT(axis_angle(back.axis_W, path[i].pose.axis_W), 1e-9);
  }
}

TEST(PathKinematics, RotaryAxisUnwrappedOverThreeTurns) {
  const vk::MachineModel model = vk::make_table_table_sample();
  std::vector<vk::PathPose> path;
  const int n = 600;
  for (int i = 0; i <= n; ++i) {
    const double psi = 6.0 * kPi * i / n;
    vk::ToolPose p;
    p.tip_W_m = Eigen::Vector3d(0.03 * std::cos(psi), 0.03 * std::sin(psi), 0.02 + 0.01 * i / n);
    p.axis_W = Eigen::Vector3d(std::sin(0.5) * std::cos(psi), std::sin(0.5) * std::sin(psi),
                               std::cos(0.5));
    path.push_back({p, 0});
  }
  const vk::PathKinematics pk =
      vk::solve_path_kinematics(model, path, model.home_positions(), kToolLength, {});
  double sign = 0.0;
  for (Eigen::Index i = 1; i <= n; ++i) {
    const double step = pk.q(4, i) - pk.q(4, i - 1);
    if (i == 1) sign = step > 0 ? 1.0 : -1.0;
    EXPECT_GT(sign * step, 0.0) << "C not monotone at point " << i;
    EXPECT_NEAR(std::abs(step), 6.0 * kPi / n, 1e-9) << "C jumps at point " << i;
  }
  EXPECT_NEAR(std::abs(pk.q(4, n) - pk.q(4, 0)), 6.0 * kPi, 1e-9);
  for (Eigen::Index i = 0; i <= n; ++i) EXPECT_NEAR(pk.q(3, i), pk.q(3, 0), 1e-9);  // A still
}

// The derivatives of the sampled path against the Richardson reference (finite-difference
// step 2 mm and 1 mm, error O(d^4) ~ 1e-5 relative). Expected errors of the sampled estimate,
// both O(h^2): (1) s is the chord length, not the arc length: q_s is off by kappa^2 h^2 / 24
// (kappa = 30 /m on the table-table helix: 3.8e-5 at h = 1 mm), q_ss and q_sss by 2x and 3x
// that; (2) the fit of a degree-4 polynomial over 7 points: O((h / l)^2) with l ~ 30 mm the
// curve's length scale, with a constant of order 0.1-1 for q_sss, larger one-sided (the three
// points at each end). Measured at h = 1 mm: q_s 3.8e-5, q_ss 7.5e-5 (ends 1.3e-4), q_sss 8.3e-4
// (ends 5.1e-3); the tolerances below give a factor of about 3, and the halving of h must
// divide the errors by about 4.
void expect_derivative_accuracy(const DerivativeErrors& coarse, const DerivativeErrors& fine) {
  const double interior_tolerance[3] = {1e-4, 3e-4, 3e-3};
  const double end_tolerance[3] = {1e-4, 5e-4, 2e-2};
  for (int k = 0; k < 3; ++k) {
    EXPECT_LT(coarse.interior[k], interior_tolerance[k]) << "derivative order " << k + 1;
    EXPECT_LT(coarse.ends[k], end_tolerance[k]) << "derivative order " << k + 1;
    EXPECT_LT(fine.interior[k], 0.35 * coarse.interior[k]) << "not O(h^2), order " << k + 1;
    EXPECT_LT(fine.ends[k], 0.35 * coarse.ends[k]) << "not O(h^2), order " << k + 1;
  }
}

TEST(PathKinematics, DerivativesMatchRichardsonReferenceTableTable) {
  const vk::MachineModel model = vk::make_table_table_sample();
  vk::PathKinematicsOptions options;
  options.fit_half_window_m = 0.0;  // 7-point windows: the estimator's own O(h^2)
  const DerivativeErrors coarse =
      compare_with_reference(model, table_table_helix(), 0.12, 120, options, 2e-3);  // h = 1 mm
  const DerivativeErrors fine =
      compare_with_reference(model, table_table_helix(), 0.12, 240, options, 2e-3);  // h = 0.5 mm
  expect_derivative_accuracy(coarse, fine);
}

TEST(PathKinematics, DerivativesMatchRichardsonReferenceRobot) {
  // The robot's IKT is iterative (1e-12 m): the reference's rounding is ~1e-12 / d^3 ~ 1e-3
  // absolute, far below the q_sss values (~1e2 rad/m^3).
  const vk::MachineModel robot = vk::make_robot_sample();
  vk::PathKinematicsOptions options;
  options.fit_half_window_m = 0.0;
  const DerivativeErrors coarse =
      compare_with_reference(robot, robot_helix(robot), 0.15, 150, options, 2e-3);
  const DerivativeErrors fine =
      compare_with_reference(robot, robot_helix(robot), 0.15, 300, options, 2e-3);
  expect_derivative_accuracy(coarse, fine);
}

TEST(PathKinematics, DensePolylineWithRoundedCoordinatesGivesSmoothedDerivatives) {
  // A CAM-style polyline: the helix every 0.02 mm, tips rounded to 1 um and axis components to
  // 1e-6, as in an ISO file. With the default +-1 mm fit window the derivatives are those of the
  // curve smoothed over ~4 mm: errors of order e / L^k (L = 2 mm, e ~ 0.3 um) plus the fit bias
  // (L / l)^2 ~ 5e-3, not e / h^k.
  const vk::MachineModel model = vk::make_table_table_sample();
  const PoseOfArc exact = table_table_helix();
  const PoseOfArc rounded = [&](double sigma) {
    vk::ToolPose p = exact(sigma);
    for (int i = 0; i < 3; ++i) {
      p.tip_W_m[i] = std::round(p.tip_W_m[i] * 1e6) / 1e6;
      p.axis_W[i] = std::round(p.axis_W[i] * 1e6) / 1e6;
    }
    return p;
  };
  const double length = 0.03;
  const int segments = 1500;
  auto max_error = [&](const vk::PathKinematicsOptions& options) {
    const auto path = sample(rounded, length, segments);
    const vk::PathKinematics pk =
        vk::solve_path_kinematics(model, path, model.home_positions(), kToolLength, {}, options);
    // The rounding turns the 20 um chords by up to some degrees; the secant test over the fit
    // window keeps that from being taken for corners.
    if (options.fit_half_window_m > 0.0) {
      EXPECT_TRUE(pk.corners.empty());
    }
    std::array<double, 3> worst{0, 0, 0};
    // Linear axes X Y Z, points away from the ends, every 25th.
    for (int i = 100; i <= segments - 100; i += 25) {
      const auto c = static_cast<Eigen::Index>(i);
      const Reference r = reference_derivatives(model, exact, length * i / segments, pk.q.col(c), 2e-3);
      worst[0] = std::max(worst[0], (pk.q_s.col(c).head<3>() - r.q_s.head<3>()).cwiseAbs().maxCoeff());
      worst[1] = std::max(worst[1], (pk.q_ss.col(c).head<3>() - r.q_ss.head<3>()).cwiseAbs().maxCoeff());
      worst[2] = std::max(worst[2], (pk.q_sss.col(c).head<3>() - r.q_sss.head<3>()).cwiseAbs().maxCoeff());
    }
    return worst;
  };
  const std::array<double, 3> smoothed = max_error({});
  // Scales of the linear axes on this helix: q_s ~ 1, q_ss ~ 35 /m, q_sss ~ 1.2e3 /m^2.
  // Measured with the default 2 mm half window: 3.6e-4, 0.33 (1 %), 245 (20 %): q_sss is only
  // right in magnitude on such data (1 mm: 2.7e3; 4 mm: 96).
  EXPECT_LT(smoothed[0], 1e-3);
  EXPECT_LT(smoothed[1], 1.0);
  EXPECT_LT(smoothed[2], 500.0);
  // Without the smoothing length (7-point windows over 0.12 mm), the rounding dominates: this is
  // the garbage the window length prevents.
  vk::PathKinematicsOptions raw;
  raw.fit_half_window_m = 0.0;
  const std::array<double, 3> unsmoothed = max_error(raw);
  EXPECT_GT(unsmoothed[2], 100.0 * smoothed[2]);
}

TEST(PathKinematics, CornerReportedAndNotDifferentiatedAcross) {
  const vk::MachineModel model = vk::make_table_table_sample();
  const Eigen::Vector3d axis = Eigen::Vector3d(std::sin(0.4), 0.0, std::cos(0.4));
  std::vector<vk::PathPose> path;
  for (int i = 0; i <= 20; ++i) path.push_back({{Eigen::Vector3d(-0.02 + 0.001 * i, 0.0, 0.03), axis}, 0});
  for (int i = 1; i <= 20; ++i) path.push_back({{Eigen::Vector3d(0.0, 0.001 * i, 0.03), axis}, 1});
  const vk::PathKinematics pk =
      vk::solve_path_kinematics(model, path, model.home_positions(), kToolLength, {});
  ASSERT_EQ(pk.corners.size(), 1u);
  EXPECT_EQ(pk.corners[0].point, 20u);
  EXPECT_NEAR(pk.corners[0].angle_rad, kPi / 2, 1e-12);
  EXPECT_NEAR(pk.corners[0].s_m, 0.02, 1e-12);
  // Rotary axes stand still; the linear axes are linear in s on each leg, so every point of a
  // leg, including those next to the corner, has that leg's slope and no curvature.
  const Eigen::VectorXd slope_in = (pk.q.col(20) - pk.q.col(0)) / 0.02;
  const Eigen::VectorXd slope_out = (pk.q.col(40) - pk.q.col(20)) / 0.02;
  for (Eigen::Index i = 0; i <= 40; ++i) {
    const Eigen::VectorXd& expected = i < 20 ? slope_in : slope_out;  // the corner: outgoing
    EXPECT_LT((pk.q_s.col(i) - expected).cwiseAbs().maxCoeff(), 1e-9) << "point " << i;
    EXPECT_LT(pk.q_ss.col(i).cwiseAbs().maxCoeff(), 1e-6) << "point " << i;
    EXPECT_LT(pk.q_sss.col(i).cwiseAbs().maxCoeff(), 1e-3) << "point " << i;
  }
  EXPECT_GT((slope_in - slope_out).norm(), 0.5);
}

TEST(PathKinematics, StationaryTipIsAReorientationStretchParametrisedByTheRotaryMotion) {
  // A pure reorientation (the tip stands still between points 10 and 11, the tool tilts from
  // 0.3 to 0.35 rad) has no tip arc length: it is a stretch of its own (corners at 10 and 11)
  // whose s counts kReorientationLever_m per rad of rotary motion: 0.1 m * 0.05 rad (only the
  // tilting axis moves: the tilt stays in one plane). Before, the stationary tip was a single
  // cut and the planner refused the zero-length segment.
  const vk::MachineModel model = vk::make_table_table_sample();
  std::vector<vk::PathPose> path;
  for (int i = 0; i <= 20; ++i) {
    const double x = 0.001 * (i <= 10 ? i : i - 1);
    const double tilt = i <= 10 ? 0.3 : 0.35;
    path.push_back({{Eigen::Vector3d(x, 0.0, 0.03), Eigen::Vector3d(std::sin(tilt), 0, std::cos(tilt))}, 0});
  }
  const vk::PathKinematics pk =
      vk::solve_path_kinematics(model, path, model.home_positions(), kToolLength, {});
  ASSERT_EQ(pk.corners.size(), 2u);
  EXPECT_EQ(pk.corners[0].point, 10u);
  EXPECT_EQ(pk.corners[1].point, 11u);
  EXPECT_NEAR(pk.s_m[11] - pk.s_m[10], vk::kReorientationLever_m * 0.05, 1e-12);
  EXPECT_NEAR(pk.s_m[10], 0.010, 1e-12);
  ASSERT_EQ(pk.turns_in_place.size(), path.size());
  for (std::size_t i = 0; i < path.size(); ++i) EXPECT_EQ(pk.turns_in_place[i], i == 11) << i;
  EXPECT_TRUE(pk.q_s.allFinite() && pk.q_ss.allFinite() && pk.q_sss.allFinite());
  EXPECT_LT(pk.q_s.row(3).segment(0, 10).cwiseAbs().maxCoeff(), 1e-9);  // A constant before
  EXPECT_LT(pk.q_s.row(3).segment(11, 10).cwiseAbs().maxCoeff(), 1e-9);  // and after
  // On the turn A moves 0.05 rad over 0.005 m of s.
  EXPECT_NEAR(std::abs(pk.q_s(3, 10)), 10.0, 1e-9);
}

TEST(PathKinematics, UnreachablePoseNamesPointAndBlock) {
  const vk::MachineModel model = vk::make_table_table_sample();
  std::vector<vk::PathPose> path;
  for (int i = 0; i < 10; ++i) {
    path.push_back({{Eigen::Vector3d(0.001 * i, 0, 0.03), Eigen::Vector3d::UnitZ()}, i / 4});
  }
  path[7].pose.axis_W = Eigen::Vector3d(0.0, std::sin(2.5), std::cos(2.5));  // A = 143 deg
  try {
    vk::solve_path_kinematics(model, path, model.home_positions(), kToolLength, {"N10", "N20", "N30"});
    FAIL() << "no error";
  } catch (const vmsim::InfeasibleError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("point 7"), std::string::npos) << message;
    EXPECT_NE(message.find("N20"), std::string::npos) << message;
    EXPECT_NE(message.find("axis A"), std::string::npos) << message;
  }
  // Without names, the block number.
  try {
    vk::solve_path_kinematics(model, path, model.home_positions(), kToolLength, {});
    FAIL() << "no error";
  } catch (const vmsim::InfeasibleError& e) {
    EXPECT_NE(std::string(e.what()).find("block #1"), std::string::npos) << e.what();
  }
}

TEST(PathKinematics, RobotPathFromHomeToAFarFirstPose) {
  const vk::MachineModel robot = vk::make_robot_sample();
  const PoseOfArc helix = robot_helix(robot);
  // The path starts 0.3 m and some 17 degrees away from the home pose.
  const PoseOfArc shifted = [&](double sigma) {
    vk::ToolPose p = helix(sigma);
    p.tip_W_m += Eigen::Vector3d(-0.2, 0.15, -0.15);
    p.axis_W = Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitY()) * p.axis_W;
    return p;
  };
  const auto path = sample(shifted, 0.1, 100);
  const vk::PathKinematics pk =
      vk::solve_path_kinematics(robot, path, robot.home_positions(), kToolLength, {});
  for (std::size_t i = 0; i < path.size(); ++i) {
    const vk::ToolPose back =
        vk::forward_kinematics(robot, pk.q.col(static_cast<Eigen::Index>(i)), kToolLength);
    EXPECT_LT((back.tip_W_m - path[i].pose.tip_W_m).norm(), 1e-11);
    EXPECT_LT(axis_angle(back.axis_W, path[i].pose.axis_W), 1e-11);
  }
  // Continuity: consecutive points 1 mm apart move the joints by little.
  for (Eigen::Index i = 1; i < pk.q.cols(); ++i) {
    EXPECT_LT((pk.q.col(i) - pk.q.col(i - 1)).cwiseAbs().maxCoeff(), 0.02) << "point " << i;
  }
}

// A tool change to a tool 35 mm longer (PathPose::tool_length_m) at the same programmed tip: the
// axes lift the spindle by 35 mm (a real motion of 35 mm of s, from the new tool's tip at the old
// axes), each pose's direct kinematics with its own tool gives its tip, and the point before the
// change is a corner (the change is at rest).
TEST(PathKinematics, EachPoseIsSolvedWithItsOwnToolAndTheChangeIsACorner) {
  const vk::MachineModel m = vk::make_table_table_sample();
  const double short_m = 0.06, long_m = 0.095;
  Eigen::VectorXd q_ref = m.home_positions();
  q_ref[2] = -0.2;  // Z well inside its travel
  const vk::ToolPose start = vk::forward_kinematics(m, q_ref, short_m);
  const Eigen::Vector3d x(0.01, 0.0, 0.0);
  std::vector<vk::PathPose> path(4);
  path[0].pose = start;
  path[1].pose = {start.tip_W_m + x, start.axis_W};
  path[2].pose = {start.tip_W_m + x, start.axis_W};
  path[2].tool_length_m = long_m;
  path[3].pose = {start.tip_W_m + 2.0 * x, start.axis_W};
  path[3].tool_length_m = long_m;
  const vk::PathKinematics pk = vk::solve_path_kinematics(m, path, q_ref, short_m, {});
  const double lengths[] = {short_m, short_m, long_m, long_m};
  for (std::size_t i = 0; i < 4; ++i) {
    const Eigen::Vector3d tip = vk::forward_kinematics(m, pk.q.col(static_cast<Eigen::Index>(i)), lengths[i]).tip_W_m;
    EXPECT_LT((tip - path[i].pose.tip_W_m).norm(), 1e-9) << i;
    EXPECT_DOUBLE_EQ(pk.length_into(i), lengths[i]);
  }
  // The spindle 35 mm higher: the short tool's tip at the new axes is 35 mm above the program.
  const Eigen::Vector3d lifted = vk::forward_kinematics(m, pk.q.col(2), short_m).tip_W_m;
  EXPECT_LT((lifted - (path[2].pose.tip_W_m + 0.035 * start.axis_W)).norm(), 1e-9);
  EXPECT_NEAR(pk.s_m[1], 0.01, 1e-12);
  EXPECT_NEAR(pk.s_m[2] - pk.s_m[1], 0.035, 1e-12);
  EXPECT_NEAR(pk.s_m[3] - pk.s_m[2], 0.01, 1e-12);
  bool corner_at_change = false;
  for (const auto& corner : pk.corners) corner_at_change = corner_at_change || corner.point == 1;
  EXPECT_TRUE(corner_at_change);
  // One length everywhere: no per-point lengths.
  for (auto& pose : path) pose.tool_length_m = std::numeric_limits<double>::quiet_NaN();
  path[2].pose.tip_W_m += 0.035 * start.axis_W;  // the same axes with the short tool
  path[3].pose.tip_W_m += 0.035 * start.axis_W;
  const vk::PathKinematics one = vk::solve_path_kinematics(m, path, q_ref, short_m, {});
  EXPECT_TRUE(one.point_tool_length_m.empty());
  EXPECT_LT((one.q - pk.q).cwiseAbs().maxCoeff(), 1e-9);
}
