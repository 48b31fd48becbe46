// vmsim identify: the drive parameters of each axis (friction, inertia, offset, delay) from
// measured traces, written into an updated machine file (identify/README.md).
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>

#include "commands.hpp"
#include "vmsim/common/errors.hpp"
#include "vmsim/common/files.hpp"
#include "vmsim/common/output_folder.hpp"
#include "vmsim/common/trace.hpp"
#include "vmsim/identify/identify.hpp"
#include "vmsim/kinematics/machine_loader.hpp"

namespace vmsim::app {
namespace {

struct IdentifyCommandOptions {
  std::string machine_path;
  std::vector<std::string> trace_paths;
  std::string out_path;
  double filter_cutoff_hz = 0.0;
};

// Four significant digits, for messages and comments.
std::string short_number(double v) {
  char text[32];
  std::snprintf(text, sizeof text, "%.4g", v);
  return text;
}

std::string directory_of(const std::string& path) {
  const std::string parent = std::filesystem::path(path).parent_path().string();
  return parent.empty() ? "." : parent;
}

int run_identify(const IdentifyCommandOptions& options, const CommandContext& context) {
  std::vector<std::string> input_files = options.trace_paths;
  input_files.push_back(options.machine_path);
  check_output_file(options.out_path, input_files);  // before the work: never an input
  kinematics::MachineModel machine = kinematics::load_machine(options.machine_path);
  for (const std::string& warning : machine.warnings) context.warn(warning);
  TraceReadOptions read_options;
  read_options.known_axes.emplace();
  for (const auto& axis : machine.axes) read_options.known_axes->insert(axis.name);
  std::vector<identify::AxisMeasurement> data;
  for (const auto& path : options.trace_paths) {
    auto axes = identify::extract_measurements(machine, read_trace(path, read_options), path);
    data.insert(data.end(), axes.begin(), axes.end());
  }
  identify::IdentifyOptions identify_options;
  identify_options.filter_cutoff_hz = options.filter_cutoff_hz;
  std::vector<std::string> held_axes;
  const auto results = identify::identify_axes(machine, data, identify_options, &held_axes);
  if (results.empty() && !held_axes.empty()) {
    throw vmsim::InputError(options.trace_paths.front() + ": every axis of the trace is held still (" +
                     held_axes.front() + " ...): nothing to identify");
  }
  std::vector<identify::AxisNote> notes;
  for (const auto& r : results) {
    identify::apply_identification(machine, r);
    const bool linear = machine.axes[static_cast<std::size_t>(r.axis_index)].type ==
                        kinematics::AxisType::linear;
    const double k = linear ? 1e3 : 180.0 / 3.141592653589793;
    const std::string u = linear ? " mm" : " deg";
    notes.push_back({r.axis_name, "identified from " + std::to_string(r.samples_used) +
                                      " samples: R^2 " + short_number(r.r2) +
                                      ", residual RMS " + short_number(r.residual_rms_A) + " A"});
    notes.push_back({r.axis_name, "closed-loop effort residual RMS " +
                                      short_number(r.simulation_effort_rms_before_A) + " -> " +
                                      short_number(r.simulation_effort_rms_A) +
                                      " A, position residual RMS " +
                                      short_number(r.simulation_position_rms_before * k) + " -> " +
                                      short_number(r.simulation_position_rms * k) + u});
    if (std::abs(r.offset_A) > 0.01 * r.friction_dry_A + 1e-3) {
      notes.push_back({r.axis_name, "constant effort offset " + short_number(r.offset_A) +
                                        " A beyond the model's gravity (" +
                                        short_number(r.gravity_A) +
                                        " A): the machine file has no key for it"});
    }
  }
  const std::string text = identify::updated_machine_yaml(
      read_file(options.machine_path), machine, notes, options.machine_path,
      directory_of(options.machine_path));
  write_file_atomically(options.out_path, text);
  context.say("wrote " + options.out_path);
  for (const auto& name : held_axes) context.say("  " + name + ": held still in the trace, left as it was");
  for (const auto& r : results) {
    context.say("  " + r.axis_name + ": J_eq " + short_number(r.equivalent_inertia_kg_m2) +
                " kg m^2, viscous " + short_number(r.friction_viscous_A_per_joint_unit_per_s) +
                " A s/unit, dry " + short_number(r.friction_dry_A) + " A, offset " +
                short_number(r.offset_A) + " A, delay " + short_number(r.delay_s * 1e3) +
                " ms; R^2 " + short_number(r.r2) + ", residual RMS " +
                short_number(r.residual_rms_A) + " A; closed-loop effort RMS " +
                short_number(r.simulation_effort_rms_before_A) + " -> " +
                short_number(r.simulation_effort_rms_A) + " A");
  }
  return 0;
}

}  // namespace

void add_identify_command(CLI::App& app, CommandContext& context) {
  auto options = std::make_shared<IdentifyCommandOptions>();
  CLI::App* command = app.add_subcommand(
      "identify",
      "identify each axis's friction, inertia, offset and delay from measured traces (least "
      "squares on the effort, delay by closed-loop simulation)");
  command->add_option("--machine", options->machine_path, "machine description (YAML)")
      ->required()
      ->check(CLI::ExistingFile);
  command->add_option("--trace", options->trace_paths,
                      "measured trace(s): t, <AXIS>.cmd, .pos and .cur, .torque or .force; "
                      "repeat for several runs")
      ->required()
      ->check(CLI::ExistingFile);
  command->add_option("--out", options->out_path, "updated machine file (YAML)")->required();
  command->add_option("--filter-cutoff-hz", options->filter_cutoff_hz,
                      "zero-phase low-pass before differentiating the measured position; "
                      "default 8 % of the sample rate, at most 50 Hz");
  command->callback([options, &context] { context.result = run_identify(*options, context); });
}

}  // namespace vmsim::app
