#pragma once
// Where simulate-part looks at the machined surface: one N-buffer per "view".
//  - Each design sphere the tool path works on gets a buffer of lines along its normals over
//    the band of polar angles the path covers (a dome's slopes are seen head-on, not through a
//    Z-map's 1 / cos(slope)).
//  - Each design cylinder the tool path works on gets a buffer of lines along its normals
//    (square to the axis) over the band of angles about the axis and the axial range that both
//    the path comes near and the patch covers (a flank-milled boss or bore, a fillet).
//  - The Z-map (lines along +z over the stock box) sees every face that looks up.
//  - Each steep plane of the design surface (a wall: normal more than 45 deg from +z) gets its
//    own buffer of lines along its normal, on a grid over the patch, so that a wall's deviation
//    is measured along the wall's normal at the same accuracy as a floor's. A Z-map cannot do it:
//    a wall moved by 30 um sideways moves the Z-map's step between two lines, which reads as a
//    deviation of the wall's whole height.
// On every view, lines where the reference surface is steep for that view (the height changes by
// more than kSteepStepPerSpacing line spacings between neighbours) are not assessed: along such a
// line the deviation is amplified by 1 / cos(slope) and a sideways shift reads as a depth.
#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "part_file.hpp"
#include "vmsim/removal/nbuffer.hpp"
#include "vmsim/removal/stl.hpp"
#include "vmsim/viz/surface.hpp"

namespace vmsim::app {

class ViewDeviation;  // view_deviation.hpp

/// Neighbouring lines whose reference lengths differ by more than this many line spacings
/// (a slope above 71.6 deg for the view) are not assessed.
inline constexpr double kSteepStepPerSpacing = 3.0;

/// What every view starts from: the stock box, or a closed mesh (a near-net stock) and its bounds.
struct StockShape {
  removal::Box bounds;
  const removal::TriangleMesh* mesh = nullptr;  ///< null: the box `bounds` is the stock
};

/// The design surface whose normals a view's lines follow (the Z-map's follow +z).
enum class ViewShape { plane, sphere, cylinder };

struct SurfaceView {
  std::string id;     ///< "zmap", "wall1", "sphere1", "cylinder1", ...: file names
  std::string title;  ///< for reports and renders
  bool zmap = true;
  /// The design patch whose normals the lines follow (PartDescription::design_patches); -1 for
  /// the Z-map, which sees every patch that looks up.
  int design_patch = -1;
  ViewShape shape = ViewShape::plane;  ///< when not the Z-map
  double spacing_m = 0.0;
  // Wall views: line (i, j) starts at corner + i s u + j s v - depth_inside n (inside the
  // material, s = spacing) and runs along n (out of the material).
  Eigen::Vector3d corner_W_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d u_W = Eigen::Vector3d::UnitX(), v_W = Eigen::Vector3d::UnitY();
  Eigen::Vector3d normal_W = Eigen::Vector3d::UnitZ();
  double depth_inside_m = 0.0;
  int nu = 0, nv = 0;
  // Sphere and cylinder views: line (i, j) runs along the surface's normal, from depth_inside_m
  // inside the material (out of it: away from the centre or axis for a dome or a boss, towards
  // it for a pocket, a bore or a fillet). The normal at azimuth a = azimuth_first +
  // i * azimuth_step about axis_W, from u_W towards v_W (u_W, v_W, axis_W right-handed):
  //  - sphere (axis_W = +z, u_W = +x): at polar angle polar_first + j * polar_step from the axis;
  //  - cylinder: square to the axis, at axial position axial_first + j * spacing along axis_W
  //    from centre_W_m (a point of the axis).
  Eigen::Vector3d centre_W_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d axis_W = Eigen::Vector3d::UnitZ();
  double radius_m = 0.0;
  double outward = 1.0;  ///< +1: material inside the sphere or cylinder (a dome, a boss), -1: outside
  double azimuth_first_rad = 0.0, azimuth_step_rad = 0.0;
  double polar_first_rad = 0.0, polar_step_rad = 0.0;  ///< sphere views
  double axial_first_m = 0.0;                          ///< cylinder views

  /// Line (i, j): origin (inside the material) and unit direction (out of it) [m, W].
  void line(int iu, int iv, Eigen::Vector3d& origin_W_m, Eigen::Vector3d& direction_W) const;

