#pragma once
// Diagnosis of a drive model against measurements: where the simulation driven by the measured
// set points is wrong, which effect of a catalogue explains it, and how much the model extended
// with the effects found gains on data not used for fitting (identify/README.md).
//
// Evidence: the effort residual (measured - simulated, equivalent current [A]) first, and the
// load-minus-motor position residual when a load-side scale (`.pos2`) was logged. Both are
// weighted by their noise level, so the cost of a model is sum((residual / noise)^2).
#include <map>
#include <string>
#include <vector>

#include "vmsim/identify/identify.hpp"

namespace vmsim::identify {

/// The catalogue, in the order it is tried.
const std::vector<std::string>& effect_keys();

struct DiagnoseOptions {
  /// Held-out part when no validation trace is given: the trace is cut into this many blocks of
  /// equal length and every second one is held out.
  int blocks = 10;
  /// An effect is found when, in one evidence channel (effort, or load minus motor), its
  /// validation gain exceeds the penalty k ln(N_val) (k added parameters, N_val effective
  /// validation samples, cost in noise units) and three times the cost change of a noise
  /// control (the model perturbed by amounts that explain nothing), the other channel does not
  /// get worse beyond the same margin, and that channel's validation cost falls by at least
  /// this fraction.
  double minimum_relative_gain = 0.05;
  /// At most this many effects are added per axis (forward selection).
  int max_effects = 4;
  /// Effects to leave out of the catalogue (keys of effect_keys()).
  std::vector<std::string> excluded;
  /// White-noise level of the measured effort [A] (equivalent current); 0 = estimated from the
  /// measured signal itself (robust scale of its fourth difference), never from a residual, so
  /// that model error cannot raise it.
  double effort_noise_A = 0.0;
  /// Noise of the measured position [joint unit: m or rad]; 0 = estimated likewise, at least
  /// the encoder's quantum / sqrt(12).
  double position_noise = 0.0;
  /// Samples this close to either end of a trace are left out of fit and validation [s] (the
  /// filter's edges; the simulation itself starts in steady motion, see simulate()).
  double edge_s = 0.02;
  /// A residual left after the found effects is "unexplained" when its RMS on the validation
  /// samples exceeds this many noise levels (effort: the low-passed residual against the
  /// low-passed noise; load minus motor: raw).
  double unexplained_noise_units = 3.0;
  /// An axis whose commanded travel in the trace is below this is held still (a rotary axis of
  /// a 3-axis program): listed in Diagnosis::held_axes, not diagnosed [m] / [rad].
  double least_travel_m = 1e-6;
  double least_travel_rad = 1e-6;
  /// Tool length for the tool tip's contour error (kinematics::forward_kinematics) [m]; 0 = the
  /// spindle gauge point.
  double tool_length_m = 0.0;
};

/// One candidate effect fitted on the fit data and judged on the validation data.
struct CandidateResult {
  std::string effect;
  std::map<std::string, double> parameters;  ///< names carry their units
  int parameter_count = 0;
  double validation_cost_before = 0.0;  ///< in noise units
  double validation_cost_after = 0.0;
  /// 1 - after / before on the evidence channel of the score (effort, or load minus motor)
  double relative_gain = 0.0;
  /// Per channel: before - after - max(k ln(N_val), 3 x the noise control's cost change); the
  /// better channel's value, or negative when the other channel gets worse beyond its noise.
  double score = 0.0;
  bool found = false;
  std::string evidence;  ///< what the residual shows for this effect, one sentence
  /// The channel the score was taken on: "effort", "load_minus_motor" or "position".
  std::string channel;
  /// Non-empty when a fitted parameter stayed on a bound of its scan, or a plausibility rule
  /// rejected the fit (e.g. a force carried by a position channel that the effort does not
  /// confirm): the candidate is then rejected whatever its gain.
  std::string bound_note;
};

/// What is left after the found effects, on the validation samples, against the noise.
struct Unexplained {
  bool present = false;  ///< above options.unexplained_noise_units on a channel
  double effort_noise_units = 0.0;  ///< RMS of the low-passed residual / low-passed noise
  double effort_rms_A = 0.0;
  double load_diff_noise_units = 0.0;  ///< 0 without a second measuring system
  double load_diff_rms = 0.0;          ///< [joint unit]
  double position_noise_units = 0.0;   ///< information: the loop hides model errors here
  double position_rms = 0.0;           ///< [joint unit]
  /// Where the largest share of the effort residual's excess lies: a time span, its dominant
  /// phase and the position range there.
  double t_from_s = 0.0, t_to_s = 0.0;
  std::string phase;
  double position_from = 0.0, position_to = 0.0;  ///< [joint unit]
  double span_share = 0.0;  ///< that span's share of the residual's excess energy
  std::string sentence;     ///< the verdict, one sentence
};

/// Residual statistics of one class of samples.
struct PhaseStatistics {
  std::string phase;  ///< standstill, constant_velocity, acceleration, reversal
  std::size_t samples = 0;
  double effort_rms_A = 0.0, effort_mean_A = 0.0, effort_peak_A = 0.0;
  double position_rms = 0.0;  ///< [joint unit]
};

/// Share of the effort residual's variance a regressor family explains.
struct Relation {
  std::string against;  ///< e.g. sign_velocity, position_mod_lead
  double r2 = 0.0;
  std::string note;
};

struct ResidualSummary {
  double effort_rms_A = 0.0, effort_peak_A = 0.0;
  double position_rms = 0.0, position_peak = 0.0;       ///< pos residual [joint unit]
  double load_diff_rms = 0.0, load_diff_peak = 0.0;     ///< (pos2 - pos) residual
  double weighted_rms = 0.0;  ///< sqrt(cost / N): 1 = noise level
};

struct AxisDiagnosis {
  std::string axis_name;
  int axis_index = -1;
  std::string effort_signal;
  double effort_noise_A = 0.0;  ///< white-noise level of the raw effort residual
  /// The same after the zero-phase low-pass the effort residual is judged with.
  double effort_noise_filtered_A = 0.0;
  double load_diff_noise = 0.0;  ///< 0 when no .pos2
  double position_noise = 0.0;   ///< noise of the measured position [joint unit]
  /// "measured signals" (estimated from them) or "given" (options).
  std::string noise_source;
  std::size_t fit_samples = 0, validation_samples = 0;
  /// Largest change of the validation cost under model changes that explain nothing (first
  /// round): what noise alone gives.
  double noise_control_cost = 0.0;
  double validation_cost_before = 0.0;  ///< baseline, in noise units
  std::vector<PhaseStatistics> phases;  ///< of the baseline residual, all samples
  std::vector<Relation> relations;      ///< of the baseline effort residual
  std::vector<CandidateResult> first_round;  ///< every candidate against the baseline, ranked
  std::vector<CandidateResult> found;        ///< in the order forward selection added them
  ResidualSummary before, after;             ///< on the validation samples
  Unexplained unexplained;                   ///< what the found effects leave
  DriveModel extended;
  // Residual series for residuals.csv (validation data or the whole trace).
  std::vector<double> t, effort_before, effort_after, position_before, position_after;
};

/// The tool tip's contour error on a whole machine's trace: the tip through the direct
/// kinematics of the commanded axes, of the measured ones, and of the simulated ones before and
/// after the found effects (simulated = measured - position residual). Each deviation is taken
/// square to the commanded tip's direction of motion (the lag along the path leaves no mark);
/// where the tip stands, whole. Statistics over the judged samples less the trace's edges.
struct ContourError {
  bool computed = false;
  std::string note;  ///< why not computed
  double tool_length_m = 0.0;
  std::size_t samples = 0;
  double measured_rms_um = 0.0, measured_peak_um = 0.0;  ///< tip(pos) vs tip(cmd)
  /// What the model predicts: tip(simulated) vs tip(cmd), before and after the found effects.
  double predicted_before_rms_um = 0.0, predicted_before_peak_um = 0.0;
  double predicted_after_rms_um = 0.0, predicted_after_peak_um = 0.0;
  /// What the model misses: tip(pos) vs tip(simulated), before and after.
  double residual_before_rms_um = 0.0, residual_before_peak_um = 0.0;
  double residual_after_rms_um = 0.0, residual_after_peak_um = 0.0;
  std::vector<double> t, measured_um, predicted_before_um, predicted_after_um,
      residual_before_um, residual_after_um;  ///< per sample [um]
};

/// An axis of the trace that was not diagnosed, and why.
struct HeldAxis {
  std::string axis_name;
  std::string reason;
};

struct Diagnosis {
  std::vector<AxisDiagnosis> axes;
  std::vector<HeldAxis> held_axes;  ///< in the trace but held still
  ContourError contour;             ///< the tool tip (whole-machine traces)
  std::string validation;  ///< "held-out blocks" or the validation file
};

/// Diagnoses every axis of `data` (the fitting trace). With `validation` non-empty (same axes,
/// another run) it judges there; otherwise on held-out blocks of `data`.
Diagnosis diagnose(const kinematics::MachineModel& machine, const std::vector<AxisMeasurement>& data,
                   const std::vector<AxisMeasurement>& validation,
                   const DiagnoseOptions& options = {});

/// diagnosis.json (schema in identify/README.md), report.md and residuals.csv texts.
std::string diagnosis_json(const Diagnosis& diagnosis, const kinematics::MachineModel& machine,
                           const std::string& trace_file);
std::string diagnosis_report(const Diagnosis& diagnosis, const kinematics::MachineModel& machine,
                             const std::string& trace_file);
std::string residuals_csv(const Diagnosis& diagnosis, const kinematics::MachineModel& machine);

/// The machine with every axis replaced by its extended model; offsets go to `notes`.
kinematics::MachineModel extended_machine(const kinematics::MachineModel& machine,
                                          const Diagnosis& diagnosis,
                                          std::vector<AxisNote>& notes);

}  // namespace vmsim::identify
