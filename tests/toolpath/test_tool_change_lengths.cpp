// Tool changes to tools of different lengths in the readers: the tool in the spindle places the
// machine axes' tip (PathPoint::tool_length_m), against positions worked out by hand on a
// machine whose axes move the spindle gauge point in W (gauge = machine axes), with the
// callbacks placing the caller's tool (default_tool_length_mm, 60 mm) as the app's do.
#include <gtest/gtest.h>

#include <string>
#include <utility>
#include <vector>

#include "vmsim/toolpath/heidenhain_reader.hpp"
#include "vmsim/toolpath/toolpath.hpp"

namespace vmsim::toolpath {
namespace {

constexpr double kDefaultMm = 60.0;

ReaderOptions two_tools() {
  ReaderOptions options;
  options.default_tool_length_mm = kDefaultMm;
  options.tool_length_mm = {{1, 60.0}, {2, 95.0}};
  // The caller's tool (60 mm) at the machine axes: tip = gauge - 60 mm along +Z.
  options.axis_words_to_pose = [](const std::vector<std::pair<char, double>>& words) {
    Eigen::Vector3d gauge = Eigen::Vector3d::Zero();
    for (const auto& [letter, value] : words) {
      if (letter >= 'X' && letter <= 'Z') gauge[letter - 'X'] = value * 1e-3;
    }
    return AxisWordPose{gauge - Eigen::Vector3d(0, 0, kDefaultMm * 1e-3), Eigen::Vector3d::UnitZ()};
  };
  return options;
}

TEST(ToolChangeLengths, GcodeG43HPutsEachToolsTipOnTheProgrammedZ) {
  // T1: machine Z = 10 + 60, tip 10. T2 M6 G43 H2 Z10: machine Z = 10 + 95 (35 mm higher), the
  // 95 mm tool's tip at 10 again: the same tip, another machine position (kept, not merged).
  const Toolpath path = parse_gcode(
      "G90 G21\nT1 M6\nG43 H1 G0 X0 Y0 Z10\nG1 Z-5 F500\nG0 Z10\nT2 M6\nG43 H2 Z10\nG1 Z-8 F500\n"
      "T1 M6\nG0 Z10\n",
      "two.nc", two_tools());
  ASSERT_EQ(path.points.size(), 6u);
  const double z_mm[] = {10, -5, 10, 10, -8, 45};
  const double length_mm[] = {60, 60, 60, 95, 95, 60};
  for (std::size_t i = 0; i < path.points.size(); ++i) {
    EXPECT_NEAR(path.points[i].tip_W_m.z() * 1e3, z_mm[i], 1e-9) << i;
    EXPECT_NEAR(path.points[i].tool_length_m * 1e3, length_mm[i], 1e-12) << i;
  }
  // The last point: T1 back in the spindle while H2 (95 mm) is in force: machine Z = 10 + 95,
  // the 60 mm tool's tip 35 mm above the programmed 10, as on the machine.
}

TEST(ToolChangeLengths, HeidenhainToolCallAndSiemensTDPlaceEachTool) {
  const Toolpath tnc = parse_heidenhain(
      "0 BEGIN PGM T MM\n1 TOOL CALL 1 Z S1000\n2 L X+0 Y+0 Z+10 R0 FMAX\n3 TOOL CALL 2 Z S1000\n"
      "4 L Z+10 FMAX\n5 L Z-8 F500\n6 END PGM T MM\n",
      "two.h", two_tools());
  ASSERT_EQ(tnc.points.size(), 3u);
  EXPECT_NEAR(tnc.points[0].tip_W_m.z() * 1e3, 10.0, 1e-9);
  EXPECT_NEAR(tnc.points[1].tip_W_m.z() * 1e3, 10.0, 1e-9);
  EXPECT_NEAR(tnc.points[2].tip_W_m.z() * 1e3, -8.0, 1e-9);
  EXPECT_NEAR(tnc.points[1].tool_length_m * 1e3, 95.0, 1e-12);
  const Toolpath siemens = parse_siemens("G90 G71\nT1 M6\nG0 X0 Y0 Z10\nT2 M6\nZ10\nG1 Z-8 F500\nM30\n", "two.mpf",
                                         two_tools());
  ASSERT_EQ(siemens.points.size(), 3u);
  EXPECT_NEAR(siemens.points[1].tip_W_m.z() * 1e3, 10.0, 1e-9);
  EXPECT_NEAR(siemens.points[2].tip_W_m.z() * 1e3, -8.0, 1e-9);
  EXPECT_NEAR(siemens.points[2].tool_length_m * 1e3, 95.0, 1e-12);
}

TEST(ToolChangeLengths, AptLoadtlCarriesTheTablesLength) {
  const Toolpath apt = parse_apt("LOADTL/2\nFEDRAT/500\nGOTO/0,0,10\nGOTO/10,0,10\nFINI\n", "two.apt", two_tools());
  ASSERT_EQ(apt.points.size(), 2u);
  EXPECT_NEAR(apt.points[0].tool_length_m * 1e3, 95.0, 1e-12);
  EXPECT_NEAR(apt.points[0].tip_W_m.z() * 1e3, 10.0, 1e-12);  // CL points are tips
}

}  // namespace
}  // namespace vmsim::toolpath
