// Dwells through `vmsim plan`, for each dialect (ISO G4 P, 840D G4 F, TNC CYCL DEF 9): the same
// L-shaped move with and without a 0.5 s dwell at its corner (an exact stop in every dialect:
// no blending programmed) plans 0.5 s longer to one interpolation period, and the set points
// (setpoints.csv) stay constant over at least 0.5 s.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "cli_runner.hpp"
#include "vmsim/common/files.hpp"
#include "vmsim/common/trace.hpp"

namespace vmsim {
namespace {

namespace fs = std::filesystem;
const std::string kRoot = VMSIM_SOURCE_DIR;

struct Dialect {
  const char* name;
  const char* extension;
  std::string program_with(const std::string& dwell) const {
    const std::string n(name);
    if (n == "iso") {
      return "G21 G90 G94 G17\nT1 M6\nG54\nG0 X-20. Y-10.\nG43 Z5. H1\nG1 Z-1. F600.\nG1 X20. F2000.\n" + dwell +
             "G1 Y10.\nG0 Z50.\nM30\n";
    }
    if (n == "840d") {
      return "G90 G94 G17 G60\nT1 M6\nD1\nG54\nG0 X-20 Y-10\nZ5\nG1 Z-1 F600\nG1 X20 F2000\n" + dwell +
             "G1 Y10\nG0 Z50\nM30\n";
    }
    return "0 BEGIN PGM D MM\n1 TOOL CALL 1 Z S8000\n2 L X-20 Y-10 R0 FMAX\n3 L Z+5 FMAX\n4 L Z-1 F600\n"
           "5 L X+20 F2000\n" + dwell + "6 L Y+10\n7 L Z+50 FMAX\n8 END PGM D MM\n";
  }
  const char* dwell() const {
    const std::string n(name);
    return n == "iso" ? "G4 P500\n" : n == "840d" ? "G4 F0.5\n" : "51 CYCL DEF 9.0 DWELL TIME\n52 CYCL DEF 9.1 DWELL 0.5\n";
  }
};

class DwellsPlan : public ::testing::TestWithParam<Dialect> {};

TEST_P(DwellsPlan, HalfASecondLongerAndTheSetPointsHeld) {
  const Dialect& d = GetParam();
  const fs::path folder = test::fresh_folder(std::string("dwells_plan_") + d.name);
  double duration[2] = {0.0, 0.0};
  for (int with = 0; with < 2; ++with) {
    const fs::path sub = folder / (with ? "with" : "without");
    fs::create_directories(sub);
    std::ofstream(sub / (std::string("program.") + d.extension)) << d.program_with(with ? d.dwell() : "");
    std::ofstream(sub / "part.yaml")
        << "name: dwell\nmachine: " << kRoot << "/samples/machines/mikron_ucp710.yaml\n"
        << "toolpath: program." << d.extension << "\n"
        << "tools: [{number: 1, type: flat, diameter_mm: 10, length_mm: 60, cutting_length_mm: 30}]\n"
        << "stock: {box: {min_mm: [-50, -40, -20], max_mm: [50, 40, 0]}}\n"
        << "setup:\n  work_offsets_mm: {G54: [0, 0, 30]}\nfeeds: {}\n";
    const test::RunResult run =
        test::run_vmsim("plan --no-plot --no-third-order --part " + (sub / "part.yaml").string() + " --out " + (sub / "out").string());
    ASSERT_EQ(run.exit_code, 0) << run.output;
    const auto summary = nlohmann::json::parse(read_file((sub / "out" / "summary.json").string()));
    duration[with] = summary["duration_s"].get<double>();
    const double period = summary["period_s"].get<double>();
    if (!with) continue;
    EXPECT_NEAR(duration[1] - duration[0], 0.5, period);
    // The set points: the longest stretch where no axis moves at all.
    const Trace trace = read_trace((sub / "out" / "setpoints.csv").string());
    std::size_t longest = 0, run_length = 0;
    const std::size_t samples = trace.sample_count();
    for (std::size_t k = 1; k < samples; ++k) {
      bool still = true;
      for (const char* axis : {"X.cmd", "Y.cmd", "Z.cmd"}) still = still && trace.column(axis)[k] == trace.column(axis)[k - 1];
      run_length = still ? run_length + 1 : 0;
      longest = std::max(longest, run_length);
    }
    EXPECT_GE(static_cast<double>(longest) * period, 0.5 - period) << longest;
  }
  fs::remove_all(folder);
}

INSTANTIATE_TEST_SUITE_P(Dialects, DwellsPlan,
                         ::testing::Values(Dialect{"iso", "nc"}, Dialect{"840d", "mpf"}, Dialect{"tnc", "h"}),
                         [](const auto& dialect_info) {
                           const std::string name = dialect_info.param.name;
                           return name == "840d" ? std::string("Siemens840d") : name == "iso" ? std::string("Iso") : std::string("HeidenhainTnc");
                         });

}  // namespace
}  // namespace vmsim
