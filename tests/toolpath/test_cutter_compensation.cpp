// Cutter radius compensation (G41 / G42, toolpath/src/cutter_compensation.cpp and the G-code
// reader's use of it), against the control's documented motion (LinuxCNC "Cutter
// Compensation": the entry move ends tangent to the tool circle about its programmed end,
// concave corners at the offsets' intersection, convex corners rolled about the corner, G40's
// exit from the last offset point) with hand-computed points, and a property test: random
// convex polygons offset outward stay at the tool radius from the contour (brute-force
// point-to-segment distances) and touch it at every corner.
#include <gtest/gtest.h>

#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "plane_path_support.hpp"
#include "reader_test_support.hpp"
#include "vmsim/toolpath/cutter_compensation.hpp"
#include "vmsim/toolpath/toolpath.hpp"

namespace vmsim::toolpath {
namespace {

using namespace test;  // input_error_of, the plane-path helpers

ReaderOptions with_radius(double radius_mm) {
  ReaderOptions options;
  options.cutter_radius_mm = {{1, radius_mm}};
  return options;
}

const std::vector<Eigen::Vector2d> kSquare = {{0, 0}, {40, 0}, {40, 40}, {0, 40}};

// --- Squares: inside (G41 on a counter-clockwise pocket) and outside (G42) -----------------------

// Pocket 40 x 40, counter-clockwise, G41 (tool left: inside), r = 5. The entry from (20, 20) to
// P = (20, 0) ends where it is tangent to the circle of radius 5 about P (LinuxCNC): T = (20 +
// 5 sin t, 5 cos t), cos t = 5 / 20; it meets the bottom's offset y = 5 in a concave corner, so it
// stops on that line: x = 20 + (15 / 18.75) 5 sin t = 20 + sqrt(15). Every inside corner is the
// intersection of the offset sides (35, 5), (35, 35), (5, 35), (5, 5); G40 ends the last side at
// its offset end (20, 5); the exit goes to the programmed (20, 20).
TEST(CutterCompensation, InsideSquareCornersAreTheOffsetsIntersections) {
  const std::string program =
      "G17 G21 G90 G94 G40\n"  // 1
      "G0 X20 Y20 Z5\n"        // 2
      "G1 Z-2 F300\n"          // 3
      "G41 D1 X20 Y0\n"        // 4
      "X40\n"                  // 5
      "Y40\n"                  // 6
      "X0\n"                   // 7
      "Y0\n"                   // 8
      "X20\n"                  // 9
      "G40 X20 Y20\n"          // 10
      "G0 Z5\n"                // 11
      "M30\n";
  const Toolpath path = parse_gcode(program, "pocket.nc", with_radius(5.0));
  expect_xy(end_of_line(path, 4), 20.0 + std::sqrt(15.0), 5.0);
  expect_xy(end_of_line(path, 5), 35.0, 5.0);
  expect_xy(end_of_line(path, 6), 35.0, 35.0);
  expect_xy(end_of_line(path, 7), 5.0, 35.0);
  expect_xy(end_of_line(path, 8), 5.0, 5.0);
  expect_xy(end_of_line(path, 9), 20.0, 5.0);
  expect_xy(end_of_line(path, 10), 20.0, 20.0);
  // One point per block (no corner arcs inside), every contour point 5 from the contour.
  const std::vector<PathPoint> contour = points_of_lines(path, 5, 9);
  EXPECT_EQ(contour.size(), 5u);
  for (const PathPoint& point : contour) {
    EXPECT_NEAR(distance_to_polygon(xy_mm(point), kSquare), 5.0, kTight);
    EXPECT_NEAR(z_mm(point), -2.0, kTight);
    EXPECT_EQ(point.kind, MotionKind::linear);
  }
  EXPECT_NEAR(z_mm(path.points.back()), 5.0, kTight);
}

// The same square outside, G42 (tool right of a counter-clockwise contour): sides on x = -5,
// 45 and y = -5, 45, each outside corner an arc of radius 5 about the corner from one side's
// offset end to the next one's offset start (90 deg, counter-clockwise).
TEST(CutterCompensation, OutsideSquareRollsAboutEachCorner) {
  const std::string program =
      "G17 G21 G90 G94 G40\n"  // 1
      "G0 X20 Y-20 Z5\n"       // 2
      "G1 Z-2 F300\n"          // 3
      "G42 D1 Y0\n"            // 4
      "X40\n"                  // 5
      "Y40\n"                  // 6
      "X0\n"                   // 7
      "Y0\n"                   // 8
      "X20\n"                  // 9
      "G40 Y-20\n"             // 10
      "M30\n";
  const Toolpath path = parse_gcode(program, "outside.nc", with_radius(5.0));
  expect_xy(end_of_line(path, 4), 20.0 + std::sqrt(15.0), -5.0);  // mirror of the pocket's entry
  expect_xy(end_of_line(path, 5), 40.0, -5.0);
  expect_xy(end_of_line(path, 6), 45.0, 40.0);
  expect_xy(end_of_line(path, 7), 0.0, 45.0);
  expect_xy(end_of_line(path, 8), -5.0, 0.0);
  expect_xy(end_of_line(path, 9), 20.0, -5.0);
  expect_xy(end_of_line(path, 10), 20.0, -20.0);
  // The corner arcs belong to the block after the corner; their points are 5 from the corner.
  const Eigen::Vector2d corner_of_line[] = {{40, 0}, {40, 40}, {0, 40}, {0, 0}};
  for (int line = 6; line <= 9; ++line) {
    const std::vector<PathPoint> points = points_of_lines(path, line, line);
    ASSERT_GE(points.size(), 3u) << "line " << line;
    for (std::size_t i = 0; i + 1 < points.size(); ++i) {
      EXPECT_NEAR((xy_mm(points[i]) - corner_of_line[line - 6]).norm(), 5.0, kTight) << "line " << line;
      EXPECT_EQ(points[i].kind, MotionKind::arc);
    }
    EXPECT_EQ(points.back().kind, MotionKind::linear);
  }
  for (const PathPoint& point : points_of_lines(path, 5, 9)) {
    EXPECT_NEAR(distance_to_polygon(xy_mm(point), kSquare), 5.0, kTight);
  }
}

// The pocket programmed incrementally (G91: each move from the programmed, not the compensated,
// point) and in inch (the table's radius stays 5 mm) gives the same tool-centre points.
TEST(CutterCompensation, IncrementalAndInchProgramsGiveTheSamePocket) {
  const std::string incremental =
      "G17 G21 G90 G94\nG0 X20 Y20 Z5\nG1 Z-2 F300\nG91 G41 D1 Y-20\nX20\nY40\nX-40\nY-40\nX20\nG40 Y20\n";
  std::ostringstream inch;
  inch.precision(17);
  inch << "G17 G20 G90 G94\nG0 X" << 20 / 25.4 << " Y" << 20 / 25.4 << " Z" << 5 / 25.4 << "\nG1 Z" << -2 / 25.4
       << " F12\nG41 D1 Y0\nX" << 40 / 25.4 << "\nY" << 40 / 25.4 << "\nX0\nY0\nX" << 20 / 25.4 << "\nG40 Y"
       << 20 / 25.4 << "\n";
  for (const std::string& program : {incremental, inch.str()}) {
    const Toolpath path = parse_gcode(program, "pocket.nc", with_radius(5.0));
    expect_xy(end_of_line(path, 4), 20.0 + std::sqrt(15.0), 5.0);
    expect_xy(end_of_line(path, 5), 35.0, 5.0);
    expect_xy(end_of_line(path, 6), 35.0, 35.0);
    expect_xy(end_of_line(path, 7), 5.0, 35.0);
    expect_xy(end_of_line(path, 8), 5.0, 5.0);
    expect_xy(end_of_line(path, 9), 20.0, 5.0);
    expect_xy(end_of_line(path, 10), 20.0, 25.0 - 5.0 * (program == incremental ? 0.0 : 1.0));
  }
}

// G41.1 D<diameter> (LinuxCNC) is G41 with the diameter in the block.
TEST(CutterCompensation, DynamicCompensationTakesTheDiameterFromTheBlock) {
  const std::string program = "G17 G21 G90\nG0 X20 Y20 Z5\nG1 Z-2 F300\nG41.1 D10 X20 Y0\nX40\nY40\nG40 X20 Y20\n";
  const Toolpath path = parse_gcode(program, "dynamic.nc");
  expect_xy(end_of_line(path, 4), 20.0 + std::sqrt(15.0), 5.0);
  expect_xy(end_of_line(path, 5), 35.0, 5.0);
  expect_xy(end_of_line(path, 6), 35.0, 40.0);  // G40: the offset end of the last side
}

// Z-only moves inside the contour stay at the offset position where the previous side ends
// (known only once the next side comes: the corner is concave).
TEST(CutterCompensation, ZOnlyMovesKeepTheOffset) {
  const std::string program =
      "G17 G21 G90\n"   // 1
      "G0 X20 Y20 Z5\n" // 2
      "G1 Z-2 F300\n"   // 3
      "G41 D1 Y0\n"     // 4
      "X40\n"           // 5
      "Y40\n"           // 6
      "G0 Z5\n"         // 7
      "G1 Z-2\n"        // 8
      "X0\n"            // 9
      "G40 X20 Y20\n";  // 10
  const Toolpath path = parse_gcode(program, "lift.nc", with_radius(5.0));
  expect_xy(end_of_line(path, 6), 35.0, 35.0);
  expect_xy(end_of_line(path, 7), 35.0, 35.0);
  expect_xy(end_of_line(path, 8), 35.0, 35.0);
  EXPECT_NEAR(z_mm(points_of_lines(path, 7, 7).back()), 5.0, kTight);
  EXPECT_EQ(points_of_lines(path, 7, 7).back().kind, MotionKind::rapid);
  EXPECT_NEAR(z_mm(points_of_lines(path, 8, 8).back()), -2.0, kTight);
  expect_xy(end_of_line(path, 9), 0.0, 35.0);  // G40 next: the offset end
  // The moves come in program order although each is made one element late.
  for (std::size_t i = 1; i < path.points.size(); ++i) {
    EXPECT_LE(line_of(path, path.points[i - 1]), line_of(path, path.points[i]));
  }
}

// --- Circles: radius R - r inside, R + r outside ------------------------------------------------

struct CircleCase {
  const char* compensation;
  const char* arc;
  double offset_radius_mm;  // R = 20, r = 5
};

class CompensatedCircle : public ::testing::TestWithParam<CircleCase> {};

// Entry from the centre (0, 0) to the circle's start P = (20, 0), r = 5, cos t = 5 / 20. With the
// tool inside (G41 on G3, G42 on G2) the entry's tangent point T = (18.75, +-5 sin t) lies beyond
// the offset circle of radius 15: the entry stops on it, on the line from the centre through T:
// 15 T / |T| = 15 T / sqrt(375) = (3 * 18.75 / sqrt(15), +-3.75). Outside, the tool rolls about P
// from T onto the offset circle of radius 25 at (25, 0).
TEST_P(CompensatedCircle, FollowsTheOffsetCircle) {
  const CircleCase& c = GetParam();
  const std::string program = std::string("G17 G21 G90\nG0 X0 Y0 Z5\nG1 Z-2 F300\n") + c.compensation +
                              " D1 X20 Y0\n" + c.arc + " X20 Y0 I-20 J0\nG40 G1 X0 Y0\n";
  const Toolpath path = parse_gcode(program, "circle.nc", with_radius(5.0));
  const bool ccw = std::string(c.arc) == "G3";
  const bool inside = c.offset_radius_mm < 20.0;
  if (inside) {
    expect_xy(end_of_line(path, 4), 3.0 * 18.75 / std::sqrt(15.0), ccw ? 3.75 : -3.75);
  } else {
    expect_xy(end_of_line(path, 4), 18.75, (ccw ? -1.0 : 1.0) * 5.0 * std::sqrt(15.0) / 4.0);
  }
  const std::vector<PathPoint> circle = points_of_lines(path, 5, 5);
  ASSERT_GT(circle.size(), 100u);
  std::size_t on_circle = 0;
  for (const PathPoint& point : circle) {
    const double from_centre = xy_mm(point).norm();
    const double from_p = (xy_mm(point) - Eigen::Vector2d(20, 0)).norm();
    // Outside: the roll about P first (radius 5 about P), then the offset circle.
    if (!inside && std::abs(from_p - 5.0) < kTight && std::abs(from_centre - 25.0) > kTight) continue;
    EXPECT_NEAR(from_centre, c.offset_radius_mm, kTight) << xy_mm(point).transpose();
    ++on_circle;
  }
  EXPECT_GT(on_circle, 100u);
  expect_xy(end_of_line(path, 5), c.offset_radius_mm, 0.0);  // G40: the offset end
  expect_xy(end_of_line(path, 6), 0.0, 0.0);
}

INSTANTIATE_TEST_SUITE_P(Sides, CompensatedCircle,
                         ::testing::Values(CircleCase{"G41", "G3", 15.0}, CircleCase{"G42", "G3", 25.0},
                                           CircleCase{"G42", "G2", 15.0}, CircleCase{"G41", "G2", 25.0}),
                         [](const ::testing::TestParamInfo<CircleCase>& param_info) {
                           return std::string(param_info.param.compensation) + "_" + param_info.param.arc;
                         });

// --- The geometry alone: entry, line-arc and arc-arc joints ------------------------------------

PlaneElement line(Eigen::Vector2d a, Eigen::Vector2d b, int tag) {
  PlaneElement e;
  e.start = a;
  e.end = b;
  e.tag = tag;
  return e;
}

PlaneElement arc(Eigen::Vector2d a, Eigen::Vector2d b, Eigen::Vector2d centre, bool ccw, int tag) {
  PlaneElement e;
  e.arc = true;
  e.start = a;
  e.end = b;
  e.centre = centre;
  double sweep = std::atan2((b - centre).y(), (b - centre).x()) - std::atan2((a - centre).y(), (a - centre).x());
  if (ccw && sweep <= 0) sweep += 2 * std::numbers::pi;
  if (!ccw && sweep >= 0) sweep -= 2 * std::numbers::pi;
  e.sweep_rad = sweep;
  e.tag = tag;
  return e;
}

/// The move of element `tag` (corner: its corner arc).
CompensatedMove move_of(const std::vector<CompensatedMove>& moves, int tag, bool corner = false) {
  for (const CompensatedMove& m : moves) {
    if (m.tag == tag && m.corner == corner) return m;
  }
  ADD_FAILURE() << "no move of element " << tag << (corner ? " (corner)" : "");
  return {};
}

std::vector<CompensatedMove> run(CutterCompensator& compensator, const std::vector<PlaneElement>& elements) {
  std::vector<CompensatedMove> moves;
  for (const PlaneElement& e : elements) {
    for (const CompensatedMove& m : compensator.add(e)) moves.push_back(m);
  }
  for (const CompensatedMove& m : compensator.finish()) moves.push_back(m);
  return moves;
}

// LinuxCNC's entry from C = (0, 0) to P = (10, 0) with r = 6: T at 6 from P with (T - C) square
// to (T - P): cos t = 6 / 10, T = (10 - 6 * 0.6, +-6 * 0.8) = (6.4, +-4.8), left for G41.
TEST(CutterCompensator, EntryEndsTangentToTheToolCircleAboutItsEnd) {
  for (const auto side : {CompensationSide::left, CompensationSide::right}) {
    CutterCompensator compensator(side, 6.0, {0, 0}, 0.0);
    const auto moves = run(compensator, {line({0, 0}, {10, 0}, 1)});
    ASSERT_EQ(moves.size(), 1u);
    expect_xy(moves[0].end, 6.4, side == CompensationSide::left ? 4.8 : -4.8);
    EXPECT_NEAR((moves[0].end - Eigen::Vector2d(10, 0)).dot(moves[0].end), 0.0, kTight);
  }
}

// A line +x into a counter-clockwise arc about (10, 10) that starts along +x: tangent, so the
// line's offset end (10, 2) is the arc's offset start; the arc (inside, radius 10 - 2) ends at
// (18, 10). No corner move.
TEST(CutterCompensator, TangentLineArcJoinIsUnchanged) {
  CutterCompensator compensator(CompensationSide::left, 2.0, {-10, 0}, 0.0);
  const auto moves =
      run(compensator, {line({-10, 0}, {0, 0}, 1), line({0, 0}, {10, 0}, 2), arc({10, 0}, {20, 10}, {10, 10}, true, 3)});
  ASSERT_EQ(moves.size(), 4u);  // the entry, its corner onto the line, the line, the arc
  expect_xy(move_of(moves, 2).end, 10.0, 2.0);
  const CompensatedMove a = move_of(moves, 3);
  EXPECT_TRUE(a.arc);
  expect_xy(a.start, 10.0, 2.0);
  expect_xy(a.end, 18.0, 10.0);
  expect_xy(a.centre, 10.0, 10.0);
  EXPECT_NEAR(a.sweep_rad, std::numbers::pi / 2.0, kTight);
  EXPECT_EQ(moves.back().tag, 3);  // no corner move before the arc
}

// A line +x into a counter-clockwise arc about (20, 0) starting at (10, 0) (its start tangent is
// -y: a right turn of 90 deg). G41: convex, the tool rolls about (10, 0) from (10, 2) to the
// arc's offset start (12, 0), clockwise, 90 deg. G42: concave, the line's offset y = -2 meets
// the arc's offset (radius 12) at x = 20 - sqrt(144 - 4).
TEST(CutterCompensator, NonTangentLineArcJoins) {
  const std::vector<PlaneElement> elements = {line({-10, 0}, {0, 0}, 1), line({0, 0}, {10, 0}, 2),
                                              arc({10, 0}, {30, 0}, {20, 0}, true, 3)};
  {
    CutterCompensator compensator(CompensationSide::left, 2.0, {-10, 0}, 0.0);
    const auto moves = run(compensator, elements);
    expect_xy(move_of(moves, 2).end, 10.0, 2.0);
    const CompensatedMove corner = move_of(moves, 3, true);
    expect_xy(corner.start, 10.0, 2.0);
    expect_xy(corner.centre, 10.0, 0.0);
    expect_xy(corner.end, 12.0, 0.0);
    EXPECT_NEAR(corner.sweep_rad, -std::numbers::pi / 2.0, kTight);
    const CompensatedMove a = move_of(moves, 3);
    expect_xy(a.end, 28.0, 0.0);  // radius 8 about (20, 0), half a turn
    EXPECT_NEAR(a.sweep_rad, std::numbers::pi, kTight);
  }
  {
    CutterCompensator compensator(CompensationSide::right, 2.0, {-10, 0}, 0.0);
    const auto moves = run(compensator, elements);
    expect_xy(move_of(moves, 2).end, 20.0 - std::sqrt(140.0), -2.0);
    const CompensatedMove a = move_of(moves, 3);
    EXPECT_TRUE(a.arc);
    expect_xy(a.start, 20.0 - std::sqrt(140.0), -2.0);
    expect_xy(a.end, 32.0, 0.0);
    EXPECT_NEAR((a.end - a.centre).norm(), 12.0, kTight);
    EXPECT_EQ(moves.back().tag, 3);  // no corner arc before the arc: concave
  }
}

// Two counter-clockwise arcs meeting at (0, 10): about (0, 0) from (10, 0) and about (10, 10)
// from (0, 10) (a left turn from -x to -y). G41, r = 2: both offsets have radius 8; the concave
// corner is their intersection nearest the corner, (5 - sqrt 7, 5 + sqrt 7).
TEST(CutterCompensator, ConcaveArcArcJoinIsTheCirclesIntersection) {
  CutterCompensator compensator(CompensationSide::left, 2.0, {10, -20}, 0.0);
  const auto moves = run(compensator, {line({10, -20}, {10, 0}, 1), arc({10, 0}, {0, 10}, {0, 0}, true, 2),
                                       arc({0, 10}, {10, 0}, {10, 10}, true, 3)});
  const CompensatedMove first = move_of(moves, 2), second = move_of(moves, 3);
  expect_xy(first.end, 5.0 - std::sqrt(7.0), 5.0 + std::sqrt(7.0));
  expect_xy(second.start, 5.0 - std::sqrt(7.0), 5.0 + std::sqrt(7.0));
  expect_xy(second.end, 10.0, 2.0);
  EXPECT_NEAR(first.end.norm(), 8.0, kTight);
  EXPECT_EQ(moves.back().tag, 3);
}

// A move along w only is made where the previous element ends, once the next one says where.
TEST(CutterCompensator, NormalMovesWaitForTheCorner) {
  CutterCompensator compensator(CompensationSide::left, 1.0, {0, -10}, 5.0);
  EXPECT_EQ(compensator.add_normal_move(-1.0, 1).size(), 1u);  // before the entry: at once
  EXPECT_TRUE(compensator.add(line({0, -10}, {0, 0}, 2)).empty());
  EXPECT_TRUE(compensator.add_normal_move(3.0, 3).empty());
  const auto moves = compensator.add(line({0, 0}, {-10, 0}, 4));  // a left turn: concave for G41
  // The entry's tangent point T = (-sqrt(0.99), -0.1) (cos t = 1 / 10); the entry stops where its
  // line from (0, -10) meets the next side's offset y = -1: 9 / 9.9 of the way.
  ASSERT_EQ(moves.size(), 2u);
  const double x = -std::sqrt(0.99) * 9.0 / 9.9;
  expect_xy(moves[0].end, x, -1.0);
  expect_xy(moves[1].start, x, -1.0);
  expect_xy(moves[1].end, x, -1.0);
  EXPECT_DOUBLE_EQ(moves[1].end_w_mm, 3.0);
  EXPECT_EQ(moves[1].tag, 3);
}

// --- Errors, each at its file, line and column --------------------------------------------------

std::string error_of(const std::string& program, const ReaderOptions& options = with_radius(5.0)) {
  return input_error_of([&] { parse_gcode(program, "t.nc", options); });
}

const std::string kStart = "G17 G21 G90\nG0 X0 Y0 Z5\nG1 Z-2 F300\n";  // lines 1-3

TEST(CutterCompensationErrors, AreLocated) {
  // An inside arc smaller than the tool.
  EXPECT_NE(error_of(kStart + "G41 D1 X20 Y0\nG3 X26 Y0 I3 J0\n")
                .find("t.nc:5:1: 'G3': tool radius larger than arc radius"),
            std::string::npos)
      << error_of(kStart + "G41 D1 X20 Y0\nG3 X26 Y0 I3 J0\n");
  // An arc as the entry move.
  EXPECT_NE(error_of(kStart + "G41 D1 G2 X20 Y0 I10 J0\n").find("t.nc:4:8: 'G2': the move that starts cutter "
                                                                 "compensation must be a line"),
            std::string::npos);
  // An entry not longer than the radius.
  EXPECT_NE(error_of(kStart + "G41 D1 X4 Y0\n").find("t.nc:4:8: 'X4': the move that starts cutter compensation is 4 mm"),
            std::string::npos);
  // A slot 8 mm wide for a 10 mm tool: the bottom's offset runs backwards at the corner.
  const std::string slot = "G17 G21 G90\nG0 X4 Y20 Z5\nG1 Z-2 F300\nG41 D1 X4 Y0\nX8\nY40\nX0\nY0\nG40 X4 Y20\n";
  EXPECT_NE(error_of(slot).find("t.nc:6:1: 'Y40': cutter compensation gouges"), std::string::npos) << error_of(slot);
  // A D that the tool table does not have.
  EXPECT_NE(error_of(kStart + "G41 D7 X20 Y0\n").find("t.nc:4:5: 'D7': no cutter radius for D7 (the tool table has D1"),
            std::string::npos);
  // Other planes and tool-centre-point mode.
  EXPECT_NE(error_of(kStart + "G18 G41 D1\n").find("t.nc:4:5: 'G41': cutter radius compensation in the G18 plane"),
            std::string::npos);
  EXPECT_NE(error_of(kStart + "G43.4 H0\nG42 D1\n").find("t.nc:5:1: 'G42': cutter radius compensation under "
                                                       "tool-centre-point mode"),
            std::string::npos);
  // An arc right after G40.
  EXPECT_NE(error_of(kStart + "G41 D1 X20 Y0\nX40\nG40\nG2 X50 Y-10 I0 J-10\n")
                .find("t.nc:7:1: 'G2': the move after G40 (cutter compensation off) must be a line"),
            std::string::npos);
  // What would move the contour under compensation.
  EXPECT_NE(error_of(kStart + "G41 D1 X20 Y0\nG55\n").find("t.nc:5:1: 'G55': a work offset change under cutter "
                                                          "compensation is not supported"),
            std::string::npos);
  EXPECT_NE(error_of(kStart + "G41 D1 X20 Y0\nG81 X30 Y0 Z-5 R1\n").find("t.nc:5:1: 'G81'"), std::string::npos);
  EXPECT_NE(error_of(kStart + "G41 D1 X20 Y0\nG42 D1\n").find("t.nc:5:1: 'G42': cutter compensation is already on"),
            std::string::npos);
  // No radius known: no D and no tool.
  EXPECT_NE(error_of(kStart + "G41 X20 Y0\n").find("t.nc:4:1: 'G41': G41 / G42 without D and without a tool"),
            std::string::npos);
}

// Without D the last D, else the tool in the spindle (LinuxCNC); D0 leaves the path as written.
TEST(CutterCompensation, RadiusWithoutDAndD0) {
  ReaderOptions options;
  options.cutter_radius_mm = {{3, 5.0}};
  const std::string tool_in_spindle = "T3 M6\n" + kStart + "G41 X20 Y0\nX40\nG40 Y20\n";
  expect_xy(end_of_line(parse_gcode(tool_in_spindle, "t.nc", options), 6), 40.0, 5.0);
  const std::string d0 = kStart + "G41 D0 X20 Y0\nX40\nG40 Y20\n";
  expect_xy(end_of_line(parse_gcode(d0, "t.nc", options), 5), 40.0, 0.0);
  options.default_cutter_radius_mm = 2.0;  // a D not in the table takes the default
  const std::string other_d = kStart + "G41 D9 X20 Y0\nX40\nG40 Y20\n";
  expect_xy(end_of_line(parse_gcode(other_d, "t.nc", options), 5), 40.0, 2.0);
}

// A G41 left on at the end: the last element ends at its offset end, with a warning.
TEST(CutterCompensation, StillOnAtTheEndIsEndedAsByG40) {
  const Toolpath path = parse_gcode(kStart + "G41 D1 X20 Y0\nX40\nM30\n", "t.nc", with_radius(5.0));
  expect_xy(end_of_line(path, 5), 40.0, 5.0);
  bool warned = false;
  for (const auto& warning : path.warnings) warned = warned || warning.message.find("no G40") != std::string::npos;
  EXPECT_TRUE(warned);
}

// --- Siemens 840D: G41 / G42 with the active tool's radius, NORM entry ---------------------------

ReaderOptions siemens_options() {
  ReaderOptions options;
  options.cutter_radius_mm = {{1, 5.0}};  // by T number: the cutting edge D1 of T1
  options.tool_length_mm = {{1, 0.0}};
  return options;
}

// The pocket of InsideSquareCornersAreTheOffsetsIntersections on an 840D: the same corners; the
// entry (NORM) goes straight to the first side's offset start (20, 5). Under MIRROR X0 every point
// is mirrored (the tool stays inside the mirrored pocket: the control turns G41 into G42 there).
TEST(CutterCompensationSiemens, PocketWithNormEntryAndUnderAMirror) {
  for (const bool mirrored : {false, true}) {
    const std::string program = std::string("G17 G71 G90 G94\nT1 M6\n") + (mirrored ? "MIRROR X0\n" : "G0 X20\n") +
                                "G0 X20 Y20 Z5\nG1 Z-2 F300\nG41 X20 Y0\nX40\nY40\nX0\nY0\nX20\nG40 X20 Y20\nM30\n";
    const Toolpath path = parse_siemens(program, "pocket.mpf", siemens_options());
    const double sx = mirrored ? -1.0 : 1.0;
    expect_xy(end_of_line(path, 6), sx * 20.0, 5.0);
    expect_xy(end_of_line(path, 7), sx * 35.0, 5.0);
    expect_xy(end_of_line(path, 8), sx * 35.0, 35.0);
    expect_xy(end_of_line(path, 9), sx * 5.0, 35.0);
    expect_xy(end_of_line(path, 10), sx * 5.0, 5.0);
    expect_xy(end_of_line(path, 11), sx * 20.0, 5.0);
    expect_xy(end_of_line(path, 12), sx * 20.0, 20.0);
  }
}

TEST(CutterCompensationSiemens, ErrorsAreLocated) {
  const std::string start = "G17 G71 G90 G94\nT1 M6\nG0 X20 Y20 Z5\nG1 Z-2 F300\nG41 X20 Y0\n";  // 1-5
  const auto error = [](const std::string& program) {
    return input_error_of([&] { parse_siemens(program, "t.mpf", siemens_options()); });
  };
  EXPECT_NE(error(start + "TRANS X10\n").find("t.mpf:6:1: 'TRANS': TRANS under cutter compensation is not supported"),
            std::string::npos)
      << error(start + "TRANS X10\n");
  EXPECT_NE(error(start + "CIP X40 Y0 I1=30 J1=-5\n").find("t.mpf:6:1: 'CIP'"), std::string::npos);
  EXPECT_NE(error(start + "X40\nG3 X46 Y0 CR=3\n").find("t.mpf:7:1: 'G3': tool radius larger than arc radius"),
            std::string::npos)
      << error(start + "X40\nG3 X46 Y0 CR=3\n");
  ReaderOptions no_radius = siemens_options();
  no_radius.cutter_radius_mm.clear();
  EXPECT_NE(input_error_of([&] { parse_siemens(start, "t.mpf", no_radius); })
                .find("t.mpf:5:1: 'G41': no cutter radius for T1 D1"),
            std::string::npos);
}

// --- Property: random convex polygons offset outward -------------------------------------------

// For each random convex polygon and tool radius, the outside contour is programmed both ways
// (counter-clockwise with G42, clockwise with G41): every tool-centre point of the contour is
// r from the polygon (brute force: the nearest of its edges), outside it, and at every corner a
// point is exactly r from the corner (the tool touches it there).
TEST(CutterCompensationProperty, ConvexPolygonsOffsetOutwardStayAtTheRadius) {
  std::mt19937 random(19);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int trial = 0; trial < 200; ++trial) {
    const int n = 3 + static_cast<int>(unit(random) * 10.0);
    const double size = 20.0 + 40.0 * unit(random);
    const double radius = 0.5 + 9.5 * unit(random);
    // Vertices on an ellipse at sorted random angles, at least 5 deg apart: convex.
    std::vector<double> angles;
    while (static_cast<int>(angles.size()) < n) {
      const double a = 2.0 * std::numbers::pi * unit(random);
      bool apart = true;
      for (double b : angles) {
        const double d = std::abs(std::remainder(a - b, 2.0 * std::numbers::pi));
        apart = apart && d > 5.0 * std::numbers::pi / 180.0;
      }
      if (apart) angles.push_back(a);
    }
    std::sort(angles.begin(), angles.end());
    const double aspect = 0.5 + unit(random);
    std::vector<Eigen::Vector2d> polygon;
    for (double a : angles) polygon.emplace_back(size * std::cos(a), aspect * size * std::sin(a));
    for (const bool clockwise : {false, true}) {
      std::vector<Eigen::Vector2d> order = polygon;
      if (clockwise) std::reverse(order.begin(), order.end());
      const Eigen::Vector2d edge = (order[1] - order[0]).normalized();
      // Outside of the first edge: right of a counter-clockwise contour, left of a clockwise one.
      const Eigen::Vector2d outward = clockwise ? Eigen::Vector2d(-edge.y(), edge.x())
                                                : Eigen::Vector2d(edge.y(), -edge.x());
      // The entry runs along the first side's offset line: LinuxCNC's tangent point is then the
      // side's offset start and the joint is tangent (an entry at an angle can gouge a short
      // side or the last one, as on the control).
      const Eigen::Vector2d entry = order[0] + radius * outward - 3.0 * radius * edge;
      std::ostringstream program;
      program.precision(17);
      program << "G17 G21 G90 G94\nG0 X" << entry.x() << " Y" << entry.y() << " Z5\nG1 Z-1 F500\n";  // 1-3
      program << (clockwise ? "G41" : "G42") << " D1 X" << order[0].x() << " Y" << order[0].y() << "\n";  // 4
      for (std::size_t i = 1; i <= order.size(); ++i) {  // lines 5 .. 4 + n
        const Eigen::Vector2d& p = order[i % order.size()];
        program << "X" << p.x() << " Y" << p.y() << "\n";
      }
      program << "G40 X" << entry.x() << " Y" << entry.y() << "\n";
      const Toolpath path = parse_gcode(program.str(), "polygon.nc", with_radius(radius));
      const std::vector<PathPoint> contour = points_of_lines(path, 5, 4 + n);
      ASSERT_GE(contour.size(), static_cast<std::size_t>(n)) << "trial " << trial;
      std::vector<double> nearest_to_corner(static_cast<std::size_t>(n), std::numeric_limits<double>::infinity());
      for (const PathPoint& point : contour) {
        const Eigen::Vector2d p = xy_mm(point);
        const double d = distance_to_polygon(p, polygon);
        EXPECT_GE(d, radius - 1e-9) << "trial " << trial << " point " << p.transpose();
        EXPECT_LE(d, radius + 1e-9) << "trial " << trial << " point " << p.transpose();
        for (std::size_t k = 0; k < polygon.size(); ++k) {
          nearest_to_corner[k] = std::min(nearest_to_corner[k], (p - polygon[k]).norm());
        }
      }
      for (std::size_t k = 0; k < polygon.size(); ++k) {
        EXPECT_NEAR(nearest_to_corner[k], radius, 1e-9) << "trial " << trial << " corner " << k;
      }
      // Outside: farther from the centre than the contour along the same direction is not
      // needed: a point r from a convex polygon's boundary and not inside it is outside; check
      // it is not inside (left of every counter-clockwise edge).
      for (const PathPoint& point : contour) {
        const Eigen::Vector2d p = xy_mm(point);
        bool inside = true;
        for (std::size_t k = 0; k < polygon.size(); ++k) {
          const Eigen::Vector2d a = polygon[k], b = polygon[(k + 1) % polygon.size()];
          inside = inside && (b - a).x() * (p - a).y() - (b - a).y() * (p - a).x() > 0.0;
        }
        EXPECT_FALSE(inside) << "trial " << trial;
      }
      EXPECT_NEAR((xy_mm(path.points.back()) - entry).norm(), 0.0, 1e-9);
    }
  }
}

}  // namespace
}  // namespace vmsim::toolpath
