// G-code coordinate systems, canned cycles, arc tolerances and NC modes, each against positions
// worked out by hand from the control's documented behaviour: work offsets (G54 .. G59, G54.1,
// G10), tool length compensation (G43 H / G49), reference returns (G28 / G30), machine
// coordinates (G53), local shifts (G52 / G92), rotation (G68), canned cycles (G73 G81 G83 G85,
// G98 / G99, incremental repeats), arcs within the control's tolerance and path control modes.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <optional>
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

/// Tips in mm, for comparing with hand-worked positions.
std::vector<Eigen::Vector3d> tips_mm(const Toolpath& path) {
  std::vector<Eigen::Vector3d> tips;
  for (const PathPoint& point : path.points) tips.push_back(point.tip_W_m * 1e3);
  return tips;
}

void expect_tips(const Toolpath& path, const std::vector<Eigen::Vector3d>& expected_mm,
                 double tolerance_mm = 1e-9) {
  const auto tips = tips_mm(path);
  ASSERT_EQ(tips.size(), expected_mm.size());
  for (std::size_t i = 0; i < tips.size(); ++i) {
    SCOPED_TRACE("point " + std::to_string(i));
    expect_vector(tips[i], expected_mm[i], tolerance_mm);
  }
}

// A hand-made table-table machine: X Y Z move the spindle, whose gauge point is 500 mm above the
// table centre at machine zero; the C table turns the workpiece frame W about +Z through the
// table centre. The tool is 80 mm long. The tip in W: Rz(-C) (q + (0, 0, 500 - 80)).
constexpr double kGaugeHeightMm = 500.0;
constexpr double kToolLengthMm = 80.0;

AxisWordPose table_machine_pose(const std::vector<std::pair<char, double>>& words) {
  Eigen::Vector3d q = Eigen::Vector3d::Zero();
  double c_deg = 0.0;
  for (const auto& [letter, value] : words) {
    if (letter == 'X') q.x() = value;
    if (letter == 'Y') q.y() = value;
    if (letter == 'Z') q.z() = value;
    if (letter == 'C') c_deg = value;
  }
  const Eigen::Vector3d tip_B = q + Eigen::Vector3d(0.0, 0.0, kGaugeHeightMm - kToolLengthMm);
  const double c = -c_deg * std::numbers::pi / 180.0;
  const Eigen::Vector3d tip_W(std::cos(c) * tip_B.x() - std::sin(c) * tip_B.y(),
                              std::sin(c) * tip_B.x() + std::cos(c) * tip_B.y(), tip_B.z());
  return {tip_W * 1e-3, Eigen::Vector3d::UnitZ()};
}

ReaderOptions table_machine_options() {
  ReaderOptions options;
  options.axis_words_to_pose = table_machine_pose;
  options.rotary_words_to_tool_axis = [](const auto&) { return Eigen::Vector3d::UnitZ(); };
  options.machine_zero_W_mm = {0.0, 0.0, kGaugeHeightMm};
  // Work zero at (10, 20, 30) in W: the gauge point is there at machine (10, 20, -470).
  options.work_offsets_mm["G54"] = {10.0, 20.0, 30.0 - kGaugeHeightMm};
  options.work_offsets_mm["G55"] = {-40.0, 0.0, -kGaugeHeightMm};
  options.tool_length_mm[1] = kToolLengthMm;
  options.tool_length_mm[2] = kToolLengthMm - 1.0;  // an H one millimetre short
  return options;
}

