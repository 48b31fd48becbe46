// vmsim simulate-part: the main job (see simulate_part.hpp).
#include <unistd.h>

#include <chrono>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <limits>

#include "commands.hpp"
#include "effects_option.hpp"
#include "report_marks.hpp"
#include "simulate_part.hpp"
#include "vmsim/common/errors.hpp"
#include "vmsim/common/files.hpp"
#include "vmsim/removal/tile_store.hpp"

namespace vmsim::app {
namespace {

struct CommandOptions {
  std::string part_path;
  std::string out_dir = "out/simulate-part";
  std::string method = "kinematic";
  std::string limits = "tuned";
  std::string effects = "all";
  double production_feed_mm_per_min = 0.0;
  double reference_feed_mm_per_min = 0.0;
  double grid_um = 20.0;
  double mark_threshold_um = 2.0;
  double path_tolerance_um = SimulatePartOptions{}.setpoint_path_tolerance_m * 1e6;
  double turning_path_tolerance_um = SimulatePartOptions{}.setpoint_turning_path_tolerance_m * 1e6;
  bool no_renders = false;
  bool no_commanded_check = false;
  std::string reference = "auto";  ///< commanded, simulated or auto
  double commanded_reference_fraction = SimulatePartOptions{}.commanded_reference_fraction;
  bool perfect_drives = false;
  bool third_order = false;
  bool no_third_order = false;
  std::string feedforward;  ///< "", "on" or "off"
  bool compare_methods = false;
  /// NaN = not given: the program's corner tolerances (G61 / G64 P / G5.1), else exact stop.
  double corner_tolerance_mm = std::numeric_limits<double>::quiet_NaN();
  /// NaN = not given: the compressor where the program asks (COMPCAD, CYCLE832).
  double compressor_tolerance_mm = std::numeric_limits<double>::quiet_NaN();
  double tolerance_um = 0.0;
  int threads = 0;
  long long compact_zmap_above_lines = static_cast<long long>(SimulatePartOptions{}.compact_zmap_above_lines);
  double servo_window_s = SimulatePartOptions{}.servo_window_s;
  long long gather_piece_lines = static_cast<long long>(SimulatePartOptions{}.gather_piece_lines);
  double memory_budget_gb = std::numeric_limits<double>::quiet_NaN();  ///< NaN: half the physical memory
  std::string spill_dir;           ///< "": the system's temporary directory
};

// The compact Z-maps' offsets in memory up to the budget, beyond it in files in the spill
// directory (removal/tile_store.hpp). The default leaves half the memory to the rest of the run,
// split between the ranks on this machine.
void set_spill(const CommandOptions& command) {
  removal::SpillSettings spill;
  if (!std::isnan(command.memory_budget_gb)) {
    if (!(command.memory_budget_gb >= 0.0 && command.memory_budget_gb <= 1e6)) {
      throw InputError("--memory-budget-gb must be >= 0 and at most 1e6, got " + format_double(command.memory_budget_gb));
    }
    spill.memory_budget_bytes = static_cast<std::size_t>(command.memory_budget_gb * 1073741824.0);
  } else {
    // Shared by the ranks mpirun started on this machine (OpenMPI names their count).
    const char* local_ranks_text = std::getenv("OMPI_COMM_WORLD_LOCAL_SIZE");
    const long local_ranks = local_ranks_text ? std::max(1L, std::strtol(local_ranks_text, nullptr, 10)) : 1L;
    const long pages = ::sysconf(_SC_PHYS_PAGES), page_bytes = ::sysconf(_SC_PAGE_SIZE);
    if (pages > 0 && page_bytes > 0) {
      spill.memory_budget_bytes = static_cast<std::size_t>(pages) * static_cast<std::size_t>(page_bytes) / 2 /
                                  static_cast<std::size_t>(local_ranks);
    }
  }
  if (!command.spill_dir.empty()) spill.directory = command.spill_dir;  // checked by CLI11: a directory
  removal::set_spill_settings(spill);
}

// The built-in sample: part 1 of the second paper on the Mikron sample, from the source tree
// this program was built from, or from ./samples when run from a checkout.
std::string built_in_part() {
  const std::string relative = "samples/parts/part1_tangency/part.yaml";
  const std::string in_source = std::string(VMSIM_SOURCE_DIR) + "/" + relative;
  if (std::filesystem::exists(in_source)) return in_source;
  if (std::filesystem::exists(relative)) return relative;
  throw InputError("the built-in sample " + relative +
                   " is not there (neither in the source tree nor here): give --part");
}

int run(const CommandOptions& command, const CommandContext& context) {
  SimulatePartOptions options;
  options.part_path = command.part_path.empty() ? built_in_part() : command.part_path;
  options.out_dir = command.out_dir;
  options.method = parse_method(command.method);
  options.limits = parse_limit_source(command.limits);
  options.effects = parse_effects(command.effects);
  if (command.production_feed_mm_per_min < 0 || command.reference_feed_mm_per_min < 0) {
    throw InputError("feeds must be > 0");
  }
  options.production_feed_m_per_s = command.production_feed_mm_per_min * 1e-3 / 60.0;
  options.reference_feed_m_per_s = command.reference_feed_mm_per_min * 1e-3 / 60.0;
  if (!(command.grid_um > 0)) throw InputError("--grid-um must be > 0, got " + format_double(command.grid_um));
  if (!(command.mark_threshold_um > 0)) {
    throw InputError("--mark-threshold-um must be > 0, got " + format_double(command.mark_threshold_um));
  }
  options.grid_m = command.grid_um * 1e-6;
  options.mark_threshold_m = command.mark_threshold_um * 1e-6;
  if (!(command.path_tolerance_um > 0) || !std::isfinite(command.path_tolerance_um)) {
    throw InputError("--path-tolerance-um must be > 0, got " + format_double(command.path_tolerance_um));
  }
  options.setpoint_path_tolerance_m = command.path_tolerance_um * 1e-6;
  if (!(command.turning_path_tolerance_um > 0) || !std::isfinite(command.turning_path_tolerance_um)) {
    throw InputError("--turning-path-tolerance-um must be > 0, got " + format_double(command.turning_path_tolerance_um));
  }
  options.setpoint_turning_path_tolerance_m = command.turning_path_tolerance_um * 1e-6;
  options.renders = !command.no_renders;
  options.commanded_check = !command.no_commanded_check;
  options.reference_mode = command.reference == "commanded"   ? ReferenceMode::commanded
                           : command.reference == "simulated" ? ReferenceMode::simulated
                                                              : ReferenceMode::automatic;
  if (!(command.commanded_reference_fraction > 0) || !(command.commanded_reference_fraction <= 1)) {
    throw InputError("--commanded-reference-fraction must be > 0 and at most 1, got " +
                     format_double(command.commanded_reference_fraction));
  }
  options.commanded_reference_fraction = command.commanded_reference_fraction;
  if (command.compact_zmap_above_lines < 0) {
    throw InputError("--compact-zmap-above-lines must be >= 0, got " + std::to_string(command.compact_zmap_above_lines));
  }
  options.compact_zmap_above_lines = static_cast<std::size_t>(command.compact_zmap_above_lines);
  if (command.gather_piece_lines < 1) {
    throw InputError("--gather-piece-lines must be >= 1, got " + std::to_string(command.gather_piece_lines));
  }
  options.gather_piece_lines = static_cast<std::size_t>(command.gather_piece_lines);
  if (!(command.servo_window_s > 0) || !std::isfinite(command.servo_window_s)) {
    throw InputError("--servo-window-s must be > 0, got " + format_double(command.servo_window_s));
  }
  options.servo_window_s = command.servo_window_s;
  options.perfect_drives = command.perfect_drives;
  if (command.third_order && command.no_third_order) {
    throw InputError("--third-order and --no-third-order contradict each other: give one");
  }
  if (command.third_order || command.no_third_order) options.third_order = command.third_order;
  if (!command.feedforward.empty()) options.feedforward = command.feedforward == "on";
  options.compare_methods = command.compare_methods;
  const bool tolerance_given = !std::isnan(command.corner_tolerance_mm);
  if (tolerance_given && !(command.corner_tolerance_mm >= 0.0)) {
    throw InputError("--corner-tolerance-mm must be >= 0, got " + format_double(command.corner_tolerance_mm));
  }
  options.corner_tolerance_m = tolerance_given ? command.corner_tolerance_mm * 1e-3 : 0.0;
  options.corner_tolerance_override = tolerance_given;
  if (!std::isnan(command.compressor_tolerance_mm)) {
    if (!(command.compressor_tolerance_mm >= 0.0) || !std::isfinite(command.compressor_tolerance_mm)) {
      throw InputError("--compressor-tolerance-mm must be >= 0, got " + format_double(command.compressor_tolerance_mm));
    }
    options.compressor_tolerance_override_m = command.compressor_tolerance_mm * 1e-3;
  }
  options.threads = command.threads;
  if (!(command.tolerance_um >= 0.0) || command.tolerance_um > 1e4) {
    throw InputError("--tolerance-um must be > 0 and at most 10 000 (10 mm), got " +
                     format_double(command.tolerance_um));
  }
  options.tolerance_m = command.tolerance_um * 1e-6;
  options.command_line = context.command_line;
  set_spill(command);

  const auto start = std::chrono::steady_clock::now();
  const bool terminal = ::isatty(STDOUT_FILENO) != 0;
  const ProgressSink progress = [&](const std::string& line) {
    if (context.quiet) return;
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    char stamp[32];
    std::snprintf(stamp, sizeof stamp, "[%6.1f s] ", elapsed);
    // On a terminal each stage overwrites the previous line; in a log every line stays.
    if (terminal) {
      std::cout << '\r' << stamp << line << "\033[K" << std::flush;
    } else {
      std::cout << stamp << line << std::endl;  // flushed: a log shows where a long run is
    }
  };
  const nlohmann::json report = simulate_part(options, progress);
  if (terminal && !context.quiet) std::cout << '\n';
  if (report.empty()) return 0;  // a rank other than 0 of an MPI job: rank 0 reports

  context.say("wrote " + options.out_dir + "/ (report.json, report.html, marks.csv, surfaces, images)");
  const auto& production = report["runs"]["production"];
  const auto& reference = report["runs"]["reference"];
  context.say("production " + format_double(production["feed_mm_per_min"].get<double>()) +
              " mm/min: T = " + format_double(std::round(production["duration_s"].get<double>() * 1e3) / 1e3) +
              " s; reference " + format_double(reference["feed_mm_per_min"].get<double>()) +
              " mm/min: T = " + format_double(std::round(reference["duration_s"].get<double>() * 1e3) / 1e3) + " s");
  if (production.contains("tool_tip_while_cutting")) {
    const auto& tip = production["tool_tip_while_cutting"];
    std::string line = "production tool tip while cutting: off the commanded path by up to " +
                       format_double(std::round(tip["contour_error_peak_um"].get<double>() * 10) / 10) + " um (RMS " +
                       format_double(std::round(tip["contour_error_rms_um"].get<double>() * 10) / 10) + " um)";
    if (tip.contains("joint_deflection_peak_um")) {
      line += ", of which the joints' elastic deflection up to " +
              format_double(std::round(tip["joint_deflection_peak_um"].get<double>() * 10) / 10) + " um";
    }
    context.say(line);
  }
  context.say(report["verdict"]["headline"].get<std::string>());
  context.say("marks deeper than " + format_double(options.mark_threshold_m * 1e6) +
              " um: " + std::to_string(report["marks"].size()) + " (and " +
              std::to_string(report["specks"]["count"].get<std::size_t>()) + " specks too small to be marks)");
  std::size_t shown = 0;
  for (const auto& mark : report["marks"]) {
    if (shown++ == 5) break;
    const std::string places = joined(mark["place"], ", ", true);
    const std::string axes = joined(mark["responsible_axes"], ",", false);
    char line[400];
    std::snprintf(line, sizeof line, "  %-6s %7.2f um, %8.3f mm2, at s = %.2f mm (%s)%s%s%s",
                  mark["kind"].get<std::string>().c_str(), mark["depth_um"].get<double>(),
                  mark["area_mm2"].get<double>(), mark["s_mm"].get<double>(),
                  mark["block"].get<std::string>().c_str(), places.empty() ? "" : ", ",
                  places.c_str(), axes.empty() ? "" : (", axes " + axes).c_str());
    context.say(line);
  }
  if (report["renders"].contains("skipped")) {
    context.warn("no images: " + report["renders"]["skipped"].get<std::string>() +
                 " (every numerical result was written)");
  }
  return 0;
}

}  // namespace

void add_simulate_part_command(CLI::App& app, CommandContext& context) {
  auto options = std::make_shared<CommandOptions>();
  CLI::App* command = app.add_subcommand(
      "simulate-part",
      "the whole chain for one part at production and reference feed: marks found and related "
      "to the tool path, report and images (no arguments: the built-in sample, part 1)");
  command->add_option("--part", options->part_path, "part file (part.yaml)")->check(CLI::ExistingFile);
  command->add_option("--out", options->out_dir, "output folder: new, empty or a previous vmsim result (replaced as a whole)")->capture_default_str();
  command->add_option("--method", options->method, "feedrate planning: kinematic or dynamic")
      ->capture_default_str();
  command->add_option("--limits", options->limits,
                      "dynamic limits: tuned (Eq. 10 from the kinematic limits) or actuator (Table 2)")
      ->capture_default_str();
  command->add_option("--effects", options->effects, "dynamic effects: H,Hcpl,B,C,G,F or all")
      ->capture_default_str();
  command->add_option("--feed-mm-per-min", options->production_feed_mm_per_min,
                      "production feed (default: the part file's)");
  command->add_option("--reference-feed-mm-per-min", options->reference_feed_mm_per_min,
                      "reference feed (default: the part file's)");
  command->add_option("--grid-um", options->grid_um, "Z-map line spacing [um]")->capture_default_str();
  command->add_option("--mark-threshold-um", options->mark_threshold_um,
                      "a mark is a connected region deviating by more than this [um]")
      ->capture_default_str();
  command->add_option("--path-tolerance-um", options->path_tolerance_um,
                      "largest distance of a set point's tool tip from the programmed path [um]: the "
                      "planner adds points until its path holds it; a set point beyond it stops the run")
      ->capture_default_str();
  command->add_option("--turning-path-tolerance-um", options->turning_path_tolerance_um,
                      "the same where the programmed tool axis turns between two points (simultaneous "
                      "5-axis motion) [um]")
      ->capture_default_str();
  command->add_option("--tolerance-um", options->tolerance_um,
                      "the deepest mark the part can take [um]: the report's verdict (default: the part "
                      "file's tolerance_um; none: no verdict)");
  command->add_option("--threads", options->threads, "threads for the removal (0: all)")
      ->capture_default_str();
  command->add_flag("--perfect-drives", options->perfect_drives,
                    "the axes follow the planned motion exactly (no servo): what the planner alone does");
  command->add_flag("--no-renders", options->no_renders, "write no images");
  command->add_flag("--compare-methods", options->compare_methods,
                    "also run the production feed with the other planning method (kinematic / "
                    "dynamic) and report cycle time and marks side by side");
  command->add_flag("--third-order", options->third_order,
                    "apply jerk / torque-rate limits in the plan (as SOFT on a Siemens 840D; exact, "
                    "slower planning); default: what the program asks (SOFT / BRISK, CYCLE832), "
                    "no jerk limit where it says nothing");
  command->add_flag("--no-third-order", options->no_third_order,
                    "velocity and acceleration (or torque) limits only (BRISK), whatever the program asks");
  command->add_option("--feedforward", options->feedforward,
                      "the drives' feedforward: on (as the machine file configures it) or off; default: "
                      "what the program asks (FFWON / FFWOF), the machine file's where it says nothing")
      ->check(CLI::IsMember({"on", "off"}));
  command->add_option("--corner-tolerance-mm", options->corner_tolerance_mm,
                      "blend G1 corners within this distance [mm] (0: exact stop) at every "
                      "corner; default: what the program asks (G61 / G9 exact stop, G64 P, "
                      "G5.1), exact stop where it says nothing");
  command->add_option("--compressor-tolerance-mm", options->compressor_tolerance_mm,
                      "the NC block compressor (840D COMPCAD) within this tolerance [mm] on every run of "
                      "short G1 blocks, 0: off; default: where the program asks (COMPCAD / COMPCURV / "
                      "COMPON, CYCLE832), within its tolerance");
  command->add_flag("--no-commanded-check", options->no_commanded_check,
                    "skip cutting the commanded path to check the reference run");
  command->add_option("--reference", options->reference,
                      "the surface production is compared with: commanded (the planned tool path's, valid "
                      "within the bound the reference run's path stages measure: one removal less), "
                      "simulated (the reference run cut), or auto: commanded where the bound is within "
                      "--commanded-reference-fraction of the mark threshold")
      ->check(CLI::IsMember({"commanded", "simulated", "auto"}))
      ->capture_default_str();
  command->add_option("--commanded-reference-fraction", options->commanded_reference_fraction,
                      "--reference auto: the largest bound on the line heights, as a fraction of the mark "
                      "threshold, at which the planned tool path's surface is the reference")
      ->capture_default_str();
  command->add_option("--compact-zmap-above-lines", options->compact_zmap_above_lines,
                      "Z-maps with more lines store heights compactly (float offsets from a base a "
                      "tile, within 2^-24 of the depth; tiles only where a tool reaches); 0 = always")
      ->capture_default_str();
  command->add_option("--gather-piece-lines", options->gather_piece_lines,
                      "under mpirun: each rank sends rank 0 its band of a view in pieces of about this "
                      "many lines (whole tile rows; the results do not depend on it)")
      ->capture_default_str();
  command->add_option("--servo-window-s", options->servo_window_s,
                      "the servo, direct kinematics and thinning run in windows of this much machine "
                      "time [s] (memory bounded by the window; the results do not depend on it)")
      ->capture_default_str();
  command->add_option("--memory-budget-gb", options->memory_budget_gb,
                      "compact Z-map heights held in memory [GiB]; beyond it they go to memory-mapped "
                      "files in --spill-dir, removed at once (default: half the physical memory)");
  command->add_option("--spill-dir", options->spill_dir,
                      "directory of those files (default: the system's temporary directory)")
      ->check(CLI::ExistingDirectory);
  command->callback([options, &context] { context.result = run(*options, context); });
}

}  // namespace vmsim::app
