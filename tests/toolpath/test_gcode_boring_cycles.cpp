// Canned cycles G87 (back boring) and G88 (boring, manual retract), and the G76 / G87 shift by
// I J, against point sequences written by hand from the Fanuc manual's description of each
// cycle (not from the reader's output):
//  G87: position in X Y at the initial level; spindle orient, shift by Q (the machine's shift
//       direction) or by (I, J); rapid down to R (below the part); shift back; spindle on, feed
//       up to Z; orient, shift; rapid up to the initial level; shift back. G99 is not used with
//       G87 on a Fanuc (R is below the part): the reader returns to the initial level, with a
//       warning.
//  G88: position, rapid to R, feed to Z, dwell P, spindle stop, program stop for the operator's
//       manual retract (assumed: straight out along Z to R), cycle start: rapid to the initial
//       level (G98) or stay at R (G99).
// G91: R from the initial level, Z from R, X Y per repeat (K / L).
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "reader_test_support.hpp"
#include "vmsim/common/errors.hpp"
#include "vmsim/toolpath/toolpath.hpp"

namespace vmsim::toolpath {
namespace {

using test::expect_vector;

Toolpath gcode(const std::string& text, const ReaderOptions& options = {}) {
  return parse_gcode(text, "part.nc", options);
}

std::string gcode_error(const std::string& text, const ReaderOptions& options = {}) {
  return test::input_error_of([&] { gcode(text, options); });
}

struct Expected {
  Eigen::Vector3d tip_mm;
  bool rapid = true;
};

constexpr bool R = true;   // rapid
constexpr bool F = false;  // feed

void expect_points(const Toolpath& path, const std::vector<Expected>& expected,
                   double feed_mm_per_min) {
  ASSERT_EQ(path.points.size(), expected.size());
  for (std::size_t i = 0; i < expected.size(); ++i) {
    SCOPED_TRACE("point " + std::to_string(i));
    const PathPoint& point = path.points[i];
    expect_vector(point.tip_W_m * 1e3, expected[i].tip_mm, 1e-9);
    if (i == 0) continue;  // the start pose
    EXPECT_EQ(point.kind, expected[i].rapid ? MotionKind::rapid : MotionKind::linear);
    EXPECT_DOUBLE_EQ(point.feed_m_per_s, expected[i].rapid ? 0.0 : feed_mm_per_min * 1e-3 / 60.0);
    EXPECT_EQ(point.corner_tolerance_m, 0.0);  // every level of a cycle is an exact stop
  }
}

bool has_warning(const Toolpath& path, const std::string& part) {
  for (const ReaderWarning& w : path.warnings) {
    if (w.message.find(part) != std::string::npos) return true;
  }
  return false;
}

// One G87 hole at (x, 5) from the initial level 20, R -25, Z -3, shifted by (dx, dy).
std::vector<Expected> back_bore(double x, double y, double dx, double dy) {
  return {{{x, y, 20}, R},       {{x + dx, y + dy, 20}, R}, {{x + dx, y + dy, -25}, R},
          {{x, y, -25}, R},      {{x, y, -3}, F},           {{x + dx, y + dy, -3}, R},
          {{x + dx, y + dy, 20}, R}, {{x, y, 20}, R}};
}

TEST(GcodeBackBoring, G87AbsoluteG98ShiftsByQAlongTheMachinesDirection) {
  ReaderOptions options;
  options.fine_boring_shift_direction = {-1.0, 0.0};  // the tool's edge points +X: shift to -X
  const Toolpath path = gcode(
      "G0 X0 Y0 Z20\n"
      "G90 G98 G87 X10 Y5 Z-3 R-25 Q2 F80\n"
      "X30\n"
      "G80\n",
      options);
  std::vector<Expected> expected = {{{0, 0, 20}, R}};
  for (const double x : {10.0, 30.0}) {
    const auto hole = back_bore(x, 5, -2, 0);
    expected.insert(expected.end(), hole.begin(), hole.end());
  }
  expect_points(path, expected, 80.0);
  EXPECT_TRUE(path.warnings.empty());
}

TEST(GcodeBackBoring, G87IncrementalWithRepeats) {
  // G91: R = 20 - 45 = -25 (from the initial level), Z = -25 + 22 = -3 (from R), X + 10 per
  // hole, K2 holes; the default shift direction is +X.
  const Toolpath path = gcode("G0 X0 Y5 Z20\nG91 G87 X10 Z22 R-45 Q1.5 K2 F80\n");
  std::vector<Expected> expected = {{{0, 5, 20}, R}};
  for (const double x : {10.0, 20.0}) {
    const auto hole = back_bore(x, 5, 1.5, 0);
    expected.insert(expected.end(), hole.begin(), hole.end());
  }
  expect_points(path, expected, 80.0);
}

TEST(GcodeBackBoring, G87ShiftByIJAndG99ReturnsToTheInitialLevel) {
  // I-1.5 J2: the shift as a vector in the plane (Fanuc with I J shifts, Haas); modal while the
  // cycle is. Under G99 a Fanuc G87 still ends at the initial level.
  const Toolpath path = gcode("G0 X0 Y0 Z20\nG99 G87 X10 Y5 Z-3 R-25 I-1.5 J2 F60\nY-5\n");
  std::vector<Expected> expected = {{{0, 0, 20}, R}};
  for (const double y : {5.0, -5.0}) {
    const auto hole = back_bore(10, y, -1.5, 2);
    expected.insert(expected.end(), hole.begin(), hole.end());
  }
  expect_points(path, expected, 60.0);
  EXPECT_TRUE(has_warning(path, "G87 under G99")) << path.warnings.size();
}

TEST(GcodeBackBoring, G76ShiftByIJ) {
  // G76 with I J: feed to the bottom, shift by (I, J), rapid out, shift back.
  const Toolpath path = gcode("G0 X0 Y0 Z10\nG76 X5 Y5 Z-5 R2 I0.3 J-0.4 F100\n");
  expect_points(path,
                {{{0, 0, 10}, R},
                 {{5, 5, 10}, R},
                 {{5, 5, 2}, R},
                 {{5, 5, -5}, F},
                 {{5.3, 4.6, -5}, R},
                 {{5.3, 4.6, 10}, R},
                 {{5, 5, 10}, R}},
                100.0);
}

TEST(GcodeManualRetractBoring, G88AbsoluteG98ThenG99) {
  const Toolpath path = gcode(
      "G0 X0 Y0 Z20\n"
      "G98 G88 X10 Y5 Z-8 R2 P500 F60\n"
      "G99 X30\n"
      "G80\n");
  expect_points(path,
                {{{0, 0, 20}, R},
                 // G98: to R, feed to Z, the manual retract to R, then to the initial level.
                 {{10, 5, 20}, R},
                 {{10, 5, 2}, R},
                 {{10, 5, -8}, F},
                 {{10, 5, 2}, R},
                 {{10, 5, 20}, R},
                 // G99: the retract ends at R, where the tool stays.
                 {{30, 5, 20}, R},
                 {{30, 5, 2}, R},
                 {{30, 5, -8}, F},
                 {{30, 5, 2}, R}},
                60.0);
  EXPECT_TRUE(has_warning(path, "manual retract"));
}

TEST(GcodeManualRetractBoring, G88IncrementalWithRepeats) {
  // G91: R = 20 - 18 = 2, Z = 2 - 10 = -8, L2 holes 10 mm apart in X, G99.
  const Toolpath path = gcode("G0 X0 Y0 Z20\nG91 G99 G88 X10 Z-10 R-18 P500 L2 F60\n");
  expect_points(path,
                {{{0, 0, 20}, R},
                 {{10, 0, 20}, R},
                 {{10, 0, 2}, R},
                 {{10, 0, -8}, F},
                 {{10, 0, 2}, R},
                 {{20, 0, 2}, R},
                 {{20, 0, -8}, F},
                 {{20, 0, 2}, R}},
                60.0);
}

TEST(GcodeBoringCycles, BadInputIsALocatedError) {
  struct Case {
    std::string text, where, what;
  };
  const std::vector<Case> cases = {
      // G87 cuts upwards: Z above R, the initial level above Z.
      {"G0 X0 Y0 Z20\nG87 Z-30 R-25 Q1 F80\n", "part.nc:2:5: 'Z-30'",
       "Z point Z-30 mm is not above the R level -25 mm"},
      {"G0 X0 Y0 Z-5\nG87 Z-3 R-25 Q1 F80\n", "part.nc:2:1: 'G87'",
       "initial level -5 mm is not above the Z point Z-3 mm"},
      {"G0 X0 Y0 Z20\nG87 Z-3 Q1 F80\n", "part.nc:2:1: 'G87'", "without its R level"},
      {"G0 X0 Y0 Z20\nG87 Z-3 R-25 Q1 I1 F80\n", "part.nc:2:14: 'Q1'", "both Q and I J"},
      {"G0 X0 Y0 Z20\nG81 Z-3 R2 I1 F80\n", "part.nc:2:12: 'I1'", "no meaning in this canned cycle"},
      {"G0 X0 Y0 Z20\nG18 G87 Z-3 Y-25 R-25 I1 F80\n", "part.nc:2:23: 'I1'", "G17 only"},
      {"G0 X0 Y0 Z20\nG88 Z1 R-2 P100 F80\n", "part.nc:2:5: 'Z1'", "not below the R level"},
      {"G0 X0 Y0 Z20\nG88 Z-5 R2 P-1 F80\n", "part.nc:2:12: 'P-1'", ""},
      {"G0 X0 Y0 Z20\nG88 Z-5 R2 Q1 F80\n", "part.nc:2:12: 'Q1'", "Q has no meaning"},
      {"G0 X0 Y0 Z20\nG87 Z-3 R-25 Q1 K1.5 F80\n", "part.nc:2:17: 'K1.5'", "whole number"},
  };
  for (const Case& c : cases) {
    const std::string message = gcode_error(c.text);
    EXPECT_NE(message.find(c.where), std::string::npos) << c.text << " -> " << message;
    EXPECT_NE(message.find(c.what), std::string::npos) << c.text << " -> " << message;
  }
}

}  // namespace
}  // namespace vmsim::toolpath
