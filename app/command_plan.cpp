// vmsim plan: feedrate interpolation (the NC's interpolator): the maximum feedrate profile
// (first paper, Sec. 2), the executed profile under every limit, and the axis set points at the
// machine's interpolation period.
#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <iomanip>
#include <memory>
#include <sstream>

#include "chain_inputs.hpp"
#include "commands.hpp"
#include "effects_option.hpp"
#include "vmsim/common/errors.hpp"
#include "vmsim/common/files.hpp"
#include "vmsim/common/trace.hpp"
#include "vmsim/planner/feedrate.hpp"

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
  bool exact_stop = false;
  bool no_third_order = false;
};

std::string number(double value) {
  if (std::isinf(value)) return "inf";
  return format_double(value);
}

int run_plan(const PlanOptions& options, const CommandContext& context) {
  planner::FeedrateOptions fo;
  fo.method = parse_method(options.method);
  fo.limits = parse_limit_source(options.limits);
  fo.effects = parse_effects(options.effects);
  fo.third_order = !options.no_third_order;
  if (options.feed_mm_per_min < 0.0) {
    throw InputError("--feed-mm-per-min must be > 0, got " + format_double(options.feed_mm_per_min));
  }
  fo.feed_m_per_s = options.feed_mm_per_min * 1e-3 / 60.0;
  if (options.corner_tolerance_mm > 0.0 && !options.exact_stop) {
    throw InputError("--corner-tolerance-mm: corner blending is not implemented yet; use "
                     "--exact-stop (the default: feed 0 at every corner)");
  }

  const ChainInputs inputs = load_chain_inputs(options.inputs);
  for (const std::string& warning : inputs.warnings) context.warn(warning);
  const kinematics::PathKinematics path = kinematics::solve_path_kinematics(
      inputs.machine, inputs.path, inputs.machine.home_positions(), inputs.tool_length_m,
      inputs.block_names);
  fo.point_feed_m_per_s.resize(path.s_m.size(), 0.0);
  for (std::size_t i = 0; i < path.s_m.size(); ++i) {
    const planner::PathPoint& point = inputs.toolpath.points[inputs.toolpath_point[i]];
    fo.point_feed_m_per_s[i] = point.kind == planner::MotionKind::rapid ? 0.0 : point.feed_m_per_s;
  }
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
  summary["corners"] = "exact stop";
  summary["period_s"] = plan.setpoints.period_s;
  summary["setpoints"] = plan.setpoints.t_s.size();
  summary["grid_points"] = prof.s_m.size();
  summary["path_length_mm"] = prof.s_m.back() * 1e3;
  summary["slowdown_rounds"] = plan.slowdown_rounds;
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

  // Everything computed: write.
  std::filesystem::create_directories(options.out_dir);
  const std::filesystem::path dir(options.out_dir);
  write_file_atomically((dir / "limits.csv").string(), limits_csv.str());
  write_file_atomically((dir / "setpoints.csv").string(), format_trace(trace));
  write_file_atomically((dir / "summary.json").string(), summary.dump(2) + "\n");

  std::ostringstream line;
  line << std::setprecision(5) << "T = " << plan.duration_s << " s, T_lb = " << plan.lower_bound_s
       << " s (T / T_lb = " << plan.duration_s / plan.lower_bound_s << "), "
       << plan.setpoints.t_s.size() << " set points at " << plan.setpoints.period_s * 1e3
       << " ms; wrote " << options.out_dir << "/{limits.csv,setpoints.csv,summary.json}";
  context.say(line.str());
  for (const auto& note : plan.notes) context.say("note: " + note);
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
  auto* tolerance = command->add_option("--corner-tolerance-mm", options->corner_tolerance_mm,
                                        "corner blending tolerance (not implemented yet)");
  command->add_flag("--exact-stop", options->exact_stop, "stop at every corner (the default)")
      ->excludes(tolerance);
  command->add_flag("--no-third-order", options->no_third_order,
                    "leave out the jerk / torque-rate limits");
  command->add_option("--out", options->out_dir,
                      "output folder: limits.csv, setpoints.csv, summary.json")
      ->required();
  command->callback([options, &context] { context.result = run_plan(*options, context); });
}

}  // namespace vmsim::app
