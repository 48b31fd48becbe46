// DKT and IKT of the sample machines: closed-form and KDL references, inverse(forward(q)) on
// seeded random configurations, both table-table solutions, the general closed form on
// head-head, mixed and nutating structures, the robot's iterative solver (far seeds, least
// joint motion), the singular pose, unreachable poses.
#include <gtest/gtest.h>

#include <cmath>
#include <kdl/chain.hpp>
#include <kdl/chainfksolverpos_recursive.hpp>
#include <kdl/frames.hpp>
#include <kdl/jntarray.hpp>
#include <numbers>
#include <random>

#include "vmsim/kinematics/kinematics.hpp"
#include "vmsim/kinematics/machine_loader.hpp"
#include "vmsim/kinematics/sample_models.hpp"

namespace vk = vmsim::kinematics;

namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kToolLength = 0.1;

/// Random q within the travel (continuous axes: within +-3 turns), shrunk towards the middle
/// of the travel by `shrink` (1 = the whole travel).
Eigen::VectorXd random_q(const vk::MachineModel& model, std::mt19937& rng, double shrink = 1.0) {
  Eigen::VectorXd q(static_cast<Eigen::Index>(model.axis_count()));
  for (std::size_t i = 0; i < model.axis_count(); ++i) {
    const vk::Axis& axis = model.axes[i];
    double lo = axis.travel_min;
    double hi = axis.travel_max;
    if (axis.type == vk::AxisType::rotary && axis.continuous) {
      lo = -3.0 * kPi;
      hi = 3.0 * kPi;
    }
    const double mid = 0.5 * (lo + hi);
    const double half = 0.5 * (hi - lo) * shrink;
    q[static_cast<Eigen::Index>(i)] = std::uniform_real_distribution<double>(mid - half, mid + half)(rng);
  }
  return q;
}

double axis_angle(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b));
}

Eigen::Isometry3d translation(const Eigen::Vector3d& p) {
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  X.translation() = p;
  return X;
}

vk::Joint moving(const vk::MachineModel& model, const std::string& name, vk::JointType type,
                 const Eigen::Isometry3d& origin, const Eigen::Vector3d& direction) {
  vk::Joint joint;
  joint.name = name;
  joint.type = type;
  joint.axis_index = model.axis_index(name);
  joint.origin = origin;
  joint.direction = direction.normalized();
  return joint;
}

vk::Joint fixed(const std::string& name, const Eigen::Isometry3d& origin) {
  vk::Joint joint;
  joint.name = name;
  joint.origin = origin;
  return joint;
}

vk::Axis axis(const std::string& name, vk::AxisType type, double lo, double hi,
              bool continuous = false) {
  vk::Axis a;
  a.name = name;
  a.type = type;
  a.travel_min = lo;
  a.travel_max = hi;
  a.continuous = continuous;
  return a;
}

/// Head-head: the table moves in X, Y; the head carries Z, then C (about z), then A (about a
/// tilted, offset x axis), then the spindle with a pivot length.
vk::MachineModel make_head_head() {
  vk::MachineModel m;
  m.name = "head-head test machine";
  m.axes = {axis("X", vk::AxisType::linear, -0.5, 0.5), axis("Y", vk::AxisType::linear, -0.5, 0.5),
            axis("Z", vk::AxisType::linear, -0.5, 0.5),
            axis("C", vk::AxisType::rotary, -2.0 * kPi, 2.0 * kPi),
            axis("A", vk::AxisType::rotary, -1.9, 1.9)};
  m.workpiece_chain = {moving(m, "X", vk::JointType::prismatic, translation({0.01, 0, 0}), {-1, 0, 0}),
                       moving(m, "Y", vk::JointType::prismatic, translation({0, 0.02, 0}), {0, -1, 0}),
                       fixed("table", translation({0.0, 0.0, 0.1}))};
  Eigen::Isometry3d a_origin = translation({0.003, -0.002, -0.05});
  a_origin.linear() = Eigen::AngleAxisd(0.02, Eigen::Vector3d::UnitY()).toRotationMatrix();
  m.tool_chain = {moving(m, "Z", vk::JointType::prismatic, translation({0, 0, 0.6}), {0, 0, 1}),
                  moving(m, "C", vk::JointType::revolute, translation({0, 0, 0.1}), {0, 0, 1}),
                  moving(m, "A", vk::JointType::revolute, a_origin, {1, 0, 0}),
                  fixed("spindle", translation({0.0, 0.001, -0.2}))};
  return m;
}

