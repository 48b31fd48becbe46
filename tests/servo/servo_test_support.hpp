#pragma once
// Helpers of the servo tests: the sample machines, a jerk-limited move written independently.
#include <algorithm>
#include <cmath>
#include <string>

#include "vmsim/kinematics/machine_loader.hpp"
#include "vmsim/servo/servo.hpp"

namespace vmsim::servo::test {

inline kinematics::MachineModel load_sample(const std::string& name) {
  return kinematics::load_machine(std::string(VMSIM_SOURCE_DIR) + "/samples/machines/" + name);
}

/// The bench's X axis, without gravity (horizontal anyway).
inline AxisServoModel bench_model() {
  const kinematics::MachineModel machine = load_sample("ballscrew_bench.yaml");
  return make_axis_servo_model(machine, 0, {0.0}, false);
}

/// The bench without friction and with an ideal encoder: the loops alone, for closed forms.
inline AxisServoModel frictionless_bench_model() {
  AxisServoModel model = bench_model();
  model.axis.drive.friction_dry_A = 0.0;
  model.axis.drive.friction_viscous_A_per_joint_unit_per_s = 0.0;
  model.axis.controller.encoder_counts_per_rev = 0.0;
  return model;
}

/// A symmetric jerk-limited (7-phase) move of `length` [m] at velocity v, acceleration a and
/// jerk j, starting after `rest` seconds, sampled at `period`, followed by 0.3 s of rest.
inline AxisInput jerk_limited_move(double length, double v, double a, double j, double period,
                                   double rest) {
  const double t1 = std::min(a / j, std::sqrt(v / j));
  const double a_peak = j * t1;
  const double t2 = (v - a_peak * t1) / a_peak;
  const double accel_distance = v * (2.0 * t1 + t2) / 2.0;
  const double cruise = (length - 2.0 * accel_distance) / v;
  const double phases[7][2] = {{j, t1}, {0, t2}, {-j, t1}, {0, cruise}, {-j, t1}, {0, t2}, {j, t1}};
  double total = 0.0;
  for (const auto& phase : phases) total += phase[1];
  AxisInput input;
  input.period_s = period;
  const auto n = static_cast<std::size_t>(std::ceil((rest + total + 0.3) / period));
  for (std::size_t k = 0; k <= n; ++k) {
    double t = static_cast<double>(k) * period - rest;
    double x = 0, vel = 0, acc = 0;
    for (const auto& phase : phases) {
      if (t <= 0.0) break;
      const double dt = std::min(t, phase[1]);
      x += vel * dt + acc * dt * dt / 2.0 + phase[0] * dt * dt * dt / 6.0;
      vel += acc * dt + phase[0] * dt * dt / 2.0;
      acc += phase[0] * dt;
      t -= dt;
    }
    input.values.push_back(x + vel * std::max(t, 0.0));
  }
  return input;
}

}  // namespace vmsim::servo::test
