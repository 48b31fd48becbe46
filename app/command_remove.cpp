// vmsim remove: material removal alone on the commanded tool path, or on the axis positions of
// a simulated or measured trace through the direct kinematics. Two models: the N-buffer Z-map
// with exact swept volumes (default; writes the heights, binary and optional CSV), or the
// OpenVDB level set (--model level-set; writes the grids as stock.vdb and the surface as .vtp).
// Both write the machined surface (STL) and a summary (JSON) into --out.
#include <yaml-cpp/yaml.h>

#include <nlohmann/json.hpp>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <functional>
#include <numbers>
#include <optional>
#include <sstream>

#include "commands.hpp"
#include "json_text.hpp"
#include "part_file.hpp"
#include "tool_table.hpp"
#include "vmsim/common/errors.hpp"
#include "vmsim/common/files.hpp"
#include "vmsim/common/output_folder.hpp"
#include "vmsim/common/trace.hpp"
#include "vmsim/kinematics/kinematics.hpp"
#include "vmsim/kinematics/machine_loader.hpp"
#include "vmsim/kinematics/yaml_input.hpp"
#include "vmsim/toolpath/toolpath.hpp"
#include "vmsim/removal/level_set.hpp"
#include "vmsim/removal/nbuffer.hpp"
#include "vmsim/removal/output.hpp"
#include "vmsim/removal/stl.hpp"

