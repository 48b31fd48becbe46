#pragma once
// Feed drive simulation: how each axis drive follows its position set points (the second
// paper's "level 2", Sec. 2). servo/README.md describes the model, the integration and the
// machine-file fields; this header is the interface.
//
// Units: SI inside (m, rad, s, kg, N, N m, A, V). Joint values are in joint units (m for a linear
// axis, rad for a rotary one). Motor-side quantities (angle theta, speed omega, torque) are at the
// motor shaft; q = r theta with r = Drive::ratio.
//
// Model per axis (axes independent, as in the paper, Sec. 2.2):
//
//   NC:    set points q_c(t) at the interpolation period -> fine interpolation -> delay (the
//          paper's adjustable delay) -> balancing (dead time or lag) of the position set point
//   P:     v* = Kv (q_c,bal - q_meas) + w_v q_c'            (velocity feedforward, weight w_v)
//   PI/P:  tau* = Kp (v*/r - omega_meas) + I + w_t J_eq q_c''/r   (torque feedforward)
//          omega_meas = filtered difference of the motor encoder over one velocity period
//   current: ideal (i = i*), first order (di/dt = 2 pi f_c (i* - i)) or PI on
//          L di/dt = u - R i - Ke omega
//   mechanics (rigid): J_eq theta'' = Kt i - c omega - tau_dry(omega) - tau_g(q) + r F_ext
//          + tau_cog(theta);   c = Kt a r,  tau_dry = Kt b sign(omega) (Eq. 6 of the first paper)
//   mechanics (two-mass, effects.compliance): motor J_m and load J_eq - J_m joined by a spring
//          k r^2 (with the backlash dead zone when effects.backlash is on); friction, gravity and
//          the external force act on the load, cogging and the motor torque on the motor.
//   mechanics (rigid with effects.backlash): motor side J_m (drive.rotor_inertia_kg_m2) and
//          load J_eq - J_m: one body while the motor pushes the load on a flank, decoupled
//          inside the gap, inelastic impact at the flank.
//   feedforward: interpolated linearly between position ticks at the velocity loop's rate
//          (SimulationOptions::interpolate_feedforward).
//
// Integration: between two ticks of the fastest loop the inputs are held; the linear part
// (inertias, viscous friction, spring, current dynamics) is integrated exactly by its matrix
// exponential; the dry friction is a held input per (sub)step, with a stick state at zero
// velocity (no chatter). See README.
#include <Eigen/Core>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "vmsim/common/trace.hpp"
#include "vmsim/kinematics/machine_model.hpp"

