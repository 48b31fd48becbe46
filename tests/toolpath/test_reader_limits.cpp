// Tool path readers: the expansion limits (ReaderOptions::max_points_per_block,
// max_path_points) and the rotary words carried on each point. Small limits here stand for the
// defaults, which are sized for memory: 20 000 full circles expanded at the default chord
// tolerance would take 14 million points (over 1 GB in the reader, about 14 GB down the chain).
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <string>

#include "reader_test_support.hpp"
#include "vmsim/toolpath/toolpath.hpp"

namespace vmsim::toolpath {
namespace {

#define EXPECT_CONTAINS(text, part) \
  EXPECT_NE(std::string(text).find(part), std::string::npos) << "in: " << (text)

std::string repeated_circles(int count) {
  std::string program = "G1 X10 Y0 F100\n";
  for (int i = 0; i < count; ++i) program += "G2 X10 Y0 I-10 J0\n";
  return program;
}

TEST(ReaderLimits, RepeatedFullCirclesStopAtThePathLimitWithTheCountInTheMessage) {
  ReaderOptions options;
  options.arc_chord_tolerance_m = 5e-3;  // 4 points (quarter turns) per circle of radius 10 mm
  options.max_path_points = 1000;
  const std::string message =
      test::input_error_of([&] { parse_gcode(repeated_circles(20000), "circles.nc", options); });
  // 1 + 4 * 249 = 997 points; the next circle would make 1001.
  EXPECT_CONTAINS(message, "circles.nc:251:");
  EXPECT_CONTAINS(message, "brings the tool path to 1001 points");
  EXPECT_CONTAINS(message, "limit of 1000 points");
  EXPECT_EQ(parse_gcode(repeated_circles(249), "circles.nc", options).points.size(), 997u);
}

TEST(ReaderLimits, ADefaultPathLimitOfTwoMillionPoints) {
  EXPECT_EQ(ReaderOptions{}.max_path_points, 2'000'000u);
  EXPECT_EQ(ReaderOptions{}.max_points_per_block, 1'000'000u);
}

TEST(ReaderLimits, AptMultiPointGotoCountsAgainstTheLimits) {
  ReaderOptions options;
  options.max_points_per_block = 2;
  std::string message = test::input_error_of(
      [&] { parse_apt("MULTAX/OFF\nFEDRAT/1\nGOTO/0,0,0,1,0,0,2,0,0\n", "p.apt", options); });
  EXPECT_CONTAINS(message, "p.apt:3:1:");
  EXPECT_CONTAINS(message, "expands to 3 points");
  options.max_points_per_block = 10;
  options.max_path_points = 3;
  message = test::input_error_of([&] {
    parse_apt("MULTAX/OFF\nFEDRAT/1\nGOTO/0,0,0,1,0,0\nGOTO/2,0,0,3,0,0\n", "p.apt", options);
  });
  EXPECT_CONTAINS(message, "p.apt:4:1:");
}

TEST(ReaderLimits, ALongRotaryTurnIsSplitWithinTheBlockLimit) {
  ReaderOptions options;
  options.axis_words_to_pose = [](const std::vector<std::pair<char, double>>&) {
    return AxisWordPose{Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ()};
  };
  options.max_points_per_block = 100;
  // 100 turns of C in steps of 90 deg: 400 points.
  const std::string message = test::input_error_of(
      [&] { parse_gcode("G1 X0 Y0 Z0 C0 F100\nG1 C36000\n", "turns.nc", options); });
  EXPECT_CONTAINS(message, "turns.nc:2:");
  EXPECT_CONTAINS(message, "36000 deg");
  EXPECT_CONTAINS(message, "expands to 400 points");
}

TEST(ReaderLimits, PointsCarryTheirRotaryWords) {
  ReaderOptions options;
  options.axis_words_to_pose = [](const std::vector<std::pair<char, double>>&) {
    return AxisWordPose{Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ()};
  };
  // Every pose is the same; the words differ, so no point is merged away.
  const Toolpath path = parse_gcode("G1 X0 Y0 Z0 C0 F100\nG1 C360\nG1 A10\n", "w.nc", options);
  ASSERT_EQ(path.points.size(), 6u);
  EXPECT_TRUE(std::isnan(path.points[0].rotary_words_deg[0]));
  EXPECT_EQ(path.points[0].rotary_words_deg[2], 0.0);
  EXPECT_EQ(path.points[1].rotary_words_deg[2], 90.0);
  EXPECT_EQ(path.points[4].rotary_words_deg[2], 360.0);
  EXPECT_EQ(path.points[5].rotary_words_deg[0], 10.0);
  EXPECT_EQ(path.points[5].rotary_words_deg[2], 360.0);
  // Programs without rotary words carry none.
  const Toolpath plain = parse_gcode("G1 X0 Y0 Z0 F100\nG1 X1\n", "p.nc");
  for (const PathPoint& point : plain.points) {
    for (double word : point.rotary_words_deg) EXPECT_TRUE(std::isnan(word));
  }
}

TEST(ReaderLimits, AFullTurnUnderG43_4IsSplitIntoToolAxesAlongTheCone) {
  ReaderOptions options;
  // Tool axis of a table-table machine: +z tilted by A about x, then turned by C about z (in W
  // the table's turn is the other way: -C).
  options.rotary_words_to_tool_axis = [](const std::vector<std::pair<char, double>>& words) {
    double a = 0.0, c = 0.0;
    for (const auto& [letter, value] : words) {
      if (letter == 'A') a = value * std::numbers::pi / 180.0;
      if (letter == 'C') c = -value * std::numbers::pi / 180.0;
    }
    return Eigen::Vector3d(std::sin(a) * std::sin(c), -std::sin(a) * std::cos(c),
                           std::cos(a));
  };
  const Toolpath path =
      parse_gcode("G43.4\nG1 X0 Y0 Z0 A-30 C0 F100\nG1 C360\n", "tcp.nc", options);
  ASSERT_EQ(path.points.size(), 5u);
  for (std::size_t k = 0; k < 5; ++k) {
    EXPECT_EQ(path.points[k].rotary_words_deg[2], 90.0 * static_cast<double>(k));
    EXPECT_NEAR(path.points[k].axis_W.z(), std::cos(30.0 * std::numbers::pi / 180.0), 1e-15);
  }
  // Half way round, the tool leans the other way.
  EXPECT_NEAR(path.points[2].axis_W.y(), -path.points[0].axis_W.y(), 1e-15);
  EXPECT_NEAR(path.points[4].axis_W.y(), path.points[0].axis_W.y(), 1e-15);
}

}  // namespace
}  // namespace vmsim::toolpath
