#include "chain_inputs.hpp"

#include <array>
#include <filesystem>
#include <cmath>
#include <limits>
#include <map>
#include <numbers>
#include <sstream>
#include <optional>

#include "part_file.hpp"
#include "vmsim/common/errors.hpp"
#include "vmsim/common/files.hpp"
#include "vmsim/kinematics/kinematics.hpp"
#include "vmsim/kinematics/redundancy.hpp"
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

std::vector<double> point_feeds_m_per_s(const ChainInputs& inputs,
                                        const kinematics::PathKinematics& path,
                                        const FeedSetting& feed) {
  std::vector<double> feeds(inputs.path.size(), 0.0);
  for (std::size_t i = 1; i < inputs.path.size(); ++i) {
    const toolpath::PathPoint& point = inputs.toolpath.points[inputs.toolpath_point[i]];
    if (point.kind == toolpath::MotionKind::rapid) continue;
    if (i < path.turns_in_place.size() && path.turns_in_place[i]) continue;
    if (feed.fixed_m_per_s > 0.0) {
      feeds[i] = feed.fixed_m_per_s;
      continue;
    }
    double programmed = point.feed_m_per_s;
    if (point.inverse_time_feed_per_s > 0.0) {
      // G93: the move takes 1 / F; its chord at that time (an arc's chords each got n F).
      const double chord_m = (inputs.path[i].pose.tip_W_m - inputs.path[i - 1].pose.tip_W_m).norm();
      programmed = chord_m * point.inverse_time_feed_per_s;
    }
    if (!(programmed > 0.0)) {
      if (point.inverse_time_feed_per_s > 0.0) continue;  // G93 without tip motion: axes' limits
      const auto& block = inputs.toolpath.blocks[static_cast<std::size_t>(point.block)];
      throw InputError(located_message(block.file, block.line, 0,
                                       "a cutting move without a programmed feed (F / FEDRAT)"));
    }
    feeds[i] = programmed * feed.programmed_factor;
  }
  return feeds;
}

double to_trace_unit(const kinematics::Axis& axis, double joint_value_si) {
  return axis.type == kinematics::AxisType::linear ? joint_value_si * 1e3
                                                   : joint_value_si * 180.0 / std::numbers::pi;
}

namespace {

// Machine axis values from G-code words: letters must be axis names of the machine, and each
// word must lie within its axis's travel: a word beyond it (A720 on A [-120, 30] deg) would give
// a pose that the direct kinematics folds back into the travel (A720 is the pose of A0), and the
// motion would silently vanish. The reader places the error at the block.
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
    const bool limited = !(axis.type == kinematics::AxisType::rotary && axis.continuous);
    constexpr double kTravelSlack = 1e-12;  // joint unit, as kinematics::within_travel
    if (limited && !(q[index] >= axis.travel_min - kTravelSlack &&
                     q[index] <= axis.travel_max + kTravelSlack)) {
      const char* unit = axis.type == kinematics::AxisType::linear ? " mm" : " deg";
      // The travel as the machine file gives it (mm or deg, not the rounding of m or rad).
      const auto as_written = [&](double joint_value) {
        return format_double(std::round(to_trace_unit(axis, joint_value) * 1e9) / 1e9);
      };
      throw InfeasibleError("axis word " + std::string(1, letter) + format_double(value) +
                            " is outside the travel of axis " + axis.name + " [" +
                            as_written(axis.travel_min) + ", " + as_written(axis.travel_max) +
                            "]" + unit);
    }
  }
  return q;
}

// True when both points carry the same rotary words (NaN: not programmed, equal to NaN).
bool same_rotary_words(const toolpath::PathPoint& a, const toolpath::PathPoint& b) {
  for (std::size_t k = 0; k < a.rotary_words_deg.size(); ++k) {
    const double x = a.rotary_words_deg[k];
    const double y = b.rotary_words_deg[k];
    if (std::isnan(x) != std::isnan(y) || (!std::isnan(x) && x != y)) return false;
  }
  return true;
}