  /// The uncut buffer of this view over `stock`: the same lines on every call. Z-map over a
  /// mesh: each line from the bounds' bottom to the mesh's highest exit
  /// (removal::NBuffer::zmap(mesh, ...)). Wall and sphere views: lines from 1 mm inside the
  /// design surface to 1 mm out, clipped to the stock's bounds and, for a mesh, to the top of
  /// `stock_zmap` (the uncut Z-map over the mesh, interpolated bilinearly; without it, the
  /// bounds only).
  /// `mesh_report` (optional) receives how the mesh became Z-map lines.
  removal::NBuffer fresh_buffer(const StockShape& stock, removal::MeshZmapReport* mesh_report = nullptr,
                                const removal::NBuffer* stock_zmap = nullptr) const;
  /// Distance of line (iu, iv)'s surface point out of the design surface along its normal [m]
  /// (wall, sphere and cylinder views), or the height in W (Z-map).
  double surface_offset_m(const removal::NBuffer& buffer, int iu, int iv) const;
};

/// Line spacing of sphere views: at least this (a general buffer tests every line of the tiles
/// a sweep meets; the Z-map's 20 um would make part 3's sphere view 25 times slower).
inline constexpr double kSphereViewMinSpacing_m = 50e-6;

/// Line spacing of cylinder views: at least this. A flank or a fillet is cut over its whole
/// band by every pass, and a general buffer tests each line of every 16 x 16 tile whose box
/// meets the sweep's box (the tool's footprint, several mm): the work grows as
/// 1 / spacing^2 (sample part 1's fillet at 50 um: 99 million line tests in the production
/// run, 2.5 times the whole Z-map's removal time; at 200 um, 11 million). Heights along a line
/// stay exact; the spacing decides only where the surface is sampled.
inline constexpr double kCylinderViewMinSpacing_m = 200e-6;

/// The Z-map, then one view per steep design plane of the part (in the order of the file), then
/// one per design sphere that `cutting_tips_W_m` (the commanded tool tips of the cutting moves)
/// come within `reach_m` of, over the band of polar angles they span widened by reach_m, then
/// one per design cylinder the tips come within reach_m of (radially, and along the axis within
/// reach_m of the patch): over the angles about the axis that the patch covers (within its
/// ranges and the stock) and that are within reach_m of a tip (arc length on the cylinder), and
/// over the patch's axial extent at those angles clipped to the tips' axial span widened by
/// reach_m. A band all round the axis closes on itself between its last line and its first
/// (the buffer does not wrap: a mark across that seam counts as two).
std::vector<SurfaceView> surface_views(const PartDescription& part, const removal::Box& stock,
                                       double spacing_m,
                                       const std::vector<Eigen::Vector3d>& cutting_tips_W_m = {},
                                       double reach_m = 0.0);

/// The design patch (index into part.design_patches) a mark whose deepest point is `point_W_m`
/// lies on, for its tolerance: the view's own patch (walls, spheres, cylinders); on the Z-map,
/// of the patches whose ranges widened by `margin_m` hold the point, the one with the tightest
/// tolerance (a patch without its own has `part_tolerance_m`; 0 = none, the loosest), since a
/// mark at the border of two patches must satisfy both. nullopt: on no patch (no ranges hold it).
std::optional<std::size_t> design_patch_of_mark(const PartDescription& part, const SurfaceView& view,
                                                const Eigen::Vector3d& point_W_m, double margin_m,
                                                double part_tolerance_m);

/// Sets the deviation of the lines where `reference` is steep (see above) to 0; returns how
/// many lines that excluded. (simulate-part evaluates the same test per line: ViewDeviation,
/// view_deviation.hpp; this whole-view form is its tests' reference.)
std::size_t exclude_steep_lines(const removal::NBuffer& reference, double spacing_m,
                                std::vector<double>& deviation_m);

/// The view's surface as a height field for renders and .vtp files, every `stride`-th line:
/// (x, y) are W's for the Z-map and otherwise (i, j) times the view's spacing (the (u, v)
/// coordinates of a wall's grid; on a sphere or cylinder, about the arc length on the surface);
/// the height is SurfaceView::surface_offset_m; the deviation (optional) ViewDeviation::at.
viz::HeightField view_height_field(const SurfaceView& view, const removal::NBuffer& buffer,
                                   const ViewDeviation* deviation, int stride);

/// Inclusive range of a view's lines [iu_first, iu_last] x [iv_first, iv_last].
struct LineWindow {
  int iu_first = 0, iu_last = 0, iv_first = 0, iv_last = 0;
};

/// The nodes of view_height_field(view, buffer, deviation, 1) within `window`, every
/// `stride`-th line in each direction from the window's corner, which is the origin (a mark's
/// close-up, without the whole view's field).
viz::HeightField view_height_field_window(const SurfaceView& view, const removal::NBuffer& buffer,
                                          const ViewDeviation& deviation, const LineWindow& window,
                                          int stride = 1);

/// The stride that keeps a close-up of `window` at most `max_nodes` nodes (1 when it fits: a
/// mark along a whole die is drawn from every few lines, not from hundreds of millions).
int close_up_stride(const LineWindow& window, double max_nodes);

/// The lines a close-up of a mark shows: the mark's bounding box of lines [iu_min, iu_max] x
/// [iv_min, iv_max] widened on every side by `margin_m` (whole lines at `spacing_m`, rounded
/// down), clipped to the grid of nu x nv lines. The window holds the whole box whatever its size
/// (a long mark is not cut to a fixed window), and its sides keep the box's proportions plus the
/// margin (the render keeps x and y at one scale). Throws vmsim::InputError on a box outside
/// the grid or a spacing <= 0.
LineWindow mark_close_up_window(int iu_min, int iu_max, int iv_min, int iv_max, int nu, int nv,
                                double spacing_m, double margin_m);

}  // namespace vmsim::app
