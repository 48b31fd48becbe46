// Programmed feeds (G94 F, G93 inverse time) and the part file's feed settings
// (app/chain_inputs.hpp point_feeds_m_per_s, app/part_file.hpp FeedSetting), against feeds
// computed by hand from the program's words.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "chain_inputs.hpp"
#include "cli_runner.hpp"
#include "part_file.hpp"
#include "vmsim/common/errors.hpp"
#include "vmsim/common/files.hpp"
#include "vmsim/kinematics/path_kinematics.hpp"

namespace vmsim {
namespace {

const std::string kRoot = VMSIM_SOURCE_DIR;
const std::string kMikron = kRoot + "/samples/machines/mikron_ucp710.yaml";

// Tool tips under G43.4. Points: 0 the start (G0), 1 G1 F600 (10 mm), 2 G1 (modal F600,
// 5 mm), 3 G93 F60 (a 10 mm move in 1 s), 4 G94 G0 rapid, 5 G1 F1200.
const char* kProgram =
    "G21 G90 G94\n"
    "G43.4 H1\n"
    "G0 X0 Y0 Z50 A0 C0\n"
    "G1 X10 F600\n"
    "G1 X15\n"
    "G93 G1 X25 F60\n"
    "G94 G0 Z80\n"
    "G1 Z70 F1200\n";

app::ChainInputs load(const std::filesystem::path& folder) {
  std::ofstream(folder / "feeds.nc") << kProgram;
  app::ChainInputOptions options;
  options.machine_path = kMikron;
  options.toolpath_path = (folder / "feeds.nc").string();
  options.tool_length_mm = 100.0;
  return app::load_chain_inputs(options);
}

TEST(ChainFeeds, ProgrammedFeedsG94AndG93TimesTheOverrideRapidsUnlimited) {
  const auto folder = test::fresh_folder("chain_feeds");
  const app::ChainInputs inputs = load(folder);
  ASSERT_EQ(inputs.path.size(), 6u);
  const kinematics::PathKinematics path = kinematics::solve_path_kinematics(
      inputs.machine, inputs.path, inputs.machine.home_positions(), inputs.tool_length_m,
      inputs.block_names);
  const double f600 = 600e-3 / 60.0, f1200 = 1200e-3 / 60.0;
  const double g93 = 10e-3 * 60.0 / 60.0;  // 10 mm in 1/(60 1/min) = 1 s
  const std::vector<double> expected{0.0, f600, f600, g93, 0.0, f1200};
  for (const double factor : {1.0, 1.5, 0.01}) {
    const std::vector<double> feeds = app::point_feeds_m_per_s(inputs, path, {0.0, factor});
    ASSERT_EQ(feeds.size(), expected.size());
    for (std::size_t i = 0; i < feeds.size(); ++i) {
      EXPECT_NEAR(feeds[i], expected[i] * factor, 1e-15) << "point " << i << " factor " << factor;
    }
  }
  // A fixed feed (production_mm_per_min, --feed-mm-per-min): every cutting move, G93 included.
  const std::vector<double> fixed = app::point_feeds_m_per_s(inputs, path, {0.2, 0.0});
  const std::vector<double> fixed_expected{0.0, 0.2, 0.2, 0.2, 0.0, 0.2};
  for (std::size_t i = 0; i < fixed.size(); ++i) EXPECT_EQ(fixed[i], fixed_expected[i]) << i;
}

std::string part_with_feeds(const std::filesystem::path& folder, const std::string& feeds) {
  std::ofstream(folder / "part.yaml")
      << "name: feeds\n"
         "machine: " << kMikron << "\n"
         "toolpath: toolpath.nc\n"
         "tool: {type: flat, diameter_mm: 10, length_mm: 60}\n"
         "feeds: " << feeds << "\n";
  std::ofstream(folder / "toolpath.nc") << "G0 X0 Y0 Z50\n";
  return (folder / "part.yaml").string();
}

TEST(ChainFeeds, PartFileFeedsFixedOrProgrammedTimesAPercentage) {
  const auto folder = test::fresh_folder("part_feeds");
  // Today's files: fixed feeds, as before.
  app::PartDescription part = app::load_part(
      part_with_feeds(folder, "{production_mm_per_min: 6000, reference_mm_per_min: 60}"));
  EXPECT_DOUBLE_EQ(part.production_feed.fixed_m_per_s, 0.1);
  EXPECT_DOUBLE_EQ(part.reference_feed.fixed_m_per_s, 0.001);
  EXPECT_DOUBLE_EQ(part.production_feed_m_per_s, 0.1);
  // Nothing given: the programmed feed at 100 %, the reference at 1 % of it.
  part = app::load_part(part_with_feeds(folder, "{}"));
  EXPECT_EQ(part.production_feed.fixed_m_per_s, 0.0);
  EXPECT_DOUBLE_EQ(part.production_feed.programmed_factor, 1.0);
  EXPECT_EQ(part.reference_feed.fixed_m_per_s, 0.0);
  EXPECT_DOUBLE_EQ(part.reference_feed.programmed_factor, 0.01);
  part = app::load_part(part_with_feeds(folder, "{override_percent: 120, reference_percent: 2}"));
  EXPECT_DOUBLE_EQ(part.production_feed.programmed_factor, 1.2);
  EXPECT_DOUBLE_EQ(part.reference_feed.programmed_factor, 0.02);
  part = app::load_part(part_with_feeds(folder, "{override_percent: 80, reference_mm_per_min: 30}"));
  EXPECT_DOUBLE_EQ(part.production_feed.programmed_factor, 0.8);
  EXPECT_DOUBLE_EQ(part.reference_feed.fixed_m_per_s, 0.0005);
}

TEST(ChainFeeds, ContradictoryOrImplausibleFeedSettingsNameFileLineAndField) {
  const auto folder = test::fresh_folder("part_feeds_bad");
  struct Case {
    std::string feeds, expected;
  };
  for (const Case& c :
       {Case{"{production_mm_per_min: 6000, override_percent: 100}", "give either production_mm_per_min or override_percent"},
        Case{"{reference_mm_per_min: 60, reference_percent: 1}", "give either reference_mm_per_min or reference_percent"},
        Case{"{override_percent: 0}", "feeds.override_percent: must be > 0, got '0'"},
        Case{"{override_percent: 1500}", "feeds.override_percent: 1500 % is above 1000 %"},
        Case{"{reference_percent: 150}", "feeds.reference_percent: 150 % is above 100 %"},
        Case{"{overide_percent: 100}", "override_percent"}}) {
    try {
      app::load_part(part_with_feeds(folder, c.feeds));
      ADD_FAILURE() << "no error for " << c.feeds;
    } catch (const InputError& error) {
      const std::string message = error.what();
      EXPECT_NE(message.find("part.yaml:5"), std::string::npos) << message;
      EXPECT_NE(message.find(c.expected), std::string::npos) << message;
    }
  }
}

// simulate-part end to end on a 5-axis program as CAM systems post them: G43.4, a rapid
// re-orientation at a safe height (A 0 -> -20 -> 0 about the fixed tip), a plunge at F2000 and
// a pass at F3000. The feeds follow the program: production at 100 % (largest cutting feed
// 3000 mm/min), reference at 10 % (300 mm/min). Before, the run stopped at the re-orientation
// ("changes the tool orientation without moving the tip") and ran every move at one feed.
TEST(ChainFeeds, SimulatePartRunsAReorientationAtTheProgrammedFeedsTimesTheOverrides) {
  const auto folder = test::fresh_folder("chain_feeds_simulate");
  std::ofstream(folder / "prog.nc") << "G21 G90 G94\nG43.4 H1\nG0 X-30 Y0 Z60 A0 C0\nG0 A-20\nG0 A0\n"
                                       "G1 Z18 F2000\nG1 X30 F3000\nG0 Z60\n";
  std::ofstream(folder / "part.yaml")
      << "name: reorientation\n"
         "machine: " << kMikron << "\n"
         "toolpath: prog.nc\n"
         "tool: {type: ball, diameter_mm: 10, length_mm: 100, cutting_length_mm: 20}\n"
         "stock: {box: {min_mm: [-20, -10, 0], max_mm: [20, 10, 20]}}\n"
         "feeds: {override_percent: 100, reference_percent: 10}\n";
  const test::RunResult run =
      test::run_vmsim("simulate-part --part " + (folder / "part.yaml").string() + " --out " +
                      (folder / "out").string() + " --no-renders --threads 1");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const nlohmann::json report = nlohmann::json::parse(read_file((folder / "out" / "report.json").string()));
  EXPECT_EQ(report["runs"]["production"]["feed_mm_per_min"].get<double>(), 3000.0);
  EXPECT_EQ(report["runs"]["reference"]["feed_mm_per_min"].get<double>(), 300.0);
  // The reference cuts the pass ten times slower: 40 mm of stock at 300 mm/min is 8 s at least.
  EXPECT_GT(report["runs"]["reference"]["duration_s"].get<double>(), 8.0);
}

}  // namespace
}  // namespace vmsim