// The rotary axes a point's programmed words A B C give (joint unit, NaN for the other axes);
// empty when the point carries no words, or when its tool axis is not theirs (a G43.5 tool
// vector after G43.4 words: the words in force no longer place the axes, the IKT does).
Eigen::VectorXd programmed_rotary_axes(const kinematics::MachineModel& machine,
                                       const toolpath::PathPoint& point, double tool_length_m) {
  Eigen::VectorXd q = Eigen::VectorXd::Constant(static_cast<Eigen::Index>(machine.axis_count()),
                                                std::numeric_limits<double>::quiet_NaN());
  bool any = false;
  for (std::size_t k = 0; k < point.rotary_words_deg.size(); ++k) {
    if (std::isnan(point.rotary_words_deg[k])) continue;
    const int index = machine.axis_index(std::string(1, static_cast<char>('A' + k)));
    if (index < 0 || machine.axes[static_cast<std::size_t>(index)].type !=
                         kinematics::AxisType::rotary) {
      continue;
    }
    q[index] = point.rotary_words_deg[k] * std::numbers::pi / 180.0;
    any = true;
  }
  if (!any) return {};
  Eigen::VectorXd q_full = machine.home_positions();
  for (Eigen::Index i = 0; i < q.size(); ++i) {
    if (!std::isnan(q[i])) q_full[i] = q[i];
  }
  const Eigen::Vector3d axis_W = kinematics::forward_kinematics(machine, q_full, tool_length_m).axis_W;
  if (std::atan2(axis_W.cross(point.axis_W).norm(), axis_W.dot(point.axis_W)) > 1e-6) return {};
  return q;
}

}  // namespace

void apply_machine_setup(const kinematics::MachineModel& machine,
                         const std::optional<MachineSetup>& setup, double tool_length_m,
                         toolpath::ReaderOptions& reader, const std::string& part_path) {
  // The part's tool for every H and T not in its tools: table (ReaderOptions::tool_length_mm),
  // and the tool the callbacks place.
  reader.default_tool_length_mm = tool_length_m * 1e3;
  std::array<int, 3> linear{};
  bool has_linear_axes = true;
  for (std::size_t k = 0; k < 3; ++k) {
    linear[k] = machine.axis_index(std::string(1, "XYZ"[k]));
    has_linear_axes = has_linear_axes && linear[k] >= 0 &&
                      machine.axes[static_cast<std::size_t>(linear[k])].type ==
                          kinematics::AxisType::linear;
  }
  Eigen::Matrix3d axes_W = Eigen::Matrix3d::Identity();
  Eigen::Vector3d zero_W_mm = Eigen::Vector3d::Zero();
  if (has_linear_axes) {
    // The gauge point is affine in the linear axes: its place at machine zero (rotary axes at
    // 0) and its motion per mm of each axis.
    Eigen::VectorXd q0 = machine.home_positions();
    for (std::size_t i = 0; i < machine.axes.size(); ++i) {
      q0[static_cast<Eigen::Index>(i)] = 0.0;
    }
    const auto gauge_W_mm = [&](const Eigen::VectorXd& q) -> Eigen::Vector3d {
      return kinematics::forward_kinematics(machine, q, 0.0).tip_W_m * 1e3;
    };
    zero_W_mm = gauge_W_mm(q0);
    const Eigen::VectorXd home = machine.home_positions();
    for (std::size_t k = 0; k < 3; ++k) {
      Eigen::VectorXd q = q0;
      q[linear[k]] += 1e-3;  // 1 mm
      axes_W.col(static_cast<Eigen::Index>(k)) = gauge_W_mm(q) - zero_W_mm;
      reader.g28_reference_mm[static_cast<Eigen::Index>(k)] = home[linear[k]] * 1e3;
    }
    reader.g30_reference_mm = reader.g28_reference_mm;
    for (std::size_t k = 0; k < 3; ++k) {  // rotary axes named in G28 / G30 go home
      const int rotary = machine.axis_index(std::string(1, "ABC"[k]));
      if (rotary >= 0 && machine.axes[static_cast<std::size_t>(rotary)].type == kinematics::AxisType::rotary) {
        reader.rotary_reference_deg[k] = home[rotary] * 180.0 / std::numbers::pi;
      }
    }
    reader.machine_axes_W = axes_W;
    reader.machine_zero_W_mm = zero_W_mm;
  }
  if (!setup) return;
  if (setup->g28_reference_mm) reader.g28_reference_mm = *setup->g28_reference_mm;
  if (setup->g30_reference_mm) reader.g30_reference_mm = *setup->g30_reference_mm;
  reader.initial_work_offset = setup->active_offset;
  if (setup->work_zero_W_mm.empty()) return;
  if (!has_linear_axes || std::abs(axes_W.determinant()) < 1e-9) {
    throw InputError(part_path + ": setup.work_offsets_mm needs a machine whose linear axes X Y Z "
                     "move the tool in three directions (" + machine.name + ", " +
                     machine.source_file + ")");
  }
  // The control's offset: the machine axes that put the gauge point at the work zero.
  const Eigen::Matrix3d to_axes = axes_W.inverse();
  for (const auto& [name, zero_mm] : setup->work_zero_W_mm) {
    reader.work_offsets_mm[name] = to_axes * (zero_mm - zero_W_mm);
  }
}

