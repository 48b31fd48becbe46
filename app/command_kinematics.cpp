// vmsim kinematics: axis positions along a tool path (IKT), in the trace format, with the
// corners and singular zones found.
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <iostream>

#include "chain_inputs.hpp"
#include "commands.hpp"
#include "input_files.hpp"
#include "json_text.hpp"
#include "vmsim/common/files.hpp"
#include "vmsim/common/output_folder.hpp"
#include "vmsim/common/trace.hpp"
#include "vmsim/kinematics/path_kinematics.hpp"

namespace vmsim::app {
namespace {

struct KinematicsOptions {
  ChainInputOptions inputs;
  std::string out_path;
  std::string summary_path;
  double corner_angle_deg = 5.0;
};

// Time at the programmed feed, never faster than any axis's velocity limit: the `t` column of
// the output (the planner computes the real timing).
std::vector<double> nominal_time(const ChainInputs& inputs, const kinematics::PathKinematics& result) {
  std::vector<double> t(result.s_m.size(), 0.0);
  for (std::size_t i = 1; i < t.size(); ++i) {
    const toolpath::PathPoint& point = inputs.toolpath.points[inputs.toolpath_point[i]];
    double dt = 0.0;
    const double ds = result.s_m[i] - result.s_m[i - 1];
    if (point.inverse_time_feed_per_s > 0.0) {
      dt = 1.0 / point.inverse_time_feed_per_s;
    } else if (point.feed_m_per_s > 0.0) {
      dt = ds / point.feed_m_per_s;
    }
    for (std::size_t j = 0; j < inputs.machine.axes.size(); ++j) {
      const double dq = std::abs(result.q(static_cast<Eigen::Index>(j), static_cast<Eigen::Index>(i)) -
                                 result.q(static_cast<Eigen::Index>(j), static_cast<Eigen::Index>(i - 1)));
      dt = std::max(dt, dq / inputs.machine.axes[j].limits.velocity_max);
    }
    t[i] = t[i - 1] + std::max(dt, 1e-9);
  }
  return t;
}

int run_kinematics(const KinematicsOptions& options, const CommandContext& context) {
  const ChainInputs inputs = load_chain_inputs(options.inputs);
  for (const std::string& warning : inputs.warnings) context.warn(warning);
  if (!inputs.tool_roll.empty()) context.say("note: " + inputs.tool_roll);
  // The outputs are checked before the computation; with --summary both files are replaced
  // together or not at all.
  std::vector<std::string> out_paths = {options.out_path};
  if (!options.summary_path.empty()) out_paths.push_back(options.summary_path);
  OutputFileSet outputs(out_paths, chain_input_files(options.inputs, inputs));

  kinematics::PathKinematicsOptions path_options;
  path_options.corner_angle_rad = options.corner_angle_deg * M_PI / 180.0;
  const kinematics::PathKinematics result = kinematics::solve_path_kinematics(
      inputs.machine, inputs.path, inputs.q_start, inputs.tool_length_m,
      inputs.block_names, path_options);

  Trace trace;
  trace.metadata = {{"source", "vmsim kinematics (IKT of the tool path; t at the programmed feed)"},
                    {"machine", inputs.machine.source_file},
                    {"toolpath", inputs.toolpath.blocks.empty() ? "" : inputs.toolpath.blocks[0].file},
                    {"tool_length_mm", format_double(inputs.tool_length_m * 1e3)}};
  trace.add_column("t", nominal_time(inputs, result));
  std::vector<double> s_mm(result.s_m.size());
  std::vector<double> line(result.s_m.size());
  for (std::size_t i = 0; i < s_mm.size(); ++i) {
    s_mm[i] = result.s_m[i] * 1e3;
    const int block = inputs.path[i].block;
    line[i] = block >= 0 ? inputs.toolpath.blocks[static_cast<std::size_t>(block)].line : 0;
  }
  trace.add_column("s_mm", s_mm);
  if (!result.point_tool_length_m.empty()) {
    // Tools of different lengths: each point's (the metadata's tool_length_mm is the run's own).
    std::vector<double> length_mm(result.point_tool_length_m.size());
    for (std::size_t i = 0; i < length_mm.size(); ++i) length_mm[i] = result.point_tool_length_m[i] * 1e3;
    trace.add_column("tool_length_mm", length_mm);
  }
  trace.add_column("line", line);
  for (std::size_t j = 0; j < inputs.machine.axes.size(); ++j) {
    const kinematics::Axis& axis = inputs.machine.axes[j];
    std::vector<double> column(result.s_m.size());
    for (std::size_t i = 0; i < column.size(); ++i) {
      column[i] = to_trace_unit(axis, result.q(static_cast<Eigen::Index>(j), static_cast<Eigen::Index>(i)));
    }
    trace.add_column(axis.name + ".cmd", column);
  }

  nlohmann::json summary;
  summary["points"] = result.s_m.size();
  summary["length_mm"] = result.s_m.empty() ? 0.0 : result.s_m.back() * 1e3;
  summary["corners"] = nlohmann::json::array();
  for (const auto& corner : result.corners) {
    const int block = inputs.path[corner.point].block;
    summary["corners"].push_back({{"point", corner.point},
                                  {"s_mm", corner.s_m * 1e3},
                                  {"angle_deg", corner.angle_rad * 180.0 / M_PI},
                                  {"block", block >= 0 ? inputs.block_names[static_cast<std::size_t>(block)] : ""}});
  }
  summary["singular_zones"] = nlohmann::json::array();
  for (const auto& zone : result.singular_zones) {
    const int block = inputs.path[zone.first_point].block;
    summary["singular_zones"].push_back(
        {{"first_point", zone.first_point},
         {"last_point", zone.last_point},
         {"s_begin_mm", zone.s_begin_m * 1e3},
         {"s_end_mm", zone.s_end_m * 1e3},
         {"block", block >= 0 ? inputs.block_names[static_cast<std::size_t>(block)] : ""}});
  }
  summary["warnings"] = inputs.warnings;

  outputs.write(options.out_path, format_trace(trace));
  if (!options.summary_path.empty()) {
    outputs.write(options.summary_path, json_file_text(summary));
  }
  outputs.commit();
  context.say("wrote " + options.out_path + ": " + std::to_string(result.s_m.size()) +
              " points, path length " + format_double(std::round(result.s_m.back() * 1e6) / 1e3) +
              " mm");
  context.say("corners: " + std::to_string(result.corners.size()) +
              ", singular zones: " + std::to_string(result.singular_zones.size()));
  for (const auto& zone : summary["singular_zones"]) {
    context.say("  singular zone s = " + format_double(zone["s_begin_mm"].get<double>()) + " .. " +
                format_double(zone["s_end_mm"].get<double>()) + " mm, from " +
                zone["block"].get<std::string>());
  }
  return 0;
}

}  // namespace

void add_kinematics_command(CLI::App& app, CommandContext& context) {
  auto options = std::make_shared<KinematicsOptions>();
  CLI::App* command = app.add_subcommand(
      "kinematics",
      "axis positions along a tool path (inverse kinematics), as set points in the trace format");
  add_chain_input_options(*command, options->inputs);
  command->add_option("--out", options->out_path, "output trace (CSV): t, s_mm, line, <AXIS>.cmd")
      ->required();
  command->add_option("--summary", options->summary_path,
                      "optional JSON: corners and singular zones with their s and block");
  command->add_option("--corner-angle-deg", options->corner_angle_deg,
                      "turning angle of the tip tangent above which a point is a corner")
      ->capture_default_str();
  command->callback([options, &context] { context.result = run_kinematics(*options, context); });
}

}  // namespace vmsim::app
