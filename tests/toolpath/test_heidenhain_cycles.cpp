// Heidenhain TNC machining cycles 200 / 201 / 203 / 205, their calls (CYCL CALL, CYCL CALL POS,
// M99, M89, PATTERN DEF with CYCL CALL PAT), labels and calls (LBL, CALL LBL ... REP, CALL PGM) and the polar APPR / DEP forms
// (toolpath/src/heidenhain_reader.cpp). The expected tool-tip points and feeds are worked out by
// hand from the TNC 640 manual's description of each cycle (the comments give the arithmetic).
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <string>
#include <vector>

#include "plane_path_support.hpp"
#include "reader_test_support.hpp"
#include "vmsim/toolpath/heidenhain_reader.hpp"
#include "vmsim/toolpath/toolpath.hpp"

namespace vmsim::toolpath {
namespace {

using namespace test;

ReaderOptions tool_options() {
  ReaderOptions options;
  options.cutter_radius_mm = {{1, 5.0}};
  options.tool_length_mm = {{1, 0.0}};
  return options;
}

Toolpath parse(const std::string& text, const ReaderOptions& options = tool_options()) {
  return parse_heidenhain(text, "t.h", options);
}

double per_min(double mm_per_min) { return mm_per_min / 60000.0; }  // m/s

/// One expected move of a cycle: tip Z [mm], rapid or the feed [mm/min].
struct Expected {
  double z_mm;
  bool rapid;
  double feed_mm_per_min;
};

void expect_moves(const std::vector<PathPoint>& points, double x_mm, double y_mm,
                  const std::vector<Expected>& expected) {
  ASSERT_EQ(points.size(), expected.size());
  for (std::size_t i = 0; i < expected.size(); ++i) {
    expect_xy(xy_mm(points[i]), x_mm, y_mm);
    EXPECT_NEAR(z_mm(points[i]), expected[i].z_mm, kTight) << "move " << i;
    EXPECT_EQ(points[i].kind == MotionKind::rapid, expected[i].rapid) << "move " << i;
    if (!expected[i].rapid) {
      EXPECT_NEAR(points[i].feed_m_per_s, per_min(expected[i].feed_mm_per_min), 1e-15) << "move " << i;
    }
    EXPECT_EQ(points[i].corner_tolerance_m, 0.0) << "move " << i;  // exact stop at each level
  }
}

// Cycle 200: surface Q203 = 0, set-up clearance Q200 = 2, depth Q201 = -12, strokes Q202 = 5 at
// Q206 = 150. FMAX to Z+2; 5 mm to Z-5; FMAX out to Z+2 and back to 2 above the depth (Z-3); to
// Z-10; out, back to Z-8; the last 2 mm to Z-12; FMAX out to Z+2, then to the 2nd set-up
// clearance Q204 = 50 above the surface.
TEST(HeidenhainCycles, Drilling200PecksWithFullRetracts) {
  const Toolpath path = parse(
      "0 BEGIN PGM D MM\n"                  // 1
      "1 TOOL CALL 1 Z S2000\n"             // 2
      "2 L X+10 Y+20 Z+50 R0 FMAX\n"        // 3
      "3 CYCL DEF 200 DRILLING ~\n"         // 4
      "  Q200=+2 ;SET-UP CLEARANCE ~\n"     // 5
      "  Q201=-12 ;DEPTH ~\n"               // 6
      "  Q206=+150 ;FEED RATE FOR PLNGNG ~\n"
      "  Q202=+5 ;PLUNGING DEPTH ~\n"
      "  Q210=+0 ;DWELL TIME AT TOP ~\n"
      "  Q203=+0 ;SURFACE COORDINATE ~\n"   // 10
      "  Q204=+50 ;2ND SET-UP CLEARANCE ~\n"
      "  Q211=+0.5 ;DWELL TIME AT DEPTH\n"  // 12
      "4 CYCL CALL M3\n"                    // 13
      "5 END PGM D MM\n");
  expect_moves(points_of_lines(path, 13, 13), 10.0, 20.0,
               {{2, true, 0}, {-5, false, 150}, {2, true, 0}, {-3, true, 0}, {-10, false, 150},
                {2, true, 0}, {-8, true, 0}, {-12, false, 150}, {2, true, 0}, {50, true, 0}});
}

// Cycle 203 with a decrement and chip breaking: surface Z+5, clearance 2 (Z+7), depth -20 (Z-15),
// strokes Q202 = 8 less Q212 = 2 each, not below Q205 = 3: 8, 6, 4, 3 -> levels Z-3, Z-9,
// Z-13, Z-15 (the last cut short). One chip break (Q213 = 1, up Q256 = 0.5 at Q208 = 500)
// before each full retract (at Q208 to Z+7, FMAX back to 2 above the depth). Out at Q208, then
// FMAX to the 2nd set-up clearance Z+5+20.
TEST(HeidenhainCycles, UniversalDrilling203DecrementAndChipBreaking) {
  const Toolpath path = parse(
      "BEGIN PGM D MM\nTOOL CALL 1 Z S2000\nL X+30 Y-10 Z+50 R0 FMAX\n"  // 1-3
      "CYCL DEF 203 UNIVERSAL DRILLING\n"                                // 4
      "Q200=+2 ;SET-UP CLEARANCE\nQ201=-20 ;DEPTH\nQ206=+100 ;FEED RATE FOR PLNGNG\n"
      "Q202=+8 ;PLUNGING DEPTH\nQ210=+0 ;DWELL TIME AT TOP\nQ203=+5 ;SURFACE COORDINATE\n"
      "Q204=+20 ;2ND SET-UP CLEARANCE\nQ212=+2 ;DECREMENT\nQ213=+1 ;NR OF BREAKS\n"
      "Q205=+3 ;MIN. PLUNGING DEPTH\nQ211=+0 ;DWELL TIME AT DEPTH\nQ208=+500 ;RETRACTION FEED RATE\n"
      "Q256=+0.5 ;DIST FOR CHIP BRKNG\nQ395=+0 ;DEPTH REFERENCE\n"       // 5-18
      "CYCL CALL\n"                                                      // 19
      "END PGM D MM\n");
  expect_moves(points_of_lines(path, 19, 19), 30.0, -10.0,
               {{7, true, 0}, {-3, false, 100}, {-2.5, false, 500}, {-9, false, 100}, {7, false, 500},
                {-7, true, 0}, {-13, false, 100}, {-12.5, false, 500}, {-15, false, 100}, {7, false, 500},
                {25, true, 0}});
  // The parameters are Q parameters too, as on the control.
  const Toolpath uses_q = parse(
      "BEGIN PGM D MM\nTOOL CALL 1 Z\nCYCL DEF 201 REAMING Q200=2 Q201=-10 Q206=80 Q211=0 Q208=0 Q203=+0 Q204=10\n"
      "L X+0 Y+0 Z+10 R0 FMAX\nL X+Q201 FMAX\nEND PGM D MM\n");
  EXPECT_NEAR(xy_mm(uses_q.points.back()).x(), -10.0, kTight);
}

// Cycle 205 with a decrement, a minimum plunging depth and graded advanced stop distances:
// surface Z0, clearance 2, depth -20, strokes Q202 = 6 less Q212 = 2 each, not below Q205 = 3:
// 6, 4, 3, 3, 3, 1 -> levels Z-6, -10, -13, -16, -19, -20. After each stroke but the last: FMAX
// out to Z+2 and FMAX back to the advanced stop distance above the depth reached, 1 (Q258) at
// the first of the 5 retracts, 0.2 (Q259) at the last, linearly between: 1, 0.8, 0.6, 0.4, 0.2.
// Out at Q208 = 500, then FMAX to Q204 = 30.
TEST(HeidenhainCycles, UniversalPecking205DecrementAndAdvancedStop) {
  const Toolpath path = parse(
      "BEGIN PGM D MM\nTOOL CALL 1 Z S2000\nL X+5 Y+6 Z+50 R0 FMAX\n"  // 1-3
      "CYCL DEF 205 UNIVERSAL PECKING ~\n"                            // 4
      "  Q200=+2 ;SET-UP CLEARANCE ~\n  Q201=-20 ;DEPTH ~\n  Q206=+100 ;FEED RATE FOR PLNGNG ~\n"
      "  Q202=+6 ;PLUNGING DEPTH ~\n  Q203=+0 ;SURFACE COORDINATE ~\n  Q204=+30 ;2ND SET-UP CLEARANCE ~\n"
      "  Q212=+2 ;DECREMENT ~\n  Q205=+3 ;MIN. PLUNGING DEPTH ~\n  Q258=+1 ;UPPER ADV STOP DIST ~\n"
      "  Q259=+0.2 ;LOWER ADV STOP DIST ~\n  Q257=+0 ;DEPTH FOR CHIP BRKNG ~\n"
      "  Q256=+0.2 ;DIST FOR CHIP BRKNG ~\n  Q211=+0 ;DWELL TIME AT DEPTH ~\n"
      "  Q379=+0 ;STARTING POINT ~\n  Q253=+750 ;F PRE-POSITIONING ~\n  Q208=+500 ;RETRACTION FEED RATE ~\n"
      "  Q395=+0 ;DEPTH REFERENCE\n"                                  // 5-21
      "CYCL CALL\n"                                                    // 22
      "END PGM D MM\n");
  expect_moves(points_of_lines(path, 22, 22), 5.0, 6.0,
               {{2, true, 0}, {-6, false, 100}, {2, true, 0}, {-5, true, 0},
                {-10, false, 100}, {2, true, 0}, {-9.2, true, 0},
                {-13, false, 100}, {2, true, 0}, {-12.4, true, 0},
                {-16, false, 100}, {2, true, 0}, {-15.6, true, 0},
                {-19, false, 100}, {2, true, 0}, {-18.8, true, 0},
                {-20, false, 100}, {2, false, 500}, {30, true, 0}});
}

// Cycle 205 with a deepened starting point and chip breaking: Q379 = 3 below the surface Z0,
// reached at Q253 = 750 to Q200 = 2 above it (Z-1); strokes of Q202 = 5 from Z-3: to Z-8, then
// to the depth Z-10; inside a stroke a chip break every Q257 = 2 (Z-5, Z-7: back Q256 = 0.3 at
// Q208 = 0, i.e. at Q206 = 100). One full retract (FMAX to Z+2, FMAX back to Q258 = Q259 = 0.5
// above Z-8); out at Q206, FMAX to Q204 = 20.
TEST(HeidenhainCycles, UniversalPecking205DeepenedStartAndChipBreaks) {
  const Toolpath path = parse(
      "BEGIN PGM D MM\nTOOL CALL 1 Z S2000\nL X-4 Y+0 Z+50 R0 FMAX\n"  // 1-3
      "CYCL DEF 205 UNIVERSAL PECKING Q200=2 Q201=-10 Q206=100 Q202=5 Q203=0 Q204=20 Q212=0 Q205=0 "
      "Q258=0.5 Q259=0.5 Q257=2 Q256=0.3 Q211=0 Q379=3 Q253=750 Q208=0\n"  // 4
      "CYCL CALL\n"                                                         // 5
      "END PGM D MM\n");
  expect_moves(points_of_lines(path, 5, 5), -4.0, 0.0,
               {{2, true, 0}, {-1, false, 750}, {-5, false, 100}, {-4.7, false, 100}, {-7, false, 100},
                {-6.7, false, 100}, {-8, false, 100}, {2, true, 0}, {-7.5, true, 0},
                {-10, false, 100}, {2, false, 100}, {20, true, 0}});
}

// PATTERN DEF with CYCL CALL PAT: cycle 200 (one stroke: Q202 = 5 is more than the depth 3)
// at each point in the order defined. POS1 (10, 0); ROW1 from (0, 20), 10 apart, NUM 3, turned
// ROT 90: (0, 20), (0, 30), (0, 40), its surface Z-1 (added to Q203 = 0); PAT1 from (50, 0),
// DX 10, DY 5, 2 x 2, turned 90 deg about (50, 0): the local (i 10, j 5) becomes (-j 5, i 10):
// (50, 0), (50, 10), (45, 0), (45, 10). The tool at Z+50 at the call: between the points at
// max(50, surface + Q204 10) = Z+50. At each: up to Z+50, across in rapid, FMAX to the surface
// + 2, Q206 = 100 to the surface - 3, FMAX out to the surface + 2, FMAX to the surface + 10.
TEST(HeidenhainPatterns, PointRowAndTurnedPatternCallTheCycleAtEachPoint) {
  const Toolpath path = parse(
      "BEGIN PGM P MM\nTOOL CALL 1 Z S2000\nL X+0 Y+0 Z+50 R0 FMAX\n"       // 1-3
      "CYCL DEF 200 DRILLING Q200=2 Q201=-3 Q206=100 Q202=5 Q210=0 Q203=0 Q204=10 Q211=0\n"  // 4
      "PATTERN DEF ~\n"                                                       // 5
      "  POS1 (X+10 Y+0 Z+0) ~\n"                                             // 6
      "  ROW1 (X+0 Y+20 D+10 NUM3 ROT+90 Z-1) ~\n"                            // 7
      "  PAT1 (X+50 Y+0 DX+10 DY+5 NUMX2 NUMY2 ROT+90 ROTX+0 ROTY+0 Z+0)\n"   // 8
      "CYCL CALL PAT FMAX M13\n"                                              // 9
      "END PGM P MM\n");
  const std::vector<PathPoint> points = points_of_lines(path, 9, 9);
  struct Hole {
    double x_mm, y_mm, surface_mm;
  };
  const std::vector<Hole> holes = {{10, 0, 0},  {0, 20, -1}, {0, 30, -1}, {0, 40, -1},
                                   {50, 0, 0}, {50, 10, 0}, {45, 0, 0},  {45, 10, 0}};
  // The first hole: 5 moves (the tool is at Z+50 already); each after it: 6.
  ASSERT_EQ(points.size(), 5u + 6u * (holes.size() - 1));
  std::size_t at = 0;
  for (std::size_t h = 0; h < holes.size(); ++h) {
    const Hole& hole = holes[h];
    if (h > 0) {  // up to the travel height where the last hole left the tool
      expect_xy(xy_mm(points[at]), holes[h - 1].x_mm, holes[h - 1].y_mm);
      EXPECT_NEAR(z_mm(points[at]), 50.0, kTight) << "hole " << h;
      EXPECT_EQ(points[at].kind, MotionKind::rapid);
      ++at;
    }
    expect_xy(xy_mm(points[at]), hole.x_mm, hole.y_mm);  // across at Z+50
    EXPECT_NEAR(z_mm(points[at]), 50.0, kTight) << "hole " << h;
    EXPECT_EQ(points[at].kind, MotionKind::rapid);
    ++at;
    const double s = hole.surface_mm;
    expect_moves({points.begin() + static_cast<std::ptrdiff_t>(at), points.begin() + static_cast<std::ptrdiff_t>(at + 4)},
                 hole.x_mm, hole.y_mm, {{s + 2, true, 0}, {s - 3, false, 100}, {s + 2, true, 0}, {s + 10, true, 0}});
    at += 4;
  }
}

// Circles and the travel height: PITCHCIRC1 about (0, 0), D 20, from 90 deg, 4 points: (0, 10),
// (-10, 0), (0, -10), (10, 0); CIRC1 about (100, 0), D 10, from 0 in steps of 45, 2 points:
// (105, 0), (100 + 5 cos 45, 5 sin 45). The tool at Z+5 at the call, below the 2nd set-up
// clearance Z+10: between the points at Z+10 (after each hole it is there already).
TEST(HeidenhainPatterns, CirclesAndTheHigherOfTheCallHeightAndTheSecondClearance) {
  const Toolpath path = parse(
      "BEGIN PGM P MM\nTOOL CALL 1 Z S2000\nL X+0 Y+0 Z+5 R0 FMAX\n"  // 1-3
      "CYCL DEF 200 DRILLING Q200=2 Q201=-3 Q206=100 Q202=5 Q210=0 Q203=0 Q204=10 Q211=0\n"  // 4
      "PATTERN DEF PITCHCIRC1 (X+0 Y+0 D+20 START+90 NUM4 Z+0)\n"       // 5
      "CIRC1 (X+100 Y+0 D+10 START+0 STEP+45 NUM2 Z+0)\n"                // 6
      "CYCL CALL PAT\n"                                                  // 7
      "END PGM P MM\n");
  const std::vector<PathPoint> points = points_of_lines(path, 7, 7);
  const double r45 = 5.0 * std::sqrt(0.5);
  const std::vector<Eigen::Vector2d> holes = {{0, 10}, {-10, 0}, {0, -10}, {10, 0}, {105, 0}, {100 + r45, r45}};
  // The first hole: up to Z+10, across, 4 cycle moves; after it: across, 4.
  ASSERT_EQ(points.size(), 6u + 5u * (holes.size() - 1));
  EXPECT_NEAR(z_mm(points[0]), 10.0, kTight);
  expect_xy(xy_mm(points[0]), 0.0, 0.0);
  std::size_t at = 1;
  for (const Eigen::Vector2d& hole : holes) {
    expect_xy(xy_mm(points[at]), hole.x(), hole.y());
    EXPECT_NEAR(z_mm(points[at]), 10.0, kTight);
    expect_moves({points.begin() + static_cast<std::ptrdiff_t>(at + 1), points.begin() + static_cast<std::ptrdiff_t>(at + 5)},
                 hole.x(), hole.y(), {{2, true, 0}, {-3, false, 100}, {2, true, 0}, {10, true, 0}});
    at += 5;
  }
}

// CYCL CALL PAT F500: across at 500 mm/min. POS2's IX / IY count from POS1 (1, 1): (6, 2), its
// Z-2 shifting the surface (Q203 = 0) to Z-2. The tool at Z+50: after POS1 up to Z+50, across.
TEST(HeidenhainPatterns, IncrementalPointsAndAFeedBetweenThem) {
  const Toolpath path = parse(
      "BEGIN PGM P MM\nTOOL CALL 1 Z S2000\nL X+0 Y+0 Z+50 R0 FMAX\n"  // 1-3
      "CYCL DEF 200 DRILLING Q200=2 Q201=-3 Q206=100 Q202=5 Q210=0 Q203=0 Q204=10 Q211=0\n"  // 4
      "PATTERN DEF POS1 (X+1 Y+1 Z+0) ~\n"  // 5
      "~\n"                                  // 6
      "POS2 (IX+5 IY+1 Z-2)\n"               // 7
      "CYCL CALL PAT F500\n"                 // 8
      "END PGM P MM\n");
  const std::vector<PathPoint> points = points_of_lines(path, 8, 8);
  ASSERT_EQ(points.size(), 11u);
  expect_xy(xy_mm(points[0]), 1.0, 1.0);
  EXPECT_EQ(points[0].kind, MotionKind::linear);
  EXPECT_NEAR(points[0].feed_m_per_s, per_min(500), 1e-15);
  EXPECT_NEAR(z_mm(points[5]), 50.0, kTight);  // up after POS1
  expect_xy(xy_mm(points[6]), 6.0, 2.0);
  EXPECT_NEAR(points[6].feed_m_per_s, per_min(500), 1e-15);
  expect_moves({points.begin() + 7, points.end()}, 6.0, 2.0,
               {{0, true, 0}, {-5, false, 100}, {0, true, 0}, {8, true, 0}});
}

// Located errors of patterns: file:line:column, the word, what is wrong.
TEST(HeidenhainPatterns, LocatedErrors) {
  const std::string head =
      "BEGIN PGM E MM\nTOOL CALL 1 Z\nL X+0 Y+0 Z+10 R0 FMAX\n"
      "CYCL DEF 200 DRILLING Q200=2 Q201=-3 Q206=100 Q202=5 Q210=0 Q203=0 Q204=10 Q211=0\n";  // 1-4
  const auto error = [&](const std::string& body) {
    return input_error_of([&] { parse(head + body + "END PGM E MM\n"); });
  };
  const std::string no_pattern = error("CYCL CALL PAT\n");
  EXPECT_NE(no_pattern.find("t.h:5:11: 'PAT': CYCL CALL PAT without a PATTERN DEF"), std::string::npos) << no_pattern;
  const std::string no_num = error("PATTERN DEF\nROW1 (X+0 Y+0 D+5 ROT+0)\nCYCL CALL PAT\n");
  EXPECT_NE(no_num.find("t.h:6:1: 'ROW1': NUM is missing"), std::string::npos) << no_num;
  const std::string bad_word = error("PATTERN DEF\n  POS1 (X+1 Y+2 W+3)\n");
  EXPECT_NE(bad_word.find("t.h:6:17: 'W+3': unsupported word in the pattern element POS1"), std::string::npos)
      << bad_word;
  const std::string open = error("PATTERN DEF POS1 (X+1 Y+2\n");
  EXPECT_NE(open.find("t.h:5:18: 'POS1': '(' is not closed on its line"), std::string::npos) << open;
  const std::string zero = error("PATTERN DEF PAT1 (X+0 Y+0 DX+5 DY+5 NUMX0 NUMY2)\n");
  EXPECT_NE(zero.find("t.h:5:37: NUMX = 0: expected a whole number"), std::string::npos) << zero;
  const std::string not_number = error("PATTERN DEF\nPOS1 (X+1 Y+abc)\n");
  EXPECT_NE(not_number.find("t.h:6:11: 'Y+abc': expected a number"), std::string::npos) << not_number;
  const std::string frame = error("PATTERN DEF\nFRAME1 (X+1 Y+2 Z+0 ROT+0)\n");
  EXPECT_NE(frame.find("t.h:6:1: 'FRAME1': FRAME (a pattern frame) is not read"), std::string::npos) << frame;
}

// Cycle 201 (one stroke at Q206 = 80, out at Q208 = 0: at Q206) called by CYCL CALL POS (its Z
// shifts the surface: Z-2 + Q203 0; the tool at Z+30 is above it: first in the plane), by M99
// (once, at the block's end point) and M89 (after every positioning block until M99).
TEST(HeidenhainCycles, Reaming201CalledByPosM99AndM89) {
  const Toolpath path = parse(
      "BEGIN PGM D MM\nTOOL CALL 1 Z S800\nL X+0 Y+0 Z+30 R0 FMAX\n"  // 1-3
      "CYCL DEF 201 REAMING\nQ200=+2\nQ201=-10\nQ206=+80\nQ211=+0\nQ208=+0\nQ203=+0\nQ204=+10\n"  // 4-11
      "CYCL CALL POS X+10 Y+5 Z-2 FMAX\n"  // 12
      "L X+20 Y+5 FMAX M99\n"              // 13
      "L X+30 FMAX M89\n"                  // 14
      "L X+40 FMAX\n"                      // 15
      "L X+50 FMAX M99\n"                  // 16
      "L X+60 FMAX\n"                      // 17
      "END PGM D MM\n");
  const std::vector<PathPoint> pos = points_of_lines(path, 12, 12);
  ASSERT_EQ(pos.size(), 5u);
  expect_xy(xy_mm(pos[0]), 10.0, 5.0);  // in the plane at Z+30
  EXPECT_NEAR(z_mm(pos[0]), 30.0, kTight);
  expect_moves({pos.begin() + 1, pos.end()}, 10.0, 5.0,
               {{0, true, 0}, {-12, false, 80}, {0, false, 80}, {8, true, 0}});
  const std::vector<PathPoint> m99 = points_of_lines(path, 13, 13);
  ASSERT_EQ(m99.size(), 5u);
  expect_moves({m99.begin() + 1, m99.end()}, 20.0, 5.0,
               {{2, true, 0}, {-10, false, 80}, {2, false, 80}, {10, true, 0}});
  // Holes: at X 10, 20 (M99), 30 (M89), 40 (modal), 50 (M99 ends it), none at X 60.
  std::vector<double> holes;
  for (const PathPoint& p : path.points) {
    if (std::abs(z_mm(p) - (-10.0)) < 1e-9 || std::abs(z_mm(p) - (-12.0)) < 1e-9) holes.push_back(xy_mm(p).x());
  }
  EXPECT_EQ(holes, (std::vector<double>{10.0, 20.0, 30.0, 40.0, 50.0}));
  expect_xy(xy_mm(path.points.back()), 60.0, 5.0);
}

// LBL / CALL LBL: a section repeat (REP 2: the section three times), a subprogram after M30
// (REP 1: run twice), and a named label.
TEST(HeidenhainLabels, SectionRepeatsAndSubprograms) {
  const Toolpath path = parse(
      "0 BEGIN PGM L MM\n"          // 1
      "1 TOOL CALL 1 Z\n"           // 2
      "2 L X+0 Y+0 Z+10 R0 FMAX\n"  // 3
      "3 LBL 1\n"                   // 4
      "4 L IX+10 F100\n"            // 5
      "5 CALL LBL 1 REP 2\n"        // 6
      "6 CALL LBL 5 REP1\n"         // 7
      "7 CALL LBL \"UP\"\n"         // 8
      "8 L X+0 FMAX\n"              // 9
      "9 M30\n"                     // 10
      "10 LBL 5\n"                  // 11
      "11 L IY+5 F100\n"            // 12
      "12 LBL 0\n"                  // 13
      "13 LBL \"UP\"\n"             // 14
      "14 L Z+20 FMAX\n"            // 15
      "15 LBL 0\n"                  // 16
      "16 END PGM L MM\n");
  std::vector<int> lines;
  for (const PathPoint& p : path.points) lines.push_back(line_of(path, p));
  EXPECT_EQ(lines, (std::vector<int>{3, 5, 5, 5, 12, 12, 15, 9}));
  const std::vector<PathPoint> section = points_of_lines(path, 5, 5);
  ASSERT_EQ(section.size(), 3u);
  for (std::size_t i = 0; i < 3; ++i) expect_xy(xy_mm(section[i]), 10.0 * static_cast<double>(i + 1), 0.0);
  const std::vector<PathPoint> sub = points_of_lines(path, 12, 12);
  ASSERT_EQ(sub.size(), 2u);
  expect_xy(xy_mm(sub[1]), 30.0, 10.0);
  EXPECT_NEAR(z_mm(path.points.back()), 20.0, kTight);
  expect_xy(xy_mm(path.points.back()), 0.0, 10.0);
}

// Nested section repeats, as the manual's example nests them: the inner section twice in each of
// the two passes of the outer one: 4 steps in X, 2 in Y.
TEST(HeidenhainLabels, NestedRepeatsAndCyclesInSubprograms) {
  const Toolpath path = parse(
      "BEGIN PGM L MM\nTOOL CALL 1 Z\nL X+0 Y+0 Z+10 R0 FMAX\n"
      "LBL 1\nLBL 2\nL IX+1 F100\nCALL LBL 2 REP 1\nL IY+1\nCALL LBL 1 REP 1\n"
      "CYCL DEF 200 DRILLING\nQ200=2\nQ201=-3\nQ206=100\nQ202=5\nQ210=0\nQ203=0\nQ204=10\nQ211=0\n"
      "L X+50 Y+50 FMAX\nCALL LBL 9\nL X+60 FMAX\nCALL LBL 9\nM30\n"
      "LBL 9\nCYCL CALL\nLBL 0\nEND PGM L MM\n");
  int x_steps = 0, y_steps = 0, holes = 0;
  for (const PathPoint& p : path.points) {
    const int line = line_of(path, p);
    if (line == 6) ++x_steps;
    if (line == 8) ++y_steps;
    if (std::abs(z_mm(p) + 3.0) < 1e-9) ++holes;
  }
  EXPECT_EQ(x_steps, 4);
  EXPECT_EQ(y_steps, 2);
  EXPECT_EQ(holes, 2);
}

// CALL PGM: another file of the program's folder, run to its END PGM; its points name it.
TEST(HeidenhainLabels, CallProgramReadsTheFileBesideTheProgram) {
  const std::filesystem::path folder = std::filesystem::temp_directory_path() / "vmsim_tnc_call_pgm";
  std::filesystem::create_directories(folder);
  std::ofstream(folder / "main.h") << "0 BEGIN PGM MAIN MM\n1 TOOL CALL 1 Z\n2 L X+0 Y+0 Z+10 R0 FMAX\n"
                                      "3 CALL PGM TNC:\\nc\\HOLE.H\n4 L X+5 FMAX\n5 END PGM MAIN MM\n";
  std::ofstream(folder / "hole.h") << "0 BEGIN PGM HOLE MM\n1 L Z+2 FMAX\n2 L Z-1 F50\n3 L Z+10 FMAX\n4 END PGM HOLE MM\n";
  const Toolpath path = read_heidenhain((folder / "main.h").string(), tool_options());
  ASSERT_EQ(path.points.size(), 5u);
  const SourceBlock& cut = path.blocks[static_cast<std::size_t>(path.points[2].block)];
  EXPECT_EQ(std::filesystem::path(cut.file).filename(), "hole.h");
  EXPECT_EQ(cut.line, 3);
  EXPECT_NEAR(z_mm(path.points[2]), -1.0, kTight);
  expect_xy(xy_mm(path.points.back()), 5.0, 0.0);
  std::ofstream(folder / "bad.h") << "BEGIN PGM MAIN MM\nTOOL CALL 1 Z\nL X+0 Y+0 Z+10 R0 FMAX\nCALL PGM NOPE\nEND PGM MAIN MM\n";
  const std::string missing = input_error_of([&] { read_heidenhain((folder / "bad.h").string(), tool_options()); });
  EXPECT_NE(missing.find("bad.h:4:10: 'NOPE': CALL PGM: NOPE.h is not in"), std::string::npos) << missing;
  std::filesystem::remove_all(folder);
}

// Located errors: file:line:column, the word, what is wrong.
TEST(HeidenhainLabels, LocatedErrors) {
  const std::string head = "BEGIN PGM E MM\nTOOL CALL 1 Z\nL X+0 Y+0 Z+10 R0 FMAX\n";  // 1-3
  const auto error = [&](const std::string& body, ReaderOptions options = tool_options()) {
    return input_error_of([&] { parse(head + body + "END PGM E MM\n", options); });
  };
  EXPECT_NE(error("CALL LBL 7\n").find("t.h:4:10: '7': label 7 is not defined"), std::string::npos)
      << error("CALL LBL 7\n");
  EXPECT_NE(error("LBL 3\nLBL 3\n").find("t.h:5:5: '3': label 3 is defined twice (first at line 4)"), std::string::npos);
  EXPECT_NE(error("CALL LBL 0\n").find("t.h:4:10: '0': LBL 0 ends a subprogram"), std::string::npos);
  // Recursion stops at the nesting limit, at the CALL that goes one too deep.
  const std::string recursion = error("CALL LBL 1\nM30\nLBL 1\nL IX+1 F100\nCALL LBL 1\nLBL 0\n");
  EXPECT_NE(recursion.find("t.h:8:10: '1': calls nested more than 64 deep"), std::string::npos) << recursion;
  // A repeat that runs too long stops at the executed-block limit.
  ReaderOptions few = tool_options();
  few.max_executed_blocks = 1000;
  const std::string runaway = error("LBL 1\nLBL 2\nL IX+1 F100\nCALL LBL 2 REP 65534\nCALL LBL 1 REP 65534\n", few);
  EXPECT_NE(runaway.find("more than 1000 blocks run"), std::string::npos) << runaway;
  EXPECT_NE(error("CALL LBL 1 REP x\nLBL 1\n").find("t.h:4:16: 'x': REP needs a whole number"), std::string::npos)
      << error("CALL LBL 1 REP x\nLBL 1\n");
  // Cycles: a missing parameter at the CYCL DEF block, unknown cycles, a call without one.
  const std::string missing = error("CYCL DEF 200 DRILLING\nQ200=2\nQ201=-5\nQ202=2\nQ203=0\nQ204=10\nCYCL CALL\n");
  EXPECT_NE(missing.find("t.h:4:10: cycle 200: Q206 is missing (feed rate for plunging)"), std::string::npos) << missing;
  EXPECT_NE(error("CYCL DEF 262 THREAD MILLING\n").find("t.h:4:10: '262': cycle 262 is not supported"), std::string::npos)
      << error("CYCL DEF 262 THREAD MILLING\n");
  EXPECT_NE(error("CYCL CALL\n").find("t.h:4:1: 'CYCL': cycle call without a machining cycle defined"), std::string::npos);
  const std::string upward = error("CYCL DEF 201 REAMING Q200=2 Q201=+5 Q206=80 Q211=0 Q208=0 Q203=0 Q204=10\nCYCL CALL\n");
  EXPECT_NE(upward.find("t.h:4:10: cycle 201: Q201 (depth) = 5: only a negative depth"), std::string::npos) << upward;
  const std::string tiny = error("CYCL DEF 200 DRILLING Q200=2 Q201=-500 Q206=80 Q202=0.00001 Q210=0 Q203=0 Q204=10\nCYCL CALL\n");
  EXPECT_NE(tiny.find("t.h:5:1: 'CYCL': cycle 200 expands to more than"), std::string::npos) << tiny;
  // A formula's error names its column in the line, on a parameter line and on the CYCL DEF line.
  EXPECT_NE(error("CYCL DEF 200 DRILLING\n  Q200=+2 * ;SET-UP CLEARANCE\n").find("t.h:5:13: in the formula"), std::string::npos)
      << error("CYCL DEF 200 DRILLING\n  Q200=+2 * ;SET-UP CLEARANCE\n");
  EXPECT_NE(error("CYCL DEF 200 DRILLING Q200=2/0\n").find("t.h:4:30: in the formula"), std::string::npos)
      << error("CYCL DEF 200 DRILLING Q200=2/0\n");
  // Cycle 205: a missing advanced stop distance, a deepened start below the depth.
  const std::string no_q258 = error("CYCL DEF 205 UNIVERSAL PECKING Q200=2 Q201=-10 Q206=100 Q202=5 Q203=0 Q204=20 "
                                    "Q212=0 Q205=0 Q259=0.5 Q257=0 Q208=0\nCYCL CALL\n");
  EXPECT_NE(no_q258.find("t.h:4:10: cycle 205: Q258 is missing (upper advanced stop distance)"), std::string::npos)
      << no_q258;
  const std::string deep_start = error("CYCL DEF 205 UNIVERSAL PECKING Q200=2 Q201=-10 Q206=100 Q202=5 Q203=0 Q204=20 "
                                       "Q212=0 Q205=0 Q258=0.5 Q259=0.5 Q257=0 Q208=0 Q379=12 Q253=500\nCYCL CALL\n");
  EXPECT_NE(deep_start.find("t.h:4:10: cycle 205: Q379 (deepened starting point) = 12 is not above the depth"),
            std::string::npos)
      << deep_start;
  EXPECT_NE(error("CYCL DEF 201 REAMING Q200=2 Q201=-5 Q206=FMAX Q211=0 Q208=0 Q203=0 Q204=10\nCYCL CALL\n")
                .find("Q206 (feed rate for plunging) FMAX"),
            std::string::npos);
}

// Polar APPR / DEP: the same motion as the Cartesian form at the point PR PA about CC. With
// CC (10, 0), PA = (0, 0) is PR 10 at PA 180 (or -180); with CC (0, 0), DEP LCT's PN (-20, -10)
// is PR sqrt(500) at PA 180 + atan2(10, 20) deg.
TEST(HeidenhainApproach, PolarFormsEqualTheCartesianOnes) {
  const auto square = [](const std::string& appr, const std::string& dep) {
    return "BEGIN PGM P MM\nTOOL CALL 1 Z S1000\nL X-30 Y-30 Z-2 R0 FMAX\nCC X+10 Y+0\n" + appr +
           "\nL Y+40\nL X+40\nL Y+0\nL X+0\nCC X+0 Y+0\n" + dep + "\nL Z+5 FMAX\nEND PGM P MM\n";
  };
  const double pn_angle_deg = 180.0 + std::atan2(10.0, 20.0) * 180.0 / std::numbers::pi;
  char dep_polar[128];
  std::snprintf(dep_polar, sizeof dep_polar, "DEP PLCT PR+%.12f PA+%.12f R+10 F400", std::sqrt(500.0), pn_angle_deg);
  const std::vector<std::pair<std::string, std::string>> pairs = {
      {"APPR LT X+0 Y+0 LEN15 RL F200", "APPR PLT PR+10 PA+180 LEN15 RL F200"},
      {"APPR LN X+0 Y+0 LEN10 RL F200", "APPR PLN PR+10 PA+180 LEN10 RL F200"},
      {"APPR CT X+0 Y+0 CCA90 R+10 RL F200", "APPR PCT PR+10 PA-180 CCA90 R+10 RL F200"},
      {"APPR LCT X+0 Y+0 R+10 RL F200", "APPR PLCT PR+10 PA+180 R+10 RL F200"},
  };
  for (const auto& [cartesian, polar] : pairs) {
    const Toolpath a = parse(square(cartesian, "DEP LCT X-20 Y-10 R+10 F400"));
    const Toolpath b = parse(square(polar, dep_polar));
    ASSERT_EQ(a.points.size(), b.points.size()) << polar;
    for (std::size_t i = 0; i < a.points.size(); ++i) {
      expect_vector(a.points[i].tip_W_m * 1e3, b.points[i].tip_W_m * 1e3, 1e-9);
    }
  }
  const std::string no_pole = input_error_of([] {
    parse("BEGIN PGM P MM\nTOOL CALL 1 Z\nL X-30 Y-30 Z-2 R0 FMAX\nAPPR PLT PR+10 PA+180 LEN15 RL F200\nL Y+40\n");
  });
  EXPECT_NE(no_pole.find("t.h:4:6: 'PLT': polar coordinates without a pole CC"), std::string::npos) << no_pole;
  const std::string no_angle = input_error_of([] {
    parse("BEGIN PGM P MM\nTOOL CALL 1 Z\nL X-30 Y-30 Z-2 R0 FMAX\nCC X+0 Y+0\nAPPR PLT PR+10 LEN15 RL F200\nL Y+40\n");
  });
  EXPECT_NE(no_angle.find("t.h:5:6: 'PLT': APPR PLT needs the polar radius PR and angle PA"), std::string::npos) << no_angle;
}

}  // namespace
}  // namespace vmsim::toolpath