/// Mixed: a C table (workpiece side), X Y Z and a B head about y (tool side).
vk::MachineModel make_mixed() {
  vk::MachineModel m;
  m.name = "mixed table-head test machine";
  m.axes = {axis("X", vk::AxisType::linear, -0.5, 0.5), axis("Y", vk::AxisType::linear, -0.5, 0.5),
            axis("Z", vk::AxisType::linear, -0.8, 0.5), axis("B", vk::AxisType::rotary, -1.7, 1.7),
            axis("C", vk::AxisType::rotary, 0.0, 0.0, true)};
  m.workpiece_chain = {moving(m, "C", vk::JointType::revolute, translation({0.01, 0, 0.2}), {0, 0, 1}),
                       fixed("table", translation({0.0, 0.0, 0.05}))};
  m.tool_chain = {moving(m, "X", vk::JointType::prismatic, translation({0, 0, 0}), {1, 0, 0}),
                  moving(m, "Y", vk::JointType::prismatic, translation({0, 0, 0}), {0, 1, 0}),
                  moving(m, "Z", vk::JointType::prismatic, translation({0, 0, 0.9}), {0, 0, 1}),
                  moving(m, "B", vk::JointType::revolute, translation({0, 0, 0.1}), {0, 1, 0}),
                  fixed("spindle", translation({0.0, 0.0, -0.15}))};
  return m;
}

/// Nutating head: C about z, then B' about (0, -sin 45, cos 45): the rotary axes are not
/// orthogonal, which exercises the general subproblem 2.
vk::MachineModel make_nutating() {
  vk::MachineModel m = make_head_head();
  m.name = "nutating head test machine";
  m.axes[4] = axis("A", vk::AxisType::rotary, -kPi, kPi);
  m.tool_chain[2].direction = Eigen::Vector3d(0.0, -1.0, 1.0).normalized();
  return m;
}

/// inverse(forward(q)) = pose for random q; checks every solution returned.
void check_round_trip(const vk::MachineModel& model, std::uint32_t seed, int samples,
                      double shrink, double seed_noise, int* singular_count = nullptr) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, 1.0);
  for (int n = 0; n < samples; ++n) {
    const Eigen::VectorXd q = random_q(model, rng, shrink);
    const vk::ToolPose pose = vk::forward_kinematics(model, q, kToolLength);
    Eigen::VectorXd q_previous = q;
    for (Eigen::Index i = 0; i < q.size(); ++i) q_previous[i] += seed_noise * noise(rng);
    const auto all = vk::inverse_kinematics_all(model, pose, q_previous, kToolLength);
    ASSERT_FALSE(all.empty()) << model.name << ", sample " << n << ", q = " << q.transpose();
    for (const vk::InverseResult& r : all) {
      const vk::ToolPose back = vk::forward_kinematics(model, r.q, kToolLength);
      EXPECT_LT((back.tip_W_m - pose.tip_W_m).norm(), 1e-9) << model.name << ", sample " << n;
      EXPECT_LT(axis_angle(back.axis_W, pose.axis_W), 1e-9) << model.name << ", sample " << n;
      EXPECT_TRUE(vk::within_travel(model, r.q));
      if (singular_count != nullptr && r.singular) ++*singular_count;
    }
    const auto one = vk::inverse_kinematics(model, pose, q_previous, kToolLength);
    ASSERT_TRUE(one.has_value());
    EXPECT_LT((one->q - all.front().q).norm(), 1e-15);
  }
}

Eigen::Matrix3d rot_x(double t) {
  Eigen::Matrix3d R;
  R << 1, 0, 0, 0, std::cos(t), -std::sin(t), 0, std::sin(t), std::cos(t);
  return R;
}