TEST(GcodeCoordinates, WorkOffsetAndToolLengthPutTheTipAtTheProgrammedWorkPoint) {
  // G54 G43 H1 Z5: machine Z = 5 + (-470) + 80 = -385; tip z = -385 + 420 = 35 = 30 + 5.
  const Toolpath path = gcode(
      "G54 G0 X1 Y2 Z100\n"
      "G43 H1 Z5\n"
      "G1 X3 F100\n"
      "G43 H2 Z5\n"   // H 1 mm shorter than the tool: the tip 1 mm lower
      "G49 G0 Z100\n"  // no compensation: the tip a whole tool length below the program
      "G55 G43 H1 G0 X0 Y0 Z0\n",
      table_machine_options());
  expect_tips(path, {{11, 22, 30 + 100 - 80},
                     {11, 22, 35},
                     {13, 22, 35},
                     {13, 22, 34},
                     {13, 22, 30 + 100 - 80},
                     {-40, 0, 0}});
}

TEST(GcodeCoordinates, OutsideTcpTheTableTurnsThePointAwayUnderTcpTheOffsetTurnsWithTheTable) {
  const ReaderOptions options = table_machine_options();
  // Machine axes X=11 Y=20 Z=-385 at C90: the tip in machine axes is (11, 20, 35); W turned by
  // 90 deg about +Z sees it at Rz(-90) (11, 20) = (20, -11).
  Toolpath path = gcode("G54 G43 H1 G0 X1 Y0 Z5 C90\n", options);
  expect_tips(path, {{20, -11, 35}});
  // Under G43.4 the program is in the work system on the table: the work zero in W is
  // machine_zero_W + G54 = (10, 20, 30), whatever C does.
  path = gcode("G54 G43.4 H1 G0 X1 Y0 Z5 C0\nG1 C90 F100\n", options);
  expect_tips(path, {{11, 20, 35}, {11, 20, 35}});
  // Without offsets G54 is the identity in both modes (the meaning before work offsets).
  ReaderOptions plain = options;
  plain.work_offsets_mm.clear();
  path = gcode("G54 G0 X0 Y0 Z-100 C0\nG43.4 G1 X1 Y2 Z3 C0 F100\n", plain);
  expect_tips(path, {{0, 0, 320}, {1, 2, 3}});
}

TEST(GcodeCoordinates, LeavingTcpTheMachineAxesAreWhereTheLastTipPutThem) {
  // The machine's inverse for its C angle: tip_B = Rz(C) tip_W, machine = tip_B - (0, 0, 420).
  ReaderOptions options = table_machine_options();
  options.tip_to_axis_words = [](const Eigen::Vector3d& tip_W_m, const Eigen::Vector3d&,
                                 const std::vector<std::pair<char, double>>& rotary_words) {
    double c_deg = 0.0;
    for (const auto& [letter, value] : rotary_words) {
      if (letter == 'C') c_deg = value;
    }
    const double c = c_deg * std::numbers::pi / 180.0;
    const Eigen::Vector3d tip_mm = tip_W_m * 1e3;
    return std::optional<Eigen::Vector3d>(Eigen::Vector3d(
        std::cos(c) * tip_mm.x() - std::sin(c) * tip_mm.y(),
        std::sin(c) * tip_mm.x() + std::cos(c) * tip_mm.y(),
        tip_mm.z() - (kGaugeHeightMm - kToolLengthMm)));
  };
  // Under G43.4 the tip is at (11, 20, 35) in W with C at 90; G49 leaves the machine axes at
  // (-20, 11, -385), so the retract `G0 Z100` (machine Z = 100 - 470 = -370, no tool length
  // now) lifts the tip straight above that point: (11, 20, 50). Keeping the program's X1 Y0 as
  // machine words would throw the tip to Rz(-90) (11, 20) = (20, -11).
  const std::string program = "G54 G43.4 H1 G0 X1 Y0 Z5 C0\nG1 C90 F100\nG49\nG0 Z100\n";
  expect_tips(gcode(program, options), {{11, 20, 35}, {11, 20, 35}, {11, 20, 50}});
  // Without the machine's inverse the program numbers are kept (the documented fallback).
  expect_tips(gcode(program, table_machine_options()), {{11, 20, 35}, {11, 20, 35}, {20, -11, 50}});
}

