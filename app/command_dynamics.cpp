// vmsim dynamics: each actuator's torque and torque rate, term by term, along a tool path at
// constant feed (first paper, Eq. 4-5 with s'' = s''' = 0, i.e. its Eq. 7-8).
#include <cmath>
#include <iomanip>
#include <sstream>

#include "chain_inputs.hpp"
#include "commands.hpp"
#include "effects_option.hpp"
#include "input_files.hpp"
#include "vmsim/common/files.hpp"
#include "vmsim/common/output_folder.hpp"
#include "vmsim/common/trace.hpp"
#include "vmsim/kinematics/dynamics.hpp"
#include "vmsim/kinematics/path_kinematics.hpp"

namespace vmsim::app {
namespace {

struct DynamicsOptions {
  ChainInputOptions inputs;
  std::string out_path;
  double feed_mm_per_min = 0.0;
  std::string effects = "all";
};

int run_dynamics(const DynamicsOptions& options, const CommandContext& context) {
  if (!(options.feed_mm_per_min > 0.0)) {
    throw CommandLineError("--feed-mm-per-min must be > 0, got " + format_double(options.feed_mm_per_min));
  }
  const kinematics::EffectSet effects = parse_effects(options.effects);
  const ChainInputs inputs = load_chain_inputs(options.inputs);
  for (const std::string& warning : inputs.warnings) context.warn(warning);
  check_output_file(options.out_path, chain_input_files(options.inputs, inputs));  // before the work
  const kinematics::PathKinematics path = kinematics::solve_path_kinematics(
      inputs.machine, inputs.path, inputs.q_start, inputs.tool_length_m,
      inputs.block_names);
  const double feed_m_per_s = options.feed_mm_per_min * 1e-3 / 60.0;
  const kinematics::DynamicsModel model(inputs.machine);
  const kinematics::TorqueProfile profile =
      kinematics::torque_profile_at_constant_feed(model, path, feed_m_per_s, effects);

  const std::size_t points = path.s_m.size();
  Trace trace;
  trace.metadata = {{"source", "vmsim dynamics (actuator torque at constant feed, Eq. 7-8)"},
                    {"machine", inputs.machine.source_file},
                    {"feed_mm_per_min", format_double(options.feed_mm_per_min)},
                    {"effects", options.effects}};
  std::vector<double> t(points), s_mm(points), line(points);
  for (std::size_t i = 0; i < points; ++i) {
    t[i] = path.s_m[i] / feed_m_per_s;
    s_mm[i] = path.s_m[i] * 1e3;
    const int block = inputs.path[i].block;
    line[i] = block >= 0 ? inputs.toolpath.blocks[static_cast<std::size_t>(block)].line : 0;
  }
  // Points that share s (an orientation change in place) would break the strictly increasing t.
  for (std::size_t i = 1; i < points; ++i) {
    if (!(t[i] > t[i - 1])) {
      throw InputError("the tool path changes orientation without moving the tip at " +
                       inputs.block_names[static_cast<std::size_t>(inputs.path[i].block)] +
                       ": constant feed along s is undefined there");
    }
  }
  trace.add_column("t", t);
  trace.add_column("s_mm", s_mm);
  trace.add_column("line", line);
  auto row = [](const Eigen::MatrixXd& matrix, std::size_t axis) {
    std::vector<double> values(static_cast<std::size_t>(matrix.cols()));
    for (std::size_t i = 0; i < values.size(); ++i) {
      values[i] = matrix(static_cast<Eigen::Index>(axis), static_cast<Eigen::Index>(i));
    }
    return values;
  };
  for (std::size_t j = 0; j < inputs.machine.axes.size(); ++j) {
    const std::string& name = inputs.machine.axes[j].name;
    trace.add_column(name + ".cmd", [&] {
      std::vector<double> values(points);
      for (std::size_t i = 0; i < points; ++i) {
        values[i] = to_trace_unit(inputs.machine.axes[j],
                                  path.q(static_cast<Eigen::Index>(j), static_cast<Eigen::Index>(i)));
      }
      return values;
    }());
    trace.add_column(name + ".torque", row(profile.total_torque_N_m, j));
    trace.add_column(name + "_torque_rate", row(profile.total_torque_rate_N_m_per_s, j));
    for (int e = 0; e < kinematics::kEffectCount; ++e) {
      const auto effect = static_cast<kinematics::Effect>(e);
      if (!effects.contains(effect)) continue;
      const std::string key(kinematics::effect_name(effect));
      trace.add_column(name + "_torque_" + key, row(profile.torque_N_m[static_cast<std::size_t>(e)], j));
      trace.add_column(name + "_torque_rate_" + key,
                       row(profile.torque_rate_N_m_per_s[static_cast<std::size_t>(e)], j));
    }
  }
  write_trace(options.out_path, trace);

  context.say("wrote " + options.out_path + ": " + std::to_string(points) + " points at " +
              format_double(options.feed_mm_per_min) + " mm/min, effects " + options.effects);
  context.say("axis   peak |torque| / limit [N m]      peak |torque rate| / limit [N m/s]");
  for (std::size_t j = 0; j < inputs.machine.axes.size(); ++j) {
    const auto& axis = inputs.machine.axes[j];
    const double peak_torque = profile.total_torque_N_m.row(static_cast<Eigen::Index>(j)).cwiseAbs().maxCoeff();
    const double peak_rate =
        profile.total_torque_rate_N_m_per_s.row(static_cast<Eigen::Index>(j)).cwiseAbs().maxCoeff();
    std::ostringstream text;
    text << std::left << std::setw(6) << axis.name << std::right << std::setw(10)
         << std::setprecision(4) << peak_torque << " / " << std::setw(8) << axis.drive.torque_max_N_m
         << "          " << std::setw(10) << peak_rate << " / " << std::setw(8)
         << axis.drive.torque_rate_max_N_m_per_s;
    context.say(text.str());
  }
  if (!path.corners.empty()) {
    context.say("note: " + std::to_string(path.corners.size()) +
                " corners (tangent discontinuities) on the path: at constant feed the torque "
                "there is not defined; values at corners use one-sided derivatives");
  }
  return 0;
}

}  // namespace

void add_dynamics_command(CLI::App& app, CommandContext& context) {
  auto options = std::make_shared<DynamicsOptions>();
  CLI::App* command = app.add_subcommand(
      "dynamics",
      "each actuator's torque and torque rate, term by term, along a tool path at constant feed");
  add_chain_input_options(*command, options->inputs);
  command->add_option("--feed-mm-per-min", options->feed_mm_per_min, "constant feed along the path")
      ->required();
  command->add_option("--effects", options->effects,
                      "effects switched on: H,Hcpl,B,C,G,F (inertia, coupled inertia, centrifugal, "
                      "Coriolis, gravity, friction) or all")
      ->capture_default_str();
  command->add_option("--out", options->out_path,
                      "output CSV: t, s_mm, line, <AXIS>.cmd, <AXIS>.torque, <AXIS>_torque_rate, "
                      "<AXIS>_torque_<effect>, <AXIS>_torque_rate_<effect>")
      ->required();
  command->callback([options, &context] { context.result = run_dynamics(*options, context); });
}

}  // namespace vmsim::app