Eigen::Matrix3d rot_z(double t) {
  Eigen::Matrix3d R;
  R << std::cos(t), -std::sin(t), 0, std::sin(t), std::cos(t), 0, 0, 0, 1;
  return R;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// DKT against independent references.

TEST(ForwardKinematics, TableTableMatchesHandBuiltComposition) {
  const vk::MachineModel model = vk::make_table_table_sample();
  // The structure this reference is written for (the numbers are read from the model).
  ASSERT_EQ(model.workpiece_chain.size(), 3u);
  ASSERT_EQ(model.tool_chain.size(), 4u);
  ASSERT_TRUE(model.workpiece_chain[0].direction.isApprox(Eigen::Vector3d::UnitX()));
  ASSERT_TRUE(model.workpiece_chain[1].direction.isApprox(Eigen::Vector3d::UnitZ()));
  for (const auto* chain : {&model.workpiece_chain, &model.tool_chain}) {
    for (const vk::Joint& j : *chain) ASSERT_TRUE(j.origin.linear().isIdentity(0.0));
  }
  const Eigen::Vector3d o_A = model.workpiece_chain[0].origin.translation();
  const Eigen::Vector3d o_C = model.workpiece_chain[1].origin.translation();
  const Eigen::Vector3d o_W = model.workpiece_chain[2].origin.translation();
  Eigen::Vector3d o_S = Eigen::Vector3d::Zero();
  for (const vk::Joint& j : model.tool_chain) o_S += j.origin.translation();

  std::mt19937 rng(20240611);
  for (int n = 0; n < 200; ++n) {
    const Eigen::VectorXd q = random_q(model, rng);
    const double X = q[0], Y = q[1], Z = q[2], A = q[3], C = q[4];
    // p_B of the tip: the spindle point minus the tool length along z (no head rotation).
    const Eigen::Vector3d tip_B = Eigen::Vector3d(X, Y, Z) + o_S - Eigen::Vector3d(0, 0, kToolLength);
    // X_BW = T(o_A) Rx(A) T(o_C) Rz(C) T(o_W), so p_W = Rz(-C)(Rx(-A)(p_B - o_A) - o_C) - o_W.
    const Eigen::Vector3d tip_W =
        rot_z(-C) * (rot_x(-A) * (tip_B - o_A) - o_C) - o_W;
    const Eigen::Vector3d axis_W(std::sin(C) * std::sin(A), std::cos(C) * std::sin(A), std::cos(A));
    const vk::ToolPose pose = vk::forward_kinematics(model, q, kToolLength);
    EXPECT_LT((pose.tip_W_m - tip_W).norm(), 1e-12) << "q = " << q.transpose();
    EXPECT_LT((pose.axis_W - axis_W).norm(), 1e-12) << "q = " << q.transpose();
  }
}

namespace {

KDL::Frame to_kdl(const Eigen::Isometry3d& X) {
  const Eigen::Matrix3d& R = X.linear();
  return KDL::Frame(KDL::Rotation(R(0, 0), R(0, 1), R(0, 2), R(1, 0), R(1, 1), R(1, 2), R(2, 0),
                                  R(2, 1), R(2, 2)),
                    KDL::Vector(X.translation().x(), X.translation().y(), X.translation().z()));
}

/// The chain as kdl_parser builds it from a URDF: each joint a KDL joint about the axis
/// origin.M * direction through origin.p, followed by the segment tip frame `origin`.
KDL::Chain to_kdl_chain(const vk::Chain& chain) {
  KDL::Chain out;
  for (const vk::Joint& j : chain) {
    const KDL::Frame origin = to_kdl(j.origin);
    const KDL::Vector axis = origin.M * KDL::Vector(j.direction.x(), j.direction.y(), j.direction.z());
    KDL::Joint::JointType type = KDL::Joint::Fixed;
    if (j.type == vk::JointType::revolute) type = KDL::Joint::RotAxis;
    if (j.type == vk::JointType::prismatic) type = KDL::Joint::TransAxis;
    out.addSegment(KDL::Segment(j.name, type == KDL::Joint::Fixed
                                            ? KDL::Joint(j.name, KDL::Joint::Fixed)
                                            : KDL::Joint(j.name, origin.p, axis, type),
                                origin));
  }
  return out;
}

Eigen::Isometry3d from_kdl(const KDL::Frame& F) {
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) X.linear()(r, c) = F.M(static_cast<unsigned>(r), static_cast<unsigned>(c));
    X.translation()[r] = F.p[r];
  }
  return X;
}

}  // namespace