TEST(GcodeCoordinates, ReferenceReturnAndMachineCoordinates) {
  ReaderOptions options;
  options.work_offsets_mm["G54"] = {100.0, 50.0, -200.0};
  options.tool_length_mm[1] = 80.0;
  options.g28_reference_mm = {-300.0, -250.0, 0.0};
  options.g30_reference_mm = {0.0, 0.0, -10.0};
  // Without a machine the machine axes are W and the tip is the gauge point less H along Z.
  const Toolpath path = gcode(
      "G28 G91 Z0\n"       // Z to the reference; X Y unknown: no point yet
      "G90 G54 G0 X10 Y20\n"  // (110, 70) at machine Z 0
      "G43 Z5 H1\n"        // tip at work Z 5 = -195
      "G28 X50\n"          // via work X50 (machine 150) to machine X -300
      "G53 G0 Y-10\n"      // machine Y -10 for this block only
      "G0 X0 Y0\n"         // back in G54
      "G30 G91 Z0\n"       // Z to the second reference, machine -10: tip -90
      "G90 G53 G1 Z-20 F100\n",
      options);
  EXPECT_TRUE(path.warnings.empty());
  expect_tips(path, {{110, 70, 0},
                     {110, 70, -195},
                     {150, 70, -195},
                     {-300, 70, -195},
                     {-300, -10, -195},
                     {100, 50, -195},
                     {100, 50, -90},
                     {100, 50, -100}});
}

TEST(GcodeCoordinates, G53BeforeTheOtherAxesAreKnownAndG10ToolLengths) {
  ReaderOptions options;
  options.work_offsets_mm["G54"] = {100.0, 50.0, -200.0};
  // A Haas-style start: Z up in machine coordinates first, then X Y in the work system.
  const Toolpath path = gcode(
      "G53 G0 Z-5\n"
      "G54 X1 Y2\n"           // (101, 52) at machine Z -5
      "G10 L10 P7 R40\n"      // tool length 40 for H7
      "G43 H7 Z10\n",         // machine Z 10 - 200 + 40 = -150; tip -190
      options);
  EXPECT_TRUE(path.warnings.empty());
  expect_tips(path, {{101, 52, -5}, {101, 52, -190}});
}

TEST(GcodeCoordinates, LocalShiftsAndProgrammedOffsets) {
  const Toolpath path = gcode(
      "G0 X0 Y0 Z0\n"
      "G52 X10 Y5\n"
      "G0 X1 Y1\n"           // (11, 6)
      "G52 X0 Y0\n"
      "G92 X100\n"           // here (physical X 11) is now X100
      "G0 X101\n"            // physical 12
      "G92.1\n"
      "G0 X0\n"              // physical 0
      "G10 L2 P2 X20 Y30 Z-5\n"
      "G55 G0 X1 Y1 Z1\n"    // (21, 31, -4)
      "G91 G10 L2 P2 X5\n"   // incremental: G55 X becomes 25
      "G90 G0 X1\n"          // (26, 31, -4)
      "G10 L20 P3 X-7 Y0 Z0\n"
      "G54.1 P3 G0 X0 Y0 Z0\n",  // (-7, 0, 0)
      [] {
        ReaderOptions options;
        options.work_offsets_mm["G54"] = Eigen::Vector3d::Zero();
        return options;
      }());
  expect_tips(path, {{0, 0, 0},
                     {11, 6, 0},
                     {12, 6, 0},
                     {0, 6, 0},
                     {21, 31, -4},
                     {26, 31, -4},
                     {-7, 0, 0}});
}

TEST(GcodeCoordinates, G68RotatesTheProgramAboutItsCentre) {
  const Toolpath path = gcode(
      "G0 X0 Y0 Z0\n"
      "G68 X10 Y0 R90\n"
      "G1 X20 Y0 F100\n"  // (20, 0) turned 90 deg about (10, 0): (10, 10)
      "G91 X0 Y5\n"       // incremental +Y turned: -X
      "G90 G69\n"
      "G1 X20 Y0\n",
      {});
  expect_tips(path, {{0, 0, 0}, {10, 10, 0}, {5, 10, 0}, {20, 0, 0}});
}

