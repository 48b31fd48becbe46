// KUKA KRL reader: poses against frames computed by hand in the comments.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <string>

#include "reader_test_support.hpp"
#include "vmsim/toolpath/toolpath.hpp"

namespace vmsim::toolpath {
namespace {

using test::expect_vector;
using test::input_error_of;

constexpr double kDeg = std::numbers::pi / 180.0;

TEST(KrlReader, LinInARotatedBaseGivesTheHandComputedTipAndAxis) {
  // $BASE: 90 deg about z, at (1000, 200, 300) mm. The target {X 10, Y 0, Z 5, A 0, B 90, C 0}:
  // Ry(90 deg) sends the TCP's x (the tool direction) to (0, 0, -1): the tool points down, so
  // the axis tip -> spindle is +z. The position (10, 0, 5) turned by 90 deg about z is
  // (0, 10, 5); plus the base origin: (1000, 210, 305) mm.
  const Toolpath path = parse_krl(
      "DEF T()\n"
      "$BASE = {FRAME: X 1000, Y 200, Z 300, A 90, B 0, C 0}\n"
      "$VEL.CP = 0.1\n"
      "LIN {X 10, Y 0, Z 5, A 0, B 90, C 0}\n"
      "END\n",
      "t.src");
  ASSERT_EQ(path.points.size(), 1u);
  expect_vector(path.points[0].tip_W_m, Eigen::Vector3d(1.000, 0.210, 0.305), 1e-15);
  expect_vector(path.points[0].axis_W, Eigen::Vector3d(0, 0, 1), 1e-15);
  EXPECT_EQ(path.points[0].kind, MotionKind::linear);
  EXPECT_DOUBLE_EQ(path.points[0].feed_m_per_s, 0.1);
  EXPECT_EQ(path.points[0].corner_tolerance_m, 0.0);  // no approximation: exact stop
}

TEST(KrlReader, EulerAnglesAreZyxAndCTurnsAboutTheToolDirection) {
  // R = Rz(A) Ry(B) Rx(C); Rx(C) leaves x alone, so the tool direction is
  // Rz(A) Ry(B) e_x = (cos A cos B, sin A cos B, -sin B): for A = 30, B = 45 deg
  // (0.612372, 0.353553, -0.707107). The axis tip -> spindle is its opposite, whatever C.
  const double a = 30 * kDeg, b = 45 * kDeg;
  const Eigen::Vector3d direction(std::cos(a) * std::cos(b), std::sin(a) * std::cos(b), -std::sin(b));
  for (const char* c : {"0", "60", "-170"}) {
    const Toolpath path = parse_krl(std::string("DEF T()\n$VEL.CP=0.2\nLIN {X 1,Y 2,Z 3,A 30,B 45,C ") + c + "}\nEND\n",
                                    "t.src");
    ASSERT_EQ(path.points.size(), 1u);
    expect_vector(path.points[0].axis_W, -direction, 1e-15);
    expect_vector(path.points[0].tip_W_m, Eigen::Vector3d(1e-3, 2e-3, 3e-3), 1e-18);
  }
}

TEST(KrlReader, WorldIsPlacedInWAndBaseDataIsComposed) {
  // $WORLD in W: translated by (-1.8, 0, -0.4) m (a robot 1.8 m behind and 0.4 m below W).
  // BASE_DATA[2] = (1800, 0, 400) mm, turned by B = 180 deg (Ry(180): x -> -x, z -> -z).
  // Target (10, 20, 30) mm in the base -> (-10, 20, -30) turned, + (1800, 0, 400) in $WORLD
  // = (1790, 20, 370), in W: (-10, 20, -30) mm. Orientation A B C = 0: the tool direction is
  // the base's x, i.e. -x in $WORLD: the axis tip -> spindle is +x.
  ReaderOptions options;
  options.krl_world_in_W(0, 3) = -1.8;
  options.krl_world_in_W(2, 3) = -0.4;
  const Toolpath path = parse_krl(
      "DEF T()\n"
      "BASE_DATA[2] = {X 1800, Y 0, Z 400, A 0, B 180, C 0}\n"
      "BAS(#BASE, 2)\n"
      "$VEL.CP = 0.05\n"
      "LIN {E6POS: X 10, Y 20, Z 30, A 0, B 0, C 0, S 6, T 27, E1 0}\n"
      "END\n",
      "t.src", options);
  ASSERT_EQ(path.points.size(), 1u);
  expect_vector(path.points[0].tip_W_m, Eigen::Vector3d(-0.010, 0.020, -0.030), 1e-15);
  expect_vector(path.points[0].axis_W, Eigen::Vector3d(1, 0, 0), 1e-15);
}

TEST(KrlReader, ApproximationDistanceAndFeedGoIntoEachPoint) {
  const Toolpath path = parse_krl(
      "DEF T()\n"
      "$VEL.CP = 0.25 ; m/s\n"
      "$APO.CDIS = 0.5\n"
      "PTP {X 0, Y 0, Z 50, A 0, B 90, C 0}\n"
      "LIN {Z 0} C_DIS\n"
      "LIN {X 100} C_VEL\n"
      "$APO.CDIS = 2\n"
      "LIN {Y 40} C_DIS\n"
      "LIN {X 0}\n"
      "END\n",
      "t.src");
  ASSERT_EQ(path.points.size(), 5u);
  EXPECT_EQ(path.points[0].kind, MotionKind::rapid);
  EXPECT_DOUBLE_EQ(path.points[1].corner_tolerance_m, 0.5e-3);
  EXPECT_TRUE(std::isnan(path.points[2].corner_tolerance_m));
  EXPECT_DOUBLE_EQ(path.points[3].corner_tolerance_m, 2e-3);
  EXPECT_EQ(path.points[4].corner_tolerance_m, 0.0);
  // Left-out components keep the previous position's: (100, 40, 0) then (0, 40, 0).
  expect_vector(path.points[3].tip_W_m, Eigen::Vector3d(0.1, 0.04, 0.0), 1e-15);
  expect_vector(path.points[4].tip_W_m, Eigen::Vector3d(0.0, 0.04, 0.0), 1e-15);
  for (std::size_t k = 1; k < 5; ++k) EXPECT_DOUBLE_EQ(path.points[k].feed_m_per_s, 0.25);
  EXPECT_EQ(path.blocks[static_cast<std::size_t>(path.points[3].block)].line, 8);
}

TEST(KrlReader, CircPassesThroughItsPointsOnTheCircle) {
  // Start (100, 0, 0), auxiliary (0, 100, 0), end (-100, 0, 0): the half circle of radius
  // 100 mm about the origin, counter-clockwise seen from +z (through +y).
  ReaderOptions options;
  options.arc_chord_tolerance_m = 1e-6;
  const Toolpath path = parse_krl(
      "DEF T()\n"
      "$VEL.CP = 0.1\n"
      "LIN {X 100, Y 0, Z 0, A 0, B 90, C 0}\n"
      "CIRC {X 0, Y 100, Z 0}, {X -100, Y 0, Z 0, A 0, B 90, C 0} C_DIS\n"
      "END\n",
      "t.src", options);
  ASSERT_GT(path.points.size(), 100u);
  double largest_y = 0;
  for (std::size_t k = 1; k < path.points.size(); ++k) {
    EXPECT_NEAR(path.points[k].tip_W_m.norm(), 0.1, 1e-15);
    EXPECT_EQ(path.points[k].kind, MotionKind::arc);
    largest_y = std::max(largest_y, path.points[k].tip_W_m.y());
    expect_vector(path.points[k].axis_W, Eigen::Vector3d(0, 0, 1), 1e-15);
  }
  EXPECT_NEAR(largest_y, 0.1, 1e-9);
  expect_vector(path.points.back().tip_W_m, Eigen::Vector3d(-0.1, 0, 0), 1e-15);
  // Chords within the tolerance: sagitta r (1 - cos(dphi / 2)) <= 1 um.
  const double dphi = std::acos(path.points[1].tip_W_m.dot(path.points[2].tip_W_m) / 0.01);
  EXPECT_LE(0.1 * (1 - std::cos(dphi / 2)), 1e-6 + 1e-12);
}

TEST(KrlReader, DatFileVariablesAndJointPtp) {
  ReaderOptions options;
  int calls = 0;
  options.robot_joints_to_pose = [&calls](const std::vector<double>& joints) {
    ++calls;
    EXPECT_EQ(joints.size(), 6u);
    EXPECT_DOUBLE_EQ(joints[1], -90.0);
    return AxisWordPose{Eigen::Vector3d(1, 2, 3), Eigen::Vector3d(0, 0, 1)};
  };
  const Toolpath path = parse_krl(
      "DEF PANEL()\n"
      ";FOLD PTP HOME\n"
      "PTP XHOME\n"
      ";ENDFOLD\n"
      "BAS(#VEL_CP, 0.3)\n"
      "LIN XP1 C_DIS\n"
      "END\n",
      "panel.src", options,
      "DEFDAT PANEL\n"
      "DECL E6AXIS XHOME={A1 0,A2 -90,A3 90,A4 0,A5 0,A6 0}\n"
      "DECL E6POS XP1={X 1000,Y 2000,Z 2900,A 0,B 90,C 0,S 6,T 27,E1 0,E2 0}\n"
      "DECL FDAT FP1={TOOL_NO 1,BASE_NO 1,IPO_FRAME #BASE}\n"
      "ENDDAT\n",
      "panel.dat");
  EXPECT_EQ(calls, 1);
  ASSERT_EQ(path.points.size(), 2u);
  expect_vector(path.points[0].tip_W_m, Eigen::Vector3d(1, 2, 3));
  expect_vector(path.points[1].tip_W_m, Eigen::Vector3d(1, 2, 2.9), 1e-15);
  expect_vector(path.points[1].axis_W, Eigen::Vector3d(0, 0, 1), 1e-15);
  EXPECT_DOUBLE_EQ(path.points[1].feed_m_per_s, 0.3);
}

TEST(KrlReader, ErrorsNameTheLineAndTheWord) {
  const auto error = [](const std::string& body) {
    return input_error_of([&] { parse_krl("DEF T()\n$VEL.CP=0.1\n" + body + "END\n", "e.src"); });
  };
  EXPECT_NE(error("LIN {X 1,Y 2,Z 3,A 0,B 0,Q 0}\n").find("e.src:3:"), std::string::npos);
  EXPECT_NE(error("LIN {X 1,Y 2,Z 3,A 0,B 0,Q 0}\n").find("unknown component 'Q'"), std::string::npos);
  EXPECT_NE(error("LIN {X 1}\n").find("first motion"), std::string::npos);
  EXPECT_NE(error("LIN P7\n").find("'P7' is not a declared position"), std::string::npos);
  EXPECT_NE(error("LIN_REL {X 1}\n").find("LIN_REL is not supported"), std::string::npos);
  EXPECT_NE(error("FOR I=1 TO 3\n").find("control flow"), std::string::npos);
  EXPECT_NE(error("LIN {X 1,Y 2,Z 3,A 0,B 0,C 0}\nCIRC {X 2,Y 2,Z 3}, {X 3,Y 2,Z 3}\n").find("one line"),
            std::string::npos);
  EXPECT_NE(error("$BASE = BASE_DATA[4]\n").find("BASE_DATA[4] is not set"), std::string::npos);
  EXPECT_NE(error("LIN {X 1,Y 2,Z 1.2.3,A 0,B 0,C 0}\n").find("e.src:3:"), std::string::npos);
  EXPECT_NE(input_error_of([] { parse_krl("DEF T()\nLIN {X 1,Y 2,Z 3,A 0,B 0,C 0}\nEND\n", "f.src"); })
                .find("before any $VEL.CP"),
            std::string::npos);
  EXPECT_NE(input_error_of([] { parse_krl("DEF T()\nEND\n", "g.src"); }).find("no motion"), std::string::npos);
}

}  // namespace
}  // namespace vmsim::toolpath
