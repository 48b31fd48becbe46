// The side of the joint spring the drive's friction acts on (effects.compliance.friction_side):
// closed-form results of the two-mass system with Coulomb friction on the motor side and on the
// load side, and a small independent integrator of the same cascade written here (explicit
// sub-steps, its own stick logic), not the servo's exact discretisation.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <numbers>
#include <string>

#include "servo_test_support.hpp"
#include "vmsim/common/errors.hpp"

namespace vmsim::servo {
namespace {

using kinematics::FrictionSide;
using test::load_sample;

/// The KR180 sample's q2 without gravity: P velocity loop, ideal current, ideal encoder, no
/// feedforward, Coulomb and viscous friction as in the file, the joint spring of the file.
AxisServoModel two_mass_q2(FrictionSide side) {
  const kinematics::MachineModel machine = load_sample("kr180_class.yaml");
  AxisServoModel model = make_axis_servo_model(machine, 1, {0.0, 0.0, 0.0, 0.0, 0.5, 0.0}, false);
  auto& c = model.axis.controller;
  c.velocity_type = kinematics::VelocityControllerType::P;
  c.current_model = kinematics::CurrentLoopModel::ideal;
  c.encoder_counts_per_rev = 0.0;
  c.velocity_feedforward = false;
  c.torque_feedforward = false;
  c.balancing_type = kinematics::BalancingType::none;
  c.current_max_A = 0.0;
  c.velocity_filter_time_s = 0.0;
  model.axis.effects.compliance.friction_side = side;
  model.axis.effects.compliance.compensate_gravity_deflection = false;
  return model;
}

TEST(FrictionSide, MachineFileDefaultIsMotorOnARobotAndLoadOnAMachineTool) {
  const kinematics::MachineModel robot = load_sample("kr180_class.yaml");
  for (const auto& axis : robot.axes) {
    EXPECT_EQ(axis.effects.compliance.friction_side, FrictionSide::motor) << axis.name;
  }
  const std::string dir = std::string(VMSIM_SOURCE_DIR) + "/samples/machines/";
  const std::string yaml = R"(name: bench
kind: machine_tool
interpolation_period_ms: 1
axes:
  - name: X
    type: linear
    travel_mm: [0, 500]
    limits: {velocity_m_per_min: 10, acceleration_m_per_s2: 1, jerk_m_per_s3: 10}
    drive: {screw_lead_mm: 10, equivalent_inertia_kg_m2: 0.002, rotor_inertia_kg_m2: 0.001, torque_constant_N_m_per_A: 1, torque_max_N_m: 10, torque_rate_max_N_m_per_s: 100}
    controller:
      position: {kv_per_s: 30, period_ms: 1}
      velocity: {type: PI, gain_N_m_s_per_rad: 1, integral_time_ms: 10, period_us: 125}
      current: {model: ideal}
    effects:
      compliance: {stiffness_N_per_um: 200, damping_ratio: 0.05}
structure:
  workpiece_chain: [{fixed: table}]
  tool_chain: [{joint: X, direction: [1, 0, 0]}, {fixed: spindle}]
)";
  const auto tool = kinematics::parse_machine(yaml, "bench.yaml", dir);
  EXPECT_EQ(tool.axes[0].effects.compliance.friction_side, FrictionSide::load);
  std::string motor = yaml;
  motor.replace(motor.find("damping_ratio: 0.05}"), 20, "damping_ratio: 0.05, friction_side: motor}");
  EXPECT_EQ(kinematics::parse_machine(motor, "bench.yaml", dir).axes[0].effects.compliance.friction_side,
            FrictionSide::motor);
  std::string bad = yaml;
  bad.replace(bad.find("damping_ratio: 0.05}"), 20, "damping_ratio: 0.05, friction_side: gear}");
  try {
    kinematics::parse_machine(bad, "bench.yaml", dir);
    ADD_FAILURE() << "friction_side: gear accepted";
  } catch (const vmsim::InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("bench.yaml:"), std::string::npos) << what;
    EXPECT_NE(what.find("gear"), std::string::npos) << what;
    EXPECT_NE(what.find("motor, load"), std::string::npos) << what;
  }
}

