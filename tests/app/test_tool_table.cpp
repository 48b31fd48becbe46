// The part file's tool table (`tools:`) and the removal switching tools stretch by stretch
// (app/tool_table.hpp), against closed forms: a flat end mill leaves a flat slot as wide as the
// tool, a ball end mill the circular groove z = tip + R - sqrt(R^2 - y^2).
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <string>

#include "cli_runner.hpp"
#include "part_file.hpp"
#include "tool_table.hpp"
#include "vmsim/common/errors.hpp"

namespace vmsim {
namespace {

const std::string kRoot = VMSIM_SOURCE_DIR;

std::string part_with_tools(const std::filesystem::path& folder, const std::string& tools) {
  std::ofstream(folder / "toolpath.nc") << "G0 X0 Y0 Z50\n";
  std::ofstream(folder / "part.yaml")
      << "name: tools\n"
         "machine: " << kRoot << "/samples/machines/mikron_ucp710.yaml\n"
         "toolpath: toolpath.nc\n"
      << tools
      << "feeds: {production_mm_per_min: 6000, reference_mm_per_min: 60}\n";
  return (folder / "part.yaml").string();
}

TEST(ToolTable, ToolsAreReadByNumberAndTheOldSingleToolStillHolds) {
  const auto folder = test::fresh_folder("tool_table");
  app::PartDescription part = app::load_part(part_with_tools(
      folder,
      "tools:\n"
      "  - {number: 3, type: flat, diameter_mm: 10, length_mm: 60}\n"
      "  - {number: 7, type: bull, diameter_mm: 8, corner_radius_mm: 1, length_mm: 60, cutting_length_mm: 20}\n"));
  ASSERT_EQ(part.tools.size(), 2u);
  EXPECT_EQ(part.tools[0].number, 3);
  EXPECT_EQ(part.tools[1].number, 7);
  ASSERT_NE(part.tool_for(7), nullptr);
  EXPECT_DOUBLE_EQ(part.tool_for(7)->corner_radius_m, 1e-3);
  EXPECT_DOUBLE_EQ(part.tool_for(7)->cutting_length_m, 20e-3);
  EXPECT_EQ(part.tool_for(5), nullptr);
  // Without `tool:`, the program's "no tool selected" is the table's first tool.
  EXPECT_EQ(part.tool_for(-1)->type, app::ToolType::flat);
  EXPECT_DOUBLE_EQ(part.tool.diameter_m, 10e-3);
  // The old single tool, alone.
  part = app::load_part(part_with_tools(folder, "tool: {type: ball, diameter_mm: 6, length_mm: 50}\n"));
  EXPECT_TRUE(part.tools.empty());
  EXPECT_DOUBLE_EQ(part.tool_for(-1)->corner_radius_m, 3e-3);
}

TEST(ToolTable, BadTablesNameTheLineTheEntryAndTheValue) {
  const auto folder = test::fresh_folder("tool_table_bad");
  struct Case {
    std::string tools, expected;
  };
  for (const Case& c : {
           Case{"tools:\n  - {number: 1, type: flat, diameter_mm: 10, length_mm: 60}\n"
                "  - {number: 1, type: ball, diameter_mm: 6, length_mm: 60}\n",
                "part.yaml:6:14: tools[1].number: T1 is in the table twice"},
           Case{"tools:\n  - {number: 1.5, type: flat, diameter_mm: 10, length_mm: 60}\n",
                "part.yaml:5:14: tools[0].number: expected a whole number 0 .. 1e9, got '1.5'"},
           Case{"tools:\n  - {number: 2, type: flat, diameter_mm: 10, length_mm: 60, lenght_mm: 3}\n",
                "part.yaml:5:61: unknown field 'tools[0].lenght_mm' (did you mean 'length_mm'?)"},
           Case{"tools:\n  - {number: 2, type: drill, diameter_mm: 10, length_mm: 60}\n",
                "tools[0].type: 'drill' is not one of ball, flat, bull"},
           Case{"tools: []\n", "tools: expected a list of tools"}}) {
    try {
      app::load_part(part_with_tools(folder, c.tools));
      ADD_FAILURE() << "no error for " << c.tools;
    } catch (const InputError& error) {
      EXPECT_NE(std::string(error.what()).find(c.expected), std::string::npos) << error.what();
    }
  }
}

// Two slots along x at z = 8 mm in a 10 mm high block: from x = 2 to 12 mm with a flat D10, on
// to x = 22 mm with a ball D6 (the tool of the path point the motion runs towards). Across
// x = 4 mm the flat leaves z = 8 for |y| < 5; across x = 19 mm (the flat at rest at x = 12
// reaches x = 17) the ball leaves z = 11 - sqrt(9 - y^2) for |y| < 3, and 10 beyond.
TEST(ToolTable, TheRemovalCutsEachStretchWithItsOwnTool) {
  removal::Tool flat;
  flat.type = removal::ToolType::flat;
  flat.diameter_m = 10e-3;
  flat.corner_radius_m = 0.0;
  flat.length_m = 20e-3;
  removal::Tool ball;
  ball.type = removal::ToolType::ball;
  ball.diameter_m = 6e-3;
  ball.corner_radius_m = 3e-3;
  ball.length_m = 20e-3;
  const double spacing = 0.1e-3;
  removal::NBuffer buffer = removal::NBuffer::zmap(
      removal::Box{Eigen::Vector3d(0, -10e-3, 0), Eigen::Vector3d(30e-3, 10e-3, 10e-3)}, spacing);
  const std::vector<removal::Pose> poses{{Eigen::Vector3d(2e-3, 0, 8e-3), Eigen::Vector3d::UnitZ()},
                                         {Eigen::Vector3d(12e-3, 0, 8e-3), Eigen::Vector3d::UnitZ()},
                                         {Eigen::Vector3d(22e-3, 0, 8e-3), Eigen::Vector3d::UnitZ()}};
  const std::vector<removal::Tool> tools{flat, flat, ball};
  const removal::CutStatistics stats = app::cut_with_tools(buffer, tools, poses, {0, 1, 2});
  EXPECT_EQ(stats.segments, 2u);
  const double z0 = buffer.zmap_origin_m().z();
  const int i4 = static_cast<int>(std::lround(4e-3 / spacing));
  const int i19 = static_cast<int>(std::lround(19e-3 / spacing));
  for (int j = 0; j < buffer.nv(); ++j) {
    const double y = buffer.origin(0, j).y();
    const double flat_z = std::abs(y) < 5e-3 - 1e-9 ? 8e-3 : 10e-3;
    const double ball_z = std::abs(y) < 3e-3 ? std::min(10e-3, 11e-3 - std::sqrt(9e-6 - y * y)) : 10e-3;
    if (std::abs(std::abs(y) - 5e-3) > 1e-9) {
      EXPECT_NEAR(buffer.length(i4, j) + z0, flat_z, 1e-9) << "y = " << y;
    }
    EXPECT_NEAR(buffer.length(i19, j) + z0, ball_z, 1e-9) << "y = " << y;
  }
}

// A tool change to a tool 5 mm longer after the pose at x = 12 mm (a flat D6 from there): the
// new tool's first segment starts where its own tip was at that pose, 5 mm lower (z = 3 mm), and
// rises to (22, 0, 8). By hand: at x = 12 the D6 at its start leaves z = 3; at x = 17 the lowest
// the rising D6 reaches is at its position x = 14 (17 - 3): z = 3 + 5 x 2 / 10 = 4.
TEST(ToolTable, AChangeOfLengthStartsTheNewToolAtItsOwnTip) {
  removal::Tool flat;
  flat.type = removal::ToolType::flat;
  flat.diameter_m = 10e-3;
  flat.corner_radius_m = 0.0;
  flat.length_m = 20e-3;
  removal::Tool small = flat;
  small.diameter_m = 6e-3;
  const double spacing = 0.1e-3;
  removal::NBuffer buffer = removal::NBuffer::zmap(
      removal::Box{Eigen::Vector3d(0, -10e-3, 0), Eigen::Vector3d(30e-3, 10e-3, 10e-3)}, spacing);
  const std::vector<removal::Pose> poses{{Eigen::Vector3d(2e-3, 0, 8e-3), Eigen::Vector3d::UnitZ()},
                                         {Eigen::Vector3d(12e-3, 0, 8e-3), Eigen::Vector3d::UnitZ()},
                                         {Eigen::Vector3d(22e-3, 0, 8e-3), Eigen::Vector3d::UnitZ()}};
  app::cut_with_tools(buffer, {flat, flat, small}, poses, {0, 1, 2}, {}, {0.060, 0.060, 0.065});
  const double z0 = buffer.zmap_origin_m().z();
  const int j0 = static_cast<int>(std::lround((0.0 - buffer.origin(0, 0).y()) / spacing));
  const auto height = [&](double x) { return buffer.length(static_cast<int>(std::lround(x / spacing)), j0) + z0; };
  EXPECT_NEAR(height(12e-3), 3e-3, 1e-9);
  EXPECT_NEAR(height(17e-3), 4e-3, 1e-9);
  EXPECT_NEAR(height(5e-3), 8e-3, 1e-9);  // the first tool's slot
}

}  // namespace
}  // namespace vmsim
