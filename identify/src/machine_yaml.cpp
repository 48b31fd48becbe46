// Writing identified and extended drive parameters back into a machine file: the original YAML
// with each axis's drive, controller and effects fields replaced (keys as the loader reads them).
#include <filesystem>
#include <yaml-cpp/yaml.h>

#include "vmsim/common/errors.hpp"
#include "vmsim/common/files.hpp"
#include "vmsim/identify/identify.hpp"
#include "vmsim/kinematics/machine_loader.hpp"
#include "vmsim/kinematics/yaml_input.hpp"

namespace vmsim::identify {
namespace {

std::string number(double v) { return format_double(v); }

// Removes every key of `map` that starts with `prefix` (a quantity with any unit suffix).
void remove_prefixed(YAML::Node map, const std::string& prefix) {
  std::vector<std::string> keys;
  for (const auto& item : map) {
    const std::string key = item.first.as<std::string>();
    if (key.rfind(prefix, 0) == 0) keys.push_back(key);
  }
  for (const auto& key : keys) map.remove(key);
}

void write_axis(YAML::Node node, const kinematics::Axis& axis) {
  const bool linear = axis.type == kinematics::AxisType::linear;
  YAML::Node drive = node["drive"];
  drive["equivalent_inertia_kg_m2"] = number(axis.drive.equivalent_inertia_kg_m2);
  if (drive["rotor_inertia_kg_m2"] || axis.drive.rotor_inertia_kg_m2 > 0.0) {
    drive["rotor_inertia_kg_m2"] = number(axis.drive.rotor_inertia_kg_m2);
  }
  remove_prefixed(drive, "friction_viscous");
  drive[linear ? "friction_viscous_A_s_per_m" : "friction_viscous_A_s_per_rad"] =
      number(axis.drive.friction_viscous_A_per_joint_unit_per_s);
  drive["friction_dry_A"] = number(axis.drive.friction_dry_A);

  YAML::Node controller = node["controller"];
  remove_prefixed(controller, "delay");
  if (axis.controller.delay_s != 0.0) controller["delay_s"] = number(axis.controller.delay_s);
  if (axis.controller.torque_feedforward && controller["feedforward"]) {
    // The inertia fit keeps the feedforward's own inertia (J_eq x weight) where it was.
    controller["feedforward"]["torque_weight"] = number(axis.controller.torque_feedforward_weight);
  }
  if (axis.controller.current_max_A > 0.0) {
    controller["saturation"]["current_A"] = number(axis.controller.current_max_A);
  }

  const kinematics::DriveEffects& e = axis.effects;
  YAML::Node effects(YAML::NodeType::Map);
  const std::string viscous_unit = linear ? "_A_s_per_m" : "_A_s_per_rad";
  if (e.stribeck.enabled) {
    YAML::Node s;
    s["static_friction_A"] = number(e.stribeck.static_friction_A);
    s[linear ? "velocity_m_per_s" : "velocity_rad_per_s"] = number(e.stribeck.velocity);
    s["exponent"] = number(e.stribeck.exponent);
    effects["stribeck"] = s;
  }
  if (e.asymmetric_friction.enabled) {
    YAML::Node s;
    s["dry_positive_A"] = number(e.asymmetric_friction.dry_positive_A);
    s["dry_negative_A"] = number(e.asymmetric_friction.dry_negative_A);
    s["viscous_positive" + viscous_unit] =
        number(e.asymmetric_friction.viscous_positive_A_per_joint_unit_per_s);
    s["viscous_negative" + viscous_unit] =
        number(e.asymmetric_friction.viscous_negative_A_per_joint_unit_per_s);
    effects["asymmetric_friction"] = s;
  }
  if (e.backlash.enabled) {
    YAML::Node s;
    s[linear ? "gap_m" : "gap_rad"] = number(e.backlash.gap);
    effects["backlash"] = s;
  }
  if (e.cogging.enabled) {
    YAML::Node s;
    s["amplitude_N_m"] = number(e.cogging.amplitude_N_m);
    s["periods_per_rev"] = number(e.cogging.periods_per_rev);
    s["phase_rad"] = number(e.cogging.phase_rad);
    effects["cogging"] = s;
  }
  if (e.pitch_error.enabled) {
    YAML::Node s;
    s[linear ? "amplitude_m" : "amplitude_rad"] = number(e.pitch_error.amplitude);
    s[linear ? "period_m" : "period_rad"] = number(e.pitch_error.period);
    s["phase_rad"] = number(e.pitch_error.phase_rad);
    effects["pitch_error"] = s;
  }
  if (e.compliance.enabled) {
    YAML::Node s;
    s[linear ? "stiffness_N_per_m" : "stiffness_N_m_per_rad"] = number(e.compliance.stiffness);
    s["damping_ratio"] = number(e.compliance.damping_ratio);
    s["motor_side_inertia_kg_m2"] = number(e.compliance.motor_side_inertia_kg_m2);
    if (e.compliance.compensate_gravity_deflection) s["compensate_gravity_deflection"] = true;
    // Always written: the loader's default depends on the machine's kind, and a robot's explicit
    // `load` must come back as it was.
    s["friction_side"] = e.compliance.friction_side == kinematics::FrictionSide::motor ? "motor" : "load";
    effects["compliance"] = s;
  }
  if (e.smooth_friction.enabled) {
    YAML::Node s;
    s[linear ? "speed_m_per_s" : "speed_rad_per_s"] = number(e.smooth_friction.speed);
    effects["smooth_friction"] = s;
  }
  if (e.gravity_compensated) effects["gravity_compensated"] = true;
  if (effects.size() > 0) {
    node["effects"] = effects;
  } else if (node["effects"]) {
    node.remove("effects");
  }
}

}  // namespace

std::string updated_machine_yaml(const std::string& original_yaml,
                                 const kinematics::MachineModel& machine,
                                 const std::vector<AxisNote>& notes,
                                 const std::string& file_name_for_messages,
                                 const std::string& base_directory) {
  YAML::Node root = kinematics::parse_yaml_input(original_yaml, file_name_for_messages);
  if (!root.IsMap() || !root["axes"] || !root["axes"].IsSequence()) {
    throw InputError(file_name_for_messages + ": no 'axes' list");
  }
  for (YAML::Node node : root["axes"]) {
    if (!node["name"]) continue;
    const std::string name = node["name"].as<std::string>();
    for (const auto& axis : machine.axes) {
      if (axis.name == name) write_axis(node, axis);
    }
  }
  // The written file goes elsewhere (a result folder): a URDF named relative to the original's
  // folder is written with its absolute path, so that the file still loads from there.
  if (root["structure"] && root["structure"].IsMap() && root["structure"]["urdf"]) {
    const std::filesystem::path urdf = root["structure"]["urdf"].as<std::string>();
    if (!urdf.is_absolute()) {
      root["structure"]["urdf"] =
          std::filesystem::absolute(std::filesystem::path(base_directory) / urdf).lexically_normal().string();
    }
  }
  YAML::Emitter out;
  out << root;
  std::string text = "# Written by vmsim from " + file_name_for_messages +
                     " with identified or extended drive parameters.\n";
  for (const auto& note : notes) text += "# axis " + note.axis_name + ": " + note.text + "\n";
  text += out.c_str();
  text += "\n";
  // The result must load: a failure here is a bug, reported with the text's own messages.
  kinematics::parse_machine(text, file_name_for_messages + " (updated)", base_directory);
  return text;
}

}  // namespace vmsim::identify
