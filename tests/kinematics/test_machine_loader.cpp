// The machine loader: unit conversion of the samples, URDF import against the explicit chain,
// and one located error per kind of bad input.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <numbers>
#include <sstream>
#include <string>

#include "vmsim/common/errors.hpp"
#include "vmsim/kinematics/machine_loader.hpp"

namespace vmsim::kinematics {
namespace {

const std::string kSamples = std::string(VMSIM_SOURCE_DIR) + "/samples/machines/";
constexpr double kPi = std::numbers::pi;

std::string read_text(const std::string& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// Replaces the first occurrence of `from` (which must exist) in the Mikron sample's text.
std::string mikron_with(const std::string& from, const std::string& to) {
  std::string text = read_text(kSamples + "mikron_ucp710.yaml");
  const std::size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << "test setup: '" << from << "' not in the sample";
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

// The error message of parsing `text`, or "" when it parses.
std::string error_of(const std::string& text) {
  try {
    parse_machine(text, "bad.yaml", kSamples);
  } catch (const InputError& error) {
    return error.what();
  }
  return "";
}

TEST(MachineLoader, MikronSampleIsConvertedToSI) {
  const MachineModel model = load_machine(kSamples + "mikron_ucp710.yaml");
  ASSERT_EQ(model.axis_count(), 5u);
  EXPECT_EQ(model.kind, MachineKind::machine_tool);
  EXPECT_DOUBLE_EQ(model.interpolation_period_s, 0.004);
  const Axis& x = model.axes[static_cast<std::size_t>(model.axis_index("X"))];
  EXPECT_DOUBLE_EQ(x.limits.velocity_max, 0.5);  // 30 m/min
  EXPECT_DOUBLE_EQ(x.limits.acceleration_max, 2.5);
  EXPECT_DOUBLE_EQ(x.travel_min, -0.355);
  EXPECT_NEAR(x.drive.ratio, 0.020 / (2 * kPi), 1e-15);  // 20 mm lead
  EXPECT_NEAR(x.controller.position_gain_kv_per_s, 50.0, 1e-12);  // 3 (m/min)/mm
  EXPECT_DOUBLE_EQ(x.controller.velocity_period_s, 125e-6);
  EXPECT_DOUBLE_EQ(x.controller.balancing_time_s, 1.5e-3);
  const Axis& a = model.axes[static_cast<std::size_t>(model.axis_index("A"))];
  EXPECT_EQ(a.type, AxisType::rotary);
  EXPECT_NEAR(a.limits.velocity_max, 15.0 * 2 * kPi / 60.0, 1e-15);  // 15 rev/min
  EXPECT_NEAR(a.limits.acceleration_max, 0.83 * 2 * kPi, 1e-15);
  EXPECT_NEAR(a.travel_min, -120.0 * kPi / 180.0, 1e-15);
  EXPECT_DOUBLE_EQ(a.drive.ratio, 0.01);
  const Axis& c = model.axes[static_cast<std::size_t>(model.axis_index("C"))];
  EXPECT_TRUE(c.continuous);
  EXPECT_NEAR(c.controller.velocity_max_rad_per_s, 4000.0 * 2 * kPi / 60.0, 1e-12);
  ASSERT_EQ(model.workpiece_chain.size(), 3u);
  EXPECT_EQ(model.workpiece_chain[0].type, JointType::revolute);
  EXPECT_NEAR(model.workpiece_chain[0].origin.translation().z(), 0.25, 1e-15);
  EXPECT_EQ(model.tool_chain.back().type, JointType::fixed);
}

TEST(MachineLoader, EquivalentInertiasReproduceTable1ThroughEq10) {
  // tau_eq = J_eq / r * q''max (first paper, Eq. 10; Table 1).
  const MachineModel model = load_machine(kSamples + "mikron_ucp710.yaml");
  const double table1_tau_eq_N_m[] = {44.0, 45.2, 29.7, 10.7, 9.29};
  for (std::size_t i = 0; i < 5; ++i) {
    const Axis& axis = model.axes[i];
    const double tau_eq =
        axis.drive.equivalent_inertia_kg_m2 / axis.drive.ratio * axis.limits.acceleration_max;
    EXPECT_NEAR(tau_eq, table1_tau_eq_N_m[i], 0.005 * table1_tau_eq_N_m[i]) << axis.name;
  }
}

TEST(MachineLoader, UrdfRobotEqualsTheExplicitChain) {
  const MachineModel explicit_model = load_machine(kSamples + "kr180_class.yaml");
  const MachineModel urdf_model = load_machine(kSamples + "kr180_class_urdf.yaml");
  EXPECT_EQ(explicit_model.kind, MachineKind::robot);
  ASSERT_EQ(explicit_model.tool_chain.size(), urdf_model.tool_chain.size());
  for (std::size_t i = 0; i < explicit_model.tool_chain.size(); ++i) {
    const Joint& a = explicit_model.tool_chain[i];
    const Joint& b = urdf_model.tool_chain[i];
    EXPECT_EQ(a.type, b.type) << i;
    EXPECT_EQ(a.axis_index, b.axis_index) << i;
    EXPECT_TRUE(a.origin.isApprox(b.origin, 1e-12)) << i;
    EXPECT_TRUE(a.direction.isApprox(b.direction, 1e-12)) << i;
    EXPECT_NEAR(a.body.mass_kg, b.body.mass_kg, 1e-12) << i;
    EXPECT_TRUE(a.body.com_m.isApprox(b.body.com_m, 1e-12) ||
                (a.body.com_m - b.body.com_m).norm() < 1e-12) << i;
    EXPECT_TRUE((a.body.inertia_kg_m2 - b.body.inertia_kg_m2).norm() < 1e-12) << i;
  }
  ASSERT_EQ(urdf_model.workpiece_chain.size(), 1u);
  EXPECT_TRUE(explicit_model.workpiece_chain[0].origin.isApprox(urdf_model.workpiece_chain[0].origin));
  for (std::size_t i = 0; i < 6; ++i) {
    EXPECT_NEAR(explicit_model.axes[i].travel_min, urdf_model.axes[i].travel_min, 1e-6);
  }
}

TEST(MachineLoaderErrors, MissingFieldNamesFileLineFieldAndAxis) {
  const std::string message = error_of(mikron_with("      torque_max_N_m: 65\n", ""));
  EXPECT_NE(message.find("bad.yaml:"), std::string::npos) << message;
  EXPECT_NE(message.find("axes[0].drive"), std::string::npos) << message;
  EXPECT_NE(message.find("axis X"), std::string::npos) << message;
  EXPECT_NE(message.find("torque_max_N_m"), std::string::npos) << message;
  // The line of the drive map of X.
  const std::string text = read_text(kSamples + "mikron_ucp710.yaml");
  const int drive_line =
      1 + static_cast<int>(std::count(text.begin(), text.begin() + static_cast<long>(text.find("    drive:")), '\n'));
  EXPECT_NE(message.find(":" + std::to_string(drive_line + 1) + ":"), std::string::npos)
      << message << " (drive map starts on line " << drive_line + 1 << ")";
}

TEST(MachineLoaderErrors, BadValuesAreNamed) {
  std::string message = error_of(mikron_with("torque_max_N_m: 65", "torque_max_N_m: -65"));
  EXPECT_NE(message.find("torque_max_N_m"), std::string::npos) << message;
  EXPECT_NE(message.find("-65"), std::string::npos) << message;

  message = error_of(mikron_with("acceleration_m_per_s2: 2.5", "acceleration_m_per_s2: 2,5"));
  EXPECT_NE(message.find("'2,5'"), std::string::npos) << message;
  EXPECT_NE(message.find("axis X"), std::string::npos) << message;

  message = error_of(mikron_with("velocity_m_per_min: 30", "velocity_m_per_min: 30\n      velocity_mm_per_s: 500"));
  EXPECT_NE(message.find("keep one"), std::string::npos) << message;

  message = error_of(mikron_with("velocity_m_per_min: 30", "velocity_m_per_hour: 30"));
  EXPECT_NE(message.find("velocity_m_per_hour"), std::string::npos) << message;  // unknown field
  message = error_of(mikron_with("torque_max_N_m: 65", "torqe_max_N_m: 65"));
  EXPECT_NE(message.find("missing field 'torque_max_N_m' (the map has 'torqe_max_N_m'"),
            std::string::npos) << message;
  message = error_of(mikron_with("encoder_counts_per_rev: 4194304", "encoder_counts: 4194304"));
  EXPECT_NE(message.find("unknown field 'encoder_counts'"), std::string::npos) << message;

  message = error_of(mikron_with("type: linear", "type: linaer"));
  EXPECT_NE(message.find("'linaer' is not one of"), std::string::npos) << message;

  message = error_of(mikron_with("travel_mm: [-355, 355]", "travel_mm: [355, -355]"));
  EXPECT_NE(message.find("min < max"), std::string::npos) << message;

  message = error_of(mikron_with("    - joint: Y\n", "    - joint: W\n"));
  EXPECT_NE(message.find("no axis named 'W'"), std::string::npos) << message;

  message = error_of(mikron_with("  - name: Y", "  - name: X"));
  EXPECT_NE(message.find("duplicate axis name 'X'"), std::string::npos) << message;

  message = error_of(mikron_with("direction: [1, 0, 0]", "direction: [0, 0, 0]"));
  EXPECT_NE(message.find("zero vector"), std::string::npos) << message;

  message = error_of(mikron_with("inertia_kg_m2: {ixx: 12, iyy: 10, izz: 14}",
                                 "inertia_kg_m2: {ixx: 1, iyy: 1, izz: 14}"));
  EXPECT_NE(message.find("triangle inequality"), std::string::npos) << message;

  message = error_of("name: [unclosed");
  EXPECT_NE(message.find("YAML syntax"), std::string::npos) << message;
}

TEST(MachineLoaderErrors, AnAxisMissingFromTheStructureIsAnError) {
  const std::string message = error_of(mikron_with(
      "    - joint: Y\n      direction: [0, 1, 0]\n", "    - fixed: no_y\n"));
  EXPECT_NE(message.find("axis Y is moved by 0 joints"), std::string::npos) << message;
}

TEST(MachineLoaderErrors, MissingFileIsNamed) {
  try {
    load_machine("/nonexistent/machine.yaml");
    FAIL() << "no error";
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find("/nonexistent/machine.yaml"), std::string::npos);
  }
}

}  // namespace
}  // namespace vmsim::kinematics
