#include "surface_views.hpp"

#include "view_deviation.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>

#include "vmsim/common/errors.hpp"
#include "vmsim/common/files.hpp"

namespace vmsim::app {
namespace {

// Wall lines start this far inside the material behind the design plane and reach as far out
// of it: marks are tens of um deep, a gouge deeper than this saturates at the line's origin.
constexpr double kDepthInside_m = 1e-3;
constexpr double kDepthOutside_m = 1e-3;
// A plane is a wall (gets its own view) when its normal is more than 45 deg from +z.
constexpr double kWallMaxNormalZ = 0.7071;

// The interval [lo, hi] of t over which point + t direction lies in the box (lo > hi: never).
void box_interval(const Eigen::Vector3d& point, const Eigen::Vector3d& direction, const removal::Box& box,
                  double& lo, double& hi) {
  lo = -std::numeric_limits<double>::infinity();
  hi = std::numeric_limits<double>::infinity();
  for (int axis = 0; axis < 3; ++axis) {
    if (std::abs(direction[axis]) <= 1e-15) {
      if (point[axis] < box.min_W_m[axis] || point[axis] > box.max_W_m[axis]) lo = hi + 1.0;
      continue;
    }
    const double a = (box.min_W_m[axis] - point[axis]) / direction[axis];
    const double b = (box.max_W_m[axis] - point[axis]) / direction[axis];
    lo = std::max(lo, std::min(a, b));
    hi = std::min(hi, std::max(a, b));
  }
}

// Largest t in [0, limit] for which point + t direction stays in the box (0 when the point is
// outside it).
double inside_box_length(const Eigen::Vector3d& point, const Eigen::Vector3d& direction,
                         const removal::Box& box, double limit) {
  double lo = 0.0, hi = 0.0;
  box_interval(point, direction, box, lo, hi);
  if (lo > 0.0 || hi < 0.0) return 0.0;
  return std::max(0.0, std::min(limit, hi));
}

// A value rounded to `digits` decimals, as text.
std::string rounded(double value, int digits) {
  const double scale = std::pow(10.0, digits);
  return format_double(std::round(value * scale) / scale);
}

std::string millimetres(const Eigen::Vector3d& v, double scale) {
  return "(" + rounded(v.x() * scale, 3) + ", " + rounded(v.y() * scale, 3) + ", " + rounded(v.z() * scale, 3) + ")";
}

constexpr double kDegreesPerRadian = 180.0 / std::numbers::pi;

SurfaceView wall_view(const DesignPlane& plane, const removal::Box& stock, double spacing_m,
                      int number) {
  SurfaceView view;
  view.id = "wall" + std::to_string(number);
  view.zmap = false;
  view.spacing_m = spacing_m;
  view.normal_W = plane.normal_W;
  view.u_W = Eigen::Vector3d::UnitZ().cross(plane.normal_W).normalized();  // horizontal
  view.v_W = plane.normal_W.cross(view.u_W);                               // up the wall
  view.depth_inside_m = kDepthInside_m;
  // The patch's bounds clipped to the stock, projected on (u, v).
  const Eigen::Vector3d lo = plane.min_W_m.cwiseMax(stock.min_W_m);
  const Eigen::Vector3d hi = plane.max_W_m.cwiseMin(stock.max_W_m);
  double a_min = std::numeric_limits<double>::infinity(), a_max = -a_min;
  double b_min = a_min, b_max = -a_min;
  for (int corner = 0; corner < 8; ++corner) {
    const Eigen::Vector3d p((corner & 1) ? hi.x() : lo.x(), (corner & 2) ? hi.y() : lo.y(),
                            (corner & 4) ? hi.z() : lo.z());
    const Eigen::Vector3d r = p - plane.point_W_m;
    a_min = std::min(a_min, r.dot(view.u_W));
    a_max = std::max(a_max, r.dot(view.u_W));
    b_min = std::min(b_min, r.dot(view.v_W));
    b_max = std::max(b_max, r.dot(view.v_W));
  }
  // Lines at the centres of the grid's cells, never on the box's faces: a line in the plane of a
  // stock face or of a floor is in the plane of a flat end's face there, and is cut whole or not
  // at all by a rounding of the tool's height.
  view.corner_W_m = plane.point_W_m + (a_min + 0.5 * spacing_m) * view.u_W + (b_min + 0.5 * spacing_m) * view.v_W;
  view.nu = static_cast<int>(std::floor((a_max - a_min) / spacing_m + 1e-9));
  view.nv = static_cast<int>(std::floor((b_max - b_min) / spacing_m + 1e-9));
  view.title = "wall " + std::to_string(number) + ": plane through " +
               millimetres(plane.point_W_m, 1e3) + " mm, normal " + millimetres(plane.normal_W, 1.0) +
               "; x: along " + millimetres(view.u_W, 1.0) + ", y: along " + millimetres(view.v_W, 1.0) +
               " [mm from " + millimetres(view.corner_W_m, 1e3) + "]";
  return view;
}

// The top of the stock at (x, y) from its uncut Z-map, bilinear between the four lines around;
// -inf outside the grid.
double stock_top_m(const removal::NBuffer& zmap, double x, double y) {
  const double s = zmap.spacing_m();
  const double fx = (x - zmap.zmap_origin_m().x()) / s, fy = (y - zmap.zmap_origin_m().y()) / s;
  const int i = static_cast<int>(std::floor(fx)), j = static_cast<int>(std::floor(fy));
  if (i < 0 || j < 0 || i + 1 >= zmap.nu() || j + 1 >= zmap.nv()) return -std::numeric_limits<double>::infinity();
  const double a = fx - i, b = fy - j;
  const double h = (1 - a) * (1 - b) * zmap.length(i, j) + a * (1 - b) * zmap.length(i + 1, j) +
                   (1 - a) * b * zmap.length(i, j + 1) + a * b * zmap.length(i + 1, j + 1);
  return zmap.zmap_origin_m().z() + h;
}

// Where a line leaves the stock described by its uncut Z-map, within [0, limit] (the stock is
// taken to be crossed once along the short line): bisection to well below a nanometre.
double inside_zmap_length(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                          const removal::NBuffer& zmap, double limit) {
  auto inside = [&](double t) {
    const Eigen::Vector3d p = origin + t * direction;
    return p.z() < stock_top_m(zmap, p.x(), p.y());
  };
  if (!inside(0.0)) return 0.0;
  if (inside(limit)) return limit;
  double lo = 0.0, hi = limit;
  for (int k = 0; k < 40; ++k) (inside(0.5 * (lo + hi)) ? lo : hi) = 0.5 * (lo + hi);
  return lo;
}

// What sphere and cylinder views share: no Z-map, lines along the normals from kDepthInside_m
// inside the material, at least the kind's minimum spacing apart.
SurfaceView curved_view(ViewShape shape, const std::string& id, double spacing_m, double radius_m,
                        bool material_inside) {
  SurfaceView view;
  view.zmap = false;
  view.shape = shape;
  view.id = id;
  view.spacing_m = std::max(spacing_m, shape == ViewShape::sphere ? kSphereViewMinSpacing_m : kCylinderViewMinSpacing_m);
  view.radius_m = radius_m;
  view.outward = material_inside ? 1.0 : -1.0;
  view.depth_inside_m = kDepthInside_m;
  return view;
}

SurfaceView sphere_view(const DesignSphere& sphere, const std::vector<Eigen::Vector3d>& tips,
                        double reach_m, double spacing_m, int number) {
  SurfaceView view = curved_view(ViewShape::sphere, "sphere" + std::to_string(number), spacing_m,
                                 sphere.radius_m, sphere.material_inside);
  view.centre_W_m = sphere.centre_W_m;
  double polar_min = std::numbers::pi, polar_max = 0.0;
  for (const Eigen::Vector3d& tip : tips) {
    const Eigen::Vector3d r = tip - sphere.centre_W_m;
    if (std::abs(r.norm() - sphere.radius_m) > reach_m || r.norm() < 1e-9) continue;
    const double polar = std::acos(std::clamp(r.z() / r.norm(), -1.0, 1.0));
    polar_min = std::min(polar_min, polar);
    polar_max = std::max(polar_max, polar);
  }
  if (polar_min > polar_max) return view;  // no cutting near this sphere: nu = nv = 0
  polar_min = std::max(0.0, polar_min - reach_m / sphere.radius_m);
  polar_max = std::min(std::numbers::pi, polar_max + reach_m / sphere.radius_m);
  // Spacing along the widest ring of the band; narrower rings have their lines closer.
  const double widest = sphere.radius_m * std::max({std::sin(polar_min), std::sin(polar_max),
                                                    polar_min < 0.5 * std::numbers::pi && polar_max > 0.5 * std::numbers::pi ? 1.0 : 0.0});
  view.nu = std::max(2, static_cast<int>(std::ceil(2.0 * std::numbers::pi * widest / view.spacing_m)));
  view.azimuth_step_rad = 2.0 * std::numbers::pi / view.nu;
  view.polar_step_rad = view.spacing_m / sphere.radius_m;
  view.polar_first_rad = polar_min;
  view.nv = static_cast<int>(std::floor((polar_max - polar_min) / view.polar_step_rad)) + 1;
  view.title = "sphere " + std::to_string(number) + ": centre " + millimetres(sphere.centre_W_m, 1e3) +
               " mm, radius " + format_double(sphere.radius_m * 1e3) + " mm, seen along its normals; x: azimuth (" +
               rounded(widest * view.azimuth_step_rad * 1e6, 3) + " um per line), y: polar angle from " +
               rounded(polar_min * kDegreesPerRadian, 2) + " deg (" + rounded(view.spacing_m * 1e6, 3) +
               " um per line) [mm of arc]";
  return view;
}

// Angle bins over a full turn in which a cylinder view's band of azimuths is found (0.1 deg:
// 26 um of arc on part 1's R15 fillet, well below the views' line spacing).
constexpr int kCylinderAzimuthBins = 3600;

SurfaceView cylinder_view(const DesignCylinder& cylinder, const removal::Box& stock,
                          const std::vector<Eigen::Vector3d>& tips, double reach_m, double spacing_m, int number) {
  SurfaceView view = curved_view(ViewShape::cylinder, "cylinder" + std::to_string(number), spacing_m,
                                 cylinder.radius_m, cylinder.material_inside);
  const double radius = cylinder.radius_m;
  view.centre_W_m = cylinder.axis_point_W_m;
  view.axis_W = cylinder.axis_W;
  // Azimuth 0 along the W axis most square to the cylinder's (x for a vertical or a y axis).
  Eigen::Index least = 0;
  cylinder.axis_W.cwiseAbs().minCoeff(&least);
  const Eigen::Vector3d e = Eigen::Vector3d::Unit(least);
  view.u_W = (e - e.dot(view.axis_W) * view.axis_W).normalized();
  view.v_W = view.axis_W.cross(view.u_W);
  removal::Box patch;  // the patch's bounds clipped to the stock
  patch.min_W_m = cylinder.min_W_m.cwiseMax(stock.min_W_m);
  patch.max_W_m = cylinder.max_W_m.cwiseMin(stock.max_W_m);
  if (!(patch.min_W_m.array() <= patch.max_W_m.array()).all()) return view;

  // Per bin (at its centre azimuth): the axial interval of the cylinder's line inside the patch.
  constexpr int bins = kCylinderAzimuthBins;
  const double bin_rad = 2.0 * std::numbers::pi / bins;
  const auto normal_at = [&](double azimuth) { return std::cos(azimuth) * view.u_W + std::sin(azimuth) * view.v_W; };
  std::vector<double> axial_lo(bins), axial_hi(bins);
  double patch_lo = std::numeric_limits<double>::infinity(), patch_hi = -patch_lo;
  for (int k = 0; k < bins; ++k) {
    box_interval(view.centre_W_m + radius * normal_at((k + 0.5) * bin_rad), view.axis_W, patch, axial_lo[k], axial_hi[k]);
    if (axial_lo[k] > axial_hi[k]) continue;
    patch_lo = std::min(patch_lo, axial_lo[k]);
    patch_hi = std::max(patch_hi, axial_hi[k]);
  }
  // The tips within reach: radially and along the axis from the patch.
  std::vector<int> tips_in_bin(bins, 0);
  double tips_lo = std::numeric_limits<double>::infinity(), tips_hi = -tips_lo;
  for (const Eigen::Vector3d& tip : tips) {
    const Eigen::Vector3d r = tip - view.centre_W_m;
    const double axial = r.dot(view.axis_W);
    const Eigen::Vector3d radial = r - axial * view.axis_W;
    if (std::abs(radial.norm() - radius) > reach_m || axial < patch_lo - reach_m || axial > patch_hi + reach_m) continue;
    double azimuth = std::atan2(radial.dot(view.v_W), radial.dot(view.u_W));
    if (azimuth < 0.0) azimuth += 2.0 * std::numbers::pi;
    ++tips_in_bin[std::min(bins - 1, static_cast<int>(azimuth / bin_rad))];
    tips_lo = std::min(tips_lo, axial - reach_m);
    tips_hi = std::max(tips_hi, axial + reach_m);
  }
  if (tips_lo > tips_hi) return view;  // no cutting near this cylinder: nu = nv = 0
  // A bin is in the view where the patch is and a tip is within reach_m of arc (a running sum
  // over the bins three times round: each bin sees its neighbours across azimuth 0).
  const int half = static_cast<int>(std::min<double>(bins, std::ceil(reach_m / radius / bin_rad)));
  std::vector<long> running(3 * bins + 1, 0);
  for (int k = 0; k < 3 * bins; ++k) running[k + 1] = running[k] + tips_in_bin[k % bins];
  std::vector<std::uint8_t> selected(bins, 0);
  int selected_count = 0;
  for (int k = 0; k < bins; ++k) {
    const int lo = std::max(0, bins + k - half), hi = std::min(3 * bins - 1, bins + k + half);
    const bool near = running[hi + 1] - running[lo] > 0;
    selected[k] = near && std::max(axial_lo[k], tips_lo) <= std::min(axial_hi[k], tips_hi);
    selected_count += selected[k];
  }
  if (selected_count == 0) return view;
  // The band: all round, or from the end of the longest run of bins not in the view to its start.
  int gap_length = 0, gap_end = 0;  // gap_end: the first selected bin after the longest gap
  if (selected_count < bins) {
    for (int k = 0, run = 0; k < 2 * bins; ++k) {
      run = selected[k % bins] ? 0 : run + 1;
      if (run > gap_length) {
        gap_length = run;
        gap_end = (k + 1) % bins;
      }
    }
  }
  const bool all_round = gap_length == 0;
  double axial_first = std::numeric_limits<double>::infinity(), axial_last = -axial_first;
  for (int k = 0; k < bins; ++k) {
    if (!selected[k]) continue;
    axial_first = std::min(axial_first, std::max(axial_lo[k], tips_lo));
    axial_last = std::max(axial_last, std::min(axial_hi[k], tips_hi));
  }
  if (all_round) {
    view.nu = std::max(2, static_cast<int>(std::ceil(2.0 * std::numbers::pi * radius / view.spacing_m)));
    view.azimuth_step_rad = 2.0 * std::numbers::pi / view.nu;
    view.azimuth_first_rad = 0.0;
  } else {
    // From the centre of the first bin in the view to the centre of the last one.
    const double band_rad = (bins - gap_length - 1) * bin_rad;
    view.azimuth_step_rad = view.spacing_m / radius;
    view.azimuth_first_rad = (gap_end + 0.5) * bin_rad;
    view.nu = static_cast<int>(std::floor(band_rad / view.azimuth_step_rad + 1e-9)) + 1;
  }
  // Rows at the centres of the axial cells, never at the ends of the patch (the floor's height:
  // a line there lies in the plane of a flat end's face, see wall_view).
  view.axial_first_m = axial_first + 0.5 * view.spacing_m;
  view.nv = static_cast<int>(std::floor((axial_last - axial_first) / view.spacing_m + 1e-9));
  view.title = "cylinder " + std::to_string(number) + ": axis through " + millimetres(cylinder.axis_point_W_m, 1e3) +
               " mm along " + millimetres(view.axis_W, 1.0) + ", radius " + format_double(radius * 1e3) +
               " mm, seen along its normals; x: azimuth from " + rounded(view.azimuth_first_rad * kDegreesPerRadian, 2) +
               " deg about the axis, from " + millimetres(view.u_W, 1.0) + " towards " + millimetres(view.v_W, 1.0) +
               (all_round ? ", all round" : "") + " (" + rounded(radius * view.azimuth_step_rad * 1e6, 3) +
               " um per line), y: along the axis from " + rounded(axial_first * 1e3, 3) + " mm (" +
               rounded(view.spacing_m * 1e6, 3) + " um per line) [mm of arc]";
  return view;
}

}  // namespace

void SurfaceView::line(int iu, int iv, Eigen::Vector3d& origin_W_m, Eigen::Vector3d& direction_W) const {
  if (shape == ViewShape::sphere || shape == ViewShape::cylinder) {
    const double azimuth = azimuth_first_rad + iu * azimuth_step_rad;
    const Eigen::Vector3d radial = std::cos(azimuth) * u_W + std::sin(azimuth) * v_W;
    Eigen::Vector3d normal, foot_W_m;  // the unit normal away from the centre or axis, its foot
    if (shape == ViewShape::sphere) {
      const double polar = polar_first_rad + iv * polar_step_rad;
      normal = std::sin(polar) * radial + std::cos(polar) * axis_W;
      foot_W_m = centre_W_m + radius_m * normal;
    } else {
      normal = radial;
      foot_W_m = centre_W_m + (axial_first_m + iv * spacing_m) * axis_W + radius_m * normal;
    }
    direction_W = outward * normal;
    origin_W_m = foot_W_m - depth_inside_m * direction_W;
    return;
  }
  direction_W = normal_W;
  origin_W_m = corner_W_m + (iu * spacing_m) * u_W + (iv * spacing_m) * v_W - depth_inside_m * normal_W;
}

removal::NBuffer SurfaceView::fresh_buffer(const StockShape& stock, removal::MeshZmapReport* mesh_report,
                                           const removal::NBuffer* stock_zmap) const {
  if (zmap) {
    return stock.mesh ? removal::NBuffer::zmap(*stock.mesh, spacing_m, mesh_report)
                      : removal::NBuffer::zmap(stock.bounds, spacing_m);
  }
  const auto count = static_cast<std::size_t>(nu) * static_cast<std::size_t>(nv);
  std::vector<Eigen::Vector3d> origins(count), directions(count);
  std::vector<double> lengths(count);
  for (int j = 0; j < nv; ++j) {
    for (int i = 0; i < nu; ++i) {
      const std::size_t k = static_cast<std::size_t>(i) + static_cast<std::size_t>(nu) * static_cast<std::size_t>(j);
      line(i, j, origins[k], directions[k]);
      lengths[k] = inside_box_length(origins[k], directions[k], stock.bounds, depth_inside_m + kDepthOutside_m);
      if (stock.mesh && stock_zmap) lengths[k] = inside_zmap_length(origins[k], directions[k], *stock_zmap, lengths[k]);
    }
  }
  return removal::NBuffer::lines(nu, nv, std::move(origins), std::move(directions), std::move(lengths));
}

double SurfaceView::surface_offset_m(const removal::NBuffer& buffer, int iu, int iv) const {
  if (zmap) return buffer.zmap_origin_m().z() + buffer.length(iu, iv);
  return buffer.length(iu, iv) - depth_inside_m;
}

std::vector<SurfaceView> surface_views(const PartDescription& part, const removal::Box& stock,
                                       double spacing_m, const std::vector<Eigen::Vector3d>& cutting_tips_W_m,
                                       double reach_m) {
  std::vector<SurfaceView> views(1);
  views[0].id = "zmap";
  views[0].title = "Z-map (seen from +z)";
  views[0].zmap = true;
  views[0].spacing_m = spacing_m;
  int walls = 0;
  for (const DesignPlane& plane : part.design_planes) {
    if (std::abs(plane.normal_W.z()) > kWallMaxNormalZ) continue;
    SurfaceView view = wall_view(plane, stock, spacing_m, ++walls);
    view.design_patch = static_cast<int>(plane.patch_index);
    if (view.nu >= 2 && view.nv >= 2) views.push_back(std::move(view));
  }
  // Sphere and cylinder views, numbered among their kind in the order of the file.
  const auto add_curved = [&views](const auto& patches, const auto& make_view) {
    int number = 0;
    for (const auto& patch : patches) {
      SurfaceView view = make_view(patch, number + 1);
      view.design_patch = static_cast<int>(patch.patch_index);
      if (view.nu < 2 || view.nv < 2) continue;
      ++number;
      views.push_back(std::move(view));
    }
  };
  add_curved(part.design_spheres, [&](const DesignSphere& sphere, int number) {
    return sphere_view(sphere, cutting_tips_W_m, reach_m, spacing_m, number);
  });
  add_curved(part.design_cylinders, [&](const DesignCylinder& cylinder, int number) {
    return cylinder_view(cylinder, stock, cutting_tips_W_m, reach_m, spacing_m, number);
  });
  return views;
}

std::optional<std::size_t> design_patch_of_mark(const PartDescription& part, const SurfaceView& view,
                                                const Eigen::Vector3d& point_W_m, double margin_m,
                                                double part_tolerance_m) {
  if (view.design_patch >= 0) return static_cast<std::size_t>(view.design_patch);
  std::optional<std::size_t> tightest;
  double tightest_m = std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k < part.design_patches.size(); ++k) {
    const DesignPatch& patch = part.design_patches[k];
    if (((point_W_m.array() < patch.min_W_m.array() - margin_m) ||
         (point_W_m.array() > patch.max_W_m.array() + margin_m)).any()) {
      continue;
    }
    const double tolerance_m = patch.tolerance_m > 0.0 ? patch.tolerance_m : part_tolerance_m;
    const double key_m = tolerance_m > 0.0 ? tolerance_m : std::numeric_limits<double>::max();
    if (!tightest || key_m < tightest_m) {
      tightest = k;
      tightest_m = key_m;
    }
  }
  return tightest;
}

