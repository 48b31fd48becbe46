// vmsim diagnose: where the drive simulation driven by the measured set points is wrong, which
// effects explain it, and the extended model with its gain on held-out data (identify/README.md).
#include <filesystem>
#include <memory>
#include <sstream>

#include "commands.hpp"
#include "diagnosis_inputs.hpp"
#include "vmsim/common/errors.hpp"
#include "vmsim/common/files.hpp"
#include "vmsim/common/output_folder.hpp"
#include "vmsim/common/trace.hpp"
#include "vmsim/identify/diagnose.hpp"
#include "vmsim/kinematics/machine_loader.hpp"

namespace vmsim::app {
namespace {

struct DiagnoseCommandOptions {
  DiagnosisInputOptions inputs;
  std::string out_dir;
  double effort_noise_A = 0.0;
  double position_noise_um = 0.0;
  double tool_length_mm = 0.0;
};
int run_diagnose(const DiagnoseCommandOptions& options, const CommandContext& context) {
  const DiagnosisInputOptions& in = options.inputs;
  OutputFolder output(options.out_dir, {in.machine_path, in.trace_path, in.validate_path}, {"diagnose", VMSIM_VERSION});
  const DiagnosisInputs inputs = load_diagnosis_inputs(options.inputs, context);
  const kinematics::MachineModel& machine = inputs.machine;
  identify::DiagnoseOptions diagnose_options = catalogue_options(options.inputs);
  diagnose_options.effort_noise_A = options.effort_noise_A;
  // um -> m on a linear axis; the same factor reads urad -> rad on a rotary one.
  diagnose_options.position_noise = options.position_noise_um * 1e-6;
  diagnose_options.tool_length_m = options.tool_length_mm * 1e-3;
  const identify::Diagnosis diagnosis =
      identify::diagnose(machine, inputs.data, inputs.validation, diagnose_options);
  std::vector<identify::AxisNote> notes;
  const kinematics::MachineModel extended = identify::extended_machine(machine, diagnosis, notes);
  const std::string parent = std::filesystem::path(options.inputs.machine_path).parent_path().string();
  const std::string yaml =
      identify::updated_machine_yaml(read_file(options.inputs.machine_path), extended, notes,
                                     options.inputs.machine_path, parent.empty() ? "." : parent);
  const std::string json = identify::diagnosis_json(diagnosis, machine, options.inputs.trace_path);
  const std::string report = identify::diagnosis_report(diagnosis, machine, options.inputs.trace_path);
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
  add_diagnosis_input_options(*command, options->inputs, "machine description (YAML)",
                              "measured trace: t, <AXIS>.cmd, .pos, .cur/.torque/.force (.pos2 if a "
                              "load-side scale was logged)");
  command->add_option("--out", options->out_dir,
                      "output folder (new, empty or a previous vmsim result: replaced as a whole): "
                      "diagnosis.json, machine_extended.yaml, residuals.csv, report.md")
      ->required();
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
