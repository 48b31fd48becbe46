#include "chain_inputs.hpp"

#include <cmath>
#include <numbers>

#include "part_file.hpp"
#include "vmsim/common/errors.hpp"
#include "vmsim/kinematics/kinematics.hpp"
#include "vmsim/kinematics/machine_loader.hpp"

namespace vmsim::app {

void add_chain_input_options(CLI::App& command, ChainInputOptions& options) {
  command.add_option("--part", options.part_path,
                     "part file (part.yaml): gives the machine, tool path and tool")
      ->check(CLI::ExistingFile);
  command.add_option("--machine", options.machine_path, "machine description (YAML)")
      ->check(CLI::ExistingFile);
  command.add_option("--toolpath", options.toolpath_path, "tool path (APT/CL or G-code)")
      ->check(CLI::ExistingFile);
  command.add_option("--tool-length-mm", options.tool_length_mm,
                     "tool length from the spindle gauge point to the tool tip [mm]");
}

double to_trace_unit(const kinematics::Axis& axis, double joint_value_si) {
  return axis.type == kinematics::AxisType::linear ? joint_value_si * 1e3
                                                   : joint_value_si * 180.0 / std::numbers::pi;
}

namespace {

// Machine axis values from G-code words: letters must be axis names of the machine.
Eigen::VectorXd axes_from_words(const kinematics::MachineModel& machine,
                                const std::vector<std::pair<char, double>>& words) {
  Eigen::VectorXd q = machine.home_positions();
  for (const auto& [letter, value] : words) {
    const int index = machine.axis_index(std::string(1, letter));
    if (index < 0) {
      throw InputError("axis word " + std::string(1, letter) + " names no axis of the machine " +
                       machine.name + " (" + machine.source_file + ")");
    }
    const auto& axis = machine.axes[static_cast<std::size_t>(index)];
    q[index] = axis.type == kinematics::AxisType::linear ? value * 1e-3
                                                         : value * std::numbers::pi / 180.0;
  }
  return q;
}

}  // namespace

ChainInputs load_chain_inputs(const ChainInputOptions& options) {
  ChainInputs inputs;
  std::string machine_path = options.machine_path;
  std::string toolpath_path = options.toolpath_path;
  double tool_length_m = options.tool_length_mm >= 0.0 ? options.tool_length_mm * 1e-3 : -1.0;
  if (!options.part_path.empty()) {
    const PartDescription part = load_part(options.part_path);
    inputs.warnings.insert(inputs.warnings.end(), part.warnings.begin(), part.warnings.end());
    if (machine_path.empty()) machine_path = part.machine_path;
    if (toolpath_path.empty()) toolpath_path = part.toolpath_path;
    if (tool_length_m < 0.0) tool_length_m = part.tool.length_m;
  }
  if (machine_path.empty()) throw InputError("no machine: give --machine or --part");
  if (toolpath_path.empty()) throw InputError("no tool path: give --toolpath or --part");
  if (tool_length_m < 0.0) throw InputError("no tool length: give --tool-length-mm or --part");
  inputs.tool_length_m = tool_length_m;
  inputs.machine = kinematics::load_machine(machine_path);
  inputs.warnings.insert(inputs.warnings.end(), inputs.machine.warnings.begin(),
                         inputs.machine.warnings.end());

  planner::ReaderOptions reader;
  const kinematics::MachineModel& machine = inputs.machine;
  reader.rotary_words_to_tool_axis = [&machine, tool_length_m](const auto& words) {
    return kinematics::forward_kinematics(machine, axes_from_words(machine, words), tool_length_m)
        .axis_W;
  };
  reader.axis_words_to_pose = [&machine, tool_length_m](const auto& words) {
    const kinematics::ToolPose pose =
        kinematics::forward_kinematics(machine, axes_from_words(machine, words), tool_length_m);
    return planner::AxisWordPose{pose.tip_W_m, pose.axis_W};
  };
  inputs.toolpath = planner::read_toolpath(toolpath_path, reader);
  if (inputs.toolpath.points.empty()) {
    throw InputError(toolpath_path + ": the tool path has no motion");
  }
  for (const auto& warning : inputs.toolpath.warnings) {
    inputs.warnings.push_back(located_message(warning.file, warning.line, 0, warning.message));
  }
  if (options.corner_tolerance_m > 0.0) {
    planner::CornerBlendOptions blend;
    blend.tolerance_m = options.corner_tolerance_m;
    blend.axis_tolerance_rad = options.corner_axis_tolerance_rad;
    blend.corner_angle_rad = inputs.path_kinematics.corner_angle_rad;
    blend.corner_baseline_m = inputs.path_kinematics.fit_half_window_m;
    planner::CornerBlendResult result = planner::blend_corners(inputs.toolpath, blend);
    inputs.path_kinematics.fit_half_window_m =
        result.fit_half_window_m(inputs.path_kinematics.fit_half_window_m);
    inputs.toolpath = std::move(result.toolpath);
    inputs.blended_corners = std::move(result.blended);
    inputs.exact_stop_corners = std::move(result.exact_stops);
  }
  for (const auto& block : inputs.toolpath.blocks) {
    std::string name = block.file + ":" + std::to_string(block.line);
    if (block.block_number >= 0) name += " N" + std::to_string(block.block_number);
    inputs.block_names.push_back(name);
  }
  // Consecutive identical poses carry no motion: merge them, and say so.
  for (std::size_t i = 0; i < inputs.toolpath.points.size(); ++i) {
    const planner::PathPoint& point = inputs.toolpath.points[i];
    if (!inputs.path.empty()) {
      const kinematics::ToolPose& last = inputs.path.back().pose;
      if ((last.tip_W_m - point.tip_W_m).norm() < 1e-12 &&
          (last.axis_W - point.axis_W).norm() < 1e-12) {
        const auto& block = inputs.toolpath.blocks[static_cast<std::size_t>(point.block)];
        inputs.warnings.push_back(located_message(block.file, block.line, 0,
                                                  "repeats the previous pose; merged with it"));
        continue;
      }
    }
    inputs.path.push_back({{point.tip_W_m, point.axis_W}, point.block});
    inputs.toolpath_point.push_back(i);
  }
  return inputs;
}

}  // namespace vmsim::app
