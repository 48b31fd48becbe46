#include "tool_table.hpp"

#include "following_errors.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <span>
#include <string>

#include "vmsim/common/errors.hpp"
#include "vmsim/common/files.hpp"
#include "vmsim/kinematics/kinematics.hpp"
#include "vmsim/kinematics/path_kinematics.hpp"

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
// is an error naming the block. (Its length places the axes: PathPose::tool_length_m.)
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
      last_number = point.tool_number;
      tools.push_back(removal_tool(*description));
    } else {
      tools.push_back(tools.back());
    }
  }
  return tools;
}

std::vector<double> point_tool_lengths_m(const ChainInputs& inputs) {
  std::vector<double> lengths;
  lengths.reserve(inputs.path.size());
  for (const auto& pose : inputs.path) lengths.push_back(kinematics::pose_tool_length_m(pose, inputs.tool_length_m));
  return lengths;
}

std::size_t motion_point_at(const std::vector<double>& path_s_m, double s_m) {
  const auto i = static_cast<std::size_t>(std::lower_bound(path_s_m.begin(), path_s_m.end(), s_m) - path_s_m.begin());
  return std::min(i, path_s_m.size() - 1);
}

ToolPoseStream::ToolPoseStream(const kinematics::MachineModel& machine, std::vector<double> point_length_m,
                               const std::vector<double>& path_s_m, removal::TrajectoryThinner& thinner)
    : machine_(machine), point_length_m_(std::move(point_length_m)), path_s_m_(path_s_m), thinner_(thinner) {
  for (const double length : point_length_m_) one_length_ = one_length_ && length == point_length_m_.front();
}

void ToolPoseStream::push(const Eigen::VectorXd& q, double s_m) { push(spindle_frame_W(machine_, q), s_m); }

void ToolPoseStream::push(const Eigen::Isometry3d& spindle_W, double s_m) {
  const double length_m =
      point_length_m_.empty() ? 0.0 : one_length_ ? point_length_m_.front() : point_length_m_[motion_point_at(path_s_m_, s_m)];
  kinematics::ToolPose pose;
  pose.tip_W_m = tool_tip_W_m(spindle_W, length_m);
  pose.axis_W = spindle_W.linear().col(2);
  if (any_ && length_m != last_length_m_) {
    // The tool changed at rest after the last sample: thin on from it with the new tool.
    thinner_.restart_from({kinematics::tip_with_tool_length(last_pose_.tip_W_m, last_pose_.axis_W, last_length_m_, length_m),
                           last_pose_.axis_W});
  }
  last_pose_ = {pose.tip_W_m, pose.axis_W};
  last_length_m_ = length_m;
  any_ = true;
  thinner_.push(last_pose_);
}

// Cuts the trajectory into `buffer`, each stretch with the tool of the path point its poses
// run towards (pose_point: per pose, the index in inputs.path); the pose where the tool changes
// ends one stretch and starts the next.
removal::CutStatistics cut_with_tools(removal::NBuffer& buffer, const std::vector<removal::Tool>& point_tools,
                                      const std::vector<removal::Pose>& poses,
                                      const std::vector<std::size_t>& pose_point,
                                      const removal::CutOptions& options,
                                      const std::vector<double>& point_length_m,
                                      const std::function<void(removal::NBuffer&)>& between_stretches) {
  removal::CutStatistics total;
  const auto length_of = [&](std::size_t pose) {
    return point_length_m.empty() ? 0.0 : point_length_m[pose_point[pose]];
  };
  const auto same = [](const removal::Tool& a, const removal::Tool& b) {
    return a.type == b.type && a.diameter_m == b.diameter_m && a.corner_radius_m == b.corner_radius_m &&
           a.length_m == b.length_m;
  };
  const auto add = [&total](const removal::CutStatistics& part) {
    total.segments += part.segments;
    total.sub_segments += part.sub_segments;
    total.tiles_visited += part.tiles_visited;
    total.lines_lowered += part.lines_lowered;
    total.chained_turning += part.chained_turning;
    total.junction_rows_covered += part.junction_rows_covered;
    total.interrupted = total.interrupted || part.interrupted;
  };
  std::size_t first = 0;
  while (first < poses.size()) {
    const removal::Tool& tool = point_tools[pose_point[first]];
    const double length_m = length_of(first);
    std::size_t last = first;
    while (last + 1 < poses.size() && same(point_tools[pose_point[last + 1]], tool) && length_of(last + 1) == length_m) {
      ++last;
    }
    // The segment into the next stretch's first pose is cut with that stretch's tool; after a
    // change of length it starts where the new tool's tip was at the last pose (the axes there).
    std::size_t begin = first == 0 ? 0 : first - 1;
    if (first > 0 && length_of(first - 1) != length_m) {
      const removal::Pose& before = poses[first - 1];
      const std::array<removal::Pose, 2> junction = {
          removal::Pose{kinematics::tip_with_tool_length(before.tip_W_m, before.axis_W, length_of(first - 1), length_m),
                        before.axis_W},
          poses[first]};
      add(buffer.cut(tool, std::span<const removal::Pose>(junction.data(), junction.size()), options));
      if (total.interrupted) break;
      begin = first;
    }
    const removal::CutStatistics part =
        buffer.cut(tool, std::span<const removal::Pose>(poses.data() + begin, last - begin + 1), options);
    add(part);
    if (part.interrupted) break;
    first = last + 1;
    if (first < poses.size() && between_stretches) between_stretches(buffer);
  }
  return total;
}

}  // namespace vmsim::app