namespace vmsim::app {
namespace {

struct RemoveOptions {
  std::string part_path, toolpath_path, machine_path, trace_path, out_dir;
  std::string tool_type;
  double tool_diameter_mm = -1.0, corner_radius_mm = -1.0, tool_length_mm = -1.0;
  std::vector<double> stock_min_mm, stock_max_mm;
  double grid_mm = 0.05;
  bool csv = false;
  int threads = 0;
  double orientation_tolerance_um = -1.0;  // < 0: the model's default
  std::size_t stl_max_triangles = 4'000'000;
  std::string model = "nbuffer";
  std::string stock_stl;
  double voxel_mm = 0.05, region_voxel_mm = 0.02;
  std::vector<double> regions_mm;  // 6 numbers per region
};

Eigen::Vector3d vector_mm(const std::vector<double>& v) { return Eigen::Vector3d(v[0], v[1], v[2]) * 1e-3; }

// The stock box of a part file: stock: {box: {min_mm: [..], max_mm: [..]}}.
removal::Box stock_from_part(const std::string& path) {
  const YAML::Node root = kinematics::load_yaml_input(path);
  const YAML::Node box = root["stock"] ? root["stock"]["box"] : YAML::Node();
  if (!box || !box["min_mm"] || !box["max_mm"]) throw InputError(path + ": missing field 'stock.box.min_mm/max_mm'");
  auto read = [&](const char* key) {
    const YAML::Node node = box[key];
    std::vector<double> v;
    try {
      v = node.as<std::vector<double>>();
    } catch (const YAML::Exception&) {
      throw InputError(located_message(path, node.Mark().line + 1, node.Mark().column + 1,
                                       std::string("stock.box.") + key + ": expected [x, y, z]"));
    }
    if (v.size() != 3) {
      throw InputError(located_message(path, node.Mark().line + 1, node.Mark().column + 1,
                                       std::string("stock.box.") + key + ": expected 3 numbers"));
    }
    return vector_mm(v);
  };
  return removal::Box{read("min_mm"), read("max_mm")};
}

removal::ToolType tool_type(const std::string& name) {
  if (name == "ball") return removal::ToolType::ball;
  if (name == "flat") return removal::ToolType::flat;
  if (name == "bull") return removal::ToolType::bull;
  throw InputError("--tool-type '" + name + "': expected ball, flat or bull");
}

// Tool poses from a trace: <AXIS>.pos columns, else <AXIS>.cmd, through the direct kinematics.
std::vector<removal::Pose> poses_from_trace(const std::string& machine_path, const std::string& trace_path,
                                            double tool_length_m, std::string& signal) {
  const kinematics::MachineModel machine = kinematics::load_machine(machine_path);
  TraceReadOptions read_options;
  std::set<std::string> names;
  for (const auto& axis : machine.axes) names.insert(axis.name);
  read_options.known_axes = names;
  const Trace trace = read_trace(trace_path, read_options);
  signal = "pos";
  for (const auto& axis : machine.axes) {
    if (!trace.column_index(axis.name + ".pos")) signal = "cmd";
  }
  std::vector<const std::vector<double>*> columns;
  for (const auto& axis : machine.axes) {
    const std::string name = axis.name + "." + signal;
    if (!trace.column_index(name)) {
      throw InputError(trace_path + ": no column " + axis.name + ".pos or " + axis.name + ".cmd for axis " + axis.name +
                       " of " + machine_path);
    }
    columns.push_back(&trace.column(name));
  }
  std::vector<removal::Pose> poses(trace.sample_count());
  Eigen::VectorXd q(static_cast<Eigen::Index>(machine.axes.size()));
  for (std::size_t i = 0; i < poses.size(); ++i) {
    for (std::size_t j = 0; j < machine.axes.size(); ++j) {
      const double v = (*columns[j])[i];
      q[static_cast<Eigen::Index>(j)] = machine.axes[j].type == kinematics::AxisType::linear ? v * 1e-3 : v * std::numbers::pi / 180.0;
    }
    const kinematics::ToolPose pose = kinematics::forward_kinematics(machine, q, tool_length_m);
    poses[i] = removal::Pose{pose.tip_W_m, pose.axis_W};
  }
  return poses;
}

// Prints the progress of a cut every 10 % (both models' interrupted callbacks); never stops it.
std::function<bool(double)> progress_printer(const CommandContext& context) {
  return [&context, last_percent = -10](double fraction) mutable {
    const int percent = static_cast<int>(fraction * 100.0);
    if (percent >= last_percent + 10) {
      last_percent = percent;
      context.say("  " + std::to_string(percent) + " %");
    }
    return false;
  };
}

// The level-set model: the stock (box or closed STL) as OpenVDB grids, cut along the poses;
// writes stock.vdb, surface.stl, surface.vtp (point data z_mm) and summary.json.
int run_level_set(const RemoveOptions& o, const CommandContext& context, const removal::Tool& tool,
                  const removal::Box& stock, const std::optional<removal::TriangleMesh>& stock_mesh,
                  const std::vector<removal::Pose>& poses, const std::string& source, OutputFolder& output) {
  removal::LevelSetOptions options;
  options.voxel_m = o.voxel_mm * 1e-3;
  for (std::size_t i = 0; i < o.regions_mm.size(); i += 6) {
    const std::vector<double> lo(o.regions_mm.begin() + i, o.regions_mm.begin() + i + 3);
    const std::vector<double> hi(o.regions_mm.begin() + i + 3, o.regions_mm.begin() + i + 6);
    options.regions.push_back(removal::LevelSetRegion{removal::Box{vector_mm(lo), vector_mm(hi)}, o.region_voxel_mm * 1e-3});
  }
  removal::LevelSetStock grids = stock_mesh ? removal::LevelSetStock::mesh(*stock_mesh, options)
                                            : removal::LevelSetStock::box(stock, options);
  removal::LevelSetCutOptions cut;
  cut.threads = o.threads;
  const double tolerance_um = o.orientation_tolerance_um > 0.0 ? o.orientation_tolerance_um : 1.0;
  cut.orientation_tolerance_m = tolerance_um * 1e-6;
  cut.interrupted = progress_printer(context);
  context.say("removal: " + std::to_string(poses.size()) + " samples from " + source + "; level set at " +
              format_double(o.voxel_mm) + " mm voxels, " + std::to_string(options.regions.size()) + " fine region(s) at " +
              format_double(o.region_voxel_mm) + " mm");
  const auto start = std::chrono::steady_clock::now();
  const removal::LevelSetCutStatistics stats = grids.cut(tool, poses, cut);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const removal::TriangleMesh surface = grids.surface();
  std::vector<double> z_mm;
  z_mm.reserve(surface.vertices_m.size());
  for (const auto& v : surface.vertices_m) z_mm.push_back(v.z() * 1e3);

  write_file_atomically(output.path_of("stock.vdb"), grids.vdb_bytes());
  write_file_atomically(output.path_of("surface.stl"), removal::mesh_stl(surface));
  write_file_atomically(output.path_of("surface.vtp"), removal::mesh_vtp(surface, &z_mm, "z_mm"));
  nlohmann::json regions = nlohmann::json::array();
  for (const auto& r : options.regions) {
    regions.push_back({{"min_mm", {r.box_W_m.min_W_m.x() * 1e3, r.box_W_m.min_W_m.y() * 1e3, r.box_W_m.min_W_m.z() * 1e3}},
                       {"max_mm", {r.box_W_m.max_W_m.x() * 1e3, r.box_W_m.max_W_m.y() * 1e3, r.box_W_m.max_W_m.z() * 1e3}},
                       {"voxel_mm", r.voxel_m * 1e3}});
  }
  nlohmann::json summary = {
      {"model", "level-set"},
      {"source", source},
      {"samples", poses.size()},
      {"sub_segments", stats.sub_segments},
      {"stock", stock_mesh ? o.stock_stl : std::string("box")},
      {"voxel_mm", o.voxel_mm},
      {"regions", regions},
      {"band_mm", grids.band_m() * 1e3},
      {"tool", {{"type", o.tool_type.empty() ? "part" : o.tool_type}, {"diameter_mm", tool.diameter_m * 1e3},
                {"corner_radius_mm", tool.corner_radius() * 1e3}, {"length_mm", tool.length_m * 1e3}}},
      {"voxels_evaluated", stats.voxels_evaluated},
      {"voxels_changed", stats.voxels_changed},
      {"active_voxels", grids.active_voxel_count()},
      {"memory_mb", static_cast<double>(grids.memory_bytes()) / 1e6},
      {"surface_triangles", surface.triangles.size()},
      {"seconds", seconds},
      {"orientation_tolerance_um", tolerance_um}};
  write_file_atomically(output.path_of("summary.json"), json_file_text(summary));
  output.commit();
  std::ostringstream line;
  line << "cut " << poses.size() << " samples in " << seconds << " s; wrote " << o.out_dir
       << "/{stock.vdb,surface.stl,surface.vtp,summary.json}";
  context.say(line.str());
  return 0;
}

int run_remove(const RemoveOptions& o, const CommandContext& context) {
  removal::Tool tool;
  removal::Box stock;
  bool have_tool = false, have_stock = false;
  std::string toolpath_path = o.toolpath_path, machine_path = o.machine_path;
  if (!o.part_path.empty()) {
    const PartDescription part = load_part(o.part_path);
    for (const std::string& warning : part.warnings) context.warn(warning);
    tool = removal_tool(part.tool);  // (type, sizes, conical shapes)
    tool.length_m = part.tool.length_m;
    have_tool = true;
    stock = stock_from_part(o.part_path);
    have_stock = true;
    if (toolpath_path.empty() && o.trace_path.empty()) toolpath_path = part.toolpath_path;
    if (machine_path.empty()) machine_path = part.machine_path;
  }
  if (!o.tool_type.empty()) tool.type = tool_type(o.tool_type), have_tool = true;
  if (o.tool_diameter_mm > 0.0) tool.diameter_m = o.tool_diameter_mm * 1e-3, have_tool = true;
  if (o.corner_radius_mm >= 0.0) tool.corner_radius_m = o.corner_radius_mm * 1e-3;
  if (o.tool_length_mm > 0.0) {
    tool.length_m = o.tool_length_mm * 1e-3;
  } else if (o.part_path.empty()) {
    tool.length_m = std::max(30e-3, 3.0 * tool.diameter_m);
  }
  if (!have_tool || (o.part_path.empty() && (o.tool_type.empty() || o.tool_diameter_mm <= 0.0))) {
    throw InputError("no tool: give --part or --tool-type and --tool-diameter-mm");
  }
  if (o.model != "nbuffer" && o.model != "level-set") {
    throw InputError("--model '" + o.model + "': expected nbuffer or level-set");
  }
  std::optional<removal::TriangleMesh> stock_mesh;
  if (!o.stock_stl.empty()) {
    stock_mesh = removal::read_stl(o.stock_stl);
    stock = stock_mesh->bounds();
    have_stock = true;
  }
  if (!o.stock_min_mm.empty()) stock.min_W_m = vector_mm(o.stock_min_mm), have_stock = true;
  if (!o.stock_max_mm.empty()) stock.max_W_m = vector_mm(o.stock_max_mm), have_stock = true;
  if (!have_stock || (o.part_path.empty() && !stock_mesh && (o.stock_min_mm.empty() || o.stock_max_mm.empty()))) {
    throw InputError("no stock: give --part, --stock-stl, or --stock-min-mm and --stock-max-mm");
  }
  if (stock_mesh && (!o.stock_min_mm.empty() || !o.stock_max_mm.empty())) {
    throw InputError("--stock-stl and --stock-min-mm/--stock-max-mm: give one stock");
  }
  if (o.regions_mm.size() % 6 != 0) {
    throw InputError("--regions-mm: " + std::to_string(o.regions_mm.size()) +
                     " numbers; expected 6 per region (x0,y0,z0,x1,y1,z1)");
  }
  if (o.model != "level-set" && !o.regions_mm.empty()) {
    throw InputError("--regions-mm needs --model level-set");
  }
  tool.validate();
  // The output folder is checked (and its staging folder made) before the trajectory is read.
  OutputFolder output(o.out_dir, {o.part_path, toolpath_path, machine_path, o.trace_path, o.stock_stl},
                      {"remove", VMSIM_VERSION});

  std::vector<removal::Pose> poses;
  std::string source;
  if (!o.trace_path.empty()) {
    if (machine_path.empty()) throw InputError("--trace needs --machine (or --part)");
    std::string signal;
    poses = poses_from_trace(machine_path, o.trace_path, tool.length_m, signal);
    source = o.trace_path + " (" + signal + " columns, direct kinematics of " + machine_path + ")";
  } else {
    if (toolpath_path.empty()) throw InputError("no trajectory: give --toolpath, --trace or --part");
    // G41 / G42 D<n>: the one tool of the run for every D.
    toolpath::ReaderOptions reader;
    reader.default_cutter_radius_mm = 0.5 * tool.diameter_m * 1e3;
    const toolpath::Toolpath path = toolpath::read_toolpath(toolpath_path, reader);
    for (const auto& w : path.warnings) context.warn(w.file + ":" + std::to_string(w.line) + ": " + w.message);
    for (const auto& p : path.points) poses.push_back(removal::Pose{p.tip_W_m, p.axis_W});
    source = toolpath_path + " (commanded tool path)";
  }
  if (poses.empty()) throw InputError(source + ": no trajectory samples");

  if (o.model == "level-set") return run_level_set(o, context, tool, stock, stock_mesh, poses, source, output);
  const double tolerance_um = o.orientation_tolerance_um > 0.0 ? o.orientation_tolerance_um : 0.05;
  removal::NBuffer buffer = stock_mesh ? removal::NBuffer::zmap(*stock_mesh, o.grid_mm * 1e-3)
                                      : removal::NBuffer::zmap(stock, o.grid_mm * 1e-3);
  removal::CutOptions cut;
  cut.threads = o.threads;
  cut.orientation_tolerance_m = tolerance_um * 1e-6;
  cut.interrupted = progress_printer(context);
  context.say("removal: " + std::to_string(poses.size()) + " samples from " + source + "; Z-map " +
              std::to_string(buffer.nu()) + " x " + std::to_string(buffer.nv()) + " lines at " +
              format_double(o.grid_mm) + " mm");
  const auto start = std::chrono::steady_clock::now();
  const removal::CutStatistics stats = buffer.cut(tool, poses, cut);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  const int stride = removal::stl_stride_for(buffer, o.stl_max_triangles);
  write_file_atomically(output.path_of("heights.bin"), removal::heights_binary(buffer));
  if (o.csv) write_file_atomically(output.path_of("heights.csv"), removal::heights_csv(buffer));
  write_file_atomically(output.path_of("surface.stl"), removal::surface_stl(buffer, stride));
  double lowest = 1e300;
  for (double h : buffer.lengths()) lowest = std::min(lowest, h);
  nlohmann::json summary = {
      {"source", source},
      {"samples", poses.size()},
      {"sub_segments", stats.sub_segments},
      {"lines", buffer.line_count()},
      {"grid", {{"nx", buffer.nu()}, {"ny", buffer.nv()}, {"spacing_mm", o.grid_mm},
                {"x0_mm", stock.min_W_m.x() * 1e3}, {"y0_mm", stock.min_W_m.y() * 1e3}, {"z0_mm", stock.min_W_m.z() * 1e3}}},
      {"tool", {{"type", o.tool_type.empty() ? "part" : o.tool_type}, {"diameter_mm", tool.diameter_m * 1e3},
                {"corner_radius_mm", tool.corner_radius() * 1e3}, {"length_mm", tool.length_m * 1e3}}},
      {"lines_lowered", stats.lines_lowered},
      {"tiles_visited", stats.tiles_visited},
      {"lowest_z_mm", (stock.min_W_m.z() + lowest) * 1e3},
      {"seconds", seconds},
      {"stl_stride", stride},
      {"orientation_tolerance_um", tolerance_um}};
  write_file_atomically(output.path_of("summary.json"), json_file_text(summary));
  output.commit();
  std::ostringstream line;
  line << "cut " << poses.size() << " samples in " << seconds << " s; wrote " << o.out_dir
       << "/{heights.bin" << (o.csv ? ",heights.csv" : "") << ",surface.stl,summary.json}";
  context.say(line.str());
  return 0;
}

}  // namespace

void add_remove_command(CLI::App& app, CommandContext& context) {
  auto o = std::make_shared<RemoveOptions>();
  CLI::App* c = app.add_subcommand("remove", "material removal alone (N-buffer Z-map or OpenVDB level set, exact "
                                             "swept volumes) on a tool path or on the axis positions of a trace");
  c->add_option("--part", o->part_path, "part file (part.yaml): tool, stock, tool path, machine")->check(CLI::ExistingFile);
  c->add_option("--toolpath", o->toolpath_path, "tool path (APT/CL or G-code), commanded poses")->check(CLI::ExistingFile);
  c->add_option("--machine", o->machine_path, "machine (YAML) for --trace")->check(CLI::ExistingFile);
  c->add_option("--trace", o->trace_path, "axis trace (CSV): <AXIS>.pos columns, else <AXIS>.cmd")->check(CLI::ExistingFile);
  c->add_option("--tool-type", o->tool_type, "ball, flat or bull");
  c->add_option("--tool-diameter-mm", o->tool_diameter_mm, "tool diameter [mm]");
  c->add_option("--corner-radius-mm", o->corner_radius_mm, "corner radius of a bull-nose mill [mm]");
  c->add_option("--tool-length-mm", o->tool_length_mm, "tip to spindle gauge point [mm] (default: the part's, else max(30, 3 D))");
  c->add_option("--stock-min-mm", o->stock_min_mm, "stock box corner x,y,z [mm]")->delimiter(',')->expected(3);
  c->add_option("--stock-max-mm", o->stock_max_mm, "stock box corner x,y,z [mm]")->delimiter(',')->expected(3);
  c->add_option("--grid-mm", o->grid_mm, "Z-map line spacing [mm]")->capture_default_str();
  c->add_option("--threads", o->threads, "threads (0: all)")->capture_default_str();
  c->add_option("--orientation-tolerance-um", o->orientation_tolerance_um,
                "largest error of the swept volume where the tool axis turns [um] (default: nbuffer 0.05, level-set 1)");
  c->add_option("--stl-max-triangles", o->stl_max_triangles, "surface.stl takes every k-th line to stay under this")
      ->capture_default_str();
  c->add_flag("--csv", o->csv, "also write heights.csv (large; nbuffer)");
  c->add_option("--model", o->model, "nbuffer (Z-map, exact heights) or level-set (OpenVDB grids, .vdb)")
      ->capture_default_str();
  c->add_option("--stock-stl", o->stock_stl, "closed STL stock [mm] instead of a box")->check(CLI::ExistingFile);
  c->add_option("--voxel-mm", o->voxel_mm, "level-set voxel over the whole stock [mm]")->capture_default_str();
  c->add_option("--regions-mm", o->regions_mm, "level-set fine boxes x0,y0,z0,x1,y1,z1[,...] [mm]")->delimiter(',');
  c->add_option("--region-voxel-mm", o->region_voxel_mm, "level-set voxel in the fine boxes [mm]")->capture_default_str();
  c->add_option("--out", o->out_dir, "output folder (new, empty or a previous vmsim result: replaced as a whole)")->required();
  c->callback([o, &context] { context.result = run_remove(*o, context); });
}

}  // namespace vmsim::app
