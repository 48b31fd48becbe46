// The diagnosis outputs: diagnosis.json (schema in identify/README.md), report.md, residuals.csv.
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstdio>
#include <sstream>

#include "vmsim/common/files.hpp"
#include "vmsim/identify/diagnose.hpp"

namespace vmsim::identify {
namespace {

using nlohmann::json;

bool linear(const kinematics::MachineModel& machine, int axis) {
  return machine.axes[static_cast<std::size_t>(axis)].type == kinematics::AxisType::linear;
}

// Joint unit -> the file unit (mm or deg) and its name.
double position_scale(bool lin) { return lin ? 1e3 : 180.0 / 3.141592653589793; }

json summary_json(const ResidualSummary& s, bool lin) {
  const double k = position_scale(lin);
  const std::string u = lin ? "_mm" : "_deg";
  return json{{"effort_rms_A", s.effort_rms_A},
              {"effort_peak_A", s.effort_peak_A},
              {"position_rms" + u, s.position_rms * k},
              {"position_peak" + u, s.position_peak * k},
              {"load_minus_motor_rms" + u, s.load_diff_rms * k},
              {"load_minus_motor_peak" + u, s.load_diff_peak * k},
              {"weighted_rms", s.weighted_rms}};
}

json candidate_json(const CandidateResult& c) {
  if (c.parameter_count == 0) {  // not observable in these data: nothing was fitted
    return json{{"effect", c.effect}, {"parameters", json::object()}, {"parameter_count", 0},
                {"evidence", c.evidence}, {"gain", nullptr}, {"found", false}};
  }
  json parameters = json::object();
  for (const auto& [name, value] : c.parameters) parameters[name] = value;
  return json{{"effect", c.effect},
              {"parameters", parameters},
              {"parameter_count", c.parameter_count},
              {"evidence", c.evidence},
              {"gain",
               {{"validation_cost_before", c.validation_cost_before},
                {"validation_cost_after", c.validation_cost_after},
                {"relative", c.relative_gain},
                {"score", c.score}}},
              {"found", c.found},
              {"channel", c.channel},
              {"bound_note", c.bound_note.empty() ? json(nullptr) : json(c.bound_note)}};
}

json contour_json(const ContourError& c) {
  if (!c.computed) return json{{"computed", false}, {"note", c.note}};
  return json{{"computed", true},
              {"tool_length_mm", c.tool_length_m * 1e3},
              {"samples", c.samples},
              {"contour_error_measured", {{"rms_um", c.measured_rms_um}, {"peak_um", c.measured_peak_um}}},
              {"contour_error_predicted_before",
               {{"rms_um", c.predicted_before_rms_um}, {"peak_um", c.predicted_before_peak_um}}},
              {"contour_error_predicted_after",
               {{"rms_um", c.predicted_after_rms_um}, {"peak_um", c.predicted_after_peak_um}}},
              {"residual_before", {{"rms_um", c.residual_before_rms_um}, {"peak_um", c.residual_before_peak_um}}},
              {"residual_after", {{"rms_um", c.residual_after_rms_um}, {"peak_um", c.residual_after_peak_um}}}};
}

std::string num(double v, const char* format = "%.4g") {
  char text[64];
  std::snprintf(text, sizeof text, format, v);
  return text;
}

}  // namespace

std::string diagnosis_json(const Diagnosis& diagnosis, const kinematics::MachineModel& machine,
                           const std::string& trace_file) {
  json root;
  root["machine"] = machine.source_file;
  root["trace"] = trace_file;
  root["validation"] = diagnosis.validation;
  root["effects"] = json::array();
  root["axes"] = json::array();
  for (const AxisDiagnosis& a : diagnosis.axes) {
    const bool lin = linear(machine, a.axis_index);
    const std::string u = lin ? "_mm" : "_deg";
    json axis;
    axis["axis"] = a.axis_name;
    axis["effort_signal"] = a.effort_signal;
    axis["samples"] = {{"fit", a.fit_samples}, {"validation", a.validation_samples}};
    axis["noise"] = {{"effort_A", a.effort_noise_A},
                     {"effort_filtered_A", a.effort_noise_filtered_A},
                     {"load_minus_motor" + u, a.load_diff_noise * position_scale(lin)},
                     {"position" + u, a.position_noise * position_scale(lin)},
                     {"source", a.noise_source},
                     {"control_cost_change", a.noise_control_cost},
                     {"validation_cost_before", a.validation_cost_before}};
    json phases = json::array();
    for (const auto& p : a.phases) {
      phases.push_back({{"phase", p.phase},
                        {"samples", p.samples},
                        {"effort_rms_A", p.effort_rms_A},
                        {"effort_mean_A", p.effort_mean_A},
                        {"effort_peak_A", p.effort_peak_A},
                        {"position_rms" + u, p.position_rms * position_scale(lin)}});
    }
    axis["phases"] = phases;
    json relations = json::array();
    for (const auto& r : a.relations) {
      relations.push_back({{"against", r.against}, {"r2", r.r2}, {"note", r.note}});
    }
    axis["relations"] = relations;
    json candidates = json::array();
    int rank = 1;
    for (const auto& c : a.first_round) {
      json j = candidate_json(c);
      j["rank"] = rank++;
      candidates.push_back(j);
    }
    axis["candidates"] = candidates;
    json found = json::array();
    int order = 1;
    for (const auto& c : a.found) {
      json j = candidate_json(c);
      j["axis"] = a.axis_name;
      j["order"] = order++;
      found.push_back(j);
      root["effects"].push_back(j);
    }
    axis["found"] = found;
    axis["before"] = summary_json(a.before, lin);
    axis["after"] = summary_json(a.after, lin);
    const Unexplained& x = a.unexplained;
    const double um = lin ? 1e6 : 1.0;  // joint unit -> um (linear); rotary axes stay in rad
    const std::string uu = lin ? "_um" : "_rad";
    axis["unexplained"] = {{"present", x.present},
                           {"effort_noise_units", x.effort_noise_units},
                           {"effort_rms_A", x.effort_rms_A},
                           {"load_minus_motor_noise_units", x.load_diff_noise_units},
                           {"load_minus_motor_rms" + uu, x.load_diff_rms * um},
                           {"position_noise_units", x.position_noise_units},
                           {"position_rms" + uu, x.position_rms * um},
                           {"t_from_s", x.t_from_s},
                           {"t_to_s", x.t_to_s},
                           {"phase", x.phase},
                           {"position_from" + u, x.position_from * position_scale(lin)},
                           {"position_to" + u, x.position_to * position_scale(lin)},
                           {"share_of_excess", x.span_share},
                           {"verdict", x.sentence}};
    root["axes"].push_back(axis);
  }
  root["held_axes"] = json::array();
  for (const HeldAxis& h : diagnosis.held_axes) {
    root["held_axes"].push_back({{"axis", h.axis_name}, {"reason", h.reason}});
  }
  root["tool_tip"] = contour_json(diagnosis.contour);
  return root.dump(2) + "\n";
}

std::string diagnosis_report(const Diagnosis& diagnosis, const kinematics::MachineModel& machine,
                             const std::string& trace_file) {
  std::ostringstream out;
  out << "# Drive model diagnosis\n\n"
      << "Machine `" << machine.source_file << "`, trace `" << trace_file
      << "`, judged on: " << diagnosis.validation << ".\n\n"
      << "Residual = measured - simulated (the servo simulation driven by the measured set "
         "points). Effort in equivalent current [A], low-passed (zero phase) before it is "
         "judged; positions in mm or deg.\n";
  for (const HeldAxis& h : diagnosis.held_axes) {
    out << "\nAxis " << h.axis_name << ": " << h.reason << ".\n";
  }
  const ContourError& tip = diagnosis.contour;
  if (tip.computed) {
    out << "\n## Tool tip\n\n"
        << "Contour error (the tip's deviation square to the commanded direction of motion; "
           "tool length "
        << num(tip.tool_length_m * 1e3) << " mm; " << tip.samples << " samples) [um]:\n\n"
        << "| | RMS | peak |\n|---|---|---|\n"
        << "| measured (pos vs cmd) | " << num(tip.measured_rms_um) << " | " << num(tip.measured_peak_um) << " |\n"
        << "| predicted, model before | " << num(tip.predicted_before_rms_um) << " | "
        << num(tip.predicted_before_peak_um) << " |\n"
        << "| predicted, model after | " << num(tip.predicted_after_rms_um) << " | "
        << num(tip.predicted_after_peak_um) << " |\n"
        << "| measured vs predicted, before | " << num(tip.residual_before_rms_um) << " | "
        << num(tip.residual_before_peak_um) << " |\n"
        << "| measured vs predicted, after | " << num(tip.residual_after_rms_um) << " | "
        << num(tip.residual_after_peak_um) << " |\n";
  }
  for (const AxisDiagnosis& a : diagnosis.axes) {
    const bool lin = linear(machine, a.axis_index);
    const double k = position_scale(lin);
    const std::string pu = lin ? "mm" : "deg";
    out << "\n## Axis " << a.axis_name << " (effort from `." << a.effort_signal << "`)\n\n"
        << "Samples: " << a.fit_samples << " fit, " << a.validation_samples
        << " validation. Noise: effort " << num(a.effort_noise_A) << " A (after the low-pass "
        << num(a.effort_noise_filtered_A) << " A; from the " << a.noise_source << ")";
    if (a.load_diff_noise > 0.0) out << ", load minus motor " << num(a.load_diff_noise * k) << " " << pu;
    out << "; a model change that explains nothing moves the validation cost by "
        << num(a.noise_control_cost) << " (of " << num(a.validation_cost_before) << ").\n\n"
        << "### Where the baseline is wrong\n\n"
        << "| phase | samples | effort RMS [A] | effort mean [A] | effort peak [A] | position RMS ["
        << pu << "] |\n|---|---|---|---|---|---|\n";
    for (const auto& p : a.phases) {
      out << "| " << p.phase << " | " << p.samples << " | " << num(p.effort_rms_A) << " | "
          << num(p.effort_mean_A) << " | " << num(p.effort_peak_A) << " | "
          << num(p.position_rms * k) << " |\n";
    }
    out << "\n| effort residual against | R^2 | note |\n|---|---|---|\n";
    for (const auto& r : a.relations) {
      out << "| " << r.against << " | " << num(r.r2, "%.3f") << " | " << r.note << " |\n";
    }
    out << "\n### Candidates (first round, ranked by validation score)\n\n"
        << "| rank | effect | parameters | k | validation gain | score | found |\n"
        << "|---|---|---|---|---|---|---|\n";
    int rank = 1;
    for (const auto& c : a.first_round) {
      std::string parameters;
      for (const auto& [name, value] : c.parameters) {
        parameters += (parameters.empty() ? "" : ", ") + name + " " + num(value);
      }
      if (c.parameter_count == 0) {
        out << "| " << rank++ << " | " << c.effect << " | " << c.evidence << " | 0 | - | - | no |\n";
        continue;
      }
      out << "| " << rank++ << " | " << c.effect << " | " << parameters << " | "
          << c.parameter_count << " | " << num(100.0 * c.relative_gain, "%.1f") << " % | "
          << num(c.score) << " | " << (c.found ? "yes" : "no") << " |\n";
    }
    out << "\n### Found (forward selection)\n\n";
    if (a.found.empty()) out << "No effect of the catalogue stands above the noise.\n";
    int order = 1;
    for (const auto& c : a.found) {
      out << order++ << ". **" << c.effect << "**: " << c.evidence << " (validation cost -"
          << num(100.0 * c.relative_gain, "%.1f") << " %)\n";
    }
    out << "\n### What is left\n\n" << a.unexplained.sentence << ".\n";
    out << "\n### Gain on the validation data\n\n"
        << "| | effort RMS [A] | effort peak [A] | position RMS [" << pu << "] | position peak ["
        << pu << "] | load-motor RMS [" << pu << "] | weighted RMS |\n|---|---|---|---|---|---|---|\n";
    for (const auto* s : {&a.before, &a.after}) {
      out << "| " << (s == &a.before ? "before" : "after") << " | " << num(s->effort_rms_A)
          << " | " << num(s->effort_peak_A) << " | " << num(s->position_rms * k) << " | "
          << num(s->position_peak * k) << " | " << num(s->load_diff_rms * k) << " | "
          << num(s->weighted_rms) << " |\n";
    }
  }
  return out.str();
}

std::string residuals_csv(const Diagnosis& diagnosis, const kinematics::MachineModel& machine) {
  Trace trace;
  trace.metadata.push_back({"source", "vmsim diagnose: residual = measured - simulated"});
  trace.metadata.push_back({"machine", machine.source_file});
  std::size_t n = 0;
  for (const auto& a : diagnosis.axes) n = std::max(n, a.t.size());
  for (const auto& a : diagnosis.axes) {
    if (a.t.size() == n) {
      trace.add_column("t", a.t);
      break;
    }
  }
  for (const auto& a : diagnosis.axes) {
    if (a.t.size() != n) continue;  // another grid: left out (one grid per file)
    const double k = position_scale(linear(machine, a.axis_index));
    const std::string u = linear(machine, a.axis_index) ? "mm" : "deg";
    auto scaled = [&](std::vector<double> v) {
      for (double& x : v) x *= k;
      return v;
    };
    trace.add_column(a.axis_name + "_effort_residual_before_A", a.effort_before);
    trace.add_column(a.axis_name + "_effort_residual_after_A", a.effort_after);
    trace.add_column(a.axis_name + "_position_residual_before_" + u, scaled(a.position_before));
    trace.add_column(a.axis_name + "_position_residual_after_" + u, scaled(a.position_after));
  }
  const ContourError& c = diagnosis.contour;
  if (c.computed && c.t.size() == n && !trace.columns.empty()) {
    trace.add_column("tip_contour_error_measured_um", c.measured_um);
    trace.add_column("tip_contour_residual_before_um", c.residual_before_um);
    trace.add_column("tip_contour_residual_after_um", c.residual_after_um);
  }
  return format_trace(trace);
}

}  // namespace vmsim::identify
