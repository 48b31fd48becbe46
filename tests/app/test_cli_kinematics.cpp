// The vmsim program end to end: `vmsim kinematics` on a sample, checked against the direct
// kinematics; and the exit code, message and absence of output for each kind of bad input.
#include <gtest/gtest.h>

#include <fstream>
#include <numbers>
#include <sstream>

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

// Hand-computed axes of the Mikron sample (samples/machines/mikron_ucp710.yaml): the workpiece
// chain is Trans(0,0,250) RotX(A) Trans(0,0,-120) RotZ(C), the spindle gauge point sits at
// (X, Y, Z + 600) mm with the tool along +z. The tip p_W is reached at
// p_B = (0,0,250) + RotX(A) ((0,0,-120) + RotZ(C) p_W), X = p_B.x, Y = p_B.y,
// Z = p_B.z - 600 + L; the tool axis in W is (sin A sin C, sin A cos C, cos A).
struct MikronAxes {
  double x_mm, y_mm, z_mm;
};
MikronAxes mikron_axes(double a_deg, double c_deg, Eigen::Vector3d tip_W_mm, double tool_mm) {
  const double a = a_deg * std::numbers::pi / 180.0, c = c_deg * std::numbers::pi / 180.0;
  const Eigen::Vector3d rc(std::cos(c) * tip_W_mm.x() - std::sin(c) * tip_W_mm.y(),
                           std::sin(c) * tip_W_mm.x() + std::cos(c) * tip_W_mm.y(),
                           tip_W_mm.z() - 120.0);
  const Eigen::Vector3d p_B(rc.x(), std::cos(a) * rc.y() - std::sin(a) * rc.z(),
                            250.0 + std::sin(a) * rc.y() + std::cos(a) * rc.z());
  return {p_B.x(), p_B.y(), p_B.z() - 600.0 + tool_mm};
}

// The user's case: under G43.4 the NC moves A and C to the programmed words, even where the
// other branch (A +5.545, C +25.608) is nearer the previous pose; only a tool vector (G43.5
// I J K) is left to the inverse kinematics, which takes the branch nearest the previous pose.
TEST(CliKinematics, ProgrammedRotaryWordsAreKeptUnderG43_4AndToolVectorsTakeTheNearestBranch) {
  const auto folder = test::fresh_folder("kinematics_tcp_words");
  const double a_deg = -5.545, c_deg = -154.392;
  const double a = a_deg * std::numbers::pi / 180.0, c = c_deg * std::numbers::pi / 180.0;
  const Eigen::Vector3d axis(std::sin(a) * std::sin(c), std::sin(a) * std::cos(c), std::cos(a));
  std::ostringstream vector_program;
  vector_program.precision(17);
  vector_program << "G21 G90 G94\nG43.5 H1 G0 X10 Y20 Z30 I" << axis.x() << " J" << axis.y()
                 << " K" << axis.z() << "\nG1 X12 F1000\n";
  write(folder / "words.nc", "G21 G90 G94\nG43.4 H1\nG0 X10 Y20 Z30 A-5.545 C-154.392\nG1 X12 F1000\n");
  write(folder / "vector.nc", vector_program.str());
  struct Case {
    std::string file;
    double a_deg, c_deg;
  };
  // From home (A0 C0) the nearest branch of the tool vector is A +5.545, C +25.608.
  for (const Case& expected : {Case{"words.nc", a_deg, c_deg},
                               Case{"vector.nc", -a_deg, c_deg + 180.0}}) {
    const std::string out = (folder / (expected.file + ".csv")).string();
    const test::RunResult run =
        test::run_vmsim("kinematics --machine " + kMikron + " --toolpath " +
                        (folder / expected.file).string() + " --tool-length-mm 100 --out " + out);
    ASSERT_EQ(run.exit_code, 0) << run.output;
    const Trace trace = read_trace(out);
    ASSERT_EQ(trace.sample_count(), 2u) << expected.file;
    for (std::size_t i = 0; i < 2; ++i) {
      const Eigen::Vector3d tip_mm(i == 0 ? 10.0 : 12.0, 20.0, 30.0);
      const MikronAxes hand = mikron_axes(expected.a_deg, expected.c_deg, tip_mm, 100.0);
      EXPECT_NEAR(trace.column("A.cmd")[i], expected.a_deg, 1e-9) << expected.file << " " << i;
      EXPECT_NEAR(trace.column("C.cmd")[i], expected.c_deg, 1e-9) << expected.file << " " << i;
      EXPECT_NEAR(trace.column("X.cmd")[i], hand.x_mm, 1e-6) << expected.file << " " << i;
      EXPECT_NEAR(trace.column("Y.cmd")[i], hand.y_mm, 1e-6) << expected.file << " " << i;
      EXPECT_NEAR(trace.column("Z.cmd")[i], hand.z_mm, 1e-6) << expected.file << " " << i;
    }
  }
}

}  // namespace
}  // namespace vmsim
