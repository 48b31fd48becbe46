// The free rotation about a robot's tool axis: the chosen roll reaches the same tool pose and
// moves the arm away from a joint limit the nearest solution sits at.
#include <gtest/gtest.h>

#include <cmath>
#include <Eigen/SVD>
#include <iostream>
#include <numbers>

#include "vmsim/kinematics/kinematics.hpp"
#include "vmsim/kinematics/redundancy.hpp"
#include "vmsim/kinematics/sample_models.hpp"

namespace vmsim::kinematics {
namespace {

TEST(Redundancy, ToolRollKeepsThePoseAndLeavesAJointLimit) {
  const MachineModel robot = make_robot_sample();
  const double tool = 0.1, deg = std::numbers::pi / 180.0;
  // q6 at 5 deg from its travel end: the tool roll is free to take the arm away from it.
  Eigen::VectorXd q(6);
  q << 5 * deg, 20 * deg, 15 * deg, 10 * deg, 50 * deg, robot.axes[5].travel_max - 5 * deg;
  const ToolPose pose = forward_kinematics(robot, q, tool);
  const RedundancyMargins before = redundancy_margins(robot, q, tool);
  const auto choice = choose_tool_roll(robot, pose, q, tool);
  ASSERT_TRUE(choice.has_value());
  const ToolPose reached = forward_kinematics(robot, choice->q, tool);
  EXPECT_LT((reached.tip_W_m - pose.tip_W_m).norm(), 1e-9);
  EXPECT_LT((reached.axis_W - pose.axis_W).norm(), 1e-9);
  EXPECT_TRUE(within_travel(robot, choice->q));
  // Hand computation of the seed's margin: 5 deg of the 700 deg travel of q6.
  const double range = robot.axes[5].travel_max - robot.axes[5].travel_min;
  EXPECT_NEAR(before.travel_margin, 5 * deg / range, 1e-9);
  EXPECT_GT(choice->margins.score(), 2.0 * before.score());
  EXPECT_GT(choice->rolls_solved, 10);
  // The margins reported are those of the configuration returned.
  EXPECT_DOUBLE_EQ(choice->margins.score(), redundancy_margins(robot, choice->q, tool).score());
}

}  // namespace
}  // namespace vmsim::kinematics