TEST(GcodeArcs, WithinTheToleranceTheCentreMovesOntoTheBisector) {
  // Start (10, 0), end (0, 10.02), centre (0, 0): the radii differ by 0.02 mm, within
  // max(0.0283 mm, 0.1 %). The corrected centre lies on the bisector of start and end, moved
  // from the programmed one along the chord direction u by t = (|e-c|^2 - |s-c|^2) / (2 |e-s|).
  const Toolpath path = gcode("G0 X10 Y0 Z0\nG3 X0 Y10.02 I-10 J0 F100\n");
  const Eigen::Vector2d s(10.0, 0.0), e(0.0, 10.02);
  const Eigen::Vector2d u = (e - s).normalized();
  const double t = (e.squaredNorm() - s.squaredNorm()) / (2.0 * (e - s).norm());
  const Eigen::Vector2d c = t * u;
  const double r = (s - c).norm();
  ASSERT_GT(path.points.size(), 3u);
  for (std::size_t i = 1; i < path.points.size(); ++i) {
    const Eigen::Vector2d p = path.points[i].tip_W_m.head<2>() * 1e3;
    EXPECT_NEAR((p - c).norm(), r, 1e-9) << "point " << i;
  }
  expect_vector(path.points.back().tip_W_m * 1e3, {0.0, 10.02, 0.0}, 1e-12);

  // A tighter tolerance refuses it, saying by how much and which tolerance.
  ReaderOptions tight;
  tight.arc_radius_tolerance_mm = 0.001;
  const std::string message = gcode_error("G0 X10 Y0 Z0\nG3 X0 Y10.02 I-10 J0 F100\n", tight);
  EXPECT_NE(message.find("part.nc:2:1: 'G3'"), std::string::npos) << message;
  EXPECT_NE(message.find("differ by 0.02"), std::string::npos) << message;
  EXPECT_NE(message.find("tolerance of 0.01002 mm"), std::string::npos) << message;  // 0.1 % r
}

TEST(GcodeArcs, InchProgramsUseTheInchTolerance) {
  // 0.002 inch (0.0508 mm) off: beyond 0.0283 mm but within 0.002 sqrt 2 inch.
  const Toolpath path = gcode("G20 G0 X1 Y0 Z0\nG3 X0 Y1.002 I-1 J0 F10\n");
  expect_vector(path.points.back().tip_W_m * 1e3, {0.0, 1.002 * 25.4, 0.0}, 1e-9);
  const std::string message = gcode_error("G20 G0 X1 Y0 Z0\nG3 X0 Y1.004 I-1 J0 F10\n");
  EXPECT_NE(message.find("the larger of 0.002828 inch"), std::string::npos) << message;
}

TEST(GcodeArcs, AbsoluteArcCentresUnderG90_1) {
  const Toolpath absolute = gcode("G0 X10 Y0 Z0\nG90.1 G3 X0 Y10 I0 J0 F100\n");
  const Toolpath relative = gcode("G0 X10 Y0 Z0\nG91.1 G3 X0 Y10 I-10 J0 F100\n");
  ASSERT_EQ(absolute.points.size(), relative.points.size());
  for (std::size_t i = 0; i < absolute.points.size(); ++i) {
    expect_vector(absolute.points[i].tip_W_m, relative.points[i].tip_W_m, 1e-15);
  }
}

