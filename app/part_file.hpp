#pragma once
// A part description (samples/parts/<part>/part.yaml): machine, tool path, tool, stock, feeds.
// Documented in samples/parts/README.md. Paths inside are relative to the part file.
#include <Eigen/Core>
#include <limits>
#include <map>
#include <optional>
#include <vector>
#include <string>

#include "vmsim/removal/stl.hpp"

namespace vmsim::app {

/// ball, flat, bull; v (engraving / chamfer), tapered_flat, tapered_ball: conical tools
/// (removal::Tool, samples/parts/README.md).
enum class ToolType { ball, flat, bull, v, tapered_flat, tapered_ball };

struct ToolDescription {
  ToolType type = ToolType::ball;
  double diameter_m = 0.0;
  double corner_radius_m = 0.0;
  double length_m = 0.0;  ///< from the spindle gauge point to the tool tip
  /// The cutting body from the tip (`cutting_length_mm`, D <= it <= length_m): the solid the
  /// material removal sweeps (removal::Tool::length_m); the shank and holder above it are not
  /// modelled. 0 = not given: the whole length_m.
  double cutting_length_m = 0.0;
  /// Conical tools: the tip's flat (v, tapered_flat) or ball (tapered_ball) diameter
  /// (`tip_diameter_mm`) [m]; v: 0 unless given.
  double tip_diameter_m = 0.0;
  double tip_angle_rad = 0.0;    ///< v: included angle (`tip_angle_deg`, in (0, 180)) [rad]
  double taper_angle_rad = 0.0;  ///< tapered_*: angle per side (`taper_angle_deg`, in [0, 45)) [rad]
};

/// One entry of the part file's `tools:` table: the tool a program selects with T<number> M6.
struct NumberedTool {
  int number = 0;  ///< the T number, >= 0
  ToolDescription tool;
};

/// The stock box [m, W].
struct StockBox {
  Eigen::Vector3d min_W_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d max_W_m = Eigen::Vector3d::Zero();
};

/// A plane patch of the design surface (`design.surfaces`, type plane) [m, W]. Planes, spheres
/// and cylinders are read here (simulate-part puts N-buffer lines along the normals of walls,
/// spheres and cylinders); the height-function patches are read by the sample tests only.
struct DesignPlane {
  std::size_t patch_index = 0;  ///< its place in `design.surfaces` (PartDescription::design_patches)
  Eigen::Vector3d point_W_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d normal_W = Eigen::Vector3d::UnitZ();  ///< unit, out of the material
  /// Bounds of the patch's points (x_range_mm, y_range_mm, z_range_mm); +-inf where not given.
  Eigen::Vector3d min_W_m = Eigen::Vector3d::Constant(-std::numeric_limits<double>::infinity());
  Eigen::Vector3d max_W_m = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
};

/// A sphere patch of the design surface (`design.surfaces`, type sphere) [m, W]: simulate-part
/// looks at it along its normals (lines through the centre).
struct DesignSphere {
  std::size_t patch_index = 0;  ///< its place in `design.surfaces` (PartDescription::design_patches)
  Eigen::Vector3d centre_W_m = Eigen::Vector3d::Zero();
  double radius_m = 0.0;
  bool material_inside = true;  ///< a dome (`material: inside`); else a spherical pocket
};

/// A cylinder patch of the design surface (`design.surfaces`, type cylinder) [m, W]:
/// simulate-part looks at it along its normals (lines through the axis, square to it).
struct DesignCylinder {
  std::size_t patch_index = 0;  ///< its place in `design.surfaces` (PartDescription::design_patches)
  Eigen::Vector3d axis_point_W_m = Eigen::Vector3d::Zero();  ///< `axis_point_mm`
  Eigen::Vector3d axis_W = Eigen::Vector3d::UnitZ();         ///< `axis_direction`, made unit
  double radius_m = 0.0;
  /// A boss (`material: inside`); else a concave fillet or a bore (`outside`).
  bool material_inside = true;
  /// Bounds of the patch's points (x_range_mm, y_range_mm, z_range_mm); +-inf where not given.
  Eigen::Vector3d min_W_m = Eigen::Vector3d::Constant(-std::numeric_limits<double>::infinity());
  Eigen::Vector3d max_W_m = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
};

/// What every patch of `design.surfaces` has, whatever its type (the tolerance of the report's
/// verdict on the marks that lie on it).
struct DesignPatch {
  std::string type;  ///< "plane", "sphere", "cylinder", "quadratic_height", ...
  /// `name:` where given, else "design surface <k> (<type>)", k counted from 1 in the file.
  std::string name;
  /// `tolerance_um` of the patch [m]: the deepest mark it can take; 0 = the part's tolerance.
  double tolerance_m = 0.0;
  /// Bounds of the patch's points (x_range_mm, y_range_mm, z_range_mm); +-inf where not given.
  Eigen::Vector3d min_W_m = Eigen::Vector3d::Constant(-std::numeric_limits<double>::infinity());
  Eigen::Vector3d max_W_m = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
};

/// `setup:` how the workpiece sits on the machine, for G-code programs (samples/parts/README.md,
/// "setup"). Without it G54 is the identity: X Y Z outside tool-centre-point mode are machine
/// axis positions, under it W coordinates.
struct MachineSetup {
  /// Where each work zero lies in W [mm] (on the table for a table-table machine, so it turns
  /// with the table), by name: "G54" .. "G59", "G54.1 P1" .. "G54.1 P48".
  std::map<std::string, Eigen::Vector3d> work_zero_W_mm;
  /// The work offset in force at the program start (`active_offset`, default G54).
  std::string active_offset = "G54";
  /// G28 / G30 reference points as machine axis positions X Y Z [mm]; not given: the machine's
  /// home positions.
  std::optional<Eigen::Vector3d> g28_reference_mm;
  std::optional<Eigen::Vector3d> g30_reference_mm;
};

/// How a run sets the feed of its cutting moves (part file `feeds`, samples/parts/README.md).
/// Rapids and turns of the tool about a fixed tip get no feed limit (the axes' own limits).
struct FeedSetting {
  /// > 0: every cutting move at this feed [m/s] (`production_mm_per_min`,
  /// `reference_mm_per_min`, --feed-mm-per-min), whatever the program says.
  double fixed_m_per_s = 0.0;
  /// Else: the programmed feed (G94 F, APT FEDRAT; G93 inverse time as the chord over the
  /// programmed time) times this factor (`override_percent` / 100, `reference_percent` / 100).
  double programmed_factor = 1.0;
};

struct PartDescription {
  std::string file;
  std::string name;
  std::string description;
  std::string machine_path;   ///< resolved against the part file's folder
  std::string toolpath_path;  ///< resolved against the part file's folder
  /// The tool where the program selects none (PathPoint::tool_number -1): `tool:`, or the
  /// first entry of `tools:` where only the table is given.
  ToolDescription tool;
  /// `tools:` (T numbers, distinct), in the order of the file; empty where not given.
  std::vector<NumberedTool> tools;
  /// The tool for a PathPoint::tool_number: `tool` for -1, else the table's entry; nullptr
  /// where the table has no such number.
  const ToolDescription* tool_for(int tool_number) const;
  std::optional<StockBox> stock;  ///< `stock: {box: {min_mm, max_mm}}` where given
  /// `stock: {stl: <file>}`: a closed mesh (a near-net stock, mm), read and checked with the
  /// part file; `stock_stl_path` is resolved against the part file's folder. One of `stock` and
  /// `stock_mesh` at most.
  std::optional<removal::TriangleMesh> stock_mesh;
  std::string stock_stl_path;
  std::vector<DesignPatch> design_patches;  ///< every patch of `design.surfaces`, in its order
  std::vector<DesignPlane> design_planes;  ///< the plane patches of `design.surfaces`
  std::vector<DesignSphere> design_spheres;  ///< the sphere patches of `design.surfaces`
  std::vector<DesignCylinder> design_cylinders;  ///< the cylinder patches of `design.surfaces`
  std::optional<MachineSetup> setup;  ///< `setup:` where given
  /// `tolerance_um`: the deepest mark the part can take [m] (the report's verdict); 0 = not given.
  /// A patch's own `tolerance_um` (DesignPatch::tolerance_m) overrides it on that patch.
  double tolerance_m = 0.0;
  /// The fixed feeds where the file gives them (0 where the feed follows the program).
  double production_feed_m_per_s = 0.0;
  double reference_feed_m_per_s = 0.0;
  /// The production and reference feeds as the runs apply them.
  FeedSetting production_feed;
  FeedSetting reference_feed{0.0, 0.01};
  /// Values plausible but unusual (a feed of 500 m/min, a tool 2 m long), each naming the file,
  /// line and field; the program prints them as warnings.
  std::vector<std::string> warnings;
};

/// Reads a part file; throws vmsim::InputError naming the file, line, column, field and value:
/// for bad YAML, a key given twice, a second document, an unknown key (with the nearest known
/// one), a value of the wrong type, a number that is not finite and normal (or zero), and a
/// value no part has (a tool 10 m long, a feed of 10 km/min).
PartDescription load_part(const std::string& path);

}  // namespace vmsim::app