ChainInputs load_chain_inputs(const ChainInputOptions& options) {
  ChainInputs inputs;
  std::string machine_path = options.machine_path;
  std::string toolpath_path = options.toolpath_path;
  double tool_length_m = options.tool_length_mm >= 0.0 ? options.tool_length_mm * 1e-3 : -1.0;
  std::optional<MachineSetup> setup;
  // Cutter radii for G41 / G42 D<n> [mm]: the part file's tools by T number, or its one tool
  // for every D where it has no table.
  std::map<int, double> cutter_radius_mm;
  std::optional<double> default_cutter_radius_mm;
  // Tool lengths by T (and H) number [mm]: the table's; the part's tool for any other.
  std::map<int, double> tool_length_mm;
  if (!options.part_path.empty()) {
    const PartDescription part = load_part(options.part_path);
    setup = part.setup;
    for (const NumberedTool& numbered : part.tools) {
      cutter_radius_mm[numbered.number] = 0.5 * numbered.tool.diameter_m * 1e3;
      tool_length_mm[numbered.number] = numbered.tool.length_m * 1e3;
    }
    if (part.tools.empty()) default_cutter_radius_mm = 0.5 * part.tool.diameter_m * 1e3;
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

  toolpath::ReaderOptions reader;
  const kinematics::MachineModel& machine = inputs.machine;
  reader.rotary_words_to_tool_axis = [&machine, tool_length_m](const auto& words) {
    return kinematics::forward_kinematics(machine, axes_from_words(machine, words), tool_length_m)
        .axis_W;
  };
  reader.axis_words_to_pose = [&machine, tool_length_m](const auto& words) {
    const kinematics::ToolPose pose =
        kinematics::forward_kinematics(machine, axes_from_words(machine, words), tool_length_m);
    return toolpath::AxisWordPose{pose.tip_W_m, pose.axis_W};
  };
  // Leaving TCP mode: the linear axes under the last tip, with the rotary axes at their words.
  reader.tip_to_axis_words = [&machine, tool_length_m](const Eigen::Vector3d& tip_W_m, const Eigen::Vector3d& axis_W,
                                                       const auto& rotary_words) -> std::optional<Eigen::Vector3d> {
    const Eigen::VectorXd q_given = axes_from_words(machine, rotary_words);
    const std::optional<kinematics::InverseResult> solved = kinematics::inverse_kinematics_given_rotary(
        machine, {tip_W_m, axis_W}, q_given, q_given, tool_length_m, 1e-6);
    if (!solved) return std::nullopt;
    Eigen::Vector3d machine_mm;
    for (int k = 0; k < 3; ++k) {
      const int index = machine.axis_index(std::string(1, "XYZ"[k]));
      if (index < 0 || machine.axes[static_cast<std::size_t>(index)].type != kinematics::AxisType::linear) {
        return std::nullopt;
      }
      machine_mm[k] = solved->q[index] * 1e3;
    }
    return machine_mm;
  };
  // KUKA KRL: $WORLD is the robot's base B; its place in W and PTP {A1 .. A6} in machine order.
  reader.krl_world_in_W = kinematics::workpiece_frame_B(machine, machine.home_positions()).inverse().matrix();
  reader.robot_joints_to_pose = [&machine, tool_length_m](const std::vector<double>& joints_deg) {
    if (joints_deg.size() != machine.axes.size()) {
      throw InputError("PTP gives " + std::to_string(joints_deg.size()) + " axis values, the machine " +
                       machine.name + " has " + std::to_string(machine.axes.size()) + " axes");
    }
    Eigen::VectorXd q(static_cast<Eigen::Index>(joints_deg.size()));
    for (std::size_t i = 0; i < joints_deg.size(); ++i) {
      q[static_cast<Eigen::Index>(i)] = machine.axes[i].type == kinematics::AxisType::linear
                                            ? joints_deg[i] * 1e-3
                                            : joints_deg[i] * std::numbers::pi / 180.0;
    }
    const kinematics::ToolPose pose = kinematics::forward_kinematics(machine, q, tool_length_m);
    return toolpath::AxisWordPose{pose.tip_W_m, pose.axis_W};
  };
  apply_machine_setup(machine, setup, tool_length_m, reader, options.part_path);
  reader.cutter_radius_mm = cutter_radius_mm;
  reader.tool_length_mm = tool_length_mm;
  reader.default_cutter_radius_mm = default_cutter_radius_mm;
  inputs.toolpath = toolpath::read_toolpath(toolpath_path, reader);
  if (inputs.toolpath.points.empty()) {
    throw InputError(toolpath_path + ": the tool path has no motion");
  }
  for (const auto& warning : inputs.toolpath.warnings) {
    inputs.warnings.push_back(located_message(warning.file, warning.line, 0, warning.message));
  }
  {
    // The compressor first (the 840D compresses blocks before its corner rounding): its curve
    // keeps the runs' end points and tangents, so the corners between runs are still corners.
    planner::CompressorOptions compressor;
    compressor.override_tolerance_m = options.compressor_tolerance_override_m;
    planner::CompressorResult compressed = planner::compress_polylines(inputs.toolpath, compressor);
    inputs.compression = compressed.summary;
    if (!compressed.runs.empty()) inputs.toolpath = std::move(compressed.toolpath);
  }
  bool programmed_blending = false;  // a G64 P / G5.1 tolerance somewhere in the program
  if (!options.corner_tolerance_override) {
    for (const auto& point : inputs.toolpath.points) {
      programmed_blending = programmed_blending || point.corner_tolerance_m > 0.0;
    }
  }
  if (options.corner_tolerance_m > 0.0 || programmed_blending) {
    planner::CornerBlendOptions blend;
    blend.tolerance_m = options.corner_tolerance_m;
    blend.program_tolerances = !options.corner_tolerance_override;
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
    // The file's name, not its path: block names go into reports that are forwarded.
    std::string name = std::filesystem::path(block.file).filename().string() + ":" + std::to_string(block.line);
    if (block.block_number >= 0) name += " N" + std::to_string(block.block_number);
    inputs.block_names.push_back(name);
  }
  // Consecutive identical poses carry no motion: merge them, and say so. Not when their
  // programmed rotary words differ: the same pose at C0 and C360 is a real turn of C.
  for (std::size_t i = 0; i < inputs.toolpath.points.size(); ++i) {
    const toolpath::PathPoint& point = inputs.toolpath.points[i];
    if (!inputs.path.empty()) {
      const kinematics::ToolPose& last = inputs.path.back().pose;
      const toolpath::PathPoint& last_point = inputs.toolpath.points[inputs.toolpath_point.back()];
      if ((last.tip_W_m - point.tip_W_m).norm() < 1e-12 &&
          (last.axis_W - point.axis_W).norm() < 1e-12 &&
          same_rotary_words(last_point, point) &&
          kinematics::pose_tool_length_m(inputs.path.back(), inputs.tool_length_m) ==
              (std::isnan(point.tool_length_m) ? inputs.tool_length_m : point.tool_length_m)) {
        const auto& block = inputs.toolpath.blocks[static_cast<std::size_t>(point.block)];
        inputs.warnings.push_back(located_message(block.file, block.line, 0,
                                                  "repeats the previous pose; merged with it"));
        inputs.point_dwell_s.back() += point.dwell_s;
        continue;
      }
    }
    // An NC moves the rotary axes to the programmed words (G43.4 included): they are kept,
    // not chosen again by the inverse kinematics.
    inputs.path.push_back({{point.tip_W_m, point.axis_W},
                           point.block,
                           programmed_rotary_axes(inputs.machine, point, inputs.tool_length_m)});
    // The tool in the spindle on this motion (T / M6, TOOL CALL, T D), where it is not the
    // run's own length.
    if (!std::isnan(point.tool_length_m) && point.tool_length_m != inputs.tool_length_m) {
      inputs.path.back().tool_length_m = point.tool_length_m;
    }
    inputs.toolpath_point.push_back(i);
    inputs.point_dwell_s.push_back(point.dwell_s);
    const double programmed_m = point.corner_tolerance_m;
    double contour_m = options.corner_tolerance_override || std::isnan(programmed_m) ? options.corner_tolerance_m
                                                                                      : programmed_m;
    if (point.kind == toolpath::MotionKind::rapid || !(contour_m > 0.0)) contour_m = 0.0;
    inputs.contour_tolerance_m.push_back(contour_m);
  }
  // A robot's sixth degree of freedom, the rotation about the tool axis, is free: choose it
  // along the whole path away from joint limits and singularities (a roll profile, smooth in s,
  // kinematics::choose_tool_roll_along_path); where that finds none, at the first pose only (the
  // path then keeps least joint motion from there).
  inputs.q_start = inputs.machine.home_positions();
  if (inputs.machine.kind == kinematics::MachineKind::robot && !inputs.path.empty() &&
      inputs.path.front().q_given.size() == 0) {
    const auto choice = kinematics::choose_tool_roll(inputs.machine, inputs.path.front().pose,
                                                     inputs.q_start, inputs.tool_length_m);
    const auto profile = kinematics::choose_tool_roll_along_path(inputs.machine, inputs.path, inputs.q_start,
                                                                 inputs.tool_length_m);
    constexpr double kDeg = 180.0 / std::numbers::pi;
    std::ostringstream text;
    text.precision(3);
    inputs.roll_profile = profile;
    // Applied only where it raises the smallest score (else the path stays as it was).
    if (profile && profile->min_score > profile->min_score_free + 1e-6) {
      inputs.roll_profile_applied = true;
      inputs.q_start = profile->q_start;
      for (std::size_t i = 0; i < inputs.path.size(); ++i) inputs.path[i].roll_rad = profile->roll_rad[i];
      text << "tool roll (the free rotation about the tool axis) chosen along the path for the largest smallest "
           << "min(travel margin, inverse condition of the Jacobian) (" << profile->rolls << " rolls at each of "
           << profile->samples << " samples, rate at most " << profile->max_rate_rad_per_m * kDeg / 1000.0
           << " deg/mm): roll " << profile->roll_min_rad * kDeg << " to " << profile->roll_max_rad * kDeg
           << " deg; smallest score along the path " << profile->min_score << " at s = " << profile->min_score_s_m * 1e3
           << " mm (without the choice, the first pose's roll then least joint motion: " << profile->min_score_free
           << " at s = " << profile->min_score_free_s_m * 1e3 << " mm)";
      inputs.tool_roll = text.str();
    } else if (choice) {
      inputs.q_start = choice->q;
      text << "tool roll (the free rotation about the tool axis) at the first pose: " << choice->roll_rad * kDeg
           << " deg (" << choice->rolls_solved + 1 << " of " << choice->rolls_tried + 1 << " rolls every 15 deg reachable within travel), chosen for the largest of min(travel margin, "
           << "inverse condition of the Jacobian): travel margin " << choice->margins.travel_margin * 100.0
           << " % of a joint's travel, inverse condition " << choice->margins.inverse_condition
           << " (the solution nearest home: " << choice->seed_margins.travel_margin * 100.0 << " %, "
           << choice->seed_margins.inverse_condition << ")";
      if (profile) {
        text << "; a roll profile along the path (roll " << profile->roll_min_rad * kDeg << " to "
             << profile->roll_max_rad * kDeg << " deg) was not better: smallest score along the path "
             << profile->min_score << ", without it " << profile->min_score_free << " at s = "
             << profile->min_score_free_s_m * 1e3 << " mm";
      } else {
        text << "; no roll profile along the path was found";
      }
      inputs.tool_roll = text.str();
    }
  }
  return inputs;
}

std::vector<bool> rapid_ends(const ChainInputs& inputs) {
  std::vector<bool> rapid(inputs.path.size(), false);
  for (std::size_t i = 0; i < rapid.size(); ++i) {
    rapid[i] = inputs.toolpath.points[inputs.toolpath_point[i]].kind == toolpath::MotionKind::rapid;
  }
  return rapid;
}

}  // namespace vmsim::app