std::size_t exclude_steep_lines(const removal::NBuffer& reference, double spacing_m,
                                std::vector<double>& deviation_m) {
  const int nu = reference.nu(), nv = reference.nv();
  const double step_limit = kSteepStepPerSpacing * spacing_m;
  std::vector<std::uint8_t> steep(reference.line_count(), 0);
  auto index = [nu](int i, int j) { return static_cast<std::size_t>(i) + static_cast<std::size_t>(nu) * static_cast<std::size_t>(j); };
  for (int j = 0; j < nv; ++j) {
    for (int i = 0; i < nu; ++i) {
      const double h = reference.length(i, j);
      if (i + 1 < nu && std::abs(reference.length(i + 1, j) - h) > step_limit) {
        steep[index(i, j)] = steep[index(i + 1, j)] = 1;
      }
      if (j + 1 < nv && std::abs(reference.length(i, j + 1) - h) > step_limit) {
        steep[index(i, j)] = steep[index(i, j + 1)] = 1;
      }
    }
  }
  std::size_t excluded = 0;
  for (std::size_t k = 0; k < steep.size(); ++k) {
    if (!steep[k]) continue;
    deviation_m[k] = 0.0;
    ++excluded;
  }
  return excluded;
}

viz::HeightField view_height_field(const SurfaceView& view, const removal::NBuffer& buffer,
                                   const ViewDeviation* deviation, int stride) {
  viz::HeightField field;
  if (view.zmap) {
    field.origin_x_m = buffer.zmap_origin_m().x();
    field.origin_y_m = buffer.zmap_origin_m().y();
  }
  field.spacing_x_m = field.spacing_y_m = view.spacing_m * stride;
  field.nx = (buffer.nu() - 1) / stride + 1;
  field.ny = (buffer.nv() - 1) / stride + 1;
  for (int j = 0; j < field.ny; ++j) {
    for (int i = 0; i < field.nx; ++i) {
      field.height_m.push_back(view.surface_offset_m(buffer, i * stride, j * stride));
      if (deviation) field.deviation_m.push_back(deviation->at(i * stride, j * stride));
    }
  }
  return field;
}