TEST(GcodeCycles, G81DrillsEachHoleAndReturnsToTheInitialLevelUnderG98) {
  // Fanuc / LinuxCNC G81: rapid to the hole in X Y, rapid to R, feed to Z, rapid out to the
  // initial level (G98) or R (G99).
  const Toolpath path = gcode(
      "G0 X0 Y0 Z50\n"
      "G98 G81 X10 Y20 Z-5 R2 F120\n"
      "X30\n"
      "G99 X40\n"
      "Y30\n"
      "G80\n"
      "G0 Z60\n");
  expect_tips(path, {{0, 0, 50},
                     {10, 20, 50}, {10, 20, 2}, {10, 20, -5}, {10, 20, 50},
                     {30, 20, 50}, {30, 20, 2}, {30, 20, -5}, {30, 20, 50},
                     {40, 20, 50}, {40, 20, 2}, {40, 20, -5}, {40, 20, 2},
                     {40, 30, 2}, {40, 30, -5}, {40, 30, 2},
                     {40, 30, 60}});
  // Feeds only on the drilling moves; every level is an exact stop.
  EXPECT_EQ(path.points[3].kind, MotionKind::linear);
  EXPECT_DOUBLE_EQ(path.points[3].feed_m_per_s, 120e-3 / 60.0);
  EXPECT_EQ(path.points[2].kind, MotionKind::rapid);
  EXPECT_EQ(path.points[3].corner_tolerance_m, 0.0);
  // G80 ends the cycle and its hole data: a new cycle needs its R again.
  const std::string message =
      gcode_error("G0 X0 Y0 Z50\nG81 X10 Z-5 R2 F120\nG80\nG81 X20 Z-5\n");
  EXPECT_NE(message.find("part.nc:4:1: 'G81': canned cycle without its R level"),
            std::string::npos)
      << message;
}

TEST(GcodeCycles, PeckCyclesG83AndG73) {
  ReaderOptions options;
  options.peck_clearance_mm = 0.5;
  options.peck_retract_mm = 0.25;
  // G83 Q3 from R2 to -5: pecks to -1, -4, -5; after each a rapid out to R and a rapid back to
  // 0.5 above the last depth.
  Toolpath path = gcode("G0 X0 Y0 Z10\nG83 Z-5 R2 Q3 F100\n", options);
  expect_tips(path, {{0, 0, 10}, {0, 0, 2}, {0, 0, -1}, {0, 0, 2}, {0, 0, -0.5}, {0, 0, -4},
                     {0, 0, 2}, {0, 0, -3.5}, {0, 0, -5}, {0, 0, 10}});
  // G73: the same depths, each followed by a back-off of 0.25.
  path = gcode("G0 X0 Y0 Z10\nG99 G73 Z-5 R2 Q3 F100\n", options);
  expect_tips(path, {{0, 0, 10}, {0, 0, 2}, {0, 0, -1}, {0, 0, -0.75}, {0, 0, -4},
                     {0, 0, -3.75}, {0, 0, -5}, {0, 0, 2}});
}

TEST(GcodeCycles, IncrementalRepeatsAndBoring) {
  // G91: R from the initial level (10 - 8 = 2), Z from R (2 - 7 = -5); K3 repeats the X step.
  Toolpath path = gcode("G0 X0 Y0 Z10\nG91 G99 G81 X10 Z-7 R-8 K3 F100\n");
  expect_tips(path, {{0, 0, 10}, {10, 0, 10}, {10, 0, 2}, {10, 0, -5}, {10, 0, 2},
                     {20, 0, 2}, {20, 0, -5}, {20, 0, 2},
                     {30, 0, 2}, {30, 0, -5}, {30, 0, 2}});
  // G85: feed in and feed out to R, then to the initial level under G98.
  path = gcode("G0 X0 Y0 Z10\nG85 Z-5 R2 F100\n");
  expect_tips(path, {{0, 0, 10}, {0, 0, 2}, {0, 0, -5}, {0, 0, 2}, {0, 0, 10}});
  EXPECT_EQ(path.points[3].kind, MotionKind::linear);
  EXPECT_EQ(path.points[4].kind, MotionKind::rapid);
}