TEST(ForwardKinematics, RobotMatchesKdl) {
  const vk::MachineModel model = vk::make_robot_sample();
  const KDL::Chain tool = to_kdl_chain(model.tool_chain);
  const KDL::Chain workpiece = to_kdl_chain(model.workpiece_chain);
  ASSERT_EQ(tool.getNrOfJoints(), 6u);
  ASSERT_EQ(workpiece.getNrOfJoints(), 0u);
  KDL::ChainFkSolverPos_recursive tool_fk(tool);
  KDL::ChainFkSolverPos_recursive workpiece_fk(workpiece);
  std::mt19937 rng(7);
  for (int n = 0; n < 200; ++n) {
    const Eigen::VectorXd q = random_q(model, rng);
    KDL::JntArray jq(6);
    for (unsigned i = 0; i < 6; ++i) jq(i) = q[static_cast<Eigen::Index>(i)];
    KDL::Frame F_BS;
    KDL::Frame F_BW;
    ASSERT_GE(tool_fk.JntToCart(jq, F_BS), 0);
    KDL::JntArray none(0);
    ASSERT_GE(workpiece_fk.JntToCart(none, F_BW), 0);
    const Eigen::Isometry3d X_BS = vk::spindle_frame_B(model, q);
    EXPECT_LT((X_BS.matrix() - from_kdl(F_BS).matrix()).cwiseAbs().maxCoeff(), 1e-12);
    const KDL::Frame F_WT = F_BW.Inverse() * F_BS * KDL::Frame(KDL::Vector(0, 0, -kToolLength));
    const vk::ToolPose pose = vk::forward_kinematics(model, q, kToolLength);
    EXPECT_LT((pose.tip_W_m - from_kdl(F_WT).translation()).norm(), 1e-12);
    EXPECT_LT((pose.axis_W - from_kdl(F_WT).linear().col(2)).norm(), 1e-12);
  }
}

TEST(ForwardKinematics, JacobianMatchesFiniteDifferences) {
  for (const vk::MachineModel& model :
       {vk::make_table_table_sample(), vk::make_robot_sample(), make_head_head()}) {
    std::mt19937 rng(11);
    for (int n = 0; n < 20; ++n) {
      const Eigen::VectorXd q = random_q(model, rng, 0.9);
      Eigen::Matrix3Xd Jp;
      Eigen::Matrix3Xd Jw;
      vk::tool_jacobian_W(model, q, kToolLength, Jp, Jw);
      const vk::ToolPose pose = vk::forward_kinematics(model, q, kToolLength);
      const double h = 1e-6;
      for (Eigen::Index k = 0; k < q.size(); ++k) {
        Eigen::VectorXd qp = q, qm = q;
        qp[k] += h;
        qm[k] -= h;
        const vk::ToolPose pp = vk::forward_kinematics(model, qp, kToolLength);
        const vk::ToolPose pm = vk::forward_kinematics(model, qm, kToolLength);
        // Central differences: truncation O(h^2) ~ 1e-12, rounding ~ 1e-16 / h ~ 1e-10.
        EXPECT_LT(((pp.tip_W_m - pm.tip_W_m) / (2 * h) - Jp.col(k)).norm(), 1e-8) << model.name;
        EXPECT_LT(((pp.axis_W - pm.axis_W) / (2 * h) - Jw.col(k).cross(pose.axis_W)).norm(), 1e-8)
            << model.name;
      }
    }
  }
}

// ---------------------------------------------------------------------------------------------
// IKT, machine tools (closed form).

