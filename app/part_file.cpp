#include "part_file.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>

#include "vmsim/common/errors.hpp"
#include "vmsim/common/files.hpp"
#include "vmsim/kinematics/yaml_input.hpp"

namespace vmsim::app {
namespace {

using Keys = std::vector<std::string>;

// Plausibility bounds [mm] and [mm/min]: beyond an error bound a value is a slip of unit or a
// typo, not a part; beyond a warning bound it is unusual enough to say so.
constexpr double kCoordinateLimit_mm = 1e6;  // 1 km
constexpr double kToolSizeLimit_mm = 10e3;   // 10 m
constexpr double kToolSizeWarning_mm = 1e3;  // 1 m
constexpr double kFeedLimit_mm_per_min = 1e7;
constexpr double kFeedWarningAbove_mm_per_min = 200e3;  // 200 m/min
constexpr double kFeedWarningBelow_mm_per_min = 1.0;

// Reads one part file: every error names the file, line, column, field path and value.
class PartReader {
 public:
  explicit PartReader(std::string file) : file_(std::move(file)) {}

  [[noreturn]] void fail(const YAML::Node& at, const std::string& message) const {
    throw InputError(kinematics::located_at(file_, at, message));
  }

  void warn(const YAML::Node& at, const std::string& message) {
    warnings.push_back(kinematics::located_at(file_, at, message));
  }

  /// `node` must be a map with only `known` keys (a misspelt key is never silently ignored).
  void require_map(const YAML::Node& node, const std::string& path, const Keys& known) const {
    if (!node.IsMap()) fail(node, path + ": expected a map, got " + what(node));
    for (const auto& entry : node) {
      const std::string key = entry.first.Scalar();
      if (std::find(known.begin(), known.end(), key) == known.end()) {
        fail(entry.first, "unknown field '" + join(path, key) + "'" +
                              kinematics::nearest_key_hint(key, known));
      }
    }
  }

  YAML::Node required(const YAML::Node& map, const std::string& key, const std::string& path) const {
    if (!map[key] || map[key].IsNull()) fail(map, "missing field '" + join(path, key) + "'");
    return map[key];
  }

  double number(const YAML::Node& node, const std::string& field) const {
    if (!node.IsScalar()) fail(node, field + ": expected a number, got " + what(node));
    const kinematics::NumberText number = kinematics::parse_number_text(node.Scalar());
    if (!number.ok) fail(node, field + ": '" + node.Scalar() + "' " + number.problem);
    if (field.ends_with("_mm") && !field.ends_with("_per_mm") &&
        std::abs(number.value) > kCoordinateLimit_mm) {
      fail(node, field + ": " + node.Scalar() + " mm is not a plausible length (more than 1 km)");
    }
    return number.value;
  }

  double positive_number(const YAML::Node& map, const std::string& key, const std::string& path) const {
    const YAML::Node node = required(map, key, path);
    const double value = number(node, join(path, key));
    if (!(value > 0.0)) fail(node, join(path, key) + ": must be > 0, got '" + node.Scalar() + "'");
    return value;
  }

  std::string text(const YAML::Node& map, const std::string& key, const std::string& path) const {
    const YAML::Node node = required(map, key, path);
    if (!node.IsScalar()) fail(node, join(path, key) + ": expected a text value, got " + what(node));
    return node.Scalar();
  }

  std::vector<double> numbers(const YAML::Node& node, const std::string& field, std::size_t count) const {
    if (!node.IsSequence() || node.size() != count) {
      const std::string expected = count == 3 ? "[x, y, z]" : "a list of " + std::to_string(count) + " numbers";
      const std::string got =
          node.IsSequence() ? "a list of " + std::to_string(node.size()) : what(node);
      fail(node, field + ": expected " + expected + ", got " + got);
    }
    std::vector<double> values;
    for (std::size_t i = 0; i < count; ++i) values.push_back(number(node[i], field));
    return values;
  }

  Eigen::Vector3d vector3(const YAML::Node& map, const std::string& key, const std::string& path,
                          double scale) const {
    const std::vector<double> v = numbers(required(map, key, path), join(path, key), 3);
    return Eigen::Vector3d(v[0], v[1], v[2]) * scale;
  }

