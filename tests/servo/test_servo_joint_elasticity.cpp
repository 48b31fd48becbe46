// Joint elasticity (effects.compliance) on the robot: the two-mass response against its closed
// form, and the tool-tip deflection under gravity against an independent rigid + spring model
// (Orocos KDL's gravity torques and forward kinematics, the joint springs written here).
#include <gtest/gtest.h>

#include <kdl/chain.hpp>
#include <kdl/chainfksolverpos_recursive.hpp>
#include <kdl/chainidsolver_recursive_newton_euler.hpp>

#include <cmath>
#include <fstream>
#include <iostream>
#include <numbers>
#include <sstream>

#include "servo_test_support.hpp"
#include "vmsim/kinematics/kinematics.hpp"

namespace vmsim::servo {
namespace {

using test::load_sample;

TEST(JointElasticity, LoadStepResponseMatchesTheClosedFormTwoMassSolution) {
  // The KR180 sample's q2 with an open loop (velocity gain 0: the motor gets no current) and no
  // friction: motor and arm are two free bodies joined by the joint spring k and damper c. A
  // torque step F on the arm at t0 gives, with tau = t - t0, J = Jm + JL, Jr = Jm JL / J,
  // x = q_motor - q_arm:
  //   centre of inertia: F tau^2 / (2 J);
  //   x'' + (c / Jr) x' + (k / Jr) x = -F / JL, x(t0) = x'(t0) = 0:
  //   x = x_s (1 - exp(-zeta w tau) (cos(w_d tau) + zeta / sqrt(1 - zeta^2) sin(w_d tau))),
  //   x_s = -F Jr / (JL k), w = sqrt(k / Jr), w_d = w sqrt(1 - zeta^2);
  //   q_arm = q0 + F tau^2 / (2 J) - (Jm / J) x.
  // All at the joint (inertias divided by r^2).
  const kinematics::MachineModel machine = load_sample("kr180_class.yaml");
  const double q0 = 0.3;
  AxisServoModel model = make_axis_servo_model(machine, 1, {0.0, q0, 0.2, 0.0, 0.5, 0.0}, false);
  auto& c = model.axis.controller;
  c.velocity_type = kinematics::VelocityControllerType::P;
  c.velocity_gain_N_m_s_per_rad = 0.0;
  c.encoder_counts_per_rev = 0.0;
  model.axis.drive.friction_dry_A = 0.0;
  model.axis.drive.friction_viscous_A_per_joint_unit_per_s = 0.0;
  const double k = 4e6, zeta = 0.05;  // N m/rad at the joint
  const double r = model.axis.drive.ratio;
  const double jm_motor = model.axis.drive.rotor_inertia_kg_m2;
  model.axis.effects.compliance = {true, k, zeta, jm_motor, false};
  const double jm = jm_motor / (r * r);
  const double jl = (model.axis.drive.equivalent_inertia_kg_m2 - jm_motor) / (r * r);
  const double j = jm + jl, jr = jm * jl / j;
  const double w = std::sqrt(k / jr), wd = w * std::sqrt(1 - zeta * zeta);
  const double force = 2000.0;  // N m on the arm
  const double t0 = 0.01;

  AxisInput input;
  input.period_s = 1e-3;
  input.values.assign(301, q0);
  input.external_force.assign(301, 0.0);
  for (std::size_t i = 10; i < input.external_force.size(); ++i) input.external_force[i] = force;
  SimulationOptions options;
  options.record_period_s = c.velocity_period_s;
  const AxisSignals s = simulate_axis(model, input, options);

  const double xs = -force * jr / (jl * k);
  double worst_arm = 0.0, worst_deflection = 0.0, largest_deflection = 0.0;
  for (std::size_t i = 0; i < s.t.size(); ++i) {
    const double tau = std::max(0.0, s.t[i] - t0);
    const double x = xs * (1 - std::exp(-zeta * w * tau) *
                                   (std::cos(wd * tau) + zeta / std::sqrt(1 - zeta * zeta) * std::sin(wd * tau)));
    const double arm = q0 + force * tau * tau / (2 * j) - jm / j * x;
    worst_arm = std::max(worst_arm, std::abs(s.load_pos[i] - arm));
    worst_deflection = std::max(worst_deflection, std::abs((s.pos[i] - s.load_pos[i]) - x));
    largest_deflection = std::max(largest_deflection, std::abs(x));
  }
  std::cout << "two-mass step: mode " << w / (2 * std::numbers::pi) << " Hz, deflection up to "
            << largest_deflection * 180 / std::numbers::pi * 3600 << " arcsec; simulated vs closed form: arm "
            << worst_arm << " rad, deflection " << worst_deflection << " rad\n";
  EXPECT_GT(largest_deflection, 1.5 * std::abs(xs));  // it rang (overshoot of a lightly damped mode)
  // The plant is integrated exactly over each tick (matrix exponential): rounding only.
  EXPECT_LT(worst_deflection, 1e-9 * largest_deflection + 1e-15);
  EXPECT_LT(worst_arm, 1e-9 * std::abs(s.load_pos.back() - q0));
}

TEST(JointElasticity, DamperAtTheJointIsReadAsItsDampingRatio) {
  const std::string dir = std::string(VMSIM_SOURCE_DIR) + "/samples/machines/";
  const kinematics::MachineModel rigid = load_sample("kr180_class.yaml");
  const auto& drive = rigid.axes[1].drive;
  // d = 2 zeta sqrt(k J_red), J_red at the joint from the motor-side inertias over r^2.
  const double k = 2e6, d = 3000.0;
  const double jm = drive.rotor_inertia_kg_m2 / (drive.ratio * drive.ratio);
  const double jl = (drive.equivalent_inertia_kg_m2 - drive.rotor_inertia_kg_m2) / (drive.ratio * drive.ratio);
  const double expected = d / (2 * std::sqrt(k * jm * jl / (jm + jl)));
  kinematics::Compliance read;
  {
    std::ifstream in(dir + "kr180_class.yaml");
    std::stringstream text;
    text << in.rdbuf();
    std::string yaml = text.str();
    // Replace q2's compliance with a damper given at the joint.
    const std::string anchor = "  - name: q2\n";
    const std::size_t at = yaml.find(anchor);
    const std::size_t effects = yaml.find("compliance:", at);
    const std::size_t end = yaml.find('\n', effects);
    yaml.replace(effects, end - effects,
                 "compliance: {stiffness_N_m_per_rad: 2e6, damping_N_m_s_per_rad: 3000}");
    read = kinematics::parse_machine(yaml, "kr180.yaml", dir).axes[1].effects.compliance;
  }
  EXPECT_TRUE(read.enabled);
  EXPECT_DOUBLE_EQ(read.stiffness, k);
  EXPECT_NEAR(read.damping_ratio, expected, 1e-12 * expected);
  EXPECT_FALSE(read.compensate_gravity_deflection);
}

KDL::Vector kdl(const Eigen::Vector3d& v) { return KDL::Vector(v.x(), v.y(), v.z()); }

KDL::Frame kdl(const Eigen::Isometry3d& X) {
  const Eigen::Matrix3d R = X.linear();
  return KDL::Frame(KDL::Rotation(R(0, 0), R(0, 1), R(0, 2), R(1, 0), R(1, 1), R(1, 2), R(2, 0), R(2, 1), R(2, 2)),
                    kdl(X.translation()));
}

/// The tool chain as a KDL chain: a fixed segment for each joint origin, then the moving one
/// carrying the body.
KDL::Chain kdl_chain(const kinematics::Chain& chain) {
  KDL::Chain out;
  for (const kinematics::Joint& joint : chain) {
    out.addSegment(KDL::Segment(joint.name + "_origin", KDL::Joint(KDL::Joint::None), kdl(joint.origin)));
    const Eigen::Matrix3d& I = joint.body.inertia_kg_m2;
    const KDL::RigidBodyInertia inertia(joint.body.mass_kg, kdl(joint.body.com_m),
                                        KDL::RotationalInertia(I(0, 0), I(1, 1), I(2, 2), I(0, 1), I(0, 2), I(1, 2)));
    const bool moving = joint.type == kinematics::JointType::revolute;
    const KDL::Joint kjoint = moving ? KDL::Joint(joint.name, KDL::Vector::Zero(), kdl(joint.direction.normalized()),
                                                  KDL::Joint::RotAxis)
                                     : KDL::Joint(joint.name, KDL::Joint::None);
    out.addSegment(KDL::Segment(joint.name, kjoint, KDL::Frame::Identity(), inertia));
  }
  return out;
}

TEST(JointElasticity, ToolTipSagUnderGravityMatchesARigidPlusSpringModel) {
  const kinematics::MachineModel machine = load_sample("kr180_class.yaml");
  ASSERT_EQ(machine.axes.size(), 6u);
  const double tool_length = 0.12;
  const std::vector<double> q0 = {0.1, -0.35, 0.45, 0.2, 1.1, -0.3};
  Eigen::VectorXd q_cmd(6), q_load(6), q_load_compensated(6), q_load_motor_friction(6);
  for (int i = 0; i < 6; ++i) {
    AxisServoModel model = make_axis_servo_model(machine, i, q0, true);
    ASSERT_TRUE(model.axis.effects.compliance.enabled) << model.axis.name;
    AxisInput input;
    input.period_s = 4e-3;
    input.values.assign(50, q0[static_cast<std::size_t>(i)]);  // 0.2 s at rest
    model.axis.effects.compliance.compensate_gravity_deflection = false;
    // The sample's friction acts on the motor: the arm, free behind its spring, settles where
    // the spring carries the gravity of the yielded pose (second order apart from G(q_cmd) / k).
    q_load_motor_friction[i] = simulate_axis(model, input).load_pos.back();
    // On the load side the friction holds the arm at its start, G(q_cmd) / k: the reference's.
    model.axis.effects.compliance.friction_side = kinematics::FrictionSide::load;
    q_load[i] = simulate_axis(model, input).load_pos.back();
    model.axis.effects.compliance.compensate_gravity_deflection = true;
    const AxisSignals compensated = simulate_axis(model, input);
    q_load_compensated[i] = compensated.load_pos.back();
    EXPECT_DOUBLE_EQ(compensated.cmd.back(), q0[static_cast<std::size_t>(i)]);  // the set point as given
    q_cmd[i] = q0[static_cast<std::size_t>(i)];
  }
  const auto tip = [&](const Eigen::VectorXd& q) {
    return kinematics::forward_kinematics(machine, q, tool_length).tip_W_m;
  };
  const Eigen::Vector3d sag = tip(q_load) - tip(q_cmd);

  // Independent: KDL's gravity torques G(q) hold the arm; each joint spring yields by G_i / k_i
  // against its motor; KDL's forward kinematics of the yielded joints, the tool tip along -z_S.
  const KDL::Chain chain = kdl_chain(machine.tool_chain);
  ASSERT_EQ(chain.getNrOfJoints(), 6u);
  const KDL::Vector g = kdl(machine.gravity_B_m_per_s2);
  KDL::ChainIdSolver_RNE rne(chain, g);
  KDL::JntArray q(6), zero(6), torque(6);
  for (unsigned i = 0; i < 6; ++i) q(i) = q0[i];
  KDL::Wrenches no_force(chain.getNrOfSegments(), KDL::Wrench::Zero());
  ASSERT_GE(rne.CartToJnt(q, zero, zero, no_force, torque), 0);
  KDL::JntArray yielded(6);
  for (unsigned i = 0; i < 6; ++i) {
    yielded(i) = q0[i] - torque(i) / machine.axes[i].effects.compliance.stiffness;
  }
  KDL::ChainFkSolverPos_recursive fk(chain);
  const auto kdl_tip = [&](const KDL::JntArray& joints) {
    KDL::Frame S;
    EXPECT_GE(fk.JntToCart(joints, S), 0);
    const KDL::Vector p = S.p - tool_length * S.M.UnitZ();
    return Eigen::Vector3d(p.x(), p.y(), p.z());
  };
  // W is translated from B only (the sample's work table): a difference of tips is the same in both.
  const Eigen::Isometry3d X_BW = kinematics::workpiece_frame_B(machine, q_cmd);
  ASSERT_TRUE(X_BW.linear().isApprox(Eigen::Matrix3d::Identity(), 1e-15));
  const Eigen::Vector3d expected = kdl_tip(yielded) - kdl_tip(q);
  std::cout << "tool-tip sag under gravity: vmsim (servo two-mass + kinematics) " << sag.transpose() * 1e3
            << " mm, KDL rigid + springs " << expected.transpose() * 1e3 << " mm (apart by " << (sag - expected).norm() * 1e9 << " nm); with the controller's "
            << "deflection compensation " << (tip(q_load_compensated) - tip(q_cmd)).norm() * 1e6 << " um\n";
  EXPECT_GT(expected.norm(), 0.3e-3);  // a robot's sag: a fraction of a millimetre and more
  // The servo starts at rest in its static equilibrium at the set point (dry friction then holds
  // the arm there): the same spring torque G(q_cmd) as the reference, so only rounding remains.
  EXPECT_LT((sag - expected).norm(), 1e-6 * expected.norm());
  EXPECT_LT((tip(q_load_motor_friction) - tip(q_cmd) - expected).norm(), 1e-3 * expected.norm());
  // Compensated: what remains is the gravity change over the yield (second order).
  EXPECT_LT((tip(q_load_compensated) - tip(q_cmd)).norm(), 1e-3 * expected.norm());
}

}  // namespace
}  // namespace vmsim::servo
