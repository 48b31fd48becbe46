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

// Rigid backlash against an exact, event-driven solution written here. Motor side m_m and load
// m_L (J_m / r^2 and (J_eq - J_m) / r^2 at the table), no friction, a gap 2h, a force F_k on the
// motor held over [t_k, t_k + T). Apart, the motor accelerates alone and the load coasts; at
// the flank an inelastic impact gives both the speed (m_m v_m + m_L v_L) / (m_m + m_L); in
// contact both accelerate at F / (m_m + m_L) until the force pulls the motor away.
struct PlayReference {
  double m_motor, m_load, half_gap, period;
  struct Sample {
    double motor, load, motor_velocity;
  };
  std::vector<Sample> run(const std::vector<double>& force) const {
    double xm = 0, vm = 0, xl = 0, vl = 0;
    int side = 0;
    std::vector<Sample> out;
    for (double f : force) {
      out.push_back({xm, xl, vm});
      double left = period;
      while (left > 0.0) {
        if (side != 0 && side * f >= 0.0) {  // pushing: one body
          const double acc = f / (m_motor + m_load);
          xm += vm * left + 0.5 * acc * left * left;
          vm += acc * left;
          xl = xm - side * half_gap;
          vl = vm;
          break;
        }
        side = 0;
        // Apart: the relative position d(s) = d0 + dv s + acc s^2 / 2 meets +-h after s?
        const double acc = f / m_motor, d0 = xm - xl, dv = vm - vl;
        double hit = left;
        int hit_side = 0;
        for (int flank : {1, -1}) {
          const double c = d0 - flank * half_gap;  // acc/2 s^2 + dv s + c = 0
          double roots[2] = {-1.0, -1.0};
          if (std::abs(acc) < 1e-300) {
            if (dv != 0.0) roots[0] = -c / dv;
          } else {
            const double disc = dv * dv - 2.0 * acc * c;
            if (disc >= 0.0) {
              roots[0] = (-dv - std::sqrt(disc)) / acc;
              roots[1] = (-dv + std::sqrt(disc)) / acc;
            }
          }
          for (double root : roots) {
            // Reaching the flank moving outwards (not leaving the one it starts on).
            if (root > 0.0 && root < hit && flank * (dv + acc * root) > 0.0) {
              hit = root;
              hit_side = flank;
            }
          }
        }
        xm += vm * hit + 0.5 * acc * hit * hit;
        vm += acc * hit;
        xl += vl * hit;
        left -= hit;
        if (hit_side != 0) {
          side = hit_side;
          vm = vl = (m_motor * vm + m_load * vl) / (m_motor + m_load);
          xl = xm - side * half_gap;
        }
      }
    }
    return out;
  }
};

TEST(ServoEffects, RigidBacklashMatchesTheExactTwoBodySolution) {
  // The bench with the torque set by the torque feedforward alone (Kp = 0, ideal current, no
  // computation delays, all loops at the set-point period): over [t_k, t_k + T) the motor gets
  // J_eq q''_k / r, q''_k the central second difference of the set points at sample k.
  AxisServoModel model = test::frictionless_bench_model();
  const auto& d = model.axis.drive;
  auto& c = model.axis.controller;
  c.velocity_type = kinematics::VelocityControllerType::P;
  c.velocity_gain_N_m_s_per_rad = 0.0;
  c.position_output_delay_samples = 0;
  c.velocity_output_delay_samples = 0;
  c.torque_feedforward = true;
  c.current_max_A = 0.0;
  const double gap = 20e-6;
  model.axis.effects.backlash = {true, gap};
  // Rest, 30 ms at +1 m/s^2, then -1 m/s^2: the motor crosses half the gap to the front flank,
  // pushes, leaves the load when the acceleration reverses and crosses the whole gap back.
  const double T = 1e-3, a = 1.0;
  AxisInput input;
  input.period_s = T;
  double x = 0, v = 0;
  for (int k = 0; k < 120; ++k) {
    input.values.push_back(x);
    const double acc = k < 10 ? 0.0 : k < 40 ? a : -a;
    x += v * T + 0.5 * acc * T * T;
    v += acc * T;
  }
  const double r = d.ratio, j = d.equivalent_inertia_kg_m2, jm = d.rotor_inertia_kg_m2;
  std::vector<double> force;  // on the motor, at the table [N]
  const std::vector<double>& q = input.values;
  for (std::size_t k = 0; k < q.size(); ++k) {
    const double before = q[k == 0 ? 0 : k - 1], after = q[k + 1 < q.size() ? k + 1 : k];
    force.push_back(j / (r * r) * (after - 2.0 * q[k] + before) / (T * T));
  }
  const PlayReference reference{jm / (r * r), (j - jm) / (r * r), 0.5 * gap, T};
  const auto expected = reference.run(force);
  SimulationOptions options;
  options.plant_substeps = 100;
  const AxisSignals s = simulate_axis(model, input, options);
  ASSERT_EQ(s.t.size(), expected.size());
  double worst_motor = 0, worst_load = 0, worst_velocity = 0;
  for (std::size_t k = 0; k < expected.size(); ++k) {
    worst_motor = std::max(worst_motor, std::abs(s.pos[k] - expected[k].motor));
    worst_load = std::max(worst_load, std::abs(s.load_pos[k] - expected[k].load));
    worst_velocity = std::max(worst_velocity, std::abs(s.vel[k] - expected[k].motor_velocity));
  }
  std::cout << "rigid backlash vs exact two-body solution: motor " << worst_motor * 1e9
            << " nm, load " << worst_load * 1e9 << " nm, motor speed " << worst_velocity * 1e6
            << " um/s\n";
  // The impact speeds are exact; the contact time is found within a plant sub-step (10 us)
  // and interpolated linearly in it (0.04 nm here).
  EXPECT_LT(worst_motor, 0.5e-9);
  EXPECT_LT(worst_load, 0.5e-9);
  EXPECT_LT(worst_velocity, 1e-9);
  // The events happened: the load waits while the motor crosses half the gap, the motor runs
  // ahead by the half gap while pushing, then lags by it after crossing back.
  EXPECT_EQ(s.load_pos[12], 0.0);
  EXPECT_NEAR(s.pos[35] - s.load_pos[35], 0.5 * gap, 1e-12);
  EXPECT_NEAR(s.pos[110] - s.load_pos[110], -0.5 * gap, 1e-12);

  // With compliance the gap is in the spring: a stiff, well-damped spring (a nearly inelastic
  // contact) tends to the rigid result, within the order of the spring's deflection F / k under
  // the whole force F = m a (87 N).
  for (double k : {1e9, 1e10}) {
    model.axis.effects.compliance = {true, k, 0.9, jm};
    const AxisSignals stiff = simulate_axis(model, input, options);
    double worst_stiff = 0;
    for (std::size_t i = 0; i < expected.size(); ++i) {
      worst_stiff = std::max(worst_stiff, std::abs(stiff.load_pos[i] - expected[i].load));
    }
    const double deflection = j / (r * r) * a / k;
    std::cout << "two-mass with backlash, k = " << k << " N/m, vs the exact rigid solution: load "
              << worst_stiff * 1e9 << " nm (F / k = " << deflection * 1e9 << " nm)\n";
    EXPECT_LT(worst_stiff, 2.0 * deflection);
  }
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
