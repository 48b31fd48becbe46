// Each further effect of the drive in a small targeted test, and the `effects` fields of the
// machine file with their located errors.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <numbers>
#include <sstream>

#include "servo_test_support.hpp"
#include "vmsim/common/errors.hpp"

namespace vmsim::servo {
namespace {

using test::bench_model;
using test::jerk_limited_move;
using test::load_sample;

constexpr double kPi = std::numbers::pi;

// A move out and back (reversal in the middle), 20 mm each way.
AxisInput out_and_back() {
  AxisInput out = jerk_limited_move(0.02, 0.05, 2.0, 100.0, 1e-3, 0.05);
  const AxisInput back = jerk_limited_move(0.02, 0.05, 2.0, 100.0, 1e-3, 0.05);
  for (double q : back.values) out.values.push_back(0.02 - q);
  return out;
}

TEST(ServoEffects, BacklashLoadLagsByTheGapAfterAReversal) {
  AxisServoModel model = bench_model();
  model.axis.controller.encoder_counts_per_rev = 0.0;
  model.axis.effects.backlash = {true, 20e-6};
  const AxisInput input = out_and_back();
  const AxisSignals s = simulate_axis(model, input);
  const std::size_t half = input.values.size() / 2;
  // At rest after the outward move (pushing forwards) and after the return (pushing back), the
  // motor-side position minus the load position differs by the gap.
  const double shift_out = s.pos[half - 1] - s.load_pos[half - 1];
  const double shift_back = s.pos.back() - s.load_pos.back();
  EXPECT_NEAR(shift_out - shift_back, 20e-6, 1e-9);
  EXPECT_NEAR(shift_out, 10e-6, 1e-9);
}

TEST(ServoEffects, BacklashWithComplianceKeepsTheGap) {
  AxisServoModel model = bench_model();
  model.axis.controller.encoder_counts_per_rev = 0.0;
  model.axis.effects.backlash = {true, 20e-6};
  model.axis.effects.compliance = {true, 1e8, 0.05, 1.7e-4};
  const AxisSignals s = simulate_axis(model, out_and_back());
  const std::size_t half = s.t.size() / 2;
  const double shift_out = s.pos[half - 1] - s.load_pos[half - 1];
  const double shift_back = s.pos.back() - s.load_pos.back();
  // At rest the stuck load may keep part of the friction in the spring: up to F / k on each
  // side (0.2 A * 0.5 N m/A / r / 1e8 N/m = 0.6 um).
  const double r = model.axis.drive.ratio;
  const double spring_share = 0.2 * 0.5 / r / 1e8;
  EXPECT_NEAR(shift_out - shift_back, 20e-6, 2.0 * spring_share + 1e-9);
  EXPECT_GT(shift_out, 10e-6 - 1e-9);
}

TEST(ServoEffects, CoggingRippleIsPeriodicInMotorAngle) {
  AxisServoModel model = bench_model();
  model.axis.controller.encoder_counts_per_rev = 0.0;
  model.axis.effects.cogging = {true, 0.05, 12.0, 0.0};
  // Slow constant speed: 5 mm/s = 0.5 rev/s, so the ripple is at 6 Hz, well inside the loop.
  AxisInput input;
  input.period_s = 1e-3;
  for (int k = 0; k < 4000; ++k) input.values.push_back(0.005 * std::max(0.0, k * 1e-3 - 0.2));
  const AxisSignals s = simulate_axis(model, input);
  const double r = model.axis.drive.ratio;
  auto amplitude = [&](double harmonic) {  // of the current against the motor angle
    double c = 0, sn = 0;
    std::size_t n = 0;
    for (std::size_t k = 0; k < s.t.size(); ++k) {
      if (s.t[k] < 1.0 || s.t[k] > 3.0) continue;  // 2 s: one motor turn
      const double angle = s.pos[k] / r;
      c += s.current[k] * std::cos(harmonic * angle);
      sn += s.current[k] * std::sin(harmonic * angle);
      ++n;
    }
    return 2.0 * std::hypot(c, sn) / static_cast<double>(n);
  };
  const double at_period = amplitude(12.0);
  std::cout << "cogging: current ripple at 12/rev " << at_period << " A, at 7/rev " << amplitude(7.0)
            << " A, at 17/rev " << amplitude(17.0) << " A\n";
  // The loop answers the cogging torque (0.1 A equivalent) with a current ripple of that order,
  // at the cogging period in motor angle and nowhere else.
  const double cogging_A = 0.05 / model.axis.drive.torque_constant_N_m_per_A;
  EXPECT_GT(at_period, 0.5 * cogging_A);
  EXPECT_LT(at_period, 2.5 * cogging_A);
  EXPECT_LT(amplitude(7.0), 0.05 * at_period);
  EXPECT_LT(amplitude(17.0), 0.05 * at_period);
  // Without cogging there is no ripple at that period.
  model.axis.effects.cogging.enabled = false;
  const AxisSignals smooth = simulate_axis(model, input);
  double c = 0, sn = 0;
  for (std::size_t k = 1000; k <= 3000; ++k) {
    c += smooth.current[k] * std::cos(12.0 * smooth.pos[k] / r);
    sn += smooth.current[k] * std::sin(12.0 * smooth.pos[k] / r);
  }
  EXPECT_LT(2.0 * std::hypot(c, sn) / 2001.0, 0.05 * at_period);
}

TEST(ServoEffects, PitchErrorIsPeriodicInPosition) {
  AxisServoModel model = bench_model();
  model.axis.controller.encoder_counts_per_rev = 0.0;
  model.axis.effects.pitch_error = {true, 3e-6, 0.01, 0.3};
  const AxisSignals s = simulate_axis(model, jerk_limited_move(0.05, 0.05, 2.0, 100.0, 1e-3, 0.05));
  for (std::size_t k = 0; k < s.t.size(); k += 7) {
    const double expected = 3e-6 * std::sin(2.0 * kPi * s.pos[k] / 0.01 + 0.3);
    ASSERT_NEAR(s.load_pos[k] - s.pos[k], expected, 1e-12) << "t = " << s.t[k];
  }
  // With the loop closed on a load-side scale the table goes where it is told instead (a PI
  // velocity loop, so that friction leaves no standstill error).
  model.axis.controller.position_feedback = kinematics::PositionFeedback::load;
  model.axis.controller.velocity_type = kinematics::VelocityControllerType::PI;
  model.axis.controller.velocity_integral_time_s = 0.02;
  model.axis.drive.friction_dry_A = 0.0;  // no stick short of the target
  AxisInput settled = jerk_limited_move(0.05, 0.05, 2.0, 100.0, 1e-3, 0.05);
  settled.extra_time_s = 1.0;  // 25 time constants of the position loop (Kv = 25 1/s)
  const AxisSignals direct = simulate_axis(model, settled);
  EXPECT_NEAR(direct.load_pos.back(), 0.05, 1e-8);
}

TEST(ServoEffects, ComplianceRingsAtTheTwoMassFrequency) {
  AxisServoModel model = bench_model();
  auto& c = model.axis.controller;
  c.encoder_counts_per_rev = 0.0;
  c.velocity_gain_N_m_s_per_rad = 1e-4;  // nearly open loop: the motor is almost free
  model.axis.drive.friction_dry_A = 0.0;
  model.axis.drive.friction_viscous_A_per_joint_unit_per_s = 0.0;
  const double k = 2e7, jm = 1.7e-4, j = model.axis.drive.equivalent_inertia_kg_m2;
  model.axis.effects.compliance = {true, k, 0.0, jm};
  AxisInput input;
  input.kind = AxisInput::Kind::velocity;
  input.period_s = c.velocity_period_s;
  input.values.assign(400, 0.05);
  input.values[0] = 0.0;
  SimulationOptions options;
  options.plant_substeps = 20;
  options.record_period_s = c.velocity_period_s;
  const AxisSignals s = simulate_axis(model, input, options);
  // Deflection motor - load: count the upward zero crossings of its oscillation about the mean.
  std::vector<double> deflection;
  for (std::size_t i = 0; i < s.t.size(); ++i) deflection.push_back(s.pos[i] - s.load_pos[i]);
  double mean = 0;
  for (double value : deflection) mean += value;
  mean /= static_cast<double>(deflection.size());
  std::vector<double> crossings;
  for (std::size_t i = 1; i < deflection.size(); ++i) {
    const double a = deflection[i - 1] - mean, b = deflection[i] - mean;
    if (a < 0 && b >= 0) crossings.push_back(s.t[i - 1] + (s.t[i] - s.t[i - 1]) * a / (a - b));
  }
  ASSERT_GE(crossings.size(), 5u);
  const double measured = static_cast<double>(crossings.size() - 1) / (crossings.back() - crossings.front());
  const double r = model.axis.drive.ratio;
  const double expected = std::sqrt(k * r * r * (1.0 / jm + 1.0 / (j - jm))) / (2.0 * kPi);
  std::cout << "compliance: ringing at " << measured << " Hz, two-mass frequency " << expected << " Hz\n";
  EXPECT_NEAR(measured, expected, 0.02 * expected);
}

TEST(ServoEffects, AsymmetricFrictionGivesDirectionDependentCurrent) {
  AxisServoModel model = bench_model();
  auto& c = model.axis.controller;
  c.velocity_type = kinematics::VelocityControllerType::PI;
  c.velocity_integral_time_s = 0.02;
  model.axis.effects.asymmetric_friction = {true, 0.3, 0.1, 2.0, 4.0};
  for (double v : {0.04, -0.04}) {
    AxisInput input;
    input.period_s = 1e-3;
    for (int k = 0; k < 1500; ++k) input.values.push_back(v * std::max(0.0, k * 1e-3 - 0.1));
    const AxisSignals s = simulate_axis(model, input);
    double mean = 0;
    int n = 0;
    for (std::size_t k = 1000; k < s.t.size(); ++k, ++n) mean += s.current[k];
    mean /= n;
    const double expected = v > 0 ? 0.3 + 2.0 * v : -0.1 + 4.0 * v;
    EXPECT_NEAR(mean, expected, 0.01) << "v = " << v;
  }
}

TEST(ServoEffects, StribeckRaisesTheBreakawayCurrent) {
  AxisServoModel model = bench_model();
  auto& c = model.axis.controller;
  c.velocity_type = kinematics::VelocityControllerType::PI;
  c.velocity_integral_time_s = 0.02;
  c.encoder_counts_per_rev = 0.0;
  model.axis.effects.stribeck = {true, 0.8, 1e-3, 2.0};
  AxisInput input;
  input.period_s = 1e-3;
  for (int k = 0; k < 1500; ++k) input.values.push_back(0.02 * std::max(0.0, k * 1e-3 - 0.1));
  const AxisSignals s = simulate_axis(model, input);
  double peak = 0;
  for (double i : s.current) peak = std::max(peak, i);
  // Before it moves the motor must push through the static level; at 20 mm/s the friction
  // is back to b + a v.
  EXPECT_GT(peak, 0.8);
  EXPECT_NEAR(s.current.back(), 0.2 + 2.0 * 0.02, 0.01);
}

TEST(ServoEffects, EncoderQuantisationRoundsThePosition) {
  AxisServoModel model = bench_model();  // 4000 counts per motor turn: 2.5 um at the table
  const AxisSignals s = simulate_axis(model, jerk_limited_move(0.01, 0.05, 2.0, 100.0, 1e-3, 0.05));
  const double count = 0.01 / 4000.0;
  for (double q : s.pos) ASSERT_NEAR(q / count, std::round(q / count), 1e-6);
}

TEST(ServoEffects, StandstillWithDryFrictionDoesNotChatter) {
  AxisServoModel model = bench_model();
  model.axis.controller.encoder_counts_per_rev = 0.0;
  AxisInput input;
  input.period_s = 1e-3;
  input.values.assign(500, 0.0);
  const AxisSignals s = simulate_axis(model, input);
  for (std::size_t k = 0; k < s.t.size(); ++k) {
    ASSERT_EQ(s.vel[k], 0.0);
    ASSERT_EQ(s.pos[k], 0.0);
  }
}

// --- the machine file ------------------------------------------------------------------------

std::string bench_with(const std::string& insert_after_controller_block) {
  std::ifstream in(std::string(VMSIM_SOURCE_DIR) + "/samples/machines/ballscrew_bench.yaml");
  std::stringstream text;
  text << in.rdbuf();
  std::string yaml = text.str();
  const std::string anchor = "      encoder_counts_per_rev: 4000\n";
  yaml.insert(yaml.find(anchor) + anchor.size(), insert_after_controller_block);
  return yaml;
}

TEST(ServoEffects, MachineFileEffectsAreRead) {
  const kinematics::MachineModel machine = kinematics::parse_machine(
      bench_with("    effects:\n"
                 "      stribeck: {static_friction_A: 0.5, velocity_mm_per_s: 2}\n"
                 "      asymmetric_friction: {dry_positive_A: 0.3}\n"
                 "      backlash: {gap_um: 8}\n"
                 "      cogging: {amplitude_N_m: 0.02, periods_per_rev: 36, phase_deg: 90}\n"
                 "      pitch_error: {amplitude_um: 2}\n"
                 "      compliance: {stiffness_N_per_um: 150, damping_ratio: 0.03}\n"
                 "      gravity_compensated: true\n"),
      "bench.yaml", std::string(VMSIM_SOURCE_DIR) + "/samples/machines/");
  const kinematics::DriveEffects& fx = machine.axes[0].effects;
  EXPECT_DOUBLE_EQ(fx.stribeck.velocity, 2e-3);
  EXPECT_DOUBLE_EQ(fx.stribeck.exponent, 2.0);
  EXPECT_DOUBLE_EQ(fx.asymmetric_friction.dry_positive_A, 0.3);
  EXPECT_DOUBLE_EQ(fx.asymmetric_friction.dry_negative_A, 0.2);  // the drive's b
  EXPECT_DOUBLE_EQ(fx.backlash.gap, 8e-6);
  EXPECT_NEAR(fx.cogging.phase_rad, kPi / 2.0, 1e-15);
  EXPECT_NEAR(fx.pitch_error.period, 0.01, 1e-15);  // default: the lead
  EXPECT_DOUBLE_EQ(fx.compliance.stiffness, 1.5e8);
  EXPECT_DOUBLE_EQ(fx.compliance.motor_side_inertia_kg_m2, 1.7e-4);  // the rotor's
  EXPECT_TRUE(fx.gravity_compensated);
}

TEST(ServoEffects, BadEffectsAreLocatedErrors) {
  const std::string dir = std::string(VMSIM_SOURCE_DIR) + "/samples/machines/";
  const std::pair<std::string, std::string> cases[] = {
      {"    effects:\n      backlash: {gap_um: -1}\n", "gap"},
      {"    effects:\n      backlash: {gap_deg: 1}\n", "gap_<unit>"},
      {"    effects:\n      cogging: {amplitude_N_m: 0.1}\n", "periods_per_rev"},
      {"    effects:\n      stribeck: {static_friction_A: 0.1, velocity_mm_per_s: 1}\n",
       "below the dry friction"},
      {"    effects:\n      compliance: {stiffness_N_per_um: 100, motor_side_inertia_kg_m2: 1}\n",
       "motor-side inertia"},
      {"    effects:\n      backlash_gap_um: 3\n", "unknown field 'backlash_gap_um'"},
  };
  for (const auto& [text, needle] : cases) {
    try {
      kinematics::parse_machine(bench_with(text), "bench.yaml", dir);
      ADD_FAILURE() << "no error for " << text;
    } catch (const InputError& error) {
      const std::string message = error.what();
      EXPECT_NE(message.find("bench.yaml:"), std::string::npos) << message;
      EXPECT_NE(message.find("axis X"), std::string::npos) << message;
      EXPECT_NE(message.find(needle), std::string::npos) << message;
    }
  }
}

}  // namespace
}  // namespace vmsim::servo