TEST(InverseKinematics, TableTableRoundTripAndBothSolutions) {
  const vk::MachineModel model = vk::make_table_table_sample();
  check_round_trip(model, 1, 500, 1.0, 0.5);
  // Both solutions (A, C) and (-A, C + pi) when -A is within travel too.
  std::mt19937 rng(2);
  int both = 0;
  for (int n = 0; n < 300; ++n) {
    Eigen::VectorXd q = random_q(model, rng);
    const vk::ToolPose pose = vk::forward_kinematics(model, q, kToolLength);
    const auto all = vk::inverse_kinematics_all(model, pose, q, kToolLength);
    // The mirror configuration, by hand: A' = -A, C' = C + pi, and the linear axes that put
    // the tip back: p_B = Rx(A')(Rz(C')(p_W + o_W) + o_C) + o_A, XYZ = p_B - o_S + L z.
    const Eigen::Vector3d o_A = model.workpiece_chain[0].origin.translation();
    const Eigen::Vector3d o_C = model.workpiece_chain[1].origin.translation();
    const Eigen::Vector3d o_W = model.workpiece_chain[2].origin.translation();
    const Eigen::Vector3d o_S = model.tool_chain[3].origin.translation();
    Eigen::VectorXd mirror(5);
    mirror[3] = -q[3];
    mirror[4] = q[4] + kPi;
    mirror.head<3>() = rot_x(mirror[3]) * (rot_z(mirror[4]) * (pose.tip_W_m + o_W) + o_C) + o_A -
                       o_S + Eigen::Vector3d(0, 0, kToolLength);
    const bool mirror_in_travel = vk::within_travel(model, mirror) && std::abs(q[3]) > 1e-3;
    ASSERT_EQ(all.size(), mirror_in_travel ? 2u : 1u) << "A = " << q[3];
    // The first one is the configuration we started from (closest to q_previous = q).
    EXPECT_LT((all[0].q - q).norm(), 1e-9);
    if (all.size() == 2) {
      ++both;
      EXPECT_NEAR(all[1].q[3], -q[3], 1e-9);
      EXPECT_LT((all[1].q.head<3>() - mirror.head<3>()).norm(), 1e-9);
      // C + pi, unwrapped next to the previous C.
      EXPECT_NEAR(std::abs(all[1].q[4] - q[4]), kPi, 1e-9);
      for (const auto& r : all) {
        const vk::ToolPose back = vk::forward_kinematics(model, r.q, kToolLength);
        EXPECT_LT((back.tip_W_m - pose.tip_W_m).norm(), 1e-9);
        EXPECT_LT(axis_angle(back.axis_W, pose.axis_W), 1e-9);
      }
    }
  }
  EXPECT_GT(both, 100);  // the test exercised the two-solution case
}

TEST(InverseKinematics, OtherFiveAxisStructuresRoundTrip) {
  int singular = 0;
  check_round_trip(make_head_head(), 3, 300, 1.0, 0.3, &singular);
  check_round_trip(make_mixed(), 4, 300, 1.0, 0.3, &singular);
  check_round_trip(make_nutating(), 5, 300, 1.0, 0.3, &singular);
  EXPECT_EQ(singular, 0);  // random poses are not singular
}

