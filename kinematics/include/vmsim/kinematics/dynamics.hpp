#pragma once
// Rigid-body dynamics of the machine: actuator torques and torque rates, effect by effect
// (first paper, Eq. 4-6 and Appendix A), along a path (Eq. 7-8 and their exact form with s'' and
// s'''), and the equivalent actuator limits of Eq. 10-11.
//
// Units: SI (m, rad, s, kg, N, N m). Joint values q are in joint units (m for a linear axis, rad
// for a rotary one); q_s, q_ss, q_sss are per m, m^2, m^3 of tool-tip arc length s.
// Frames: the recursion works in each link's joint frame (the frame J of machine_model.hpp after
// the joint motion); gravity is MachineModel::gravity_B_m_per_s2, in the base frame B.
//
// Model / data split (as in Pinocchio): DynamicsModel is built once from a MachineModel and never
// changes; DynamicsData holds the scratch space and the results of one call, one per thread.
// Every function reads `function(model, data, inputs...)` and writes into `data`; none allocates
// once the data exists.
//
// The dynamic model, per axis i (its actuator is the motor):
//
//   tau_i = r_i Q_i(q, qd, qdd) + (J_rotor,i / r_i) qdd_i + Kt_i (a_i qd_i + b_i sign(qd_i))
//
//   Q = H(q) qdd + B(q) qd^2 + C(q) qd_j qd_k + G(q)     (joint generalised force, Eq. 4, of the
//                                                          rigid bodies only [N or N m])
//   r_i      Drive::ratio, joint unit per motor rad; so the motor torque is r_i Q_i
//   J_rotor  Drive::rotor_inertia_kg_m2 (inertia at the motor shaft the links do not carry)
//   Kt, a, b Drive::torque_constant_N_m_per_A, friction_viscous_..., friction_dry_A (Eq. 6)
//
// Dry friction at qd_i = 0: sign(0) = 0, so the dry term is 0 at rest. Its time derivative is
// taken as 0 everywhere (the Dirac impulse at a velocity zero crossing is left out): tau-dot is the
// derivative of tau on each interval of constant velocity sign. The planner must treat the jump
// at a crossing itself (first paper, Sec. 3.3).
//
// Both chains of the model (workpiece chain B -> W and tool chain B -> S) are independent
// serial chains with a fixed base B; their joints are treated in one pass. The bodies of fixed
// joints are lumped into the moving link before them (a fixed joint before the first moving
// joint of a chain is part of the base and carries nothing dynamic).
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <initializer_list>
#include <string>
#include <string_view>
#include <vector>

#include "vmsim/kinematics/machine_model.hpp"

namespace vmsim::kinematics {

struct PathKinematics;  // path_kinematics.hpp

// ---------------------------------------------------------------------------------------------
// Effects (first paper, Eq. 4-5 and Sec. 3.3, Fig. 8)

/// The terms the actuator torque is split into. Each is given at the motor (N m), i.e. the rigid
/// part multiplied by r_i.
enum class Effect : std::uint8_t {
  /// Uncoupled inertia: r_i H_ii qdd_i + (J_rotor,i / r_i) qdd_i (the rotor belongs here).
  inertia = 0,
  /// Inertial coupling: r_i sum_{j != i} H_ij qdd_j.
  inertia_coupling = 1,
  /// Centrifugal: r_i sum_j B_ij qd_j^2, with B_ij the velocity-product term of joint j alone.
  centrifugal = 2,
  /// Coriolis: r_i sum_{j<k} C_ijk qd_j qd_k (all velocity products minus the centrifugal ones).
  coriolis = 3,
  /// Gravity: r_i G_i(q).
  gravity = 4,
  /// Friction of Eq. 6: Kt_i (a_i qd_i + b_i sign(qd_i)).
  friction = 5,
};
inline constexpr int kEffectCount = 6;

/// Lower-case name of an effect, for CSV/JSON keys: "inertia", "inertia_coupling",
/// "centrifugal", "coriolis", "gravity", "friction".
std::string_view effect_name(Effect effect);

/// A set of effects switched on (a bitmask). EffectSet::all() is the full model.
class EffectSet {
 public:
  constexpr EffectSet() = default;  ///< empty
  constexpr EffectSet(std::initializer_list<Effect> effects) {
    for (Effect e : effects) bits_ = static_cast<std::uint8_t>(bits_ | bit(e));
  }
  static constexpr EffectSet all() {
    EffectSet s;
    s.bits_ = (1u << kEffectCount) - 1u;
    return s;
  }
  constexpr bool contains(Effect e) const { return (bits_ & bit(e)) != 0; }
  constexpr EffectSet with(Effect e) const {
    EffectSet s = *this;
    s.bits_ = static_cast<std::uint8_t>(s.bits_ | bit(e));
    return s;
  }
  constexpr EffectSet without(Effect e) const {
    EffectSet s = *this;
    s.bits_ = static_cast<std::uint8_t>(s.bits_ & ~bit(e));
    return s;
  }
  constexpr bool operator==(const EffectSet&) const = default;

