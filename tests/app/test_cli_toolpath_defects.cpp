// The vmsim program on hostile tool paths (defects found with mutated files): bytes that are
// not UTF-8 were an internal error (exit 1) once a warning reached the JSON summary; a rotary
// word beyond the travel (A720 on A [-120, 30] deg) was merged away as "repeats the previous
// pose" and the run succeeded. Now: exit 3 naming line, column and byte; exit 4 naming the block,
// the word and the travel. No output file is written.
#include <gtest/gtest.h>

#include <filesystem>
#include <cmath>
#include <fstream>
#include <vector>

#include "cli_runner.hpp"
#include "vmsim/common/trace.hpp"

namespace vmsim {
namespace {

const std::string kRoot = VMSIM_SOURCE_DIR;
const std::string kMikron = kRoot + "/samples/machines/mikron_ucp710.yaml";

#define EXPECT_CONTAINS(text, part) \
  EXPECT_NE(std::string(text).find(part), std::string::npos) << "in: " << (text)

test::RunResult run_kinematics(const std::filesystem::path& folder, const std::string& name,
                               const std::string& toolpath) {
  const std::filesystem::path path = folder / name;
  std::ofstream(path, std::ios::binary) << toolpath;
  return test::run_vmsim("kinematics --machine " + kMikron + " --toolpath " + path.string() +
                         " --tool-length-mm 50 --out " + (folder / "axes.csv").string() +
                         " --summary " + (folder / "summary.json").string());
}

TEST(CliToolpathDefects, ByteThatIsNotUtf8InAnAptRecordExitsWith3NamingLineColumnAndByte) {
  const auto folder = test::fresh_folder("toolpath_not_utf8");
  const test::RunResult run = run_kinematics(
      folder, "path.apt", "FEDRAT/1000\nGOTO/0,0,-100\nPLANE\xFF/1\nGOTO/10,0,-100\n");
  EXPECT_EQ(run.exit_code, 3) << run.output;
  EXPECT_CONTAINS(run.output, "path.apt:3:6:");
  EXPECT_CONTAINS(run.output, "0xFF");
  EXPECT_FALSE(std::filesystem::exists(folder / "axes.csv"));
  EXPECT_FALSE(std::filesystem::exists(folder / "summary.json"));
}

TEST(CliToolpathDefects, RotaryWordOutsideTheTravelExitsWith4NamingTheBlockWordAndTravel) {
  const auto folder = test::fresh_folder("toolpath_a720");
  const test::RunResult run = run_kinematics(
      folder, "path.nc", "G0 X0 Y0 Z-100 A0 C0\nG1 X10 F1000\nG1 A720\nG1 X20\n");
  EXPECT_EQ(run.exit_code, 4) << run.output;
  EXPECT_CONTAINS(run.output, "path.nc:3:");
  EXPECT_CONTAINS(run.output, "A720");
  EXPECT_CONTAINS(run.output, "[-120, 30] deg");
  EXPECT_FALSE(std::filesystem::exists(folder / "axes.csv"));
}

TEST(CliToolpathDefects, LinearWordOutsideTheTravelExitsWith4) {
  const auto folder = test::fresh_folder("toolpath_x_travel");
  const test::RunResult run =
      run_kinematics(folder, "path.nc", "G0 X0 Y0 Z-100 A0 C0\nG1 X400 F1000\n");
  EXPECT_EQ(run.exit_code, 4) << run.output;
  EXPECT_CONTAINS(run.output, "path.nc:2:");
  EXPECT_CONTAINS(run.output, "X400");
  EXPECT_CONTAINS(run.output, "[-355, 355] mm");
}

TEST(CliToolpathDefects, AFullTurnOfTheEndlessCAxisIsKeptAsMotion) {
  // A tilted so that C sets the tool axis in W; C0 -> C360 returns to the same pose.
  const auto folder = test::fresh_folder("toolpath_c360");
  const test::RunResult run = run_kinematics(
      folder, "path.nc", "G0 X50 Y0 Z-100 A-30 C0\nG1 X60 F1000\nG1 C360\nG1 X70\n");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_EQ(run.output.find("merged"), std::string::npos) << run.output;
  const Trace trace = read_trace((folder / "axes.csv").string());
  const std::vector<double>& c_deg = trace.column("C.cmd");
  ASSERT_GE(c_deg.size(), 6u);
  EXPECT_NEAR(std::abs(c_deg[c_deg.size() - 2]), 360.0, 1e-6);
  EXPECT_NEAR(std::abs(c_deg.back()), 360.0, 1e-6);
}

}  // namespace
}  // namespace vmsim