namespace vmsim::servo {

/// Options of one simulation run.
struct SimulationOptions {
  /// Period of the recorded signals [s]; 0 = the set points' period. Must be a whole multiple
  /// of each simulated axis's fastest loop period.
  double record_period_s = 0.0;
  /// Record the inner signals (AxisSignals::following_error ... current_setpoint).
  bool inner_signals = false;
  /// Plant sub-steps per tick of the fastest loop; 0 = automatic (1, or 8 when backlash or
  /// compliance is on: their mode switches and the stick state are resolved per sub-step).
  int plant_substeps = 0;
  /// Gravity torque from the rigid-body model of the machine (see AxisServoModel::gravity_*).
  bool gravity = true;
  /// Velocity and torque feedforward between two position-loop ticks: true = interpolated
  /// linearly at every velocity-loop tick, from this tick's value to the next one's, as the
  /// drive's fine interpolation does (the velocity set point has no steps at the position
  /// period); false = held over the position period as the NC sends them (each step makes a
  /// current pulse at every position tick).
  bool interpolate_feedforward = true;
};

/// What drives an axis: position set points at a uniform period (the normal case), or, to test
/// the velocity loop alone, velocity set points at the input of the velocity controller (the
/// position loop is then open). Values before the first sample hold the first, after the last
/// hold the last.
struct AxisInput {
  enum class Kind { position, velocity };
  Kind kind = Kind::position;
  double start_time_s = 0.0;
  double period_s = 0.0;       ///< uniform sample period, > 0
  std::vector<double> values;  ///< q [joint unit] or q' [joint unit / s]
  /// Optional external force on the load along +q [N or N m], held per sample (same grid);
  /// empty = none. E.g. minus the cutting force.
  std::vector<double> external_force;
  /// Simulated time after the last sample [s].
  double extra_time_s = 0.0;
};

/// Parameters of one axis drive derived from the machine model (SI, motor side), built once.
struct AxisServoModel {
  kinematics::Axis axis;  ///< the axis as loaded (drive, controller, effects)
  /// Gravity torque at the motor, the load's resistant torque [N m]:
  ///   tau_g(q) = gravity_constant + gravity_cos cos(q) + gravity_sin sin(q)  (rotary)
  ///   tau_g    = gravity_constant                                            (linear)
  /// r G_i(q) of the rigid-body model with the other axes held at `reference` (the start of
  /// the run): exact in q_i for that configuration (a prismatic joint's gravity force does not
  /// depend on its own position, a revolute joint's is a sinusoid of its angle).
  double gravity_constant_N_m = 0.0;
  double gravity_cos_N_m = 0.0;
  double gravity_sin_N_m = 0.0;
};

/// Builds the servo model of axis `axis_index`. `reference` is the configuration of the other
/// axes for the gravity torque (joint units, one per axis); with gravity = false or an axis whose
/// effects say gravity_compensated, the gravity terms are zero. Throws vmsim::InputError naming
/// the machine file, the axis, the field and the value when the loop periods are not whole
/// multiples of the fastest one, or the parameters do not make a usable drive.
AxisServoModel make_axis_servo_model(const kinematics::MachineModel& machine, int axis_index,
                                     const std::vector<double>& reference, bool gravity = true);

/// Signals of one axis at the record period. Joint units (m or rad, m/s or rad/s).
struct AxisSignals {
  std::vector<double> t;          ///< [s]
  std::vector<double> cmd;        ///< set point at t (fine interpolation, no delay)
  std::vector<double> pos;        ///< position from the encoder the loop is closed on
  std::vector<double> load_pos;   ///< actual load (table) position
  /// Motor encoder (quantised) times r: what a `.pos_motor` column logs [joint unit].
  std::vector<double> motor_pos;
  std::vector<double> vel;        ///< actual motor speed times r [joint unit / s]
  std::vector<double> current;    ///< actual torque-producing current [A]
  // Inner signals (filled when SimulationOptions::inner_signals):
  std::vector<double> following_error;       ///< cmd(t) - pos(t) [joint unit]
  std::vector<double> control_deviation;     ///< position controller input [joint unit]
  std::vector<double> velocity_setpoint;     ///< velocity controller set point [joint unit / s]
  std::vector<double> velocity_feedforward;  ///< w_v q_c' [joint unit / s]
  std::vector<double> torque_feedforward;    ///< [N m]
  std::vector<double> current_setpoint;      ///< after saturation [A]
};

/// The fastest loop period of an axis [s]: the velocity period, or the current period when
/// the current loop is a PI.
double base_period_s(const kinematics::Controller& controller);

/// Simulates one axis. Throws vmsim::InputError when the input is empty or not usable (period
/// <= 0, record period not a multiple of the fastest loop period).
AxisSignals simulate_axis(const AxisServoModel& model, const AxisInput& input,
                          const SimulationOptions& options = {});

/// One axis simulated window by window along its set points: the loop state (plant,
/// integrators, filters, delay lines, the set points still to be read) is kept between calls, so
/// that the records of the set points split into any windows are, bit for bit, those of
/// simulate_axis on the whole input (which runs on this class, in one window). Memory is bounded
/// by the window, not by the run.
///
/// A tick is simulated once the set points it reads are known (up to its time plus the delay and
/// one position period, and two more knots for the central differences): a window's records lag
/// its set points by that much; finish() simulates the rest, to the last set point plus
/// extra_time_s. The model is copied.
class AxisSimulator {
 public:
  /// Set points on the grid start_time_s + k period_s. Throws vmsim::InputError when
  /// period_s <= 0.
  AxisSimulator(const AxisServoModel& model, double start_time_s, double period_s,
                AxisInput::Kind kind = AxisInput::Kind::position, const SimulationOptions& options = {});
  ~AxisSimulator();
  AxisSimulator(AxisSimulator&&) noexcept;
  AxisSimulator& operator=(AxisSimulator&&) noexcept;