viz::HeightField view_height_field_window(const SurfaceView& view, const removal::NBuffer& buffer,
                                          const ViewDeviation& deviation, const LineWindow& window, int stride) {
  viz::HeightField field;
  const double origin_x_m = view.zmap ? buffer.zmap_origin_m().x() : 0.0;
  const double origin_y_m = view.zmap ? buffer.zmap_origin_m().y() : 0.0;
  field.origin_x_m = origin_x_m + window.iu_first * view.spacing_m;
  field.origin_y_m = origin_y_m + window.iv_first * view.spacing_m;
  field.spacing_x_m = field.spacing_y_m = view.spacing_m * stride;
  field.nx = (window.iu_last - window.iu_first) / stride + 1;
  field.ny = (window.iv_last - window.iv_first) / stride + 1;
  for (int j = window.iv_first; j <= window.iv_last; j += stride) {
    for (int i = window.iu_first; i <= window.iu_last; i += stride) {
      field.height_m.push_back(view.surface_offset_m(buffer, i, j));
      field.deviation_m.push_back(deviation.at(i, j));
    }
  }
  return field;
}

int close_up_stride(const LineWindow& window, double max_nodes) {
  const double nodes = static_cast<double>(window.iu_last - window.iu_first + 1) *
                       static_cast<double>(window.iv_last - window.iv_first + 1);
  return std::max(1, static_cast<int>(std::ceil(std::sqrt(nodes / max_nodes))));
}

LineWindow mark_close_up_window(int iu_min, int iu_max, int iv_min, int iv_max, int nu, int nv,
                                double spacing_m, double margin_m) {
  if (!(spacing_m > 0.0) || iu_min < 0 || iv_min < 0 || iu_min > iu_max || iv_min > iv_max || iu_max >= nu ||
      iv_max >= nv) {
    throw InputError("mark close-up: lines [" + std::to_string(iu_min) + ", " + std::to_string(iu_max) + "] x [" +
                     std::to_string(iv_min) + ", " + std::to_string(iv_max) + "] outside the grid of " +
                     std::to_string(nu) + " x " + std::to_string(nv) + " lines or spacing " +
                     format_double(spacing_m) + " m");
  }
  const int margin = static_cast<int>(std::max(0.0, margin_m) / spacing_m);
  return {std::max(0, iu_min - margin), std::min(nu - 1, iu_max + margin), std::max(0, iv_min - margin),
          std::min(nv - 1, iv_max + margin)};
}

}  // namespace vmsim::app