 private:
  static constexpr std::uint8_t bit(Effect e) {
    return static_cast<std::uint8_t>(1u << static_cast<unsigned>(e));
  }
  std::uint8_t bits_ = 0;
};

// ---------------------------------------------------------------------------------------------
// Model and data

namespace detail {
/// One moving joint and the rigid body it carries (fixed bodies after it lumped in).
struct DynLink {
  int axis = -1;      ///< index into q
  int parent = -1;    ///< index of the parent link, -1 for the base B
  bool revolute = true;
  Eigen::Vector3d direction = Eigen::Vector3d::UnitZ();  ///< joint axis, in the link frame
  /// Fixed part of the parent -> link transform: the link's joint frame at q = 0, in the parent
  /// link's frame (or B).
  Eigen::Matrix3d R_parent_joint = Eigen::Matrix3d::Identity();
  Eigen::Vector3d p_parent_joint = Eigen::Vector3d::Zero();
  // Spatial inertia about the link origin, in the link frame: mass, first moment h = m c, and
  // rotational inertia about the origin.
  double mass = 0.0;
  Eigen::Vector3d first_moment = Eigen::Vector3d::Zero();
  Eigen::Matrix3d inertia_origin = Eigen::Matrix3d::Zero();
};

/// Per-link scratch of the recursion (angular part first).
struct DynLinkState {
  Eigen::Matrix3d E;   ///< rotation parent coords -> link coords
  Eigen::Vector3d r;   ///< link origin in parent coords
  Eigen::Vector3d w, v, wd, vd;      ///< velocity, acceleration (spatial, link coords)
  Eigen::Vector3d w_t, v_t, wd_t, vd_t;  ///< their time derivatives
  Eigen::Vector3d n, f, n_t, f_t;    ///< force on the link from its parent, and its derivative
};
}  // namespace detail

/// The immutable dynamic model of a machine. Throws vmsim::InputError (naming the machine's
/// source file, the joint and the value) when an axis index is out of range or an axis is moved
/// by two joints, a drive ratio is zero, or a body has a negative mass.
class DynamicsModel {
 public:
  explicit DynamicsModel(const MachineModel& machine);

  int axis_count() const { return static_cast<int>(ratio.size()); }

  std::vector<detail::DynLink> links;  ///< moving joints of both chains, parents first
  Eigen::Vector3d gravity_B = Eigen::Vector3d::Zero();  ///< [m/s^2]
  Eigen::VectorXd ratio;          ///< r per axis [joint unit / motor rad]
  Eigen::VectorXd rotor_inertia;  ///< J_rotor per axis [kg m^2]
  Eigen::VectorXd friction_viscous_N_m_s;  ///< Kt a per axis [N m s / joint unit]
  Eigen::VectorXd friction_dry_N_m;        ///< Kt b per axis [N m]
  std::vector<std::string> axis_names;
};

/// Torques and torque rates of every effect, one column per Effect (index = enum value).
struct TorqueTerms {
  Eigen::Matrix<double, Eigen::Dynamic, kEffectCount> torque_N_m;
  Eigen::Matrix<double, Eigen::Dynamic, kEffectCount> torque_rate_N_m_per_s;
  Eigen::VectorXd total_torque_N_m;            ///< sum of the effects switched on
  Eigen::VectorXd total_torque_rate_N_m_per_s;  ///< sum of their rates
};

/// Coefficients that make the actuator torques and torque rates at one path point functions of
/// the path motion (s', s'', s''') — the TOPP-RA form (FIELD-NOTES, "TOPP-RA"), with ' = d/dt
/// for s and the subscript s / suffix _s = d/ds for the coefficients:
///
///   tau     = a sdd + b sd^2 + c + d sd + e sign(sd)
///   tau-dot = a sddd + (a_s + 2 b) sd sdd + b_s sd^3 + c_s sd + d_s sd^2 + d sdd
///
///   a = r H q_s + J_rotor/r q_s                          [N m s^2 / m]
///   b = r (H q_ss + c(q, q_s)) + J_rotor/r q_ss          [N m s^2 / m^2]  (c: velocity products)
///   c = r G                                              [N m]
///   d = Kt a_visc q_s  (viscous friction)                [N m s / m]
///   e = Kt b_dry sign(q_s) (dry friction, sign(0) = 0)   [N m]
///
/// Exact; the first paper's Eq. 7-8 are the case sdd = sddd = 0. Only the effects switched on
/// contribute (inertia and inertia_coupling to a and b, centrifugal and coriolis to b, gravity to
/// c, friction to d and e).
struct PathTorqueCoefficients {
  Eigen::VectorXd a, b, c, d, e;
  Eigen::VectorXd a_s, b_s, c_s, d_s;  ///< d/ds of a, b, c, d [their unit per m]

