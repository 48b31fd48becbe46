// The servo model of one axis: checks of the loop periods, gravity from the rigid-body model.
#include <cmath>
#include <numbers>

#include "vmsim/common/errors.hpp"
#include "vmsim/kinematics/dynamics.hpp"
#include "vmsim/servo/servo.hpp"

namespace vmsim::servo {
namespace {

using kinematics::Axis;
using kinematics::Controller;
using kinematics::CurrentLoopModel;

std::string number_text(double value) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.10g", value);
  return buffer;
}

[[noreturn]] void fail(const kinematics::MachineModel& machine, const Axis& axis,
                       const std::string& field, const std::string& message) {
  throw InputError(located_message(machine.source_file, 0, 0,
                                   "axes." + axis.name + "." + field + " (axis " + axis.name +
                                       "): " + message));
}

// A period must be a whole multiple (>= 1) of the base period.
void check_multiple(const kinematics::MachineModel& machine, const Axis& axis,
                    const std::string& field, double period_s, double base_s) {
  const double ratio = period_s / base_s;
  if (ratio < 1.0 - 1e-9 || std::abs(ratio - std::round(ratio)) > 1e-6 * ratio) {
    fail(machine, axis, field,
         number_text(period_s * 1e6) + " us is not a whole multiple of the fastest loop period " +
             number_text(base_s * 1e6) + " us");
  }
}

}  // namespace

double base_period_s(const Controller& controller) {
  if (controller.current_model == CurrentLoopModel::PI) {
    return std::min(controller.current_period_s, controller.velocity_period_s);
  }
  return controller.velocity_period_s;
}

AxisServoModel make_axis_servo_model(const kinematics::MachineModel& machine, int axis_index,
                                     const std::vector<double>& reference, bool gravity) {
  if (axis_index < 0 || axis_index >= static_cast<int>(machine.axes.size())) {
    throw InputError(located_message(machine.source_file, 0, 0,
                                     "no axis with index " + std::to_string(axis_index)));
  }
  AxisServoModel model;
  model.axis = machine.axes[static_cast<std::size_t>(axis_index)];
  const Axis& axis = model.axis;
  const Controller& c = axis.controller;
  const double base = base_period_s(c);
  if (!(base > 0.0)) fail(machine, axis, "controller.velocity.period", "must be > 0");
  check_multiple(machine, axis, "controller.position.period", c.position_period_s, base);
  check_multiple(machine, axis, "controller.velocity.period", c.velocity_period_s, base);
  if (c.current_model == CurrentLoopModel::PI) {
    check_multiple(machine, axis, "controller.current.period", c.current_period_s, base);
  }
  if (!(axis.drive.ratio > 0.0)) fail(machine, axis, "drive", "ratio must be > 0");
  if (!(axis.drive.equivalent_inertia_kg_m2 > 0.0)) {
    fail(machine, axis, "drive.equivalent_inertia_kg_m2", "must be > 0");
  }
  const double rotor = axis.drive.rotor_inertia_kg_m2;
  if (axis.effects.backlash.enabled && !axis.effects.compliance.enabled &&
      !(rotor > 0.0 && rotor < axis.drive.equivalent_inertia_kg_m2)) {
    fail(machine, axis, "drive.rotor_inertia_kg_m2",
         number_text(rotor) + " kg m^2: effects.backlash needs the motor side that moves alone "
         "inside the gap, in (0, equivalent_inertia_kg_m2 = " +
             number_text(axis.drive.equivalent_inertia_kg_m2) + ")");
  }

  if (gravity && !axis.effects.gravity_compensated && !machine.axes.empty()) {
    if (reference.size() != machine.axes.size()) {
      throw InputError(located_message(machine.source_file, 0, 0,
                                       "gravity reference has " + std::to_string(reference.size()) +
                                           " values for " + std::to_string(machine.axes.size()) +
                                           " axes"));
    }
    const kinematics::DynamicsModel dynamics(machine);
    kinematics::DynamicsData data(dynamics);
    const Eigen::Index n = static_cast<Eigen::Index>(machine.axes.size());
    Eigen::VectorXd q = Eigen::Map<const Eigen::VectorXd>(reference.data(), n);
    const Eigen::VectorXd zero = Eigen::VectorXd::Zero(n);
    auto gravity_at = [&](double qi) {
      q(axis_index) = qi;
      kinematics::rigid_body_dynamics(dynamics, data, q, zero, zero, zero, true);
      return axis.drive.ratio * data.Q(axis_index);  // at the motor
    };
    if (axis.type == kinematics::AxisType::linear) {
      model.gravity_constant_N_m = gravity_at(reference[static_cast<std::size_t>(axis_index)]);
    } else {
      // G(q) = g0 + gc cos q + gs sin q, exactly, for the other axes fixed.
      const double g0 = gravity_at(0.0);
      const double g1 = gravity_at(std::numbers::pi / 2.0);
      const double g2 = gravity_at(std::numbers::pi);
      model.gravity_constant_N_m = 0.5 * (g0 + g2);
      model.gravity_cos_N_m = 0.5 * (g0 - g2);
      model.gravity_sin_N_m = g1 - model.gravity_constant_N_m;
    }
  }
  return model;
}

}  // namespace vmsim::servo
