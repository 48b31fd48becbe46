// G-code reader: arcs against closed-form circles, modes (G91, G20, G93), 5-axis
// tool-centre-point programming, and each kind of bad input. The last tests check that an APT
// file and G-code files describing the same 5-axis motion give the same canonical points.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include "vmsim/common/errors.hpp"
#include "reader_test_support.hpp"
#include "vmsim/toolpath/toolpath.hpp"

namespace vmsim::toolpath {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kDeg = kPi / 180.0;

Toolpath gcode(const std::string& text, const ReaderOptions& options = {}) {
  return parse_gcode(text, "part.nc", options);
}

std::string gcode_error(const std::string& text, const ReaderOptions& options = {}) {
  return test::input_error_of([&] { gcode(text, options); });
}

using test::expect_vector;

/// An arc in the plane (u, v) with normal w, as indices into X Y Z.
struct Plane {
  int u, v, w;
};
constexpr Plane kXY{0, 1, 2};
constexpr Plane kZX{2, 0, 1};
constexpr Plane kYZ{1, 2, 0};

/// Checks path.points[first .. last] (the arc, after the start point path.points[first - 1])
/// against a circle of centre c_m and radius r_m in `plane`:
///  - every point at distance r_m from the centre (in the plane) within 1e-12 m;
///  - every step turns the right way (counter-clockwise seen from +w when ccw) by less than pi;
///  - the chord error r (1 - cos(step / 2)) of every step <= tolerance, and no fewer points
///    would do (the tessellation is not wastefully fine);
///  - the steps add up to sweep_rad.
void check_arc(const Toolpath& path, std::size_t first, std::size_t last,
               const Eigen::Vector3d& c_m, double r_m, Plane plane, bool ccw, double sweep_rad, double tolerance_m) {
  ASSERT_GE(first, 1u);
  ASSERT_LT(last, path.points.size());
  double total = 0.0;
  for (std::size_t i = first; i <= last; ++i) {
    EXPECT_EQ(path.points[i].kind, MotionKind::arc);
    const Eigen::Vector3d& a = path.points[i - 1].tip_W_m;
    const Eigen::Vector3d& b = path.points[i].tip_W_m;
    const Eigen::Vector2d da(a[plane.u] - c_m[plane.u], a[plane.v] - c_m[plane.v]);
    const Eigen::Vector2d db(b[plane.u] - c_m[plane.u], b[plane.v] - c_m[plane.v]);
    EXPECT_NEAR(db.norm(), r_m, 1e-12) << "point " << i;
    const double cross = da.x() * db.y() - da.y() * db.x();
    const double step = std::atan2(cross, da.dot(db));
    EXPECT_GT(ccw ? step : -step, 0.0) << "point " << i;
    EXPECT_LE(r_m * (1.0 - std::cos(0.5 * step)), tolerance_m * (1.0 + 1e-9)) << "point " << i;
    total += step;
  }
  EXPECT_NEAR(total, sweep_rad, 1e-9);
  const double fewer = static_cast<double>(last - first);  // one segment less
  if (fewer >= 1.0) {
    EXPECT_GT(r_m * (1.0 - std::cos(0.5 * std::abs(sweep_rad) / fewer)), tolerance_m);
  }
}

TEST(GcodeReader, LinearMovesFeedAndBlocks) {
  const Toolpath path = gcode(
      "%\n"
      "O1000 (A PROGRAM)\n"
      "N10 G21 G90 G17 G40 G49 G80 G94 G54 G64 G98 G15\n"
      "N20 G0 X1 Y2 Z3 S1000 M3 T1 H1 D1\n"
      "N30 G1 X4 F600\n"
      "N40 Y-5.5 ; a comment with X99\n"
      "N50 (MOVE) Z-.5 (ANOTHER) M8\n"
      "%\n");
  ASSERT_EQ(path.points.size(), 4u);
  EXPECT_TRUE(path.warnings.empty());
  expect_vector(path.points[0].tip_W_m, {0.001, 0.002, 0.003});
  EXPECT_EQ(path.points[0].kind, MotionKind::rapid);
  EXPECT_EQ(path.points[0].feed_m_per_s, 0.0);
  expect_vector(path.points[1].tip_W_m, {0.004, 0.002, 0.003});
  EXPECT_EQ(path.points[1].kind, MotionKind::linear);
  EXPECT_NEAR(path.points[1].feed_m_per_s, 0.01, 1e-17);
  expect_vector(path.points[2].tip_W_m, {0.004, -0.0055, 0.003});
  expect_vector(path.points[3].tip_W_m, {0.004, -0.0055, -0.0005});
  expect_vector(path.points[3].axis_W, {0.0, 0.0, 1.0});
  EXPECT_EQ(path.blocks[path.points[3].block].line, 7);
  EXPECT_EQ(path.blocks[path.points[3].block].block_number, 50);
  EXPECT_EQ(path.blocks[path.points[3].block].text, "N50 (MOVE) Z-.5 (ANOTHER) M8");
}

TEST(GcodeReader, UnprogrammedAxesBlockDeleteAndProgramEnd) {
  const Toolpath path = gcode(
      "G0 X10\n"
      "/G0 X50\n"
      "G0 Y20 M30\n"
      "G0 X99\n");
  ASSERT_EQ(path.points.size(), 2u);
  expect_vector(path.points[0].tip_W_m, {0.010, 0.0, 0.0});
  expect_vector(path.points[1].tip_W_m, {0.010, 0.020, 0.0});
  ASSERT_EQ(path.warnings.size(), 3u);  // Y and Z taken as 0, and the block delete
  EXPECT_EQ(path.warnings[0].line, 1);
  EXPECT_NE(path.warnings[0].message.find("Y"), std::string::npos);
  EXPECT_EQ(path.warnings[2].line, 2);
  EXPECT_NE(path.warnings[2].message.find("block delete"), std::string::npos);
}

TEST(GcodeReader, G17ArcsBothWays) {
  const double tol = 0.1e-6;
  // From (10, 0) to (0, 10) about the origin: G3 turns 90 deg, G2 turns -270 deg.
  const Toolpath ccw = gcode("G0 X10 Y0 Z2\nG3 X0 Y10 I-10 J0 F600\n");
  check_arc(ccw, 1, ccw.points.size() - 1, {0, 0, 0}, 0.010, kXY, true, kPi / 2.0, tol);
  expect_vector(ccw.points.back().tip_W_m, {0.0, 0.010, 0.002}, 1e-17);  // exact end
  for (const PathPoint& p : ccw.points) EXPECT_DOUBLE_EQ(p.tip_W_m.z(), 0.002);
  EXPECT_NEAR(ccw.points.back().feed_m_per_s, 0.01, 1e-17);

  const Toolpath cw = gcode("G0 X10 Y0 Z2\nG2 X0 Y10 I-10 F600\n");
  check_arc(cw, 1, cw.points.size() - 1, {0, 0, 0}, 0.010, kXY, false, -1.5 * kPi, tol);
  expect_vector(cw.points.back().tip_W_m, {0.0, 0.010, 0.002}, 1e-17);
  // The clockwise arc passes through (0, -10) and (-10, 0).
  double min_x = 1.0;
  double min_y = 1.0;
  for (const PathPoint& p : cw.points) {
    min_x = std::min(min_x, p.tip_W_m.x());
    min_y = std::min(min_y, p.tip_W_m.y());
  }
  EXPECT_NEAR(min_x, -0.010, tol);
  EXPECT_NEAR(min_y, -0.010, tol);
}

TEST(GcodeReader, G18AndG19Arcs) {
  const double tol = 0.1e-6;
  // G18: the plane (Z, X); G3 from Z10 X0 to Z0 X10 about the origin is a quarter turn through
  // Z = X = 10 cos 45 deg, seen from +Y counter-clockwise.
  const Toolpath zx = gcode("G18 G0 X0 Y3 Z10\nG3 X10 Z0 K-10 F100\n");
  check_arc(zx, 1, zx.points.size() - 1, {0, 0, 0}, 0.010, kZX, true, kPi / 2.0, tol);
  for (const PathPoint& p : zx.points) {
    EXPECT_DOUBLE_EQ(p.tip_W_m.y(), 0.003);
    EXPECT_GE(p.tip_W_m.x(), 0.0);
    EXPECT_GE(p.tip_W_m.z(), 0.0);
  }
  expect_vector(zx.points.back().tip_W_m, {0.010, 0.003, 0.0}, 1e-17);
  // G2 in G18 from the same start to the same end goes the long way, through X = -10.
  const Toolpath zx_cw = gcode("G18 G0 X0 Y3 Z10\nG2 X10 Z0 K-10 F100\n");
  check_arc(zx_cw, 1, zx_cw.points.size() - 1, {0, 0, 0}, 0.010, kZX, false, -1.5 * kPi, tol);

  // G19: the plane (Y, Z), centre (Y, Z) = (5, 5).
  const Toolpath yz = gcode("G19 G0 X-1 Y15 Z5\nG3 Y5 Z15 J-10 K0 F100\n");
  check_arc(yz, 1, yz.points.size() - 1, {0, 0.005, 0.005}, 0.010, kYZ, true, kPi / 2.0, tol);
  for (const PathPoint& p : yz.points) {
    EXPECT_DOUBLE_EQ(p.tip_W_m.x(), -0.001);
    EXPECT_GE(p.tip_W_m.y(), 0.005 - 1e-15);
    EXPECT_GE(p.tip_W_m.z(), 0.005 - 1e-15);
  }
}

TEST(GcodeReader, RadiusFormArcs) {
  const double tol = 0.1e-6;
  // R10 from (10, 0) to (0, 10): G3 about the origin (90 deg); G3 R-10 about (10, 10) (270 deg);
  // G2 R10 about (10, 10) (-90 deg); G2 R-10 about the origin (-270 deg).
  const Toolpath a = gcode("G0 X10 Y0\nG3 X0 Y10 R10 F100\n");
  check_arc(a, 1, a.points.size() - 1, {0, 0, 0}, 0.010, kXY, true, kPi / 2.0, tol);
  const Toolpath b = gcode("G0 X10 Y0\nG3 X0 Y10 R-10 F100\n");
  check_arc(b, 1, b.points.size() - 1, {0.010, 0.010, 0}, 0.010, kXY, true, 1.5 * kPi, tol);
  const Toolpath c = gcode("G0 X10 Y0\nG2 X0 Y10 R10 F100\n");
  check_arc(c, 1, c.points.size() - 1, {0.010, 0.010, 0}, 0.010, kXY, false, -kPi / 2.0, tol);
  const Toolpath d = gcode("G0 X10 Y0\nG2 X0 Y10 R-10 F100\n");
  check_arc(d, 1, d.points.size() - 1, {0, 0, 0}, 0.010, kXY, false, -1.5 * kPi, tol);
  expect_vector(d.points.back().tip_W_m, {0.0, 0.010, 0.0}, 1e-17);
}

TEST(GcodeReader, FullCircleAndCoarseTolerance) {
  const Toolpath path = gcode("G0 X10 Y0 Z1\nG2 I-10 F100\nG3 X10 Y0 I-10 J0\n");
  // Two full circles: the first clockwise, the second counter-clockwise, both back at (10, 0).
  std::size_t split = 0;
  for (std::size_t i = 1; i < path.points.size(); ++i) {
    if (path.points[i].block != path.points[1].block) {
      split = i;
      break;
    }
  }
  ASSERT_GT(split, 1u);
  check_arc(path, 1, split - 1, {0, 0, 0.001}, 0.010, kXY, false, -2.0 * kPi, 0.1e-6);
  check_arc(path, split, path.points.size() - 1, {0, 0, 0.001}, 0.010, kXY, true, 2.0 * kPi,
            0.1e-6);
  expect_vector(path.points[split - 1].tip_W_m, {0.010, 0.0, 0.001}, 1e-17);
  expect_vector(path.points.back().tip_W_m, {0.010, 0.0, 0.001}, 1e-17);

  // A 10 um chord tolerance on r = 10 mm: step <= 2 acos(1 - 1e-3) = 0.08945 rad -> 71 steps.
  ReaderOptions coarse;
  coarse.arc_chord_tolerance_m = 10e-6;
  const Toolpath c = gcode("G0 X10 Y0\nG2 I-10 F100\n", coarse);
  EXPECT_EQ(c.points.size(), 1u + 71u);
  check_arc(c, 1, c.points.size() - 1, {0, 0, 0}, 0.010, kXY, false, -2.0 * kPi, 10e-6);
}

TEST(GcodeReader, HelixRisesInProportionToTheAngle) {
  // A quarter turn counter-clockwise about (0, 0) while Z rises 5 mm.
  const Toolpath path = gcode("G0 X10 Y0 Z0\nG3 X0 Y10 Z5 I-10 J0 F100\n");
  check_arc(path, 1, path.points.size() - 1, {0, 0, 0}, 0.010, kXY, true, kPi / 2.0, 0.1e-6);
  double angle = 0.0;
  for (std::size_t i = 1; i < path.points.size(); ++i) {
    const Eigen::Vector3d& a = path.points[i - 1].tip_W_m;
    const Eigen::Vector3d& b = path.points[i].tip_W_m;
    angle += std::atan2(a.x() * b.y() - a.y() * b.x(), a.x() * b.x() + a.y() * b.y());
    EXPECT_NEAR(b.z(), 0.005 * angle / (kPi / 2.0), 1e-12) << "point " << i;
  }
  expect_vector(path.points.back().tip_W_m, {0.0, 0.010, 0.005}, 1e-17);

  // A full helical turn (end above the start) in G19: X moves along the normal.
  const Toolpath turn = gcode("G19 G0 X0 Y10 Z0\nG2 X-3 J-10 F100\n");
  check_arc(turn, 1, turn.points.size() - 1, {0, 0, 0}, 0.010, kYZ, false, -2.0 * kPi, 0.1e-6);
  expect_vector(turn.points.back().tip_W_m, {-0.003, 0.010, 0.0}, 1e-17);
}

TEST(GcodeReader, IncrementalAndInch) {
  const Toolpath path = gcode(
      "G90 G0 X0 Y0 Z0\n"
      "G91 G0 X10 Y10 Z10\n"
      "G1 X5 F100\n"
      "G1 Y-5 Z-5\n"
      "G3 X-10 Y10 I-10\n"  // from (15, 5) about (5, 5) to (5, 15)
      "G90 G20 G1 X1 Y2 Z3 F10\n");
  expect_vector(path.points[1].tip_W_m, {0.010, 0.010, 0.010});
  expect_vector(path.points[2].tip_W_m, {0.015, 0.010, 0.010});
  expect_vector(path.points[3].tip_W_m, {0.015, 0.005, 0.005});
  const std::size_t end_of_arc = path.points.size() - 2;
  check_arc(path, 4, end_of_arc, {0.005, 0.005, 0.005}, 0.010, kXY, true, kPi / 2.0, 0.1e-6);
  expect_vector(path.points[end_of_arc].tip_W_m, {0.005, 0.015, 0.005}, 1e-17);
  expect_vector(path.points.back().tip_W_m, {0.0254, 0.0508, 0.0762});
  EXPECT_NEAR(path.points.back().feed_m_per_s, 0.254 / 60.0, 1e-17);  // 10 in/min
}

TEST(GcodeReader, InverseTimeFeed) {
  const Toolpath path = gcode(
      "G0 X0 Y0 Z0\n"
      "G93 G1 X10 F2\n"    // 2 / min: this move takes 30 s
      "G0 X20\n"           // rapids need no F
      "G2 X30 I5 F0.5\n"   // a half circle in 2 min, tessellated into n segments
      "G94 G1 X40 F600\n");
  EXPECT_NEAR(path.points[1].inverse_time_feed_per_s, 2.0 / 60.0, 1e-17);
  EXPECT_EQ(path.points[1].feed_m_per_s, 0.0);
  EXPECT_EQ(path.points[2].inverse_time_feed_per_s, 0.0);
  const std::size_t arc_points = path.points.size() - 4;
  double minutes = 0.0;
  for (std::size_t i = 3; i < 3 + arc_points; ++i) {
    ASSERT_EQ(path.points[i].kind, MotionKind::arc);
    minutes += 1.0 / (60.0 * path.points[i].inverse_time_feed_per_s);
  }
  EXPECT_NEAR(minutes, 2.0, 1e-12);  // the segments share the arc's time
  EXPECT_NEAR(path.points.back().feed_m_per_s, 0.01, 1e-17);
  EXPECT_EQ(path.points.back().inverse_time_feed_per_s, 0.0);

  const std::string message = gcode_error("G0 X0 Y0 Z0\nG93 G1 X10 F2\nG1 X20\n");
  EXPECT_NE(message.find("part.nc:3:1: 'G1'"), std::string::npos) << message;
  EXPECT_NE(message.find("G93"), std::string::npos) << message;
}

TEST(GcodeReader, G43_5ToolVectors) {
  const Toolpath path = gcode(
      "G43.5 H1 G0 X0 Y0 Z100 I0 J0 K1\n"
      "G1 X10 Z50 I0.6 J0 K0.8 F1000\n"
      "G1 X20 J3 K4\n"  // I left out: 0
      "G1 Y5\n"         // no vector: the axis stays
      "G49\n");
  ASSERT_EQ(path.points.size(), 4u);
  expect_vector(path.points[0].axis_W, {0, 0, 1});
  expect_vector(path.points[1].tip_W_m, {0.010, 0.0, 0.050});
  expect_vector(path.points[1].axis_W, {0.6, 0.0, 0.8});
  expect_vector(path.points[2].axis_W, {0.0, 0.6, 0.8});
  expect_vector(path.points[3].tip_W_m, {0.020, 0.005, 0.050});
  expect_vector(path.points[3].axis_W, {0.0, 0.6, 0.8});

  std::string message = gcode_error("G43.5 G0 X0 Y0 Z1 I0 J0 K1\nG1 X1 I0 J0 K0 F100\n");
  EXPECT_NE(message.find("part.nc:2:"), std::string::npos) << message;
  EXPECT_NE(message.find("zero tool axis"), std::string::npos) << message;
  // Without G43.5, I J K on a linear move mean nothing.
  message = gcode_error("G0 X0 Y0 Z1\nG1 X1 I1 F100\n");
  EXPECT_NE(message.find("part.nc:2:7: 'I1'"), std::string::npos) << message;
  // A motion in machine axes after a tilted TCP axis needs a machine.
  message = gcode_error("G43.5 G0 X0 Y0 Z1 I1 J0 K1\nG49\nG0 Z50\n");
  EXPECT_NE(message.find("part.nc:3:"), std::string::npos) << message;
  EXPECT_NE(message.find("axis_words_to_pose"), std::string::npos) << message;
}

TEST(GcodeReader, TraoriToolVectorComponents) {
  const Toolpath path = gcode(
      "TRAORI\n"
      "G0 X0 Y0 Z100 A3=0 B3=0 C3=1\n"
      "G1 X10 Z50 A3=0.6 B3=0 C3=0.8 F1000\n"
      "G1 X20 A3 = -3 C3=4\n"  // B3 left out: 0; blanks around '='
      "TRAFOOF\n");
  ASSERT_EQ(path.points.size(), 3u);
  expect_vector(path.points[1].axis_W, {0.6, 0.0, 0.8});
  expect_vector(path.points[2].axis_W, {-0.6, 0.0, 0.8});
  expect_vector(path.points[2].tip_W_m, {0.020, 0.0, 0.050});
  const std::string message = gcode_error("G0 X0 Y0 Z0 A3=1\n");
  EXPECT_NE(message.find("part.nc:1:13: 'A3=1'"), std::string::npos) << message;
  EXPECT_NE(message.find("TRAORI"), std::string::npos) << message;
}

/// A test machine: B tilts the tool from +Z towards +X, then C turns it about Z.
Eigen::Vector3d b_then_c(const std::vector<std::pair<char, double>>& words) {
  double b = 0.0;
  double c = 0.0;
  for (const auto& [letter, value] : words) {
    if (letter == 'B') b = value * kDeg;
    if (letter == 'C') c = value * kDeg;
    EXPECT_TRUE(letter == 'B' || letter == 'C') << letter;
  }
  return {std::sin(b) * std::cos(c), std::sin(b) * std::sin(c), std::cos(b)};
}

TEST(GcodeReader, G43_4RotaryWordsThroughTheMachine) {
  ReaderOptions options;
  options.rotary_words_to_tool_axis = b_then_c;
  const Toolpath path = gcode(
      "G43.4 H1 G0 X0 Y0 Z100 B0 C0\n"
      "G1 X10 Z50 B90 F1000\n"
      "G1 C90\n"           // only C: B stays 90
      "G91 G1 B-90 C-90\n"  // incremental rotary words: back to B0 C0
      "G49\n",
      options);
  ASSERT_EQ(path.points.size(), 4u);
  expect_vector(path.points[1].tip_W_m, {0.010, 0.0, 0.050});
  expect_vector(path.points[1].axis_W, {1.0, 0.0, 0.0}, 1e-15);
  expect_vector(path.points[2].axis_W, {0.0, 1.0, 0.0}, 1e-15);
  expect_vector(path.points[2].tip_W_m, {0.010, 0.0, 0.050});  // a pure reorientation
  expect_vector(path.points[3].axis_W, {0.0, 0.0, 1.0}, 1e-15);

  const std::string message = gcode_error("G43.4 H1 G0 X0 Y0 Z100 B30\n");
  EXPECT_NE(message.find("part.nc:1:24: 'B30'"), std::string::npos) << message;
  EXPECT_NE(message.find("needs a machine"), std::string::npos) << message;
  EXPECT_NE(message.find("rotary_words_to_tool_axis"), std::string::npos) << message;
}

TEST(GcodeReader, MachineAxisWordsThroughTheMachine) {
  // Rotary words outside TCP: an error without a machine, the machine's pose with one.
  const std::string message = gcode_error("G0 X0 Y0 Z0\nG1 X1 A20 F100\n");
  EXPECT_NE(message.find("part.nc:2:7: 'A20'"), std::string::npos) << message;
  EXPECT_NE(message.find("axis_words_to_pose"), std::string::npos) << message;

  ReaderOptions options;
  std::vector<std::vector<std::pair<char, double>>> seen;
  options.axis_words_to_pose = [&seen](const std::vector<std::pair<char, double>>& words) {
    seen.push_back(words);
    // A made-up machine: the tip is the X Y Z words shifted by 1 m in Y; A turns the axis.
    double x = 0, y = 0, z = 0, a = 0;
    for (const auto& [letter, value] : words) {
      if (letter == 'X') x = value;
      if (letter == 'Y') y = value;
      if (letter == 'Z') z = value;
      if (letter == 'A') a = value * kDeg;
    }
    return AxisWordPose{Eigen::Vector3d(x * 1e-3, 1.0 + y * 1e-3, z * 1e-3),
                        Eigen::Vector3d(0.0, -std::sin(a), std::cos(a)) * 2.0};
  };
  const Toolpath path = gcode("G20 G0 X0 Y0 Z0\nG1 X1 A30 F100\n", options);
  ASSERT_EQ(path.points.size(), 2u);
  ASSERT_EQ(seen.size(), 2u);
  ASSERT_EQ(seen[1].size(), 4u);
  EXPECT_EQ(seen[1][0], (std::pair<char, double>('X', 25.4)));  // mm after G20
  EXPECT_EQ(seen[1][3], (std::pair<char, double>('A', 30.0)));  // deg, not scaled
  expect_vector(path.points[1].tip_W_m, {0.0254, 1.0, 0.0});
  expect_vector(path.points[1].axis_W, {0.0, -0.5, std::sqrt(3.0) / 2.0});  // normalised
}

TEST(GcodeReader, ArcErrorsNameTheBlock) {
  struct Case {
    const char* text;
    const char* where;
    const char* what;
  };
  const Case cases[] = {
      {"G0 X10 Y0\nG2 X0 Y11 I-10 F100\n", "part.nc:2:1:", "same distance"},
      // 0.05 mm is beyond the default tolerance max(0.02 sqrt 2 mm, 0.1 % of 10 mm).
      {"G0 X10 Y0\nG2 X0 Y10.05 I-10 F100\n", "part.nc:2:1:", "end radius 10.05"},
      {"G0 X10 Y0\nG2 X0 Y10.05 I-10 F100\n", "part.nc:2:1:", "differ by 0.05"},
      {"G0 X10 Y0\nG2 X0 Y10.05 I-10 F100\n", "part.nc:2:1:", "tolerance of 0.028284 mm"},
      {"G0 X10 Y0\nN7 G3 X-20 Y0 R10 F100\n", "part.nc:2:15: 'R10'", "smaller than half"},
      {"G0 X10 Y0\nG3 R10 F100\n", "part.nc:2:4: 'R10'", "full circle"},
      {"G0 X10 Y0\nG3 X0 Y10 F100\n", "part.nc:2:1: 'G3'", "centre (I J K) or a radius"},
      {"G0 X10 Y0\nG3 X0 Y10 I-10 R10 F100\n", "part.nc:2:16: 'R10'", "both"},
      {"G0 X10 Y0\nG3 X0 Y10 I-10 K1 F100\n", "part.nc:2:16: 'K1'", "G17"},
      {"G3 X0 Y10 I-10 F100\n", "part.nc:1:1: 'G3'", "first motion"},
      {"G0 X10 Y0\nG3 X0 Y10 I-10 F100 A3=1\n", "part.nc:2:", "tool vector"},
      {"G0 X10 Y0\nG1 X1 R5 F100\n", "part.nc:2:7: 'R5'", "G2/G3"},
  };
  for (const Case& c : cases) {
    const std::string message = gcode_error(c.text);
    EXPECT_NE(message.find(c.where), std::string::npos) << c.text << " -> " << message;
    EXPECT_NE(message.find(c.what), std::string::npos) << c.text << " -> " << message;
  }
  // Within the radius tolerance the arc is accepted and ends exactly where programmed.
  const Toolpath path = gcode("G0 X10 Y0\nG3 X0 Y10.0005 I-10 F100\n");
  expect_vector(path.points.back().tip_W_m, {0.0, 0.0100005, 0.0}, 1e-17);
}

TEST(GcodeReader, EachKindOfBadInputIsAnError) {
  struct Case {
    const char* text;
    const char* where;
    const char* what;
  };
  const Case cases[] = {
      {"G0 X0 Y0 Z0\nG1 X1.2.3 F100\n", "part.nc:2:4: 'X1.2.3'", "malformed number"},
      {"G0 X0 Y0 Z0\nG1 X F100\n", "part.nc:2:4:", "no value"},
      {"G0 X0 Y0 Z0\nG1 X1 # F100\n", "part.nc:2:7: '#'", "a parameter needs a number"},
      {"G0 X0 Y0 Z0 (OPEN\n", "part.nc:1:13:", "not closed"},
      {"X10 Y0\n", "part.nc:1:1: 'X10'", "before any motion mode"},
      {"G0 X0 Y0 Z0\nG1 X10\n", "part.nc:2:1: 'G1'", "before any F"},
      {"G0 X0 Y0 Z0\nG1 X10 F0\n", "part.nc:2:8: 'F0'", "positive"},
      {"G0 X0 Y0 Z0\nG0 X1 X2\n", "part.nc:2:7: 'X2'", "twice"},
      {"G0 X0 Y0 Z0\nG0 G1 X2\n", "part.nc:2:4: 'G1'", "second motion"},
      {"G0 X0 Y0 Z0\nG41 D1 G1 X2 F100\n", "part.nc:2:5: 'D1'", "no cutter radius for D1"},
      {"G0 X0 Y0 Z0\nG42 G1 X2 F100\n", "part.nc:2:1: 'G42'", "without D and without a tool"},
      {"G0 X0 Y0 Z0\nG68 X0 Y0\n", "part.nc:2:1: 'G68'", "needs R"},
      {"G0 X0 Y0 Z0\nG51 P2\n", "part.nc:2:1: 'G51'", "scaling"},
      {"G0 X0 Y0 Z0\nG54.1 P1\n", "part.nc:2:1: 'G54.1'", "G54.1 P1 is not set up"},
      {"G0 X0 Y0 Z0\nG55\n", "part.nc:2:1: 'G55'", "work offset G55 is not set up"},
      {"G0 X0 Y0 Z0\nG52\n", "part.nc:2:1: 'G52'", "at least one of X Y Z"},
      {"G0 X0 Y0 Z0\nG81 Z-5 F100\n", "part.nc:2:1: 'G81'", "R level"},
      {"G0 X0 Y0 Z0\nG81 Z5 R1 F100\n", "part.nc:2:5: 'Z5'", "not below the R level"},
      {"G0 X0 Y0 Z0\nG83 Z-5 R1 F100\n", "part.nc:2:1: 'G83'", "peck depth Q"},
      {"G0 X0 Y0 Z9\nG87 Z-5 R1 Q1 F100\n", "part.nc:2:5: 'Z-5'", "is not above the R level"},
      {"G43.4 G0 X0 Y0 Z0\nG28 Z0\n", "part.nc:2:1: 'G28'", "tool-centre-point"},
      {"G0 X0 Y0 Z0\nG43 H2 Z5\n", "part.nc:2:5: 'H2'", "no tool length for H2"},
      {"G0 X0 Y0 Z0\nG43 Z5\n", "part.nc:2:1: 'G43'", "tool length is unknown"},
      {"G0 X0 Y0 Z0\nM6\n", "part.nc:2:1: 'M6'", "without a tool selected"},
      {"G0 X0 Y0 Z0\nG10 L3 P1 X0\n", "part.nc:2:5: 'L3'", "not supported"},
      {"G0 X0 Y0 Z0\nG64 P0\n", "part.nc:2:5: 'P0'", "positive"},
      {"G0 X0 Y0 Z0\nG52 X1 G68 R30\n", "part.nc:2:8: 'G68'", "separate blocks"},
      {"G0 X0 Y0 Z0\nG53 G28 Z0\n", "part.nc:2:1: 'G53'", "in one block"},
      {"G0 X0 Y0 Z0\nG7.5\n", "part.nc:2:1: 'G7.5'", "unsupported G-code"},
      {"G0 X0 Y0 Z0\nG1 U5 F100\n", "part.nc:2:4: 'U5'", "unsupported word"},
      {"G0 X0 Y0 Z0\nG1 X1 P5 F100\n", "part.nc:2:7: 'P5'", "no meaning"},
      {"G0 X0 Y0 Z0\nM98 P1000\n", "part.nc:2:1: 'M98'", "subprogram"},
      {"G0 X0 Y0 Z0\nCYCLE81(10)\n", "part.nc:2:1: 'CYCLE81'", "unsupported word"},
      {"", "part.nc: ", "no motion"},
      {"%\n(ONLY COMMENTS)\nG21 G90 F100 M3 S100\n%\n", "part.nc: ", "no motion"},
  };
  for (const Case& c : cases) {
    const std::string message = gcode_error(c.text);
    EXPECT_NE(message.find(c.where), std::string::npos) << c.text << " -> " << message;
    EXPECT_NE(message.find(c.what), std::string::npos) << c.text << " -> " << message;
  }
  // G4 dwell: its X is a time, not a position.
  const Toolpath dwell = gcode("G0 X0 Y0 Z0\nG4 X2.5\nG4 P100\nG1 X1 F100\n");
  ASSERT_EQ(dwell.points.size(), 2u);
  expect_vector(dwell.points[1].tip_W_m, {0.001, 0.0, 0.0});
}

/// Reads the three sample files of the same 5-axis motion (tests/data/toolpaths/five_axis.*).
Toolpath sample(const std::string& name) {
  return read_toolpath(std::string(VMSIM_SOURCE_DIR) + "/tests/data/toolpaths/" + name);
}

void expect_same_motion(const Toolpath& a, const Toolpath& b) {
  ASSERT_EQ(a.points.size(), b.points.size());
  for (std::size_t i = 0; i < a.points.size(); ++i) {
    SCOPED_TRACE("point " + std::to_string(i));
    EXPECT_LE((a.points[i].tip_W_m - b.points[i].tip_W_m).norm(), 1e-12);
    EXPECT_LE((a.points[i].axis_W - b.points[i].axis_W).norm(), 1e-12);
    EXPECT_NEAR(a.points[i].axis_W.norm(), 1.0, 1e-15);
    EXPECT_EQ(a.points[i].kind, b.points[i].kind);
    EXPECT_NEAR(a.points[i].feed_m_per_s, b.points[i].feed_m_per_s, 1e-15);
  }
}

TEST(SameMotion, AptAndG43_5AndTraoriGiveTheSameCanonicalPoints) {
  const Toolpath apt = sample("five_axis.apt");
  const Toolpath fanuc = sample("five_axis_g43_5.nc");
  const Toolpath siemens = sample("five_axis_traori.mpf");
  ASSERT_EQ(apt.points.size(), 7u);
  EXPECT_TRUE(apt.warnings.empty());
  EXPECT_TRUE(fanuc.warnings.empty());
  EXPECT_TRUE(siemens.warnings.empty());
  expect_same_motion(apt, fanuc);
  expect_same_motion(apt, siemens);
  // A hand-checked point: GOTO/30.0,10.0,4.5,0.0,-0.6,0.8 at 1200 mm/min.
  expect_vector(apt.points[4].tip_W_m, {0.030, 0.010, 0.0045});
  expect_vector(apt.points[4].axis_W, {0.0, -0.6, 0.8});
  EXPECT_NEAR(apt.points[4].feed_m_per_s, 0.02, 1e-17);
  EXPECT_EQ(fanuc.blocks[fanuc.points[4].block].block_number, 80);
}

TEST(SameMotion, G43_4ThroughATestMachineGivesTheAptPoints) {
  // The APT axes (0.6, 0, 0.8) and (0, -0.6, 0.8) as B (tilt from +Z towards +X) and C (turn
  // about Z): B = atan(0.6 / 0.8) = 36.86989764584402 deg, C = 0 and -90 deg.
  const std::string program =
      "G21 G90 G94\n"
      "G43.4 H1 G0 X0 Y0 Z100 B0 C0\n"
      "X10 Y-5 Z20\n"
      "G1 Z5 F1200\n"
      "X20 Y0 B36.86989764584402\n"
      "X30 Y10 Z4.5 C-90\n";
  ReaderOptions options;
  options.rotary_words_to_tool_axis = b_then_c;
  const Toolpath fanuc = gcode(program, options);
  Toolpath apt = sample("five_axis.apt");
  apt.points.resize(5);
  expect_same_motion(apt, fanuc);
}

}  // namespace
}  // namespace vmsim::toolpath