  /// Actuator torques for this path motion [N m] (sd in m/s, sdd in m/s^2).
  Eigen::VectorXd torque(double sd, double sdd) const;
  /// Actuator torque rates [N m / s] (sddd in m/s^3).
  Eigen::VectorXd torque_rate(double sd, double sdd, double sddd) const;
};

/// Scratch space and results; construct one per DynamicsModel and per thread.
struct DynamicsData {
  explicit DynamicsData(const DynamicsModel& model);

  // Results (sized axis_count()).
  Eigen::VectorXd Q;       ///< rigid-body joint generalised force [N or N m]
  Eigen::VectorXd Q_dot;   ///< its time derivative [N/s or N m/s]
  Eigen::VectorXd tau;      ///< actuator torque [N m]
  Eigen::VectorXd tau_dot;  ///< actuator torque rate [N m / s]
  Eigen::MatrixXd mass_matrix;  ///< H(q) of the rigid bodies (no rotor) [kg or kg m^2 ...]
  TorqueTerms terms;
  PathTorqueCoefficients coefficients;
  /// Joint motion from the last path call (chain rule of path_joint_motion).
  Eigen::VectorXd qd, qdd, qddd;

  // Scratch (not part of the interface).
  std::vector<detail::DynLinkState> link_state;
  Eigen::MatrixXd mass_matrix_rate;
  Eigen::Matrix<double, Eigen::Dynamic, kEffectCount> split_value, split_rate;
  Eigen::VectorXd zero, unit, unit2, tmp_Q, tmp_Qd, tmp_Q2, tmp_Qd2;
};

// ---------------------------------------------------------------------------------------------
// Joint space (rigid bodies only)

/// Recursive Newton-Euler inverse dynamics of the rigid bodies and its exact time derivative,
/// in one pass (derivatives of the link velocities, accelerations and forces propagated in the
/// same recursion): data.Q = Q(q, qd, qdd) (Eq. 4 without friction), data.Q_dot = dQ/dt given
/// qddd. With include_gravity = false, G is left out (and so is its derivative).
void rigid_body_dynamics(const DynamicsModel& model, DynamicsData& data,
                         const Eigen::Ref<const Eigen::VectorXd>& q,
                         const Eigen::Ref<const Eigen::VectorXd>& qd,
                         const Eigen::Ref<const Eigen::VectorXd>& qdd,
                         const Eigen::Ref<const Eigen::VectorXd>& qddd,
                         bool include_gravity = true);

/// data.mass_matrix = H(q) of the rigid bodies (Eq. 4; symmetric positive definite when every
/// joint moves some mass). The actuator model adds J_rotor / r^2 to H_ii; this does not.
void mass_matrix(const DynamicsModel& model, DynamicsData& data,
                 const Eigen::Ref<const Eigen::VectorXd>& q);

// ---------------------------------------------------------------------------------------------
// Actuators

/// Full model (every effect), tau and tau-dot in one pass: data.tau, data.tau_dot (and data.Q,
/// data.Q_dot). Eq. 4-6 and their time derivative Eq. 5.
void actuator_torque(const DynamicsModel& model, DynamicsData& data,
                     const Eigen::Ref<const Eigen::VectorXd>& q,
                     const Eigen::Ref<const Eigen::VectorXd>& qd,
                     const Eigen::Ref<const Eigen::VectorXd>& qdd,
                     const Eigen::Ref<const Eigen::VectorXd>& qddd);

/// Every effect's torque and torque rate (data.terms, one column per Effect; columns of effects
/// not in `effects` are zero) and the sum of those switched on. With EffectSet::all() the total
/// equals actuator_torque(). Costs 2n + 2 recursions (n = axis count).
void actuator_torque_terms(const DynamicsModel& model, DynamicsData& data,
                           const Eigen::Ref<const Eigen::VectorXd>& q,
                           const Eigen::Ref<const Eigen::VectorXd>& qd,
                           const Eigen::Ref<const Eigen::VectorXd>& qdd,
                           const Eigen::Ref<const Eigen::VectorXd>& qddd,
                           EffectSet effects = EffectSet::all());

// ---------------------------------------------------------------------------------------------
// Along a path

/// Path motion at one point: s [m] is not needed by the dynamics; sd [m/s], sdd [m/s^2],
/// sddd [m/s^3].
struct PathMotion {
  double sd = 0.0;
  double sdd = 0.0;
  double sddd = 0.0;
};

/// Exact chain rule: qd = q_s sd; qdd = q_ss sd^2 + q_s sdd;
/// qddd = q_sss sd^3 + 3 q_ss sd sdd + q_s sddd. Writes data.qd, data.qdd, data.qddd.
void path_joint_motion(DynamicsData& data, const Eigen::Ref<const Eigen::VectorXd>& q_s,
                       const Eigen::Ref<const Eigen::VectorXd>& q_ss,
                       const Eigen::Ref<const Eigen::VectorXd>& q_sss, const PathMotion& motion);

/// tau and tau-dot at one path point (data.tau, data.tau_dot; data.qd/qdd/qddd hold the joint
/// motion). With effects != all, data.terms is filled too and data.tau/tau_dot are its totals.
void actuator_torque_on_path(const DynamicsModel& model, DynamicsData& data,
                             const Eigen::Ref<const Eigen::VectorXd>& q,
                             const Eigen::Ref<const Eigen::VectorXd>& q_s,
                             const Eigen::Ref<const Eigen::VectorXd>& q_ss,
                             const Eigen::Ref<const Eigen::VectorXd>& q_sss,
                             const PathMotion& motion, EffectSet effects = EffectSet::all());

/// data.coefficients at one path point (see PathTorqueCoefficients), for the effects switched
/// on. Three recursions for the full model, up to 4n + 3 otherwise. `with_s_derivatives` =
/// false: a_s, b_s, c_s, d_s are not computed (set to 0; the torque alone needs none of them,
/// and the full model's recursions then skip their derivative parts).
void path_torque_coefficients(const DynamicsModel& model, DynamicsData& data,
                              const Eigen::Ref<const Eigen::VectorXd>& q,
                              const Eigen::Ref<const Eigen::VectorXd>& q_s,
                              const Eigen::Ref<const Eigen::VectorXd>& q_ss,
                              const Eigen::Ref<const Eigen::VectorXd>& q_sss,
                              EffectSet effects = EffectSet::all(), bool with_s_derivatives = true);

/// Per point, per axis, per effect: torques and torque rates along a path at a constant feed
/// (sd = feed, sdd = sddd = 0): the first paper's Eq. 7-8 term by term.
struct TorqueProfile {
  std::vector<std::string> axis_names;
  /// torque_N_m[e](axis, point) for Effect e (index = enum value); zero for effects switched off.
  std::array<Eigen::MatrixXd, kEffectCount> torque_N_m;
  std::array<Eigen::MatrixXd, kEffectCount> torque_rate_N_m_per_s;
  Eigen::MatrixXd total_torque_N_m;             ///< (axis, point), effects switched on
  Eigen::MatrixXd total_torque_rate_N_m_per_s;  ///< (axis, point)
};

/// q, q_s, q_ss, q_sss: one column per path point, one row per axis (as in PathKinematics).
/// Throws vmsim::InputError when the shapes disagree with each other or with the model.
TorqueProfile torque_profile_at_constant_feed(const DynamicsModel& model,
                                              const Eigen::Ref<const Eigen::MatrixXd>& q,
                                              const Eigen::Ref<const Eigen::MatrixXd>& q_s,
                                              const Eigen::Ref<const Eigen::MatrixXd>& q_ss,
                                              const Eigen::Ref<const Eigen::MatrixXd>& q_sss,
                                              double feed_m_per_s,
                                              EffectSet effects = EffectSet::all());

/// The same from the result of solve_path_kinematics.
TorqueProfile torque_profile_at_constant_feed(const DynamicsModel& model,
                                              const PathKinematics& path, double feed_m_per_s,
                                              EffectSet effects = EffectSet::all());

// ---------------------------------------------------------------------------------------------
// Equivalent limits (first paper, Sec. 2.3 and 4.1)

struct ActuatorLimits {
  double torque_N_m = 0.0;
  double torque_rate_N_m_per_s = 0.0;
};

/// Eq. 10: tau_eq = J_eq / r * qdd_max, taudot_eq = J_eq / r * qddd_max, from
/// Drive::equivalent_inertia_kg_m2, Drive::ratio and the axis's KinematicLimits.
ActuatorLimits equivalent_actuator_limits(const Axis& axis);

/// Eq. 11: taudot_max = tau_max * taudot_eq / tau_eq (the ratio of the equivalent limits kept
/// at the actuator's torque capability). Throws vmsim::InputError if equivalent.torque_N_m <= 0.
double scaled_torque_rate_limit(double torque_max_N_m, const ActuatorLimits& equivalent);

}  // namespace vmsim::kinematics
