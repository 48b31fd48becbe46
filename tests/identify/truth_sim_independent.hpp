#pragma once
// A second, independent "truth" simulator for the diagnosis tests (issue 20), written from the
// physics without reading servo/ (nor sharing code with truth_sim.cpp): an industrial-style
// cascade on a ball-screw axis closed on a direct load-side scale.
//
// - Position loop: P (kv) every position period, on the direct scale; velocity and torque
//   feedforward from backward differences of the set points, HELD over the position period (as
//   an NC computes them once per position cycle). The position controller's output reaches the
//   velocity loop one velocity cycle later (computation delay).
// - Velocity loop: PI every velocity period, on the motor encoder differenced over one period;
//   its output (a current command) applied one velocity cycle later.
// - Current loop: continuous first-order lag (exact exponential update each sub-step) towards
//   the held command, clamped at the current limit.
// - Mechanics: motor inertia and load mass, rigid or two-mass (compliance) or with a play
//   between them (backlash as a dead zone of a stiff contact); friction without stiction:
//   viscous + tanh-regularised Coulomb (+ an optional Gaussian low-speed hump), on the load.
//   External loads on the load: a constant force (a lifted mass), gravity's sinusoid of a
//   tilting axis's angle, an optional bump.
// - Measurement every trace period: set point, scale (quantised), motor encoder in joint units
//   (quantised), actual current with white noise and quantisation.
// - The record window starts and ends while the axis moves (the run is longer than the trace).
#include <cstdint>
#include <string>
#include <vector>

#include "vmsim/common/trace.hpp"

namespace vmsim::identify::test {

struct IndependentDrive {
  // Mechanics (SI).
  double lead_m = 0.016;
  double motor_inertia_kg_m2 = 6.0e-4;  ///< rotor + coupling + screw (a 32 mm screw, 1 m)
  double load_mass_kg = 150.0;
  double kt_N_m_per_A = 1.5;
  double viscous_A_s_per_m = 3.0;       ///< friction in equivalent current at the motor
  double coulomb_A = 0.4;
  double smooth_speed_m_per_s = 2e-4;   ///< tanh width of the Coulomb friction (no stiction)
  // Controller.
  double kv_per_s = 50.0;
  double position_period_s = 1e-3;
  double velocity_period_s = 250e-6;
  double velocity_gain_N_m_s_per_rad = 0.6;
  double velocity_integral_time_s = 0.008;
  double current_bandwidth_hz = 1200.0;
  double current_max_A = 20.0;
  bool velocity_feedforward = true, torque_feedforward = true;
  int substeps = 16;  ///< mechanics sub-steps per velocity period
  /// Velocity cycles between the position controller's computation and its output's use.
  int position_output_delay_cycles = 1;
  // Hidden effects (off when zero / false).
  double inertia_factor = 1.0;          ///< true J_eq / nominal
  bool asymmetric = false;
  double coulomb_positive_A = 0.0, coulomb_negative_A = 0.0;
  double viscous_positive_A_s_per_m = 0.0, viscous_negative_A_s_per_m = 0.0;
  double hump_A = 0.0, hump_speed_m_per_s = 0.0;  ///< extra friction exp(-(v/v_h)^2)
  double backlash_m = 0.0;
  double contact_stiffness_N_per_m = 5e8;
  double stiffness_N_per_m = 0.0, damping_ratio = 0.0;  ///< two-mass; 0 = rigid
  double cogging_N_m = 0.0, cogging_phase_rad = 0.0;
  int cogging_per_rev = 0;
  double pitch_amplitude_m = 0.0, pitch_period_m = 0.0, pitch_phase_rad = 0.0;
  double setpoint_delay_s = 0.0;
  double offset_force_N = 0.0;          ///< constant force resisting +x
  /// Gravity on a tilting rotary axis: a torque resisting +q of gravity_cos_N cos(q) +
  /// gravity_sin_N sin(q), q the load's angle [N m] (for a body whose centre of mass lies at
  /// (c_y, c_z) in the joint's frame about x: m g c_y and -m g c_z).
  double gravity_cos_N = 0.0, gravity_sin_N = 0.0;
  /// Unmodelled external force: `bump_force_N` acting between these times (smooth edges).
  double bump_force_N = 0.0, bump_start_s = 0.0, bump_end_s = 0.0;
  // Measurement.
  double current_noise_A = 0.02, current_quantum_A = 0.005;
  double scale_quantum_m = 5e-9;
  double motor_counts_per_rev = 1048576.0;
  double trace_period_s = 1e-3;
  std::string description;
  // Whole machines (issue 20): one drive per axis, each simulated on its own.
  std::string axis_name = "X";
  bool rotary = false;  ///< joint unit rad (logged in deg), else m (logged in mm)
  /// Joint displacement per motor radian where > 0 (a gear: 1 / ratio), else lead / 2 pi; the
  /// load "mass" is then in joint units (kg m^2 on a rotary axis) and forces in N (N m).
  double ratio_joint_per_rad = 0.0;
  /// The position loop closed on the motor encoder (`.pos`), the load scale logged as `.pos2`;
  /// else on the scale (`.pos`) with `.pos_motor` logged.
  bool loop_on_motor_encoder = false;

  double ratio_m_per_rad() const;
  double equivalent_inertia_kg_m2() const;  ///< nominal, without inertia_factor
};

/// Set points [m] on the position period: a run that starts from rest, with moves at several
/// speeds both ways, reversals and hard accelerations; `record_from`/`record_to` receive the
/// index window to log (both inside motion).
std::vector<double> independent_excitation(double period_s, std::size_t& record_from,
                                           std::size_t& record_to, int repeats = 1);

/// Simulates and returns the logged window: t, X.cmd, X.pos (scale), X.pos_motor, X.cur.
Trace simulate_independent(const IndependentDrive& drive, const std::vector<double>& setpoints_m,
                           std::size_t record_from, std::size_t record_to, std::uint32_t seed);

/// A whole machine: every drive follows its own set points [joint units, one vector per drive,
/// all on the position period, which must be the same for all], each on its own (no coupling,
/// seed + the drive's index); the logged windows are merged into one trace.
Trace simulate_independent_machine(const std::vector<IndependentDrive>& drives,
                                   const std::vector<std::vector<double>>& setpoints,
                                   std::size_t record_from, std::size_t record_to, std::uint32_t seed);

/// The machine file (YAML text) that describes the nominal drive in vmsim's terms.
std::string independent_machine_yaml(const IndependentDrive& nominal);

/// Peak |current| of the logged trace.
double independent_peak_current(const Trace& trace);

}  // namespace vmsim::identify::test
