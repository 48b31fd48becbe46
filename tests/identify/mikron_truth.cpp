// The Mikron sample as the independent truth simulator has its drives (see mikron_truth.hpp).
#include "mikron_truth.hpp"

#include <yaml-cpp/yaml.h>

#include <stdexcept>

namespace vmsim::identify::test {
namespace {

constexpr double kPi = 3.141592653589793;
constexpr double kGravity_m_per_s2 = 9.81;

YAML::Node mikron_file() {
  return YAML::LoadFile(std::string(VMSIM_SOURCE_DIR) + "/samples/machines/mikron_ucp710.yaml");
}

}  // namespace

std::string mikron_truth_machine_yaml(double y_delay_s) {
  YAML::Node m = mikron_file();
  m.remove("interpolation_period_ms");
  m["interpolation_period_s"] = 0.002;  // the set points reach the 2 ms position loop directly
  for (YAML::Node axis : m["axes"]) {
    const bool linear = axis["type"].as<std::string>() == "linear";
    YAML::Node old = axis["controller"];
    YAML::Node c;
    c["position"]["kv_per_s"] = 50.0;  // 3 (m/min)/mm
    c["position"]["period_s"] = 0.002;
    c["position"]["output_dead_time_s"] = 0.000125;
    if (linear) {
      c["position"]["load_encoder_resolution_nm"] = 5.0;
    } else {  // 5 nm at a 200 mm radius
      c["position"]["load_encoder_resolution_arcsec"] = 5e-9 / 0.2 * 180.0 / kPi * 3600.0;
    }
    c["velocity"]["type"] = "PI";
    c["velocity"]["gain_N_m_s_per_rad"] = old["velocity"]["gain_N_m_s_per_rad"];
    c["velocity"]["integral_time_s"] = 0.004;
    c["velocity"]["period_s"] = 0.000125;
    c["velocity"]["output_delay_samples"] = 1;
    c["current"]["model"] = "first_order";
    c["current"]["bandwidth_hz"] = 800.0;
    c["feedforward"]["velocity"] = true;
    c["feedforward"]["torque"] = false;
    c["feedforward"]["timing"] = "held_backward";
    c["delay_s"] = axis["name"].as<std::string>() == "Y" ? y_delay_s : 0.0;
    c["saturation"]["current_A"] = 32.5;
    c["encoder_counts_per_rev"] = 4194304;
    axis["controller"] = c;
    if (linear) {
      axis["effects"]["smooth_friction"]["speed_mm_per_s"] = 0.2;
    } else {
      axis["effects"]["smooth_friction"]["speed_deg_per_s"] = 0.2;
    }
  }
  YAML::Emitter out;
  out << m;
  return std::string("# Mikron UCP710 sample, drives as the independent truth simulator has them\n") +
         out.c_str() + "\n";
}

double mikron_z_lifted_mass_kg() {
  const YAML::Node m = mikron_file();
  double mass = 0.0;
  bool from_z = false;
  for (const YAML::Node& link : m["structure"]["tool_chain"]) {
    if (link["joint"] && link["joint"].as<std::string>() == "Z") from_z = true;
    if (from_z && link["body"]) mass += link["body"]["mass_kg"].as<double>();
  }
  return mass;
}

void mikron_a_first_moment_kg_m(double& y_kg_m, double& z_kg_m) {
  // Walk the workpiece chain from joint A on, adding the link origins (A's own origin places
  // the axis: left out); a body behind a rotary joint with its centre of mass off that joint's
  // axis would move it with the joint: refused, as the sample has none.
  const YAML::Node m = mikron_file();
  y_kg_m = z_kg_m = 0.0;
  double origin_y_m = 0.0, origin_z_m = 0.0;
  bool from_a = false;
  for (const YAML::Node& link : m["structure"]["workpiece_chain"]) {
    const bool is_a = link["joint"] && link["joint"].as<std::string>() == "A";
    if (from_a && link["origin_mm"]) {
      if (link["origin_mm"][0].as<double>() != 0.0 || link["origin_rpy_deg"]) {
        throw std::runtime_error("mikron_a_first_moment_kg_m: a link off the table's axis");
      }
      origin_y_m += 1e-3 * link["origin_mm"][1].as<double>();
      origin_z_m += 1e-3 * link["origin_mm"][2].as<double>();
    }
    if (is_a) from_a = true;
    if (!from_a || !link["body"]) continue;
    const YAML::Node com = link["body"]["com_mm"];
    if (!is_a && (com[0].as<double>() != 0.0 || com[1].as<double>() != 0.0)) {
      throw std::runtime_error("mikron_a_first_moment_kg_m: a centre of mass off the table's axis");
    }
    const double mass = link["body"]["mass_kg"].as<double>();
    y_kg_m += mass * (origin_y_m + 1e-3 * com[1].as<double>());
    z_kg_m += mass * (origin_z_m + 1e-3 * com[2].as<double>());
  }
}

std::vector<IndependentDrive> mikron_truth_drives(const kinematics::MachineModel& machine, double y_delay_s) {
  double a_moment_y_kg_m = 0.0, a_moment_z_kg_m = 0.0;
  mikron_a_first_moment_kg_m(a_moment_y_kg_m, a_moment_z_kg_m);
  std::vector<IndependentDrive> drives;
  for (const auto& axis : machine.axes) {
    IndependentDrive d;
    d.axis_name = axis.name;
    d.rotary = axis.type == kinematics::AxisType::rotary;
    d.ratio_joint_per_rad = axis.drive.ratio;
    d.motor_inertia_kg_m2 = axis.drive.rotor_inertia_kg_m2;
    d.load_mass_kg = (axis.drive.equivalent_inertia_kg_m2 - axis.drive.rotor_inertia_kg_m2) /
                     (axis.drive.ratio * axis.drive.ratio);
    d.kt_N_m_per_A = axis.drive.torque_constant_N_m_per_A;
    d.viscous_A_s_per_m = axis.drive.friction_viscous_A_per_joint_unit_per_s;
    d.coulomb_A = axis.drive.friction_dry_A;
    d.smooth_speed_m_per_s = d.rotary ? 0.2 * kPi / 180.0 : 0.2e-3;
    d.kv_per_s = 50.0;
    d.position_period_s = 0.002;
    d.velocity_period_s = 0.000125;
    d.velocity_gain_N_m_s_per_rad = axis.controller.velocity_gain_N_m_s_per_rad;
    d.velocity_integral_time_s = 0.004;
    d.current_bandwidth_hz = 800.0;
    d.current_max_A = 32.5;
    d.velocity_feedforward = true;
    d.torque_feedforward = false;
    d.substeps = 8;
    d.position_output_delay_cycles = 1;
    d.motor_counts_per_rev = 4194304.0;
    d.scale_quantum_m = d.rotary ? 5e-9 / 0.2 : 5e-9;  // 5 nm; a 200 mm radius on a table
    d.loop_on_motor_encoder = true;
    d.trace_period_s = 0.002;
    if (axis.name == "Z") d.offset_force_N = mikron_z_lifted_mass_kg() * kGravity_m_per_s2;  // resists +z
    if (axis.name == "A") {
      // The cradle turns about +x by A (base z up, gravity -z): a centre of mass at (c_y, c_z)
      // moves to (c_y cos A - c_z sin A, ...); gravity's torque about +x is -m g times that y.
      d.gravity_cos_N = kGravity_m_per_s2 * a_moment_y_kg_m;
      d.gravity_sin_N = -kGravity_m_per_s2 * a_moment_z_kg_m;
    }
    if (axis.name == "Y") d.setpoint_delay_s = y_delay_s;
    drives.push_back(d);
  }
  return drives;
}

}  // namespace vmsim::identify::test
