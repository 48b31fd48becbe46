// vmsim diagnose: where the drive simulation driven by the measured set points is wrong, which
// effects explain it, and the extended model with its gain on held-out data (identify/README.md).
#include <filesystem>
#include <memory>
#include <sstream>

#include "commands.hpp"
#include "vmsim/common/errors.hpp"
#include "vmsim/common/files.hpp"
#include "vmsim/common/output_folder.hpp"
#include "vmsim/common/trace.hpp"
#include "vmsim/identify/diagnose.hpp"
#include "vmsim/kinematics/machine_loader.hpp"

namespace vmsim::app {
namespace {

struct DiagnoseCommandOptions {
  std::string machine_path;
  std::string trace_path;
  std::string validate_path;
  std::string out_dir;
  std::vector<std::string> exclude;
  int max_effects = 4;
  double effort_noise_A = 0.0;
  double position_noise_um = 0.0;
  double tool_length_mm = 0.0;
};

int run_diagnose(const DiagnoseCommandOptions& options, const CommandContext& context) {
  OutputFolder output(options.out_dir, {options.machine_path, options.trace_path, options.validate_path},
                      {"diagnose", VMSIM_VERSION});
  const kinematics::MachineModel machine = kinematics::load_machine(options.machine_path);
  for (const std::string& warning : machine.warnings) context.warn(warning);
  TraceReadOptions read_options;
  read_options.known_axes.emplace();
  for (const auto& axis : machine.axes) read_options.known_axes->insert(axis.name);
  const auto data = identify::extract_measurements(
      machine, read_trace(options.trace_path, read_options), options.trace_path);
  std::vector<identify::AxisMeasurement> validation;
  if (!options.validate_path.empty()) {
    validation = identify::extract_measurements(
        machine, read_trace(options.validate_path, read_options), options.validate_path);
  }
  identify::DiagnoseOptions diagnose_options;
  diagnose_options.excluded = options.exclude;
  diagnose_options.max_effects = options.max_effects;
  diagnose_options.effort_noise_A = options.effort_noise_A;
  // um -> m on a linear axis; the same factor reads urad -> rad on a rotary one.
  diagnose_options.position_noise = options.position_noise_um * 1e-6;
  diagnose_options.tool_length_m = options.tool_length_mm * 1e-3;
  const identify::Diagnosis diagnosis =
      identify::diagnose(machine, data, validation, diagnose_options);
  std::vector<identify::AxisNote> notes;
  const kinematics::MachineModel extended = identify::extended_machine(machine, diagnosis, notes);
  const std::string parent = std::filesystem::path(options.machine_path).parent_path().string();
  const std::string yaml =
      identify::updated_machine_yaml(read_file(options.machine_path), extended, notes,
                                     options.machine_path, parent.empty() ? "." : parent);
  const std::string json = identify::diagnosis_json(diagnosis, machine, options.trace_path);
  const std::string report = identify::diagnosis_report(diagnosis, machine, options.trace_path);
  const std::string residuals = identify::residuals_csv(diagnosis, machine);
  // Everything computed: into the staging folder, then the set swapped in.
  write_file_atomically(output.path_of("diagnosis.json"), json);
  write_file_atomically(output.path_of("machine_extended.yaml"), yaml);
  write_file_atomically(output.path_of("residuals.csv"), residuals);
  write_file_atomically(output.path_of("report.md"), report);
  output.commit();
  context.say("wrote " + options.out_dir + "/{diagnosis.json, machine_extended.yaml, "
              "residuals.csv, report.md}");
  for (const auto& axis : diagnosis.axes) {
    std::ostringstream line;
    line << "  " << axis.axis_name << ": ";
    if (axis.found.empty()) line << "no effect of the catalogue found";
    for (std::size_t i = 0; i < axis.found.size(); ++i) {
      line << (i ? ", " : "found ") << axis.found[i].effect;
    }
    line.precision(4);
    line << "; validation effort residual RMS " << axis.before.effort_rms_A << " -> "
         << axis.after.effort_rms_A << " A";
    context.say(line.str());
    context.say("    " + axis.unexplained.sentence);
  }
  for (const auto& held : diagnosis.held_axes) context.say("  " + held.axis_name + ": " + held.reason);
  if (diagnosis.contour.computed) {
    const auto& tip = diagnosis.contour;
    std::ostringstream line;
    line.precision(3);
    line << "  tool tip contour error: measured " << tip.measured_rms_um << " um RMS ("
         << tip.measured_peak_um << " peak); measured minus simulated " << tip.residual_before_rms_um
         << " -> " << tip.residual_after_rms_um << " um RMS";
    context.say(line.str());
  }
  return 0;
}

}  // namespace

void add_diagnose_command(CLI::App& app, CommandContext& context) {
  auto options = std::make_shared<DiagnoseCommandOptions>();
  CLI::App* command = app.add_subcommand(
      "diagnose",
      "compare the drive simulation with a measured trace, find the effects the model lacks, "
      "extend it and report the gain on held-out data");
  command->add_option("--machine", options->machine_path, "machine description (YAML)")
      ->required()
      ->check(CLI::ExistingFile);
  command->add_option("--trace", options->trace_path,
                      "measured trace: t, <AXIS>.cmd, .pos, .cur/.torque/.force (.pos2 if a "
                      "load-side scale was logged)")
      ->required()
      ->check(CLI::ExistingFile);
  command->add_option("--validate", options->validate_path,
                      "a second measured run to judge on (default: held-out blocks of --trace)")
      ->check(CLI::ExistingFile);
  command->add_option("--out", options->out_dir,
                      "output folder (new, empty or a previous vmsim result: replaced as a whole): "
                      "diagnosis.json, machine_extended.yaml, residuals.csv, report.md")
      ->required();
  command->add_option("--exclude", options->exclude,
                      "effects to leave out of the catalogue (e.g. current_saturation)");
  command->add_option("--max-effects", options->max_effects, "at most this many effects per axis")
      ->check(CLI::Range(0, 12));
  command->add_option("--effort-noise-A", options->effort_noise_A,
                      "white-noise level of the measured effort [A]; default: estimated from the "
                      "measured signal itself")
      ->check(CLI::PositiveNumber);
  command->add_option("--position-noise-um", options->position_noise_um,
                      "noise of the measured position [um; urad on a rotary axis]; default: "
                      "estimated from the measured signal, at least the encoder quantum / sqrt(12)")
      ->check(CLI::PositiveNumber);
  command->add_option("--tool-length-mm", options->tool_length_mm,
                      "tool length for the tool tip's contour error on a whole machine's trace "
                      "[mm]; default 0: the spindle gauge point")
      ->check(CLI::NonNegativeNumber);
  command->callback([options, &context] { context.result = run_diagnose(*options, context); });
}

}  // namespace vmsim::app
