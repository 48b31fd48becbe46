// The NC modes a run applies (app/nc_modes.hpp): the program's where it gives them, the
// command line's over them (and said so), the mode of most cutting moves where the program
// switches, the default where it says nothing; FFWOF switches the drives' feedforward off.
#include <gtest/gtest.h>

#include <cmath>

#include "nc_modes.hpp"

namespace vmsim::app {
namespace {

using toolpath::FeedforwardMode;
using toolpath::JerkMode;

/// n cutting points on line `line` of "p.mpf" with the given modes.
void add(toolpath::Toolpath& path, int line, std::size_t n, JerkMode jerk, FeedforwardMode ff,
         double corner_m = toolpath::PathPoint::kNotProgrammed) {
  path.blocks.push_back({"dir/p.mpf", line, -1, "G1"});
  for (std::size_t k = 0; k < n; ++k) {
    toolpath::PathPoint p;
    p.block = static_cast<int>(path.blocks.size()) - 1;
    p.jerk_mode = jerk;
    p.feedforward = ff;
    p.corner_tolerance_m = corner_m;
    path.points.push_back(p);
  }
}

TEST(NcModes, TheProgramsModeOfMostCuttingMovesAndItsStretches) {
  toolpath::Toolpath path;
  add(path, 3, 2, JerkMode::unspecified, FeedforwardMode::unspecified);
  add(path, 5, 10, JerkMode::soft, FeedforwardMode::off, 1e-5);
  add(path, 9, 4, JerkMode::brisk, FeedforwardMode::off, 0.0);
  const NcModes modes = decide_nc_modes(path, {});
  EXPECT_TRUE(modes.third_order);  // SOFT over 10 points, BRISK over 4
  EXPECT_EQ(modes.jerk.source, "program");
  EXPECT_FALSE(modes.jerk.overridden);
  EXPECT_NE(modes.jerk.note.find("switches"), std::string::npos);
  ASSERT_EQ(modes.jerk.program.size(), 3u);
  EXPECT_EQ(modes.jerk.program[1].mode, "SOFT");
  EXPECT_EQ(modes.jerk.program[1].from, "p.mpf:5");
  EXPECT_EQ(modes.jerk.program[1].cutting_points, 10u);
  ASSERT_TRUE(modes.feedforward.has_value());
  EXPECT_FALSE(*modes.feedforward);
  EXPECT_EQ(modes.corners.program[1].mode, "blend 0.01 mm");
  EXPECT_EQ(modes.corners.program[2].mode, "exact stop");
}

TEST(NcModes, TheCommandLineOverridesAndTheDefaultFillsIn) {
  toolpath::Toolpath path;
  add(path, 1, 5, JerkMode::soft, FeedforwardMode::unspecified);
  NcModeCommandLine command_line;
  command_line.third_order = false;
  command_line.third_order_option = "--no-third-order";
  command_line.feedforward = true;
  NcModes modes = decide_nc_modes(path, command_line);
  EXPECT_FALSE(modes.third_order);
  EXPECT_TRUE(modes.jerk.overridden);
  EXPECT_EQ(modes.jerk.source, "command line: --no-third-order");
  EXPECT_FALSE(modes.feedforward_use.overridden);  // the program says nothing about it
  // Nothing programmed: the command's default.
  toolpath::Toolpath plain;
  add(plain, 1, 5, JerkMode::unspecified, FeedforwardMode::unspecified);
  NcModeCommandLine plan_default;
  plan_default.default_third_order = true;
  modes = decide_nc_modes(plain, plan_default);
  EXPECT_TRUE(modes.third_order);
  EXPECT_FALSE(modes.feedforward.has_value());
  EXPECT_EQ(modes.jerk.source, "default: the program does not say");
}

TEST(NcModes, FeedforwardOffClearsEveryDrivesFeedforwardAndItsBalancing) {
  kinematics::MachineModel machine;
  machine.axes.resize(2);
  for (auto& axis : machine.axes) {
    axis.controller.velocity_feedforward = true;
    axis.controller.torque_feedforward = true;
    axis.controller.balancing_type = kinematics::BalancingType::first_order_lag;
    axis.controller.balancing_time_s = 1.5e-3;
  }
  const kinematics::MachineModel off = with_feedforward(machine, false);
  for (const auto& axis : off.axes) {
    EXPECT_FALSE(axis.controller.velocity_feedforward);
    EXPECT_FALSE(axis.controller.torque_feedforward);
    EXPECT_EQ(axis.controller.balancing_type, kinematics::BalancingType::none);
  }
  const kinematics::MachineModel on = with_feedforward(machine, true);
  EXPECT_TRUE(on.axes[1].controller.velocity_feedforward);
}

}  // namespace
}  // namespace vmsim::app
