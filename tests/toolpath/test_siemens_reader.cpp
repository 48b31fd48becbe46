// The Siemens 840D reader against hand-computed results: each frame operation (TRANS ATRANS ROT
// AROT MIRROR, CYCLE800), each arc form (G2/G3 with I J K and CR=, CIP, CT), the NC modes that
// go into the path points (CYCLE832, G60/G64/G641/G642, SOFT/BRISK, FFWON/FFWOF, COMPCAD), the
// language (R parameters, DEF, IF/GOTOF, WHILE, FOR, REPEAT, L subprograms) and bad input.
#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <cmath>
#include <fstream>
#include <numbers>
#include <string>

#include "../temp_folder.hpp"
#include "reader_test_support.hpp"
#include "vmsim/toolpath/toolpath.hpp"

namespace vmsim::toolpath {
namespace {

using test::expect_vector;

Toolpath siemens(const std::string& text, const ReaderOptions& options = {}) {
  return parse_siemens(text, "part.mpf", options);
}
std::string siemens_error(const std::string& text, const ReaderOptions& options = {}) {
  return test::input_error_of([&] { siemens(text, options); });
}
Eigen::Vector3d mm(double x, double y, double z) { return Eigen::Vector3d(x, y, z) * 1e-3; }
constexpr double kTight = 1e-15;
const double kSqrt3 = std::sqrt(3.0);

// --- Frames --------------------------------------------------------------------------------

TEST(SiemensFrames, TransShiftsTheZeroAndAnAbsoluteTransReplacesIt) {
  const Toolpath path = siemens(
      "G0 X0 Y0 Z0\n"
      "TRANS X10 Y20\n"
      "G1 X5 Y5 F1000\n"
      "TRANS Z-3\n"  // absolute: X Y shift gone
      "G1 X5 Y5 Z0\n"
      "TRANS\n"
      "G1 X1 Y2 Z3\n");
  ASSERT_EQ(path.points.size(), 4u);
  expect_vector(path.points[1].tip_W_m, mm(15, 25, 0), kTight);
  expect_vector(path.points[2].tip_W_m, mm(5, 5, -3), kTight);
  expect_vector(path.points[3].tip_W_m, mm(1, 2, 3), kTight);
}

TEST(SiemensFrames, RotInThePlaneAndRpyInSpace) {
  // ROT RPL=30 under G17: X10 -> (10 cos 30, 10 sin 30).
  Toolpath path = siemens("G0 X0 Y0 Z0\nROT RPL=30\nG1 X10 Y0 F100\n");
  expect_vector(path.points.back().tip_W_m, mm(5 * kSqrt3, 5, 0), 1e-17);
  // ROT Z30 is the same rotation.
  path = siemens("G0 X0 Y0 Z0\nROT Z30\nG1 X10 Y0 F100\n");
  expect_vector(path.points.back().tip_W_m, mm(5 * kSqrt3, 5, 0), 1e-17);
  // ROT X90 Z90: about Z, then the new Y (0), then the new X: R = Rz(90) Rx(90). X1 -> Rz(90)
  // (1, 0, 0) = (0, 1, 0); Y1 -> Rz(90) Rx(90) (0, 1, 0) = Rz(90) (0, 0, 1) = (0, 0, 1).
  path = siemens("G0 X0 Y0 Z0\nROT X90 Z90\nG1 X1 Y0 Z0 F100\nG1 X0 Y1 Z0\n");
  expect_vector(path.points[1].tip_W_m, mm(0, 1, 0), 1e-17);
  expect_vector(path.points[2].tip_W_m, mm(0, 0, 1), 1e-17);
  // ROT G18 RPL=90 turns about Y: Z1 -> X1 (Ry(90) (0, 0, 1) = (1, 0, 0)).
  path = siemens("G0 X0 Y0 Z0\nG18\nROT RPL=90\nG1 X0 Y0 Z1 F100\n");
  expect_vector(path.points.back().tip_W_m, mm(1, 0, 0), 1e-17);
}

TEST(SiemensFrames, AtransAndArotAddInTheCurrentFrame) {
  // TRANS X10, then AROT RPL=90 about the new zero: X5 -> (10, 5, 0).
  Toolpath path = siemens("G0 X0 Y0 Z0\nTRANS X10\nAROT RPL=90\nG1 X5 Y0 F100\n");
  expect_vector(path.points.back().tip_W_m, mm(10, 5, 0), 1e-15);
  // ROT RPL=90, then ATRANS X10 along the rotated X (= W's Y): X1 -> (0, 11, 0).
  path = siemens("G0 X0 Y0 Z0\nROT RPL=90\nATRANS X10\nG1 X1 Y0 F100\n");
  expect_vector(path.points.back().tip_W_m, mm(0, 11, 0), 1e-15);
  // Two AROT RPL=45 make 90: X2 -> (0, 2, 0).
  path = siemens("G0 X0 Y0 Z0\nAROT RPL=45\nAROT RPL=45\nG1 X2 Y0 F100\n");
  expect_vector(path.points.back().tip_W_m, mm(0, 2, 0), 1e-15);
}

TEST(SiemensFrames, MirrorFlipsTheAxisAndTheSenseOfArcs) {
  Toolpath path = siemens("G0 X0 Y0 Z0\nMIRROR X0\nG1 X5 Y3 F100\nG91 X2\n");
  expect_vector(path.points[1].tip_W_m, mm(-5, 3, 0), kTight);
  expect_vector(path.points[2].tip_W_m, mm(-7, 3, 0), kTight);
  // G2 from (10, 0) to (0, 10) about the origin is the long way in program coordinates (270 deg
  // clockwise, through (0, -10) and (-10, 0)); mirrored in X it runs on W from (-10, 0) through
  // (0, -10) and (10, 0) to (0, 10): counter-clockwise, as the control turns G2 into G3.
  path = siemens("G0 X10 Y0 Z0\nMIRROR X0\nG0 X10 Y0\nG2 X0 Y10 I-10 J0 F100\n");
  const std::size_t first = 2;
  double min_y = 1.0;
  for (std::size_t i = first; i < path.points.size(); ++i) {
    EXPECT_NEAR(path.points[i].tip_W_m.norm(), 0.010, 1e-9);
    min_y = std::min(min_y, path.points[i].tip_W_m.y());
  }
  EXPECT_NEAR(min_y, -0.010, 1e-7);  // it passes (0, -10), within the chord tolerance
  // Counter-clockwise on W: the cross product of successive radii points to +Z.
  const Eigen::Vector3d a = path.points[first].tip_W_m, b = path.points[first + 1].tip_W_m;
  EXPECT_GT(a.cross(b).z(), 0.0);
  expect_vector(path.points.back().tip_W_m, mm(0, 10, 0), kTight);
}

TEST(SiemensFrames, Cycle800SwivelsTheFrameAndTheToolAxis) {
  // Axis by axis, _MODE 57 (X, then Y, then Z): 30 deg about Y. A point p of the swivelled
  // plane is at Ry(30) p in W and the tool axis is Ry(30) z = (sin 30, 0, cos 30).
  Toolpath path = siemens(
      "G0 X0 Y0 Z0\n"
      "CYCLE800(1,\"TC1\",200000,57,0,0,0,0,30,0,0,0,0,-1,100,1)\n"
      "G0 X10 Y0 Z0\n"
      "G1 X0 Y0 Z10 F100\n");
  ASSERT_EQ(path.points.size(), 3u);
  expect_vector(path.points[1].tip_W_m, mm(5 * kSqrt3, 0, -5), 1e-17);
  expect_vector(path.points[1].axis_W, {0.5, 0.0, kSqrt3 / 2}, 1e-15);
  expect_vector(path.points[2].tip_W_m, mm(5, 0, 5 * kSqrt3), 1e-17);
  // Zero before the rotation (_X0 = 10) and after it (_Z1 = 5): W = (10, 0, 0) + R ((0, 0, 5) + p).
  path = siemens(
      "G0 X0 Y0 Z0\n"
      "CYCLE800(1,\"TC1\",200000,57,10,0,0,0,30,0,0,0,5,-1,100,1)\n"
      "G0 X0 Y0 Z0\n");
  expect_vector(path.points[1].tip_W_m, mm(10 + 2.5, 0, 2.5 * kSqrt3), 1e-17);
  // _MODE 27 (Z, then Y, then X): 90 deg about Z; the tool stays vertical.
  path = siemens("G0 X0 Y0 Z0\nCYCLE800(0,\"\",0,27,0,0,0,90,0,0,0,0,0,1)\nG1 X10 Y0 Z0 F100\n");
  expect_vector(path.points[1].tip_W_m, mm(0, 10, 0), 1e-15);
  expect_vector(path.points[1].axis_W, {0, 0, 1}, kTight);
  // Two rotations in order: X by 90 then the new Y by 90: R = Rx(90) Ry(90); R z = Rx(90) (1, 0, 0)
  // = (1, 0, 0): the tool lies along +X.
  path = siemens("G0 X0 Y0 Z0\nCYCLE800(0,\"\",0,57,0,0,0,90,90,0,0,0,0,1)\nG1 X0 Y0 Z1 F100\n");
  expect_vector(path.points[1].axis_W, {1, 0, 0}, 1e-15);
  expect_vector(path.points[1].tip_W_m, mm(1, 0, 0), 1e-17);
  // CYCLE800() resets: back to the plain frame and a vertical tool.
  path = siemens(
      "G0 X0 Y0 Z0\nCYCLE800(1,\"TC1\",200000,57,0,0,0,0,30,0,0,0,0,-1,100,1)\nG0 X10 Y0 Z0\n"
      "CYCLE800()\nG0 X10 Y0 Z50\n");
  expect_vector(path.points.back().tip_W_m, mm(10, 0, 50), kTight);
  expect_vector(path.points.back().axis_W, {0, 0, 1}, kTight);
}

TEST(SiemensFrames, SettableOffsetsAndTheToolLengthOutsideTraori) {
  // G54 holds the machine axes at which the gauge point is at the work zero; D1 after M6 takes
  // the tool's length: machine Z = offset Z + length + program Z, and the tip is the program
  // point moved by the offset.
  ReaderOptions options;
  options.work_offsets_mm["G54"] = Eigen::Vector3d(100, 50, -200);
  options.work_offsets_mm["G55"] = Eigen::Vector3d(0, 0, -100);
  options.tool_length_mm[3] = 60.0;
  std::vector<std::pair<char, double>> seen;
  options.axis_words_to_pose = [&](const std::vector<std::pair<char, double>>& words) {
    seen = words;
    Eigen::Vector3d machine(words[0].second, words[1].second, words[2].second);
    return AxisWordPose{(machine - Eigen::Vector3d(0, 0, 60)) * 1e-3, Eigen::Vector3d::UnitZ()};
  };
  const Toolpath path = siemens("T3 M6\nG54 G0 X1 Y2 Z3\nG55\nG0 X1 Y2 Z3\nG500 G0 X1 Y2 Z3\n", options);
  ASSERT_EQ(path.points.size(), 3u);
  expect_vector(path.points[0].tip_W_m, mm(101, 52, -197), 1e-15);
  expect_vector(path.points[1].tip_W_m, mm(1, 2, -97), 1e-15);
  expect_vector(path.points[2].tip_W_m, mm(1, 2, 3), 1e-15);
  ASSERT_EQ(seen.size(), 3u);
  EXPECT_DOUBLE_EQ(seen[2].second, 63.0);  // G500: machine Z = length + program Z
}

TEST(SiemensFrames, TraoriToolVectorTurnsWithTheFrame) {
  // Under TRAORI the tip is programmed; ROT Z90 turns both the point and the vector (ORIWKS).
  const Toolpath path = siemens(
      "TRAORI\nG0 X0 Y0 Z100 A3=0 B3=0 C3=1\nROT Z90\nG1 X10 Y0 Z5 A3=0.6 B3=0 C3=0.8 F1000\nTRAFOOF\n");
  expect_vector(path.points.back().tip_W_m, mm(0, 10, 5), 1e-15);
  expect_vector(path.points.back().axis_W, {0, 0.6, 0.8}, 1e-15);
}

// --- Arcs ----------------------------------------------------------------------------------

/// Every point from `first` on lies on the circle of centre c and radius r [mm] in the plane z.
void expect_on_circle(const Toolpath& path, std::size_t first, const Eigen::Vector3d& c_mm, double r_mm) {
  for (std::size_t i = first; i < path.points.size(); ++i) {
    EXPECT_NEAR((path.points[i].tip_W_m * 1e3 - c_mm).norm(), r_mm, 1e-9) << "point " << i;
  }
}

TEST(SiemensArcs, CentreAndRadiusForms) {
  // G3 from (10, 0) to (0, 10) with I-10: the quarter about the origin.
  Toolpath path = siemens("G0 X10 Y0 Z0\nG3 X0 Y10 I-10 J0 F100\n");
  expect_on_circle(path, 1, {0, 0, 0}, 10);
  EXPECT_GT(path.points[1].tip_W_m.x(), 0.0);
  EXPECT_GT(path.points[1].tip_W_m.y(), 0.0);
  expect_vector(path.points.back().tip_W_m, mm(0, 10, 0), kTight);
  // I=AC(0) J=AC(0): the same centre given absolutely.
  Toolpath absolute = siemens("G0 X10 Y0 Z0\nG3 X0 Y10 I=AC(0) J=AC(0) F100\n");
  ASSERT_EQ(absolute.points.size(), path.points.size());
  for (std::size_t i = 0; i < path.points.size(); ++i) expect_vector(absolute.points[i].tip_W_m, path.points[i].tip_W_m, 1e-15);
  // CR=10: the short arc, same quarter.
  Toolpath short_arc = siemens("G0 X10 Y0 Z0\nG3 X0 Y10 CR=10 F100\n");
  ASSERT_EQ(short_arc.points.size(), path.points.size());
  for (std::size_t i = 0; i < path.points.size(); ++i) expect_vector(short_arc.points[i].tip_W_m, path.points[i].tip_W_m, 1e-15);
  // CR=-10: the long way, about (10, 10): it reaches x = 20.
  Toolpath long_arc = siemens("G0 X10 Y0 Z0\nG3 X0 Y10 CR=-10 F100\n");
  expect_on_circle(long_arc, 1, {10, 10, 0}, 10);
  double max_x = 0.0;
  for (const auto& p : long_arc.points) max_x = std::max(max_x, p.tip_W_m.x());
  EXPECT_NEAR(max_x, 0.020, 1e-7);
  // G2 (clockwise) helix: from (10, 0, 0) to (0, -10, -5) about the origin: a quarter with Z
  // falling linearly with the angle.
  Toolpath helix = siemens("G0 X10 Y0 Z0\nG2 X0 Y-10 Z-5 I-10 J0 F100\n");
  for (std::size_t i = 1; i < helix.points.size(); ++i) {
    const Eigen::Vector3d p = helix.points[i].tip_W_m * 1e3;
    const double turned = -std::atan2(p.y(), p.x());  // clockwise angle from +X
    EXPECT_NEAR(std::hypot(p.x(), p.y()), 10.0, 1e-9);
    EXPECT_NEAR(p.z(), -5.0 * turned / (std::numbers::pi / 2), 1e-9);
  }
}

TEST(SiemensArcs, CipRunsThroughItsIntermediatePoint) {
  // From (10, 0, 0) through (0, 10, 0) to (-10, 0, 0): the upper half circle about the origin.
  Toolpath path = siemens("G0 X10 Y0 Z0\nCIP X-10 Y0 Z0 I1=0 J1=10 K1=0 F100\n");
  expect_on_circle(path, 1, {0, 0, 0}, 10);
  for (const auto& p : path.points) EXPECT_GE(p.tip_W_m.y(), -1e-12);
  // Through (0, -10, 0) instead: the lower half.
  path = siemens("G0 X10 Y0 Z0\nCIP X-10 Y0 Z0 I1=0 J1=-10 K1=0 F100\n");
  for (const auto& p : path.points) EXPECT_LE(p.tip_W_m.y(), 1e-12);
  // In space, not in a main plane: the circle through (10, 0, 0), (0, 10, 0), (0, 0, 10) has its
  // centre at (10/3, 10/3, 10/3) and radius sqrt(200/3); the arc goes from the first to the last
  // over the second (240 deg).
  path = siemens("G0 X10 Y0 Z0\nCIP X0 Y0 Z10 I1=0 J1=10 K1=0 F100\n");
  const Eigen::Vector3d c(10.0 / 3, 10.0 / 3, 10.0 / 3);
  expect_on_circle(path, 1, c, std::sqrt(200.0 / 3));
  bool passes_middle = false;
  for (const auto& p : path.points) passes_middle = passes_middle || (p.tip_W_m * 1e3 - Eigen::Vector3d(0, 10, 0)).norm() < 0.01;
  EXPECT_TRUE(passes_middle);
  // G91: I1 J1 K1 from the start.
  Toolpath incremental = siemens("G0 X10 Y0 Z0\nG91 CIP X-20 Y0 Z0 I1=-10 J1=10 K1=0 F100\n");
  expect_on_circle(incremental, 1, {0, 0, 0}, 10);
}

TEST(SiemensArcs, CtContinuesTangentially) {
  // After G1 along +X to (10, 0), CT to (20, 10): the tangent arc has its centre (10, 10),
  // radius 10, and turns 90 deg (the chord makes 45 deg with the tangent); a second CT to
  // (10, 20) continues on the same circle.
  Toolpath path = siemens("G0 X0 Y0 Z0\nG1 X10 Y0 F100\nCT X20 Y10\nCT X10 Y20\n");
  expect_on_circle(path, 2, {10, 10, 0}, 10);
  expect_vector(path.points.back().tip_W_m, mm(10, 20, 0), kTight);
  // The first arc point leaves along +X (y rises slowly): tangent continuity at (10, 0).
  const Eigen::Vector3d d = path.points[2].tip_W_m - path.points[1].tip_W_m;
  EXPECT_LT(std::abs(d.y()) / d.norm(), 0.02);
  EXPECT_GT(d.x(), 0.0);
}

// --- NC modes ------------------------------------------------------------------------------

TEST(SiemensModes, Cycle832AndThePathCommandsGoIntoThePoints) {
  const Toolpath path = siemens(
      "G0 X0 Y0 Z0\n"                    // 0: nothing said
      "CYCLE832(0.01,_FINISH,1)\n"
      "G1 X1 F1000\n"                    // 1: G642 in 10 um, SOFT, FFWON, COMPCAD 10 um
      "BRISK FFWOF\n"
      "G1 X2\n"                          // 2
      "G60 G1 X3\n"                      // 3: exact stop
      "G641 ADIS=0.05 G1 X4\n"           // 4: ADIS 50 um
      "G64 G1 X5\n"                      // 5: continuous path, no tolerance
      "G642 G1 X6\n"                     // 6: CYCLE832's tolerance still
      "CYCLE832(0,_OFF,1)\n"
      "G1 X7\n"                          // 7: G64, COMPOF
      "G642 G1 X8\n"                     // 8: machine data's tolerance (contouring_tolerance_m)
      "G9 G1 X9\n"                       // 9: exact stop here only
      "G1 X10\n");                       // 10
  ASSERT_EQ(path.points.size(), 11u);
  const auto& p = path.points;
  EXPECT_TRUE(std::isnan(p[0].corner_tolerance_m));
  EXPECT_EQ(p[0].jerk_mode, JerkMode::unspecified);
  EXPECT_EQ(p[0].feedforward, FeedforwardMode::unspecified);
  EXPECT_TRUE(std::isnan(p[0].compressor_tolerance_m));
  EXPECT_DOUBLE_EQ(p[1].corner_tolerance_m, 0.01e-3);
  EXPECT_EQ(p[1].jerk_mode, JerkMode::soft);
  EXPECT_EQ(p[1].feedforward, FeedforwardMode::on);
  EXPECT_DOUBLE_EQ(p[1].compressor_tolerance_m, 0.01e-3);
  EXPECT_EQ(p[2].jerk_mode, JerkMode::brisk);
  EXPECT_EQ(p[2].feedforward, FeedforwardMode::off);
  EXPECT_EQ(p[3].corner_tolerance_m, 0.0);
  EXPECT_DOUBLE_EQ(p[4].corner_tolerance_m, 0.05e-3);
  EXPECT_TRUE(std::isnan(p[5].corner_tolerance_m));
  EXPECT_DOUBLE_EQ(p[6].corner_tolerance_m, 0.01e-3);
  EXPECT_TRUE(std::isnan(p[7].corner_tolerance_m));
  EXPECT_EQ(p[7].compressor_tolerance_m, 0.0);
  EXPECT_DOUBLE_EQ(p[8].corner_tolerance_m, ReaderOptions{}.contouring_tolerance_m);
  EXPECT_EQ(p[9].corner_tolerance_m, 0.0);
  EXPECT_DOUBLE_EQ(p[10].corner_tolerance_m, ReaderOptions{}.contouring_tolerance_m);
  EXPECT_EQ(p[10].jerk_mode, JerkMode::brisk);  // CYCLE832 _OFF leaves SOFT / BRISK as they are
}

TEST(SiemensModes, ArcChordsAreNoCorners) {
  const Toolpath path = siemens("G60 G0 X10 Y0 Z0\nG3 X0 Y10 I-10 J0 F100\n");
  ASSERT_GT(path.points.size(), 3u);
  for (std::size_t i = 1; i + 1 < path.points.size(); ++i) EXPECT_TRUE(std::isnan(path.points[i].corner_tolerance_m));
  EXPECT_EQ(path.points.back().corner_tolerance_m, 0.0);
}

// --- Language -------------------------------------------------------------------------------

TEST(SiemensLanguage, ParametersExpressionsAndDimensions) {
  const Toolpath path = siemens(
      "DEF REAL STEP=2.5, DEPTH\n"
      "R1=4 R2=R1*2+1\n"
      "DEPTH=-R1/2\n"
      "G0 X=R2 Y=SIN(30)*10 Z=DEPTH\n"      // (9, 5, -2)
      "G91 G1 X=AC(1) Y=STEP F100\n"        // X absolute 1, Y + 2.5
      "G90 G1 X=IC(2)\n"                    // X + 2
      "R3=POT(3)+SQRT(16)-ABS(-1)+TRUNC(2.7)+7 DIV 2+7 MOD 4\n"  // 9 + 4 - 1 + 2 + 3 + 3 = 20
      "G1 Z=R3\n");
  expect_vector(path.points[0].tip_W_m, mm(9, 5, -2), 1e-15);
  expect_vector(path.points[1].tip_W_m, mm(1, 7.5, -2), 1e-15);
  expect_vector(path.points[2].tip_W_m, mm(3, 7.5, -2), 1e-15);
  expect_vector(path.points[3].tip_W_m, mm(3, 7.5, 20), 1e-15);
}

TEST(SiemensLanguage, ControlFlow) {
  // Four passes by WHILE, three by FOR, two by REPEAT, one skipped by IF / GOTOF, LOOP left by
  // GOTOF: 4 + 3 + 2 + 1 points after the start.
  const Toolpath path = siemens(
      "G0 X0 Y0 Z0\n"
      "DEF INT I\n"
      "R1=0\n"
      "WHILE R1<4\n"
      "  R1=R1+1\n"
      "  G1 X=R1 F100\n"
      "ENDWHILE\n"
      "FOR I=1 TO 3\n"
      "  G1 Y=I\n"
      "ENDFOR\n"
      "R2=0\n"
      "REPEAT\n"
      "  R2=R2+1\n"
      "  G1 Z=-R2\n"
      "UNTIL R2>=2\n"
      "IF R2==2 GOTOF SKIP\n"
      "G1 X100\n"
      "SKIP:\n"
      "IF R1>3\n"
      "  G1 X50\n"
      "ELSE\n"
      "  G1 X60\n"
      "ENDIF\n"
      "LOOP\n"
      "  GOTOF OUT\n"
      "ENDLOOP\n"
      "OUT: M30\n");
  ASSERT_EQ(path.points.size(), 11u);
  expect_vector(path.points[4].tip_W_m, mm(4, 0, 0), 1e-15);
  expect_vector(path.points[7].tip_W_m, mm(4, 3, 0), 1e-15);
  expect_vector(path.points[9].tip_W_m, mm(4, 3, -2), 1e-15);
  expect_vector(path.points[10].tip_W_m, mm(50, 3, -2), 1e-15);
}

TEST(SiemensLanguage, SubprogramsWithRepeats) {
  const auto folder = vmsim::test::fresh_temp_folder("siemens_subprograms");
  std::ofstream(folder / "L100.SPF") << "G91 G1 X1 F100\nG90\nM17\n";
  std::ofstream(folder / "POCKET.SPF") << "G1 Y=R5\nRET\n";
  std::ofstream(folder / "main.mpf") << "G0 X0 Y0 Z0\nL100 P3\nR5=7\nPOCKET\nM30\n";
  const Toolpath path = read_toolpath((folder / "main.mpf").string());
  ASSERT_EQ(path.points.size(), 5u);
  expect_vector(path.points[3].tip_W_m, mm(3, 0, 0), 1e-15);
  expect_vector(path.points[4].tip_W_m, mm(3, 7, 0), 1e-15);
  EXPECT_NE(path.blocks[static_cast<std::size_t>(path.points[1].block)].file.find("L100.SPF"), std::string::npos);
  std::filesystem::remove_all(folder);
}

TEST(SiemensLanguage, NxStylePreambleReads) {
  const Toolpath path = siemens(
      "%_N_PART_MPF\n"
      ";$PATH=/_N_WKS_DIR/_N_PART_WPD\n"
      "N10 G40 G17 G710 G94 G90 G60 G601 FNORM\n"
      "N20 G64 SOFT FFWON\n"
      "N30 MSG(\"OPERATION \" << 1)\n"
      "N40 T=\"EM10\"\n"
      "N50 M6\n"
      "N60 D1 S12000 M3\n"
      "N70 CYCLE832(0.005,_FINISH,1)\n"
      "N80 G54 G0 X0 Y0\n"
      "N90 Z50 M8\n"
      "N100 G1 Z0 F500\n"
      "N110 STOPRE\n"
      "N120 M5 M9\n"
      "N130 M30\n",
      [] { ReaderOptions o; o.default_tool_length_mm = 60.0; return o; }());
  EXPECT_EQ(path.points.size(), 3u);
  EXPECT_EQ(path.blocks[static_cast<std::size_t>(path.points[2].block)].block_number, 100);
  EXPECT_DOUBLE_EQ(path.points[2].corner_tolerance_m, 0.005e-3);
}

// --- Bad input ------------------------------------------------------------------------------

TEST(SiemensErrors, NameFileLineColumnAndWord) {
  struct Case { const char* text; const char* where; const char* what; };
  const Case cases[] = {
      {"G0 X0 Y0 Z0\nG1 X1 Q5 F100\n", "part.mpf:2:7: 'Q5'", "unsupported"},
      {"G0 X0 Y0 Z0\nG18 G41 G1 X1 F100\n", "part.mpf:2:5: 'G41'", "compensation outside the G17 plane"},
      {"G0 X0 Y0 Z0\nCYCLE800(1,\"T\",0,192,0,0,0,10,20,0,0,0,0,1)\n", "part.mpf:2:1:", "axis-by-axis"},
      {"G0 X0 Y0 Z0\nGOTOF NOWHERE\n", "part.mpf:2:1:", "NOWHERE"},
      {"G0 X0 Y0 Z0\nWHILE R1<2\nG1 X1 F100\n", "part.mpf:2:", "ENDWHILE"},
      {"G0 X=UNDEFINED Y0 Z0\n", "part.mpf:1:6:", "UNDEFINED"},
      {"G0 X0 Y0 Z0\nG1 X=10/R7 F100\n", "part.mpf:2:", "division by zero"},
      {"G0 X0 Y0 Z0\nCT X10 Y5 F100\n", "part.mpf:2:1: 'CT'", "a motion before"},
      {"G0 X0 Y0 Z0\nCIP X10 Y0 I1=5 J1=0 F100\n", "part.mpf:2:1: 'CIP'", "on a line"},
      {"G0 X0 Y0 Z0\nG1 X1 F100 A3=1\n", "part.mpf:2:12: 'A3=1'", "TRAORI"},
      {"G0 X0 Y0 Z0\nL77\n", "part.mpf:2:1: 'L77'", "not found"},
      {"G0 X0 Y0 Z0\nSCALE X2\n", "part.mpf:2:1: 'SCALE'", "scaling"},
      {"G0 X0 Y0 Z0\nG3 X10 Y0 CR=2 F100\n", "part.mpf:2:11: 'CR=2'", "smaller than half"},
      {"G0 X0 Y0 Z0\nG1 X1 F100 G95\n", "part.mpf:2:12: 'G95'", "per revolution"},
      {"T1 M6 D1\nG0 X0 Y0 Z0\n", "part.mpf:2:", "no tool length for T1 D1"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.text);
    const std::string message = siemens_error(c.text);
    EXPECT_NE(message.find(c.where), std::string::npos) << message;
    EXPECT_NE(message.find(c.what), std::string::npos) << message;
  }
}

TEST(SiemensDispatch, MpfAndSpfAndSiemensContentUnderAnIsoExtension) {
  const auto folder = vmsim::test::fresh_temp_folder("siemens_dispatch");
  const std::string program = "CYCLE832(0.01,_FINISH,1)\nG0 X0 Y0 Z0\nG1 X1 F100\n";
  for (const char* name : {"a.mpf", "b.SPF", "c.nc"}) {
    std::ofstream(folder / name) << program;
    const Toolpath path = read_toolpath((folder / name).string());
    ASSERT_EQ(path.points.size(), 2u) << name;
    EXPECT_EQ(path.points[1].jerk_mode, JerkMode::soft) << name;
  }
  std::filesystem::remove_all(folder);
}

}  // namespace
}  // namespace vmsim::toolpath
