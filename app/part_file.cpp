#include "part_file.hpp"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <filesystem>

#include "vmsim/common/errors.hpp"
#include "vmsim/common/files.hpp"

namespace vmsim::app {
namespace {

[[noreturn]] void fail(const std::string& file, const YAML::Node& node, const std::string& message) {
  const YAML::Mark mark = node.Mark();
  throw InputError(located_message(file, mark.is_null() ? 0 : mark.line + 1,
                                   mark.is_null() ? 0 : mark.column + 1, message));
}

YAML::Node required(const std::string& file, const YAML::Node& map, const std::string& key,
                    const std::string& path) {
  if (!map.IsMap() || !map[key]) fail(file, map, "missing field '" + path + key + "'");
  return map[key];
}

double positive_number(const std::string& file, const YAML::Node& map, const std::string& key,
                       const std::string& path) {
  const YAML::Node node = required(file, map, key, path);
  double value = 0.0;
  try {
    value = node.as<double>();
  } catch (const YAML::Exception&) {
    fail(file, node, path + key + ": expected a number, got '" + node.Scalar() + "'");
  }
  if (!std::isfinite(value) || value <= 0.0) {
    fail(file, node, path + key + ": must be > 0, got '" + node.Scalar() + "'");
  }
  return value;
}

std::string text(const std::string& file, const YAML::Node& map, const std::string& key) {
  const YAML::Node node = required(file, map, key, "");
  if (!node.IsScalar()) fail(file, node, key + ": expected a text value");
  return node.Scalar();
}

Eigen::Vector3d vector3(const std::string& file, const YAML::Node& map, const std::string& key,
                        const std::string& path, double scale) {
  const YAML::Node node = required(file, map, key, path);
  if (!node.IsSequence() || node.size() != 3) fail(file, node, path + key + ": expected [x, y, z]");
  Eigen::Vector3d value;
  for (std::size_t i = 0; i < 3; ++i) {
    try {
      value[static_cast<Eigen::Index>(i)] = node[i].as<double>() * scale;
    } catch (const YAML::Exception&) {
      fail(file, node[i], path + key + ": '" + node[i].Scalar() + "' is not a number");
    }
  }
  return value;
}

// x_range_mm, y_range_mm, z_range_mm of a patch, where given, into [min_W_m, max_W_m].
void patch_ranges(const std::string& file, const YAML::Node& patch, const std::string& path,
                  Eigen::Vector3d& min_W_m, Eigen::Vector3d& max_W_m) {
  const char* range_keys[3] = {"x_range_mm", "y_range_mm", "z_range_mm"};
  for (int axis = 0; axis < 3; ++axis) {
    const YAML::Node range = patch[range_keys[axis]];
    if (!range) continue;
    if (!range.IsSequence() || range.size() != 2) {
      fail(file, range, path + range_keys[axis] + ": expected [low, high] in mm");
    }
    try {
      min_W_m[axis] = range[0].as<double>() * 1e-3;
      max_W_m[axis] = range[1].as<double>() * 1e-3;
    } catch (const YAML::Exception&) {
      fail(file, range, path + range_keys[axis] + ": expected two numbers");
    }
    if (!(min_W_m[axis] < max_W_m[axis])) {
      fail(file, range, path + range_keys[axis] + ": low must be below high, got [" + range[0].Scalar() + ", " +
                            range[1].Scalar() + "]");
    }
  }
}

// A unit direction from a non-zero [x, y, z].
Eigen::Vector3d direction(const std::string& file, const YAML::Node& patch, const std::string& key,
                          const std::string& path) {
  const Eigen::Vector3d value = vector3(file, patch, key, path, 1.0);
  if (!(value.norm() > 1e-9)) {
    fail(file, patch[key], path + key + ": must not be zero, got [" + format_double(value.x()) + ", " +
                               format_double(value.y()) + ", " + format_double(value.z()) + "]");
  }
  return value.normalized();
}

// `material: inside | outside` of a sphere or cylinder: true for inside.
bool material_inside(const std::string& file, const YAML::Node& patch, const std::string& path) {
  const std::string material = text(file, patch, "material");
  if (material != "inside" && material != "outside") {
    fail(file, patch["material"], path + "material: '" + material + "' is not one of inside, outside");
  }
  return material == "inside";
}

// The plane, sphere and cylinder patches of `design.surfaces` (other types are skipped).
void read_design(const std::string& file, const YAML::Node& design, PartDescription& part) {
  if (!design) return;
  const YAML::Node surfaces = required(file, design, "surfaces", "design.");
  if (!surfaces.IsSequence()) fail(file, surfaces, "design.surfaces: expected a list of patches");
  for (std::size_t k = 0; k < surfaces.size(); ++k) {
    const YAML::Node patch = surfaces[k];
    const std::string path = "design.surfaces[" + std::to_string(k) + "].";
    if (!patch.IsMap()) fail(file, patch, path + ": expected a map");
    const std::string type = text(file, patch, "type");
    if (type == "plane") {
      DesignPlane plane;
      plane.point_W_m = vector3(file, patch, "point_mm", path, 1e-3);
      plane.normal_W = direction(file, patch, "normal", path);
      patch_ranges(file, patch, path, plane.min_W_m, plane.max_W_m);
      part.design_planes.push_back(plane);
    } else if (type == "sphere") {
      DesignSphere sphere;
      sphere.centre_W_m = vector3(file, patch, "center_mm", path, 1e-3);
      sphere.radius_m = positive_number(file, patch, "radius_mm", path) * 1e-3;
      sphere.material_inside = material_inside(file, patch, path);
      part.design_spheres.push_back(sphere);
    } else if (type == "cylinder") {
      DesignCylinder cylinder;
      cylinder.axis_point_W_m = vector3(file, patch, "axis_point_mm", path, 1e-3);
      cylinder.axis_W = direction(file, patch, "axis_direction", path);
      cylinder.radius_m = positive_number(file, patch, "radius_mm", path) * 1e-3;
      cylinder.material_inside = material_inside(file, patch, path);
      patch_ranges(file, patch, path, cylinder.min_W_m, cylinder.max_W_m);
      part.design_cylinders.push_back(cylinder);
    }
  }
}

}  // namespace

PartDescription load_part(const std::string& path) {
  const std::string content = read_file(path);
  YAML::Node root;
  try {
    root = YAML::Load(content);
  } catch (const YAML::Exception& error) {
    throw InputError(located_message(path, error.mark.line + 1, error.mark.column + 1,
                                     "YAML syntax: " + error.msg));
  }
  if (!root.IsMap()) throw InputError(path + ": a part file is a YAML map");
  const std::filesystem::path folder = std::filesystem::path(path).parent_path();
  PartDescription part;
  part.file = path;
  part.name = text(path, root, "name");
  part.description = root["description"] ? root["description"].as<std::string>() : "";
  part.machine_path = (folder / text(path, root, "machine")).lexically_normal().string();
  part.toolpath_path = (folder / text(path, root, "toolpath")).lexically_normal().string();

  const YAML::Node tool = required(path, root, "tool", "");
  const std::string type = text(path, tool, "type");
  if (type == "ball") {
    part.tool.type = ToolType::ball;
  } else if (type == "flat") {
    part.tool.type = ToolType::flat;
  } else if (type == "bull") {
    part.tool.type = ToolType::bull;
  } else {
    fail(path, tool["type"], "tool.type: '" + type + "' is not one of ball, flat, bull");
  }
  part.tool.diameter_m = positive_number(path, tool, "diameter_mm", "tool.") * 1e-3;
  part.tool.length_m = positive_number(path, tool, "length_mm", "tool.") * 1e-3;
  if (tool["corner_radius_mm"]) {
    part.tool.corner_radius_m = tool["corner_radius_mm"].as<double>() * 1e-3;
  } else if (part.tool.type == ToolType::ball) {
    part.tool.corner_radius_m = part.tool.diameter_m / 2.0;
  }
  if (tool["cutting_length_mm"]) {
    part.tool.cutting_length_m = positive_number(path, tool, "cutting_length_mm", "tool.") * 1e-3;
    if (part.tool.cutting_length_m < part.tool.diameter_m - 1e-12 ||
        part.tool.cutting_length_m > part.tool.length_m + 1e-12) {
      fail(path, tool["cutting_length_mm"], "tool.cutting_length_mm: must be between diameter_mm and length_mm, got '" +
                                                tool["cutting_length_mm"].Scalar() + "'");
    }
  }
  if (root["stock"]) {
    const YAML::Node stock_node = root["stock"];
    if (stock_node.IsMap() && stock_node["stl"]) {
      if (stock_node["box"]) fail(path, stock_node, "stock: give either box or stl, not both");
      if (!stock_node["stl"].IsScalar()) fail(path, stock_node["stl"], "stock.stl: expected a file name");
      part.stock_stl_path = (folder / stock_node["stl"].Scalar()).lexically_normal().string();
      if (!std::filesystem::is_regular_file(part.stock_stl_path)) {
        fail(path, stock_node["stl"], "stock.stl: no file '" + part.stock_stl_path + "'");
      }
      try {
        part.stock_mesh = removal::read_stl(part.stock_stl_path);
      } catch (const InputError& error) {
        fail(path, stock_node["stl"], std::string("stock.stl: ") + error.what());
      }
    } else {
      if (!stock_node.IsMap() || !stock_node["box"]) {
        fail(path, stock_node, "stock: expected {box: {min_mm: [x, y, z], max_mm: [x, y, z]}} or {stl: <file>}");
      }
      const YAML::Node box = stock_node["box"];
      StockBox stock{vector3(path, box, "min_mm", "stock.box.", 1e-3),
                     vector3(path, box, "max_mm", "stock.box.", 1e-3)};
      if (!(stock.min_W_m.array() < stock.max_W_m.array()).all()) {
        fail(path, box, "stock.box: min_mm must be below max_mm in x, y and z");
      }
      part.stock = stock;
    }
  }
  read_design(path, root["design"], part);
  const YAML::Node feeds = required(path, root, "feeds", "");
  part.production_feed_m_per_s =
      positive_number(path, feeds, "production_mm_per_min", "feeds.") * 1e-3 / 60.0;
  part.reference_feed_m_per_s =
      positive_number(path, feeds, "reference_mm_per_min", "feeds.") * 1e-3 / 60.0;
  return part;
}

}  // namespace vmsim::app
