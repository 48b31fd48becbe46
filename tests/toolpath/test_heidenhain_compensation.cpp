// Heidenhain TNC radius compensation RL / RR / R0 (toolpath/src/heidenhain_reader.cpp through
// cutter_compensation.hpp): the pocket and outside square of test_cutter_compensation.cpp written
// as TNC programs against corners computed by hand (the geometry) and against the same program
// on an 840D (G41 / G42 with NORM: a reader written apart with the same entry rule and the same
// compensator, so it checks the reading: sides, entry, exit, which block owns which point);
// circles about CC, RND, CHF and CT between compensated elements, the TOOL CALL's DR, the R0
// exit and located errors.
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "plane_path_support.hpp"
#include "reader_test_support.hpp"
#include "vmsim/common/errors.hpp"
#include "vmsim/toolpath/heidenhain_reader.hpp"
#include "vmsim/toolpath/toolpath.hpp"

namespace vmsim::toolpath {
namespace {

using namespace test;  // input_error_of, the plane-path helpers

ReaderOptions with_radius(double radius_mm) {
  ReaderOptions options;
  options.cutter_radius_mm = {{1, radius_mm}};  // by T number, as the part file's tools give it
  options.tool_length_mm = {{1, 0.0}};
  return options;
}

Toolpath parse(const std::string& text, const ReaderOptions& options = with_radius(5.0)) {
  return parse_heidenhain(text, "t.h", options);
}

double distance_to_square(const Eigen::Vector2d& p) {
  return distance_to_polygon(p, {{0, 0}, {40, 0}, {40, 40}, {0, 40}});
}

/// The same tool-centre points, kinds and source lines.
void expect_same_points(const Toolpath& actual, const Toolpath& expected) {
  ASSERT_EQ(actual.points.size(), expected.points.size());
  for (std::size_t i = 0; i < actual.points.size(); ++i) {
    EXPECT_LT((actual.points[i].tip_W_m - expected.points[i].tip_W_m).norm(), 1e-12) << "point " << i;
    EXPECT_EQ(actual.points[i].kind, expected.points[i].kind) << "point " << i;
    EXPECT_EQ(line_of(actual, actual.points[i]), line_of(expected, expected.points[i])) << "point " << i;
  }
}

// --- The squares of test_cutter_compensation.cpp -----------------------------------------------

// Pocket 40 x 40, counter-clockwise, RL (tool left: inside), r = 5. The block with RL is the
// approach: it ends normal to the first side at its offset start (20, 5) (not LinuxCNC's tangent
// point of the G-code test, 20 + sqrt(15)); every inside corner is the intersection of the offset
// sides (35, 5), (35, 35), (5, 35), (5, 5) as for G41; the last side ends at its offset end
// (20, 5) and R0 goes from there to the programmed (20, 20). The 840D program with G41 (NORM)
// gives the same points.
TEST(HeidenhainCompensation, PocketWithRlIsTheG41Pocket) {
  const Toolpath path = parse(
      "0 BEGIN PGM P MM\n"            // 1
      "1 TOOL CALL 1 Z S1000\n"       // 2
      "2 L X+20 Y+20 Z+5 R0 FMAX\n"   // 3
      "3 L Z-2 F300\n"                // 4
      "4 L Y+0 RL\n"                  // 5
      "5 L X+40\n"                    // 6
      "6 L Y+40\n"                    // 7
      "7 L X+0\n"                     // 8
      "8 L Y+0\n"                     // 9
      "9 L X+20\n"                    // 10
      "10 L Y+20 R0\n"                // 11
      "11 L Z+5 FMAX\n"               // 12
      "12 END PGM P MM\n");
  expect_xy(end_of_line(path, 5), 20.0, 5.0);
  expect_xy(end_of_line(path, 6), 35.0, 5.0);
  expect_xy(end_of_line(path, 7), 35.0, 35.0);
  expect_xy(end_of_line(path, 8), 5.0, 35.0);
  expect_xy(end_of_line(path, 9), 5.0, 5.0);
  expect_xy(end_of_line(path, 10), 20.0, 5.0);
  expect_xy(end_of_line(path, 11), 20.0, 20.0);
  const std::vector<PathPoint> contour = points_of_lines(path, 6, 10);
  EXPECT_EQ(contour.size(), 5u);  // no corner arcs inside
  for (const PathPoint& point : contour) {
    EXPECT_NEAR(distance_to_square(xy_mm(point)), 5.0, kTight);
    EXPECT_NEAR(z_mm(point), -2.0, kTight);
    EXPECT_EQ(point.kind, MotionKind::linear);
  }
  EXPECT_NEAR(z_mm(path.points.back()), 5.0, kTight);
  EXPECT_EQ(path.points.back().kind, MotionKind::rapid);

  const Toolpath twin = parse_siemens(
      "G17 G71 G90 G94\nT1 M6\nG0 X20 Y20 Z5\nG1 Z-2 F300\nG41 X20 Y0\nX40\nY40\nX0\nY0\nX20\n"
      "G40 X20 Y20\nG0 Z5\nM30\n",
      "pocket.mpf", with_radius(5.0));
  expect_same_points(path, twin);
}

// The square outside, RR (tool right of the counter-clockwise contour): sides on y = -5, x = 45,
// y = 45, x = -5, each outside corner an arc of radius 5 about the corner (made by the block
// after it); the approach from (20, -20) ends at the first side's offset start (20, -5).
TEST(HeidenhainCompensation, OutsideSquareWithRrRollsAboutEachCorner) {
  const Toolpath path = parse(
      "BEGIN PGM P MM\n"           // 1
      "TOOL CALL 1 Z S1000\n"      // 2
      "L X+20 Y-20 Z+5 FMAX\n"     // 3
      "L Z-2 F300\n"               // 4
      "L Y+0 RR\n"                 // 5
      "L X+40\n"                   // 6
      "L Y+40\n"                   // 7
      "L X+0\n"                    // 8
      "L Y+0\n"                    // 9
      "L X+20\n"                   // 10
      "L Y-20 R0\n"                // 11
      "END PGM P MM\n");
  expect_xy(end_of_line(path, 5), 20.0, -5.0);
  expect_xy(end_of_line(path, 6), 40.0, -5.0);
  expect_xy(end_of_line(path, 7), 45.0, 40.0);
  expect_xy(end_of_line(path, 8), 0.0, 45.0);
  expect_xy(end_of_line(path, 9), -5.0, 0.0);
  expect_xy(end_of_line(path, 10), 20.0, -5.0);
  expect_xy(end_of_line(path, 11), 20.0, -20.0);
  const Eigen::Vector2d corner_of_line[] = {{40, 0}, {40, 40}, {0, 40}, {0, 0}};
  for (int line = 7; line <= 10; ++line) {
    const std::vector<PathPoint> points = points_of_lines(path, line, line);
    ASSERT_GE(points.size(), 3u) << "line " << line;
    for (std::size_t i = 0; i + 1 < points.size(); ++i) {
      EXPECT_NEAR((xy_mm(points[i]) - corner_of_line[line - 7]).norm(), 5.0, kTight) << "line " << line;
      EXPECT_EQ(points[i].kind, MotionKind::arc);
    }
    EXPECT_EQ(points.back().kind, MotionKind::linear);
  }
  for (const PathPoint& point : points_of_lines(path, 6, 10)) {
    EXPECT_NEAR(distance_to_square(xy_mm(point)), 5.0, kTight);
  }
  const Toolpath twin = parse_siemens(
      "G17 G71 G90 G94\nT1 M6\nG0 X20 Y-20 Z5\nG1 Z-2 F300\nG42 Y0\nX40\nY40\nX0\nY0\nX20\nG40 Y-20\nM30\n",
      "outside.mpf", with_radius(5.0));
  expect_same_points(path, twin);
}

// TOOL CALL's DR is a radius allowance: DR+1 on a 5 mm tool offsets by 6, so the pocket's
// corners are (34, 6) ...; incremental words are from the programmed points.
TEST(HeidenhainCompensation, ToolCallDrAddsToTheRadius) {
  const Toolpath path = parse(
      "BEGIN PGM P MM\nTOOL CALL 1 Z S1000 DR+1\nL X+20 Y+20 Z-2 FMAX\nL Y+0 RL F300\nL IX+20\nL IY+40\n"
      "L IX-40\nL IY-40\nL IX+20\nL IY+20 R0\n");
  expect_xy(end_of_line(path, 4), 20.0, 6.0);
  expect_xy(end_of_line(path, 5), 34.0, 6.0);
  expect_xy(end_of_line(path, 6), 34.0, 34.0);
  expect_xy(end_of_line(path, 7), 6.0, 34.0);
  expect_xy(end_of_line(path, 8), 6.0, 6.0);
  expect_xy(end_of_line(path, 9), 20.0, 6.0);
  expect_xy(end_of_line(path, 10), 20.0, 20.0);
}

// --- Circles about CC ------------------------------------------------------------------------

struct TncCircleCase {
  const char* side;       // RL / RR
  const char* direction;  // DR+ / DR-
  double offset_radius_mm;  // R = 20, r = 5: inside 15, outside 25
};

class TncCompensatedCircle : public ::testing::TestWithParam<TncCircleCase> {};

// A full circle C about CC (0, 0) from P = (20, 0), entered from the centre. Left of a
// counter-clockwise circle is its inside. The approach ends normal to the circle at P, at
// (R -+ r, 0); every point of the circle block is at R -+ r from the centre; R0 ends the circle
// at its offset end (the same point) and goes back to the centre.
TEST_P(TncCompensatedCircle, FollowsTheOffsetCircle) {
  const TncCircleCase& c = GetParam();
  const Toolpath path = parse(std::string("BEGIN PGM P MM\nTOOL CALL 1 Z S1000\nL X+0 Y+0 Z-2 FMAX\nCC X+0 Y+0\n") +
                              "L X+20 " + c.side + " F300\n" +  // 5
                              "C X+20 Y+0 " + c.direction + "\n" +  // 6
                              "L X+0 Y+0 R0\n");  // 7
  expect_xy(end_of_line(path, 5), c.offset_radius_mm, 0.0);
  const std::vector<PathPoint> circle = points_of_lines(path, 6, 6);
  ASSERT_GT(circle.size(), 100u);
  for (const PathPoint& point : circle) {
    EXPECT_NEAR(xy_mm(point).norm(), c.offset_radius_mm, kTight) << xy_mm(point).transpose();
    EXPECT_EQ(point.kind, MotionKind::arc);
  }
  // The direction: the first point after the start is above the X axis for DR+.
  const bool ccw = std::string(c.direction) == "DR+";
  EXPECT_GT((ccw ? 1.0 : -1.0) * xy_mm(circle.front()).y(), 0.0);
  expect_xy(end_of_line(path, 6), c.offset_radius_mm, 0.0);
  expect_xy(end_of_line(path, 7), 0.0, 0.0);
}

INSTANTIATE_TEST_SUITE_P(Sides, TncCompensatedCircle,
                         ::testing::Values(TncCircleCase{"RL", "DR+", 15.0}, TncCircleCase{"RR", "DR+", 25.0},
                                           TncCircleCase{"RL", "DR-", 25.0}, TncCircleCase{"RR", "DR-", 15.0}));

// --- RND, CHF and CT between compensated elements ----------------------------------------------

// The pocket with RND R8 at (40, 0): the rounding arc about (32, 8) from (32, 0) to (40, 8);
// inside (RL) its offset has radius 8 - 5 = 3: the bottom side ends at (32, 5), the rounding arc
// runs on radius 3 about (32, 8) to (35, 8) (tangent to both offset sides), the right side goes on
// to (35, 35); the top side, the last before R0, ends at its offset end (0, 35).
TEST(HeidenhainCompensation, RoundingBetweenCompensatedLines) {
  const Toolpath path = parse(
      "BEGIN PGM P MM\nTOOL CALL 1 Z S1000\nL X+20 Y+20 Z-2 FMAX\n"
      "L Y+0 RL F300\n"  // 4
      "L X+40\n"         // 5
      "RND R8\n"         // 6
      "L Y+40\n"         // 7
      "L X+0\n"          // 8
      "L Y+20 R0\n");    // 9
  expect_xy(end_of_line(path, 4), 20.0, 5.0);
  expect_xy(end_of_line(path, 5), 32.0, 5.0);
  const std::vector<PathPoint> rounding = points_of_lines(path, 6, 6);
  ASSERT_GE(rounding.size(), 2u);
  for (const PathPoint& point : rounding) {
    EXPECT_NEAR((xy_mm(point) - Eigen::Vector2d(32, 8)).norm(), 3.0, kTight);
    EXPECT_EQ(point.kind, MotionKind::arc);
  }
  expect_xy(end_of_line(path, 6), 35.0, 8.0);
  expect_xy(end_of_line(path, 7), 35.0, 35.0);
  expect_xy(end_of_line(path, 8), 0.0, 35.0);
  expect_xy(end_of_line(path, 9), 0.0, 20.0);
}

// CHF 4 at (40, 0): the chamfer from (36, 0) to (40, 4), the line x - y = 36. Its inside offset
// is x - y = 36 - 5 sqrt(2); it meets the bottom's offset y = 5 at x = 41 - 5 sqrt(2) and the
// right side's offset x = 35 at y = 5 sqrt(2) - 1 (both concave corners).
TEST(HeidenhainCompensation, ChamferBetweenCompensatedLines) {
  const Toolpath path = parse(
      "BEGIN PGM P MM\nTOOL CALL 1 Z S1000\nL X+20 Y+20 Z-2 FMAX\n"
      "L Y+0 RL F300\nL X+40\nCHF 4\nL Y+40\nL X+0 R0\n");
  const double s2 = std::sqrt(2.0);
  expect_xy(end_of_line(path, 5), 41.0 - 5.0 * s2, 5.0);
  expect_xy(end_of_line(path, 6), 35.0, 5.0 * s2 - 1.0);
  EXPECT_EQ(points_of_lines(path, 6, 6).size(), 1u);
  expect_xy(end_of_line(path, 7), 35.0, 40.0);  // R0: the right side's offset end
  expect_xy(end_of_line(path, 8), 0.0, 40.0);
}

// CT after a line: from (20, 0) tangent to +X to (40, 20) is the quarter circle about (20, 20),
// radius 20, counter-clockwise. RL (inside): the line on y = 5 ends at (20, 5) (a tangent joint),
// the arc runs on radius 15 to (35, 20), the line up x = 40 continues on x = 35. CR with R+20
// DR+ is the same arc.
TEST(HeidenhainCompensation, TangentArcCtAndCr) {
  for (const std::string arc_block : {"CT X+40 Y+20\n", "CR X+40 Y+20 R+20 DR+\n"}) {
    SCOPED_TRACE(arc_block);
    const Toolpath path = parse(
        "BEGIN PGM P MM\nTOOL CALL 1 Z S1000\nL X-10 Y+10 Z-2 FMAX\n"
        "L X+0 Y+0 RL F300\n"  // 4: normal to the next line: (0, 5)
        "L X+20\n" +           // 5
        arc_block +            // 6
        "L Y+40\n"             // 7
        "L X+50 Y+50 R0\n");   // 8
    expect_xy(end_of_line(path, 4), 0.0, 5.0);
    expect_xy(end_of_line(path, 5), 20.0, 5.0);
    const std::vector<PathPoint> arc = points_of_lines(path, 6, 6);
    ASSERT_GE(arc.size(), 3u);
    for (const PathPoint& point : arc) EXPECT_NEAR((xy_mm(point) - Eigen::Vector2d(20, 20)).norm(), 15.0, kTight);
    expect_xy(end_of_line(path, 6), 35.0, 20.0);
    expect_xy(end_of_line(path, 7), 35.0, 40.0);
    expect_xy(end_of_line(path, 8), 50.0, 50.0);
  }
}

// A plunge inside the contour (L Z only) keeps the offset; R0 on a Z-only block goes from the
// last compensated point to the programmed point below the new Z (the TNC's R0: uncompensated).
TEST(HeidenhainCompensation, ZMovesKeepTheOffsetAndR0OnZAlone) {
  const Toolpath path = parse(
      "BEGIN PGM P MM\nTOOL CALL 1 Z S1000\nL X+20 Y+20 Z+5 FMAX\n"
      "L Y+0 RL F300\n"  // 4
      "L Z-2\n"          // 5
      "L X+40\n"         // 6
      "L Y+40\n"         // 7
      "L Z+5 R0 FMAX\n");  // 8
  expect_xy(end_of_line(path, 4), 20.0, 5.0);
  expect_xy(end_of_line(path, 5), 20.0, 5.0);
  EXPECT_NEAR(z_mm(points_of_lines(path, 5, 5).back()), -2.0, kTight);
  expect_xy(end_of_line(path, 6), 35.0, 5.0);
  expect_xy(end_of_line(path, 7), 35.0, 40.0);
  expect_xy(end_of_line(path, 8), 40.0, 40.0);
  EXPECT_NEAR(z_mm(path.points.back()), 5.0, kTight);
}

// RL left on at the end: ended as by R0 there, with a warning.
TEST(HeidenhainCompensation, StillOnAtTheEndIsEndedWithAWarning) {
  const Toolpath path = parse("BEGIN PGM P MM\nTOOL CALL 1 Z\nL X+20 Y+20 Z-2 FMAX\nL Y+0 RL F300\nL X+40\nEND PGM P MM\n");
  expect_xy(end_of_line(path, 5), 40.0, 5.0);
  bool warned = false;
  for (const auto& warning : path.warnings) warned = warned || warning.message.find("no R0") != std::string::npos;
  EXPECT_TRUE(warned);
}

// --- Errors ------------------------------------------------------------------------------------

TEST(HeidenhainCompensation, ErrorsAreLocated) {
  const std::string head = "BEGIN PGM P MM\nTOOL CALL 1 Z S1000\nL X+20 Y+20 Z-2 FMAX\n";  // 1-3
  const auto error = [](const std::string& program, const ReaderOptions& options = with_radius(5.0)) {
    return input_error_of([&] { parse(program, options); });
  };
  std::string e = error(head + "L Y+0 RL F300\nL X+40\n", ReaderOptions{});
  EXPECT_NE(e.find("t.h:4:7: 'RL': RL / RR need the tool radius: none for T1 (the tool table has none"),
            std::string::npos) << e;
  e = error(head + "L Z+0 FMAX M128\nL Y+0 RL F300\n");
  EXPECT_NE(e.find("t.h:5:7: 'RL': radius compensation RL / RR under M128"), std::string::npos) << e;
  e = error(head + "L Y+0 RL F300 M128\n");
  EXPECT_NE(e.find("t.h:4:7: 'RL': radius compensation RL / RR under M128"), std::string::npos) << e;
  e = error(head + "L Y+0 RL F300\nL X+40 M128\n");
  EXPECT_NE(e.find("t.h:5:1: 'L': M128 under radius compensation"), std::string::npos) << e;
  e = error(head + "PLANE SPATIAL SPA+0 SPB+30 SPC+0 STAY\nL Y+0 RR F300\n");
  EXPECT_NE(e.find("t.h:5:7: 'RR': radius compensation RL / RR under M128 / FUNCTION TCPM or in a tilted"),
            std::string::npos) << e;
  e = error(head + "CC X+0 Y+0\nC X+20 Y+0 DR+ RL F300\n");
  EXPECT_NE(e.find("t.h:5:16: 'RL': RL / RR on C: the block that starts radius compensation"), std::string::npos)
      << e;
  // Each element is held back one block (for an RND after it): its error names its own line.
  // An inside arc of radius 4 under a tool of radius 5:
  e = error(head + "L X+20 Y+0 RL F300\nCC X+16 Y+0\nC X+12 Y+0 DR+\nL X+0\nL Y+20\n");
  EXPECT_NE(e.find("t.h:6:1: 'C X+12 Y+0 DR+': "), std::string::npos) << e;
  // A slot 8 wide under a tool of 10: the bottom's offset runs backwards, found (as in the G-code
  // reader) when the side after it comes; that side is held until line 7 and named at line 6.
  e = error(head + "L X+4 Y+0 RL F300\nL X+8\nL Y+40\nL X+0\nL Y+0\nL X+4 R0\n");
  EXPECT_NE(e.find("t.h:6:1: 'L Y+40': cutter compensation gouges"), std::string::npos) << e;
  e = error(head + "L Y+0 RL F300\nL X+40\nL Y+40 RR\n");
  EXPECT_NE(e.find("t.h:6:8: 'RR': radius compensation RL is on: cancel it (R0)"), std::string::npos) << e;
  e = error(head + "L Y+0 RL F300\nTOOL CALL 2 Z\n");
  EXPECT_NE(e.find("t.h:5:1: 'TOOL': a TOOL CALL under radius compensation"), std::string::npos) << e;
  e = error(head + "L Y+0 RL F300\nCYCL DEF 7.0 NULLPUNKT\nCYCL DEF 7.1 X+5\n");
  EXPECT_NE(e.find("t.h:6:"), std::string::npos) << e;
  EXPECT_NE(e.find("a datum shift under radius compensation"), std::string::npos) << e;
  e = error(head + "L Y+0 RL F300\nL X+40\nCC X+40 Y+20\nC X+40 Y+40 DR+ R0\n");
  EXPECT_NE(e.find("t.h:7:17: 'R0': the block with R0 leaves the contour on a straight line"), std::string::npos)
      << e;
  e = error(head + "L Y+0 RL F300\nL R0 FMAX\n");
  EXPECT_NE(e.find("t.h:5:3: 'R0': RL / RR / R0 on a block without a point"), std::string::npos) << e;
  EXPECT_EQ(error(head + "L R0 FMAX\nL X+0 F300\n"), "");  // R0 alone without compensation: nothing to do
  e = error(head + "L Y+0 RL F300\nL X+40\nL Y+40 A+10\n");
  EXPECT_NE(e.find("t.h:6:1: 'L': rotary axis words or a tool vector under radius compensation"), std::string::npos) << e;
}

}  // namespace
}  // namespace vmsim::toolpath
