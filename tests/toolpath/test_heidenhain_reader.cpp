// Heidenhain TNC conversational reader (toolpath/src/heidenhain_reader.cpp): every frame
// operation (datum shift, PLANE SPATIAL / VECTOR / EULER / RELATIV / RESET) and every arc form
// (C about CC, CR, CT, RND, CHF) against results computed by hand in the comments; Q parameters,
// feeds, M91 / M92, M128 and LN, the tolerance cycle, the stock, and bad input.
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <string>
#include <vector>

#include "reader_test_support.hpp"
#include "vmsim/common/errors.hpp"
#include "vmsim/toolpath/heidenhain_reader.hpp"
#include "vmsim/toolpath/toolpath.hpp"

namespace vmsim::toolpath {
namespace {

using test::expect_vector;
using test::input_error_of;
using V = Eigen::Vector3d;

constexpr double kTol = 1e-12;
const double kS2 = std::sqrt(0.5);

Toolpath parse(const std::string& text, const ReaderOptions& options = {}) {
  return parse_heidenhain(text, "t.h", options);
}

/// Tips in mm.
V tip_mm(const PathPoint& p) { return p.tip_W_m * 1e3; }

ReaderOptions coarse_arcs() {
  ReaderOptions o;
  o.arc_chord_tolerance_m = 1e-3;  // 1 mm: few chords, each checked by hand
  return o;
}

const char* kHead = "0 BEGIN PGM T MM\n1 TOOL CALL 1 Z S1000\n";

TEST(HeidenhainReader, LinesFeedsAndBlocks) {
  const Toolpath path = parse(std::string(kHead) +
                              "2 L X+0 Y+0 Z+10 R0 FMAX M3\n"
                              "3 L Z-1 F500\n"
                              "4 L X+10 FMAX\n"
                              "5 L IY+5\n"
                              "6 END PGM T MM\n"
                              "7 L X+99 F100\n");
  ASSERT_EQ(path.points.size(), 4u);
  EXPECT_EQ(path.points[0].kind, MotionKind::rapid);
  expect_vector(tip_mm(path.points[0]), V(0, 0, 10));
  EXPECT_EQ(path.points[1].kind, MotionKind::linear);
  EXPECT_NEAR(path.points[1].feed_m_per_s, 500e-3 / 60.0, 1e-15);
  expect_vector(tip_mm(path.points[1]), V(0, 0, -1));
  // FMAX is for its block only: the next block feeds at the F in force.
  EXPECT_EQ(path.points[2].kind, MotionKind::rapid);
  EXPECT_EQ(path.points[3].kind, MotionKind::linear);
  EXPECT_NEAR(path.points[3].feed_m_per_s, 500e-3 / 60.0, 1e-15);
  expect_vector(tip_mm(path.points[3]), V(10, 5, -1));
  EXPECT_EQ(path.points[3].tool_number, 1);
  EXPECT_EQ(path.blocks[static_cast<std::size_t>(path.points[3].block)].line, 6);
  EXPECT_EQ(path.blocks[static_cast<std::size_t>(path.points[3].block)].block_number, 5);
  EXPECT_EQ(path.blocks[static_cast<std::size_t>(path.points[3].block)].text, "5 L IY+5");
}

TEST(HeidenhainReader, CommentsStructureBlocksAndStock) {
  const Toolpath path = parse("0 BEGIN PGM T MM\n"
                              "1 BLK FORM 0.1 Z X-50 Y-40 Z-30\n"
                              "2 BLK FORM 0.2 X+50 IY+80 Z+0\n"
                              "3 * - ROUGH\n"
                              "4 ;comment only\n"
                              "5 TOOL CALL 3 Z S9000 ; the roughing tool\n"
                              "6 L X+1 Y+2 Z+3 R0 FMAX\n");
  ASSERT_TRUE(path.stock_box);
  expect_vector(path.stock_box->min_W_m * 1e3, V(-50, -40, -30), 1e-12);
  expect_vector(path.stock_box->max_W_m * 1e3, V(50, 40, 0), 1e-12);
  ASSERT_EQ(path.points.size(), 1u);
  EXPECT_EQ(path.points[0].tool_number, 3);
}

TEST(HeidenhainReader, StockIsInWThroughThePreset) {
  ReaderOptions o;
  o.work_offsets_mm["G54"] = V(10, 20, 30);  // machine axes of the preset
  o.machine_zero_W_mm = V(0, 0, 100);
  o.default_tool_length_mm = 50;
  const Toolpath path = parse("BLK FORM 0.1 Z X+0 Y+0 Z-5\nBLK FORM 0.2 X+1 Y+1 Z+0\n"
                              "TOOL CALL 1 Z\nL X+0 Y+0 Z+0 FMAX\n", o);
  // The preset in W: axes (identity) * (10, 20, 30) + (0, 0, 100).
  expect_vector(path.stock_box->min_W_m * 1e3, V(10, 20, 125), 1e-12);
  expect_vector(path.stock_box->max_W_m * 1e3, V(11, 21, 130), 1e-12);
  // Outside M128 without a machine: tip = axes (gauge - L) + zero = preset in W + q.
  expect_vector(tip_mm(path.points[0]), V(10, 20, 130), 1e-12);
}

// --- Arcs -----------------------------------------------------------------------------------

TEST(HeidenhainReader, CircleAboutCcCounterClockwiseAndClockwise) {
  // Radius 10, chord tolerance 1 mm: chords of at most 2 acos(0.9) = 0.902 rad, so a quarter
  // takes 2 chords (the middle at 45 deg) and three quarters take 6 (the middle at -135 deg).
  const Toolpath ccw = parse(std::string(kHead) + "L X+10 Y+0 Z+0 FMAX\nCC X+0 Y+0\nC X+0 Y+10 DR+ F100\n",
                             coarse_arcs());
  ASSERT_EQ(ccw.points.size(), 3u);
  EXPECT_EQ(ccw.points[1].kind, MotionKind::arc);
  expect_vector(tip_mm(ccw.points[1]), V(10 * kS2, 10 * kS2, 0), kTol);
  expect_vector(tip_mm(ccw.points[2]), V(0, 10, 0), kTol);
  const Toolpath cw = parse(std::string(kHead) + "L X+10 Y+0 Z+0 FMAX\nCC X+0 Y+0\nC X+0 Y+10 DR- F100\n",
                            coarse_arcs());
  ASSERT_EQ(cw.points.size(), 7u);
  expect_vector(tip_mm(cw.points[3]), V(-10 * kS2, -10 * kS2, 0), kTol);
  expect_vector(tip_mm(cw.points[6]), V(0, 10, 0), kTol);
}

TEST(HeidenhainReader, FullCircleAndHelixAndCentreFromThePosition) {
  // End = start: a full circle, clockwise: 7 chords of 2 pi / 7.
  const Toolpath full = parse(std::string(kHead) + "L X+10 Y+0 Z+0 FMAX\nCC X+0 Y+0\nC X+10 DR- F100\n",
                              coarse_arcs());
  ASSERT_EQ(full.points.size(), 8u);
  const double a = -2.0 * std::numbers::pi / 7.0;
  expect_vector(tip_mm(full.points[1]), V(10 * std::cos(a), 10 * std::sin(a), 0), kTol);
  expect_vector(tip_mm(full.points[7]), V(10, 0, 0), kTol);
  // A helix: Z falls linearly with the angle; CC IX: the centre 10 left of the position.
  const Toolpath helix = parse(std::string(kHead) + "L X+10 Y+0 Z+0 FMAX\nCC IX-10\nC X-10 Y+0 Z-4 DR+ F100\n",
                               coarse_arcs());
  ASSERT_EQ(helix.points.size(), 5u);  // 180 deg: 4 chords
  expect_vector(tip_mm(helix.points[2]), V(0, 10, -2), kTol);
  expect_vector(tip_mm(helix.points[4]), V(-10, 0, -4), kTol);
}

TEST(HeidenhainReader, CircleInThePlaneZX) {
  // CC X Z: the arc turns in Z/X, DR+ from Z towards X (as G18). From (X10, Z0) about (0, 0)
  // to (X0, Z10): in (u, v) = (Z, X) from (0, 10) to (10, 0), clockwise (DR-) is the quarter
  // through (X 7.07, Z 7.07).
  const Toolpath path = parse(std::string(kHead) + "L X+10 Y+5 Z+0 FMAX\nCC X+0 Z+0\nC X+0 Z+10 DR- F100\n",
                              coarse_arcs());
  ASSERT_EQ(path.points.size(), 3u);
  expect_vector(tip_mm(path.points[1]), V(10 * kS2, 5, 10 * kS2), kTol);
  expect_vector(tip_mm(path.points[2]), V(0, 5, 10), kTol);
}

TEST(HeidenhainReader, CrPicksTheCentreBySignAndDirection) {
  // From (10, 0) to (0, 10), R 10: R+ DR+ is the quarter about (0, 0); R- DR+ the three
  // quarters about (10, 10), whose middle (after 135 deg from -90 deg) is at 45 deg.
  const Toolpath minor = parse(std::string(kHead) + "L X+10 Y+0 Z+0 FMAX\nCR X+0 Y+10 R+10 DR+ F100\n", coarse_arcs());
  ASSERT_EQ(minor.points.size(), 3u);
  expect_vector(tip_mm(minor.points[1]), V(10 * kS2, 10 * kS2, 0), kTol);
  const Toolpath major = parse(std::string(kHead) + "L X+10 Y+0 Z+0 FMAX\nCR X+0 Y+10 R-10 DR+ F100\n", coarse_arcs());
  ASSERT_EQ(major.points.size(), 7u);
  expect_vector(tip_mm(major.points[3]), V(10 + 10 * kS2, 10 + 10 * kS2, 0), kTol);
  // R- DR-: the long way clockwise about (0, 0): the middle at -135 deg.
  const Toolpath major_cw = parse(std::string(kHead) + "L X+10 Y+0 Z+0 FMAX\nCR X+0 Y+10 R-10 DR- F100\n", coarse_arcs());
  expect_vector(tip_mm(major_cw.points[3]), V(-10 * kS2, -10 * kS2, 0), kTol);
}

TEST(HeidenhainReader, CtContinuesTangentially) {
  // After the line along +X ending at (10, 0), CT to (20, 10): r = |d|^2 / (2 n.d) = 200 / 20 =
  // 10, centre (10, 10), counter-clockwise; its middle (17.07, 2.93). The next CT to (10, 20)
  // leaves (20, 10) along +Y: the same circle, through (17.07, 17.07).
  const Toolpath path = parse(std::string(kHead) +
                                  "L X+0 Y+0 Z+0 FMAX\nL X+10 F100\nCT X+20 Y+10\nCT X+10 Y+20\n",
                              coarse_arcs());
  ASSERT_EQ(path.points.size(), 6u);
  expect_vector(tip_mm(path.points[2]), V(10 + 10 * kS2, 10 - 10 * kS2, 0), kTol);
  expect_vector(tip_mm(path.points[3]), V(20, 10, 0), kTol);
  expect_vector(tip_mm(path.points[4]), V(10 + 10 * kS2, 10 + 10 * kS2, 0), kTol);
  expect_vector(tip_mm(path.points[5]), V(10, 20, 0), kTol);
  EXPECT_NE(input_error_of([&] { parse(std::string(kHead) + "L X+0 Y+0 Z+0 FMAX\nL X+10 F100\nCT X+20 Y+0\n"); })
                .find("on the tangent"),
            std::string::npos);
}

TEST(HeidenhainReader, RndRoundsARightAngle) {
  // (0,0) -> (10,0) -> (10,10) with RND R2: tangent points (8, 0) and (10, 2), centre (8, 2),
  // counter-clockwise. Chord tolerance 0.1 mm on r 2: 3 chords of 30 deg.
  ReaderOptions o;
  o.arc_chord_tolerance_m = 0.1e-3;
  const Toolpath path = parse(std::string(kHead) +
                                  "L X+0 Y+0 Z+0 FMAX\nL X+10 F100\nRND R2 F50\nL Y+10\n", o);
  ASSERT_EQ(path.points.size(), 6u);
  expect_vector(tip_mm(path.points[1]), V(8, 0, 0), kTol);  // the line now ends at the tangent point
  for (std::size_t i = 2; i <= 4; ++i) {
    EXPECT_EQ(path.points[i].kind, MotionKind::arc);
    EXPECT_NEAR(path.points[i].feed_m_per_s, 50e-3 / 60.0, 1e-15);  // RND's own F
    EXPECT_NEAR((tip_mm(path.points[i]) - V(8, 2, 0)).norm(), 2.0, kTol);
  }
  expect_vector(tip_mm(path.points[2]), V(8 + 2 * std::sin(std::numbers::pi / 6), 2 - 2 * std::cos(std::numbers::pi / 6), 0), kTol);
  expect_vector(tip_mm(path.points[4]), V(10, 2, 0), kTol);
  expect_vector(tip_mm(path.points[5]), V(10, 10, 0), kTol);
  EXPECT_NEAR(path.points[5].feed_m_per_s, 100e-3 / 60.0, 1e-15);  // F100 again after RND
  // A 45 deg turn to the right: t = R tan(22.5 deg), clockwise, centre right of the first line.
  const Toolpath right = parse(std::string(kHead) + "L X+0 Y+0 Z+0 FMAX\nL X+10 F100\nRND R4\nL X+20 Y-10\n", o);
  const double t = 4 * std::tan(std::numbers::pi / 8);
  expect_vector(tip_mm(right.points[1]), V(10 - t, 0, 0), kTol);
  expect_vector(tip_mm(right.points[right.points.size() - 2]), V(10 + t * kS2, -t * kS2, 0), kTol);
  for (std::size_t i = 2; i + 1 < right.points.size(); ++i) {
    EXPECT_NEAR((tip_mm(right.points[i]) - V(10 - t, -4, 0)).norm(), 4.0, kTol);
  }
}

TEST(HeidenhainReader, ChfCutsBothLines) {
  const Toolpath square = parse(std::string(kHead) + "L X+0 Y+0 Z+0 FMAX\nL X+10 F100\nCHF 3\nL Y+10\n");
  ASSERT_EQ(square.points.size(), 4u);
  expect_vector(tip_mm(square.points[1]), V(7, 0, 0), kTol);
  expect_vector(tip_mm(square.points[2]), V(10, 3, 0), kTol);
  EXPECT_EQ(square.points[2].kind, MotionKind::linear);
  expect_vector(tip_mm(square.points[3]), V(10, 10, 0), kTol);
  const Toolpath oblique = parse(std::string(kHead) + "L X+0 Y+0 Z+0 FMAX\nL X+10 F100\nCHF 2\nL X+20 Y+10\n");
  expect_vector(tip_mm(oblique.points[1]), V(8, 0, 0), kTol);
  expect_vector(tip_mm(oblique.points[2]), V(10 + 2 * kS2, 2 * kS2, 0), kTol);
}

TEST(HeidenhainReader, CornerErrors) {
  const std::string start = std::string(kHead) + "L X+0 Y+0 Z+0 FMAX\nL X+10 F100\n";
  EXPECT_NE(input_error_of([&] { parse(start + "RND R2\nCC X+10 Y+5\nC X+10 Y+10 DR+\n"); }).find("t.h:7:"),
            std::string::npos);
  EXPECT_NE(input_error_of([&] { parse(start + "RND R20\nL Y+10\n"); }).find("more than the lines are long"),
            std::string::npos);
  EXPECT_NE(input_error_of([&] { parse(start + "RND R2\n"); }).find("end of the program"), std::string::npos);
  EXPECT_NE(input_error_of([&] { parse(start + "CHF 1\nL X+20\n"); }).find("collinear"), std::string::npos);
  EXPECT_NE(input_error_of([&] { parse(std::string(kHead) + "L X+10 Y+0 Z+0 FMAX\nCC X+0 Y+0\nC X+0 Y+10 DR+ F100\nRND R1\n"); })
                .find("must follow a straight line"),
            std::string::npos);
}

// --- Frames ---------------------------------------------------------------------------------

TEST(HeidenhainReader, DatumShiftAbsoluteIncrementalAndTheToolStays) {
  const Toolpath path = parse(std::string(kHead) +
                              "L X+0 Y+0 Z+0 FMAX\n"
                              "CYCL DEF 7.0 DATUM SHIFT\nCYCL DEF 7.1 X+100\nCYCL DEF 7.2 Y+50\nCYCL DEF 7.3 Z+0\n"
                              "L Z+5 FMAX\n"          // X Y not given: the tool stays at (0, 0)
                              "L X+1 Y+2 Z+3 FMAX\n"  // (101, 52, 3)
                              "CYCL DEF 7.0 NULLPUNKT\nCYCL DEF 7.1 IX+10\n"
                              "L X+1 FMAX\n"          // (111, 52, 3)
                              "TRANS DATUM RESET\nL X+1 FMAX\n");
  ASSERT_EQ(path.points.size(), 5u);
  expect_vector(tip_mm(path.points[1]), V(0, 0, 5), kTol);
  expect_vector(tip_mm(path.points[2]), V(101, 52, 3), kTol);
  expect_vector(tip_mm(path.points[3]), V(111, 52, 3), kTol);
  expect_vector(tip_mm(path.points[4]), V(1, 52, 3), kTol);
}

TEST(HeidenhainReader, PlaneSpatialTurnsAboutTheShiftedDatum) {
  // Datum shifted to X+5, then SPB+90: R = Ry(90) takes the tilted Z to +X and the tilted X to
  // -Z. TURN turns the tool about its tip onto +X; then (0, 0, 10) in the plane is q = (5, 0, 0)
  // + R (0, 0, 10) = (15, 0, 0), and (2, 0, 10) is (15, 0, -2).
  const Toolpath path = parse(std::string(kHead) +
                              "L X+0 Y+0 Z+50 FMAX\n"
                              "CYCL DEF 7.0 DATUM SHIFT\nCYCL DEF 7.1 X+5\n"
                              "PLANE SPATIAL SPA+0 SPB+90 SPC+0 TURN FMAX SEQ+ TABLE ROT\n"
                              "L X+0 Y+0 Z+10 FMAX\nL X+2 F100\n"
                              "PLANE RESET TURN FMAX\n"
                              "L Z+60 FMAX\n");
  ASSERT_EQ(path.points.size(), 6u);
  expect_vector(tip_mm(path.points[1]), V(0, 0, 50), kTol);  // the turn: the tip stays
  expect_vector(path.points[1].axis_W, V(1, 0, 0), kTol);
  EXPECT_EQ(path.points[1].kind, MotionKind::rapid);
  expect_vector(tip_mm(path.points[2]), V(15, 0, 0), kTol);
  expect_vector(tip_mm(path.points[3]), V(15, 0, -2), kTol);
  expect_vector(path.points[3].axis_W, V(1, 0, 0), kTol);
  expect_vector(path.points[4].axis_W, V(0, 0, 1), kTol);  // PLANE RESET TURN
  expect_vector(tip_mm(path.points[4]), V(15, 0, -2), kTol);
  expect_vector(tip_mm(path.points[5]), V(15, 0, 60), kTol);  // X Y where the tool is: (10, 0) + shift 5
}

TEST(HeidenhainReader, PlaneSpatialOrderIsABoutFixedAxes) {
  // SPA+90 SPC+90: R = Rz(90) Rx(90). Tilted Z: Rx(90) (0,0,1) = (0,-1,0), Rz(90) -> (1,0,0).
  // Tilted X: (1,0,0) -> Rz(90) -> (0,1,0). So (1, 0, 2) in the plane is (2, 1, 0).
  const Toolpath path = parse(std::string(kHead) + "L X+0 Y+0 Z+0 FMAX\n"
                              "PLANE SPATIAL SPA+90 SPB+0 SPC+90 STAY\nL X+1 Y+0 Z+2 FMAX\n");
  ASSERT_EQ(path.points.size(), 2u);
  expect_vector(tip_mm(path.points[1]), V(2, 1, 0), kTol);
  expect_vector(path.points[1].axis_W, V(0, 0, 1), kTol);  // STAY: the tool is not turned
}

TEST(HeidenhainReader, PlaneVectorEulerAndRelativ) {
  // VECTOR: N = +X is the tilted Z, B = +Y the tilted X, tilted Y = N x B = +Z: (1, 2, 3) ->
  // 1 (0,1,0) + 2 (0,0,1) + 3 (1,0,0) = (3, 1, 2). A B not perpendicular to N is corrected.
  for (const char* plane : {"PLANE VECTOR BX+0 BY+1 BZ+0 NX+1 NY+0 NZ+0 TURN FMAX",
                            "PLANE VECTOR BX+0.5 BY+1 BZ+0 NX+2 NY+0 NZ+0 TURN FMAX",
                            // Euler Z X Z: Rz(90) Rx(90) Rz(0): tilted Z = Rz(90) (0,-1,0) = (1,0,0),
                            // tilted X = Rz(90) (1,0,0) = (0,1,0): the same plane.
                            "PLANE EULER EULPR+90 EULNU+90 EULROT+0 TURN FMAX"}) {
    const Toolpath path = parse(std::string(kHead) + "L X+0 Y+0 Z+0 FMAX\n" + plane + "\nL X+1 Y+2 Z+3 FMAX\n");
    ASSERT_EQ(path.points.size(), 3u) << plane;
    expect_vector(tip_mm(path.points[2]), V(3, 1, 2), 1e-12);
    expect_vector(path.points[2].axis_W, V(1, 0, 0), 1e-15);
  }
  // RELATIV SPB+90 after SPATIAL SPA+90: R = Rx(90) Ry(90); tilted Z = Rx(90) (1,0,0) = (1,0,0).
  const Toolpath relative = parse(std::string(kHead) + "L X+0 Y+0 Z+0 FMAX\n"
                                  "PLANE SPATIAL SPA+90 SPB+0 SPC+0 STAY\nPLANE RELATIV SPB+90 TURN FMAX\n"
                                  "L X+0 Y+0 Z+1 FMAX\n");
  expect_vector(relative.points.back().axis_W, V(1, 0, 0), 1e-15);
  expect_vector(tip_mm(relative.points.back()), V(1, 0, 0), 1e-12);
}

TEST(HeidenhainReader, PlaneMbRetractsAlongTheToolFirst) {
  const Toolpath path = parse(std::string(kHead) + "L X+0 Y+0 Z+5 FMAX\n"
                              "PLANE SPATIAL SPA+0 SPB+90 SPC+0 TURN MB50 F1000\n");
  ASSERT_EQ(path.points.size(), 3u);
  expect_vector(tip_mm(path.points[1]), V(0, 0, 55), kTol);
  expect_vector(path.points[1].axis_W, V(0, 0, 1), kTol);
  expect_vector(tip_mm(path.points[2]), V(0, 0, 55), kTol);
  expect_vector(path.points[2].axis_W, V(1, 0, 0), kTol);
  EXPECT_EQ(path.points[2].kind, MotionKind::linear);
  EXPECT_NEAR(path.points[2].feed_m_per_s, 1000e-3 / 60.0, 1e-15);
}

// --- Machine axes, M91 / M92, M128, LN ------------------------------------------------------

struct Recorder {
  std::vector<std::vector<std::pair<char, double>>> calls;
};

ReaderOptions with_machine(Recorder& recorder) {
  ReaderOptions o;
  o.work_offsets_mm["G54"] = V(100, 200, -300);
  o.tool_length_mm[1] = 50.0;
  o.g28_reference_mm = V(0, 0, -5);
  // A stand-in machine: the gauge point is the axes, the tool tilts about X by A.
  o.axis_words_to_pose = [&recorder](const std::vector<std::pair<char, double>>& words) {
    recorder.calls.push_back(words);
    V m = V::Zero();
    double a = 0;
    for (const auto& [letter, value] : words) {
      if (letter == 'X') m.x() = value;
      if (letter == 'Y') m.y() = value;
      if (letter == 'Z') m.z() = value;
      if (letter == 'A') a = value;
    }
    const double r = a * std::numbers::pi / 180.0;
    const V axis(0, -std::sin(r), std::cos(r));
    return AxisWordPose{(m - 50.0 * axis) * 1e-3, axis};
  };
  o.rotary_words_to_tool_axis = [](const std::vector<std::pair<char, double>>& words) {
    double a = 0;
    for (const auto& [letter, value] : words) {
      if (letter == 'A') a = value;
    }
    const double r = a * std::numbers::pi / 180.0;
    return V(0, -std::sin(r), std::cos(r));
  };
  return o;
}

double word(const std::vector<std::pair<char, double>>& words, char letter) {
  for (const auto& [l, v] : words) {
    if (l == letter) return v;
  }
  return std::nan("");
}

TEST(HeidenhainReader, MachineAxesAreThePresetPlusTheToolLength) {
  Recorder recorder;
  const ReaderOptions o = with_machine(recorder);
  const Toolpath path = parse(std::string(kHead) +
                                  "L Z-10 R0 FMAX M91\n"           // machine Z -10, X Y unknown
                                  "L X+1 Y+2 R0 FMAX\n"            // machine (101, 202, -10)
                                  "L Z+4 A+30 FMAX\n"              // machine Z = -300 + 4 + 50
                                  "L Z+0 FMAX M92\n",              // machine Z = -5 + 0 (M92 = home)
                              o);
  ASSERT_EQ(recorder.calls.size(), 3u);
  EXPECT_EQ(word(recorder.calls[0], 'X'), 101.0);
  EXPECT_EQ(word(recorder.calls[0], 'Y'), 202.0);
  EXPECT_EQ(word(recorder.calls[0], 'Z'), -10.0);
  EXPECT_EQ(word(recorder.calls[1], 'Z'), -246.0);
  EXPECT_EQ(word(recorder.calls[1], 'A'), 30.0);
  EXPECT_EQ(word(recorder.calls[2], 'Z'), -5.0);
  EXPECT_EQ(word(recorder.calls[2], 'X'), 101.0);
  EXPECT_EQ(path.points[1].rotary_words_deg[0], 30.0);
  expect_vector(path.points[1].axis_W, V(0, -0.5, std::sqrt(0.75)), 1e-15);
}

TEST(HeidenhainReader, M128TipIsTheProgramPointAndTheAxisComesFromTheWords) {
  Recorder recorder;
  ReaderOptions o = with_machine(recorder);
  o.machine_zero_W_mm = V(0, 0, 1000);
  const Toolpath path = parse("TOOL CALL 1 Z DL+0.5 DR+0.25\n"
                              "L X+0 Y+0 Z+0 A+0 FMAX M128\n"
                              "L X+1 Y+2 Z+3 A-30 F1000\n"
                              "LN X+2 Y+2 Z+3 NX+0 NY+0 NZ+2 TX+0 TY+1 TZ+1\n"
                              "M129\n",
                              o);
  ASSERT_EQ(path.points.size(), 3u);
  // The preset in W: (100, 200, -300) + (0, 0, 1000); the tip: + q + DL along the axis.
  const V axis(0, 0.5, std::sqrt(0.75));
  expect_vector(path.points[1].axis_W, axis, 1e-15);
  expect_vector(tip_mm(path.points[1]), V(101, 202, 703) + 0.5 * axis, 1e-12);
  // LN: the axis is T made unit, the tip moves DR along the unit normal.
  const V t(0, kS2, kS2);
  expect_vector(path.points[2].axis_W, t, 1e-15);
  expect_vector(tip_mm(path.points[2]), V(102, 202, 703) + 0.5 * t + V(0, 0, 0.25), 1e-12);
  EXPECT_TRUE(recorder.calls.empty());  // no machine axes under M128
}

TEST(HeidenhainReader, FunctionTcpmAndItsErrors) {
  Recorder recorder;
  const ReaderOptions o = with_machine(recorder);
  const Toolpath path = parse("TOOL CALL 1 Z\nFUNCTION TCPM F TCP AXIS POS PATHCTRL AXIS\n"
                              "L X+0 Y+0 Z+0 A+90 FMAX\nFUNCTION RESET TCPM\n", o);
  expect_vector(path.points[0].axis_W, V(0, -1, 0), 1e-15);
  EXPECT_NE(input_error_of([&] { parse("TOOL CALL 1 Z\nL X+0 Y+0 Z+0 FMAX\nLN X+1 NX+0 NY+0 NZ+1 TX+0 TY+0 TZ+1 F100\n", o); })
                .find("needs M128"),
            std::string::npos);
  EXPECT_NE(input_error_of([&] { parse("TOOL CALL 1 Z\nL X+0 Y+0 Z+0 FMAX M128\nL Z-10 FMAX M91\n", o); })
                .find("M91 / M92 under M128"),
            std::string::npos);
  EXPECT_NE(input_error_of([&] { parse("TOOL CALL 1 Z\nL X+0 Y+0 Z+0 A+10 FMAX\n"); }).find("need a machine"),
            std::string::npos);
}

// --- Q parameters, NC modes, units ----------------------------------------------------------

TEST(HeidenhainReader, QParametersInFormulasAndFnAndWords) {
  const Toolpath path = parse(std::string(kHead) +
                              "Q1 = 10\n"
                              "Q2 = Q1 * 2 + SIN(30)\n"     // 20.5
                              "QL3=(Q1 - 4) ^ 2 / 4\n"      // 9
                              "FN 0: Q4 = +3\n"
                              "FN 8: Q5 = +Q4 LEN +4\n"     // 5
                              "FN 4: Q6 = +Q5 DIV +2\n"     // 2.5
                              "FN 13: Q7 = +1 ANG +1\n"     // 45
                              "FN 1: Q8 = +Q6 + -0.5\n"     // 2
                              "Q9 = 600\n"
                              "L X+Q2 Y-Q1 Z+QL3 R0 FMAX\n"
                              "L X+Q5 Y+Q6 Z+Q7 FQ9\n"
                              "L X+Q8 F+Q9\n");
  ASSERT_EQ(path.points.size(), 3u);
  expect_vector(tip_mm(path.points[0]), V(20.5, -10, 9), 1e-12);
  expect_vector(tip_mm(path.points[1]), V(5, 2.5, 45), 1e-12);
  EXPECT_NEAR(path.points[1].feed_m_per_s, 600e-3 / 60.0, 1e-15);
  expect_vector(tip_mm(path.points[2]), V(2, 2.5, 45), 1e-12);
  EXPECT_NE(input_error_of([&] { parse(std::string(kHead) + "L X+Q11 FMAX\n"); }).find("t.h:3:3: 'X+Q11': Q11 is read before"),
            std::string::npos);
  EXPECT_NE(input_error_of([&] { parse(std::string(kHead) + "L A+Q120 FMAX\n"); }).find("PLANE STAY"),
            std::string::npos);
  EXPECT_NE(input_error_of([&] { parse(std::string(kHead) + "Q1 = 1 / (2 - 2)\n"); }).find("division by zero"),
            std::string::npos);
  EXPECT_NE(input_error_of([&] { parse(std::string(kHead) + "FN 9: IF +Q1 EQU +0 GOTO LBL 1\n"); }).find("conditional jumps"),
            std::string::npos);
}

TEST(HeidenhainReader, ToleranceCycleSetsTheCornerTolerance) {
  const Toolpath path = parse(std::string(kHead) +
                              "L X+0 Y+0 Z+0 FMAX\n"
                              "CYCL DEF 32.0 TOLERANCE\nCYCL DEF 32.1 T0.02\nCYCL DEF 32.2 HSC-MODE:0 TA0.5\n"
                              "L X+10 F100\n"
                              "CYCL DEF 32.0 TOLERANZ\nCYCL DEF 32.1\n"
                              "L X+20\n");
  ASSERT_EQ(path.points.size(), 3u);
  EXPECT_TRUE(std::isnan(path.points[0].corner_tolerance_m));
  EXPECT_NEAR(path.points[1].corner_tolerance_m, 0.02e-3, 1e-18);
  EXPECT_TRUE(std::isnan(path.points[2].corner_tolerance_m));
  EXPECT_EQ(path.points[1].jerk_mode, JerkMode::unspecified);
}

TEST(HeidenhainReader, InchProgramsScaleLengthsAndTenthsOfInchFeeds) {
  const Toolpath path = parse("BEGIN PGM T INCH\nTOOL CALL 1 Z\nL X+0 Y+0 Z+0 FMAX\nL X+1 F100\n");
  expect_vector(tip_mm(path.points[1]), V(25.4, 0, 0), 1e-12);
  EXPECT_NEAR(path.points[1].feed_m_per_s, 100 * 2.54e-3 / 60.0, 1e-15);  // F100 = 10 inch/min
}

// --- Bad input and dispatch -----------------------------------------------------------------

TEST(HeidenhainReader, BadInputNamesFileLineColumnAndWord) {
  // RL / RR without a tool radius (no tool table): test_heidenhain_compensation.cpp has the rest.
  const std::string message = input_error_of([] { parse(std::string(kHead) + "2 L X+10 RL F100\n"); });
  EXPECT_NE(message.find("t.h:3:10: 'RL'"), std::string::npos) << message;
  EXPECT_NE(input_error_of([] { parse(std::string(kHead) + "L X+1e400 FMAX\n"); }).find("'X+1e400'"), std::string::npos);
  EXPECT_NE(input_error_of([] { parse(std::string(kHead) + "L X+1 F100 RR\n"); }).find("RL / RR"), std::string::npos);
  EXPECT_NE(input_error_of([] { parse(std::string(kHead) + "CYCL DEF 200 DRILLING\n"); }).find("cycle 200"), std::string::npos);
  EXPECT_NE(input_error_of([] { parse(std::string(kHead) + "L X+1 Y+1 Z+1 FMAX\nL X+2\n"); }).find("before any F"),
            std::string::npos);
  EXPECT_NE(input_error_of([] { parse(std::string(kHead) + "CALL LBL 1\n"); }).find("label 1 is not defined"),
            std::string::npos);
  EXPECT_NE(input_error_of([] { parse(std::string(kHead) + "SOMETHING\n"); }).find("t.h:3:1: 'SOMETHING'"),
            std::string::npos);
  EXPECT_NE(input_error_of([] { parse(std::string(kHead)); }).find("no motion"), std::string::npos);
  EXPECT_NE(input_error_of([] { parse("TOOL CALL 1 X\n"); }).find("tool axis"), std::string::npos);
  EXPECT_NE(input_error_of([] { parse("L X+1 \xE9\n"); }).find("0xE9"), std::string::npos);
}

TEST(HeidenhainReader, ReadToolpathDispatchesDotH) {
  const auto folder = std::filesystem::temp_directory_path() / "vmsim_heidenhain_dispatch";
  std::filesystem::create_directories(folder);
  for (const char* name : {"p.h", "P.H"}) {
    const auto file = folder / name;
    std::ofstream(file) << "0 BEGIN PGM P MM\n1 TOOL CALL 1 Z\n2 L X+1 Y+2 Z+3 R0 FMAX\n3 END PGM P MM\n";
    const Toolpath path = read_toolpath(file.string());
    ASSERT_EQ(path.points.size(), 1u);
    expect_vector(tip_mm(path.points[0]), V(1, 2, 3), 1e-12);
  }
  std::filesystem::remove_all(folder);
}

}  // namespace
}  // namespace vmsim::toolpath