TEST(InverseKinematics, RotaryAxesUnwrappedNextToPrevious) {
  const vk::MachineModel model = vk::make_table_table_sample();
  Eigen::VectorXd q(5);
  q << 0.01, -0.02, -0.3, 0.4, 0.3;
  const vk::ToolPose pose = vk::forward_kinematics(model, q, kToolLength);
  for (int turns : {-5, -1, 0, 2, 7}) {
    Eigen::VectorXd q_previous = q;
    q_previous[4] += turns * 2.0 * kPi + 0.2;  // near, but 0.2 rad off and some turns away
    const auto r = vk::inverse_kinematics(model, pose, q_previous, kToolLength);
    ASSERT_TRUE(r);
    EXPECT_NEAR(r->q[4], q[4] + turns * 2.0 * kPi, 1e-9);
    EXPECT_NEAR(r->q[3], q[3], 1e-9);
  }
  // A limited axis is unwrapped within its travel: the head-head C travels +-2 pi.
  const vk::MachineModel hh = make_head_head();
  Eigen::VectorXd qh(5);
  qh << 0.01, 0.02, -0.1, 1.5 * kPi, 0.7;
  const vk::ToolPose pose_h = vk::forward_kinematics(hh, qh, kToolLength);
  Eigen::VectorXd prev = qh;
  prev[3] = 1.9 * kPi;
  auto r = vk::inverse_kinematics(hh, pose_h, prev, kToolLength);
  ASSERT_TRUE(r);
  EXPECT_NEAR(r->q[3], 1.5 * kPi, 1e-9);
  prev[3] = 1.5 * kPi - 2.0 * kPi;  // nearer to -0.5 pi, which is also within the travel
  r = vk::inverse_kinematics(hh, pose_h, prev, kToolLength);
  ASSERT_TRUE(r);
  EXPECT_NEAR(r->q[3], -0.5 * kPi, 1e-9);
}

TEST(InverseKinematics, TableTableSingularPoseKeepsC) {
  const vk::MachineModel model = vk::make_table_table_sample();
  Eigen::VectorXd q_previous(5);
  q_previous << 0.05, 0.02, -0.25, 0.1, 1.234;
  for (double tilt : {0.0, 1e-5, 0.9e-3}) {
    vk::ToolPose pose;
    pose.tip_W_m = Eigen::Vector3d(0.03, -0.02, 0.04);
    pose.axis_W = Eigen::Vector3d(std::sin(tilt) * std::cos(0.3), std::sin(tilt) * std::sin(0.3),
                                  std::cos(tilt));
    const auto r = vk::inverse_kinematics(model, pose, q_previous, kToolLength);
    ASSERT_TRUE(r);
    EXPECT_TRUE(r->singular);
    EXPECT_EQ(r->q[4], q_previous[4]);  // C does not spin
    const vk::ToolPose back = vk::forward_kinematics(model, r->q, kToolLength);
    EXPECT_LT((back.tip_W_m - pose.tip_W_m).norm(), 1e-12);
    // The axis is reached within the singular-zone angle (exactly at the pole).
    EXPECT_LE(axis_angle(back.axis_W, pose.axis_W), tilt == 0.0 ? 1e-12 : 2.0 * tilt + 1e-12);
  }
  // Just outside the zone: exact, not singular.
  vk::ToolPose pose;
  pose.tip_W_m = Eigen::Vector3d(0.03, -0.02, 0.04);
  pose.axis_W = Eigen::Vector3d(std::sin(1.1e-3), 0.0, std::cos(1.1e-3));
  const auto r = vk::inverse_kinematics(model, pose, q_previous, kToolLength);
  ASSERT_TRUE(r);
  EXPECT_FALSE(r->singular);
  EXPECT_LT(axis_angle(vk::forward_kinematics(model, r->q, kToolLength).axis_W, pose.axis_W), 1e-12);
}

TEST(InverseKinematics, UnreachablePosesGiveNothing) {
  const vk::MachineModel model = vk::make_table_table_sample();
  const Eigen::VectorXd home = model.home_positions();
  vk::ToolPose pose;
  pose.axis_W = -Eigen::Vector3d::UnitZ();  // A = 180 deg: beyond the A travel
  EXPECT_FALSE(vk::inverse_kinematics(model, pose, home, kToolLength));
  EXPECT_NE(vk::explain_unreachable(model, pose, home, kToolLength).find("axis A"),
            std::string::npos);
  pose.axis_W = Eigen::Vector3d::UnitZ();
  pose.tip_W_m = Eigen::Vector3d(2.0, 0.0, 0.0);  // X beyond its travel
  EXPECT_FALSE(vk::inverse_kinematics(model, pose, home, kToolLength));
  EXPECT_NE(vk::explain_unreachable(model, pose, home, kToolLength).find("axis X"),
            std::string::npos);
  pose.axis_W = Eigen::Vector3d::Zero();
  EXPECT_FALSE(vk::inverse_kinematics(model, pose, home, kToolLength));

  const vk::MachineModel robot = vk::make_robot_sample();
  vk::ToolPose far;
  far.tip_W_m = Eigen::Vector3d(5.0, 0.0, 0.0);  // out of the robot's reach
  EXPECT_FALSE(vk::inverse_kinematics(robot, far, robot.home_positions(), kToolLength));
}

