#include "vmsim/kinematics/sample_models.hpp"

#include <cmath>
#include <numbers>

namespace vmsim::kinematics {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

Eigen::Isometry3d at(double x, double y, double z) {
  Eigen::Isometry3d origin = Eigen::Isometry3d::Identity();
  origin.translation() = Eigen::Vector3d(x, y, z);
  return origin;
}

RigidBody body(double mass_kg, Eigen::Vector3d com_m, Eigen::Vector3d principal_inertia_kg_m2) {
  RigidBody b;
  b.mass_kg = mass_kg;
  b.com_m = com_m;
  b.inertia_kg_m2 = principal_inertia_kg_m2.asDiagonal();
  return b;
}

Axis make_axis(std::string name, AxisType type, double travel_min, double travel_max,
               KinematicLimits limits, double ratio, double equivalent_inertia_kg_m2) {
  Axis axis;
  axis.name = std::move(name);
  axis.type = type;
  axis.travel_min = travel_min;
  axis.travel_max = travel_max;
  axis.limits = limits;
  axis.drive.ratio = ratio;
  axis.drive.equivalent_inertia_kg_m2 = equivalent_inertia_kg_m2;
  axis.drive.rotor_inertia_kg_m2 = 0.5 * equivalent_inertia_kg_m2;
  axis.drive.torque_constant_N_m_per_A = 2.0;
  axis.drive.friction_viscous_A_per_joint_unit_per_s = type == AxisType::linear ? 10.0 : 0.5;
  axis.drive.friction_dry_A = 1.0;
  axis.drive.torque_max_N_m = 65.0;
  axis.drive.torque_rate_max_N_m_per_s = 1000.0;
  return axis;
}

Joint moving_joint(const MachineModel& model, const std::string& axis_name, JointType type,
                   Eigen::Isometry3d origin, Eigen::Vector3d direction, RigidBody carried) {
  Joint joint;
  joint.name = axis_name;
  joint.type = type;
  joint.axis_index = model.axis_index(axis_name);
  joint.origin = origin;
  joint.direction = direction.normalized();
  joint.body = carried;
  return joint;
}

Joint fixed_joint(std::string name, Eigen::Isometry3d origin) {
  Joint joint;
  joint.name = std::move(name);
  joint.origin = origin;
  return joint;
}

}  // namespace

MachineModel make_table_table_sample() {
  MachineModel model;
  model.name = "table-table AC sample (in code)";
  model.kind = MachineKind::machine_tool;
  const double lead_m = 0.020;
  const double screw_ratio = lead_m / (2.0 * std::numbers::pi);
  const double gear_ratio = 1.0 / 100.0;
  model.axes = {
      make_axis("X", AxisType::linear, -0.355, 0.355, {0.5, 2.5, 5.0}, screw_ratio, 0.056),
      make_axis("Y", AxisType::linear, -0.275, 0.275, {0.5, 3.0, 5.0}, screw_ratio, 0.048),
      make_axis("Z", AxisType::linear, -0.6, 0.0, {0.5, 2.1, 50.0}, screw_ratio, 0.045),
      make_axis("A", AxisType::rotary, -100.0 * kDeg, 120.0 * kDeg,
                {15.0 * 2 * std::numbers::pi / 60.0, 0.83 * 2 * std::numbers::pi,
                 5.0 * 2 * std::numbers::pi},
                gear_ratio, 0.0205),
      make_axis("C", AxisType::rotary, 0.0, 0.0,
                {20.0 * 2 * std::numbers::pi / 60.0, 0.83 * 2 * std::numbers::pi,
                 50.0 * 2 * std::numbers::pi},
                gear_ratio, 0.0178),
  };
  model.axes[4].continuous = true;

  // Workpiece side: the cradle tilts about x; the C table turns about the cradle's z, its axis
  // passing 2 mm beside the A axis and its top 120 mm below it.
  model.workpiece_chain = {
      moving_joint(model, "A", JointType::revolute, at(0.0, 0.0, 0.25), Eigen::Vector3d::UnitX(),
                   body(250.0, {0.0, 0.0, -0.08}, {12.0, 10.0, 14.0})),
      moving_joint(model, "C", JointType::revolute, at(0.0, 0.002, -0.12),
                   Eigen::Vector3d::UnitZ(), body(120.0, {0.0, 0.0, -0.03}, {4.0, 4.0, 7.0})),
      fixed_joint("workpiece", at(0.0, 0.0, 0.0)),
  };
  // Tool side: X carries Y carries Z (the spindle head); S is the spindle gauge point.
  model.tool_chain = {
      moving_joint(model, "X", JointType::prismatic, at(0.0, 0.0, 0.0), Eigen::Vector3d::UnitX(),
                   body(700.0, {0.0, 0.0, 0.5}, {80.0, 60.0, 70.0})),
      moving_joint(model, "Y", JointType::prismatic, at(0.0, 0.0, 0.0), Eigen::Vector3d::UnitY(),
                   body(450.0, {0.0, 0.0, 0.6}, {40.0, 30.0, 35.0})),
      moving_joint(model, "Z", JointType::prismatic, at(0.0, 0.0, 0.0), Eigen::Vector3d::UnitZ(),
                   body(300.0, {0.0, 0.0, 0.8}, {20.0, 20.0, 5.0})),
      fixed_joint("spindle", at(0.0, 0.0, 0.6)),
  };
  return model;
}

