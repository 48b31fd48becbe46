#pragma once
// What several commands share: the machine, the tool path and the tool, from either a part file
// (--part) or from --machine, --toolpath and --tool-length-mm.
#include <CLI/CLI.hpp>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "part_file.hpp"
#include "vmsim/kinematics/machine_model.hpp"
#include "vmsim/kinematics/path_kinematics.hpp"
#include "vmsim/kinematics/redundancy.hpp"
#include "vmsim/planner/compressor.hpp"
#include "vmsim/planner/corner_blend.hpp"
#include "vmsim/toolpath/toolpath.hpp"

namespace vmsim::app {

struct ChainInputOptions {
  std::string part_path;
  std::string machine_path;
  std::string toolpath_path;
  double tool_length_mm = -1.0;
  /// Corner blending (planner/corner_blend.hpp): the largest distance between the blended and
  /// the programmed path [m]; 0 = no blending (exact stop). With corner_tolerance_override
  /// false it holds only at corners where the program says nothing; elsewhere the program's
  /// own (PathPoint::corner_tolerance_m: G61 / G9 exact stop, G64 P, G5.1).
  double corner_tolerance_m = 0.0;
  /// True: corner_tolerance_m at every corner, whatever the program asks (a command-line
  /// --corner-tolerance-mm or --exact-stop).
  bool corner_tolerance_override = false;
  /// Largest angle between the blended and the programmed tool axis at a corner [rad].
  double corner_axis_tolerance_rad = planner::CornerBlendOptions{}.axis_tolerance_rad;
  /// The compressor (planner/compressor.hpp, 840D COMPCAD / COMPCURV / COMPON): NaN = as the
  /// program asks (PathPoint::compressor_tolerance_m); 0 = off; > 0 = on everywhere within this
  /// tolerance [m] (a command-line --compressor-tolerance-mm).
  double compressor_tolerance_override_m = std::numeric_limits<double>::quiet_NaN();
};

/// Adds --part, --machine, --toolpath, --tool-length-mm to a subcommand.
void add_chain_input_options(CLI::App& command, ChainInputOptions& options);

struct ChainInputs {
  kinematics::MachineModel machine;
  /// What the compressor did (runs of short G1 blocks smoothed before corner blending).
  planner::CompressionSummary compression;
  /// The tool path as executed: short G1 runs compressed where the compressor is on, corners blended when ChainInputOptions::corner_tolerance_m > 0
  /// (blend points carry the block of the corner they replace), else as read.
  toolpath::Toolpath toolpath;
  /// The run's tool length [m] (--tool-length-mm, else the part's `tool`): every H and T not in
  /// the part's `tools:` table; the table's tools have their own (PathPose::tool_length_m).
  double tool_length_m = 0.0;
  /// The tool path as poses for the kinematics; consecutive duplicate poses merged. Each pose
  /// carries the length of the tool in the spindle where it is not tool_length_m.
  std::vector<kinematics::PathPose> path;
  /// For each point of `path`, the index of the tool path point it came from.
  std::vector<std::size_t> toolpath_point;
  /// For each point of `path`: the contour tolerance the NC works to on the motion that ends
  /// there [m] (G64 P, G5.1 ... or the command line's --corner-tolerance-mm; 0: exact stop, a
  /// rapid, or no blending). The NC may leave the programmed polyline by that much there, so
  /// the planner's path fidelity and the set-point check allow it
  /// (FeedrateOptions::point_path_tolerance_m).
  std::vector<double> contour_tolerance_m;
  /// For each point of `path`: the dwell [s] held there after its motion (PathPoint::dwell_s,
  /// those of merged points added; FeedrateOptions::point_dwell_s).
  std::vector<double> point_dwell_s;
  /// "file:line" (and " N<number>" where the block has one) for each tool path block.
  std::vector<std::string> block_names;
  /// Warnings for the user (reader warnings, merged points), each naming its file and line.
  std::vector<std::string> warnings;
  /// The corners blended and those left as exact stops (point indices of the tool path as read).
  std::vector<planner::BlendedCorner> blended_corners;
  std::vector<planner::KeptCorner> exact_stop_corners;
  /// The options to differentiate `path` with (kinematics::solve_path_kinematics): the
  /// defaults, with a fit window small enough to resolve the blends when corners were blended.
  kinematics::PathKinematicsOptions path_kinematics;
  /// Where the inverse kinematics of `path` starts (solve_path_kinematics' q_start): the home
  /// position, or on a robot the solution of the first pose whose rotation about the tool axis
  /// (free: the spindle turns the tool) keeps furthest from joint limits and singularities
  /// (kinematics::choose_tool_roll); `tool_roll` says which, in words, empty on a machine tool.
  Eigen::VectorXd q_start;
  std::string tool_roll;
  /// On a robot: the roll profile along the path (kinematics::choose_tool_roll_along_path);
  /// applied (set in each PathPose::roll_rad of `path`) only where it raises the smallest score
  /// of the path without it, else the first-pose choice is kept.
  std::optional<kinematics::RollProfile> roll_profile;
  bool roll_profile_applied = false;
};

/// Loads and checks everything; throws vmsim::InputError with file, line and value.
ChainInputs load_chain_inputs(const ChainInputOptions& options);

/// The reader options that place a G-code program on the machine (README, "Part files",
/// setup): the part's tool length for every H, the machine's gauge point map (machine axes to
/// W at rotary 0, from the direct kinematics), the G28 / G30 references (the machine's home
/// unless the setup gives them), the work offsets (each work zero in W turned into the machine
/// axis positions that put the gauge point there) and the offset active at the start. Throws
/// InputError when work offsets are given for a machine without linear axes X Y Z.
void apply_machine_setup(const kinematics::MachineModel& machine,
                         const std::optional<MachineSetup>& setup, double tool_length_m,
                         toolpath::ReaderOptions& reader, const std::string& part_path);

/// The feed limit of each path point's motion [m/s] for the planner
/// (FeedrateOptions::point_feed_m_per_s): 0 (no feed limit: the axes' own limits) on rapids and
/// on motions that turn the tool about a fixed tip (PathKinematics::turns_in_place); on cutting
/// moves feed.fixed_m_per_s where > 0, else the programmed feed (G94 F; G93: the chord length
/// times the inverse time) times feed.programmed_factor. `path` is solve_path_kinematics of
/// inputs.path. Throws vmsim::InputError naming the block where a cutting move has no feed.
/// Per path point of inputs.path: the motion that ends there is a rapid (G0, APT RAPID).
std::vector<bool> rapid_ends(const ChainInputs& inputs);

std::vector<double> point_feeds_m_per_s(const ChainInputs& inputs,
                                        const kinematics::PathKinematics& path,
                                        const FeedSetting& feed);

/// Joint value to the trace unit: mm for linear axes, deg for rotary axes.
double to_trace_unit(const kinematics::Axis& axis, double joint_value_si);

}  // namespace vmsim::app
