// vmsim diagnose through the program (issue 20): the verdict on the terminal and in
// diagnosis.json, the noise options, and a trace with both second measuring systems refused with
// its file named (exit 3, nothing written).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "../app/cli_runner.hpp"
#include "truth_sim_independent.hpp"

namespace vmsim::identify::test {
namespace {

void write(const std::filesystem::path& path, const std::string& text) { std::ofstream(path) << text; }

std::string read(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// The independent truth's control case (no hidden effect) as files.
std::filesystem::path write_case(const std::string& name, bool both_systems) {
  const auto folder = vmsim::test::fresh_folder(name);
  IndependentDrive nominal;
  std::size_t from = 0, to = 0;
  const auto sp = independent_excitation(nominal.position_period_s, from, to);
  to = std::min(to, from + 4000);  // 4 s
  Trace trace = simulate_independent(nominal, sp, from, to, 11);
  if (both_systems) {
    trace.columns.push_back("X.pos2");
    trace.values.push_back(trace.column("X.pos"));
  }
  write(folder / "machine.yaml", independent_machine_yaml(nominal));
  write_trace((folder / "trace.csv").string(), trace);
  return folder;
}

TEST(DiagnoseCli, ControlCaseSaysWhatIsLeftOnTheTerminalAndInTheJson) {
  const auto folder = write_case("diagnose_cli_control", false);
  const auto run = vmsim::test::run_vmsim(
      "diagnose --machine " + (folder / "machine.yaml").string() + " --trace " +
      (folder / "trace.csv").string() + " --out " + (folder / "out").string());
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find("no effect of the catalogue found"), std::string::npos) << run.output;
  EXPECT_NE(run.output.find("the residual left is at the noise"), std::string::npos) << run.output;
  const std::string json = read(folder / "out" / "diagnosis.json");
  EXPECT_NE(json.find("\"unexplained\""), std::string::npos);
  EXPECT_NE(json.find("\"source\": \"measured signals\""), std::string::npos);
  // A user-given noise level is used as given (and said so).
  const auto given = vmsim::test::run_vmsim(
      "diagnose --machine " + (folder / "machine.yaml").string() + " --trace " +
      (folder / "trace.csv").string() + " --out " + (folder / "out2").string() +
      " --effort-noise-A 0.02 --max-effects 0");
  ASSERT_EQ(given.exit_code, 0) << given.output;
  EXPECT_NE(read(folder / "out2" / "diagnosis.json").find("\"source\": \"given\""), std::string::npos);
}

TEST(DiagnoseCli, BadInputIsRefusedWithItsFile) {
  const auto folder = write_case("diagnose_cli_bad", true);
  const auto run = vmsim::test::run_vmsim(
      "diagnose --machine " + (folder / "machine.yaml").string() + " --trace " +
      (folder / "trace.csv").string() + " --out " + (folder / "out").string());
  EXPECT_EQ(run.exit_code, 3) << run.output;
  EXPECT_NE(run.output.find("trace.csv"), std::string::npos) << run.output;
  EXPECT_NE(run.output.find(".pos_motor"), std::string::npos) << run.output;
  EXPECT_FALSE(std::filesystem::exists(folder / "out" / "diagnosis.json"));
  const auto negative = vmsim::test::run_vmsim(
      "diagnose --machine " + (folder / "machine.yaml").string() + " --trace " +
      (folder / "trace.csv").string() + " --out " + (folder / "out").string() +
      " --effort-noise-A -0.01");
  EXPECT_NE(negative.exit_code, 0) << negative.output;
  EXPECT_NE(negative.output.find("effort-noise-A"), std::string::npos) << negative.output;
}

}  // namespace
}  // namespace vmsim::identify::test
