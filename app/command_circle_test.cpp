// vmsim circle-test: the ISO 230-4 circular test as a built-in program (app/circle_test.hpp).
#include <memory>
#include <sstream>

#include "circle_test.hpp"
#include "commands.hpp"
#include "vmsim/common/errors.hpp"
#include "vmsim/common/files.hpp"

namespace vmsim::app {
namespace {

struct CircleCommandOptions {
  std::string machine_path;
  std::string out_dir;
  std::string plane;
  double radius_mm = 100.0;
  std::string feeds_mm_per_min;
  std::string trace_path;
  std::string centre_mm;
  bool no_attribution = false;
  bool no_renders = false;
};

// "500,2000,5000" -> values; a field that is not a number is an InputError naming the option.
std::vector<double> numbers_of(const std::string& text, const std::string& option) {
  std::vector<double> values;
  std::istringstream in(text);
  std::string field;
  while (std::getline(in, field, ',')) {
    std::size_t used = 0;
    double value = 0.0;
    try {
      value = std::stod(field, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || field.find_first_not_of(" \t", used) != std::string::npos) {
      throw InputError(option + " '" + text + "': '" + field + "' is not a number");
    }
    values.push_back(value);
  }
  if (values.empty()) throw InputError(option + " '" + text + "': no value");
  return values;
}

int run(const CircleCommandOptions& command, const CommandContext& context) {
  CircleTestOptions options;
  options.machine_path = command.machine_path;
  options.out_dir = command.out_dir;
  options.plane = command.plane;
  options.radius_m = command.radius_mm * 1e-3;
  if (!command.feeds_mm_per_min.empty()) {
    for (double feed : numbers_of(command.feeds_mm_per_min, "--feeds-mm-min")) options.feeds_m_per_s.push_back(feed / 6e4);
  }
  if (!command.centre_mm.empty()) {
    std::vector<double> centre = numbers_of(command.centre_mm, "--centre-mm");
    for (double& value : centre) value *= 1e-3;
    options.centre_m = centre;
  }
  options.trace_path = command.trace_path;
  options.attribute = !command.no_attribution;
  options.renders = !command.no_renders;
  options.command_line = context.command_line;
  const nlohmann::json report = run_circle_test(options, [&](const std::string& line) { context.say(line); });
  for (const auto& warning : report["warnings"]) context.warn(warning.get<std::string>());
  if (report.contains("renders_skipped")) context.warn("polar plots skipped: " + report["renders_skipped"].get<std::string>());
  for (const auto& test : report["tests"]) {
    if (!test.contains("measured")) continue;
    std::string line = "  measured " + test["plane"].get<std::string>() + " at " +
                       format_double(test["feed_mm_per_min"].get<double>()) + " mm/min:";
    for (const char* direction : {"CCW", "CW"}) {
      if (!test["measured"].contains(direction)) continue;
      const auto& f = test["measured"][direction];
      line += std::string(" ") + direction + " G " + format_double(f["circular_deviation_G_um"].get<double>()) +
              " um, radius " + format_double(f["mean_radius_deviation_um"].get<double>()) + " um, ellipse " +
              format_double(f["ellipse"]["size_um"].get<double>()) + " um at " +
              format_double(f["ellipse"]["major_axis_deg"].get<double>()) + " deg;";
    }
    context.say(line);
  }
  if (!report["explanations"].empty()) context.say("explained by the drive model:");
  for (const auto& sentence : report["explanations"]) context.say("  " + sentence.get<std::string>());
  context.say("wrote " + command.out_dir + ": circle_test.json, circle_deviation.csv" +
              (report.contains("renders_skipped") ? std::string() : ", polar_*.png") + " (" +
              format_double(report["run_time_s"].get<double>()) + " s)");
  return 0;
}

}  // namespace

void add_circle_test_command(CLI::App& app, CommandContext& context) {
  auto options = std::make_shared<CircleCommandOptions>();
  CLI::App* command = app.add_subcommand(
      "circle-test",
      "the ISO 230-4 circular test (the ballbar circle) as a built-in program: planned, servo-simulated, "
      "G, H, radius, reversal spikes, backlash steps, servo-mismatch ellipse, each explained by the "
      "drive model's effects; with --trace the same figures from a measured circle");
  command->add_option("--machine", options->machine_path, "machine description (YAML)")->required()->check(CLI::ExistingFile);
  command->add_option("--out", options->out_dir,
                      "result folder: circle_test.json, circle_deviation.csv, polar_<plane>_F<feed>.png")
      ->required();
  command->add_option("--plane", options->plane, "XY, YZ, ZX or all (default XY, or the measured trace's plane)");
  command->add_option("--radius-mm", options->radius_mm, "nominal radius [mm] (default 100)");
  command->add_option("--feeds-mm-min", options->feeds_mm_per_min, "feeds [mm/min], comma separated (default 500,2000,5000)");
  command->add_option("--trace", options->trace_path,
                      "measured trace of a circle test (trace format: X/Y/Z .pos or .pos2 [mm]); the same "
                      "--radius-mm and --centre-mm as the measured test")
      ->check(CLI::ExistingFile);
  command->add_option("--centre-mm", options->centre_mm,
                      "x,y,z: positions of the axes X, Y, Z at the circle's centre [mm] (default: the middle of each travel)");
  command->add_flag("--no-attribution", options->no_attribution, "do not re-simulate with each drive effect off");
  command->add_flag("--no-renders", options->no_renders, "no polar plots (PNG)");
  command->callback([options, &context] { context.result = run(*options, context); });
}

}  // namespace vmsim::app
