#include "nc_modes.hpp"

#include <cmath>
#include <filesystem>
#include <functional>
#include <map>

#include "vmsim/common/files.hpp"

namespace vmsim::app {
namespace {

using toolpath::FeedforwardMode;
using toolpath::JerkMode;
using toolpath::PathPoint;

constexpr std::size_t kMaxStretches = 40;  // listed in the report; the rest are counted

std::string block_place(const toolpath::Toolpath& path, const PathPoint& point) {
  if (point.block < 0 || static_cast<std::size_t>(point.block) >= path.blocks.size()) return "?";
  const auto& block = path.blocks[static_cast<std::size_t>(point.block)];
  return std::filesystem::path(block.file).filename().string() + ":" + std::to_string(block.line);
}

std::vector<NcModeStretch> stretches(const toolpath::Toolpath& path,
                                     const std::function<std::string(const PathPoint&)>& mode_of) {
  std::vector<NcModeStretch> out;
  for (const PathPoint& point : path.points) {
    const std::string mode = mode_of(point);
    if (out.empty() || out.back().mode != mode) {
      out.push_back({mode, block_place(path, point), block_place(path, point), 0, 0});
    }
    NcModeStretch& s = out.back();
    s.to = block_place(path, point);
    ++s.points;
    if (point.kind != toolpath::MotionKind::rapid) ++s.cutting_points;
  }
  return out;
}

/// The mode over most cutting points among the programmed ones; "" when none is programmed.
std::string majority(const std::vector<NcModeStretch>& list) {
  std::map<std::string, std::size_t> count;
  for (const auto& s : list) {
    if (s.mode != "not programmed") count[s.mode] += s.cutting_points;
  }
  std::string best;
  std::size_t most = 0;
  for (const auto& [mode, n] : count) {
    if (best.empty() || n > most) {
      best = mode;
      most = n;
    }
  }
  return best;
}

std::size_t programmed_kinds(const std::vector<NcModeStretch>& list) {
  std::map<std::string, int> kinds;
  for (const auto& s : list) {
    if (s.mode != "not programmed") kinds[s.mode] = 1;
  }
  return kinds.size();
}

std::string tolerance_text(double metres) {
  return format_double(std::round(metres * 1e9) / 1e6) + " mm";
}

nlohmann::json use_json(const NcModeUse& use) {
  nlohmann::json out;
  out["applied"] = use.applied;
  out["source"] = use.source;
  out["overridden_by_command_line"] = use.overridden;
  if (!use.note.empty()) out["note"] = use.note;
  nlohmann::json list = nlohmann::json::array();
  for (std::size_t k = 0; k < use.program.size() && k < kMaxStretches; ++k) {
    const auto& s = use.program[k];
    list.push_back({{"mode", s.mode}, {"from", s.from}, {"to", s.to}, {"points", s.points},
                    {"cutting_points", s.cutting_points}});
  }
  out["program"] = list;
  if (use.program.size() > kMaxStretches) out["program_stretches_not_listed"] = use.program.size() - kMaxStretches;
  return out;
}

std::string use_line(const char* name, const NcModeUse& use) {
  std::string where;
  std::size_t listed = 0;
  for (const auto& s : use.program) {
    if (s.mode == "not programmed") continue;
    if (listed == 3) {
      where += ", ...";
      break;
    }
    where += (where.empty() ? "" : ", ") + s.mode + " " + s.from + (s.to != s.from ? "-" + s.to : "");
    ++listed;
  }
  return std::string(name) + ": " + use.applied + " (" + use.source + ")" +
         (where.empty() ? "; the program says nothing" : "; the program: " + where) +
         (use.note.empty() ? "" : "; " + use.note);
}

}  // namespace

nlohmann::json NcModes::to_json() const {
  return {{"jerk_limitation", use_json(jerk)},
          {"feedforward", use_json(feedforward_use)},
          {"corner_blending", use_json(corners)},
          {"compressor", use_json(compressor)}};
}

std::vector<std::string> NcModes::lines() const {
  return {use_line("jerk limitation", jerk), use_line("feedforward", feedforward_use),
          use_line("corner blending", corners), use_line("compressor", compressor)};
}

NcModes decide_nc_modes(const toolpath::Toolpath& path, const NcModeCommandLine& command_line) {
  NcModes modes;
  // Jerk limitation: SOFT = the planner's third order (axis jerk limits), BRISK = second order.
  modes.jerk.program = stretches(path, [](const PathPoint& p) -> std::string {
    return p.jerk_mode == JerkMode::soft ? "SOFT" : p.jerk_mode == JerkMode::brisk ? "BRISK" : "not programmed";
  });
  const std::string jerk_asked = majority(modes.jerk.program);
  const auto order_text = [](bool third) {
    return third ? std::string("jerk limited (third order: SOFT)") : std::string("acceleration only (second order: BRISK)");
  };
  if (command_line.third_order) {
    modes.third_order = *command_line.third_order;
    modes.jerk.source = "command line: " + command_line.third_order_option;
    modes.jerk.overridden = !jerk_asked.empty() && (jerk_asked == "SOFT") != modes.third_order;
  } else if (!jerk_asked.empty()) {
    modes.third_order = jerk_asked == "SOFT";
    modes.jerk.source = "program";
  } else {
    modes.third_order = command_line.default_third_order;
    modes.jerk.source = "default: the program does not say";
  }
  modes.jerk.applied = order_text(modes.third_order);
  if (programmed_kinds(modes.jerk.program) > 1 && !command_line.third_order) {
    modes.jerk.note = "the program switches between SOFT and BRISK: the mode of most cutting moves (" + jerk_asked +
                      ") is applied to the whole path (one plan order per run)";
  }

  // Feedforward: FFWON = the drives' feedforward as the machine file configures it; FFWOF = off.
  modes.feedforward_use.program = stretches(path, [](const PathPoint& p) -> std::string {
    return p.feedforward == FeedforwardMode::on ? "FFWON" : p.feedforward == FeedforwardMode::off ? "FFWOF" : "not programmed";
  });
  const std::string ff_asked = majority(modes.feedforward_use.program);
  if (command_line.feedforward) {
    modes.feedforward = command_line.feedforward;
    modes.feedforward_use.source = "command line: --feedforward";
    modes.feedforward_use.overridden = !ff_asked.empty() && (ff_asked == "FFWON") != *modes.feedforward;
  } else if (!ff_asked.empty()) {
    modes.feedforward = ff_asked == "FFWON";
    modes.feedforward_use.source = "program";
  } else {
    modes.feedforward_use.source = "default: the program does not say";
  }
  modes.feedforward_use.applied = !modes.feedforward ? "as the machine file configures the drives"
                                  : *modes.feedforward ? "on (as the machine file configures it)"
                                                       : "off (no velocity or torque feedforward)";
  if (programmed_kinds(modes.feedforward_use.program) > 1 && !command_line.feedforward) {
    modes.feedforward_use.note = "the program switches feedforward on and off: the setting of most cutting moves (" +
                                 ff_asked + ") is applied to the whole run";
  }

  // Corners: point by point, from the program unless the command line sets one for all.
  modes.corners.program = stretches(path, [](const PathPoint& p) -> std::string {
    if (std::isnan(p.corner_tolerance_m)) return "not programmed";
    return p.corner_tolerance_m == 0.0 ? "exact stop" : "blend " + tolerance_text(p.corner_tolerance_m);
  });
  if (command_line.corner_override) {
    modes.corners.source = "command line: --corner-tolerance-mm";
    modes.corners.applied = command_line.corner_tolerance_m > 0.0
                                ? "blended within " + tolerance_text(command_line.corner_tolerance_m) + " at every corner"
                                : "exact stop at every corner";
    modes.corners.overridden = programmed_kinds(modes.corners.program) > 0;
  } else {
    modes.corners.source = programmed_kinds(modes.corners.program) > 0 ? "program" : "default: the program does not say";
    modes.corners.applied = "as the program asks at each corner, exact stop where it says nothing";
  }

  // Compressor: runs of short G1 blocks smoothed within the tolerance (planner/compressor.hpp),
  // where the program switches it on, or everywhere / nowhere from the command line.
  modes.compressor.program = stretches(path, [](const PathPoint& p) -> std::string {
    if (std::isnan(p.compressor_tolerance_m)) return "not programmed";
    return p.compressor_tolerance_m == 0.0 ? "COMPOF" : "COMPCAD " + tolerance_text(p.compressor_tolerance_m);
  });
  bool compressor_asked = false;
  for (const auto& s : modes.compressor.program) compressor_asked = compressor_asked || s.mode.rfind("COMPCAD", 0) == 0;
  if (command_line.compressor_override) {
    modes.compressor.source = "command line: --compressor-tolerance-mm";
    modes.compressor.overridden = programmed_kinds(modes.compressor.program) > 0;
  } else {
    modes.compressor.source = programmed_kinds(modes.compressor.program) > 0 ? "program" : "default: the program does not say";
  }
  const bool on = command_line.compressor_override ? command_line.compressor_tolerance_m > 0.0 : compressor_asked;
  if (!on) {
    modes.compressor.applied = "off: the programmed points are followed as they are";
  } else if (!command_line.compression) {
    modes.compressor.applied = "off in this run (not emulated by this command): the programmed points are followed";
  } else {
    const planner::CompressionSummary& c = *command_line.compression;
    modes.compressor.applied =
        (command_line.compressor_override ? "on everywhere within " + tolerance_text(command_line.compressor_tolerance_m)
                                          : std::string("on where the program asks, within its tolerance")) +
        ": runs of short G1 blocks replaced by a curvature-continuous cubic B-spline (" + std::to_string(c.runs) +
        " runs, " + std::to_string(c.blocks_compressed) + " blocks; largest deviation from the programmed points " +
        tolerance_text(c.deviation_max_m) + ")";
    std::string note;
    if (c.runs_left > 0) {
      note = std::to_string(c.runs_left) + " runs left as programmed (no smooth curve within the tolerance)";
    }
    if (c.orientation_blocks_left > 0) {
      note += (note.empty() ? "" : "; ") + std::to_string(c.orientation_blocks_left) +
              " blocks left as programmed: the tool axis turns over them (the orientation is not compressed)";
    }
    modes.compressor.note = note;
  }
  return modes;
}

kinematics::MachineModel with_feedforward(const kinematics::MachineModel& machine, bool on) {
  kinematics::MachineModel out = machine;
  if (on) return out;
  for (auto& axis : out.axes) {
    axis.controller.velocity_feedforward = false;
    axis.controller.torque_feedforward = false;
    axis.controller.balancing_type = kinematics::BalancingType::none;
    axis.controller.balancing_time_s = 0.0;
  }
  return out;
}

}  // namespace vmsim::app
