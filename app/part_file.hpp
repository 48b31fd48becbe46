#pragma once
// A part description (samples/parts/<part>/part.yaml): machine, tool path, tool, stock, feeds.
// Documented in samples/parts/README.md. Paths inside are relative to the part file.
#include <Eigen/Core>
#include <limits>
#include <optional>
#include <vector>
#include <string>

namespace vmsim::app {

enum class ToolType { ball, flat, bull };

struct ToolDescription {
  ToolType type = ToolType::ball;
  double diameter_m = 0.0;
  double corner_radius_m = 0.0;
  double length_m = 0.0;  ///< from the spindle gauge point to the tool tip
};

/// The stock box [m, W].
struct StockBox {
  Eigen::Vector3d min_W_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d max_W_m = Eigen::Vector3d::Zero();
};

/// A plane patch of the design surface (`design.surfaces`, type plane) [m, W]. The other patch
/// types (cylinder, sphere, height functions) are read by the sample tests only; simulate-part
/// uses the planes to put N-buffer lines along the normals of walls a Z-map cannot see.
struct DesignPlane {
  Eigen::Vector3d point_W_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d normal_W = Eigen::Vector3d::UnitZ();  ///< unit, out of the material
  /// Bounds of the patch's points (x_range_mm, y_range_mm, z_range_mm); +-inf where not given.
  Eigen::Vector3d min_W_m = Eigen::Vector3d::Constant(-std::numeric_limits<double>::infinity());
  Eigen::Vector3d max_W_m = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
};

struct PartDescription {
  std::string file;
  std::string name;
  std::string description;
  std::string machine_path;   ///< resolved against the part file's folder
  std::string toolpath_path;  ///< resolved against the part file's folder
  ToolDescription tool;
  std::optional<StockBox> stock;  ///< `stock: {box: {min_mm, max_mm}}` where given
  std::vector<DesignPlane> design_planes;  ///< the plane patches of `design.surfaces`
  double production_feed_m_per_s = 0.0;
  double reference_feed_m_per_s = 0.0;
};

/// Reads a part file; throws vmsim::InputError naming the file, line and field.
PartDescription load_part(const std::string& path);

}  // namespace vmsim::app
