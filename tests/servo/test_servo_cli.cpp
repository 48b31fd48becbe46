// vmsim servo through the program: a run on the bench, and bad set-point files (exit 3, the
// message names the file and line, no output written).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "../app/cli_runner.hpp"
#include "vmsim/common/trace.hpp"

namespace vmsim::servo {
namespace {

const std::string kBench = std::string(VMSIM_SOURCE_DIR) + "/samples/machines/ballscrew_bench.yaml";

void write(const std::filesystem::path& path, const std::string& text) {
  std::ofstream(path) << text;
}

std::string ramp_csv() {
  std::string text = "# note: a 10 mm/s ramp\nt,X.cmd\n";
  for (int k = 0; k <= 200; ++k) {
    text += std::to_string(k * 1e-3) + "," + std::to_string(k > 20 ? (k - 20) * 1e-2 : 0.0) + "\n";
  }
  return text;
}

TEST(ServoCli, WritesTheTrace) {
  const auto folder = test::fresh_folder("servo_cli_ok");
  write(folder / "sp.csv", ramp_csv());
  const auto run = test::run_vmsim("servo --machine " + kBench + " --setpoints " +
                                   (folder / "sp.csv").string() + " --out " +
                                   (folder / "out.csv").string() + " --inner-signals");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const Trace trace = read_trace((folder / "out.csv").string());
  EXPECT_EQ(trace.sample_count(), 201u);
  for (const char* column : {"t", "X.cmd", "X.pos", "X.vel", "X.cur", "X_following_error",
                             "X_control_deviation", "X_velocity_setpoint", "X_current_setpoint"}) {
    EXPECT_TRUE(trace.column_index(column)) << column;
  }
  EXPECT_DOUBLE_EQ(trace.column("X.cmd").back(), 1.8);
}

TEST(ServoCli, BadSetPointsExitThreeWithFileAndLine) {
  const auto folder = test::fresh_folder("servo_cli_bad");
  std::string uneven = ramp_csv();
  uneven.replace(uneven.find("\n0.050000,"), 10, "\n0.050500,");  // row of t = 0.05: line 53
  // Each message names the file, the line and the offending value.
  const std::pair<std::string, std::vector<std::string>> cases[] = {
      {"t,X.cmd,Q.cmd\n0,0,0\n0.001,0,0\n", {"unknown.csv:1", "Q"}},
      {uneven, {"uneven.csv:53", "0.0015"}},
      {"t,X.cmd\n0,0\n0.001,abc\n0.002,0\n", {"broken.csv:3", "'abc'"}},
      {"t,X.cmd\n0,0\n0.001\n", {"short.csv:3", "1 fields"}},
  };
  const char* names[] = {"unknown.csv", "uneven.csv", "broken.csv", "short.csv"};
  for (std::size_t i = 0; i < std::size(cases); ++i) {
    const auto input = folder / names[i];
    write(input, cases[i].first);
    const auto out = folder / (std::string(names[i]) + ".out.csv");
    const auto run = test::run_vmsim("servo --machine " + kBench + " --setpoints " + input.string() +
                                     " --out " + out.string());
    EXPECT_EQ(run.exit_code, 3) << names[i] << ": " << run.output;
    for (const std::string& needle : cases[i].second) {
      EXPECT_NE(run.output.find(needle), std::string::npos) << needle << " in " << run.output;
    }
    EXPECT_FALSE(std::filesystem::exists(out)) << names[i];
  }
  // A record period that is not a multiple of the loop period: exit 3 too, no output.
  write(folder / "sp.csv", ramp_csv());
  const auto run = test::run_vmsim("servo --machine " + kBench + " --setpoints " +
                                   (folder / "sp.csv").string() + " --out " +
                                   (folder / "p.csv").string() + " --record-period-s 0.0015");
  EXPECT_EQ(run.exit_code, 3) << run.output;
  EXPECT_NE(run.output.find("multiple"), std::string::npos) << run.output;
  EXPECT_FALSE(std::filesystem::exists(folder / "p.csv"));
}

// A set point 1 km beyond the travel was simulated without a word: now exit 4 before any
// simulation, naming the file, line, axis, value and travel; no output.
TEST(ServoCli, ASetPointOutsideTheTravelExitsFour) {
  const auto folder = test::fresh_folder("servo_cli_travel");
  std::string text = "t,X.cmd\n";  // data from line 2 on: row k is line k + 2
  for (int k = 0; k <= 200; ++k) {
    text += std::to_string(k * 1e-3) + "," + (k == 151 ? std::string("1000000") : std::string("0")) + "\n";
  }
  write(folder / "far.csv", text);
  const auto run = test::run_vmsim("servo --machine " + kBench + " --setpoints " +
                                   (folder / "far.csv").string() + " --out " + (folder / "out.csv").string());
  EXPECT_EQ(run.exit_code, 4) << run.output;
  for (const char* needle : {"far.csv:153", "X.cmd = 1e+06 mm", "outside the travel of axis X"}) {
    EXPECT_NE(run.output.find(needle), std::string::npos) << needle << " in " << run.output;
  }
  EXPECT_FALSE(std::filesystem::exists(folder / "out.csv"));
}

}  // namespace
}  // namespace vmsim::servo
