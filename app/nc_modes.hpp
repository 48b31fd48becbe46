#pragma once
// NC modes the program asks for (toolpath::PathPoint: jerk limitation SOFT / BRISK, feedforward
// FFWON / FFWOF, corner blending, compressor) and what a run applies: the program's modes where
// it gives them, the command line where it gives one (an override, said in the report), the
// command's default where neither does.
//
// The model (README, "NC modes"): the planner plans one order for the whole path and the servo
// runs one feedforward setting, so where a program switches mode along the path the mode in
// force over most of its cutting moves is applied (the report lists every stretch and says so).
// Corner tolerances are applied point by point (ChainInputs, planner::blend_corners), and so is
// the compressor (planner::compress_polylines).
#include <nlohmann/json.hpp>

#include <optional>
#include <string>
#include <vector>

#include "vmsim/kinematics/machine_model.hpp"
#include "vmsim/planner/compressor.hpp"
#include "vmsim/toolpath/toolpath.hpp"

namespace vmsim::app {

/// A stretch of consecutive path points under one mode.
struct NcModeStretch {
  std::string mode;  ///< "SOFT", "BRISK", "not programmed", "blend 0.01 mm", ...
  std::string from;  ///< first block, "file:line"
  std::string to;    ///< last block, "file:line"
  std::size_t points = 0;
  std::size_t cutting_points = 0;
};

/// What one NC mode is in a run.
struct NcModeUse {
  std::vector<NcModeStretch> program;  ///< where the program asks for what
  std::string applied;                 ///< what the run applies
  std::string source;                  ///< "program", "command line (--...)", "default (...)"
  bool overridden = false;             ///< the command line differs from what the program asks
  std::string note;                    ///< an approximation said in words, or empty
};

struct NcModes {
  bool third_order = false;
  /// nullopt: the machine file's feedforward; true / false: switched on / off for the run.
  std::optional<bool> feedforward;
  NcModeUse jerk, feedforward_use, corners, compressor;
  nlohmann::json to_json() const;
  /// One line per mode for the terminal and the report's context.
  std::vector<std::string> lines() const;
};

/// What the command line says; nullopt where it says nothing.
struct NcModeCommandLine {
  std::optional<bool> third_order;
  std::string third_order_option;  ///< the option's name for the report ("--third-order")
  std::optional<bool> feedforward;
  bool corner_override = false;
  double corner_tolerance_m = 0.0;
  bool default_third_order = false;  ///< the command's default where the program says nothing
  /// --compressor-tolerance-mm: 0 off, > 0 on everywhere within it [m].
  bool compressor_override = false;
  double compressor_tolerance_m = 0.0;
  /// What the compressor did in this run (ChainInputs::compression); nullopt: not run.
  std::optional<planner::CompressionSummary> compression;
};

/// Decides the run's modes from the program (path.points) and the command line.
NcModes decide_nc_modes(const toolpath::Toolpath& path, const NcModeCommandLine& command_line);

/// The machine with its drives' feedforward switched off (FFWOF: no velocity or torque
/// feedforward, no balancing of it), or as the machine file has it (on).
kinematics::MachineModel with_feedforward(const kinematics::MachineModel& machine, bool on);

}  // namespace vmsim::app
