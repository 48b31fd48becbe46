// Dwells read into PathPoint::dwell_s, in every dialect: ISO G4 X (s) / P (ms) and the canned
// cycles' P (ms), 840D G4 F (s) / S (spindle revolutions at the last S) and CYCLE82 DTB /
// CYCLE83 _DTD, TNC CYCL DEF 9 and the drilling cycles' Q211 (at the depth) / Q210 (at the
// set-up clearance after each full retract). Values worked out by hand from the programs.
#include <gtest/gtest.h>

#include "reader_test_support.hpp"
#include "vmsim/toolpath/heidenhain_reader.hpp"
#include "vmsim/toolpath/toolpath.hpp"

namespace vmsim::toolpath {
namespace {

double total_dwell_s(const Toolpath& path) {
  double total = 0.0;
  for (const auto& p : path.points) total += p.dwell_s;
  return total;
}

TEST(Dwells, IsoG4SecondsAndMillisecondsOnThePointReached) {
  const Toolpath path = parse_gcode("G21 G90 G0 X0 Y0 Z10\nG1 X10 F600\nG4 P500\nG1 Y10\nG4 X1.5\nG4 X0.25\n", "d.nc");
  ASSERT_EQ(path.points.size(), 3u);
  EXPECT_EQ(path.points[0].dwell_s, 0.0);
  EXPECT_DOUBLE_EQ(path.points[1].dwell_s, 0.5);
  EXPECT_DOUBLE_EQ(path.points[2].dwell_s, 1.75);  // two dwells in a row add up
  EXPECT_NE(test::input_error_of([] { parse_gcode("G0 X0 Y0 Z0\nG4 X1 P100\n", "d.nc"); }), "");
}

TEST(Dwells, IsoG82PDwellsAtEachHoleBottom) {
  const Toolpath path = parse_gcode("G21 G90 G0 X0 Y0 Z20\nG98 G82 X5 Y5 Z-3 R2 P250 F100\nX15\nG80\n", "d.nc");
  std::size_t bottoms = 0;
  for (const auto& p : path.points) {
    if (std::abs(p.tip_W_m.z() + 3e-3) < 1e-12) {
      ++bottoms;
      EXPECT_DOUBLE_EQ(p.dwell_s, 0.25);
    } else {
      EXPECT_EQ(p.dwell_s, 0.0);
    }
  }
  EXPECT_EQ(bottoms, 2u);
  // G81 has no dwell.
  EXPECT_EQ(total_dwell_s(parse_gcode("G0 X0 Y0 Z20\nG81 X5 Y5 Z-3 R2 F100\nG80\n", "d.nc")), 0.0);
}

TEST(Dwells, Siemens840dG4SecondsRevolutionsAndCycles) {
  const Toolpath path = parse_siemens("G0 X0 Y0 Z10\nS1200 M3\nG1 X10 F600\nG4 F0.5\nG1 Y10\nG4 S30\n", "d.mpf");
  ASSERT_EQ(path.points.size(), 3u);
  EXPECT_DOUBLE_EQ(path.points[1].dwell_s, 0.5);
  EXPECT_DOUBLE_EQ(path.points[2].dwell_s, 1.5);  // 30 revolutions at 1200 rev/min
  const std::string no_speed = test::input_error_of([] { parse_siemens("G0 X0 Y0 Z10\nG4 S30\n", "d.mpf"); });
  EXPECT_NE(no_speed.find("d.mpf:2"), std::string::npos) << no_speed;
  EXPECT_NE(no_speed.find("spindle speed"), std::string::npos) << no_speed;
  EXPECT_NE(test::input_error_of([] { parse_siemens("G0 X0 Y0 Z10\nG4\n", "d.mpf"); }), "");
  // CYCLE82(RTP, RFP, SDIS, DP, DPR, DTB): 0.8 s at Z-4.
  const Toolpath drilled = parse_siemens("G0 X5 Y5 Z20\nF100\nCYCLE82(10, 0, 2, -4, , 0.8)\n", "d.mpf");
  double at_bottom = 0.0;
  for (const auto& p : drilled.points) {
    if (std::abs(p.tip_W_m.z() + 4e-3) < 1e-12) at_bottom += p.dwell_s;
  }
  EXPECT_DOUBLE_EQ(at_bottom, 0.8);
  EXPECT_DOUBLE_EQ(total_dwell_s(drilled), 0.8);
}

TEST(Dwells, HeidenhainCycle9AndDrillingDwells) {
  const Toolpath path = parse_heidenhain(
      "0 BEGIN PGM D MM\n"
      "1 TOOL CALL 1 Z S2000\n"
      "2 L X+0 Y+0 Z+10 R0 FMAX\n"
      "3 L X+10 F600\n"
      "4 CYCL DEF 9.0 DWELL TIME\n"
      "5 CYCL DEF 9.1 DWELL 0.5\n"
      "6 L Y+10\n"
      "7 END PGM D MM\n",
      "d.h");
  ASSERT_EQ(path.points.size(), 3u);
  EXPECT_DOUBLE_EQ(path.points[1].dwell_s, 0.5);
  EXPECT_DOUBLE_EQ(total_dwell_s(path), 0.5);
  // Cycle 200 (as in test_heidenhain_cycles: Z+2, to Z-5, out to Z+2, Z-3, to Z-10, out, Z-8,
  // to Z-12, out, Z+50): Q211 at Z-12, Q210 at Z+2 after each of the two retracts that go back in.
  const Toolpath drilled = parse_heidenhain(
      "0 BEGIN PGM D MM\n"
      "1 TOOL CALL 1 Z S2000\n"
      "2 L X+10 Y+20 Z+50 R0 FMAX\n"
      "3 CYCL DEF 200 DRILLING Q200=+2 Q201=-12 Q206=+150 Q202=+5 Q210=+0.2 Q203=+0 Q204=+50 Q211=+0.5\n"
      "4 CYCL CALL M3\n"
      "5 END PGM D MM\n",
      "d.h");
  double at_bottom = 0.0, at_top = 0.0;
  for (const auto& p : drilled.points) {
    if (std::abs(p.tip_W_m.z() + 12e-3) < 1e-12) at_bottom += p.dwell_s;
    if (std::abs(p.tip_W_m.z() - 2e-3) < 1e-12) at_top += p.dwell_s;
  }
  EXPECT_DOUBLE_EQ(at_bottom, 0.5);
  EXPECT_DOUBLE_EQ(at_top, 0.4);
  EXPECT_DOUBLE_EQ(total_dwell_s(drilled), 0.9);
}

}  // namespace
}  // namespace vmsim::toolpath