TEST(FrictionSide, ConstantMotorTorqueBelowBreakawayIsHeldByMotorSideFriction) {
  // Open loop (velocity gain 0: no current), a constant torque T on the motor shaft below the
  // breakaway b. Motor side: the friction holds the motor, the spring carries nothing: no motion
  // and the spring torque exactly 0. Load side: the motor turns until the spring carries T to
  // the stuck load: in steady state the spring torque is T and the load has not moved.
  // The constant torque is the cogging term A sin(n theta + phase) with n tiny and phase pi/2:
  // A cos(n theta) = A to 1e-20 for the few milliradians the motor turns.
  for (const FrictionSide side : {FrictionSide::motor, FrictionSide::load}) {
    AxisServoModel model = two_mass_q2(side);
    model.axis.controller.velocity_gain_N_m_s_per_rad = 0.0;
    const double kt = model.axis.drive.torque_constant_N_m_per_A;
    const double breakaway = kt * model.axis.drive.friction_dry_A;  // at the motor [N m]
    // Below half the breakaway: on the load side the spring's first swing overshoots to twice
    // its final torque and must not break the load away either.
    const double torque = 0.45 * breakaway;
    model.axis.effects.cogging = {true, torque, 1e-12, std::numbers::pi / 2.0};
    AxisInput input;
    input.period_s = 4e-3;
    input.values.assign(1501, 0.0);  // 6 s: the motor's ringing against the stuck load dies out
    const AxisSignals s = simulate_axis(model, input);
    const double r = model.axis.drive.ratio;
    const double k = model.axis.effects.compliance.stiffness;  // at the joint
    double largest_motion = 0.0;
    for (std::size_t i = 0; i < s.t.size(); ++i) {
      largest_motion = std::max({largest_motion, std::abs(s.load_pos[i]), std::abs(s.motor_pos[i])});
    }
    // Spring torque at the motor: k r^2 (theta_m - theta_L) = k r (q_m - q_L).
    const double spring_torque = k * r * (s.motor_pos.back() - s.load_pos.back());
    if (side == FrictionSide::motor) {
      EXPECT_EQ(largest_motion, 0.0);
      EXPECT_EQ(spring_torque, 0.0);
    } else {
      EXPECT_EQ(s.load_pos.back(), 0.0);  // the load stuck throughout
      EXPECT_NEAR(spring_torque, torque, 1e-9 * torque);
      EXPECT_GT(largest_motion, 0.0);
    }
  }
}

TEST(FrictionSide, ConstantMotorTorqueAboveBreakawayTurnsTheMotor) {
  AxisServoModel model = two_mass_q2(FrictionSide::motor);
  model.axis.controller.velocity_gain_N_m_s_per_rad = 0.0;
  const double breakaway = model.axis.drive.torque_constant_N_m_per_A * model.axis.drive.friction_dry_A;
  model.axis.effects.cogging = {true, 1.2 * breakaway, 1e-12, std::numbers::pi / 2.0};
  AxisInput input;
  input.period_s = 4e-3;
  input.values.assign(51, 0.0);
  const AxisSignals s = simulate_axis(model, input);
  EXPECT_GT(s.motor_pos.back(), 0.0);
  EXPECT_GT(s.load_pos.back(), 0.0);
}

/// The same cascade, integrated here: position P every T_pos on the motor angle, output one
/// position period later; velocity P every T_vel on the differenced motor angle, output (the
/// current, ideal) one velocity period later; the two bodies by semi-implicit Euler sub-steps,
/// Coulomb friction with a stick state on one of them. Returns the load position [joint rad] at
/// the set-point samples.
std::vector<double> independent_two_mass(const AxisServoModel& model, const AxisInput& input,
                                         FrictionSide side) {
  const auto& d = model.axis.drive;
  const auto& c = model.axis.controller;
  const double r = d.ratio, kt = d.torque_constant_N_m_per_A;
  const double jm = d.rotor_inertia_kg_m2, jl = d.equivalent_inertia_kg_m2 - jm;
  const double k = model.axis.effects.compliance.stiffness * r * r;  // at the motor
  const double damper = 2.0 * model.axis.effects.compliance.damping_ratio * std::sqrt(k * jm * jl / (jm + jl));
  const double dry = kt * d.friction_dry_A;
  const double viscous = kt * d.friction_viscous_A_per_joint_unit_per_s * r;  // per motor rad/s
  const double t_vel = c.velocity_period_s;
  const int vel_per_pos = static_cast<int>(std::lround(c.position_period_s / t_vel));
  const int sub = 250;
  const double h = t_vel / sub;
  const int vel_per_sample = static_cast<int>(std::lround(input.period_s / t_vel));
  auto setpoint = [&](double t) {
    const double u = t / input.period_s;
    if (u >= static_cast<double>(input.values.size() - 1)) return input.values.back();
    const auto i = static_cast<std::size_t>(u);
    return input.values[i] + (u - static_cast<double>(i)) * (input.values[i + 1] - input.values[i]);
  };
  double theta_m = input.values.front() / r, omega_m = 0.0, theta_l = theta_m, omega_l = 0.0;
  bool stuck = true;
  double speed_set_pending = 0.0, speed_set = 0.0;  // position loop output, one period late
  double current_pending = 0.0, current = 0.0;      // velocity loop output, one period late
  double theta_previous = theta_m;
  std::vector<double> load;
  const long ticks = static_cast<long>(input.values.size() - 1) * vel_per_sample;
  for (long tick = 0; tick <= ticks; ++tick) {
    const double t = static_cast<double>(tick) * t_vel;
    if (tick % vel_per_pos == 0) {
      speed_set = speed_set_pending;
      speed_set_pending = c.position_gain_kv_per_s * (setpoint(t) - r * theta_m) / r;
    }
    const double measured_speed = (theta_m - theta_previous) / t_vel;
    theta_previous = theta_m;
    current = current_pending;
    current_pending = c.velocity_gain_N_m_s_per_rad * (speed_set - measured_speed) / kt;
    if (tick % vel_per_sample == 0) load.push_back(r * theta_l);
    if (tick == ticks) break;
    for (int s = 0; s < sub; ++s) {
      const double spring = k * (theta_m - theta_l) + damper * (omega_m - omega_l);
      double torque_m = kt * current - spring;
      double torque_l = spring;
      double& omega_f = side == FrictionSide::motor ? omega_m : omega_l;
      double& torque_f = side == FrictionSide::motor ? torque_m : torque_l;
      const double j_f = side == FrictionSide::motor ? jm : jl;
      if (stuck) {
        if (std::abs(torque_f) <= dry) {
          torque_f = -j_f * omega_f / h;  // holds it at rest
        } else {
          torque_f -= std::copysign(dry, torque_f);
          stuck = false;
        }
      } else {
        torque_f -= std::copysign(dry, omega_f) + viscous * omega_f;
      }
      const double before = omega_f;
      omega_m += h * torque_m / jm;
      omega_l += h * torque_l / jl;
      if (!stuck && before != 0.0 && omega_f * before <= 0.0) {
        omega_f = 0.0;
        stuck = true;
      }
      theta_m += h * omega_m;
      theta_l += h * omega_l;
    }
  }
  return load;
}

