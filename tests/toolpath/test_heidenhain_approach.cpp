// Heidenhain TNC APPR / DEP (toolpath/src/heidenhain_reader.cpp): the approach and departure
// forms LT, LN, CT and LCT on the outside of the square (0, 0)-(40, 40), run clockwise from the first
// contour point PA = (0, 0) with RL (the tool outside), tool radius r = 5. The expected tool-centre
// points are worked out by hand from the TNC 640 manual's geometry (PS, PH, PA, PE, PN):
//  - first side (0, 0) -> (0, 40): tangent t = (0, 1), the compensation side (left) n = (-1, 0);
//  - last side (40, 0) -> (0, 0): tangent t = (-1, 0), n = (0, -1); its offset end (0, -5).
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <cmath>
#include <string>
#include <vector>

#include "plane_path_support.hpp"
#include "reader_test_support.hpp"
#include "vmsim/toolpath/heidenhain_reader.hpp"
#include "vmsim/toolpath/toolpath.hpp"

namespace vmsim::toolpath {
namespace {

using namespace test;

ReaderOptions with_radius(double radius_mm) {
  ReaderOptions options;
  options.cutter_radius_mm = {{1, radius_mm}};
  options.tool_length_mm = {{1, 0.0}};
  return options;
}

Toolpath parse(const std::string& text) { return parse_heidenhain(text, "t.h", with_radius(5.0)); }

/// PS = (-30, -30) at Z-2, then `appr` on line 5, the square on lines 6-9, `dep` on line 10.
std::string square(const std::string& appr, const std::string& dep) {
  return "0 BEGIN PGM P MM\n"              // 1
         "1 TOOL CALL 1 Z S1000\n"         // 2
         "2 L X-30 Y-30 Z+5 R0 FMAX\n"     // 3
         "3 L Z-2 F300\n"                  // 4
         "4 " + appr + "\n"                // 5
         "5 L Y+40\n"                      // 6
         "6 L X+40\n"                      // 7
         "7 L Y+0\n"                       // 8
         "8 L X+0\n"                       // 9
         "9 " + dep + "\n"                 // 10
         "10 L Z+5 FMAX\n"                 // 11
         "11 END PGM P MM\n";
}

/// The compensated square itself (the lines between APPR and DEP): as with L ... RL.
void expect_square(const Toolpath& path) {
  expect_xy(end_of_line(path, 6), -5.0, 40.0);
  expect_xy(end_of_line(path, 7), 40.0, 45.0);
  expect_xy(end_of_line(path, 8), 45.0, 0.0);
  expect_xy(end_of_line(path, 9), 0.0, -5.0);
}

// APPR LT: PH = PA - LEN t = (0, -15); the tool centre goes from PS to PH + r n = (-5, -15), then
// along t to PA + r n = (-5, 0). DEP LT: PN = PE + LEN t = (-12, 0), tool centre (-12, -5).
TEST(HeidenhainApproach, StraightLineTangential) {
  const Toolpath path = parse(square("APPR LT X+0 Y+0 LEN15 RL F200", "DEP LT LEN12 F400"));
  const std::vector<PathPoint> appr = points_of_lines(path, 5, 5);
  ASSERT_EQ(appr.size(), 2u);
  expect_xy(xy_mm(appr[0]), -5.0, -15.0);
  expect_xy(xy_mm(appr[1]), -5.0, 0.0);
  EXPECT_NEAR(z_mm(appr[0]), -2.0, 1e-9);
  EXPECT_NEAR(appr[1].feed_m_per_s, 0.2 / 60.0, 1e-12);
  expect_square(path);
  const std::vector<PathPoint> dep = points_of_lines(path, 10, 10);
  ASSERT_FALSE(dep.empty());
  expect_xy(xy_mm(dep.back()), -12.0, -5.0);
  EXPECT_NEAR(dep.back().feed_m_per_s, 0.4 / 60.0, 1e-12);
  // Compensation is off after DEP: the retract stays at PN's tool centre.
  expect_xy(end_of_line(path, 11), -12.0, -5.0);
}

// APPR LN: the tool centre at PH = PA + (LEN + r) n = (-15, 0), then perpendicular to PA + r n.
// With Z in APPR: to PH in the plane (at PS's Z+5), then down to Z-2 there. DEP LN: from (0, -5)
// to PE + (LEN + r) n = (0, -15), then up to DEP's Z+5.
TEST(HeidenhainApproach, StraightLinePerpendicularWithDepth) {
  std::string program = square("APPR LN X+0 Y+0 Z-2 LEN10 RL F200", "DEP LN LEN10 Z+5 F400");
  program.replace(program.find("3 L Z-2 F300"), 12, "3 L Z+5 F300");
  const Toolpath path = parse(program);
  const std::vector<PathPoint> appr = points_of_lines(path, 5, 5);
  ASSERT_EQ(appr.size(), 3u);
  expect_xy(xy_mm(appr[0]), -15.0, 0.0);
  EXPECT_NEAR(z_mm(appr[0]), 5.0, 1e-9);
  expect_xy(xy_mm(appr[1]), -15.0, 0.0);
  EXPECT_NEAR(z_mm(appr[1]), -2.0, 1e-9);
  expect_xy(xy_mm(appr[2]), -5.0, 0.0);
  EXPECT_NEAR(z_mm(appr[2]), -2.0, 1e-9);
  expect_square(path);
  const std::vector<PathPoint> dep = points_of_lines(path, 10, 10);
  ASSERT_EQ(dep.size(), 2u);
  expect_xy(xy_mm(dep[0]), 0.0, -15.0);
  EXPECT_NEAR(z_mm(dep[0]), -2.0, 1e-9);
  expect_xy(xy_mm(dep[1]), 0.0, -15.0);
  EXPECT_NEAR(z_mm(dep[1]), 5.0, 1e-9);
}

// APPR CT, RL with R > 0: counter-clockwise, the arc's centre R to the left of t at PA:
// C = (-10, 0); PH = C + rotated(PA - C, -90 deg) = (-10, -10). The tool on the arc's inside:
// radius R - r = 5, from (-10, -5) to (-5, 0). DEP CT, RL, R > 0: counter-clockwise from PE,
// C = (0, -10), PN = C + rotated(PE - C, +90 deg) = (-10, -10); tool centre radius 5 from (0, -5)
// to (-5, -10).
TEST(HeidenhainApproach, CircularArcTangential) {
  const Toolpath path = parse(square("APPR CT X+0 Y+0 CCA90 R+10 RL F200", "DEP CT CCA90 R+10 F400"));
  const std::vector<PathPoint> appr = points_of_lines(path, 5, 5);
  ASSERT_GE(appr.size(), 3u);
  expect_xy(xy_mm(appr[0]), -10.0, -5.0);
  expect_xy(xy_mm(appr.back()), -5.0, 0.0);
  for (std::size_t i = 1; i < appr.size(); ++i) {
    EXPECT_NEAR((xy_mm(appr[i]) - Eigen::Vector2d(-10.0, 0.0)).norm(), 5.0, 1e-9) << i;
    EXPECT_LE(xy_mm(appr[i]).x(), -5.0 + 1e-9) << i;  // the quarter left of and below PA
  }
  expect_square(path);
  const std::vector<PathPoint> dep = points_of_lines(path, 10, 10);
  ASSERT_GE(dep.size(), 2u);
  expect_xy(xy_mm(dep.back()), -5.0, -10.0);
  for (const PathPoint& p : dep) EXPECT_NEAR((xy_mm(p) - Eigen::Vector2d(0.0, -10.0)).norm(), 5.0, 1e-9);
}

// RL with R < 0: clockwise, from the workpiece side: C = PA - 10 n... = (10, 0) (inside the
// square), PH = C + rotated(PA - C, +90 deg) = (10, -10); the tool on the arc's outside, radius
// |R| + r = 15: from (10, -15) to (-5, 0).
TEST(HeidenhainApproach, CircularArcNegativeRadiusTurnsTheOtherWay) {
  const Toolpath path = parse(square("APPR CT X+0 Y+0 CCA90 R-10 RL F200", "DEP LT LEN12 F400"));
  const std::vector<PathPoint> appr = points_of_lines(path, 5, 5);
  ASSERT_GE(appr.size(), 3u);
  expect_xy(xy_mm(appr[0]), 10.0, -15.0);
  expect_xy(xy_mm(appr.back()), -5.0, 0.0);
  for (std::size_t i = 1; i < appr.size(); ++i) {
    EXPECT_NEAR((xy_mm(appr[i]) - Eigen::Vector2d(10.0, 0.0)).norm(), 15.0, 1e-9) << i;
  }
}

// RR mirrors RL: the square run counter-clockwise from (0, 0) to (40, 0) first has the tool
// outside on the right, n = (0, -1); APPR LT LEN15: PH = (-15, 0), tool (-15, -5) then (0, -5).
TEST(HeidenhainApproach, RightCompensation) {
  const Toolpath path = parse(
      "BEGIN PGM P MM\nTOOL CALL 1 Z S1000\nL X-30 Y-30 Z-2 R0 FMAX\n"  // 1-3
      "APPR LT X+0 Y+0 LEN15 RR F200\n"                                 // 4
      "L X+40\nL Y+40\nL X+0\nL Y+0\n"                                  // 5-8
      "DEP LN LEN5 F400\nEND PGM P MM\n");                              // 9
  const std::vector<PathPoint> appr = points_of_lines(path, 4, 4);
  ASSERT_EQ(appr.size(), 2u);
  EXPECT_EQ(appr[0].kind, MotionKind::rapid);  // to PH as the motion before APPR: FMAX
  expect_xy(xy_mm(appr[0]), -15.0, -5.0);
  expect_xy(xy_mm(appr[1]), 0.0, -5.0);
  expect_xy(end_of_line(path, 5), 40.0, -5.0);
  // Last side (0, 40) -> (0, 0): t = (0, -1), right side n = (-1, 0); PN = PE + (5 + 5) n.
  expect_xy(end_of_line(path, 9), -10.0, 0.0);
}

// APPR LCT: the arc of radius R = 10 tangent to the contour at PA from the compensation side,
// C = PA + R n = (-10, 0); the tool centre on its inside, radius R - r = 5. From PS = (-10, -10)
// (10 from C) the tangent touches that circle alpha = acos(5 / 10) = 60 deg from C -> PS, on the
// side that goes on counter-clockwise (RL): at -90 + 60 = -30 deg, PH = (-10 + 5 cos 30, -2.5);
// then the arc (30 deg) to PA + r n = (-5, 0).
// DEP LCT X-20 Y-10 R+10: C = PE + R n = (0, -10), the tool from (0, -5) counter-clockwise on
// radius 5 until the tangent to PN = (-20, -10): alpha = acos(5 / 20), cos = 1/4, the point at
// 180 deg - alpha: (-1.25, -10 + 5 sqrt(15) / 4); then the line to PN.
TEST(HeidenhainApproach, LineThenTangentialArc) {
  const Toolpath path = parse(
      "BEGIN PGM P MM\nTOOL CALL 1 Z S1000\nL X-10 Y-10 Z-2 R0 FMAX\n"  // 1-3
      "APPR LCT X+0 Y+0 R+10 RL F200\n"                                 // 4
      "L Y+40\nL X+40\nL Y+0\nL X+0\n"                                  // 5-8
      "DEP LCT X-20 Y-10 R+10 F400\nEND PGM P MM\n");                   // 9
  const std::vector<PathPoint> appr = points_of_lines(path, 4, 4);
  ASSERT_GE(appr.size(), 3u);
  expect_xy(xy_mm(appr[0]), -10.0 + 2.5 * std::sqrt(3.0), -2.5);
  expect_xy(xy_mm(appr.back()), -5.0, 0.0);
  for (const PathPoint& p : appr) EXPECT_NEAR((xy_mm(p) - Eigen::Vector2d(-10.0, 0.0)).norm(), 5.0, 1e-9);
  expect_xy(end_of_line(path, 5), -5.0, 40.0);
  const std::vector<PathPoint> dep = points_of_lines(path, 9, 9);
  ASSERT_GE(dep.size(), 2u);
  expect_xy(xy_mm(dep[dep.size() - 2]), -1.25, -10.0 + 1.25 * std::sqrt(15.0));
  expect_xy(xy_mm(dep.back()), -20.0, -10.0);
  for (std::size_t i = 0; i + 1 < dep.size(); ++i) {
    EXPECT_NEAR((xy_mm(dep[i]) - Eigen::Vector2d(0.0, -10.0)).norm(), 5.0, 1e-9) << i;
  }
}

TEST(HeidenhainApproach, ErrorsAreLocated) {
  const std::string head = "BEGIN PGM P MM\nTOOL CALL 1 Z S1000\nL X-30 Y-30 Z-2 FMAX\n";  // 1-3
  const std::string contour = "L Y+40\nL X+40\nL Y+0\nL X+0\n";
  const auto error = [](const std::string& program) { return input_error_of([&] { parse(program); }); };
  std::string e = error(head + "APPR LT X+0 Y+0 RL F300\n" + contour);
  EXPECT_NE(e.find("t.h:4:6: 'LT': APPR LT needs the length LEN"), std::string::npos) << e;
  e = error(head + "APPR LN X+0 Y+0 LEN10 F300\n" + contour);
  EXPECT_NE(e.find("t.h:4:6: 'LN': APPR LN needs the radius compensation RL or RR"), std::string::npos) << e;
  e = error(head + "APPR CT X+0 Y+0 R+10 RL F300\n" + contour);
  EXPECT_NE(e.find("t.h:4:6: 'CT': APPR CT needs the centre angle CCA"), std::string::npos) << e;
  e = error(head + "APPR CT X+0 Y+0 CCA90 RL F300\n" + contour);
  EXPECT_NE(e.find("t.h:4:6: 'CT': APPR CT needs the radius R"), std::string::npos) << e;
  e = error(head + "APPR CT X+0 Y+0 CCA90 R0 RL F300\n" + contour);
  EXPECT_NE(e.find("t.h:4:"), std::string::npos) << e;
  EXPECT_NE(e.find("R0 in APPR CT"), std::string::npos) << e;
  e = error(head + "APPR CT X+0 Y+0 CCA90 R+4 RL F300\n" + contour);  // inside arc 4 < tool 5
  EXPECT_NE(e.find("t.h:4:1: "), std::string::npos) << e;
  EXPECT_NE(e.find("not larger than the tool radius 5"), std::string::npos) << e;
  e = error(head + "L Y+40 F300\nL X+40\nL Y+0\nL X+0\nDEP LT LEN10 F300\n");
  EXPECT_NE(e.find("t.h:8:1: 'DEP': DEP without radius compensation"), std::string::npos) << e;
  e = error(head + "APPR LT X+0 Y+0 LEN10 RL F300\n" + contour + "DEP LT F300\n");
  EXPECT_NE(e.find("t.h:9:5: 'LT': DEP LT needs the length LEN"), std::string::npos) << e;
  e = error(head + "APPR LT X+0 Y+0 LEN10 RL F300\n" + contour + "DEP CT CCA90 F300\n");
  EXPECT_NE(e.find("t.h:9:5: 'CT': DEP CT needs the radius R"), std::string::npos) << e;
  e = error(head + "APPR LCT X+0 Y+0 RL F300\n" + contour);
  EXPECT_NE(e.find("t.h:4:6: 'LCT': APPR LCT needs the radius R"), std::string::npos) << e;
  e = error(head + "APPR LCT X+0 Y+0 R-10 RL F300\n" + contour);
  EXPECT_NE(e.find("t.h:4:"), std::string::npos) << e;
  EXPECT_NE(e.find("R in APPR LCT must be positive"), std::string::npos) << e;
  e = error(head + "APPR LT X+0 Y+0 LEN10 RL F300\n" + contour + "DEP LCT R+10 F300\n");
  EXPECT_NE(e.find("t.h:9:5: 'LCT': DEP LCT needs the end point PN's X and Y"), std::string::npos) << e;
  e = error(head + "APPR PLT X+0 Y+0 RL F300\n" + contour);
  EXPECT_NE(e.find("t.h:4:10: 'X+0': APPR PLT takes PR PA, not X Y"), std::string::npos) << e;
  e = error(head + "APPR PXY X+0 Y+0 RL F300\n" + contour);
  EXPECT_NE(e.find("t.h:4:6: 'PXY': APPR PXY is not read"), std::string::npos) << e;
  e = error(head + "APPR LT X+0 Y+0 LEN10 RL F300\nEND PGM P MM\n");
  EXPECT_NE(e.find("t.h:4:1: "), std::string::npos) << e;
  EXPECT_NE(e.find("no contour element follows it"), std::string::npos) << e;
  e = error(head + "APPR LT X+0 Y+0 LEN10 RL F300\nL Y+40 RL\n");
  EXPECT_NE(e.find("t.h:5:1: 'L': the block after APPR must be the first contour element"), std::string::npos) << e;
}

}  // namespace
}  // namespace vmsim::toolpath
