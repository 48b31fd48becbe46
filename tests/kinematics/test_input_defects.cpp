// Hostile machine files and URDFs: each defect gives a located vmsim::InputError (file, line,
// element or field, value) and never a hang, a crash or a silently dropped value.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <sstream>
#include <string>

#include "../temp_folder.hpp"
#include "vmsim/common/errors.hpp"
#include "vmsim/kinematics/yaml_input.hpp"
#include "vmsim/kinematics/kinematics.hpp"
#include "vmsim/kinematics/machine_loader.hpp"

namespace vmsim::kinematics {
namespace {

const std::string kSamples = std::string(VMSIM_SOURCE_DIR) + "/samples/machines/";

std::string read_text(const std::string& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

std::string replaced(std::string text, const std::string& from, const std::string& to) {
  const std::size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << "test setup: '" << from << "' not in the text";
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

std::string mikron_with(const std::string& from, const std::string& to) {
  return replaced(read_text(kSamples + "mikron_ucp710.yaml"), from, to);
}

std::string error_of(const std::string& machine_text) {
  try {
    parse_machine(machine_text, "bad.yaml", kSamples);
  } catch (const InputError& error) {
    return error.what();
  }
  return "";
}

// The error of loading the KR180 sample with its URDF replaced by `urdf_text`.
std::string urdf_error_of(const std::string& urdf_text, const std::string& test_name) {
  const auto folder = test::fresh_temp_folder(test_name);
  std::ofstream(folder / "robot.urdf") << urdf_text;
  const std::string machine = replaced(read_text(kSamples + "kr180_class_urdf.yaml"),
                                       "urdf: kr180_class.urdf",
                                       "urdf: " + (folder / "robot.urdf").string());
  return error_of(machine);
}

std::string kr180_urdf() { return read_text(kSamples + "kr180_class.urdf"); }

// --- URDF values urdfdom would drop ---------------------------------------------------------

TEST(UrdfDefects, NanMassIsRefusedWithTheLineAndValue) {
  // urdfdom cannot read "nan" and drops the inertial block: the link would lose its 400 kg.
  const std::string error =
      urdf_error_of(replaced(kr180_urdf(), "<mass value=\"400\"/>", "<mass value=\"nan\"/>"),
                    "urdf_nan_mass");
  EXPECT_NE(error.find("robot.urdf:8:"), std::string::npos) << error;
  EXPECT_NE(error.find("<mass> of link 'link1'"), std::string::npos) << error;
  EXPECT_NE(error.find("nan"), std::string::npos) << error;
}

TEST(UrdfDefects, ZeroMassOfAnInertialIsRefused) {
  const std::string error = urdf_error_of(
      replaced(kr180_urdf(), "<mass value=\"400\"/>", "<mass value=\"0\"/>"), "urdf_zero_mass");
  EXPECT_NE(error.find("a mass must be > 0"), std::string::npos) << error;
}

TEST(UrdfDefects, InertiaViolatingTheTriangleInequalityIsRefused) {
  const std::string error = urdf_error_of(
      replaced(kr180_urdf(), "ixx=\"40\" iyy=\"45\" izz=\"30\"", "ixx=\"1\" iyy=\"1\" izz=\"30\""),
      "urdf_triangle");
  EXPECT_NE(error.find("robot.urdf:9:"), std::string::npos) << error;
  EXPECT_NE(error.find("triangle inequality"), std::string::npos) << error;
}

TEST(UrdfDefects, NegativeInertiaIsRefused) {
  const std::string error = urdf_error_of(
      replaced(kr180_urdf(), "ixx=\"40\"", "ixx=\"-40\""), "urdf_negative_inertia");
  EXPECT_NE(error.find("<inertia> of link 'link1'"), std::string::npos) << error;
}

TEST(UrdfDefects, NonFiniteOriginIsRefused) {
  const std::string error = urdf_error_of(
      replaced(kr180_urdf(), "<origin xyz=\"0.35 0 0.675\"", "<origin xyz=\"0.35 inf 0.675\""),
      "urdf_origin");
  EXPECT_NE(error.find("<origin> of joint 'q2'"), std::string::npos) << error;
  EXPECT_NE(error.find("'inf'"), std::string::npos) << error;
}

TEST(UrdfDefects, ZeroAxisIsRefused) {
  const std::string error =
      urdf_error_of(replaced(kr180_urdf(), "<axis xyz=\"0 1 0\"/>", "<axis xyz=\"0 0 0\"/>"),
                    "urdf_axis");
  EXPECT_NE(error.find("<axis> of joint 'q2'"), std::string::npos) << error;
}

TEST(UrdfDefects, AbsurdJointLimitIsRefused) {
  const std::string error = urdf_error_of(
      replaced(kr180_urdf(), "lower=\"-2.443461\"", "lower=\"-1e300\""), "urdf_limit");
  EXPECT_NE(error.find("<limit> of joint 'q2'"), std::string::npos) << error;
  EXPECT_NE(error.find("not a plausible joint limit"), std::string::npos) << error;
}

TEST(UrdfDefects, SubnormalMassIsRefused) {
  const std::string error = urdf_error_of(
      replaced(kr180_urdf(), "<mass value=\"400\"/>", "<mass value=\"4.9e-324\"/>"),
      "urdf_subnormal");
  EXPECT_NE(error.find("subnormal"), std::string::npos) << error;
}

// --- URDF structure: cycles, two parents, nesting --------------------------------------------

TEST(UrdfDefects, JointCycleIsRefusedInsteadOfLoopingForEver) {
  // q1 made the child of link2: link1 -> link2 -> link1, a cycle above the tip.
  const std::string cyclic = replaced(kr180_urdf(), "<parent link=\"base\"/>",
                                      "<parent link=\"link2\"/>");
  const std::string error = urdf_error_of(cyclic, "urdf_cycle");
  EXPECT_NE(error.find("cycle"), std::string::npos) << error;
  EXPECT_NE(error.find("robot.urdf:"), std::string::npos) << error;
}

TEST(UrdfDefects, LinkWithTwoParentsIsRefused) {
  const std::string extra_joint =
      "  <joint name=\"extra\" type=\"fixed\">\n"
      "    <parent link=\"base\"/>\n"
      "    <child link=\"link2\"/>\n"
      "  </joint>\n"
      "</robot>";
  const std::string error =
      urdf_error_of(replaced(kr180_urdf(), "</robot>", extra_joint), "urdf_two_parents");
  EXPECT_NE(error.find("link 'link2' already has a parent, joint 'q2'"), std::string::npos)
      << error;
}

TEST(UrdfDefects, DeepNestingIsRefusedWithoutOverflowingTheStack) {
  std::string deep = "<?xml version=\"1.0\"?>\n<robot name=\"deep\">\n";
  for (int i = 0; i < 100000; ++i) deep += "<a>";
  for (int i = 0; i < 100000; ++i) deep += "</a>";
  deep += "\n</robot>\n";
  const std::string error = urdf_error_of(deep, "urdf_deep");
  EXPECT_NE(error.find("nest more than 100 deep"), std::string::npos) << error;
  EXPECT_NE(error.find("robot.urdf:3"), std::string::npos) << error;
}

TEST(UrdfDefects, ByteOrderMarkIsSkipped) {
  EXPECT_EQ(urdf_error_of("\xEF\xBB\xBF" + kr180_urdf(), "urdf_bom"), "");
}

// --- Rotary travel ----------------------------------------------------------------------------

TEST(TravelDefects, AbsurdRotaryTravelIsRefused) {
  const std::string error =
      error_of(mikron_with("travel_deg: [-120, 30]", "travel_deg: [-1e300, 1e300]"));
  EXPECT_NE(error.find("bad.yaml:104:"), std::string::npos) << error;
  EXPECT_NE(error.find("not plausible"), std::string::npos) << error;
  EXPECT_NE(error.find("axis A"), std::string::npos) << error;
}

TEST(TravelDefects, InverseKinematicsWithAHugeTravelReturns) {
  // A model built by hand is not checked for plausibility: the unwrapping must still end.
  MachineModel model = load_machine(kSamples + "mikron_ucp710.yaml");
  const int a = model.axis_index("A");
  ASSERT_GE(a, 0);
  model.axes[static_cast<std::size_t>(a)].travel_min = -1e300;
  model.axes[static_cast<std::size_t>(a)].travel_max = 1e300;
  Eigen::VectorXd q = model.home_positions();
  q[a] = -0.5;
  const ToolPose pose = forward_kinematics(model, q, 0.1);
  const auto solution = inverse_kinematics(model, pose, model.home_positions(), 0.1);
  ASSERT_TRUE(solution.has_value());
  EXPECT_NEAR(solution->q[a], -0.5, 1e-6);
}

// --- YAML: duplicated keys, extra documents, numbers, hints -----------------------------------

TEST(YamlDefects, KeyGivenTwiceIsRefusedWithBothLines) {
  const std::string error =
      error_of(mikron_with("travel_deg: [-120, 30]", "travel_deg: [-120, 30]\n    home_deg: 1"));
  EXPECT_NE(error.find("bad.yaml:106:"), std::string::npos) << error;
  EXPECT_NE(error.find("'home_deg' is given twice"), std::string::npos) << error;
  EXPECT_NE(error.find("first on line 105"), std::string::npos) << error;
}

TEST(YamlDefects, SecondDocumentIsRefused) {
  const std::string text = read_text(kSamples + "mikron_ucp710.yaml") + "---\nname: other\n";
  const std::string error = error_of(text);
  EXPECT_NE(error.find("second YAML document"), std::string::npos) << error;
}

TEST(YamlDefects, SubnormalNumberIsRefusedWithItsValue) {
  const std::string error =
      error_of(mikron_with("torque_max_N_m: 65", "torque_max_N_m: 4.9e-324"));
  EXPECT_NE(error.find("'4.9e-324'"), std::string::npos) << error;
  EXPECT_NE(error.find("subnormal"), std::string::npos) << error;
}

TEST(YamlDefects, ZeroStaysAllowedWhereItWas) {
  EXPECT_EQ(error_of(mikron_with("delay_ms: 0", "delay_ms: 0.0e0")), "");
}

TEST(YamlDefects, UnknownKeyNamesTheNearestKnownOne) {
  const std::string error =
      error_of(mikron_with("torque_max_N_m: 65", "torque_max_N_m: 65\n      torque_maxx_N_m: 3"));
  EXPECT_NE(error.find("unknown field 'torque_maxx_N_m' (did you mean 'torque_max_N_m'?)"),
            std::string::npos)
      << error;
}

TEST(YamlDefects, AbsurdInterpolationPeriodIsRefused) {
  const std::string error =
      error_of(mikron_with("interpolation_period_ms: 4", "interpolation_period_s: 4000"));
  EXPECT_NE(error.find("bad.yaml:24:"), std::string::npos) << error;
  EXPECT_NE(error.find("not plausible"), std::string::npos) << error;
}

TEST(YamlDefects, ByteOrderMarkIsSkipped) {
  EXPECT_EQ(error_of("\xEF\xBB\xBF" + read_text(kSamples + "mikron_ucp710.yaml")), "");
}

// --- Inputs that are not regular files ----------------------------------------------------------

TEST(InputFileDefects, MachineFileThatIsAFifoIsRefused) {
  const auto folder = test::fresh_temp_folder("machine_fifo");
  const std::string fifo = (folder / "machine.yaml").string();
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  try {
    load_machine(fifo);
    FAIL() << "a FIFO was read";
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find("FIFO"), std::string::npos) << error.what();
  }
}

TEST(InputFileDefects, UrdfThatIsADeviceIsRefused) {
  const std::string machine = replaced(read_text(kSamples + "kr180_class_urdf.yaml"),
                                       "urdf: kr180_class.urdf", "urdf: /dev/zero");
  const std::string error = error_of(machine);
  EXPECT_NE(error.find("/dev/zero"), std::string::npos) << error;
  EXPECT_NE(error.find("not a regular file"), std::string::npos) << error;
}

}  // namespace
}  // namespace vmsim::kinematics

namespace vmsim::kinematics {
namespace {

// yaml-cpp 0.7's LoadAll returns empty documents for ever on a ',' outside brackets and fills the
// memory (found by fuzz_part_file: a part file that hung for minutes): a located error at once.
TEST(YamlInput, ACommaOutsideBracketsIsASyntaxErrorNotAHang) {
  try {
    parse_yaml_input(",\nname: x\n", "comma.yaml");
    ADD_FAILURE() << "accepted";
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find("comma.yaml:1:1: YAML syntax"), std::string::npos) << error.what();
  }
}

}  // namespace
}  // namespace vmsim::kinematics
