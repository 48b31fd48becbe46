#pragma once
// What several commands share: the machine, the tool path and the tool, from either a part file
// (--part) or from --machine, --toolpath and --tool-length-mm.
#include <CLI/CLI.hpp>
#include <string>
#include <vector>

#include "vmsim/kinematics/machine_model.hpp"
#include "vmsim/kinematics/path_kinematics.hpp"
#include "vmsim/planner/toolpath.hpp"

namespace vmsim::app {

struct ChainInputOptions {
  std::string part_path;
  std::string machine_path;
  std::string toolpath_path;
  double tool_length_mm = -1.0;
};

/// Adds --part, --machine, --toolpath, --tool-length-mm to a subcommand.
void add_chain_input_options(CLI::App& command, ChainInputOptions& options);

struct ChainInputs {
  kinematics::MachineModel machine;
  planner::Toolpath toolpath;
  double tool_length_m = 0.0;
  /// The tool path as poses for the kinematics; consecutive duplicate poses merged.
  std::vector<kinematics::PathPose> path;
  /// For each point of `path`, the index of the tool path point it came from.
  std::vector<std::size_t> toolpath_point;
  /// "file:line" (and " N<number>" where the block has one) for each tool path block.
  std::vector<std::string> block_names;
  /// Warnings for the user (reader warnings, merged points), each naming its file and line.
  std::vector<std::string> warnings;
};

/// Loads and checks everything; throws vmsim::InputError with file, line and value.
ChainInputs load_chain_inputs(const ChainInputOptions& options);

/// Joint value to the trace unit: mm for linear axes, deg for rotary axes.
double to_trace_unit(const kinematics::Axis& axis, double joint_value_si);

}  // namespace vmsim::app