MachineModel make_robot_sample() {
  MachineModel model;
  model.name = "6R robot sample of the KR180 class (in code, approximate)";
  model.kind = MachineKind::robot;
  const double gear = 1.0 / 150.0;
  auto rad = [](double deg) { return deg * kDeg; };
  model.axes = {
      make_axis("q1", AxisType::rotary, rad(-185), rad(185), {rad(105), rad(300), rad(3000)}, gear,
                0.009),
      make_axis("q2", AxisType::rotary, rad(-140), rad(-5 + 140), {rad(101), rad(300), rad(3000)},
                gear, 0.012),
      make_axis("q3", AxisType::rotary, rad(-120), rad(155), {rad(107), rad(300), rad(3000)}, gear,
                0.008),
      make_axis("q4", AxisType::rotary, rad(-350), rad(350), {rad(136), rad(600), rad(6000)}, gear,
                0.004),
      make_axis("q5", AxisType::rotary, rad(-125), rad(125), {rad(129), rad(600), rad(6000)}, gear,
                0.004),
      make_axis("q6", AxisType::rotary, rad(-350), rad(350), {rad(206), rad(600), rad(6000)}, gear,
                0.003),
  };
  // Home: upper arm vertical, forearm horizontal, wrist bent down so that the tool points down.
  model.axes[1].home = rad(10);
  model.axes[2].home = rad(20);
  model.axes[4].home = rad(60);

  const Eigen::Vector3d x = Eigen::Vector3d::UnitX();
  const Eigen::Vector3d y = Eigen::Vector3d::UnitY();
  const Eigen::Vector3d z = Eigen::Vector3d::UnitZ();
  model.tool_chain = {
      moving_joint(model, "q1", JointType::revolute, at(0, 0, 0), z,
                   body(400.0, {0.1, 0.0, 0.4}, {40.0, 45.0, 30.0})),
      moving_joint(model, "q2", JointType::revolute, at(0.35, 0.0, 0.675), y,
                   body(250.0, {0.0, 0.05, 0.575}, {35.0, 35.0, 4.0})),
      moving_joint(model, "q3", JointType::revolute, at(0.0, 0.0, 1.15), y,
                   body(150.0, {0.35, 0.0, 0.041}, {2.5, 12.0, 12.0})),
      moving_joint(model, "q4", JointType::revolute, at(0.6, 0.0, 0.041), x,
                   body(50.0, {0.3, 0.0, 0.0}, {0.4, 1.5, 1.5})),
      moving_joint(model, "q5", JointType::revolute, at(0.6, 0.0, 0.0), y,
                   body(20.0, {0.08, 0.0, 0.0}, {0.1, 0.15, 0.15})),
      moving_joint(model, "q6", JointType::revolute, at(0.215, 0.0, 0.0), x,
                   body(30.0, {0.12, 0.0, 0.01}, {0.2, 0.4, 0.4})),
  };
  // The spindle on the flange: the tool sticks out along the flange's x, so the tool axis
  // (tip -> spindle) is -x of the flange: rotate -90 degrees about y.
  Eigen::Isometry3d spindle = at(0.25, 0.0, 0.0);
  spindle.linear() = Eigen::AngleAxisd(-std::numbers::pi / 2, y).toRotationMatrix();
  model.tool_chain.push_back(fixed_joint("spindle", spindle));
  model.workpiece_chain = {fixed_joint("work_table", at(1.8, 0.0, 0.4))};
  return model;
}

}  // namespace vmsim::kinematics