TEST(GcodeCycles, G76FineBoringShiftsOffTheWallAtTheBottom) {
  // Fanuc G76: feed to the bottom, shift by Q (here along -Y, the machine's setting), rapid
  // out, shift back onto the hole's axis.
  ReaderOptions options;
  options.fine_boring_shift_direction = {0.0, -2.0};
  const Toolpath path = gcode("G0 X0 Y0 Z10\nG76 X5 Y5 Z-5 R2 Q0.5 P100 F100\n", options);
  expect_tips(path, {{0, 0, 10}, {5, 5, 10}, {5, 5, 2}, {5, 5, -5}, {5, 4.5, -5},
                     {5, 4.5, 10}, {5, 5, 10}});
  EXPECT_EQ(path.points[3].kind, MotionKind::linear);
  EXPECT_EQ(path.points[4].kind, MotionKind::rapid);
}

TEST(GcodeModes, CornerTolerancesAndToolNumbers) {
  ReaderOptions options;
  options.contouring_tolerance_m = 7e-6;
  const Toolpath path = gcode(
      "T1 M6\n"
      "G0 X0 Y0 Z0\n"
      "G61 G1 X1 F100\n"
      "G64 P0.02 Q0.01 X2\n"  // LinuxCNC Q: no geometry
      "G64 X3\n"
      "G9 X4\n"
      "G5.1 Q1 R5 X5\n"
      "T2\n"
      "G5.1 Q0 X6\n"
      "M6 G05 P10000 X7\n"
      "G187 P2 E0.005 X8\n"
      "G20 G64 P0.001 X0.5\n"
      "G21 G61 G2 X0 Y0 I-6.35 J0\n",
      options);
  ASSERT_GE(path.points.size(), 13u);
  const auto& p = path.points;
  EXPECT_EQ(p[0].tool_number, 1);
  EXPECT_TRUE(std::isnan(p[0].corner_tolerance_m));
  EXPECT_EQ(p[1].corner_tolerance_m, 0.0);
  EXPECT_DOUBLE_EQ(p[2].corner_tolerance_m, 0.02e-3);
  EXPECT_TRUE(std::isnan(p[3].corner_tolerance_m));
  EXPECT_EQ(p[4].corner_tolerance_m, 0.0);   // G9: this block only
  EXPECT_DOUBLE_EQ(p[5].corner_tolerance_m, 7e-6);
  EXPECT_EQ(p[5].tool_number, 1);
  EXPECT_TRUE(std::isnan(p[6].corner_tolerance_m));
  EXPECT_EQ(p[6].tool_number, 1);  // T2 preselects; M6 changes
  EXPECT_DOUBLE_EQ(p[7].corner_tolerance_m, 7e-6);
  EXPECT_EQ(p[7].tool_number, 2);
  EXPECT_DOUBLE_EQ(p[8].corner_tolerance_m, 0.005e-3);
  EXPECT_DOUBLE_EQ(p[9].corner_tolerance_m, 0.001 * 25.4e-3);
  // The arc under G61: no stop inside it, an exact stop at its end.
  for (std::size_t i = 10; i + 1 < p.size(); ++i) EXPECT_TRUE(std::isnan(p[i].corner_tolerance_m));
  EXPECT_EQ(p.back().corner_tolerance_m, 0.0);
}

// A program as a Fusion 360 Fanuc post writes it (preamble, tool change, work offset, tool
// length on the approach, 3-decimal arcs, return to the reference, end).
constexpr const char* kPostedProgram = R"(%
O1001 (POCKET)
(T1 D=6. CR=0. - ZMIN=-2. - FLAT END MILL)
N10 G90 G94 G17 G49 G40 G80
N12 G08 P1
N15 G21
N20 G28 G91 Z0.
N25 G90
(2D CONTOUR1)
N30 T1 M6
N35 S5000 M3
N40 G54
N45 M8
N50 G0 X10. Y0.
N55 G43 Z15. H1
N60 Z5.
N65 G1 Z-2. F300.
N70 X20.
N75 G3 X26.665 Y6.667 I-0.004 J6.667 F1000.
N80 G1 Y10.
N85 G0 Z15.
N90 M9
N95 G28 G91 Z0.
N100 G90
N105 M30
%
)";

