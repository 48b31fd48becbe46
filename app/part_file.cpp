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

std::vector<DesignPlane> design_planes(const std::string& file, const YAML::Node& design) {
  std::vector<DesignPlane> planes;
  if (!design) return planes;
  const YAML::Node surfaces = required(file, design, "surfaces", "design.");
  if (!surfaces.IsSequence()) fail(file, surfaces, "design.surfaces: expected a list of patches");
  for (std::size_t k = 0; k < surfaces.size(); ++k) {
    const YAML::Node patch = surfaces[k];
    const std::string path = "design.surfaces[" + std::to_string(k) + "].";
    if (!patch.IsMap()) fail(file, patch, path + ": expected a map");
    if (text(file, patch, "type") != "plane") continue;  // spheres: design_spheres
    DesignPlane plane;
    plane.point_W_m = vector3(file, patch, "point_mm", path, 1e-3);
    const Eigen::Vector3d normal = vector3(file, patch, "normal", path, 1.0);
    if (!(normal.norm() > 1e-9)) fail(file, patch["normal"], path + "normal: must not be zero");
    plane.normal_W = normal.normalized();
    const char* range_keys[3] = {"x_range_mm", "y_range_mm", "z_range_mm"};
    for (int axis = 0; axis < 3; ++axis) {
      const YAML::Node range = patch[range_keys[axis]];
      if (!range) continue;
      if (!range.IsSequence() || range.size() != 2) {
        fail(file, range, path + range_keys[axis] + ": expected [low, high] in mm");
      }
      try {
        plane.min_W_m[axis] = range[0].as<double>() * 1e-3;
        plane.max_W_m[axis] = range[1].as<double>() * 1e-3;
      } catch (const YAML::Exception&) {
        fail(file, range, path + range_keys[axis] + ": expected two numbers");
      }
      if (!(plane.min_W_m[axis] < plane.max_W_m[axis])) {
        fail(file, range, path + range_keys[axis] + ": low must be below high");
      }
    }
    planes.push_back(plane);
  }
  return planes;
}

std::vector<DesignSphere> design_spheres(const std::string& file, const YAML::Node& design) {
  std::vector<DesignSphere> spheres;
  if (!design || !design["surfaces"] || !design["surfaces"].IsSequence()) return spheres;
  const YAML::Node surfaces = design["surfaces"];
  for (std::size_t k = 0; k < surfaces.size(); ++k) {
    const YAML::Node patch = surfaces[k];
    const std::string path = "design.surfaces[" + std::to_string(k) + "].";
    if (text(file, patch, "type") != "sphere") continue;
    DesignSphere sphere;
    sphere.centre_W_m = vector3(file, patch, "center_mm", path, 1e-3);
    sphere.radius_m = positive_number(file, patch, "radius_mm", path) * 1e-3;
    const std::string material = text(file, patch, "material");
    if (material != "inside" && material != "outside") {
      fail(file, patch["material"], path + "material: '" + material + "' is not one of inside, outside");
    }
    sphere.material_inside = material == "inside";
    spheres.push_back(sphere);
  }
  return spheres;
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
  part.design_planes = design_planes(path, root["design"]);
  part.design_spheres = design_spheres(path, root["design"]);
  const YAML::Node feeds = required(path, root, "feeds", "");
  part.production_feed_m_per_s =
      positive_number(path, feeds, "production_mm_per_min", "feeds.") * 1e-3 / 60.0;
  part.reference_feed_m_per_s =
      positive_number(path, feeds, "reference_mm_per_min", "feeds.") * 1e-3 / 60.0;
  return part;
}

}  // namespace vmsim::app
