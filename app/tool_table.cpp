#include "tool_table.hpp"

#include <cmath>
#include <span>
#include <string>

#include "vmsim/common/errors.hpp"
#include "vmsim/common/files.hpp"

namespace vmsim::app {

// The cutting body only (removal::Tool: "give a length that covers the engaged part"): a long
// body on a tilted tool costs orientation sub-steps on every segment.
removal::Tool removal_tool(const ToolDescription& description) {
  removal::Tool tool;
  switch (description.type) {
    case ToolType::ball: tool.type = removal::ToolType::ball; break;
    case ToolType::flat: tool.type = removal::ToolType::flat; break;
    case ToolType::bull: tool.type = removal::ToolType::bull; break;
    case ToolType::v: tool.type = removal::ToolType::v; break;
    case ToolType::tapered_flat: tool.type = removal::ToolType::tapered_flat; break;
    case ToolType::tapered_ball: tool.type = removal::ToolType::tapered_ball; break;
  }
  tool.tip_diameter_m = description.tip_diameter_m;
  tool.tip_angle_rad = description.tip_angle_rad;
  tool.taper_angle_rad = description.taper_angle_rad;
  tool.diameter_m = description.diameter_m;
  tool.corner_radius_m = description.corner_radius_m;
  tool.length_m = description.cutting_length_m > 0 ? description.cutting_length_m : description.length_m;
  tool.validate();
  return tool;
}

// The removal tool of each path point's motion: the part file's tool where the program selects
// none, else its T number in the part file's `tools:` table. A T number missing from the table
// is an error naming the block; so is a tool whose length differs from the one the kinematics
// runs with (one tool length per run for now).
std::vector<removal::Tool> point_tools(const PartDescription& part, const ChainInputs& inputs) {
  std::vector<removal::Tool> tools;
  tools.reserve(inputs.path.size());
  int last_number = -2;
  for (std::size_t i = 0; i < inputs.path.size(); ++i) {
    const toolpath::PathPoint& point = inputs.toolpath.points[inputs.toolpath_point[i]];
    if (point.tool_number != last_number) {
      const ToolDescription* description = part.tool_for(point.tool_number);
      const auto where = [&]() {
        const auto& block = inputs.toolpath.blocks[static_cast<std::size_t>(point.block)];
        return located_message(block.file, block.line, 0, "T" + std::to_string(point.tool_number));
      };
      if (description == nullptr) {
        throw InputError(where() + ": no tool " + std::to_string(point.tool_number) +
                         " in the part file's tools: table (" + part.file + ")");
      }
      if (std::abs(description->length_m - inputs.tool_length_m) > 1e-9) {
        throw InputError(where() + ": the tool is " + format_double(description->length_m * 1e3) +
                         " mm long, the run's tool " + format_double(inputs.tool_length_m * 1e3) +
                         " mm: tools of different lengths in one run are not supported yet");
      }
      last_number = point.tool_number;
      tools.push_back(removal_tool(*description));
    } else {
      tools.push_back(tools.back());
    }
  }
  return tools;
}

// Cuts the trajectory into `buffer`, each stretch with the tool of the path point its poses
// run towards (pose_point: per pose, the index in inputs.path); the pose where the tool changes
// ends one stretch and starts the next.
removal::CutStatistics cut_with_tools(removal::NBuffer& buffer, const std::vector<removal::Tool>& point_tools,
                                      const std::vector<removal::Pose>& poses,
                                      const std::vector<std::size_t>& pose_point,
                                      const removal::CutOptions& options,
                                      const std::function<void(removal::NBuffer&)>& between_stretches) {
  removal::CutStatistics total;
  const auto same = [](const removal::Tool& a, const removal::Tool& b) {
    return a.type == b.type && a.diameter_m == b.diameter_m && a.corner_radius_m == b.corner_radius_m &&
           a.length_m == b.length_m;
  };
  std::size_t first = 0;
  while (first < poses.size()) {
    const removal::Tool& tool = point_tools[pose_point[first]];
    std::size_t last = first;
    while (last + 1 < poses.size() && same(point_tools[pose_point[last + 1]], tool)) ++last;
    // The segment into the next stretch's first pose is cut with that stretch's tool.
    const std::size_t begin = first == 0 ? 0 : first - 1;
    const removal::CutStatistics part =
        buffer.cut(tool, std::span<const removal::Pose>(poses.data() + begin, last - begin + 1), options);
    total.segments += part.segments;
    total.sub_segments += part.sub_segments;
    total.tiles_visited += part.tiles_visited;
    total.lines_lowered += part.lines_lowered;
    total.chained_turning += part.chained_turning;
    total.junction_rows_covered += part.junction_rows_covered;
    total.interrupted = total.interrupted || part.interrupted;
    if (part.interrupted) break;
    first = last + 1;
    if (first < poses.size() && between_stretches) between_stretches(buffer);
  }
  return total;
}

}  // namespace vmsim::app
