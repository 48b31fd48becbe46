#pragma once
// Identification of a feed-drive model from measured traces (the second paper, Sec. 3), and the
// diagnosis of what the identified model still gets wrong (identify/README.md: the method, the
// catalogue of effects, the outputs' schema).
//
// Units: SI inside, joint units (m or rad). The effort of an axis, whatever was logged (`.cur`
// [A], `.torque` [N m], `.force` [N]), is converted once to the equivalent torque-producing
// current [A] (torque / Kt, force r / Kt), the unit of the drive's friction parameters.
#include <string>
#include <vector>

#include "vmsim/common/trace.hpp"
#include "vmsim/kinematics/machine_model.hpp"
#include "vmsim/servo/servo.hpp"

namespace vmsim::identify {

/// The measured signals of one axis, on the trace's uniform time grid.
struct AxisMeasurement {
  std::string axis_name;
  int axis_index = -1;
  std::string source;         ///< file the data came from (messages)
  double period_s = 0.0;      ///< uniform sample period [s]
  std::vector<double> t;      ///< [s]
  std::vector<double> cmd;    ///< position set point [joint unit]
  std::vector<double> pos;    ///< measured position (the loop's encoder) [joint unit]
  std::vector<double> pos2;   ///< load-side position [joint unit]; empty when not logged
  /// Motor encoder times r [joint unit] where the loop is closed on a direct scale (`.pos` is
  /// then that scale); empty when not logged.
  std::vector<double> pos_motor;
  std::vector<double> effort_A;  ///< effort as equivalent current [A]
  std::string effort_signal;  ///< "cur", "torque" or "force"
};

/// The axes of `trace` that have `.cmd`, `.pos` and one effort column. Throws vmsim::InputError
/// naming `file` when no axis qualifies, the period is not uniform (relative tolerance 1e-6), or
/// a `.force` column belongs to a rotary axis.
std::vector<AxisMeasurement> extract_measurements(const kinematics::MachineModel& machine,
                                                  const Trace& trace, const std::string& file);

/// The drive model the identification and the diagnosis work on: the axis as in the machine file
/// plus a constant effort offset that the machine file has no key for (a gravity error on an axis
/// the rigid-body model says is level, a cable-chain force, ...).
struct DriveModel {
  servo::AxisServoModel servo;  ///< drive, controller, effects and the gravity torque
  double offset_A = 0.0;        ///< extra resistant effort, + along +q [A]
};

/// The drive model of an axis from the machine (gravity at the axes' home).
DriveModel make_drive_model(const kinematics::MachineModel& machine, int axis_index);
/// The same with the gravity torque of the configuration `reference` (one value per machine
/// axis, joint units): on a whole machine's trace the other axes stand where the trace has them
/// (a tilted cradle loads its axis otherwise than at home).
DriveModel make_drive_model(const kinematics::MachineModel& machine, int axis_index,
                            const std::vector<double>& reference);

/// The configuration a whole machine's trace works about: each axis's mean measured position
/// where `data` has the axis, its home otherwise [joint units, one per machine axis].
std::vector<double> reference_configuration(const kinematics::MachineModel& machine,
                                            const std::vector<AxisMeasurement>& data);

/// Closed-loop simulation of `model` driven by the measured set points, recorded on the
/// measurement's grid. A trace that starts or ends in motion is simulated with a lead-in and a
/// run-out at the speed of its first and last samples (0.3 s and 20 samples), so that the model
/// is in steady motion at the first sample and the last set point has two-sided differences. Throws vmsim::InputError when the trace period is not a whole multiple of
/// the drive's fastest loop period.
servo::AxisSignals simulate(const DriveModel& model, const AxisMeasurement& data);

/// Zero-phase low-pass (second-order Butterworth run forwards and backwards) with cutoff
/// `cutoff_hz`, for signals sampled at `period_s`; the ends are padded by reflection.
std::vector<double> zero_phase_lowpass(const std::vector<double>& x, double period_s,
                                       double cutoff_hz);

/// White-noise level of a residual [its unit]: RMS of the second difference / sqrt(6) (the
/// smooth part of a residual hardly enters a second difference).
double noise_level(const std::vector<double>& residual);

/// White-noise level of a measured signal itself [its unit], independent of any model: robust
/// scale (1.4826 x median absolute value) of its fourth difference / sqrt(70). Quantisation below
/// the noise counts as noise; a signal quantised far coarser than its noise gives about q/sqrt(12)
/// only where it changes (callers add the quantum's own share).
double robust_noise_level(const std::vector<double>& signal);

// ---------------------------------------------------------------------------------------------
// Identification (vmsim identify)

struct IdentifyOptions {
  /// Cutoff of the zero-phase filter applied to the measured position before differentiation
  /// and to the effort [Hz]; 0 = 8 % of the sample rate, at most 50 Hz.
  double filter_cutoff_hz = 0.0;
  /// Samples slower than this fraction of the peak commanded speed are left out of the friction
  /// fit (standstill and reversals, where the dry friction is undetermined).
  double standstill_fraction = 0.02;
  /// Delay scan: from 0 to this [s], then refined to 1 % of the trace period.
  double delay_max_s = 0.01;
  /// Gauss-Newton iterations of the output-error refinement of J, a, b and the offset on the
  /// closed-loop simulation after the inverse model; 0 = inverse model only.
  int output_error_iterations = 3;
  /// An axis whose commanded travel is below this [joint unit: m or rad] is held still in the
  /// trace (a rotary axis of a 3-axis part program): not identified.
  double least_travel = 1e-6;
};

/// Identified parameters of one axis and the fit quality.
struct AxisIdentification {
  std::string axis_name;
  int axis_index = -1;
  double equivalent_inertia_kg_m2 = 0.0;
  double friction_viscous_A_per_joint_unit_per_s = 0.0;  ///< a [A s/m or A s/rad]
  double friction_dry_A = 0.0;                           ///< b [A]
  double offset_A = 0.0;  ///< constant effort beyond the model's gravity [A]
  /// The model's gravity torque / Kt at the trace's mean position [A] (not fitted; the fit
  /// takes it at every sample's own position).
  double gravity_A = 0.0;
  double delay_s = 0.0;   ///< the controller's set-point delay
  std::size_t samples_used = 0;  ///< rows of the least-squares fit
  double r2 = 0.0;               ///< R^2 of the inverse-model fit (filtered effort)
  double residual_rms_A = 0.0;   ///< RMS of the inverse-model fit's residual [A]
  /// Closed-loop check: the measured effort minus the simulated one with the identified model.
  double simulation_effort_rms_A = 0.0;
  double simulation_effort_rms_before_A = 0.0;  ///< the same with the machine file's model
  double simulation_position_rms = 0.0;         ///< [joint unit]
  double simulation_position_rms_before = 0.0;
};

/// Identifies every axis present in `measurements` (several traces of one axis are stacked):
/// least squares of effort = J/(Kt r) q'' + a q' + b sign(q') + c on the zero-phase-filtered
/// measured motion, then the delay by a scan of the closed-loop simulation (effort and position),
/// then an output-error refinement of J, a, b, c on the closed-loop effort and the delay again.
/// The inverse-model fit's R^2 and residual are reported for the inverse model.
/// Axes held still in the trace are skipped and, with `held_axes`, named there; gravity is taken
/// at the trace's configuration (reference_configuration).
std::vector<AxisIdentification> identify_axes(const kinematics::MachineModel& machine,
                                              const std::vector<AxisMeasurement>& measurements,
                                              const IdentifyOptions& options = {},
                                              std::vector<std::string>* held_axes = nullptr);

/// Applies identified values to a machine model (drive a, b, J_eq, controller delay).
void apply_identification(kinematics::MachineModel& machine, const AxisIdentification& result);

// ---------------------------------------------------------------------------------------------
// Machine file output

/// Extra, per-axis values to note in a written machine file that has no key for them.
struct AxisNote {
  std::string axis_name;
  std::string text;
};

/// The machine file `original_yaml` with the drive, controller and effects of every axis of
/// `machine` written back (keys as the loader reads them, SI units in the key names). The result
/// is checked with kinematics::parse_machine; `notes` become comment lines at the top. Throws
/// vmsim::InputError when the text is not a machine file.
std::string updated_machine_yaml(const std::string& original_yaml,
                                 const kinematics::MachineModel& machine,
                                 const std::vector<AxisNote>& notes,
                                 const std::string& file_name_for_messages,
                                 const std::string& base_directory = ".");

}  // namespace vmsim::identify
