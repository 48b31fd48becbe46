#pragma once
// The part file's tools in the removal: the tool of each path point's motion (PathPoint::
// tool_number through the part file's `tools:` table) and cutting a trajectory stretch by
// stretch with the tool in the spindle.
#include <cstddef>
#include <functional>
#include <vector>

#include "chain_inputs.hpp"
#include "part_file.hpp"
#include "vmsim/removal/nbuffer.hpp"
#include "vmsim/removal/tool.hpp"

namespace vmsim::app {

/// The removal tool of a part file's tool: its cutting body only (cutting_length_m where given,
/// else length_m). Throws vmsim::InputError when the tool is not valid.
removal::Tool removal_tool(const ToolDescription& description);

/// The removal tool of each point of inputs.path: the part file's `tool` where the program
/// selects none (tool_number -1), else its T number in `tools:`. Throws vmsim::InputError naming
/// the block (file:line) and the T number where the table has no such tool, or where its length
/// differs from inputs.tool_length_m (one tool length per run: the kinematics take one).
std::vector<removal::Tool> point_tools(const PartDescription& part, const ChainInputs& inputs);

/// Cuts `poses` into `buffer` stretch by stretch: the segment that ends at pose k is cut with
/// point_tools[pose_point[k]] (pose_point: per pose, the index of the path point its motion runs
/// towards); one NBuffer::cut per stretch of the same tool. Returns the summed statistics.
/// `between_stretches(buffer)`, when given, runs after each stretch that another follows (the
/// ranks of an MPI job exchange their bands' tile bounds there: banded_removal.hpp).
removal::CutStatistics cut_with_tools(removal::NBuffer& buffer, const std::vector<removal::Tool>& point_tools,
                                      const std::vector<removal::Pose>& poses,
                                      const std::vector<std::size_t>& pose_point,
                                      const removal::CutOptions& options = {},
                                      const std::function<void(removal::NBuffer&)>& between_stretches = {});

}  // namespace vmsim::app
