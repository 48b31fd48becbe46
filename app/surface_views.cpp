#include "surface_views.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <sstream>

#include "vmsim/common/files.hpp"

namespace vmsim::app {
namespace {

// Wall lines start this far inside the material behind the design plane and reach as far out
// of it: marks are tens of um deep, a gouge deeper than this saturates at the line's origin.
constexpr double kDepthInside_m = 1e-3;
constexpr double kDepthOutside_m = 1e-3;
// A plane is a wall (gets its own view) when its normal is more than 45 deg from +z.
constexpr double kWallMaxNormalZ = 0.7071;

// Largest t in [0, limit] for which point + t direction stays in the box (0 when the point is
// outside it).
double inside_box_length(const Eigen::Vector3d& point, const Eigen::Vector3d& direction,
                         const removal::Box& box, double limit) {
  for (int axis = 0; axis < 3; ++axis) {
    if (point[axis] < box.min_W_m[axis] || point[axis] > box.max_W_m[axis]) return 0.0;
    if (direction[axis] > 1e-15) {
      limit = std::min(limit, (box.max_W_m[axis] - point[axis]) / direction[axis]);
    } else if (direction[axis] < -1e-15) {
      limit = std::min(limit, (box.min_W_m[axis] - point[axis]) / direction[axis]);
    }
  }
  return std::max(0.0, limit);
}

std::string millimetres(const Eigen::Vector3d& v, double scale) {
  std::ostringstream out;
  out << "(" << format_double(std::round(v.x() * scale * 1e3) / 1e3) << ", "
      << format_double(std::round(v.y() * scale * 1e3) / 1e3) << ", "
      << format_double(std::round(v.z() * scale * 1e3) / 1e3) << ")";
  return out.str();
}

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
  view.corner_W_m = plane.point_W_m + a_min * view.u_W + b_min * view.v_W;
  view.nu = static_cast<int>(std::floor((a_max - a_min) / spacing_m + 1e-9)) + 1;
  view.nv = static_cast<int>(std::floor((b_max - b_min) / spacing_m + 1e-9)) + 1;
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

SurfaceView sphere_view(const DesignSphere& sphere, const std::vector<Eigen::Vector3d>& tips,
                        double reach_m, double spacing_m, int number) {
  SurfaceView view;
  view.zmap = false;
  view.sphere = true;
  view.id = "sphere" + std::to_string(number);
  view.spacing_m = std::max(spacing_m, kSphereViewMinSpacing_m);
  view.centre_W_m = sphere.centre_W_m;
  view.radius_m = sphere.radius_m;
  view.outward = sphere.material_inside ? 1.0 : -1.0;
  view.depth_inside_m = kDepthInside_m;
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
               format_double(std::round(widest * view.azimuth_step_rad * 1e9) / 1e3) + " um per line), y: polar angle from " +
               format_double(std::round(polar_min * 180.0 / std::numbers::pi * 100) / 100) + " deg (" +
               format_double(std::round(view.spacing_m * 1e9) / 1e3) + " um per line) [mm of arc]";
  return view;
}

}  // namespace

void SurfaceView::line(int iu, int iv, Eigen::Vector3d& origin_W_m, Eigen::Vector3d& direction_W) const {
  if (sphere) {
    const double azimuth = iu * azimuth_step_rad, polar = polar_first_rad + iv * polar_step_rad;
    const Eigen::Vector3d n(std::sin(polar) * std::cos(azimuth), std::sin(polar) * std::sin(azimuth), std::cos(polar));
    direction_W = outward * n;
    origin_W_m = centre_W_m + radius_m * n - depth_inside_m * direction_W;
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
    if (view.nu >= 2 && view.nv >= 2) views.push_back(std::move(view));
  }
  int spheres = 0;
  for (const DesignSphere& sphere : part.design_spheres) {
    SurfaceView view = sphere_view(sphere, cutting_tips_W_m, reach_m, spacing_m, spheres + 1);
    if (view.nu >= 2 && view.nv >= 2) {
      ++spheres;
      views.push_back(std::move(view));
    }
  }
  return views;
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
                                   const std::vector<double>* deviation_m, int stride) {
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
      if (deviation_m) {
        field.deviation_m.push_back(
            (*deviation_m)[static_cast<std::size_t>(i * stride) +
                           static_cast<std::size_t>(buffer.nu()) * static_cast<std::size_t>(j * stride)]);
      }
    }
  }
  return field;
}

}  // namespace vmsim::app
