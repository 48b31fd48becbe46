// The free rotation about a robot's tool axis: the chosen roll reaches the same tool pose and
// moves the arm away from a joint limit the nearest solution sits at.
#include <gtest/gtest.h>

#include <cmath>
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
