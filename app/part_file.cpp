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
  if (root["stock"]) {
    const YAML::Node box = required(path, root["stock"], "box", "stock.");
    auto corner = [&](const char* key) {
      const YAML::Node node = required(path, box, key, "stock.box.");
      if (!node.IsSequence() || node.size() != 3) {
        fail(path, node, std::string("stock.box.") + key + ": expected [x, y, z] in mm");
      }
      Eigen::Vector3d corner_m;
      for (std::size_t i = 0; i < 3; ++i) {
        try {
          corner_m[static_cast<Eigen::Index>(i)] = node[i].as<double>() * 1e-3;
        } catch (const YAML::Exception&) {
          fail(path, node[i], std::string("stock.box.") + key + ": '" + node[i].Scalar() +
                                  "' is not a number");
        }
      }
      return corner_m;
    };
    StockBox stock{corner("min_mm"), corner("max_mm")};
    if (!(stock.min_W_m.array() < stock.max_W_m.array()).all()) {
      fail(path, box, "stock.box: min_mm must be below max_mm in x, y and z");
    }
    part.stock = stock;
  }
  const YAML::Node feeds = required(path, root, "feeds", "");
  part.production_feed_m_per_s =
      positive_number(path, feeds, "production_mm_per_min", "feeds.") * 1e-3 / 60.0;
  part.reference_feed_m_per_s =
      positive_number(path, feeds, "reference_mm_per_min", "feeds.") * 1e-3 / 60.0;
  return part;
}

}  // namespace vmsim::app