namespace vmsim::kinematics {
namespace {

/// The robot sample with its spindle on a bracket, the tool axis at right angles to the flange
/// (along its z, 150 mm off the q6 axis), as milling robots often carry it: a roll about the
/// tool axis then moves every joint (with the tool along the q6 axis it would turn q6 alone).
MachineModel robot_with_bracket_spindle() {
  MachineModel robot = make_robot_sample();
  Joint& spindle = robot.tool_chain.back();
  spindle.origin = Eigen::Isometry3d::Identity();
  spindle.origin.translation() = Eigen::Vector3d(0.25, 0.0, 0.15);
  return robot;
}

/// Independent of the code under test: the 6 x 6 Jacobian by central differences of the direct
/// kinematics (tip in m, rotation vector of S in W in rad), and its inverse condition number by
/// Eigen's SVD.
double independent_inverse_condition(const MachineModel& robot, const Eigen::VectorXd& q, double tool) {
  const double h = 1e-7;
  auto frame = [&](const Eigen::VectorXd& x) {
    return Eigen::Isometry3d(workpiece_frame_B(robot, x).inverse() * spindle_frame_B(robot, x));
  };
  Eigen::Matrix<double, 6, 6> J;
  for (int j = 0; j < 6; ++j) {
    Eigen::VectorXd plus = q, minus = q;
    plus[j] += h;
    minus[j] -= h;
    const Eigen::Isometry3d P = frame(plus), M = frame(minus);
    const Eigen::Vector3d tip_p = P * Eigen::Vector3d(0, 0, -tool), tip_m = M * Eigen::Vector3d(0, 0, -tool);
    J.block<3, 1>(0, j) = (tip_p - tip_m) / (2 * h);
    const Eigen::AngleAxisd turn(P.linear() * M.linear().transpose());
    J.block<3, 1>(3, j) = turn.angle() * turn.axis() / (2 * h);
  }
  const Eigen::JacobiSVD<Eigen::Matrix<double, 6, 6>> svd(J);
  return svd.singularValues()(5) / svd.singularValues()(0);
}

/// The roll of x_S from x_W projected on the plane normal to the tool axis, written here.
double independent_roll(const MachineModel& robot, const Eigen::VectorXd& q) {
  const Eigen::Matrix3d R = (workpiece_frame_B(robot, q).inverse() * spindle_frame_B(robot, q)).linear();
  const Eigen::Vector3d z = R.col(2);
  const Eigen::Vector3d reference = (Eigen::Vector3d::UnitX() - z.x() * z).normalized();
  return std::atan2(z.cross(reference).dot(R.col(0)), reference.dot(R.col(0)));
}

/// The path solved as the planner gets it (solve_path_kinematics with the rolls given), checked
/// point by point against independent computations; returns the smallest inverse condition.
double check_rolled_path(const MachineModel& robot, std::vector<PathPose>& path, const RollProfile& profile,
                         const RollProfileOptions& options, double tool) {
  for (std::size_t i = 0; i < path.size(); ++i) path[i].roll_rad = profile.roll_rad[i];
  const PathKinematics solved = solve_path_kinematics(robot, path, profile.q_start, tool, {});
  double smallest = 1.0;
  const double wrist_sign = solved.q(4, 0) > 0 ? 1.0 : -1.0;
  for (std::size_t i = 0; i < path.size(); ++i) {
    const Eigen::VectorXd q = solved.q.col(static_cast<Eigen::Index>(i));
    const ToolPose reached = forward_kinematics(robot, q, tool);
    EXPECT_LT((reached.tip_W_m - path[i].pose.tip_W_m).norm(), 1e-9) << i;
    EXPECT_LT((reached.axis_W - path[i].pose.axis_W.normalized()).norm(), 1e-9) << i;
    EXPECT_NEAR(std::remainder(independent_roll(robot, q) - path[i].roll_rad, 2 * std::numbers::pi), 0.0, 1e-9) << i;
    EXPECT_TRUE(within_travel(robot, q)) << i;
    smallest = std::min(smallest, independent_inverse_condition(robot, q, tool));
    // One branch throughout: the wrist never straightens through q5 = 0 (no flip), no jump.
    EXPECT_GT(wrist_sign * q[4], 0.0) << i;
    if (i > 0) {
      const Eigen::VectorXd before = solved.q.col(static_cast<Eigen::Index>(i - 1));
      EXPECT_LT((q - before).cwiseAbs().maxCoeff(), 0.2) << i;
      // Continuous, and its rate within the bound.
      const double ds = (path[i].pose.tip_W_m - path[i - 1].pose.tip_W_m).norm();
      EXPECT_LE(std::abs(path[i].roll_rad - path[i - 1].roll_rad), options.max_roll_rate_rad_per_m * ds + 1e-9) << i;
    }
  }
  return smallest;
}

TEST(Redundancy, RollProfileKeepsTheArmAwayFromAWristSingularityAFixedRollRunsInto) {
  const MachineModel robot = robot_with_bracket_spindle();
  const double tool = 0.1;
  // The middle of the path: the wrist straight (q5 = 0: q4 and q6 aligned), a singularity.
  Eigen::VectorXd q_mid(6);
  q_mid << 0.1, 0.3, 0.2, 0.4, 0.0, 0.3;
  const ToolPose mid = forward_kinematics(robot, q_mid, tool);
  const double roll_mid = tool_roll_of(robot, q_mid);
  // A straight cut 200 mm long through that tip, the tool axis fixed: with the roll held at
  // roll_mid the arm passes through q_mid, where the Jacobian loses rank.
  EXPECT_LT(independent_inverse_condition(robot, q_mid, tool), 1e-6);
  std::vector<PathPose> path;
  const Eigen::Vector3d direction = Eigen::Vector3d(0.3, 1.0, 0.0).normalized();
  for (int i = -20; i <= 20; ++i) {
    path.push_back({{mid.tip_W_m + 0.005 * i * direction, mid.axis_W}, 0});
  }
  Eigen::VectorXd seed = q_mid;
  seed[4] = 0.2;  // the wrist bent one way: the branch the lanes start on
  RollProfileOptions options;
  const auto profile = choose_tool_roll_along_path(robot, path, seed, tool, options);
  ASSERT_TRUE(profile.has_value());
  std::cout << "roll " << profile->roll_min_rad * 180 / std::numbers::pi << " to "
            << profile->roll_max_rad * 180 / std::numbers::pi << " deg (fixed " << roll_mid * 180 / std::numbers::pi
            << "), smallest score " << profile->min_score << " (without the choice " << profile->min_score_free << ")\n";

  const double smallest = check_rolled_path(robot, path, *profile, options, tool);
  std::cout << "smallest inverse condition along the path (finite-difference Jacobian, SVD): " << smallest << "\n";
  EXPECT_GT(smallest, 0.02);
  EXPECT_GT(profile->min_score, 0.02);
  // The roll had to move away from the fixed one at the singular point.
  EXPECT_GT(std::abs(std::remainder(path[20].roll_rad - roll_mid, 2 * std::numbers::pi)), 5 * std::numbers::pi / 180);
}

TEST(Redundancy, RollProfileTurnsWithinItsRateBoundWhereTheBestRollMoves) {
  // The same cut, its tool axis tilting by 1 rad along 200 mm; asked for the largest score
  // everywhere (comfortable_score 1), the roll follows the best one within 0.5 deg/mm.
  const MachineModel robot = robot_with_bracket_spindle();
  const double tool = 0.1;
  Eigen::VectorXd q_mid(6);
  q_mid << 0.1, 0.3, 0.2, 0.4, 0.0, 0.3;
  const ToolPose mid = forward_kinematics(robot, q_mid, tool);
  const Eigen::Vector3d direction = Eigen::Vector3d(0.3, 1.0, 0.0).normalized();
  std::vector<PathPose> path;
  for (int i = -20; i <= 20; ++i) {
    path.push_back({{mid.tip_W_m + 0.005 * i * direction, Eigen::AngleAxisd(i / 20.0, direction) * mid.axis_W}, 0});
  }
  Eigen::VectorXd seed = q_mid;
  seed[4] = 0.2;
  RollProfileOptions options;
  options.comfortable_score = 1.0;
  const auto profile = choose_tool_roll_along_path(robot, path, seed, tool, options);
  ASSERT_TRUE(profile.has_value());
  std::cout << "roll " << profile->roll_min_rad * 180 / std::numbers::pi << " to "
            << profile->roll_max_rad * 180 / std::numbers::pi << " deg, smallest score " << profile->min_score
            << " (without the choice " << profile->min_score_free << ")\n";
  EXPECT_GT(profile->roll_max_rad - profile->roll_min_rad, 10 * std::numbers::pi / 180);
  const double smallest = check_rolled_path(robot, path, *profile, options, tool);
  EXPECT_GT(smallest, 0.1);
  EXPECT_LT(profile->min_score_free, 1e-6);  // least joint motion from the first pose's roll runs into it
}

}  // namespace
}  // namespace vmsim::kinematics