TEST(GcodePosted, AFusionStyleProgramGivesTheTipPositionsOfTheControl) {
  // The work zero at (100, 200, -300) in W; H1 = the tool's 80 mm. Through the table machine:
  // G54 in machine axes = (100, 200, -300 - 500).
  ReaderOptions options = table_machine_options();
  options.work_offsets_mm["G54"] = {100.0, 200.0, -300.0 - kGaugeHeightMm};
  const Toolpath path = gcode(kPostedProgram, options);
  EXPECT_TRUE(path.warnings.empty());
  const auto tips = tips_mm(path);
  ASSERT_GE(tips.size(), 8u);
  // N50: machine Z still at the reference 0 (G28): tip at 0 + 500 - 80.
  expect_vector(tips[0], {110, 200, 420}, 1e-9);
  expect_vector(tips[1], {110, 200, -285}, 1e-9);  // N55: work Z15
  expect_vector(tips[2], {110, 200, -295}, 1e-9);
  expect_vector(tips[3], {110, 200, -302}, 1e-9);
  expect_vector(tips[4], {120, 200, -302}, 1e-9);
  // The arc ends where programmed; its radii (6.667 and 6.669) differ by 2 um, beyond the old
  // 1 um check and within the control's tolerance.
  const std::size_t arc_end = tips.size() - 4;
  expect_vector(tips[arc_end], {126.665, 206.667, -302}, 1e-9);
  expect_vector(tips[arc_end + 1], {126.665, 210, -302}, 1e-9);
  expect_vector(tips[arc_end + 2], {126.665, 210, -285}, 1e-9);
  expect_vector(tips.back(), {126.665, 210, 420}, 1e-9);  // N95: Z to the reference
  for (const PathPoint& point : path.points) EXPECT_EQ(point.tool_number, 1);
}

}  // namespace
}  // namespace vmsim::toolpath

