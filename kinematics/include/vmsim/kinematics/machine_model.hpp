#pragma once
// The machine description: every module reads this one model.
//
// Units: SI everywhere inside (m, rad, s, kg, N, N m, A). A joint value q is in m for a linear
// axis and in rad for a rotary axis; "joint unit" below means m or rad accordingly. Conversion
// from the file's units (mm, deg, m/min, rev/min, ...) happens once, in machine_loader.cpp.
//
// Frames (Drake-style names, X_AB = pose of frame B in frame A, p_AB_A = position of B in A):
//   B  machine base (fixed to the machine bed; gravity is given in B)
//   W  workpiece frame (tool path coordinates), at the end of the workpiece chain
//   S  spindle gauge frame, at the end of the tool chain; its z axis is the tool axis, pointing
//      from the tool tip towards the spindle (the APT i,j,k convention)
//   T  tool tip frame: S translated by -tool_length along z_S
// Both chains start at B. A machine tool with a table-side A/C and spindle-side X/Y/Z has
// workpiece chain [A, C, fixed] and tool chain [X, Y, Z, fixed]; a robot has an empty workpiece
// chain (or a fixed offset to the work table) and its six joints in the tool chain.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "vmsim/kinematics/drive_effects.hpp"

namespace vmsim::kinematics {

enum class AxisType { linear, rotary };

/// Tuned kinematic limits recorded in the NC (first paper, Eq. 1). Joint units: m or rad.
struct KinematicLimits {
  double velocity_max = 0.0;      ///< joint unit / s
  double acceleration_max = 0.0;  ///< joint unit / s^2
  double jerk_max = 0.0;          ///< joint unit / s^3
};

/// Actuator and transmission of one axis (first paper, Eq. 4-6 and 10; second paper, Sec. 2.2).
struct Drive {
  /// Transmission ratio r: joint displacement per motor radian (m/rad for a ball screw of
  /// lead L: r = L / 2 pi; rad/rad for a gear: r = 1 / gear ratio). Motor angle = q / r.
  double ratio = 1.0;
  /// Equivalent inertia J_eq at the motor shaft [kg m^2]: rotor, screw and the reflected load,
  /// as identified on the machine. Used by the servo model and by Eq. 10 (tau_eq = J_eq/r q''max).
  double equivalent_inertia_kg_m2 = 0.0;
  /// Part of the inertia at the motor shaft that the rigid-body links do not carry (rotor,
  /// coupling, screw) [kg m^2]; the dynamic model adds rotor_inertia / r^2 to H_ii.
  double rotor_inertia_kg_m2 = 0.0;
  double torque_constant_N_m_per_A = 1.0;  ///< Kt
  /// Friction of Eq. 6, Gamma_f = Kt (a q' + b sign(q')), as motor current:
  double friction_viscous_A_per_joint_unit_per_s = 0.0;  ///< a [A s/m or A s/rad]
  double friction_dry_A = 0.0;                           ///< b [A]
  double torque_max_N_m = 0.0;          ///< actuator torque limit (Table 2)
  double torque_rate_max_N_m_per_s = 0.0;  ///< actuator torque-rate limit (Table 2, Eq. 11)
};

enum class VelocityControllerType { P, PI };
enum class CurrentLoopModel { ideal, first_order, PI };
enum class BalancingType { none, dead_time, first_order_lag };
enum class FineInterpolation { linear, cubic };
/// How the drive applies the NC's feedforward between two position-loop ticks: interpolated
/// linearly (central differences of the set points, the drive's fine interpolation), held (the
/// same values held over the position period), or held_backward (held, computed by the NC from
/// the set points already sent: backward differences, the velocity half a period late, the
/// acceleration one period late).
enum class FeedforwardTiming { interpolated, held, held_backward };
enum class PositionFeedback { motor, load };

/// Cascade controller of one axis drive (second paper, Sec. 2.1; a Siemens 840D-like structure).
/// servo/README.md documents the fields and how the servo simulation uses them. Each loop's
/// output is applied `*_output_delay_samples` periods of that loop after its inputs were
/// sampled (computation dead time; 1 for a digital drive).
struct Controller {
  // Position loop (P), closed in the NC or the drive.
  double position_gain_kv_per_s = 0.0;   ///< Kv [1/s] (1 (m/min)/mm = 16.67 1/s)
  double position_period_s = 0.0;        ///< sampling period of the position loop
  /// Fine interpolation of the set points (interpolation period -> position period).
  FineInterpolation fine_interpolation = FineInterpolation::linear;
  /// Encoder the position loop is closed on: the motor encoder or a direct (load-side) scale.
  PositionFeedback position_feedback = PositionFeedback::motor;
  /// Resolution of the load-side encoder [joint unit]; 0 = ideal.
  double load_encoder_resolution = 0.0;
  int position_output_delay_samples = 1;
  /// `position.output_dead_time_<s|ms|us>`: the position controller's output dead time as a
  /// time (a whole multiple of the fastest loop period: a drive that takes the NC's output at its
  /// next velocity cycle), replacing output_delay_samples; < 0 = not given.
  double position_output_dead_time_s = -1.0;
  // Velocity loop.
  VelocityControllerType velocity_type = VelocityControllerType::PI;
  double velocity_gain_N_m_s_per_rad = 0.0;  ///< Kp of the speed controller (motor side)
  double velocity_integral_time_s = 0.0;     ///< Tn of the PI; 0 for a P controller
  double velocity_period_s = 0.0;
  /// Time constant of the filter on the velocity differenced from the encoder [s]; 0 = none.
  double velocity_filter_time_s = 0.0;
  int velocity_output_delay_samples = 1;
  // Current (torque) loop.
  CurrentLoopModel current_model = CurrentLoopModel::first_order;
  double current_bandwidth_hz = 0.0;  ///< for first_order
  double current_gain_V_per_A = 0.0;  ///< for PI
  double current_integral_time_s = 0.0;
  double current_period_s = 0.0;
  int current_output_delay_samples = 1;  ///< for PI
  // Electrical model of the motor, for the PI current loop: L di/dt = u - R i - Ke omega.
  double resistance_ohm = 0.0;
  double inductance_H = 0.0;
  double back_emf_V_s_per_rad = 0.0;  ///< Ke; 0 = Kt (SI, a permanent-magnet motor)
  double voltage_max_V = 0.0;         ///< saturation of the current controller's output; 0 = none
  // Feedforward.
  bool velocity_feedforward = false;
  double velocity_feedforward_weight = 1.0;
  bool torque_feedforward = false;
  double torque_feedforward_weight = 1.0;
  /// `feedforward.timing` in the machine file.
  FeedforwardTiming feedforward_timing = FeedforwardTiming::interpolated;
  /// Balancing of the feedforward: the position set point is delayed so that both paths line up.
  BalancingType balancing_type = BalancingType::none;
  double balancing_time_s = 0.0;
  /// The second paper's adjustable delay in the position and feedforward paths.
  double delay_s = 0.0;
  // Saturations (0 = none).
  double current_max_A = 0.0;
  double velocity_max_rad_per_s = 0.0;  ///< motor speed limit
  /// Encoder resolution: counts per motor revolution (0 = ideal).
  double encoder_counts_per_rev = 0.0;
};

struct Axis {
  std::string name;
  AxisType type = AxisType::linear;
  double travel_min = 0.0;  ///< joint unit
  double travel_max = 0.0;  ///< joint unit
  /// A rotary axis without end stops (a C table); travel is then ignored.
  bool continuous = false;
  double home = 0.0;  ///< joint unit; start configuration and IK seed
  KinematicLimits limits;
  Drive drive;
  Controller controller;
  DriveEffects effects;  ///< further effects (friction variants, backlash, ...), off by default
};

/// Rigid-body parameters of the body a joint moves (first paper, Appendix A).
struct RigidBody {
  double mass_kg = 0.0;
  Eigen::Vector3d com_m = Eigen::Vector3d::Zero();  ///< centre of mass in the joint frame
  /// Inertia tensor about the centre of mass, in the joint frame [kg m^2].
  Eigen::Matrix3d inertia_kg_m2 = Eigen::Matrix3d::Zero();
};

enum class JointType { fixed, prismatic, revolute };

/// One element of a chain, as in URDF: the joint frame J sits at `origin` in the parent frame
/// (the previous element's joint frame, or B for the first), and the joint moves along / about
/// `direction` (unit, in J). The child body it carries has `body` in J.
/// X_parent_child(q) = origin * Translation(direction * q)   (prismatic)
///                   = origin * AngleAxis(q, direction)      (revolute)
struct Joint {
  std::string name;  ///< the axis name for a moving joint; a label for a fixed one
  JointType type = JointType::fixed;
  int axis_index = -1;  ///< index into MachineModel::axes; -1 for a fixed joint
  Eigen::Isometry3d origin = Eigen::Isometry3d::Identity();
  Eigen::Vector3d direction = Eigen::Vector3d::UnitZ();
  RigidBody body;
};

using Chain = std::vector<Joint>;

enum class MachineKind { machine_tool, robot };

struct MachineModel {
  std::string name;
  std::string source_file;  ///< where it was loaded from (for messages)
  MachineKind kind = MachineKind::machine_tool;
  std::vector<Axis> axes;  ///< in the order of the joint vector q
  Chain workpiece_chain;   ///< B -> W
  Chain tool_chain;        ///< B -> S
  Eigen::Vector3d gravity_B_m_per_s2{0.0, 0.0, -9.81};
  /// Interpolation period of the NC: the period of the position set points [s].
  double interpolation_period_s = 0.002;
  /// What the loader found plausible but unusual (a period of seconds, a travel of kilometres),
  /// each naming the file, line and field; the program prints them as warnings.
  std::vector<std::string> warnings;

  /// Index of the axis with this name, or -1.
  int axis_index(const std::string& axis_name) const;
  /// Axis positions at home.
  Eigen::VectorXd home_positions() const;
  std::size_t axis_count() const { return axes.size(); }
};

}  // namespace vmsim::kinematics
