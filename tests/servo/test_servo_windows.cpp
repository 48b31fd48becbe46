// The servo in windows: the set points split into windows of any size (one sample, odd sizes,
// a few seconds) give, bit for bit, the records of one whole run (issue 21: the chain streamed
// along the program). The whole run is simulate_axis; the windowed ones are AxisSimulator and
// MachineSimulator fed piece by piece. Every effect the sample machines use is switched on in
// turn on the bench's axis, and every axis of every sample machine runs as loaded.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <span>
#include <functional>
#include <string>
#include <vector>

#include "servo_test_support.hpp"
#include "vmsim/common/errors.hpp"

namespace vmsim::servo::test {
namespace {

// Equal bit for bit (NaN never appears; -0.0 against 0.0 would be a difference too).
void expect_identical(const std::vector<double>& whole, const std::vector<double>& windowed,
                      const std::string& what) {
  ASSERT_EQ(whole.size(), windowed.size()) << what;
  for (std::size_t k = 0; k < whole.size(); ++k) {
    if (std::memcmp(&whole[k], &windowed[k], sizeof(double)) != 0) {
      ADD_FAILURE() << what << ": record " << k << " differs: " << whole[k] << " whole, " << windowed[k]
                    << " windowed";
      return;
    }
  }
}

void expect_identical(const AxisSignals& whole, const AxisSignals& windowed, const std::string& what) {
  expect_identical(whole.t, windowed.t, what + " t");
  expect_identical(whole.cmd, windowed.cmd, what + " cmd");
  expect_identical(whole.pos, windowed.pos, what + " pos");
  expect_identical(whole.load_pos, windowed.load_pos, what + " load_pos");
  expect_identical(whole.motor_pos, windowed.motor_pos, what + " motor_pos");
  expect_identical(whole.vel, windowed.vel, what + " vel");
  expect_identical(whole.current, windowed.current, what + " current");
  expect_identical(whole.following_error, windowed.following_error, what + " following_error");
  expect_identical(whole.control_deviation, windowed.control_deviation, what + " control_deviation");
  expect_identical(whole.velocity_setpoint, windowed.velocity_setpoint, what + " velocity_setpoint");
  expect_identical(whole.velocity_feedforward, windowed.velocity_feedforward, what + " velocity_feedforward");
  expect_identical(whole.torque_feedforward, windowed.torque_feedforward, what + " torque_feedforward");
  expect_identical(whole.current_setpoint, windowed.current_setpoint, what + " current_setpoint");
}

// The input in windows of `window` samples through AxisSimulator.
AxisSignals windowed_run(const AxisServoModel& model, const AxisInput& input, const SimulationOptions& options,
                         std::size_t window) {
  AxisSimulator simulator(model, input.start_time_s, input.period_s, input.kind, options);
  AxisSignals out;
  for (std::size_t first = 0; first < input.values.size(); first += window) {
    const std::size_t n = std::min(window, input.values.size() - first);
    const std::span<const double> values(input.values.data() + first, n);
    std::span<const double> force;
    if (!input.external_force.empty()) force = std::span<const double>(input.external_force.data() + first, n);
    simulator.advance(values, out, force);
  }
  simulator.finish(out, input.extra_time_s);
  return out;
}

// Window sizes: one sample, small odd ones, a prime, about half the run, more than the run.
std::vector<std::size_t> window_sizes(std::size_t samples) {
  return {1, 2, 3, 7, 101, samples / 2 + 1, samples + 5};
}

void check_windows(const AxisServoModel& model, const AxisInput& input, const SimulationOptions& options,
                   const std::string& what) {
  const AxisSignals whole = simulate_axis(model, input, options);
  ASSERT_GT(whole.t.size(), 100u) << what;
  for (std::size_t window : window_sizes(input.values.size())) {
    SCOPED_TRACE(what + ", window " + std::to_string(window));
    expect_identical(whole, windowed_run(model, input, options, window), what);
  }
}

// A move there and back (reversals for the backlash and the friction), 0.1 s rest at each end.
AxisInput there_and_back(double length, double period) {
  AxisInput input = jerk_limited_move(length, 0.05, 1.0, 40.0, period, 0.02);
  const std::size_t n = input.values.size();
  for (std::size_t k = 0; k < n; ++k) input.values.push_back(input.values[n - 1 - k]);
  return input;
}

struct Variant {
  std::string name;
  std::function<void(AxisServoModel&, SimulationOptions&, AxisInput&)> apply;
};

std::vector<Variant> bench_variants() {
  using kinematics::BalancingType;
  using kinematics::CurrentLoopModel;
  using kinematics::FeedforwardTiming;
  return {
      {"as loaded", [](AxisServoModel&, SimulationOptions&, AxisInput&) {}},
      {"stribeck + asymmetric friction", [](AxisServoModel& m, SimulationOptions&, AxisInput&) {
         auto& fx = m.axis.effects;
         fx.stribeck.enabled = true;
         fx.stribeck.static_friction_A = 1.5 * m.axis.drive.friction_dry_A + 0.05;
         fx.stribeck.velocity = 0.002;
         fx.asymmetric_friction.enabled = true;
         fx.asymmetric_friction.dry_positive_A = m.axis.drive.friction_dry_A + 0.02;
         fx.asymmetric_friction.dry_negative_A = 0.8 * m.axis.drive.friction_dry_A;
         fx.asymmetric_friction.viscous_positive_A_per_joint_unit_per_s = 2.0;
         fx.asymmetric_friction.viscous_negative_A_per_joint_unit_per_s = 3.0;
       }},
      {"smooth friction", [](AxisServoModel& m, SimulationOptions&, AxisInput&) {
         m.axis.effects.smooth_friction.enabled = true;
         m.axis.effects.smooth_friction.speed = 0.001;
       }},
      {"rigid backlash", [](AxisServoModel& m, SimulationOptions&, AxisInput&) {
         m.axis.effects.backlash.enabled = true;
         m.axis.effects.backlash.gap = 5e-6;
         if (!(m.axis.drive.rotor_inertia_kg_m2 > 0.0)) m.axis.drive.rotor_inertia_kg_m2 = 0.3 * m.axis.drive.equivalent_inertia_kg_m2;
       }},
      {"compliance + backlash + gravity compensation", [](AxisServoModel& m, SimulationOptions&, AxisInput&) {
         auto& c = m.axis.effects.compliance;
         c.enabled = true;
         c.stiffness = 2e8;
         c.damping_ratio = 0.05;
         c.motor_side_inertia_kg_m2 = 0.4 * m.axis.drive.equivalent_inertia_kg_m2;
         c.compensate_gravity_deflection = true;
         m.gravity_constant_N_m = 0.3;  // a load the spring deflects under
         m.axis.effects.backlash.enabled = true;
         m.axis.effects.backlash.gap = 3e-6;
       }},
      {"cogging + pitch error + load encoder", [](AxisServoModel& m, SimulationOptions&, AxisInput&) {
         m.axis.effects.cogging.enabled = true;
         m.axis.effects.cogging.amplitude_N_m = 0.02;
         m.axis.effects.cogging.periods_per_rev = 6.0;
         m.axis.effects.pitch_error.enabled = true;
         m.axis.effects.pitch_error.amplitude = 2e-6;
         m.axis.effects.pitch_error.period = 0.01;
         m.axis.controller.position_feedback = kinematics::PositionFeedback::load;
         m.axis.controller.load_encoder_resolution = 1e-7;
       }},
      {"delays, dead time, PI current loop", [](AxisServoModel& m, SimulationOptions&, AxisInput&) {
         auto& c = m.axis.controller;
         c.delay_s = 0.0035;
         c.position_output_dead_time_s = 0.0015;
         c.velocity_output_delay_samples = 2;
         c.current_model = CurrentLoopModel::PI;
         c.current_period_s = c.velocity_period_s / 4;
         c.resistance_ohm = 1.2;
         c.inductance_H = 0.004;
         c.current_gain_V_per_A = 15.0;
         c.current_integral_time_s = 0.002;
         c.current_output_delay_samples = 2;
         c.voltage_max_V = 300.0;
       }},
      {"feedforward interpolated, cubic, dead-time balancing", [](AxisServoModel& m, SimulationOptions&, AxisInput&) {
         auto& c = m.axis.controller;
         c.velocity_feedforward = true;
         c.torque_feedforward = true;
         c.feedforward_timing = FeedforwardTiming::interpolated;
         c.fine_interpolation = kinematics::FineInterpolation::cubic;
         c.balancing_type = BalancingType::dead_time;
         c.balancing_time_s = 0.0027;
         c.position_output_delay_samples = 2;
       }},
      {"feedforward held, first-order balancing", [](AxisServoModel& m, SimulationOptions& o, AxisInput&) {
         auto& c = m.axis.controller;
         c.velocity_feedforward = true;
         c.torque_feedforward = true;
         o.interpolate_feedforward = false;
         c.balancing_type = BalancingType::first_order_lag;
         c.balancing_time_s = 0.0015;
       }},
      {"feedforward held backward", [](AxisServoModel& m, SimulationOptions&, AxisInput&) {
         auto& c = m.axis.controller;
         c.velocity_feedforward = true;
         c.torque_feedforward = true;
         c.feedforward_timing = FeedforwardTiming::held_backward;
       }},
      {"external force, extra time, start time", [](AxisServoModel&, SimulationOptions&, AxisInput& in) {
         in.start_time_s = 1.25;
         in.extra_time_s = 0.0137;
         in.external_force.resize(in.values.size());
         for (std::size_t k = 0; k < in.values.size(); ++k) in.external_force[k] = 20.0 * std::sin(0.05 * static_cast<double>(k));
       }},
      {"velocity input", [](AxisServoModel&, SimulationOptions&, AxisInput& in) {
         in.kind = AxisInput::Kind::velocity;
         for (double& v : in.values) v *= 10.0;
       }},
  };
}

TEST(ServoWindows, EveryEffectOnTheBenchIsBitIdenticalInAnyWindows) {
  for (const Variant& variant : bench_variants()) {
    AxisServoModel model = bench_model();
    SimulationOptions options;
    options.inner_signals = true;
    AxisInput input = there_and_back(0.01, 0.001);
    variant.apply(model, options, input);
    check_windows(model, input, options, variant.name);
    // A record period longer than the set points' (as simulate-part records).
    options.record_period_s = 3 * base_period_s(model.axis.controller);
    check_windows(model, input, options, variant.name + ", record period 3 ticks");
  }
}

TEST(ServoWindows, EveryAxisOfEverySampleMachineIsBitIdenticalInAnyWindows) {
  for (const char* file : {"mikron_ucp710.yaml", "kr180_class.yaml", "ballscrew_bench.yaml"}) {
    const kinematics::MachineModel machine = load_sample(file);
    std::vector<double> reference;
    for (const auto& axis : machine.axes) reference.push_back(axis.home);
    for (std::size_t j = 0; j < machine.axes.size(); ++j) {
      const AxisServoModel model = make_axis_servo_model(machine, static_cast<int>(j), reference, true);
      AxisInput input = there_and_back(machine.axes[j].type == kinematics::AxisType::linear ? 0.01 : 0.05,
                                       machine.interpolation_period_s);
      for (double& q : input.values) q += machine.axes[j].home;
      SimulationOptions options;
      options.inner_signals = true;
      check_windows(model, input, options, std::string(file) + " axis " + machine.axes[j].name);
    }
  }
}

// MachineSimulator: the axes advanced together release the same records as each axis alone,
// whatever the windows, every axis the same samples in each release.
TEST(ServoWindows, MachineSimulatorReleasesTheWholeRunsRecordsAlignedAcrossAxes) {
  const kinematics::MachineModel machine = load_sample("mikron_ucp710.yaml");
  std::vector<double> reference;
  for (const auto& axis : machine.axes) reference.push_back(axis.home);
  std::vector<int> axes;
  std::vector<AxisInput> inputs;
  for (std::size_t j = 0; j < machine.axes.size(); ++j) {
    axes.push_back(static_cast<int>(j));
    AxisInput input = there_and_back(0.004 * static_cast<double>(j + 1), machine.interpolation_period_s);
    for (double& q : input.values) q += machine.axes[j].home;
    inputs.push_back(input);
  }
  // One grid for all: the shorter moves rest at their end.
  std::size_t longest = 0;
  for (const AxisInput& input : inputs) longest = std::max(longest, input.values.size());
  for (AxisInput& input : inputs) input.values.resize(longest, input.values.back());
  SimulationOptions options;
  options.record_period_s = 2 * base_period_s(machine.axes[0].controller);
  std::vector<AxisSignals> whole;
  for (std::size_t a = 0; a < axes.size(); ++a) {
    whole.push_back(simulate_axis(make_axis_servo_model(machine, axes[a], reference, true), inputs[a], options));
  }
  const std::size_t samples = inputs[0].values.size();
  for (std::size_t window : window_sizes(samples)) {
    SCOPED_TRACE("window " + std::to_string(window));
    MachineSimulator simulator(machine, axes, reference, 0.0, machine.interpolation_period_s, options);
    std::vector<AxisSignals> collected(axes.size());
    const auto take = [&](std::vector<AxisSignals> released) {
      ASSERT_EQ(released.size(), axes.size());
      for (std::size_t a = 0; a < axes.size(); ++a) ASSERT_EQ(released[a].t.size(), released[0].t.size()) << "axis " << a;
      for (std::size_t a = 0; a < axes.size(); ++a) move_records(released[a], released[a].t.size(), collected[a]);
    };
    for (std::size_t first = 0; first < samples; first += window) {
      const std::size_t n = std::min(window, samples - first);
      Eigen::MatrixXd q(static_cast<Eigen::Index>(axes.size()), static_cast<Eigen::Index>(n));
      for (std::size_t a = 0; a < axes.size(); ++a) {
        for (std::size_t k = 0; k < n; ++k) q(static_cast<Eigen::Index>(a), static_cast<Eigen::Index>(k)) = inputs[a].values[first + k];
      }
      take(simulator.advance(q));
    }
    take(simulator.finish());
    for (std::size_t a = 0; a < axes.size(); ++a) expect_identical(whole[a], collected[a], "axis " + std::to_string(a));
  }
}

TEST(ServoWindows, WindowedInputErrors) {
  const AxisServoModel model = bench_model();
  EXPECT_THROW(AxisSimulator(model, 0.0, 0.0), InputError);
  AxisSimulator simulator(model, 0.0, 0.001);
  AxisSignals out;
  const std::vector<double> one{0.0};
  simulator.advance(one, out);
  EXPECT_THROW(simulator.finish(out), InputError);  // a single set point
  AxisSimulator forced(model, 0.0, 0.001);
  const std::vector<double> values{0.0, 0.0, 0.0}, force{1.0, 2.0};
  EXPECT_THROW(forced.advance(values, out, force), InputError);
}

}  // namespace
}  // namespace vmsim::servo::test
