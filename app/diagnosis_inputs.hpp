#pragma once
// What `vmsim diagnose` and `vmsim calibrate` share: the options naming the machine, the measured
// traces and the catalogue, and the reading of those inputs. Header-only: only the commands
// (linked with vmsim::identify) include it.
#include <CLI/CLI.hpp>

#include <string>
#include <vector>

#include "commands.hpp"
#include "vmsim/common/trace.hpp"
#include "vmsim/identify/diagnose.hpp"
#include "vmsim/kinematics/machine_loader.hpp"

namespace vmsim::app {

struct DiagnosisInputOptions {
  std::string machine_path;
  std::string trace_path;
  std::string validate_path;  ///< "": held-out blocks of the trace
  std::vector<std::string> exclude;
  int max_effects = 4;
};

/// --machine, --trace, --validate, --exclude, --max-effects.
inline void add_diagnosis_input_options(CLI::App& command, DiagnosisInputOptions& options,
                                        const std::string& machine_help, const std::string& trace_help) {
  command.add_option("--machine", options.machine_path, machine_help)->required()->check(CLI::ExistingFile);
  command.add_option("--trace", options.trace_path, trace_help)->required()->check(CLI::ExistingFile);
  command.add_option("--validate", options.validate_path,
                     "a second measured run to judge on (default: held-out blocks of --trace)")
      ->check(CLI::ExistingFile);
  command.add_option("--exclude", options.exclude, "effects to leave out of the catalogue (e.g. current_saturation)");
  command.add_option("--max-effects", options.max_effects, "at most this many effects per axis")
      ->check(CLI::Range(0, 12));
}

struct DiagnosisInputs {
  kinematics::MachineModel machine;
  std::vector<identify::AxisMeasurement> data, validation;
};

/// The machine (its warnings said) and the measured traces, every input checked.
inline DiagnosisInputs load_diagnosis_inputs(const DiagnosisInputOptions& options, const CommandContext& context) {
  DiagnosisInputs inputs;
  inputs.machine = kinematics::load_machine(options.machine_path);
  for (const std::string& warning : inputs.machine.warnings) context.warn(warning);
  TraceReadOptions read_options;
  read_options.known_axes.emplace();
  for (const auto& axis : inputs.machine.axes) read_options.known_axes->insert(axis.name);
  inputs.data = identify::extract_measurements(inputs.machine, read_trace(options.trace_path, read_options),
                                               options.trace_path);
  if (!options.validate_path.empty()) {
    inputs.validation = identify::extract_measurements(
        inputs.machine, read_trace(options.validate_path, read_options), options.validate_path);
  }
  return inputs;
}

/// The catalogue's options from the command line.
inline identify::DiagnoseOptions catalogue_options(const DiagnosisInputOptions& options) {
  identify::DiagnoseOptions diagnose_options;
  diagnose_options.excluded = options.exclude;
  diagnose_options.max_effects = options.max_effects;
  return diagnose_options;
}

}  // namespace vmsim::app
