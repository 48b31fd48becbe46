#pragma once
// The part file's tools in the removal: the tool of each path point's motion (PathPoint::
// tool_number through the part file's `tools:` table) and cutting a trajectory stretch by
// stretch with the tool in the spindle.
#include <Eigen/Geometry>
#include <cstddef>
#include <functional>
#include <vector>

#include "chain_inputs.hpp"
#include "part_file.hpp"
#include "vmsim/removal/nbuffer.hpp"
#include "vmsim/removal/tool.hpp"
#include "vmsim/removal/trajectory.hpp"

namespace vmsim::app {

/// The removal tool of a part file's tool: its cutting body only (cutting_length_m where given,
/// else length_m). Throws vmsim::InputError when the tool is not valid.
removal::Tool removal_tool(const ToolDescription& description);

/// The removal tool of each point of inputs.path: the part file's `tool` where the program
/// selects none (tool_number -1), else its T number in `tools:`. Throws vmsim::InputError naming
/// the block (file:line) and the T number where the table has no such tool.
std::vector<removal::Tool> point_tools(const PartDescription& part, const ChainInputs& inputs);

/// Per point of inputs.path, the length of the tool in the spindle on the motion that ends
/// there, gauge point to tip [m] (PathPose::tool_length_m, else inputs.tool_length_m).
std::vector<double> point_tool_lengths_m(const ChainInputs& inputs);

/// The path point whose motion holds path parameter s: the first point at or after s (the last
/// point beyond the end). A sample at a tool change point (at rest) belongs to the old tool.
std::size_t motion_point_at(const std::vector<double>& path_s_m, double s_m);

/// Tool poses of a run's axis positions, with the tool in the spindle at each sample (the
/// length of the path point motion_point_at its s), fed to a TrajectoryThinner. Where the
/// length changes between two samples, the thinner keeps the earlier one and restarts from it
/// seen with the new tool (TrajectoryThinner::restart_from): no pose is interpolated across a
/// tool change.
class ToolPoseStream {
 public:
  ToolPoseStream(const kinematics::MachineModel& machine, std::vector<double> point_length_m,
                 const std::vector<double>& path_s_m, removal::TrajectoryThinner& thinner);
  /// True when every point has the same tool length: push needs no s then (any value).
  bool one_length() const { return one_length_; }
  void push(const Eigen::VectorXd& q, double s_m);
  /// The same with q's spindle frame known (spindle_frame_W).
  void push(const Eigen::Isometry3d& spindle_W, double s_m);

 private:
  const kinematics::MachineModel& machine_;
  std::vector<double> point_length_m_;
  const std::vector<double>& path_s_m_;
  removal::TrajectoryThinner& thinner_;
  bool one_length_ = true;
  bool any_ = false;
  double last_length_m_ = 0.0;
  removal::Pose last_pose_;
};

/// Cuts `poses` into `buffer` stretch by stretch: the segment that ends at pose k is cut with
/// point_tools[pose_point[k]] (pose_point: per pose, the index of the path point its motion runs
/// towards); one NBuffer::cut per stretch of the same tool. Returns the summed statistics.
/// point_length_m (per path point, the gauge-to-tip length of its tool; empty: all the same):
/// where it changes, the segment into the new stretch starts at the last pose moved to the new
/// tool's tip (kinematics::tip_with_tool_length: the same axis positions, another tool).
/// `between_stretches(buffer)`, when given, runs after each stretch that another follows (the
/// ranks of an MPI job exchange their bands' tile bounds there: banded_removal.hpp).
removal::CutStatistics cut_with_tools(removal::NBuffer& buffer, const std::vector<removal::Tool>& point_tools,
                                      const std::vector<removal::Pose>& poses,
                                      const std::vector<std::size_t>& pose_point,
                                      const removal::CutOptions& options = {},
                                      const std::vector<double>& point_length_m = {},
                                      const std::function<void(removal::NBuffer&)>& between_stretches = {});

}  // namespace vmsim::app