  /// Appends the next set points [joint unit, or joint unit / s for a velocity input] and,
  /// optionally, the external force on the load at each [N or N m] (with every window or with
  /// none), then simulates what they determine; its records are appended to `out`. Throws
  /// vmsim::InputError when the force's length differs from the set points' or after finish().
  void advance(std::span<const double> values, AxisSignals& out,
               std::span<const double> external_force = {});
  /// No more set points: simulates to the last one plus extra_time_s, appending to `out`.
  /// Throws vmsim::InputError when fewer than two set points were given, or the record period
  /// is not a whole multiple of the fastest loop period.
  void finish(AxisSignals& out, double extra_time_s = 0.0);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Several axes of a machine advanced together window by window (an AxisSimulator each, SI
/// joint units); a window's records are released once every axis has made them, so that all
/// axes' signals returned have the same samples (the axes' loops may lag their set points by
/// different amounts). The records of any split into windows are those of one window.
class MachineSimulator {
 public:
  /// `axes`: the machine's axes simulated (indices); `reference`: per machine axis, the
  /// configuration for the gravity torque (make_axis_servo_model). Throws vmsim::InputError as
  /// make_axis_servo_model and AxisSimulator do.
  MachineSimulator(const kinematics::MachineModel& machine, const std::vector<int>& axes,
                   const std::vector<double>& reference, double start_time_s, double period_s,
                   const SimulationOptions& options = {});
  ~MachineSimulator();
  MachineSimulator(MachineSimulator&&) noexcept;

  /// The next set points, one row per simulated axis (in the order of `axes`), one column per
  /// period; returns, per simulated axis, the records every axis has made so far and not yet
  /// returned (possibly none).
  std::vector<AxisSignals> advance(const Eigen::Ref<const Eigen::MatrixXd>& setpoints);
  /// No more set points: the remaining records.
  std::vector<AxisSignals> finish(double extra_time_s = 0.0);

 private:
  std::vector<AxisSignals> release(bool all);
  std::vector<AxisSimulator> axes_;
  std::vector<AxisSignals> ready_;  ///< per axis, records made and not yet released
  std::vector<double> row_;         ///< scratch: one axis's set points of a window
};

/// Moves the first `count` records of `from` (every signal it holds) to the end of `to`.
void move_records(AxisSignals& from, std::size_t count, AxisSignals& to);

/// The whole machine from a set-point trace (trace format, `<AXIS>.cmd` columns in mm or deg,
/// uniform period: shared/spec/trace-format.md). Every axis with a `.cmd` column is simulated;
/// the others are held at their home (for gravity). Output columns: t, and per simulated axis
/// `<AXIS>.cmd`, `.pos`, `.vel`, `.cur`, plus `.pos2` (the load position) where backlash,
/// compliance or pitch error make it differ from `.pos`; with inner signals
/// `<AXIS>_following_error`, `_control_deviation` (mm or deg), `_velocity_setpoint`,
/// `_velocity_feedforward` (mm/s or deg/s), `_torque_feedforward` (N m), `_current_setpoint` (A).
/// Throws vmsim::InputError naming `setpoints_file` when there is no `.cmd` column, fewer than
/// two samples, or a period that is not uniform (relative tolerance 1e-6; the message gives the
/// first offending line). `row_lines`, optional, gives the file line of each data row (the trace
/// does not keep them) so that messages can name the line. Throws vmsim::InfeasibleError naming
/// the file, line, axis and value when a set point lies outside its axis's travel.
Trace simulate_machine(const kinematics::MachineModel& machine, const Trace& setpoints,
                       const std::string& setpoints_file, const SimulationOptions& options = {},
                       const std::vector<int>& row_lines = {});

}  // namespace vmsim::servo