TEST(InverseKinematics, WrongSizeThrows) {
  const vk::MachineModel model = vk::make_table_table_sample();
  EXPECT_THROW(vk::forward_kinematics(model, Eigen::VectorXd::Zero(4), kToolLength),
               std::invalid_argument);
  EXPECT_FALSE(vk::within_travel(model, Eigen::VectorXd::Zero(4)));
}

TEST(WithinTravel, LimitsAndContinuousAxes) {
  const vk::MachineModel model = vk::make_table_table_sample();
  Eigen::VectorXd q = model.home_positions();
  EXPECT_TRUE(vk::within_travel(model, q));
  q[4] = 100.0;  // C is continuous
  EXPECT_TRUE(vk::within_travel(model, q));
  q[3] = model.axes[3].travel_max + 1e-9;
  EXPECT_FALSE(vk::within_travel(model, q));
  EXPECT_TRUE(vk::within_travel(model, q, 1e-8));
  q[3] = 0.0;
  q[2] = model.axes[2].travel_min - 1e-6;
  EXPECT_FALSE(vk::within_travel(model, q));
}

// ---------------------------------------------------------------------------------------------
// IKT, robot (iterative).

TEST(InverseKinematics, RobotRoundTripFromNearbySeeds) {
  // Seeds 0.05 rad (per joint, rms) off: a seed much further off may fall into the basin of
  // another branch (elbow, wrist) which can lie beyond the travel.
  check_round_trip(vk::make_robot_sample(), 8, 300, 0.8, 0.05);
}

TEST(InverseKinematics, RobotConvergesFromHomeToFarPoses) {
  const vk::MachineModel robot = vk::make_robot_sample();
  const Eigen::VectorXd home = robot.home_positions();
  const vk::ToolPose home_pose = vk::forward_kinematics(robot, home, kToolLength);
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int n = 0; n < 100; ++n) {
    // Poses up to 0.5 m and 60 degrees away from home.
    vk::ToolPose pose;
    pose.tip_W_m = home_pose.tip_W_m + 0.5 * Eigen::Vector3d(u(rng), u(rng), u(rng)) / std::sqrt(3.0);
    const Eigen::Vector3d tilt_axis = Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized();
    pose.axis_W = Eigen::AngleAxisd(kPi / 3.0 * std::abs(u(rng)), tilt_axis) * home_pose.axis_W;
    const auto r = vk::inverse_kinematics(robot, pose, home, kToolLength);
    ASSERT_TRUE(r) << "pose " << n << " tip " << pose.tip_W_m.transpose();
    const vk::ToolPose back = vk::forward_kinematics(robot, r->q, kToolLength);
    EXPECT_LT((back.tip_W_m - pose.tip_W_m).norm(), 1e-11);
    EXPECT_LT(axis_angle(back.axis_W, pose.axis_W), 1e-11);
  }
}

