// The compressor from the program to the plan: decide_nc_modes says what was emulated, and an
// 840D program as a CAM post writes a circle (CYCLE832 with COMPCAD, 0.3 mm G1 blocks rounded to
// 1 um) runs through `vmsim plan` compressed, faster than with --compressor-tolerance-mm 0, and
// the report says so.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <nlohmann/json.hpp>
#include <numbers>
#include <sstream>
#include <string>

#include "cli_runner.hpp"
#include "nc_modes.hpp"
#include "vmsim/common/files.hpp"

namespace vmsim {
namespace {

namespace fs = std::filesystem;
const std::string kRoot = VMSIM_SOURCE_DIR;

TEST(CompressorModes, TheReportSaysWhatWasEmulated) {
  toolpath::Toolpath path;
  path.blocks.push_back({"dir/p.mpf", 4, -1, "G1"});
  for (int k = 0; k < 5; ++k) {
    toolpath::PathPoint p;
    p.block = 0;
    p.compressor_tolerance_m = 1e-5;
    path.points.push_back(p);
  }
  app::NcModeCommandLine command_line;
  EXPECT_NE(app::decide_nc_modes(path, command_line).compressor.applied.find("not emulated by this command"),
            std::string::npos);
  planner::CompressionSummary summary;
  summary.runs = 2;
  summary.blocks_compressed = 40;
  summary.orientation_blocks_left = 3;
  command_line.compression = summary;
  app::NcModes modes = app::decide_nc_modes(path, command_line);
  EXPECT_EQ(modes.compressor.source, "program");
  EXPECT_EQ(modes.compressor.applied.rfind("on where the program asks", 0), 0u) << modes.compressor.applied;
  EXPECT_NE(modes.compressor.applied.find("2 runs, 40 blocks"), std::string::npos) << modes.compressor.applied;
  EXPECT_NE(modes.compressor.note.find("3 blocks left as programmed"), std::string::npos) << modes.compressor.note;
  command_line.compressor_override = true;
  command_line.compressor_tolerance_m = 0.0;
  modes = app::decide_nc_modes(path, command_line);
  EXPECT_TRUE(modes.compressor.overridden);
  EXPECT_EQ(modes.compressor.applied.rfind("off", 0), 0u) << modes.compressor.applied;
}

double planned_duration(const fs::path& folder, const std::string& extra, nlohmann::json& summary) {
  const test::RunResult run = test::run_vmsim("plan --no-plot " + extra + " --part " + (folder / "part.yaml").string() +
                                              " --out " + (folder / ("out" + std::to_string(extra.size()))).string());
  EXPECT_EQ(run.exit_code, 0) << run.output;
  summary = nlohmann::json::parse(read_file((folder / ("out" + std::to_string(extra.size())) / "summary.json").string()));
  return summary["duration_s"].get<double>();
}

TEST(CompressorPlan, An840dCircleUnderCycle832PlansFasterCompressed) {
  const fs::path folder = test::fresh_folder("compressor_plan");
  std::ostringstream program;
  program << "G90 G94 G17 G710\nT1 M6\nD1\nG54\nCYCLE832(0.01,1,1)\nG0 X20 Y0\nZ5\nG1 Z-1 F600\n" << std::fixed
          << std::setprecision(3);
  const int n = 419;  // 0.3 mm chords on R 20 mm
  for (int i = 1; i <= n; ++i) {
    const double a = 2 * std::numbers::pi * i / n;
    program << "G1 X" << 20 * std::cos(a) << " Y" << 20 * std::sin(a) << (i == 1 ? " F6000" : "") << "\n";
  }
  program << "G0 Z50\nM30\n";
  std::ofstream(folder / "program.mpf") << program.str();
  std::ofstream(folder / "part.yaml") << "name: circle\nmachine: " << kRoot << "/samples/machines/mikron_ucp710.yaml\n"
                                      << "toolpath: program.mpf\n"
                                      << "tools: [{number: 1, type: ball, diameter_mm: 10, corner_radius_mm: 5, "
                                         "length_mm: 60, cutting_length_mm: 20}]\n"
                                      << "stock: {box: {min_mm: [-50, -40, -20], max_mm: [50, 40, 0]}}\n"
                                      << "setup:\n  work_offsets_mm: {G54: [0, 0, 30]}\nfeeds: {}\n";
  nlohmann::json compressed, raw;
  const double t_compressed = planned_duration(folder, "", compressed);
  const double t_raw = planned_duration(folder, "--compressor-tolerance-mm 0", raw);
  const auto& use = compressed["nc_modes"]["compressor"];
  EXPECT_EQ(use["source"], "program") << use.dump();
  EXPECT_EQ(use["applied"].get<std::string>().rfind("on where the program asks", 0), 0u) << use.dump();
  EXPECT_TRUE(raw["nc_modes"]["compressor"]["overridden_by_command_line"].get<bool>());
  EXPECT_TRUE(compressed["third_order"].get<bool>());  // CYCLE832 switches SOFT on
  std::cout << "840D circle: T = " << t_raw << " s as programmed, " << t_compressed << " s compressed\n";
  EXPECT_LT(t_compressed, 0.95 * t_raw);
  fs::remove_all(folder);
}

}  // namespace
}  // namespace vmsim
