#pragma once
// Physical effects of a feed drive beyond the rigid, linear model: each off by default, each
// with its parameters in the machine file (`axes[i].effects`, servo/README.md "effects").
// The servo simulation uses them; the diagnosis looks for them in measured data.
//
// Units: SI, joint units (m for a linear axis, rad for a rotary one) unless a name says
// otherwise. "Motor angle" is the motor shaft angle, q / Drive::ratio.
namespace vmsim::kinematics {

/// Stribeck friction: the dry friction rises to a static level at low speed,
///   F_dry(v) = b + (b_static - b) exp(-(|v| / v_s)^exponent)       [A, times Kt at the motor]
/// with b the dry friction of the drive (or of asymmetric_friction for the direction of v).
struct StribeckFriction {
  bool enabled = false;
  double static_friction_A = 0.0;  ///< b_static, the breakaway level (>= the dry level)
  double velocity = 0.0;           ///< v_s [joint unit / s], > 0
  double exponent = 2.0;           ///< shape exponent (1: exponential, 2: Gaussian), > 0
};

/// Direction-dependent friction: replaces Drive's a and b by one value per direction of motion.
struct AsymmetricFriction {
  bool enabled = false;
  double dry_positive_A = 0.0;   ///< b for q' > 0 [A]
  double dry_negative_A = 0.0;   ///< b for q' < 0 [A]
  double viscous_positive_A_per_joint_unit_per_s = 0.0;  ///< a for q' > 0 [A s/m or A s/rad]
  double viscous_negative_A_per_joint_unit_per_s = 0.0;  ///< a for q' < 0
};

/// Backlash (lost motion) between the motor and the load: a dead zone of total width `gap`.
struct Backlash {
  bool enabled = false;
  double gap = 0.0;  ///< total lost motion at the load [joint unit], > 0
};

/// Cogging / torque ripple, periodic in the motor angle theta_m:
///   tau_cog = amplitude sin(periods_per_rev theta_m + phase)   [N m, on the motor shaft]
struct Cogging {
  bool enabled = false;
  double amplitude_N_m = 0.0;
  double periods_per_rev = 0.0;  ///< ripple periods per motor revolution, > 0
  double phase_rad = 0.0;
};

/// Pitch (or scale, or gear) error, periodic in the position: the load (table) position is
///   q_load = q_nut + amplitude sin(2 pi q_nut / period + phase)
/// where q_nut = r theta_load is the nominal position the screw gives.
struct PitchError {
  bool enabled = false;
  double amplitude = 0.0;  ///< [joint unit]
  double period = 0.0;     ///< [joint unit], > 0; default in the file: travel per motor turn
  double phase_rad = 0.0;
};

/// Which body of a two-mass drive the friction of the drive (Drive's a and b and the friction
/// effects: Stribeck, asymmetric, smooth) acts on.
enum class FrictionSide {
  /// The load side, after the spring: the guideways of a machine-tool axis, whose friction is
  /// at the table (the servo's model before this choice existed).
  load,
  /// The motor side, before the spring: a robot joint, whose friction is mostly in the motor
  /// bearings and the gearbox's input stages (a harmonic or cycloidal reducer's teeth and
  /// bearings turn at or near motor speed; the joint spring is the gear's output and the
  /// arm's structure). The friction then loads the spring only through the motor's motion: an
  /// arm at rest starts as soon as the motor moves, without waiting for its spring to carry the
  /// breakaway torque.
  motor,
};

/// Two-mass compliance between motor and load (the first axial mode). The stiffness is given at
/// the joint (axial stiffness of screw, nut and bearings for a linear axis); at the motor it is
/// k r^2. The inertia J_eq splits into a motor side (rotor, coupling, screw) and a load side.
struct Compliance {
  bool enabled = false;
  double stiffness = 0.0;  ///< k at the joint [N/m or N m/rad], > 0
  /// Damping of the mode as a ratio of its critical damping (0 = undamped), in [0, 1).
  double damping_ratio = 0.0;
  /// Motor-side inertia J_m [kg m^2]; 0 = Drive::rotor_inertia_kg_m2. Must be in (0, J_eq).
  double motor_side_inertia_kg_m2 = 0.0;
  /// The controller commands the motor further by the static deflection of the spring under
  /// gravity at the set point (tau_g / k at the joint), as a robot controller's model-based
  /// deflection compensation ("absolute accuracy") does: at rest the load reaches the set point,
  /// in motion only the dynamic deflection remains. Off by default.
  bool compensate_gravity_deflection = false;
  /// Where the drive's friction acts. The machine file's default (`friction_side`) is `motor`
  /// on a robot (kind: robot) and `load` on a machine tool; the struct's default is `load`.
  FrictionSide friction_side = FrictionSide::load;
};

/// Dry friction without a stick state: b tanh(v / speed) (the dry level of the drive, or of the
/// asymmetric friction and Stribeck curve, times the tanh). What a drive whose friction has no
/// break-away (rolling elements, a lubricated screw) shows around zero speed.
struct SmoothFriction {
  bool enabled = false;
  double speed = 0.0;  ///< tanh width [joint unit / s], > 0
};

struct DriveEffects {
  SmoothFriction smooth_friction;
  StribeckFriction stribeck;
  AsymmetricFriction asymmetric_friction;
  Backlash backlash;
  Cogging cogging;
  PitchError pitch_error;
  Compliance compliance;
  /// The axis is balanced (counterweight, hydraulic or pneumatic): the servo leaves out the
  /// gravity torque the rigid-body model gives for it. Default false.
  bool gravity_compensated = false;
};

}  // namespace vmsim::kinematics
