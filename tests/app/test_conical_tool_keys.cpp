// The conical tools' keys in a part file (type v, tapered_flat, tapered_ball; tip_angle_deg,
// taper_angle_deg, tip_diameter_mm) in `tool:` and `tools:`: read into the removal tool, bad
// values refused with the file and line (exit 3 from the program).
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

// A part file whose line 4 is `tool_line`.
std::string write_part(const std::string& name, const std::string& tool_line) {
  const auto folder = test::fresh_folder(name);
  std::ofstream(folder / "part.yaml") << "name: conical\n"
                                         "machine: " + kRoot + "/samples/machines/mikron_ucp710.yaml\n"
                                         "toolpath: " + kRoot + "/samples/parts/part1_tangency/toolpath.apt\n" +
                                             tool_line + "\n"
                                             "stock: {box: {min_mm: [-40, -5, 0], max_mm: [40, 5, 40]}}\n"
                                             "feeds: {production_mm_per_min: 10000, reference_mm_per_min: 100}\n";
  return (folder / "part.yaml").string();
}

std::string error_of(const std::string& name, const std::string& tool_line) {
  try {
    app::load_part(write_part(name, tool_line));
  } catch (const InputError& error) {
    return error.what();
  }
  return "";
}

TEST(ConicalToolKeys, AreReadIntoTheRemovalTool) {
  const app::PartDescription part = app::load_part(write_part(
      "conical_ok", "tools: [{number: 1, type: v, diameter_mm: 6, tip_angle_deg: 60, tip_diameter_mm: 0.2, length_mm: 60},"
                    " {number: 2, type: tapered_ball, diameter_mm: 6, tip_diameter_mm: 1, taper_angle_deg: 5, length_mm: 60,"
                    " cutting_length_mm: 25}, {number: 3, type: tapered_flat, diameter_mm: 8, tip_diameter_mm: 2,"
                    " taper_angle_deg: 3, length_mm: 60}]"));
  const removal::Tool v = app::removal_tool(*part.tool_for(1));
  EXPECT_EQ(v.type, removal::ToolType::v);
  EXPECT_NEAR(v.tip_angle_rad, M_PI / 3, 1e-15);
  EXPECT_NEAR(v.tip_diameter_m, 0.2e-3, 1e-15);
  const removal::Tool ball = app::removal_tool(*part.tool_for(2));
  EXPECT_EQ(ball.type, removal::ToolType::tapered_ball);
  EXPECT_NEAR(ball.taper_angle_rad, 5 * M_PI / 180, 1e-15);
  EXPECT_NEAR(ball.corner_radius(), 0.5e-3, 1e-15);
  EXPECT_NEAR(ball.length_m, 25e-3, 1e-15);
  const removal::Tool flat = app::removal_tool(*part.tool_for(3));
  EXPECT_EQ(flat.type, removal::ToolType::tapered_flat);
  EXPECT_NEAR(flat.tip_diameter_m, 2e-3, 1e-15);
  // `tool:` too; a V tool's tip diameter defaults to 0 (a sharp point).
  const app::PartDescription single =
      app::load_part(write_part("conical_single", "tool: {type: v, diameter_mm: 6, tip_angle_deg: 90, length_mm: 60}"));
  EXPECT_EQ(app::removal_tool(single.tool).tip_diameter_m, 0.0);
}

TEST(ConicalToolKeys, BadValuesAreLocated) {
  struct Bad {
    const char* tool;
    const char* message;
  };
  const Bad cases[] = {
      {"tool: {type: v, diameter_mm: 6, tip_angle_deg: 180, length_mm: 60}", "tool.tip_angle_deg: the included angle"},
      {"tool: {type: v, diameter_mm: 6, tip_angle_deg: 0, length_mm: 60}", "(0, 180) deg, got '0'"},
      {"tool: {type: v, diameter_mm: 6, length_mm: 60}", "tip_angle_deg"},
      {"tool: {type: v, diameter_mm: 6, tip_angle_deg: 90, tip_diameter_mm: 6, length_mm: 60}", "tool.tip_diameter_mm"},
      {"tool: {type: tapered_flat, diameter_mm: 6, tip_diameter_mm: 1, taper_angle_deg: 45, length_mm: 60}",
       "tool.taper_angle_deg: the angle per side must be in [0, 45) deg, got '45'"},
      {"tool: {type: tapered_ball, diameter_mm: 6, tip_diameter_mm: 7, taper_angle_deg: 5, length_mm: 60}",
       "tool.tip_diameter_mm: the ball's diameter must be in (0, diameter_mm]"},
      {"tool: {type: tapered_ball, diameter_mm: 6, taper_angle_deg: 5, length_mm: 60}", "tip_diameter_mm"},
      {"tool: {type: ball, diameter_mm: 6, tip_angle_deg: 90, length_mm: 60}", "tool.tip_angle_deg: only for v tools"},
      {"tool: {type: v, diameter_mm: 6, tip_angle_deg: 90, taper_angle_deg: 5, length_mm: 60}",
       "tool.taper_angle_deg: only for tapered_flat and tapered_ball"},
      {"tool: {type: v, diameter_mm: 6, tip_angel_deg: 90, length_mm: 60}", "did you mean 'tip_angle_deg'?"},
      {"tool: {type: vee, diameter_mm: 6, length_mm: 60}", "is not one of ball, flat, bull, v, tapered_flat, tapered_ball"},
  };
  int k = 0;
  for (const Bad& bad : cases) {
    const std::string error = error_of("conical_bad_" + std::to_string(k++), bad.tool);
    EXPECT_NE(error.find("part.yaml:4:"), std::string::npos) << bad.tool << ": " << error;
    EXPECT_NE(error.find(bad.message), std::string::npos) << bad.tool << ": " << error;
  }
  // The program: exit 3, the message located, no output written.
  const std::string part = write_part("conical_bad_cli", cases[0].tool);
  const auto out = test::fresh_folder("conical_bad_cli_out");
  const test::RunResult run = test::run_vmsim("kinematics --part " + part + " --out " + (out / "k.csv").string());
  EXPECT_EQ(run.exit_code, 3) << run.output;
  EXPECT_NE(run.output.find("part.yaml:4:"), std::string::npos) << run.output;
  EXPECT_FALSE(std::filesystem::exists(out / "k.csv"));
}

}  // namespace
}  // namespace vmsim
