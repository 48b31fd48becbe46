// vmsim plan: feedrate interpolation (the NC's interpolator): the maximum feedrate profile
// (first paper, Sec. 2), the executed profile under every limit, and the axis set points at the
// machine's interpolation period; optionally with the corners blended within a tolerance
// (planner/corner_blend.hpp); a plot of sd_lim and the executed feedrate along s (PNG).
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <limits>
#include <memory>
#include <numbers>
#include <sstream>

#include "chain_inputs.hpp"
#include "commands.hpp"
#include "effects_option.hpp"
#include "input_files.hpp"
#include "json_text.hpp"
#include "nc_modes.hpp"
#include "vmsim/common/errors.hpp"
#include "vmsim/common/files.hpp"
#include "vmsim/common/output_folder.hpp"
#include "vmsim/common/trace.hpp"
#include "vmsim/planner/feedrate.hpp"
#include "vmsim/viz/display.hpp"
#include "vmsim/viz/plot.hpp"

namespace vmsim::app {
namespace {

struct PlanOptions {
  ChainInputOptions inputs;
  std::string out_dir;
  std::string method = "kinematic";
  std::string limits = "tuned";
  std::string effects = "all";
  double feed_mm_per_min = 0.0;
  double corner_tolerance_mm = 0.0;
  double compressor_tolerance_mm = std::numeric_limits<double>::quiet_NaN();
  double corner_axis_tolerance_deg = planner::CornerBlendOptions{}.axis_tolerance_rad * 180.0 / std::numbers::pi;
  bool exact_stop = false;
  bool no_third_order = false;
  bool third_order = false;
  bool no_plot = false;
  double path_tolerance_um = planner::FeedrateOptions{}.path_tolerance_m * 1e6;
  double turning_path_tolerance_um = planner::FeedrateOptions{}.turning_path_tolerance_m * 1e6;
};

std::string number(double value) {
  if (std::isinf(value)) return "inf";
  return format_double(value);
}

// plan.png: sd_lim of each constraint kind in force (the paper's prediction, sdd = sddd = 0),
// the admissible feed (their minimum, lowered where the set-point checks asked) and the
// executed feedrate, in m/min along s in mm. Limits far above the executed feed (e.g. +inf:
// acceleration on a straight line) are clipped at the top of the plot.
viz::LinePlot feedrate_plot(const planner::FeedrateProfile& prof, const std::string& title) {
  constexpr double kMPerMin = 60.0;
  viz::LinePlot plot;
  plot.title = title;
  plot.x_title = "s [mm]";
  plot.y_title = "feedrate [m/min]";
  std::vector<double> s_mm(prof.s_m.size());
  for (std::size_t i = 0; i < s_mm.size(); ++i) s_mm[i] = prof.s_m[i] * 1e3;
  double top = 0.0;
  for (std::size_t i = 0; i < prof.s_m.size(); ++i) {
    top = std::max(top, prof.sd[i]);
    if (std::isfinite(prof.sd_lim[i])) top = std::max(top, prof.sd_lim[i]);
  }
  top = (top > 0.0 ? 1.15 * top : 1.0) * kMPerMin;
  plot.y_range = viz::Range{0.0, top};
  auto series = [&](const std::string& name, const std::vector<double>& sd, viz::LineStyle style,
                    double width_px) {
    viz::Series out;
    out.name = name;
    out.x = s_mm;
    out.y.resize(sd.size());
    for (std::size_t i = 0; i < sd.size(); ++i) out.y[i] = std::min(sd[i] * kMPerMin, top);
    out.style = style;
    out.line_width_px = width_px;
    plot.series.push_back(std::move(out));
  };
  for (int kind = 0; kind < planner::kConstraintKindCount; ++kind) {
    const auto& values = prof.sd_lim_by_kind[static_cast<std::size_t>(kind)];
    if (std::none_of(values.begin(), values.end(), [](double v) { return std::isfinite(v); })) {
      continue;  // not in force on this path
    }
    series("sd_lim " +
               std::string(planner::constraint_name(static_cast<planner::ConstraintKind>(kind))),
           values, viz::LineStyle::dotted, 2.0);
  }
  series("admissible (lowest sd_lim, after set-point checks)", prof.sd_cap, viz::LineStyle::dashed,
         1.5);
  series("executed", prof.sd, viz::LineStyle::solid, 2.5);
  return plot;
}

int run_plan(const PlanOptions& options, const CommandContext& context) {
  planner::FeedrateOptions fo;
  fo.method = parse_method(options.method);
  fo.limits = parse_limit_source(options.limits);
  fo.effects = parse_effects(options.effects);
  if (options.feed_mm_per_min < 0.0) {
    throw CommandLineError("--feed-mm-per-min must be > 0, got " + format_double(options.feed_mm_per_min));
  }
  fo.feed_m_per_s = options.feed_mm_per_min * 1e-3 / 60.0;
  if (!(options.path_tolerance_um > 0.0) || !std::isfinite(options.path_tolerance_um)) {
    throw CommandLineError("--path-tolerance-um must be > 0, got " + format_double(options.path_tolerance_um));
  }
  fo.path_tolerance_m = options.path_tolerance_um * 1e-6;
  if (!(options.turning_path_tolerance_um > 0.0) || !std::isfinite(options.turning_path_tolerance_um)) {
    throw CommandLineError("--turning-path-tolerance-um must be > 0, got " +
                           format_double(options.turning_path_tolerance_um));
  }
  fo.turning_path_tolerance_m = options.turning_path_tolerance_um * 1e-6;
  ChainInputOptions input_options = options.inputs;
  if (!options.exact_stop) {
    input_options.corner_tolerance_m = options.corner_tolerance_mm * 1e-3;
    input_options.corner_axis_tolerance_rad = options.corner_axis_tolerance_deg * std::numbers::pi / 180.0;
  }
  // Either option overrides the program's corner tolerances (G61 / G64 P / G5.1); without them
  // the program's apply, exact stop where it says nothing.
  input_options.corner_tolerance_override = options.exact_stop || options.corner_tolerance_mm > 0.0;
  if (!std::isnan(options.compressor_tolerance_mm)) {
    if (!(options.compressor_tolerance_mm >= 0.0) || !std::isfinite(options.compressor_tolerance_mm)) {
      throw CommandLineError("--compressor-tolerance-mm must be >= 0, got " + format_double(options.compressor_tolerance_mm));
    }
    input_options.compressor_tolerance_override_m = options.compressor_tolerance_mm * 1e-3;
  }

  const ChainInputs inputs = load_chain_inputs(input_options);
  // Jerk limits: the command line's, else the program's SOFT / BRISK, else on (plan's default).
  NcModeCommandLine nc_command_line;
  if (options.third_order || options.no_third_order) nc_command_line.third_order = options.third_order;
  nc_command_line.third_order_option = options.third_order ? "--third-order" : "--no-third-order";
  nc_command_line.corner_override = input_options.corner_tolerance_override;
  nc_command_line.corner_tolerance_m = input_options.corner_tolerance_m;
  nc_command_line.default_third_order = true;
  nc_command_line.compressor_override = !std::isnan(input_options.compressor_tolerance_override_m);
  nc_command_line.compressor_tolerance_m = nc_command_line.compressor_override ? input_options.compressor_tolerance_override_m : 0.0;
  nc_command_line.compression = inputs.compression;
  const NcModes nc_modes = decide_nc_modes(inputs.toolpath, nc_command_line);
  fo.third_order = nc_modes.third_order;
  OutputFolder output(options.out_dir, chain_input_files(input_options, inputs), {"plan", VMSIM_VERSION});
  for (const std::string& warning : inputs.warnings) context.warn(warning);
  if (!inputs.tool_roll.empty()) context.say("note: " + inputs.tool_roll);
  const kinematics::PathKinematics path = kinematics::solve_path_kinematics(
      inputs.machine, inputs.path, inputs.q_start, inputs.tool_length_m,
      inputs.block_names, inputs.path_kinematics);
  // The programmed feeds (G94 F, G93 inverse time); rapids and turns about a fixed tip on the
  // axes' own limits.
  fo.point_feed_m_per_s = point_feeds_m_per_s(inputs, path, FeedSetting{});
  fo.point_dwell_s = inputs.point_dwell_s;
  fo.rapid_end = rapid_ends(inputs);
  fo.point_path_tolerance_m = inputs.contour_tolerance_m;
  const planner::FeedratePlan plan = planner::plan_feedrate(inputs.machine, path, fo);
  const auto& prof = plan.profile;
  const auto& axes = inputs.machine.axes;

  // limits.csv: one row per grid point.
  std::ostringstream limits_csv;
  limits_csv << "# source: vmsim plan (maximum feedrate profile, first paper Eq. 1-2 / 7-9, and "
                "the executed profile)\n";
  limits_csv << "# method: " << options.method << "\n# limits: " << options.limits
             << "\n# effects: " << options.effects << "\n";
  limits_csv << "s_mm";
  for (int kind = 0; kind < planner::kConstraintKindCount; ++kind) {
    limits_csv << ",sd_lim_" << planner::constraint_name(static_cast<planner::ConstraintKind>(kind))
               << "_mm_per_s";
  }
  limits_csv << ",sd_lim_mm_per_s,limiting_axis,limiting_constraint,sd_cap_mm_per_s,t_s,"
                "sd_mm_per_s,sdd_mm_per_s2,stop\n";
  for (std::size_t i = 0; i < prof.s_m.size(); ++i) {
    limits_csv << format_double(prof.s_m[i] * 1e3);
    for (int kind = 0; kind < planner::kConstraintKindCount; ++kind) {
      limits_csv << ',' << number(prof.sd_lim_by_kind[static_cast<std::size_t>(kind)][i] * 1e3);
    }
    const int axis = prof.limiting_axis[i];
    limits_csv << ',' << number(prof.sd_lim[i] * 1e3) << ','
               << (axis >= 0 ? axes[static_cast<std::size_t>(axis)].name : std::string("-")) << ','
               << planner::constraint_name(prof.limiting_kind[i]) << ','
               << number(prof.sd_cap[i] * 1e3) << ',' << format_double(prof.t_s[i]) << ','
               << format_double(prof.sd[i] * 1e3) << ',' << format_double(prof.sdd[i] * 1e3) << ','
               << (prof.stop[i] ? 1 : 0) << '\n';
  }

  // setpoints.csv: the trace format.
  Trace trace;
  trace.metadata = {{"source", "vmsim plan (axis set points at the interpolation period)"},
                    {"machine", inputs.machine.source_file},
                    {"period_s", format_double(plan.setpoints.period_s)},
                    {"method", options.method}};
  trace.add_column("t", plan.setpoints.t_s);
  std::vector<double> s_mm(plan.setpoints.s_m.size());
  for (std::size_t n = 0; n < s_mm.size(); ++n) s_mm[n] = plan.setpoints.s_m[n] * 1e3;
  trace.add_column("s_mm", s_mm);
  for (std::size_t j = 0; j < axes.size(); ++j) {
    std::vector<double> values(plan.setpoints.t_s.size());
    for (std::size_t n = 0; n < values.size(); ++n) {
      values[n] = to_trace_unit(axes[j], plan.setpoints.q(static_cast<Eigen::Index>(j),
                                                          static_cast<Eigen::Index>(n)));
    }
    trace.add_column(axes[j].name + ".cmd", values);
  }

  // summary.json
  nlohmann::json summary;
  summary["duration_s"] = plan.duration_s;
  summary["lower_bound_s"] = plan.lower_bound_s;
  summary["duration_over_lower_bound"] = plan.duration_s / plan.lower_bound_s;
  summary["method"] = options.method;
  summary["limits"] = options.limits;
  summary["effects"] = options.effects;
  summary["third_order"] = fo.third_order;
  summary["nc_modes"] = nc_modes.to_json();
  auto block_name = [&inputs](int block) {
    return block >= 0 ? inputs.block_names[static_cast<std::size_t>(block)] : std::string("-");
  };
  nlohmann::json corners = nlohmann::json::object();
  // Blending ran where a tolerance was given, or where the program asks one (G64 P / G5.1).
  const bool blending = input_options.corner_tolerance_m > 0.0 || !inputs.blended_corners.empty() ||
                        !inputs.exact_stop_corners.empty();
  corners["mode"] = input_options.corner_tolerance_m > 0.0 ? "blended"
                    : blending                             ? "the program's tolerances"
                                                           : "exact stop";
  if (blending) {
    if (input_options.corner_tolerance_m > 0.0) corners["tolerance_mm"] = options.corner_tolerance_mm;
    corners["axis_tolerance_deg"] = options.corner_axis_tolerance_deg;
    corners["blended"] = inputs.blended_corners.size();
    double deviation = 0.0, axis_deviation = 0.0;
    for (const auto& blend : inputs.blended_corners) {
      deviation = std::max(deviation, blend.deviation_m);
      axis_deviation = std::max(axis_deviation, blend.axis_deviation_rad);
    }
    corners["largest_deviation_mm"] = deviation * 1e3;
    corners["largest_axis_deviation_deg"] = axis_deviation * 180.0 / std::numbers::pi;
    nlohmann::json kept = nlohmann::json::array();
    for (const auto& corner : inputs.exact_stop_corners) {
      kept.push_back({{"block", block_name(corner.block)},
                      {"turn_angle_deg", corner.turn_angle_rad * 180.0 / std::numbers::pi},
                      {"reason", corner.reason}});
    }
    corners["exact_stops"] = kept;
  }
  corners["corners_in_planned_path"] = path.corners.size();
  summary["corners"] = corners;
  summary["period_s"] = plan.setpoints.period_s;
  summary["setpoints"] = plan.setpoints.t_s.size();
  summary["grid_points"] = prof.s_m.size();
  summary["path_length_mm"] = prof.s_m.back() * 1e3;
  summary["slowdown_rounds"] = plan.slowdown_rounds;
  // Path fidelity (planner/path_fidelity.hpp): points added on the programmed path, and the
  // set points' largest distance from it.
  if (plan.path_fidelity_checked) {
    double contour_tolerance_max_m = 0.0;  // where the program allows more (G64 P, G5.1)
    for (const double t : inputs.contour_tolerance_m) contour_tolerance_max_m = std::max(contour_tolerance_max_m, t);
    summary["path_fidelity"] = {{"tolerance_um", fo.path_tolerance_m * 1e6},
                                {"turning_tolerance_um", fo.turning_path_tolerance_m * 1e6},
                                {"largest_contour_tolerance_um", contour_tolerance_max_m * 1e6},
                                {"points_added", plan.points_added},
                                {"largest_deviation_um", plan.path_deviation_max_m * 1e6},
                                {"largest_deviation_s_mm", plan.path_deviation_s_m * 1e3},
                                {"largest_deviation_block", plan.path_deviation_block},
                                {"largest_axis_deviation_deg", plan.path_axis_deviation_max_rad * 180.0 / std::numbers::pi}};
  }
  summary["notes"] = plan.notes;
  // Share of the path length over which each constraint (and axis) limits sd_lim.
  nlohmann::json limiting = nlohmann::json::object();
  for (std::size_t i = 0; i + 1 < prof.s_m.size(); ++i) {
    const int axis = prof.limiting_axis[i];
    const std::string key = std::string(planner::constraint_name(prof.limiting_kind[i])) +
                            (axis >= 0 ? " " + axes[static_cast<std::size_t>(axis)].name : "");
    const double share = (prof.s_m[i + 1] - prof.s_m[i]) / prof.s_m.back();
    limiting[key] = limiting.value(key, 0.0) + share;
  }
  summary["limiting_share_of_path"] = limiting;
  nlohmann::json check = nlohmann::json::object();
  for (std::size_t j = 0; j < axes.size(); ++j) {
    nlohmann::json row = nlohmann::json::object();
    for (int kind = 1; kind < planner::kConstraintKindCount; ++kind) {
      const double r = plan.check.ratio(static_cast<Eigen::Index>(j), kind);
      if (r > 0.0) row[std::string(planner::constraint_name(static_cast<planner::ConstraintKind>(kind)))] = r;
    }
    check[axes[j].name] = row;
  }
  summary["peak_over_limit_on_setpoints"] = check;
  nlohmann::json limit_values = nlohmann::json::object();
  for (std::size_t j = 0; j < axes.size(); ++j) {
    const auto& l = plan.limits[j];
    limit_values[axes[j].name] = {{"velocity_si", l.velocity},
                                  {"acceleration_si", l.acceleration},
                                  {"jerk_si", l.jerk},
                                  {"torque_N_m", l.torque_N_m},
                                  {"torque_rate_N_m_per_s", l.torque_rate_N_m_per_s}};
  }
  summary["limit_values"] = limit_values;

  // The plot needs an X display; without one every numerical file is still written and the
  // reason goes to the summary and the terminal (as simulate-part does with its images).
  std::string no_display;
  const bool plot = !options.no_plot && viz::display_available(no_display);
  summary["plot"] = plot ? std::string("plan.png")
                         : options.no_plot ? std::string("skipped: --no-plot")
                                           : "skipped: " + no_display;

  // Everything computed: write into the staging folder, then swap the set in.
  if (plot) {
    viz::write_line_plot_png(output.path_of("plan.png"),
                             feedrate_plot(prof, "Feedrate along the path: sd_lim and executed (" +
                                                     options.method + ")"));
  }
  write_file_atomically(output.path_of("limits.csv"), limits_csv.str());
  write_file_atomically(output.path_of("setpoints.csv"), format_trace(trace));
  write_file_atomically(output.path_of("summary.json"), json_file_text(summary));
  output.commit();

  std::ostringstream line;
  line << std::setprecision(5) << "T = " << plan.duration_s << " s, T_lb = " << plan.lower_bound_s
       << " s (T / T_lb = " << plan.duration_s / plan.lower_bound_s << "), "
       << plan.setpoints.t_s.size() << " set points at " << plan.setpoints.period_s * 1e3
       << " ms; wrote " << options.out_dir << "/{limits.csv,setpoints.csv,summary.json"
       << (plot ? ",plan.png}" : "}");
  context.say(line.str());
  if (blending) {
    std::ostringstream blended;
    blended << std::setprecision(4) << "corners: " << inputs.blended_corners.size() << " blended within "
            << (input_options.corner_tolerance_m > 0.0 ? format_double(options.corner_tolerance_mm) + " mm"
                                                        : std::string("the program's tolerances"))
            << " (largest deviation "
            << corners["largest_deviation_mm"].get<double>() << " mm), "
            << inputs.exact_stop_corners.size() << " exact stops";
    context.say(blended.str());
    for (const auto& corner : inputs.exact_stop_corners) {
      context.say("  exact stop at " + block_name(corner.block) + ": " + corner.reason);
    }
  }
  for (const auto& note : plan.notes) context.say("note: " + note);
  context.say("NC mode: " + nc_modes.lines()[0]);
  if (!plot && !options.no_plot) {
    context.warn("no plot: " + no_display + " (every numerical file was written)");
  }
  return 0;
}

}  // namespace

void add_plan_command(CLI::App& app, CommandContext& context) {
  auto options = std::make_shared<PlanOptions>();
  CLI::App* command = app.add_subcommand(
      "plan", "feedrate interpolation: maximum feedrate profile, executed profile and axis set "
              "points at the interpolation period");
  add_chain_input_options(*command, options->inputs);
  command->add_option("--method", options->method, "kinematic (axis v, a, j) or dynamic (torque, torque rate)")
      ->capture_default_str();
  command->add_option("--limits", options->limits,
                      "dynamic limits: tuned (Eq. 10 from the kinematic limits) or actuator "
                      "(drive torque_max / torque_rate_max, Table 2)")
      ->capture_default_str();
  command->add_option("--effects", options->effects,
                      "dynamic effects: H,Hcpl,B,C,G,F or all")
      ->capture_default_str();
  command->add_option("--feed-mm-per-min", options->feed_mm_per_min,
                      "feed for the whole path (default: the programmed feeds; rapids unlimited)");
  auto* tolerance = command->add_option(
      "--corner-tolerance-mm", options->corner_tolerance_mm,
      "blend the corners of G1 polylines (tip tangent turning by more than 5 deg) with "
      "curvature-continuous curves that stay within this distance of the programmed path [mm]; "
      "rapids, reversals (> 176 deg) and orientation changes on the spot stay exact stops");
  tolerance->check(CLI::PositiveNumber);
  auto* axis_tolerance =
      command->add_option("--corner-axis-tolerance-deg", options->corner_axis_tolerance_deg,
                          "with --corner-tolerance-mm: largest angle between the blended and the "
                          "programmed tool axis at a corner [deg]")
          ->check(CLI::PositiveNumber)
          ->capture_default_str();
  axis_tolerance->needs(tolerance);
  command->add_option("--compressor-tolerance-mm", options->compressor_tolerance_mm,
                      "the NC block compressor (840D COMPCAD) within this tolerance [mm] on every run of "
                      "short G1 blocks, 0: off; default: where the program asks (COMPCAD / COMPCURV / "
                      "COMPON, CYCLE832), within its tolerance");
  command->add_flag("--exact-stop", options->exact_stop,
                    "stop at every corner, whatever the program asks (without it and "
                    "--corner-tolerance-mm: the program's G61 / G9 / G64 P / G5.1, exact stop "
                    "where it says nothing)")
      ->excludes(tolerance);
  auto* no_third = command->add_flag("--no-third-order", options->no_third_order,
                                     "leave out the jerk / torque-rate limits (BRISK), whatever the program asks");
  command->add_flag("--third-order", options->third_order,
                    "apply the jerk / torque-rate limits (SOFT), whatever the program asks; default: the "
                    "program's SOFT / BRISK / CYCLE832, jerk limits where it says nothing")
      ->excludes(no_third);
  command->add_flag("--no-plot", options->no_plot, "write no plan.png");
  command->add_option("--path-tolerance-um", options->path_tolerance_um,
                      "largest distance of a set point's tool tip from the programmed path [um]: the "
                      "planner adds points until its path holds it; a set point beyond it is an error")
      ->capture_default_str();
  command->add_option("--turning-path-tolerance-um", options->turning_path_tolerance_um,
                      "the same where the programmed tool axis turns between two points (simultaneous "
                      "5-axis motion) [um]")
      ->capture_default_str();
  command->add_option("--out", options->out_dir,
                      "output folder (new, empty or a previous vmsim result: replaced as a whole): "
                      "limits.csv, setpoints.csv, summary.json and plan.png (sd_lim "
                      "per constraint and the executed feedrate along s; needs an X display: run "
                      "under xvfb-run -a on a headless machine, else skipped with a warning)")
      ->required();
  command->callback([options, &context] { context.result = run_plan(*options, context); });
}

}  // namespace vmsim::app
