#pragma once
// Where simulate-part looks at the machined surface: one N-buffer per "view".
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
#include <string>
#include <vector>

#include "part_file.hpp"
#include "vmsim/removal/nbuffer.hpp"
#include "vmsim/viz/surface.hpp"

namespace vmsim::app {

/// Neighbouring lines whose reference lengths differ by more than this many line spacings
/// (a slope above 71.6 deg for the view) are not assessed.
inline constexpr double kSteepStepPerSpacing = 3.0;

struct SurfaceView {
  std::string id;     ///< "zmap", "wall1", ...: file names
  std::string title;  ///< for reports and renders
  bool zmap = true;
  double spacing_m = 0.0;
  // Wall views: line (i, j) starts at corner + i s u + j s v - depth_inside n (inside the
  // material, s = spacing) and runs along n (out of the material).
  Eigen::Vector3d corner_W_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d u_W = Eigen::Vector3d::UnitX(), v_W = Eigen::Vector3d::UnitY();
  Eigen::Vector3d normal_W = Eigen::Vector3d::UnitZ();
  double depth_inside_m = 0.0;
  int nu = 0, nv = 0;

  /// The uncut buffer of this view over `stock`.
  removal::NBuffer fresh_buffer(const removal::Box& stock) const;
  /// Distance of line (iu, iv)'s surface point above the design plane [m] (wall views), or
  /// the height in W (Z-map).
  double surface_offset_m(const removal::NBuffer& buffer, int iu, int iv) const;
};

/// The Z-map, then one view per steep design plane of the part (in the order of the file).
std::vector<SurfaceView> surface_views(const PartDescription& part, const removal::Box& stock,
                                       double spacing_m);

/// Sets the deviation of the lines where `reference` is steep (see above) to 0; returns how
/// many lines that excluded.
std::size_t exclude_steep_lines(const removal::NBuffer& reference, double spacing_m,
                                std::vector<double>& deviation_m);

/// The view's surface as a height field for renders and .vtp files, every `stride`-th line:
/// (x, y) are W's for the Z-map and the (u, v) coordinates of the wall's grid otherwise; the
/// height is SurfaceView::surface_offset_m.
viz::HeightField view_height_field(const SurfaceView& view, const removal::NBuffer& buffer,
                                   const std::vector<double>* deviation_m, int stride);

}  // namespace vmsim::app