TEST(InverseKinematics, RobotRedundancyResolvedByLeastJointMotion) {
  // For a small pose change, the minimum-norm solution moves q by J^+ J dq: no component in the
  // null space of the 5-row task Jacobian (the free rotation about the tool axis).
  const vk::MachineModel robot = vk::make_robot_sample();
  std::mt19937 rng(10);
  std::normal_distribution<double> noise(0.0, 1.0);
  for (int n = 0; n < 50; ++n) {
    const Eigen::VectorXd q0 = random_q(robot, rng, 0.6);
    Eigen::VectorXd dq(6);
    for (Eigen::Index i = 0; i < 6; ++i) dq[i] = 1e-4 * noise(rng);
    const vk::ToolPose pose = vk::forward_kinematics(robot, q0 + dq, kToolLength);
    const auto r = vk::inverse_kinematics(robot, pose, q0, kToolLength);
    ASSERT_TRUE(r);
    Eigen::Matrix3Xd Jp;
    Eigen::Matrix3Xd Jw;
    vk::tool_jacobian_W(robot, q0, kToolLength, Jp, Jw);
    const Eigen::Vector3d a = vk::forward_kinematics(robot, q0, kToolLength).axis_W;
    const Eigen::Vector3d b1 = a.unitOrthogonal();
    const Eigen::Vector3d b2 = a.cross(b1);
    Eigen::MatrixXd J(5, 6);
    J << Jp, b1.transpose() * Jw, b2.transpose() * Jw;
    const Eigen::JacobiSVD<Eigen::MatrixXd> svd(J, Eigen::ComputeFullV);
    const Eigen::VectorXd null = svd.matrixV().col(5);
    const double free_motion = std::abs(null.dot(r->q - q0));
    // The random dq has a null component of order 1e-4; the solution's is second order.
    EXPECT_LT(free_motion, 1e-6) << "null-space part of dq: " << null.dot(dq);
  }
}

namespace {

// inverse_kinematics_given_rotary keeps the given rotary axes (not the branch nearest the
// previous pose) and solves the linear axes: the direct kinematics gives the pose back. Given
// axes whose tool axis is not the pose's, or a tip beyond a linear travel, are refused with
// the reason.
TEST(Kinematics, GivenRotaryAxesAreKeptAndOnlyTheLinearAxesSolved) {
  // The Mikron sample (A -120..30 deg, C endless): both branches of A -10 deg lie in travel.
  const vk::MachineModel model =
      vk::load_machine(std::string(VMSIM_SOURCE_DIR) + "/samples/machines/mikron_ucp710.yaml");
  const double deg = std::numbers::pi / 180.0;
  Eigen::VectorXd q_words = model.home_positions();
  q_words[3] = -10.0 * deg;
  q_words[4] = -150.0 * deg;
  const vk::ToolPose pose = vk::forward_kinematics(model, q_words, kToolLength);
  // Both branches of the pose; the IKT alone takes the first (nearest home). The given axes
  // are the other one's.
  const auto all = vk::inverse_kinematics_all(model, pose, model.home_positions(), kToolLength);
  ASSERT_EQ(all.size(), 2u);
  const Eigen::VectorXd other = all[1].q;
  Eigen::VectorXd given = Eigen::VectorXd::Constant(5, std::nan(""));
  given[3] = other[3];
  given[4] = other[4];
  const auto kept = vk::inverse_kinematics_given_rotary(model, pose, given, model.home_positions(), kToolLength);
  ASSERT_TRUE(kept.has_value());
  EXPECT_EQ(kept->q[3], other[3]);
  EXPECT_EQ(kept->q[4], other[4]);
  EXPECT_GT(std::abs(all[0].q[3] - other[3]), 1.0 * deg);  // really the other branch
  EXPECT_LT((kept->q - other).norm(), 1e-12);
  const vk::ToolPose back = vk::forward_kinematics(model, kept->q, kToolLength);
  EXPECT_LT((back.tip_W_m - pose.tip_W_m).norm(), 1e-12);
  given[3] = -other[3];
  // A given A of the other sign (C kept) gives another tool axis: refused.
  std::string why;
  EXPECT_FALSE(vk::inverse_kinematics_given_rotary(model, pose, given, model.home_positions(), kToolLength,
                                                   1e-6, &why));
  EXPECT_NE(why.find("deg away from the programmed one"), std::string::npos) << why;
  // A tip 2 m away: a linear axis leaves its travel, named.
  given[3] = other[3];
  vk::ToolPose far = pose;
  far.tip_W_m.y() += 2.0;
  EXPECT_FALSE(vk::inverse_kinematics_given_rotary(model, far, given, model.home_positions(), kToolLength,
                                                   1e-6, &why));
  EXPECT_NE(why.find("outside its travel"), std::string::npos) << why;
}

}  // namespace
