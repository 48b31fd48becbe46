// Siemens 840D drilling cycles CYCLE81 / CYCLE82 / CYCLE83 and MCALL
// (toolpath/src/siemens_reader.cpp): tool-tip points and feeds worked out by hand from the
// 840D cycle manual's description of each cycle (the comments give the arithmetic).
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "plane_path_support.hpp"
#include "reader_test_support.hpp"
#include "vmsim/toolpath/toolpath.hpp"

namespace vmsim::toolpath {
namespace {

using namespace test;

Toolpath siemens(const std::string& text) {
  ReaderOptions options;
  options.tool_length_mm = {{1, 0.0}};
  return parse_siemens(text, "part.mpf", options);
}

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
      EXPECT_NEAR(points[i].feed_m_per_s, expected[i].feed_mm_per_min / 60000.0, 1e-15) << "move " << i;
    }
  }
}

const std::string kHead = "N10 T1 M6\nN20 G17 G90 G0 X10 Y20 Z50\nN30 F200\n";  // lines 1-3

// CYCLE81(RTP 50, RFP 0, SDIS 2, DP -12): G0 to Z2, G1 to Z-12 at F, G0 to RTP. DPR 12 (given
// and not 0) wins over DP, as on the control.
TEST(SiemensCycles, Cycle81DrillsToTheDepthAndBack) {
  for (const std::string call : {"CYCLE81(50, 0, 2, -12, )", "CYCLE81(50,0,2,-99,12)"}) {
    const Toolpath path = siemens(kHead + "N40 " + call + "\nN50 M30\n");
    expect_moves(points_of_lines(path, 4, 4), 10.0, 20.0, {{2, true, 0}, {-12, false, 200}, {50, true, 0}});
  }
}

// MCALL CYCLE82(RTP 10, RFP 0, SDIS 1, DP -5, , DTB 0.5): called after each positioning block
// (X10, X20) until MCALL alone; the dwell is no motion.
TEST(SiemensCycles, ModalCallAtEachPosition) {
  const Toolpath path = siemens(kHead +
                                "N40 MCALL CYCLE82(10, 0, 1, -5, , 0.5)\n"  // 4
                                "N50 X10 Y0\n"                              // 5
                                "N60 X20\n"                                 // 6
                                "N70 MCALL\n"                               // 7
                                "N80 X30\n"                                 // 8
                                "N90 M30\n");
  EXPECT_TRUE(points_of_lines(path, 4, 4).empty());
  for (const auto& [line, x] : {std::pair{5, 10.0}, std::pair{6, 20.0}}) {
    const std::vector<PathPoint> points = points_of_lines(path, line, line);
    ASSERT_EQ(points.size(), 4u) << line;
    expect_moves({points.begin() + 1, points.end()}, x, 0.0, {{1, true, 0}, {-5, false, 200}, {10, true, 0}});
  }
  ASSERT_EQ(points_of_lines(path, 8, 8).size(), 1u);
  expect_xy(xy_mm(path.points.back()), 30.0, 0.0);
}

// CYCLE83 swarf removal (VARI 1): RTP 20, RFP 0, SDIS 2, DP -25, FDPR 10, DAM 3, FRF 0.5 at F100.
// Strokes 10, 7, 4, 3, 3 (DAM shorter, not below DAM): levels Z-10, -17, -21, -24, -25. The
// first at F * FRF = 50. After each: G0 out to RFP + SDIS = Z2, G0 back to the anticipation
// distance above the depth reached: 0.6 mm (a hole of 25 mm, not deeper than 30 mm).
TEST(SiemensCycles, Cycle83SwarfRemovalWithDegression) {
  const Toolpath path = siemens(kHead + "N35 F100\nN40 CYCLE83(20,0,2,-25,,,10,3,0,0,0.5,1)\nN50 M30\n");
  expect_moves(points_of_lines(path, 5, 5), 10.0, 20.0,
               {{2, true, 0}, {-10, false, 50}, {2, true, 0}, {-9.4, true, 0}, {-17, false, 100},
                {2, true, 0}, {-16.4, true, 0}, {-21, false, 100}, {2, true, 0}, {-20.4, true, 0},
                {-24, false, 100}, {2, true, 0}, {-23.4, true, 0}, {-25, false, 100}, {20, true, 0}});
}

// CYCLE83 chip breaking (VARI 0): DPR 12 (depth Z-12), FDPR 5, no degression, _VRT 0.5: strokes
// of 5 at F, after each G1 back 0.5 at F, the next stroke from there. Then a 40 mm deep hole
// with swarf removal: the anticipation distance is 40 / 50 = 0.8 mm.
TEST(SiemensCycles, Cycle83ChipBreaking) {
  const Toolpath path = siemens(kHead + "N40 CYCLE83(20,0,2,,12,,5,0,0,0,1,0,0,0,0.5)\nN50 M30\n");
  expect_moves(points_of_lines(path, 4, 4), 10.0, 20.0,
               {{2, true, 0}, {-5, false, 200}, {-4.5, false, 200}, {-10, false, 200}, {-9.5, false, 200},
                {-12, false, 200}, {20, true, 0}});
  // A deep hole: the anticipation distance is depth / 50.
  const Toolpath deep = siemens(kHead + "N40 CYCLE83(20,0,2,-40,,,30,0,0,0,1,1)\nN50 M30\n");
  expect_moves(points_of_lines(deep, 4, 4), 10.0, 20.0,
               {{2, true, 0}, {-30, false, 200}, {2, true, 0}, {-29.2, true, 0}, {-40, false, 200}, {20, true, 0}});
}

TEST(SiemensCycles, LocatedErrors) {
  const auto error = [](const std::string& body) { return input_error_of([&] { siemens(kHead + body + "M30\n"); }); };
  EXPECT_NE(error("CYCLE81(50, 0, 2)\n").find("part.mpf:4:1: 'CYCLE81"), std::string::npos) << error("CYCLE81(50, 0, 2)\n");
  EXPECT_NE(error("CYCLE81(50, 0, 2)\n").find("needs the final drilling depth DP or DPR"), std::string::npos);
  EXPECT_NE(error("CYCLE81(-5, 0, 2, -10)\n").find("the retraction plane RTP -5 mm is below"), std::string::npos);
  EXPECT_NE(error("CYCLE83(20,0,2,-25,,,10,-0.8)\n").find("DAM < 0"), std::string::npos);
  EXPECT_NE(error("CYCLE83(20,0,2,-25)\n").find("needs the first drilling depth FDEP or FDPR"), std::string::npos);
  EXPECT_NE(error("CYCLE83(20,0,2,-500,,,0.000001)\n").find("expands to more than"), std::string::npos);
  EXPECT_NE(error("CYCLE84(20,0,2,-5)\n").find("'CYCLE84"), std::string::npos);
  // A modal call's error names the block it runs in, and the MCALL's line.
  const std::string modal = error("MCALL CYCLE81(10, 0, 1, -5)\nG93\nX20 F5\n");
  EXPECT_NE(modal.find("part.mpf:6: CYCLE81 (MCALL at line 4) under G93"), std::string::npos) << modal;
  EXPECT_NE(error("MCALL L100\n").find("part.mpf:4:1: 'MCALL': MCALL of a subprogram is not read"), std::string::npos)
      << error("MCALL L100\n");
}

}  // namespace
}  // namespace vmsim::toolpath
