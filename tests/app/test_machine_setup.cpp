// The part file's `setup:` (work offsets in W, reference points) placing a G-code program on a
// real machine model: the tip of a posted 3-axis program lands on the programmed work point in
// W (work zero + program), and outside tool-centre-point mode a turn of the C table turns that
// point with the table.
#include <gtest/gtest.h>

#include <fstream>
#include <string>

#include "chain_inputs.hpp"
#include "cli_runner.hpp"
#include "part_file.hpp"
#include "vmsim/common/errors.hpp"

namespace vmsim {
namespace {

const std::string kRoot = VMSIM_SOURCE_DIR;

std::string part_with_setup(const std::filesystem::path& folder, const std::string& setup,
                            const std::string& program) {
  std::ofstream(folder / "path.nc") << program;
  std::ofstream(folder / "part.yaml")
      << "name: setup\n"
         "machine: " << kRoot << "/samples/machines/mikron_ucp710.yaml\n"
         "toolpath: path.nc\n"
         "tool: {type: flat, diameter_mm: 10, length_mm: 60}\n"
         "feeds: {production_mm_per_min: 10000, reference_mm_per_min: 100}\n"
      << setup;
  return (folder / "part.yaml").string();
}

template <typename Call>
std::string input_error_of(Call call) {
  try {
    call();
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

app::ChainInputs load(const std::string& part) {
  app::ChainInputOptions options;
  options.part_path = part;
  return app::load_chain_inputs(options);
}

TEST(MachineSetup, APostedProgramPutsTheTipOnTheWorkPointInW) {
  const auto folder = test::fresh_folder("setup_posted");
  const app::ChainInputs inputs = load(part_with_setup(
      folder,
      "setup:\n"
      "  work_offsets_mm: {G54: [10, 20, 30], G55: [-5, 0, 12]}\n",
      "G90 G94 G17 G49 G40 G80\nG21\nG28 G91 Z0.\nG90\nT1 M6\nS5000 M3\nG54\n"
      "G0 X1. Y2.\nG43 Z5. H1\nG1 Z-1. F300.\nG55 X0 Y0 Z0\nG28 G91 Z0.\nM30\n"));
  const auto& points = inputs.toolpath.points;
  ASSERT_EQ(points.size(), 5u);
  // Work point + work zero, whatever the machine's geometry.
  EXPECT_TRUE((points[1].tip_W_m * 1e3).isApprox(Eigen::Vector3d(11, 22, 35), 1e-9))
      << points[1].tip_W_m.transpose();
  EXPECT_TRUE((points[2].tip_W_m * 1e3).isApprox(Eigen::Vector3d(11, 22, 29), 1e-9));
  EXPECT_TRUE((points[3].tip_W_m * 1e3).isApprox(Eigen::Vector3d(-5, 0, 12), 1e-9));
  // G28: machine Z at home (0 on this machine), where no setup changes anything: the tip is
  // where the plain machine-axis program "Z0" puts it.
  const auto plain_folder = test::fresh_folder("setup_plain");
  const app::ChainInputs plain =
      load(part_with_setup(plain_folder, "", "G0 X-5 Y0 Z0\nG1 X0 F100\n"));
  EXPECT_NEAR(points[4].tip_W_m.z(), plain.toolpath.points[0].tip_W_m.z(), 1e-12);
}

TEST(MachineSetup, OutsideTcpATableTurnTurnsTheProgrammedPointWithTheTable) {
  const auto folder = test::fresh_folder("setup_turn");
  const app::ChainInputs inputs = load(part_with_setup(
      folder, "setup:\n  work_offsets_mm: {G54: [0, 0, 20]}\n",
      "G54 G43 H1 G0 X30 Y0 Z5 A0 C0\nG1 C90 F1000\n"));
  const auto& points = inputs.toolpath.points;
  ASSERT_GE(points.size(), 2u);
  const Eigen::Vector3d before = points.front().tip_W_m * 1e3;
  const Eigen::Vector3d after = points.back().tip_W_m * 1e3;
  EXPECT_TRUE(before.isApprox(Eigen::Vector3d(30, 0, 25), 1e-9)) << before.transpose();
  // The machine axes stay; W turns 90 deg about its z: the point is 30 mm from the axis, a
  // quarter turn away, at the same height.
  EXPECT_NEAR(after.head<2>().norm(), 30.0, 1e-9);
  EXPECT_NEAR(after.head<2>().dot(before.head<2>()), 0.0, 1e-9);
  EXPECT_NEAR(after.z(), 25.0, 1e-9);
}

TEST(MachineSetup, BadSetupsAreLocatedErrors) {
  const auto folder = test::fresh_folder("setup_bad");
  const std::string program = "G0 X0 Y0 Z0\n";
  std::string message = input_error_of([&] {
    app::load_part(part_with_setup(folder, "setup:\n  work_offsets_mm: {G60: [0, 0, 0]}\n", program));
  });
  EXPECT_NE(message.find("part.yaml:7:"), std::string::npos) << message;
  EXPECT_NE(message.find("'G60' is not a work offset"), std::string::npos) << message;
  message = input_error_of([&] {
    app::load_part(part_with_setup(
        folder, "setup:\n  work_offsets_mm: {G54: [0, 0, 0]}\n  active_offset: G55\n", program));
  });
  EXPECT_NE(message.find("part.yaml:8:"), std::string::npos) << message;
  EXPECT_NE(message.find("G55"), std::string::npos) << message;
  // A program that selects an offset the setup does not give: the block, and what is set up.
  message = input_error_of([&] {
    load(part_with_setup(folder, "setup:\n  work_offsets_mm: {G54: [0, 0, 0]}\n",
                         "G0 X0 Y0 Z0\nG55 G0 X1\n"));
  });
  EXPECT_NE(message.find("path.nc:2:1: 'G55': work offset G55 is not set up (set up: G54"),
            std::string::npos)
      << message;
}

}  // namespace
}  // namespace vmsim
