// vmsim servo: the feed drive simulation of every axis with a set-point column, in the trace
// format (servo/README.md).
#include <algorithm>
#include <memory>
#include <sstream>

#include "commands.hpp"
#include "vmsim/common/errors.hpp"
#include "vmsim/common/files.hpp"
#include "vmsim/common/output_folder.hpp"
#include "vmsim/common/trace.hpp"
#include "vmsim/kinematics/machine_loader.hpp"
#include "vmsim/servo/servo.hpp"

namespace vmsim::app {
namespace {

struct ServoOptions {
  std::string machine_path;
  std::string setpoints_path;
  std::string out_path;
  double record_period_s = 0.0;
  bool inner_signals = false;
};

// File line of each data row (after the comments, the header and blank lines), for messages.
std::vector<int> data_row_lines(const std::string& text) {
  std::vector<int> lines;
  std::istringstream in(text);
  std::string line;
  int number = 0;
  bool header_seen = false;
  while (std::getline(in, line)) {
    ++number;
    const bool blank = line.find_first_not_of(" \t\r") == std::string::npos;
    if (blank) continue;
    if (!header_seen) {
      if (line.front() != '#') header_seen = true;
      continue;
    }
    lines.push_back(number);
  }
  return lines;
}

int run_servo(const ServoOptions& options, const CommandContext& context) {
  check_output_file(options.out_path, {options.machine_path, options.setpoints_path});  // before the work
  const kinematics::MachineModel machine = kinematics::load_machine(options.machine_path);
  for (const std::string& warning : machine.warnings) context.warn(warning);
  TraceReadOptions read_options;
  read_options.known_axes.emplace();
  for (const auto& axis : machine.axes) read_options.known_axes->insert(axis.name);
  const std::string text = read_file(options.setpoints_path);
  const Trace setpoints = parse_trace(text, options.setpoints_path, read_options);

  servo::SimulationOptions simulation;
  simulation.record_period_s = options.record_period_s;
  simulation.inner_signals = options.inner_signals;
  const Trace result = servo::simulate_machine(machine, setpoints, options.setpoints_path,
                                               simulation, data_row_lines(text));
  write_trace(options.out_path, result);
  context.say("wrote " + options.out_path + ": " + std::to_string(result.sample_count()) +
              " samples, " + std::to_string(result.columns.size()) + " columns");
  // A short summary: peak following error and current per simulated axis.
  for (const auto& axis : machine.axes) {
    const auto pos = result.column_index(axis.name + ".pos");
    if (!pos) continue;
    const auto& cmd = result.column(axis.name + ".cmd");
    const auto& p = result.values[*pos];
    const auto& cur = result.column(axis.name + ".cur");
    double error = 0.0, current = 0.0;
    for (std::size_t i = 0; i < p.size(); ++i) {
      error = std::max(error, std::abs(cmd[i] - p[i]));
      current = std::max(current, std::abs(cur[i]));
    }
    const bool linear = axis.type == kinematics::AxisType::linear;
    context.say("  " + axis.name + ": peak |cmd - pos| " +
                format_double(std::round(error * (linear ? 1e4 : 1e5)) / (linear ? 1e1 : 1e5)) +
                (linear ? " um" : " deg") + ", peak |current| " +
                format_double(std::round(current * 1e3) / 1e3) + " A");
  }
  return 0;
}

}  // namespace

void add_servo_command(CLI::App& app, CommandContext& context) {
  auto options = std::make_shared<ServoOptions>();
  CLI::App* command = app.add_subcommand(
      "servo",
      "feed drive simulation: how each axis follows its position set points (cascade control, "
      "drive mechanics, effects of the machine file)");
  command->add_option("--machine", options->machine_path, "machine description (YAML)")
      ->required()
      ->check(CLI::ExistingFile);
  command->add_option("--setpoints", options->setpoints_path,
                      "set points in the trace format: t [s] at a uniform period and "
                      "<AXIS>.cmd [mm or deg]")
      ->required()
      ->check(CLI::ExistingFile);
  command->add_option("--out", options->out_path,
                      "output trace (CSV): t, <AXIS>.cmd .pos .vel .cur (.pos2 for the load)")
      ->required();
  command->add_option("--record-period-s", options->record_period_s,
                      "period of the output samples [s], a multiple of the fastest loop period; "
                      "default: the set points' period");
  command->add_flag("--inner-signals", options->inner_signals,
                    "also write <AXIS>_following_error, _control_deviation, _velocity_setpoint, "
                    "_velocity_feedforward, _torque_feedforward, _current_setpoint");
  command->callback([options, &context] { context.result = run_servo(*options, context); });
}

}  // namespace vmsim::app
