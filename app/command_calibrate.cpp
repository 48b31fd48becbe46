// vmsim calibrate: diagnose a whole machine's measured trace, write the calibrated machine file
// (the user's file with only the fitted effects added or changed), then predict the part's marks
// with the nominal and with the calibrated machine (simulate_part) and put them side by side.
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <sstream>

#include "commands.hpp"
#include "diagnosis_inputs.hpp"
#include "part_file.hpp"
#include "simulate_part.hpp"
#include "vmsim/common/errors.hpp"
#include "vmsim/common/files.hpp"
#include "vmsim/common/output_folder.hpp"
#include "vmsim/common/trace.hpp"
#include "vmsim/identify/diagnose.hpp"
#include "vmsim/kinematics/machine_loader.hpp"

namespace vmsim::app {
namespace {

using Json = nlohmann::json;

struct CalibrateCommandOptions {
  DiagnosisInputOptions inputs;
  std::string part_path;
  std::string out_dir;
  double grid_um = 20.0;
  double mark_threshold_um = 2.0;
  double match_distance_mm = 2.0;
  bool renders = false;
  int threads = 0;
};

// The part file with its machine replaced by `machine` (as written: relative to the copy's
// folder, or absolute) and its other files made absolute, so that the copy can live anywhere.
std::string part_copy_yaml(const std::string& part_path, const std::string& machine) {
  YAML::Node root;
  try {
    root = YAML::LoadFile(part_path);
  } catch (const YAML::Exception& error) {  // load_part has read it already: not expected
    throw InputError(part_path + ": " + error.what());
  }
  const std::filesystem::path folder =
      std::filesystem::absolute(std::filesystem::path(part_path)).parent_path();
  root["machine"] = machine;
  if (root["toolpath"]) {
    root["toolpath"] = (folder / root["toolpath"].as<std::string>()).lexically_normal().string();
  }
  if (root["stock"] && root["stock"].IsMap() && root["stock"]["stl"]) {
    root["stock"]["stl"] = (folder / root["stock"]["stl"].as<std::string>()).lexically_normal().string();
  }
  YAML::Emitter out;
  out << root;
  return "# Written by vmsim calibrate: " + part_path + " with the machine " + machine + "\n" +
         out.c_str() + "\n";
}

double distance_mm(const Json& a, const Json& b) {
  double sum = 0.0;
  for (int k = 0; k < 3; ++k) sum += std::pow(a[k].get<double>() - b[k].get<double>(), 2);
  return std::sqrt(sum);
}

// One row of the side-by-side table: a mark of either run and its counterpart in the other
// (same view, centroids within `match_mm`: a mark's deepest point is no place to match by, along
// a mark of nearly constant depth it jumps from one end to the other); a depth of 0 where the
// other run has none.
struct MarkRow {
  std::string surface, view, kind, block;
  Json point_mm;
  double nominal_um = 0.0, calibrated_um = 0.0;
};

std::vector<MarkRow> pair_marks(const Json& nominal, const Json& calibrated, double match_mm) {
  std::vector<MarkRow> rows;
  std::vector<char> used(calibrated.size(), 0);
  for (const Json& mark : nominal) {
    MarkRow row{mark.value("surface", ""), mark.value("view", ""), mark.value("kind", ""),
                mark.value("block", ""), mark["centroid_mm"], mark["depth_um"].get<double>(), 0.0};
    std::size_t best = calibrated.size();
    double best_distance = match_mm;
    for (std::size_t k = 0; k < calibrated.size(); ++k) {
      if (used[k] || calibrated[k].value("view", "") != row.view) continue;
      const double d = distance_mm(calibrated[k]["centroid_mm"], row.point_mm);
      if (d <= best_distance) {
        best_distance = d;
        best = k;
      }
    }
    if (best < calibrated.size()) {
      used[best] = 1;
      row.calibrated_um = calibrated[best]["depth_um"].get<double>();
    }
    rows.push_back(row);
  }
  for (std::size_t k = 0; k < calibrated.size(); ++k) {
    if (used[k]) continue;
    const Json& mark = calibrated[k];
    rows.push_back({mark.value("surface", ""), mark.value("view", ""), mark.value("kind", ""),
                    mark.value("block", ""), mark["centroid_mm"], 0.0,
                    mark["depth_um"].get<double>()});
  }
  std::stable_sort(rows.begin(), rows.end(), [](const MarkRow& a, const MarkRow& b) {
    return std::max(a.nominal_um, a.calibrated_um) > std::max(b.nominal_um, b.calibrated_um);
  });
  return rows;
}

std::string num(double v, const char* format = "%.2f") {
  char text[64];
  std::snprintf(text, sizeof text, format, v);
  return text;
}

double deepest(const Json& marks) {
  double depth = 0.0;
  for (const Json& m : marks) depth = std::max(depth, m["depth_um"].get<double>());
  return depth;
}

int run_calibrate(const CalibrateCommandOptions& options, const CommandContext& context) {
  if (!(options.grid_um > 0)) throw InputError("--grid-um must be > 0, got " + format_double(options.grid_um));
  if (!(options.mark_threshold_um > 0)) {
    throw InputError("--mark-threshold-um must be > 0, got " + format_double(options.mark_threshold_um));
  }
  const DiagnosisInputOptions& in = options.inputs;
  OutputFolder output(options.out_dir, {in.machine_path, in.trace_path, options.part_path, in.validate_path},
                      {"calibrate", VMSIM_VERSION});
  // Every input read and checked before anything is computed (the part first: its errors are
  // the cheapest to find).
  const PartDescription part = load_part(options.part_path);
  const DiagnosisInputs inputs = load_diagnosis_inputs(in, context);
  const kinematics::MachineModel& machine = inputs.machine;

  context.say("diagnosing " + std::to_string(inputs.data.size()) + " axes of " + in.trace_path + " ...");
  identify::DiagnoseOptions diagnose_options = catalogue_options(in);
  diagnose_options.tool_length_m = part.tool.length_m;
  const identify::Diagnosis diagnosis = identify::diagnose(machine, inputs.data, inputs.validation, diagnose_options);
  std::vector<identify::AxisNote> notes;
  const kinematics::MachineModel calibrated = identify::extended_machine(machine, diagnosis, notes);
  const std::string parent = std::filesystem::path(in.machine_path).parent_path().string();
  // Only the axes with a found effect are written back: the others keep their keys as the user
  // wrote them (updated_machine_yaml rewrites the drive, controller and effects of every axis
  // it is given).
  kinematics::MachineModel changed_axes = calibrated;
  std::erase_if(changed_axes.axes, [&](const kinematics::Axis& axis) {
    return std::none_of(diagnosis.axes.begin(), diagnosis.axes.end(), [&](const identify::AxisDiagnosis& a) {
      return a.axis_name == axis.name && !a.found.empty();
    });
  });
  const std::string calibrated_yaml =
      identify::updated_machine_yaml(read_file(in.machine_path), changed_axes, notes,
                                     in.machine_path, parent.empty() ? "." : parent);

  const std::filesystem::path& staging = output.staging();
  write_file_atomically(output.path_of("machine_calibrated.yaml"), calibrated_yaml);
  write_file_atomically(output.path_of("diagnosis.json"),
                        identify::diagnosis_json(diagnosis, machine, in.trace_path));
  write_file_atomically(output.path_of("diagnosis.md"),
                        identify::diagnosis_report(diagnosis, machine, in.trace_path));
  write_file_atomically(output.path_of("residuals.csv"), identify::residuals_csv(diagnosis, machine));
  // The part run with each machine: copies of the part file beside the results (the calibrated
  // machine by a relative name, valid in the staging folder and after the swap).
  const std::string nominal_machine =
      std::filesystem::absolute(in.machine_path).lexically_normal().string();
  write_file_atomically(output.path_of("part_nominal.yaml"),
                        part_copy_yaml(options.part_path, nominal_machine));
  write_file_atomically(output.path_of("part_calibrated.yaml"),
                        part_copy_yaml(options.part_path, "machine_calibrated.yaml"));

  Json runs = Json::object();
  for (const std::string run : {"nominal", "calibrated"}) {
    SimulatePartOptions sim;
    sim.part_path = output.path_of("part_" + run + ".yaml");
    sim.out_dir = (staging / run).string();
    sim.grid_m = options.grid_um * 1e-6;
    sim.mark_threshold_m = options.mark_threshold_um * 1e-6;
    sim.renders = options.renders;
    sim.threads = options.threads;
    sim.command_line = context.command_line;
    const auto start = std::chrono::steady_clock::now();
    const ProgressSink progress = [&](const std::string& line) {
      if (context.quiet) return;
      const double elapsed =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      context.say("  [" + run + " " + num(elapsed, "%.1f") + " s] " + line);
    };
    context.say("simulate-part with the " + run + " machine ...");
    runs[run] = simulate_part(sim, progress);
  }

  const Json& nominal_marks = runs["nominal"]["marks"];
  const Json& calibrated_marks = runs["calibrated"]["marks"];
  const std::vector<MarkRow> rows = pair_marks(nominal_marks, calibrated_marks, options.match_distance_mm);
  Json result;
  result["machine"] = in.machine_path;
  result["calibrated_machine"] = "machine_calibrated.yaml";
  result["trace"] = in.trace_path;
  result["part"] = options.part_path;
  result["effects"] = Json::array();
  for (const auto& axis : diagnosis.axes) {
    for (const auto& found : axis.found) {
      Json parameters = Json::object();
      for (const auto& [name, value] : found.parameters) parameters[name] = value;
      result["effects"].push_back({{"axis", axis.axis_name}, {"effect", found.effect},
                                   {"parameters", parameters}, {"evidence", found.evidence}});
    }
  }
  result["held_axes"] = Json::array();
  for (const auto& held : diagnosis.held_axes) result["held_axes"].push_back(held.axis_name);
  const identify::ContourError& tip = diagnosis.contour;
  if (tip.computed) {
    result["tool_tip_contour_error"] = {
        {"measured_rms_um", tip.measured_rms_um},
        {"measured_peak_um", tip.measured_peak_um},
        {"residual_before_rms_um", tip.residual_before_rms_um},
        {"residual_after_rms_um", tip.residual_after_rms_um},
        {"residual_before_peak_um", tip.residual_before_peak_um},
        {"residual_after_peak_um", tip.residual_after_peak_um}};
  }
  result["mark_threshold_um"] = options.mark_threshold_um;
  result["grid_um"] = options.grid_um;
  result["match_distance_mm"] = options.match_distance_mm;
  for (const std::string run : {"nominal", "calibrated"}) {
    result["runs"][run] = {{"folder", run},
                           {"marks", runs[run]["marks"].size()},
                           {"deepest_mark_um", deepest(runs[run]["marks"])},
                           {"duration_s", runs[run]["runs"]["production"].value("duration_s", 0.0)}};
  }
  result["marks"] = Json::array();
  for (const MarkRow& row : rows) {
    result["marks"].push_back({{"surface", row.surface},
                               {"view", row.view},
                               {"kind", row.kind},
                               {"block", row.block},
                               {"centroid_mm", row.point_mm},
                               {"depth_nominal_um", row.nominal_um},
                               {"depth_calibrated_um", row.calibrated_um},
                               {"change_um", row.calibrated_um - row.nominal_um}});
  }

  std::ostringstream md;
  md << "# Calibration\n\nMachine `" << in.machine_path << "`, trace `" << in.trace_path
     << "`, part `" << options.part_path << "`.\n\n## Effects found\n\n";
  if (result["effects"].empty()) md << "None: the calibrated machine is the nominal one.\n";
  for (const auto& axis : diagnosis.axes) {
    for (const auto& found : axis.found) {
      md << "- " << axis.axis_name << ": **" << found.effect << "**: " << found.evidence << "\n";
    }
  }
  for (const auto& held : diagnosis.held_axes) md << "- " << held.axis_name << ": " << held.reason << "\n";
  if (tip.computed) {
    md << "\nTool tip contour error, measured " << num(tip.measured_rms_um) << " um RMS ("
       << num(tip.measured_peak_um) << " peak); what the model misses: " << num(tip.residual_before_rms_um)
       << " um RMS before, " << num(tip.residual_after_rms_um) << " um after the found effects.\n";
  }
  md << "\n## Marks predicted (deeper than " << num(options.mark_threshold_um) << " um, grid "
     << num(options.grid_um, "%.0f") << " um)\n\n"
     << "Deepest: nominal " << num(result["runs"]["nominal"]["deepest_mark_um"].get<double>())
     << " um, calibrated " << num(result["runs"]["calibrated"]["deepest_mark_um"].get<double>())
     << " um (folders `nominal/`, `calibrated/`).\n\n"
     << "| surface | kind | centroid [mm] | block | depth nominal [um] | depth calibrated [um] |\n"
     << "|---|---|---|---|---|---|\n";
  for (const MarkRow& row : rows) {
    md << "| " << row.surface << " | " << row.kind << " | (" << num(row.point_mm[0].get<double>())
       << ", " << num(row.point_mm[1].get<double>()) << ", " << num(row.point_mm[2].get<double>())
       << ") | " << row.block << " | " << (row.nominal_um > 0 ? num(row.nominal_um) : "-") << " | "
       << (row.calibrated_um > 0 ? num(row.calibrated_um) : "-") << " |\n";
  }
  if (rows.empty()) md << "| (no mark in either run) | | | | | |\n";
  write_file_atomically(output.path_of("calibration.json"), result.dump(2) + "\n");
  write_file_atomically(output.path_of("calibration.md"), md.str());
  output.commit();

  context.say("wrote " + options.out_dir + "/{machine_calibrated.yaml, calibration.json, calibration.md, "
              "diagnosis.json, diagnosis.md, residuals.csv, nominal/, calibrated/}");
  for (const auto& axis : diagnosis.axes) {
    std::string line = "  " + axis.axis_name + ": ";
    if (axis.found.empty()) line += "no effect found";
    for (std::size_t i = 0; i < axis.found.size(); ++i) line += (i ? ", " : "found ") + axis.found[i].effect;
    context.say(line);
  }
  context.say("deepest mark: nominal " + num(result["runs"]["nominal"]["deepest_mark_um"].get<double>()) +
              " um, calibrated " + num(result["runs"]["calibrated"]["deepest_mark_um"].get<double>()) + " um");
  return 0;
}

}  // namespace

void add_calibrate_command(CLI::App& app, CommandContext& context) {
  auto options = std::make_shared<CalibrateCommandOptions>();
  CLI::App* command = app.add_subcommand(
      "calibrate",
      "diagnose a measured multi-axis trace, write the calibrated machine file and predict the "
      "part's marks with the nominal and the calibrated machine side by side");
  add_diagnosis_input_options(*command, options->inputs, "nominal machine description (YAML)",
                              "measured trace of the machine: t, <AXIS>.cmd, .pos, .cur/.torque/.force "
                              "per axis (.pos2 / .pos_motor where logged)");
  command->add_option("--part", options->part_path, "part file (part.yaml) whose marks to predict")
      ->required()
      ->check(CLI::ExistingFile);
  command->add_option("--out", options->out_dir,
                      "output folder (new, empty or a previous vmsim result: replaced as a whole)")
      ->required();
  command->add_option("--grid-um", options->grid_um, "surface line spacing of both part runs [um]")
      ->capture_default_str();
  command->add_option("--mark-threshold-um", options->mark_threshold_um,
                      "a line deviating more than this belongs to a mark [um]")
      ->capture_default_str();
  command->add_option("--match-distance-mm", options->match_distance_mm,
                      "marks of the two runs whose centroids lie within this distance are the same mark [mm]")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  command->add_flag("--renders", options->renders, "also render the part runs' images (needs a display)");
  command->add_option("--threads", options->threads, "threads for the removal (0: all)");
  command->callback([options, &context] { context.result = run_calibrate(*options, context); });
}

}  // namespace vmsim::app