  static std::string join(const std::string& path, const std::string& key) {
    return path.empty() ? key : path + "." + key;
  }

  static std::string what(const YAML::Node& node) {
    if (node.IsScalar()) return "'" + node.Scalar() + "'";
    if (node.IsSequence()) return "a list";
    if (node.IsMap()) return "a map";
    return "nothing";
  }

  const std::string& file() const { return file_; }
  std::vector<std::string> warnings;

 private:
  std::string file_;
};

// x_range_mm, y_range_mm, z_range_mm of a patch, where given, into [min_W_m, max_W_m].
void patch_ranges(const PartReader& reader, const YAML::Node& patch, const std::string& path,
                  Eigen::Vector3d& min_W_m, Eigen::Vector3d& max_W_m) {
  const char* range_keys[3] = {"x_range_mm", "y_range_mm", "z_range_mm"};
  for (int axis = 0; axis < 3; ++axis) {
    const YAML::Node range = patch[range_keys[axis]];
    if (!range) continue;
    const std::string field = PartReader::join(path, range_keys[axis]);
    if (!range.IsSequence() || range.size() != 2) reader.fail(range, field + ": expected [low, high] in mm");
    min_W_m[axis] = reader.number(range[0], field) * 1e-3;
    max_W_m[axis] = reader.number(range[1], field) * 1e-3;
    if (!(min_W_m[axis] < max_W_m[axis])) {
      reader.fail(range, field + ": low must be below high, got [" + range[0].Scalar() + ", " +
                             range[1].Scalar() + "]");
    }
  }
}

// A unit direction from a non-zero [x, y, z].
Eigen::Vector3d direction(const PartReader& reader, const YAML::Node& patch, const std::string& key,
                          const std::string& path) {
  const Eigen::Vector3d value = reader.vector3(patch, key, path, 1.0);
  if (!(value.norm() > 1e-9)) {
    reader.fail(patch[key], PartReader::join(path, key) + ": must not be zero, got [" +
                                format_double(value.x()) + ", " + format_double(value.y()) + ", " +
                                format_double(value.z()) + "]");
  }
  return value.normalized();
}

// `material: inside | outside` of a sphere or cylinder: true for inside.
bool material_inside(const PartReader& reader, const YAML::Node& patch, const std::string& path) {
  const std::string material = reader.text(patch, "material", path);
  if (material != "inside" && material != "outside") {
    reader.fail(patch["material"], PartReader::join(path, "material") + ": '" + material +
                                       "' is not one of inside, outside");
  }
  return material == "inside";
}

// The keys of each patch type (samples/parts/README.md, "design").
const std::map<std::string, Keys>& patch_keys() {
  static const std::map<std::string, Keys> keys = {
      {"plane", {"point_mm", "normal", "role"}},
      {"sphere", {"center_mm", "radius_mm", "material"}},
      {"cylinder", {"axis_point_mm", "axis_direction", "radius_mm", "material"}},
      {"sine_height_y", {"z0_mm", "amplitude_mm", "wavelength_mm", "y_phase_mm"}},
      {"quadratic_height", {"z0_mm", "hxx_per_mm", "hxy_per_mm", "hyy_per_mm"}},
  };
  return keys;
}

// The plane, sphere and cylinder patches of `design.surfaces`; the height-function patches are
// checked (keys, numbers) but read by the sample tests only.
// `tolerance_um` of the part or of a design patch [m]: the depth of mark it can take (the
// report's verdict). Beyond 10 mm it is no surface tolerance but a unit mistake.
double read_tolerance_m(const PartReader& reader, const YAML::Node& map, const std::string& path) {
  const double tolerance_m = reader.positive_number(map, "tolerance_um", path) * 1e-6;
  if (tolerance_m > 10e-3) {
    reader.fail(map["tolerance_um"], PartReader::join(path, "tolerance_um") + ": " + map["tolerance_um"].Scalar() +
                                         " um is not a plausible surface tolerance (more than 10 mm)");
  }
  return tolerance_m;
}

void read_design(const PartReader& reader, const YAML::Node& design, PartDescription& part) {
  if (!design) return;
  reader.require_map(design, "design", {"surfaces", "corner_mm"});
  if (design["corner_mm"]) reader.vector3(design, "corner_mm", "design", 1e-3);
  const YAML::Node surfaces = reader.required(design, "surfaces", "design");
  if (!surfaces.IsSequence()) reader.fail(surfaces, "design.surfaces: expected a list of patches");
  for (std::size_t k = 0; k < surfaces.size(); ++k) {
    const YAML::Node patch = surfaces[k];
    const std::string path = "design.surfaces[" + std::to_string(k) + "]";
    if (!patch.IsMap()) reader.fail(patch, path + ": expected a map, got " + PartReader::what(patch));
    const std::string type = reader.text(patch, "type", path);
    const auto known = patch_keys().find(type);
    if (known == patch_keys().end()) {
      Keys types;
      for (const auto& [name, keys] : patch_keys()) types.push_back(name);
      reader.fail(patch["type"], path + ".type: '" + type + "' is not a known patch type" +
                                     kinematics::nearest_key_hint(type, types));
    }
    Keys keys = known->second;
    keys.insert(keys.end(), {"type", "x_range_mm", "y_range_mm", "z_range_mm", "name", "tolerance_um"});
    reader.require_map(patch, path, keys);
    DesignPatch common;
    common.type = type;
    common.name = patch["name"] ? reader.text(patch, "name", path)
                                : "design surface " + std::to_string(k + 1) + " (" + type + ")";
    if (patch["tolerance_um"]) common.tolerance_m = read_tolerance_m(reader, patch, path);
    patch_ranges(reader, patch, path, common.min_W_m, common.max_W_m);
    part.design_patches.push_back(common);
    if (type == "plane") {
      DesignPlane plane;
      plane.patch_index = k;
      plane.point_W_m = reader.vector3(patch, "point_mm", path, 1e-3);
      plane.normal_W = direction(reader, patch, "normal", path);
      if (patch["role"]) reader.text(patch, "role", path);
      patch_ranges(reader, patch, path, plane.min_W_m, plane.max_W_m);
      part.design_planes.push_back(plane);
    } else if (type == "sphere") {
      DesignSphere sphere;
      sphere.patch_index = k;
      sphere.centre_W_m = reader.vector3(patch, "center_mm", path, 1e-3);
      sphere.radius_m = reader.positive_number(patch, "radius_mm", path) * 1e-3;
      sphere.material_inside = material_inside(reader, patch, path);
      part.design_spheres.push_back(sphere);
    } else if (type == "cylinder") {
      DesignCylinder cylinder;
      cylinder.patch_index = k;
      cylinder.axis_point_W_m = reader.vector3(patch, "axis_point_mm", path, 1e-3);
      cylinder.axis_W = direction(reader, patch, "axis_direction", path);
      cylinder.radius_m = reader.positive_number(patch, "radius_mm", path) * 1e-3;
      cylinder.material_inside = material_inside(reader, patch, path);
      patch_ranges(reader, patch, path, cylinder.min_W_m, cylinder.max_W_m);
      part.design_cylinders.push_back(cylinder);
    } else {
      for (const std::string& key : known->second) {
        reader.number(reader.required(patch, key, path), PartReader::join(path, key));
      }
      Eigen::Vector3d unused_min, unused_max;
      patch_ranges(reader, patch, path, unused_min, unused_max);
    }
  }
}

// The keys of a V or tapered tool (validated here, where the line is known; the ranges are
// removal::Tool::validate's).
void read_conical_tool(PartReader& reader, const YAML::Node& tool, ToolDescription& result, const std::string& path) {
  auto bad = [&](const char* key, const std::string& why) {
    reader.fail(tool[key], path + "." + key + ": " + why + ", got '" + tool[key].Scalar() + "'");
  };
  const double diameter_mm = result.diameter_m * 1e3;
  if (result.type == ToolType::v) {
    const double angle = reader.number(reader.required(tool, "tip_angle_deg", path), path + ".tip_angle_deg");
    if (!(angle > 0.0 && angle < 180.0)) bad("tip_angle_deg", "the included angle of a V tool must be in (0, 180) deg");
    result.tip_angle_rad = angle * M_PI / 180.0;
    if (tool["tip_diameter_mm"]) {
      const double tip = reader.number(tool["tip_diameter_mm"], path + ".tip_diameter_mm");
      if (!(tip >= 0.0 && tip < diameter_mm)) bad("tip_diameter_mm", "must be in [0, diameter_mm)");
      result.tip_diameter_m = tip * 1e-3;
    }
    return;
  }
  const double taper = reader.number(reader.required(tool, "taper_angle_deg", path), path + ".taper_angle_deg");
  if (!(taper >= 0.0 && taper < 45.0)) bad("taper_angle_deg", "the angle per side must be in [0, 45) deg");
  result.taper_angle_rad = taper * M_PI / 180.0;
  const double tip = reader.number(reader.required(tool, "tip_diameter_mm", path), path + ".tip_diameter_mm");
  const bool ball = result.type == ToolType::tapered_ball;
  if (!(tip > 0.0 && (ball ? tip <= diameter_mm : tip < diameter_mm))) {
    bad("tip_diameter_mm", ball ? "the ball's diameter must be in (0, diameter_mm]" : "must be in (0, diameter_mm)");
  }
  result.tip_diameter_m = tip * 1e-3;
  if (ball) result.corner_radius_m = 0.5 * result.tip_diameter_m;
}

// `tool:`, or one entry of `tools:` (path "tools[k]", with its `number`).
void read_tool(PartReader& reader, const YAML::Node& tool, ToolDescription& result,
               const std::string& path = "tool", const Keys& extra_keys = {}) {
  Keys keys{"type",          "diameter_mm",   "corner_radius_mm", "length_mm",      "cutting_length_mm",
            "tip_angle_deg", "taper_angle_deg", "tip_diameter_mm"};
  keys.insert(keys.end(), extra_keys.begin(), extra_keys.end());
  reader.require_map(tool, path, keys);
  const std::string type = reader.text(tool, "type", path);
  if (type == "ball") {
    result.type = ToolType::ball;
  } else if (type == "flat") {
    result.type = ToolType::flat;
  } else if (type == "bull") {
    result.type = ToolType::bull;
  } else if (type == "v") {
    result.type = ToolType::v;
  } else if (type == "tapered_flat") {
    result.type = ToolType::tapered_flat;
  } else if (type == "tapered_ball") {
    result.type = ToolType::tapered_ball;
  } else {
    reader.fail(tool["type"], path + ".type: '" + type +
                                  "' is not one of ball, flat, bull, v, tapered_flat, tapered_ball");
  }
  const bool conical = result.type == ToolType::v || result.type == ToolType::tapered_flat ||
                       result.type == ToolType::tapered_ball;
  // The conical tools' keys: only for them, and each where its type needs it.
  auto only_for = [&](const char* key, bool allowed, const std::string& which) {
    if (tool[key] && !allowed) {
      reader.fail(tool[key], path + "." + key + ": only for " + which + " tools (type is " + type + ")");
    }
  };
  only_for("tip_angle_deg", result.type == ToolType::v, "v");
  only_for("taper_angle_deg", conical && result.type != ToolType::v, "tapered_flat and tapered_ball");
  only_for("tip_diameter_mm", conical, "v, tapered_flat and tapered_ball");
  only_for("corner_radius_mm", !conical, "ball, flat and bull (tapered_ball: tip_diameter_mm)");
  for (const char* key : {"diameter_mm", "length_mm"}) {
    const double value_mm = reader.positive_number(tool, key, path);
    if (value_mm > kToolSizeLimit_mm) {
      reader.fail(tool[key], path + "." + key + ": " + tool[key].Scalar() +
                                 " mm is not a plausible tool (more than 10 m; m or µm written?)");
    }
    if (value_mm > kToolSizeWarning_mm) {
      reader.warn(tool[key], path + "." + key + ": " + tool[key].Scalar() +
                                 " mm is unusually large (more than 1 m): check the unit");
    }
  }
  result.diameter_m = reader.number(tool["diameter_mm"], path + ".diameter_mm") * 1e-3;
  result.length_m = reader.number(tool["length_mm"], path + ".length_mm") * 1e-3;
  if (tool["corner_radius_mm"]) {
    const double radius_mm = reader.number(tool["corner_radius_mm"], path + ".corner_radius_mm");
    if (radius_mm < 0.0 || radius_mm * 1e-3 > result.diameter_m / 2.0 + 1e-12) {
      reader.fail(tool["corner_radius_mm"], path + ".corner_radius_mm: must be between 0 and "
                                            "diameter_mm / 2, got '" +
                                                tool["corner_radius_mm"].Scalar() + "'");
    }
    result.corner_radius_m = radius_mm * 1e-3;
  } else if (result.type == ToolType::ball) {
    result.corner_radius_m = result.diameter_m / 2.0;
  }
  if (conical) read_conical_tool(reader, tool, result, path);
  if (tool["cutting_length_mm"]) {
    result.cutting_length_m = reader.positive_number(tool, "cutting_length_mm", path) * 1e-3;
    if (result.cutting_length_m < result.diameter_m - 1e-12 ||
        result.cutting_length_m > result.length_m + 1e-12) {
      reader.fail(tool["cutting_length_mm"],
                  path + ".cutting_length_mm: must be between diameter_mm and length_mm, got '" +
                      tool["cutting_length_mm"].Scalar() + "'");
    }
  }
}

void read_stock(const PartReader& reader, const YAML::Node& stock_node,
                const std::filesystem::path& folder, PartDescription& part) {
  reader.require_map(stock_node, "stock", {"box", "stl", "allowance_mm"});
  if (stock_node["allowance_mm"]) reader.number(stock_node["allowance_mm"], "stock.allowance_mm");
  if (stock_node["stl"]) {
    if (stock_node["box"]) reader.fail(stock_node, "stock: give either box or stl, not both");
    if (!stock_node["stl"].IsScalar()) reader.fail(stock_node["stl"], "stock.stl: expected a file name");
    part.stock_stl_path = (folder / stock_node["stl"].Scalar()).lexically_normal().string();
    std::error_code status;  // (a name too long for the file system throws without one)
    if (!std::filesystem::is_regular_file(part.stock_stl_path, status)) {
      reader.fail(stock_node["stl"], "stock.stl: no file '" + part.stock_stl_path + "'" +
                                         (status ? " (" + status.message() + ")" : std::string()));
    }
    try {
      part.stock_mesh = removal::read_stl(part.stock_stl_path);
    } catch (const InputError& error) {
      reader.fail(stock_node["stl"], std::string("stock.stl: ") + error.what());
    }
    return;
  }
  if (!stock_node["box"]) {
    reader.fail(stock_node,
                "stock: expected {box: {min_mm: [x, y, z], max_mm: [x, y, z]}} or {stl: <file>}");
  }
  const YAML::Node box = stock_node["box"];
  reader.require_map(box, "stock.box", {"min_mm", "max_mm"});
  StockBox stock{reader.vector3(box, "min_mm", "stock.box", 1e-3),
                 reader.vector3(box, "max_mm", "stock.box", 1e-3)};
  if (!(stock.min_W_m.array() < stock.max_W_m.array()).all()) {
    reader.fail(box, "stock.box: min_mm must be below max_mm in x, y and z");
  }
  part.stock = stock;
}

double read_feed_m_per_s(PartReader& reader, const YAML::Node& feeds, const std::string& key) {
  const double feed_mm_per_min = reader.positive_number(feeds, key, "feeds");
  if (feed_mm_per_min > kFeedLimit_mm_per_min) {
    reader.fail(feeds[key], "feeds." + key + ": " + feeds[key].Scalar() +
                                " mm/min is not a plausible feed (more than 10 km/min)");
  }
  if (feed_mm_per_min > kFeedWarningAbove_mm_per_min ||
      feed_mm_per_min < kFeedWarningBelow_mm_per_min) {
    reader.warn(feeds[key], "feeds." + key + ": " + feeds[key].Scalar() +
                                " mm/min is unusual (feeds run at 1 mm/min to 200 m/min): check "
                                "the unit");
  }
  return feed_mm_per_min * 1e-3 / 60.0;
}

// A position [mm] within the plausible coordinates (1 km).
Eigen::Vector3d plausible_position(const PartReader& reader, const YAML::Node& node,
                                   const std::string& field, const std::vector<double>& v) {
  for (std::size_t k = 0; k < 3; ++k) {
    if (std::abs(v[k]) > kCoordinateLimit_mm) {
      reader.fail(node[k], field + ": " + node[k].Scalar() +
                               " mm is not a plausible length (more than 1 km)");
    }
  }
  return Eigen::Vector3d(v[0], v[1], v[2]);
}

// `setup:` (samples/parts/README.md, "setup").
MachineSetup read_setup(const PartReader& reader, const YAML::Node& node) {
  reader.require_map(node, "setup", {"work_offsets_mm", "active_offset", "reference_points_mm"});
  MachineSetup setup;
  if (node["work_offsets_mm"]) {
    const YAML::Node offsets = node["work_offsets_mm"];
    if (!offsets.IsMap()) {
      reader.fail(offsets, "setup.work_offsets_mm: expected a map {G54: [x, y, z], ...}, got " +
                               PartReader::what(offsets));
    }
    for (const auto& entry : offsets) {
      const std::string name = entry.first.Scalar();
      bool known = false;
      for (int n = 54; n <= 59; ++n) known = known || name == "G" + std::to_string(n);
      for (int p = 1; p <= 48; ++p) known = known || name == "G54.1 P" + std::to_string(p);
      if (!known) {
        reader.fail(entry.first, "setup.work_offsets_mm: '" + name +
                                     "' is not a work offset (G54 .. G59, 'G54.1 P1' .. "
                                     "'G54.1 P48')");
      }
      const std::string field = "setup.work_offsets_mm." + name;
      const std::vector<double> v = reader.numbers(entry.second, field, 3);
      setup.work_zero_W_mm[name] = plausible_position(reader, entry.second, field, v);
    }
  }
  if (node["active_offset"]) {
    setup.active_offset = reader.text(node, "active_offset", "setup");
    if (!setup.work_zero_W_mm.count(setup.active_offset)) {
      reader.fail(node["active_offset"], "setup.active_offset: '" + setup.active_offset +
                                             "' is not one of setup.work_offsets_mm");
    }
  } else if (!setup.work_zero_W_mm.empty() && !setup.work_zero_W_mm.count("G54")) {
    reader.fail(node, "setup: G54 (the offset in force at the start) is not in work_offsets_mm: "
                      "give it, or active_offset");
  }
  if (node["reference_points_mm"]) {
    const YAML::Node points = node["reference_points_mm"];
    reader.require_map(points, "setup.reference_points_mm", {"G28", "G30"});
    for (const char* key : {"G28", "G30"}) {
      if (!points[key]) continue;
      const std::string field = std::string("setup.reference_points_mm.") + key;
      const Eigen::Vector3d p = plausible_position(
          reader, points[key], field, reader.numbers(points[key], field, 3));
      (std::string(key) == "G28" ? setup.g28_reference_mm : setup.g30_reference_mm) = p;
    }
  }
  return setup;
}

// `tools:` a list of tools with distinct T numbers.
void read_tools(PartReader& reader, const YAML::Node& tools, PartDescription& part) {
  if (!tools.IsSequence() || tools.size() == 0) {
    reader.fail(tools, "tools: expected a list of tools, got " + PartReader::what(tools));
  }
  for (std::size_t k = 0; k < tools.size(); ++k) {
    const std::string path = "tools[" + std::to_string(k) + "]";
    const YAML::Node entry = tools[k];
    if (!entry.IsMap()) reader.fail(entry, path + ": expected a map, got " + PartReader::what(entry));
    NumberedTool numbered;
    const YAML::Node number = reader.required(entry, "number", path);
    const double value = reader.number(number, path + ".number");
    if (!(value >= 0.0 && value <= 1e9 && value == std::floor(value))) {
      reader.fail(number, path + ".number: expected a whole number 0 .. 1e9, got '" + number.Scalar() + "'");
    }
    numbered.number = static_cast<int>(value);
    for (const NumberedTool& other : part.tools) {
      if (other.number == numbered.number) {
        reader.fail(number, path + ".number: T" + number.Scalar() + " is in the table twice");
      }
    }
    read_tool(reader, entry, numbered.tool, path, {"number"});
    part.tools.push_back(numbered);
  }
}

// A percentage of the programmed feed, within (0, max_percent].
double read_percent(PartReader& reader, const YAML::Node& feeds, const std::string& key,
                    double max_percent) {
  const double percent = reader.positive_number(feeds, key, "feeds");
  if (percent > max_percent) {
    reader.fail(feeds[key], "feeds." + key + ": " + feeds[key].Scalar() + " % is above " +
                                format_double(max_percent) + " %");
  }
  return percent / 100.0;
}

// `feeds`: production = a fixed feed (production_mm_per_min, every cutting move, as before) or
// the programmed feed x override_percent (default 100 %); reference = a fixed feed
// (reference_mm_per_min) or the programmed feed x reference_percent (default 1 %).
void read_feeds(PartReader& reader, const YAML::Node& feeds, PartDescription& part) {
  reader.require_map(feeds, "feeds", {"production_mm_per_min", "override_percent",
                                      "reference_mm_per_min", "reference_percent"});
  for (const auto& [fixed, percent] : {std::pair<const char*, const char*>{"production_mm_per_min", "override_percent"},
                                       {"reference_mm_per_min", "reference_percent"}}) {
    if (feeds[fixed] && feeds[percent]) {
      reader.fail(feeds[percent], std::string("feeds: give either ") + fixed + " or " + percent +
                                      ", not both");
    }
  }
  if (feeds["production_mm_per_min"]) {
    part.production_feed_m_per_s = read_feed_m_per_s(reader, feeds, "production_mm_per_min");
    part.production_feed = {part.production_feed_m_per_s, 0.0};
  } else if (feeds["override_percent"]) {
    part.production_feed = {0.0, read_percent(reader, feeds, "override_percent", 1000.0)};
  }
  if (feeds["reference_mm_per_min"]) {
    part.reference_feed_m_per_s = read_feed_m_per_s(reader, feeds, "reference_mm_per_min");
    part.reference_feed = {part.reference_feed_m_per_s, 0.0};
  } else if (feeds["reference_percent"]) {
    part.reference_feed = {0.0, read_percent(reader, feeds, "reference_percent", 100.0)};
  }
}

}  // namespace

PartDescription load_part(const std::string& path) {
  const YAML::Node root = kinematics::load_yaml_input(path);
  PartReader reader(path);
  if (!root.IsMap()) throw InputError(located_message(path, 0, 0, "a part file is a YAML map"));
  reader.require_map(root, "", {"name", "description", "machine", "toolpath", "tool", "stock",
                                "design", "strategy", "feeds", "tools", "setup", "tolerance_um"});
  const std::filesystem::path folder = std::filesystem::path(path).parent_path();
  PartDescription part;
  part.file = path;
  part.name = reader.text(root, "name", "");
  part.description = root["description"] ? reader.text(root, "description", "") : "";
  part.machine_path = (folder / reader.text(root, "machine", "")).lexically_normal().string();
  part.toolpath_path = (folder / reader.text(root, "toolpath", "")).lexically_normal().string();
  if (root["tools"]) read_tools(reader, root["tools"], part);
  if (root["tool"] || part.tools.empty()) {
    read_tool(reader, reader.required(root, "tool", ""), part.tool);
  } else {
    part.tool = part.tools.front().tool;
  }
  if (root["stock"]) read_stock(reader, root["stock"], folder, part);
  read_design(reader, root["design"], part);
  if (root["setup"]) part.setup = read_setup(reader, root["setup"]);
  // How the path was made: informative (samples/parts/README.md), only its shape is checked.
  if (root["strategy"] && !root["strategy"].IsMap()) {
    reader.fail(root["strategy"], "strategy: expected a map, got " + PartReader::what(root["strategy"]));
  }
  read_feeds(reader, reader.required(root, "feeds", ""), part);
  // simulate-part --tolerance-um overrides the part's; a patch's own holds on that patch.
  if (root["tolerance_um"]) part.tolerance_m = read_tolerance_m(reader, root, "");
  part.warnings = std::move(reader.warnings);
  return part;
}

const ToolDescription* PartDescription::tool_for(int tool_number) const {
  if (tool_number < 0) return &tool;
  for (const NumberedTool& entry : tools) {
    if (entry.number == tool_number) return &entry.tool;
  }
  return nullptr;
}

}  // namespace vmsim::app