TEST(FrictionSide, RampLagMatchesTheClosedFormOnEachSideAndAnIndependentIntegrator) {
  // A ramp at V from rest. Steady state (both bodies at V, the damper idle): the motor torque is
  // the friction F = Kt (a V + b) (Eq. 6 at the motor); the P velocity loop needs the speed
  // error F / Kp, the P position loop the motor-side following error
  //   e_m = (V + r F / Kp) / Kv.
  // Friction on the load side: the spring carries F, deflected by F / (k r) at the joint, so the
  // arm lags by e_m + F / (k r); on the motor side the spring carries nothing: e_m.
  const double speed = 0.2;  // rad/s at the joint
  std::vector<double> lags;
  for (const FrictionSide side : {FrictionSide::motor, FrictionSide::load}) {
    const AxisServoModel model = two_mass_q2(side);
    const auto& d = model.axis.drive;
    const auto& c = model.axis.controller;
    const double r = d.ratio, kt = d.torque_constant_N_m_per_A;
    const double friction = kt * (d.friction_viscous_A_per_joint_unit_per_s * speed + d.friction_dry_A);
    const double motor_lag = (speed + r * friction / c.velocity_gain_N_m_s_per_rad) / c.position_gain_kv_per_s;
    const double spring_lag = side == FrictionSide::load ? friction / (model.axis.effects.compliance.stiffness * r) : 0.0;
    AxisInput input;
    input.period_s = 4e-3;
    const std::size_t rest = 25, samples = 500;  // 0.1 s at rest, then 1.9 s of ramp
    for (std::size_t i = 0; i <= samples; ++i) {
      input.values.push_back(speed * input.period_s * static_cast<double>(i > rest ? i - rest : 0));
    }
    const AxisSignals s = simulate_axis(model, input);
    const double lag = s.cmd.back() - s.load_pos.back();
    const double expected = motor_lag + spring_lag;
    std::cout << (side == FrictionSide::motor ? "motor" : "load") << " side: ramp lag " << lag * 1e6
              << " urad, closed form " << expected * 1e6 << " urad (spring part " << spring_lag * 1e6 << ")\n";
    EXPECT_NEAR(lag, expected, 1e-6 * expected);
    EXPECT_NEAR(s.cmd.back() - s.motor_pos.back(), motor_lag, 1e-6 * motor_lag);
    lags.push_back(lag);

    // The whole response against the independent integrator: from the start from rest (the
    // stick phase differs between the sides) to the steady ramp.
    const std::vector<double> reference = independent_two_mass(model, input, side);
    ASSERT_EQ(reference.size(), s.load_pos.size());
    double worst = 0.0;
    for (std::size_t i = 0; i < reference.size(); ++i) {
      worst = std::max(worst, std::abs(reference[i] - s.load_pos[i]));
    }
    std::cout << "  against the independent integrator: worst " << worst * 1e6 << " urad\n";
    EXPECT_LT(worst, 0.02 * spring_lag + 0.002 * motor_lag);
  }
  // The load side lags the more by the spring's share of the friction.
  EXPECT_GT(lags[1], lags[0]);
}

}  // namespace
}  // namespace vmsim::servo