namespace vmsim::toolpath {
namespace {

// Found by the posted corpus (tests/data/posted): Fusion 360 posts `G80` then `Z15.`, and
// Mastercam ends 4- and 5-axis programs with `G28 X0. Y0. A0.`.
TEST(GcodePostedForms, AfterG80TheMotionModeBeforeTheCycleIsBack) {
  const Toolpath path = parse_gcode(
      "G21 G90 G17\nG0 X0 Y0 Z10\nG98 G81 X5 Y0 Z-2 R2 F100\nX10\nG80\nZ15.\n", "drill.nc");
  const PathPoint& last = path.points.back();
  EXPECT_EQ(last.kind, MotionKind::rapid);  // the G0 before the cycle
  EXPECT_NEAR(last.tip_W_m.x(), 10e-3, 1e-12);
  EXPECT_NEAR(last.tip_W_m.z(), 15e-3, 1e-12);
  // Without a motion mode before the cycle, an axis word after G80 is still an error.
  EXPECT_THROW(parse_gcode("G21 G90 G17 G98 G81 X5 Y0 Z-2 R2 F100\nG80\nZ15.\n", "drill.nc"), InputError);
}

TEST(GcodePostedForms, RotaryWordsInG28GoToTheIntermediateThenTheReference) {
  ReaderOptions options;
  // Machine axes X Y Z A: the pose turns the tool axis about X by A (a hand-made table).
  options.axis_words_to_pose = [](const std::vector<std::pair<char, double>>& words) {
    Eigen::Vector3d tip = Eigen::Vector3d::Zero();
    double a_deg = 0;
    for (const auto& [letter, value] : words) {
      if (letter == 'X') tip.x() = value * 1e-3;
      if (letter == 'Y') tip.y() = value * 1e-3;
      if (letter == 'Z') tip.z() = value * 1e-3;
      if (letter == 'A') a_deg = value;
    }
    const double a = a_deg * 3.14159265358979323846 / 180;
    return AxisWordPose{tip, Eigen::Vector3d(0, -std::sin(a), std::cos(a))};
  };
  options.g28_reference_mm = Eigen::Vector3d(0, 0, -1);
  options.rotary_reference_deg = {5.0, 0.0, 0.0};
  const Toolpath path =
      parse_gcode("G21 G90\nG0 X10 Y20 Z30 A30\nG28 X0. Y0. A0.\n", "end.nc", options);
  ASSERT_GE(path.points.size(), 3u);
  const PathPoint& via = path.points[path.points.size() - 2];
  const PathPoint& reference = path.points.back();
  EXPECT_NEAR(via.rotary_words_deg[0], 0.0, 1e-12);  // the intermediate A0.
  EXPECT_NEAR(via.tip_W_m.x(), 0.0, 1e-12);
  EXPECT_NEAR(via.tip_W_m.z(), 30e-3, 1e-12);         // Z not named: stays
  EXPECT_NEAR(reference.rotary_words_deg[0], 5.0, 1e-12);  // A's reference
  EXPECT_NEAR(reference.tip_W_m.z(), 30e-3, 1e-12);
}

TEST(GcodePostedForms, NxAndOtherPostExtensionsAreGcode) {
  for (const char* extension : {".ptp", ".eia", ".cnc"}) {
    const auto folder = std::filesystem::temp_directory_path() / "vmsim_posted_extension";
    std::filesystem::create_directories(folder);
    const auto file = folder / (std::string("program") + extension);
    std::ofstream(file) << "G21 G90\nG0 X1 Y2 Z3\nG1 X4 F100\n";
    EXPECT_EQ(read_toolpath(file.string()).points.size(), 2u) << extension;
    std::filesystem::remove_all(folder);
  }
}

}  // namespace
}  // namespace vmsim::toolpath

namespace vmsim::toolpath {
namespace {

// Found by the posted corpus: Mastercam posts `T1 M6` then `G0 G90 G54 X-20. Y0.` and only then
// `G43 H1 Z25.`; the Z of that first motion is where the tool change left it (the machine's
// home), not the work zero (which, without the tool length, put the tool 60 mm into the part).
TEST(GcodePostedForms, AnAxisNotProgrammedYetIsAtTheReferencePointWithASetUp) {
  ReaderOptions options;
  options.work_offsets_mm = {{"G54", Eigen::Vector3d(0, 0, -100)}};
  options.g28_reference_mm = Eigen::Vector3d(0, 0, 0);
  options.default_tool_length_mm = 50.0;
  const Toolpath path = parse_gcode("G21 G90 G54\nT1 M6\nG0 X10 Y20\nG43 H1 Z5\n", "start.nc", options);
  ASSERT_EQ(path.points.size(), 2u);
  EXPECT_NEAR(path.points[0].tip_W_m.z(), 0.0, 1e-12);  // the gauge point at machine Z0 (no G43 yet)
  EXPECT_NEAR(path.points[0].tip_W_m.x(), 10e-3, 1e-12);
  EXPECT_NEAR(path.points[1].tip_W_m.z(), -95e-3, 1e-12);  // the work zero + 5 mm
  ASSERT_FALSE(path.warnings.empty());
  EXPECT_NE(path.warnings.front().message.find("G28 reference point"), std::string::npos);
  // Without a set-up, the program's 0 as before.
  const Toolpath plain = parse_gcode("G21 G90\nG0 X10 Y20\n", "plain.nc");
  EXPECT_NEAR(plain.points[0].tip_W_m.z(), 0.0, 1e-12);
}

}  // namespace
}  // namespace vmsim::toolpath
