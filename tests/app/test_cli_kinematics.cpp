// The vmsim program end to end: `vmsim kinematics` on a sample, checked against the direct
// kinematics; and the exit code, message and absence of output for each kind of bad input.
#include <gtest/gtest.h>

#include <fstream>
#include <numbers>

#include "cli_runner.hpp"
#include "vmsim/common/files.hpp"
#include "vmsim/common/trace.hpp"
#include "vmsim/kinematics/kinematics.hpp"
#include "vmsim/kinematics/machine_loader.hpp"
#include "vmsim/toolpath/toolpath.hpp"

namespace vmsim {
namespace {

const std::string kRoot = VMSIM_SOURCE_DIR;
const std::string kMikron = kRoot + "/samples/machines/mikron_ucp710.yaml";

void write(const std::filesystem::path& path, const std::string& text) {
  std::ofstream(path) << text;
}

TEST(CliKinematics, SetPointsReproduceTheToolPathThroughTheDirectKinematics) {
  const auto folder = test::fresh_folder("kinematics_ok");
  const std::string out = (folder / "axes.csv").string();
  const std::string part = kRoot + "/samples/parts/path1_yz/part.yaml";
  const test::RunResult run = test::run_vmsim("kinematics --part " + part + " --out " + out);
  ASSERT_EQ(run.exit_code, 0) << run.output;

  const kinematics::MachineModel machine = kinematics::load_machine(kMikron);
  const Trace trace = read_trace(out);
  const double tool_length_m = std::stod(trace.metadata_value("tool_length_mm").value()) * 1e-3;
  const toolpath::Toolpath toolpath = toolpath::read_toolpath(kRoot + "/samples/parts/path1_yz/toolpath.apt");
  ASSERT_EQ(trace.sample_count(), toolpath.points.size());
  for (std::size_t i = 0; i < trace.sample_count(); ++i) {
    Eigen::VectorXd q(5);
    for (std::size_t j = 0; j < 5; ++j) {
      const auto& axis = machine.axes[j];
      const double value = trace.column(axis.name + ".cmd")[i];
      q[static_cast<Eigen::Index>(j)] =
          axis.type == kinematics::AxisType::linear ? value * 1e-3 : value * std::numbers::pi / 180.0;
    }
    const kinematics::ToolPose pose = kinematics::forward_kinematics(machine, q, tool_length_m);
    EXPECT_LT((pose.tip_W_m - toolpath.points[i].tip_W_m).norm(), 1e-9) << "point " << i;
    EXPECT_LT((pose.axis_W - toolpath.points[i].axis_W).norm(), 1e-9) << "point " << i;
  }
}

TEST(CliKinematics, BadMachineFileExitsWith3NamingFileAndLineAndWritesNothing) {
  const auto folder = test::fresh_folder("kinematics_bad_machine");
  std::string machine = read_file(kMikron);
  machine.replace(machine.find("      torque_max_N_m: 65\n"), 25, "      torque_max_N_m: sixty\n");
  write(folder / "machine.yaml", machine);
  write(folder / "path.apt", "GOTO/0,0,50\nGOTO/10,0,50\n");
  const std::string out = (folder / "axes.csv").string();
  const test::RunResult run =
      test::run_vmsim("kinematics --machine " + (folder / "machine.yaml").string() + " --toolpath " +
                      (folder / "path.apt").string() + " --tool-length-mm 100 --out " + out);
  EXPECT_EQ(run.exit_code, 3) << run.output;
  EXPECT_NE(run.output.find("machine.yaml:"), std::string::npos) << run.output;
  EXPECT_NE(run.output.find("'sixty'"), std::string::npos) << run.output;
  EXPECT_FALSE(std::filesystem::exists(out));
}

TEST(CliKinematics, MalformedToolPathExitsWith3NamingTheLine) {
  const auto folder = test::fresh_folder("kinematics_bad_path");
  write(folder / "path.apt", "FEDRAT/MMPM,1000\nGOTO/0,0,50\nGOTO/10,abc,50\n");
  const std::string out = (folder / "axes.csv").string();
  const test::RunResult run =
      test::run_vmsim("kinematics --machine " + kMikron + " --toolpath " +
                      (folder / "path.apt").string() + " --tool-length-mm 100 --out " + out);
  EXPECT_EQ(run.exit_code, 3) << run.output;
  EXPECT_NE(run.output.find("path.apt:3"), std::string::npos) << run.output;
  EXPECT_FALSE(std::filesystem::exists(out));
}

TEST(CliKinematics, UnreachablePoseExitsWith4NamingTheBlock) {
  const auto folder = test::fresh_folder("kinematics_unreachable");
  // X travel is +-355 mm: a point 2 m away cannot be reached.
  write(folder / "path.apt", "FEDRAT/MMPM,1000\nGOTO/0,0,50\nGOTO/10,0,50\nGOTO/2000,0,50\n");
  const std::string out = (folder / "axes.csv").string();
  const test::RunResult run =
      test::run_vmsim("kinematics --machine " + kMikron + " --toolpath " +
                      (folder / "path.apt").string() + " --tool-length-mm 100 --out " + out);
  EXPECT_EQ(run.exit_code, 4) << run.output;
  EXPECT_NE(run.output.find("path.apt:4"), std::string::npos) << run.output;
  EXPECT_FALSE(std::filesystem::exists(out));
}

TEST(CliKinematics, UsageErrorsExitWith2) {
  EXPECT_EQ(test::run_vmsim("kinematics --machine " + kMikron).exit_code, 2);
  EXPECT_EQ(test::run_vmsim("no-such-command").exit_code, 2);
  const test::RunResult help = test::run_vmsim("--help");
  EXPECT_EQ(help.exit_code, 0);
  EXPECT_NE(help.output.find("kinematics"), std::string::npos);
  EXPECT_NE(help.output.find("Exit codes"), std::string::npos);
}

}  // namespace
}  // namespace vmsim
