// Part and machine values plausible but unusual reach the user as located warnings.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <string>

#include "cli_runner.hpp"
#include "part_file.hpp"

namespace vmsim {
namespace {

const std::string kRoot = VMSIM_SOURCE_DIR;

std::string sample_text(const std::string& path) {
  std::ifstream in(path);
  std::stringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

TEST(PartFileWarnings, FeedOf500MetresPerMinuteIsWarnedAbout) {
  const auto folder = test::fresh_folder("part_warn_feed");
  std::ofstream(folder / "part.yaml")
      << "name: fast\n"
         "machine: " << kRoot << "/samples/machines/mikron_ucp710.yaml\n"
         "toolpath: " << kRoot << "/samples/parts/part1_tangency/toolpath.apt\n"
         "tool: {type: ball, diameter_mm: 10, length_mm: 60}\n"
         "feeds: {production_mm_per_min: 500000, reference_mm_per_min: 100}\n";
  const app::PartDescription part = app::load_part((folder / "part.yaml").string());
  ASSERT_EQ(part.warnings.size(), 1u);
  EXPECT_NE(part.warnings[0].find("part.yaml:5:"), std::string::npos) << part.warnings[0];
  EXPECT_NE(part.warnings[0].find("feeds.production_mm_per_min: 500000 mm/min is unusual"),
            std::string::npos)
      << part.warnings[0];
}

TEST(PartFileWarnings, TheSamplePartsHaveNone) {
  for (const char* name : {"part1_tangency", "part2_corner", "part3_five_axis", "path1_yz", "path2_blade",
                           "mould_cavity"}) {
    const app::PartDescription part =
        app::load_part(kRoot + "/samples/parts/" + name + "/part.yaml");
    EXPECT_TRUE(part.warnings.empty()) << name << ": " << part.warnings.front();
  }
}

TEST(PartFileWarnings, MachineWarningReachesTheUser) {
  const auto folder = test::fresh_folder("machine_warn_cli");
  std::string machine = sample_text(kRoot + "/samples/machines/mikron_ucp710.yaml");
  machine.replace(machine.find("interpolation_period_ms: 4"), 26, "interpolation_period_s: 0.4");
  std::ofstream(folder / "machine.yaml") << machine;
  const test::RunResult run = test::run_vmsim(
      "kinematics --machine " + (folder / "machine.yaml").string() + " --toolpath " + kRoot +
      "/samples/parts/path1_yz/toolpath.apt --tool-length-mm 60 --out " +
      (folder / "axes.csv").string());
  EXPECT_EQ(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find("warning: " + (folder / "machine.yaml").string() + ":24:"),
            std::string::npos)
      << run.output;
}

}  // namespace
}  // namespace vmsim
