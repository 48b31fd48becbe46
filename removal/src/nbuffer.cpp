#include "vmsim/removal/nbuffer.hpp"

#include <Eigen/Geometry>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <stdexcept>
#include <string>

#include "sweep.hpp"
#include "vmsim/removal/stl.hpp"
#include "vmsim/common/errors.hpp"
#include "vmsim/common/files.hpp"

namespace vmsim::removal {

using detail::Sweep;

void Tool::validate() const {
  auto bad = [](const std::string& field, double value, const std::string& why) {
    throw InputError("tool: " + field + " = " + format_double(value * 1e3) + " mm: " + why);
  };
  if (!std::isfinite(diameter_m) || diameter_m <= 0.0) bad("diameter", diameter_m, "must be > 0");
  if (type == ToolType::bull &&
      (!std::isfinite(corner_radius_m) || corner_radius_m <= 0.0 || corner_radius_m >= 0.5 * diameter_m)) {
    bad("corner radius", corner_radius_m, "a bull-nose mill needs 0 < r < D/2");
  }
  if (!std::isfinite(length_m) || length_m < diameter_m) {
    bad("length", length_m, "must be at least the diameter");
  }
  if (!conical()) return;
  auto bad_angle = [](const std::string& field, double value_rad, const std::string& why) {
    throw InputError("tool: " + field + " = " + format_double(value_rad * 180.0 / M_PI) + " deg: " + why);
  };
  if (type == ToolType::v) {
    if (!std::isfinite(tip_angle_rad) || tip_angle_rad <= 0.0 || tip_angle_rad >= M_PI) {
      bad_angle("tip angle", tip_angle_rad, "a V tool needs 0 < angle < 180 deg");
    }
    if (!std::isfinite(tip_diameter_m) || tip_diameter_m < 0.0 || tip_diameter_m >= diameter_m) {
      bad("tip diameter", tip_diameter_m, "a V tool needs 0 <= tip diameter < diameter");
    }
    return;
  }
  if (!std::isfinite(taper_angle_rad) || taper_angle_rad < 0.0 || taper_angle_rad >= M_PI / 4.0) {
    bad_angle("taper angle", taper_angle_rad, "a tapered tool needs 0 <= angle < 45 deg");
  }
  const bool ball_tip = type == ToolType::tapered_ball;
  if (!std::isfinite(tip_diameter_m) || tip_diameter_m <= 0.0 || tip_diameter_m > diameter_m ||
      (!ball_tip && tip_diameter_m == diameter_m)) {
    bad("tip diameter", tip_diameter_m,
        ball_tip ? "a tapered ball-end needs 0 < tip (ball) diameter <= diameter"
                 : "a tapered flat-end needs 0 < tip diameter < diameter");
  }
}

double Tool::corner_radius() const {
  switch (type) {
    case ToolType::ball: return 0.5 * diameter_m;
    case ToolType::flat: return 0.0;
    case ToolType::bull: return corner_radius_m;
    case ToolType::tapered_ball: return 0.5 * tip_diameter_m;
    case ToolType::v:
    case ToolType::tapered_flat: return 0.0;
  }
  return 0.0;
}

NBuffer NBuffer::zmap(const Box& stock, double spacing_m) {
  NBuffer b = zmap_grid(stock, spacing_m);
  b.h_.assign(static_cast<std::size_t>(b.tiles_u_) * b.tiles_v_ * kTile * kTile, stock.max_W_m.z() - stock.min_W_m.z());
  b.build_tiles();
  return b;
}

NBuffer NBuffer::compact_zmap(const Box& stock, double spacing_m) {
  NBuffer b = zmap_grid(stock, spacing_m);
  const double height = stock.max_W_m.z() - stock.min_W_m.z();
  b.compact_ = true;
  b.tiles_.assign(static_cast<std::size_t>(b.tiles_u_) * b.tiles_v_, TileBounds{});
  b.band_tile_begin_ = 0, b.band_tile_end_ = b.tiles_.size();
  b.base_.assign(b.tiles_.size(), height);  // every line of a tile at its base: no offsets
  b.offsets_.reset(b.tiles_.size());
  double h[kTile * kTile];
  std::fill_n(h, kTile * kTile, height);
  for (std::size_t t = 0; t < b.tiles_.size(); ++t) b.refresh_tile(t, h);
  return b;
}

NBuffer NBuffer::zmap_grid(const Box& stock, double spacing_m) {
  const Eigen::Vector3d size = stock.max_W_m - stock.min_W_m;
  if (!(size.minCoeff() > 0.0) || !size.allFinite()) {
    throw InputError("stock box: min must be below max on every axis");
  }
  if (!(spacing_m > 0.0) || !std::isfinite(spacing_m)) {
    throw InputError("grid spacing " + format_double(spacing_m * 1e3) + " mm: must be > 0");
  }
  const double nx = std::floor(size.x() / spacing_m * (1.0 + 1e-12)) + 1.0;
  const double ny = std::floor(size.y() / spacing_m * (1.0 + 1e-12)) + 1.0;
  constexpr double kMaxLines = 2147483647.0;  // line indices are int
  if (nx * ny > kMaxLines) {
    // The finest spacing that fits: (x / s + 1)(y / s + 1) = kMaxLines, rounded up to 0.1 um.
    const double sum = size.x() + size.y(), product = size.x() * size.y();
    const double finest_m = (sum + std::sqrt(sum * sum + 4.0 * kMaxLines * product)) / (2.0 * kMaxLines);
    const auto micrometres = [](double m) { return format_double(std::ceil(m * 1e7 - 1e-6) / 10.0); };
    throw InputError("grid spacing " + micrometres(spacing_m) + " um gives " + format_double(nx * ny) +
                     " lines over the " + format_double(size.x() * 1e3) + " x " + format_double(size.y() * 1e3) +
                     " mm stock: more than the 2147483647 a surface view holds; a spacing of " +
                     micrometres(finest_m) + " um or more fits");
  }
  NBuffer b;
  b.zmap_ = true;
  b.nu_ = static_cast<int>(nx);
  b.nv_ = static_cast<int>(ny);
  b.spacing_ = spacing_m;
  b.origin0_ = stock.min_W_m;
  b.tiles_u_ = (b.nu_ + kTile - 1) / kTile;
  b.tiles_v_ = (b.nv_ + kTile - 1) / kTile;
  return b;
}

NBuffer NBuffer::zmap(const TriangleMesh& stock, double spacing_m, MeshZmapReport* report) {
  if (stock.triangles.empty()) throw InputError("stock mesh: no triangle");
  const Box bounds = stock.bounds();
  NBuffer b = zmap(bounds, spacing_m);
  const std::vector<VerticalCrossing> crossings =
      vertical_crossings(stock, b.origin0_.x(), b.origin0_.y(), spacing_m, b.nu_, b.nv_);
  MeshZmapReport counts;
  for (int iv = 0; iv < b.nv_; ++iv) {
    for (int iu = 0; iu < b.nu_; ++iu) {
      const VerticalCrossing& c = crossings[static_cast<std::size_t>(iu) + static_cast<std::size_t>(b.nu_) * iv];
      double& h = b.h_[b.index(iu, iv)];
      if (c.crossings == 0 || !(c.z_exit_m > c.z_entry_m)) {
        h = 0.0;
        ++counts.lines_missing;
        continue;
      }
      h = std::max(0.0, c.z_exit_m - b.origin0_.z());
      if (c.crossings > 2 || c.z_entry_m > b.origin0_.z()) ++counts.lines_filled;
    }
  }
  b.build_tiles();
  if (report) *report = counts;
  return b;
}

NBuffer NBuffer::lines(int nu, int nv, std::vector<Eigen::Vector3d> origins,
                       std::vector<Eigen::Vector3d> directions, std::vector<double> lengths) {
  const std::size_t n = static_cast<std::size_t>(nu) * static_cast<std::size_t>(nv);
  if (nu <= 0 || nv <= 0 || origins.size() != n || directions.size() != n || lengths.size() != n) {
    throw std::invalid_argument("NBuffer::lines: nu * nv must match the sizes of the arrays");
  }
  NBuffer b;
  b.nu_ = nu, b.nv_ = nv;
  b.tiles_u_ = (nu + kTile - 1) / kTile;
  b.tiles_v_ = (nv + kTile - 1) / kTile;
  const std::size_t stored = static_cast<std::size_t>(b.tiles_u_) * b.tiles_v_ * kTile * kTile;
  b.h_.assign(stored, 0.0);
  b.o_.assign(stored, Eigen::Vector3d::Zero());
  b.u_.assign(stored, Eigen::Vector3d::UnitZ());
  for (int iv = 0; iv < nv; ++iv) {
    for (int iu = 0; iu < nu; ++iu) {
      const std::size_t k = static_cast<std::size_t>(iu) + static_cast<std::size_t>(nu) * iv;
      const double norm = directions[k].norm();
      if (!(norm > 0.0) || !std::isfinite(norm) || !(lengths[k] >= 0.0) || !origins[k].allFinite()) {
        throw std::invalid_argument("NBuffer::lines: line " + std::to_string(k) +
                                    " has a zero direction, a negative length or a non-finite origin");
      }
      const std::size_t s = b.index(iu, iv);
      b.o_[s] = origins[k];
      b.u_[s] = directions[k] / norm;
      b.h_[s] = lengths[k];
    }
  }
  b.build_tiles();
  return b;
}

std::size_t NBuffer::index(int iu, int iv) const {
  const std::size_t tile = static_cast<std::size_t>(iu / kTile) + static_cast<std::size_t>(tiles_u_) * (iv / kTile);
  return tile * kTile * kTile + static_cast<std::size_t>(iu % kTile) + kTile * static_cast<std::size_t>(iv % kTile);
}

Eigen::Vector3d NBuffer::origin(int iu, int iv) const {
  if (zmap_) return origin0_ + Eigen::Vector3d(iu * spacing_, iv * spacing_, 0.0);
  return o_[index(iu, iv)];
}

Eigen::Vector3d NBuffer::direction(int iu, int iv) const {
  return zmap_ ? Eigen::Vector3d::UnitZ() : u_[index(iu, iv)];
}

Eigen::Vector3d NBuffer::surface_point(int iu, int iv) const {
  return origin(iu, iv) + length(iu, iv) * direction(iu, iv);
}

std::vector<double> NBuffer::lengths() const {
  std::vector<double> out(line_count());
  for (int iv = 0; iv < nv_; ++iv) {
    for (int iu = 0; iu < nu_; ++iu) out[static_cast<std::size_t>(iu) + static_cast<std::size_t>(nu_) * iv] = length(iu, iv);
  }
  return out;
}

void NBuffer::build_tiles() {
  tiles_.assign(static_cast<std::size_t>(tiles_u_) * tiles_v_, TileBounds{});
  band_tile_begin_ = 0, band_tile_end_ = tiles_.size();
  for (std::size_t t = 0; t < tiles_.size(); ++t) refresh_tile(t, &h_[t * kTile * kTile]);
}

double NBuffer::compact_length(std::size_t stored) const {
  const std::size_t tile = stored / (kTile * kTile);
  const std::span<const float> offsets = offsets_.block(tile);
  if (offsets.empty()) return base_[tile];
  // Never below 0 (the float rounding of an offset of -base could reach just below).
  return std::max(0.0, base_[tile] + static_cast<double>(offsets[stored % (kTile * kTile)]));
}

void NBuffer::tile_lengths(std::size_t tile, double* out) const {
  constexpr std::size_t n = kTile * kTile;
  if (!compact_) {
    std::copy_n(h_.begin() + static_cast<std::ptrdiff_t>((tile - band_tile_begin_) * n), n, out);
    return;
  }
  const std::span<const float> offsets = offsets_.block(tile);
  const double base = base_[tile];
  if (offsets.empty()) {
    std::fill_n(out, n, base);
    return;
  }
  for (std::size_t k = 0; k < n; ++k) out[k] = std::max(0.0, base + static_cast<double>(offsets[k]));
}

void NBuffer::make_compact() {
  if (compact_) return;
  constexpr std::size_t n = kTile * kTile;
  base_.assign(tiles_.size(), 0.0);
  offsets_.reset(tiles_.size());
  for (std::size_t t = band_tile_begin_; t < band_tile_end_; ++t) {
    const double* h = &h_[(t - band_tile_begin_) * n];
    const double base = *std::max_element(h, h + n);
    base_[t] = base;
    if (std::all_of(h, h + n, [&](double v) { return v == base; })) continue;
    const std::span<float> offsets = offsets_.block_or_allocate(t, 0.0f);
    for (std::size_t k = 0; k < n; ++k) offsets[k] = static_cast<float>(h[k] - base);
  }
  compact_ = true;
  std::vector<double>().swap(h_);
  // The bounds from the lengths as now stored (a rounded offset may sit just above the exact
  // length: the culling must see what is stored).
  double h[n];
  for (std::size_t t = band_tile_begin_; t < band_tile_end_; ++t) {
    tile_lengths(t, h);
    refresh_tile(t, h);
  }
}

std::size_t NBuffer::allocated_tiles() const {
  if (!compact_) return tiles_.size();
  return offsets_.allocated_blocks();
}

std::size_t NBuffer::length_bytes() const {
  if (!compact_) return h_.size() * sizeof(double);
  return offsets_.bytes() + base_.size() * sizeof(double);
}

void NBuffer::refresh_tile(std::size_t tile, const double* h) {
  const int tu = static_cast<int>(tile % static_cast<std::size_t>(tiles_u_));
  const int tv = static_cast<int>(tile / static_cast<std::size_t>(tiles_u_));
  const int u_end = std::min(nu_, (tu + 1) * kTile), v_end = std::min(nv_, (tv + 1) * kTile);
  TileBounds& b = tiles_[tile];
  b.h_max = 0.0;
  b.lo = Eigen::Vector3d::Constant(detail::kInf);
  b.hi = Eigen::Vector3d::Constant(-detail::kInf);
  const std::size_t base = tile * kTile * kTile;  // index(iu, iv) within the tile
  for (int iv = tv * kTile; iv < v_end; ++iv) {
    for (int iu = tu * kTile; iu < u_end; ++iu) {
      const std::size_t s = base + static_cast<std::size_t>(iu - tu * kTile) + static_cast<std::size_t>(kTile) * (iv - tv * kTile);
      b.h_max = std::max(b.h_max, h[s - base]);
      if (!zmap_) {
        const Eigen::Vector3d end = o_[s] + h[s - base] * u_[s];
        b.lo = b.lo.cwiseMin(o_[s]).cwiseMin(end);
        b.hi = b.hi.cwiseMax(o_[s]).cwiseMax(end);
      }
    }
  }
  if (zmap_) {
    b.lo = origin0_ + Eigen::Vector3d(tu * kTile * spacing_, tv * kTile * spacing_, 0.0);
    b.hi = origin0_ + Eigen::Vector3d((u_end - 1) * spacing_, (v_end - 1) * spacing_, b.h_max);
  }
}

namespace {

// Distance in the plane from a box to a segment (0 when they meet).
double box_segment_distance(double x0, double y0, double x1, double y1, double ax, double ay,
                            double bx, double by) {
  // (Squared distances, one root at the end: the root is monotonic, so the result is the same.)
  auto point_box = [&](double px, double py) {
    const double dx = std::max({x0 - px, 0.0, px - x1}), dy = std::max({y0 - py, 0.0, py - y1});
    return dx * dx + dy * dy;
  };
  // Segment crossing the box (Liang-Barsky).
  double t0 = 0.0, t1 = 1.0;
  const double dx = bx - ax, dy = by - ay;
  auto clip = [&](double p, double q) {
    if (p == 0.0) return q >= 0.0;
    const double t = q / p;
    if (p < 0.0) t0 = std::max(t0, t); else t1 = std::min(t1, t);
    return t0 <= t1;
  };
  if (clip(-dx, ax - x0) && clip(dx, x1 - ax) && clip(-dy, ay - y0) && clip(dy, y1 - ay)) return 0.0;
  return std::sqrt(std::min({point_box(ax, ay), point_box(bx, by), detail::distance_2d_squared(x0, y0, ax, ay, bx, by),
                             detail::distance_2d_squared(x1, y0, ax, ay, bx, by),
                             detail::distance_2d_squared(x0, y1, ax, ay, bx, by),
                             detail::distance_2d_squared(x1, y1, ax, ay, bx, by)}));
}

}  // namespace

// Whether the lines behind the start c0 of a continuing sweep (planar half-plane) are already
// at or below it, for lines up to z_top. Vertical tool, level or rising move: each horizontal
// slice of the tool is a disc, farther and not lower along the move. Ball-end, any axis: where
// a line lies within r cos(tilt) of c0 and c1 in the plane, the tool's lowest point on it is
// the ball's (lowest_z_beyond), and behind c0 that is the ball at c0, which the previous sweep
// held; the reach at z_top plus the move bounds that distance for every line that matters.
static bool behind_is_cut(const Sweep& s, double z_top) {
  if (!s.continues) return false;
  if (s.vertical) return true;
  const double move = std::hypot(s.c1.x() - s.c0.x(), s.c1.y() - s.c0.y());
  return s.rho == 0.0 && detail::reach_below(s, z_top) + move <= s.r * s.a.z();
}

// Whether the sweep might lower a line of the tile (false: it cannot). On a Z-map the tile is
// the prism over its xy box up to its highest line; the sweep cannot reach into it when its
// lowest point at the tile's planar distance (lowest_z_beyond), or its lowest point along the
// tool axis (the plane a . p >= amin), lies above the prism, or when the tile lies wholly
// behind the start of a continuing sweep.
static bool may_cut(const Sweep& s, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, bool zmap) {
  for (int i = 0; i < 3; ++i) {
    if (s.hi[i] < lo[i] || s.lo[i] > hi[i]) return false;
  }
  if (!zmap) return true;
  // (The cheap plane test first: it rejects most tiles of a tilted tool, and the planar distance
  // costs several square roots.)
  if (!s.vertical && s.a.z() > 0.0) {
    const double reach = s.a.x() * (s.a.x() > 0.0 ? hi.x() : lo.x()) + s.a.y() * (s.a.y() > 0.0 ? hi.y() : lo.y());
    if ((s.amin - reach) / s.a.z() >= hi.z()) return false;
  }
  const double d = box_segment_distance(lo.x(), lo.y(), hi.x(), hi.y(), s.c0.x(), s.c0.y(), s.c1.x(), s.c1.y());
  if (detail::lowest_z_beyond(s, d) >= hi.z()) return false;
  if (behind_is_cut(s, hi.z())) {
    const double dx = s.c1.x() - s.c0.x(), dy = s.c1.y() - s.c0.y();
    const double ahead = (dx > 0.0 ? hi.x() : lo.x()) - s.c0.x();
    const double side = (dy > 0.0 ? hi.y() : lo.y()) - s.c0.y();
    if (ahead * dx + side * dy <= 0.0) return false;
  }
  return true;
}

namespace {

// The x-interval of the row y where the planar distance to the segment (ax, ay)-(bx, by) is
// at most R (the capsule is convex: the hull of its end discs' and its band's intervals).
// `len`: the segment's length, std::hypot(bx - ax, by - ay) (a sweep's constant, given by the caller).
bool capsule_row(double ax, double ay, double bx, double by, double len, double R, double y, double& x0, double& x1) {
  bool any = false;
  auto add = [&](double lo, double hi) {
    if (lo > hi) return;
    x0 = any ? std::min(x0, lo) : lo;
    x1 = any ? std::max(x1, hi) : hi;
    any = true;
  };
  for (const auto& [cx, cy] : {std::pair{ax, ay}, std::pair{bx, by}}) {
    const double dy = y - cy;
    if (std::abs(dy) <= R) {
      const double w = std::sqrt((R - dy) * (R + dy));
      add(cx - w, cx + w);
    }
  }
  const double dx = bx - ax, dy = by - ay;
  if (len > 0.0) {
    // |(x - ax) dy - (y - ay) dx| <= R len and 0 <= (x - ax) dx + (y - ay) dy <= len^2.
    double lo = -detail::kInf, hi = detail::kInf;
    auto clip = [&](double v0, double v1, double a, double b) {  // a <= v0 + v1 x <= b
      if (v1 == 0.0) {
        if (v0 < a || v0 > b) lo = detail::kInf;
        return;
      }
      double p = (a - v0) / v1, q = (b - v0) / v1;
      if (p > q) std::swap(p, q);
      lo = std::max(lo, p);
      hi = std::min(hi, q);
    };
    clip(-ax * dy - (y - ay) * dx, dy, -R * len, R * len);
    clip(-ax * dx + (y - ay) * dy, dx, 0.0, len * len);
    if (std::isfinite(lo) && std::isfinite(hi)) add(lo, hi);
  }
  return any;
}

// Narrows [x0, x1] to where c0 + c1 x > 0 (nothing when c1 = 0 and c0 <= 0).
void keep_positive(double c0, double c1, double& x0, double& x1) {
  if (c1 > 0.0) {
    x0 = std::max(x0, -c0 / c1);
  } else if (c1 < 0.0) {
    x1 = std::min(x1, -c0 / c1);
  } else if (c0 <= 0.0) {
    x1 = -detail::kInf;
  }
}

// Chains: level moves along x, end to end, with the same tilted flat-end or bull-nose tool
// (same radii; the axis constant or turning). Over a chain with one axis the entry of a
// vertical line at (x, y) is a convex function of the tool's position, smallest where the line
// passes the lowest point of the tool's section by the plane through the line
// (detail::section_lowest_x). So a sweep of a chain leaves the lines ahead of that point at its
// end to the next sweep (which holds the tool there, so it cuts them at least as low), and
// skips the lines behind that point at its start (the sweep before it cut them: they were not
// ahead of its end). Both sides use the same table of section points, with the slack on
// opposite sides, so no line falls between two sweeps. A sweep then tests about the strip its
// lowest points cross, not the footprint ahead. Where the axis turns (orientation sub-steps,
// `Junction`), the next tool differs and the boundaries move by what that difference needs.
// Moves along x within a slope of 1e-3 in y and z (a bull-nose whose axis turns moves its core
// point c = tip + r a off the tip's line), with a tilted tool the sections can be found for.
bool along_x(const Sweep& s) {
  const double dx = std::abs(s.c1.x() - s.c0.x());
  return dx > 0.0 && std::abs(s.c1.y() - s.c0.y()) <= 1e-3 * dx && std::abs(s.c1.z() - s.c0.z()) <= 1e-3 * dx &&
         !s.vertical && s.rho > 0.0 && s.a.z() > 0.0 && std::abs(s.a.x()) >= detail::kSectionMinAx;
}
bool level_along_x(const Sweep& s) { return along_x(s) && s.c0.y() == s.c1.y() && s.c0.z() == s.c1.z(); }

// Where two sweeps of a chain meet with different tools (the axis turned, or the core length
// differs) or one does not move exactly along x. Their tools at the meeting point differ by a
// rotation (about c, or about the tip: `chains`), a jump of that centre and a change of length,
// so each lies within D (for c: sqrt(rho^2 + ell^2) angle + jump + |ell - ell'|) of the other
// (Hausdorff), and one contains the other eroded by D: the core (+) Ball(r - D), c fixed. On a line where the first tool's lowest point p = K + r n (K in the
// core) is below `top`, the eroded ball about K enters at most delta = u / (r nu + sqrt(r^2 nu^2
// - u)) above p, u = 2 r D - D^2, nu = (lowest core z - top) / r <= |n_z| (so the y-slope of the
// entry is at most sqrt(1 - nu^2) / nu). Moved by t along x (its move's y and z over t are
// added to D), the eroded tool enters the line at x no higher than the first tool at x -/+ t
// plus delta, and the first tool's entry along the row is convex: where its x-slope is at
// least delta / t (toward the motion) at x -/+ t, the moved one enters at least as low. So the
// sweep before the junction leaves the lines beyond that point plus t (the next sweep, t into
// its move, cuts them at least as low), and the sweep after it skips the lines behind its point
// of the opposite slope minus t (the sweep before, t before its end, cut them at least as
// low). A sweep off x also needs its own entry smallest at its end (start) there: an x-slope
// above its y drift times the y-slope bound plus its rise. No loss against the sub-steps, so
// nothing accumulates over a chain.
struct Junction {
  bool general = false;  // not the same tool moving exactly along x: the tables' own boundaries
  double turn_m = 0.0;   // D without the shift's drift (0: the same tool, t = 0)
  double r = 0.0, r_nu = 0.0;
  // Per unit of x travel, the y and z drift of the next sweep (lead side) and of the sweep before
  // (trail side) over the shift t; the x-slopes their own moves need; and their x lengths (t's
  // upper bounds).
  double lead_drift = 0.0, trail_drift = 0.0, lead_min_slope = 0.0, trail_min_slope = 0.0;
  double lead_max_shift_m = 0.0, trail_max_shift_m = 0.0;
  // How much higher a tool eroded by d can enter a line whose entry is below the top [m], for
  // entries whose normals have |n_z| >= r_nu_row / r (the junction's r_nu, or a row's).
  double delta(double d, double r_nu_row) const {
    d = d * (1.0 + 1e-9) + 1e-15;
    const double u = (2.0 * r - d) * d;
    if (!(r_nu_row * r_nu_row > 2.0 * u)) return detail::kInf;
    return u / (r_nu_row + std::sqrt(r_nu_row * r_nu_row - u)) * (1.0 + 1e-9) + 1e-15;
  }
  double delta(double d) const { return delta(d, r_nu); }
  // The boundary's x-slope for a shift t (lead: the next sweep t into its move; trail: the sweep
  // before t before its end); t is clamped to its upper bound.
  double slope(bool lead, double& t, double r_nu_row) const {
    const double max_t = lead ? lead_max_shift_m : trail_max_shift_m;
    const double min_slope = lead ? lead_min_slope : trail_min_slope;
    if (!(turn_m > 0.0)) {
      t = 0.0;
      return min_slope;
    }
    t = std::min(t, max_t);
    return std::max(min_slope, delta(turn_m + t * (lead ? lead_drift : trail_drift), r_nu_row) / t * (1.0 + 1e-9));
  }
  double slope(bool lead, double& t) const { return slope(lead, t, r_nu); }
  // A first t: near sqrt(delta R) for a curvature radius R of the section, which makes the
  // strip end about as far beyond the point of slope 0 as t itself. Any t in (0, length] is
  // exact; this one only keeps the strips short.
  double shift_for(double radius_m) const { return std::sqrt(delta(turn_m) * radius_m); }
  // The least shift t for which `slope` suffices (slope(lead, t, r_nu_row) <= slope), or NaN
  // (none up to the move's length, or no turn): delta(D + t drift) / t = slope by fixed-point
  // steps from t = 0 (rising), then checked.
  double shift_for_slope(bool lead, double slope_wanted, double r_nu_row) const {
    if (!(turn_m > 0.0) || !(slope_wanted > 0.0)) return std::nan("");
    const double drift = lead ? lead_drift : trail_drift;
    double t = 0.0;
    for (int k = 0; k < (drift > 0.0 ? 4 : 1); ++k) t = delta(turn_m + t * drift, r_nu_row) / slope_wanted * (1.0 + 2e-9);
    double checked = t;
    if (!(t <= (lead ? lead_max_shift_m : trail_max_shift_m)) || !(slope(lead, checked, r_nu_row) <= slope_wanted)) {
      return std::nan("");
    }
    return t;
  }
};

// Whether `next` continues `s` in a chain, and how (`top`: no line's material above it [m]).
bool chains(const Sweep& s, const Sweep& next, double top, Junction* junction = nullptr) {
  // (Sub-steps along the tip's line meet with their core points apart, SubStepPath::tip: that
  // distance adds to D below.)
  const double jump = (next.c0 - s.c1).norm();
  if (s.profile.active || next.profile.active) return false;  // (the section tables are for the other tools)
  if (!(along_x(s) && along_x(next) && s.rho == next.rho && s.r == next.r &&
        (s.c1.x() > s.c0.x()) == (next.c1.x() > next.c0.x()))) {
    return false;
  }
  Junction j;
  if (!(s.a == next.a && s.ell == next.ell && jump == 0.0 && level_along_x(s) && level_along_x(next))) {
    if (!(s.r > 0.0)) return false;  // (a flat-end has no ball to erode, nor a bounded y-slope)
    const double angle = std::atan2(s.a.cross(next.a).norm(), s.a.dot(next.a));
    // The rotation about c moves the core's points (at most sqrt(rho^2 + ell^2) from c) by that
    // times the angle, and c by the jump; about the tip c - r a (which sub-steps along the
    // tip's line share) by sqrt(rho^2 + (r + ell)^2) times the angle and the tip's jump: less
    // there, since the tip's jump is ~0 where c's is r times the axis step.
    const double longest = std::max(s.ell, next.ell);
    const double tip_jump = ((next.c0 - s.r * next.a) - (s.c1 - s.r * s.a)).norm();
    j.turn_m = std::min(std::hypot(s.rho, longest) * angle + jump, std::hypot(s.rho, s.r + longest) * angle + tip_jump) +
               std::abs(s.ell - next.ell);
    const double core_low =
        std::min({s.c0.z(), s.c1.z(), next.c1.z()}) - s.rho * std::max(s.tilt_sin, next.tilt_sin);
    const double nu = (core_low - top) / s.r;
    if (!(nu > 0.0) || !(nu <= 1.0)) return false;
    j.r = s.r, j.r_nu = s.r * nu;
    const double y_slope = std::sqrt((1.0 - nu) * (1.0 + nu)) / nu;
    auto per_x = [](const Sweep& m, double& length, double& y, double& rise) {
      length = std::abs(m.c1.x() - m.c0.x());
      y = std::abs(m.c1.y() - m.c0.y()) / length;
      rise = (m.c1.z() - m.c0.z()) / length;  // up along the motion > 0
    };
    double y_before = 0.0, rise_before = 0.0, y_after = 0.0, rise_after = 0.0;
    per_x(s, j.trail_max_shift_m, y_before, rise_before);
    per_x(next, j.lead_max_shift_m, y_after, rise_after);
    j.lead_drift = std::hypot(y_after, rise_after);
    j.trail_drift = std::hypot(y_before, rise_before);
    // The entry of `s` smallest at its end (of `next` at its start) beyond (behind) the point.
    j.lead_min_slope = y_slope * y_before + std::max(0.0, rise_before);
    j.trail_min_slope = y_slope * y_after + std::max(0.0, -rise_after);
    if (!std::isfinite(j.delta(j.turn_m + j.lead_max_shift_m * j.lead_drift)) ||
        !std::isfinite(j.delta(j.turn_m + j.trail_max_shift_m * j.trail_drift))) {
      return false;
    }
    j.general = true;
  }
  if (junction) *junction = j;
  return true;
}

// The section points of one tool pose (axis, radii, length, core y and z) for the grid rows in
// which it can get below the material's top: [lo, hi] of x relative to the core point, or no
// hit (the row misses the tool, or the section lies above the top); rows outside the table
// are above it too. With a general junction ahead (behind), `lead` (`trail`): the row's strip
// boundary relative to c1.x (c0.x) (Junction), else lo / hi by the direction.
struct SectionRows {
  Eigen::Vector3d a = Eigen::Vector3d::Zero();
  double rho = 0.0, r = 0.0, ell = 0.0, c_y = 0.0, c_z = 0.0;  // (c_z decides the rows: the reach)
  bool own = false;  // built for one sweep (general junction boundaries): never shared
  bool level = true;     // the sweep moves exactly along x: z_low bounds the whole move, z_point holds
  int iv0 = 0;
  std::vector<double> lo, hi;
  std::vector<double> z_low;    // below the section's lowest point, from the core point's z
  std::vector<double> z_point;  // that point's z where known within kSectionZError, else NaN
  std::vector<char> hit;
  std::vector<double> lead_x, trail_x;  // (general junctions only)
  // The section points the junction boundaries were found from (relative to c1.x, c0.x) and
  // their x-slopes' magnitudes (0: none): beyond (behind) them the tool standing at c1 (c0)
  // enters a row at least z_low + slope * distance.
  std::vector<double> lead_point_x, lead_slope, trail_point_x, trail_slope;
  // Own tables: each row's over-zone lines (NBuffer::cut's over_zone_lines; first > last: none).
  std::vector<int> over_first, over_last;
  bool same_family(const Sweep& s) const {
    return !own && a == s.a && rho == s.rho && r == s.r && ell == s.ell && c_y == s.c0.y() && c_z == s.c0.z();
  }
  int row(int iv) const {  // index into the vectors, or -1: the row cannot be cut
    const int k = iv - iv0;
    return k >= 0 && k < static_cast<int>(hit.size()) && hit[static_cast<std::size_t>(k)] ? k : -1;
  }
  // The strip boundaries of row k: lines beyond c1.x + lead are left to the next sweep, lines
  // behind c0.x + trail were cut by the one before (forward: beyond = larger x).
  double lead(int k, bool forward) const {
    return !lead_x.empty() ? lead_x[static_cast<std::size_t>(k)] : forward ? hi[static_cast<std::size_t>(k)] : lo[static_cast<std::size_t>(k)];
  }
  double trail(int k, bool forward) const {
    return !trail_x.empty() ? trail_x[static_cast<std::size_t>(k)] : forward ? lo[static_cast<std::size_t>(k)] : hi[static_cast<std::size_t>(k)];
  }
};

// Upper bounds of the lines' tops (z, m) by tile row over the x-range of the sweeps a table
// serves, taken at the start of a batch (they only fall while it is cut).
struct RowTops {
  int rows_per_tile = 16;
  std::vector<double> top, outward_up, outward_down;  // by tile row: its own; the max of it and all above / below
  double at(int iv) const { return top[static_cast<std::size_t>(iv / rows_per_tile)]; }
  double beyond(int iv, int step) const {
    return (step > 0 ? outward_up : outward_down)[static_cast<std::size_t>(iv / rows_per_tile)];
  }
};

// The table for sweep `s` on the grid rows y = y0 + iv sp (iv in [0, nv)), with the junctions
// ahead and behind (nullptr: none, or the same tool). The section's lowest z is convex in the
// row's y, smallest at the row of the tool's lowest point: the walk goes outwards from there,
// each row warm-started from the one before, and stops at the first row whose section lies
// above the tops of it and of every row farther out; rows whose section lies above their own
// top are kept as misses without their junction points.
SectionRows section_rows_for(const Sweep& s, double y0, double sp, int nv, const RowTops& tops, const Junction* lead,
                             const Junction* trail) {
  SectionRows t;
  t.a = s.a, t.rho = s.rho, t.r = s.r, t.ell = s.ell, t.c_y = s.c0.y(), t.c_z = s.c0.z();
  const bool general_lead = lead && lead->general, general_trail = trail && trail->general;
  t.own = general_lead || general_trail;
  t.level = level_along_x(s);
  const bool forward = s.c1.x() > s.c0.x();
  const double dir = forward ? 1.0 : -1.0;
  const double z_start = std::min(s.c0.z(), s.c1.z()), drift_y = std::abs(s.c1.y() - s.c0.y());
  struct Row {
    int iv;
    double lo, hi, z_low, z_point, lead, trail;
    bool hit;
    double lead_point = 0.0, lead_slope = 0.0, trail_point = 0.0, trail_slope = 0.0;  // (SectionRows)
  };
  auto walk = [&](int iv_first, int step, bool stop_at_first, std::vector<Row>& out) {
    detail::SectionWarm warm0, warm_lead, warm_trail;
    // The junction boundaries' slopes, one for the whole walk so that each row's point is
    // warm-started from the rows before on the same curve: from the section's curvature radius
    // at the walk's first row that meets the tool (how far the point of a first slope lies from
    // the lowest point: a shift t near sqrt(delta R), a short strip; any t is exact). Taken
    // there whatever the material, so the boundaries depend on the trajectory only.
    const double radius_guess = s.r + s.rho / std::max(s.tilt_sin, 1e-3);  // [m]
    double slope_lead = std::nan(""), slope_trail = std::nan("");
    // Once a walk's slope is set, the shift and slope of its boundaries are the same on every
    // row (they depend on the junction and that slope only): found once per side.
    struct Shift {
      bool known = false;
      double shift = 0.0, slope = 0.0;
    } shift_lead, shift_trail;
    for (int iv = iv_first; iv >= 0 && iv < nv; iv += step) {
      const double y = y0 + iv * sp;  // (as cut_zmap_tile computes it)
      const double eta = y - t.c_y;   // from c0
      Row row{iv, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, false};
      row.hit = detail::section_point_x(s, eta, 0.0, row.lo, row.hi, &warm0, &row.z_low, &row.z_point);
      if (!t.level) row.z_point = std::nan("");  // (the height of lines passed over holds for level moves only)
      // A junction boundary of this row (lead side: lines beyond it are left to the next sweep;
      // trail side: lines behind it were cut by the sweep before), or false.
      auto boundary = [&](const Junction& j, bool lead_side, detail::SectionWarm& w, double& walk_slope, Shift& walk_shift,
                          double& x, double& point_x, double& point_slope) {
        double slope = walk_slope, shift = 0.0;
        if (walk_shift.known) {
          shift = walk_shift.shift, slope = walk_shift.slope;
        } else {
          shift = j.shift_for_slope(lead_side, walk_slope, j.r_nu);
          if (!std::isfinite(shift)) {  // (the walk's first row, or that slope needs too long a shift)
            shift = j.shift_for(radius_guess);
            slope = j.slope(lead_side, shift);
          }
          walk_shift = {std::isfinite(walk_slope), shift, slope};
        }
        if (!std::isfinite(w.u)) w = warm0;  // start from this row's lowest point
        double lo = 0.0, hi = 0.0;
        // (The lead from c1, the trail from c0.)
        if (!detail::section_point_x(s, lead_side ? y - s.c1.y() : eta, (lead_side ? dir : -dir) * slope, lo, hi, &w)) {
          return false;
        }
        const bool upper = lead_side == forward;  // the boundary is beyond the point in +x
        x = upper ? hi + shift : lo - shift;
        point_x = upper ? hi : lo, point_slope = slope;
        if (!std::isfinite(walk_slope)) {
          const double offset = upper ? hi - row.lo : row.hi - lo;
          shift = j.shift_for(slope > 0.0 ? std::clamp(offset / slope, 1e-5, 1.0) : radius_guess);
          walk_slope = j.slope(lead_side, shift);
        }
        return true;
      };
      row.lead = dir * detail::kInf;    // (no point found: nothing left ahead)
      row.trail = -dir * detail::kInf;  // (nothing skipped behind)
      auto junction_boundaries = [&] {
        if (general_lead && !boundary(*lead, true, warm_lead, slope_lead, shift_lead, row.lead, row.lead_point, row.lead_slope)) {
          row.lead = dir * detail::kInf;
          row.lead_slope = 0.0;
        }
        if (general_trail &&
            !boundary(*trail, false, warm_trail, slope_trail, shift_trail, row.trail, row.trail_point, row.trail_slope)) {
          row.trail = -dir * detail::kInf;
          row.trail_slope = 0.0;
        }
      };
      const bool first_hit = row.hit && ((general_lead && !std::isfinite(slope_lead)) || (general_trail && !std::isfinite(slope_trail)));
      if (first_hit) junction_boundaries();  // (the walk's slopes, whatever the material)
      // Above the top here and in every row farther out, for the tool anywhere along the move:
      // its core point drifts by dy across the rows, where the section's lowest z changes by
      // at most |dy| |tan b| (b the lowest point's normal angle; convex, growing outwards).
      const double floor = z_start + row.z_low - drift_y * std::abs(warm0.tan_b()) - 1e-12;
      if (!row.hit || floor >= tops.beyond(iv, step)) {
        if (iv != iv_first || stop_at_first) break;
        row.hit = false;
        out.push_back(row);
        continue;
      }
      if (floor >= tops.at(iv)) {  // nothing to cut in this row (yet the walk goes on)
        row.hit = false;
        out.push_back(row);
        continue;
      }
      if (!first_hit) junction_boundaries();
      out.push_back(row);
    }
  };
  // The tool's lowest point (support point of -z) lies at y = c_y + rho a_z a_y / sin(tilt).
  const double y_lowest = t.c_y + s.rho * s.a.z() * s.a.y() / s.tilt_sin;
  const int iv_up = static_cast<int>(std::ceil((y_lowest + 1e-12 - y0) / sp));
  std::vector<Row> up, down;
  // (The rows a tool can span from its lowest point, either way: no reallocation on the walks.)
  const std::size_t rows_guess = static_cast<std::size_t>(std::min<double>(nv, 2.0 * (s.rho + s.r) / sp + 2.0));
  up.reserve(rows_guess), down.reserve(2 * rows_guess);
  walk(std::max(0, iv_up), 1, true, up);  // rows at or beyond the lowest point's y: monotone
  // Rows below: the first one may lie within 1e-12 m of that y (either side): never stop there.
  walk(std::min(nv - 1, iv_up - 1), -1, false, down);
  std::reverse(down.begin(), down.end());
  down.insert(down.end(), up.begin(), up.end());
  t.iv0 = down.empty() ? 0 : down.front().iv;
  for (std::vector<double>* v : {&t.lo, &t.hi, &t.z_low, &t.z_point}) v->reserve(down.size());
  t.hit.reserve(down.size());
  if (general_lead) {
    for (std::vector<double>* v : {&t.lead_x, &t.lead_point_x, &t.lead_slope}) v->reserve(down.size());
  }
  if (general_trail) {
    for (std::vector<double>* v : {&t.trail_x, &t.trail_point_x, &t.trail_slope}) v->reserve(down.size());
  }
  for (const Row& row : down) {
    if (row.iv != t.iv0 + static_cast<int>(t.hit.size())) break;  // (contiguous by construction)
    t.hit.push_back(row.hit);
    t.lo.push_back(row.lo);
    t.hi.push_back(row.hi);
    t.z_low.push_back(row.z_low);
    t.z_point.push_back(row.z_point);
    if (general_lead) {
      t.lead_x.push_back(row.lead);
      t.lead_point_x.push_back(row.lead_point);
      t.lead_slope.push_back(row.hit ? row.lead_slope : 0.0);
    }
    if (general_trail) {
      t.trail_x.push_back(row.trail);
      t.trail_point_x.push_back(row.trail_point);
      t.trail_slope.push_back(row.hit ? row.trail_slope : 0.0);
    }
  }
  return t;
}

// What a sweep does in its chain.
struct ChainRole {
  bool skip_behind = false;  // the sweep before it is in its chain
  bool leave_ahead = false;  // the sweep after it is in its chain
  Junction behind, ahead;    // (skip_behind, leave_ahead)
  int rows = -1;             // its SectionRows
};

}  // namespace

CutStatistics NBuffer::cut(const Tool& tool, std::span<const Pose> trajectory, const CutOptions& options) {
  tool.validate();
  for (std::size_t i = 0; i < trajectory.size(); ++i) {
    if (!(trajectory[i].axis_W.norm() > 0.0) || !trajectory[i].axis_W.allFinite() ||
        !trajectory[i].tip_W_m.allFinite()) {
      throw InputError("trajectory sample " + std::to_string(i) + ": zero or non-finite tool axis or tip");
    }
  }
  if (!(options.orientation_tolerance_m > 0.0)) {
    throw InputError("orientation tolerance must be > 0");
  }
  CutStatistics stats;
  const std::size_t segments = trajectory.size() <= 1 ? trajectory.size() : trajectory.size() - 1;
  stats.segments = segments;
  const std::size_t batch = std::max<std::size_t>(1, options.batch_segments);
  tbb::task_arena arena(options.threads > 0 ? options.threads : tbb::task_arena::automatic);
  std::atomic<std::size_t> tiles_visited{0}, lines_lowered{0};
  std::vector<Sweep> sweeps;
  std::vector<std::pair<std::uint32_t, std::uint32_t>> pairs;  // (tile, sweep)
  std::vector<std::size_t> group_begin;
  // Every line's material lies in this box (it only shrinks while cutting): the tool is cut
  // short above it (split_segment), which keeps 5-axis sub-steps and sweeps small.
  Box material{Eigen::Vector3d::Constant(detail::kInf), Eigen::Vector3d::Constant(-detail::kInf)};
  for (const TileBounds& t : tiles_) {
    material.min_W_m = material.min_W_m.cwiseMin(t.lo);
    material.max_W_m = material.max_W_m.cwiseMax(t.hi);
  }
  Sweep previous;
  bool have_previous = false;
  std::vector<Sweep> lookahead;  // the first sweep after the batch (chains)
  std::vector<ChainRole> roles;  // per sweep of the batch
  std::vector<SectionRows> section_rows, section_rows_before;
  SectionRows carried_rows;  // the last sweep's table when it leaves lines at a general junction
  const double sp = spacing_;
  const double slack = 1e-9;  // [m] widening of the row ranges against rounding: the exact test decides
  // The lines of row k that the lowest point of the sweep's section passes over (a chain sweep
  // moving exactly along x, its height known): they get that height (cut_zmap_tile). False when none.
  auto over_zone_lines = [&](const Sweep& s, const SectionRows& t, int k, int& first, int& last) {
    const std::size_t kk = static_cast<std::size_t>(k);
    if (!std::isfinite(t.z_point[kk])) return false;
    const double x_start = std::min(s.c0.x(), s.c1.x()), x_end = std::max(s.c0.x(), s.c1.x());
    first = static_cast<int>(std::ceil((x_start + t.hi[kk] + slack - origin0_.x()) / sp));
    last = static_cast<int>(std::floor((x_end + t.lo[kk] - slack - origin0_.x()) / sp));
    return first <= last;
  };
  // (Own tables keep them: the junction boundaries look them up for up to six neighbours.)
  auto over_zone_lines_cached = [&](const Sweep& s, const SectionRows& t, int k, int& first, int& last) {
    if (t.over_first.empty()) return over_zone_lines(s, t, k, first, last);
    first = t.over_first[static_cast<std::size_t>(k)], last = t.over_last[static_cast<std::size_t>(k)];
    return first <= last;
  };

  const std::size_t turning_cap = std::max<std::size_t>(1, options.batch_turning_sweeps);
  for (std::size_t first = 0, last = 0; first < segments; first = last) {
    sweeps.clear();
    std::size_t turning = 0;  // sub-segments whose axis differs from the one before
    for (last = first; last < std::min(segments, first + batch) && turning < turning_cap; ++last) {
      const Pose& p0 = trajectory[last];
      const Pose& p1 = trajectory.size() == 1 ? trajectory[0] : trajectory[last + 1];
      const std::size_t before = sweeps.size();
      detail::split_segment(tool, p0, p1, options.orientation_tolerance_m, sweeps, &material, detail::SubStepPath::tip);
      for (std::size_t k = std::max<std::size_t>(before, 1); k < sweeps.size(); ++k) turning += sweeps[k].a != sweeps[k - 1].a;
    }
    const Sweep last_before = previous;
    const bool have_before = have_previous;
    for (Sweep& s : sweeps) {
      // A vertical tool moving level or upwards from where the last sweep left it cuts nothing
      // new behind its start (each horizontal slice of it is a disc).
      // A ball-end's ball at c0 is the same whatever the axis (where it decides the cut: see
      // behind_is_cut).
      s.continues = have_previous && previous.c1 == s.c0 && previous.rho == s.rho && previous.r == s.r &&
                    s.c1.z() >= s.c0.z() &&
                    ((previous.vertical && s.vertical && previous.ell == s.ell) || s.rho == 0.0);
      s.continues_axis = have_previous && previous.c1 == s.c0 && previous.a == s.a && previous.rho == s.rho &&
                         previous.r == s.r;
      if (s.profile.active) s.continues = s.continues_axis = false;  // (those skips are for the other tools)
      previous = s;
      have_previous = true;
    }
    stats.sub_segments += sweeps.size();
    roles.assign(sweeps.size(), ChainRole{});
    if (zmap_ && !sweeps.empty()) {
      lookahead.clear();
      if (last < segments) {
        detail::split_segment(tool, trajectory[last], trajectory[last + 1], options.orientation_tolerance_m, lookahead,
                              &material, detail::SubStepPath::tip);
      }
      section_rows_before.swap(section_rows);
      section_rows.clear();
      const double top = material.max_W_m.z();
      // The tiles' tops by tile row over the x-range [x_lo, x_hi] (rows outside the y-range: none).
      auto row_tops = [&](double x_lo, double x_hi, double y_lo, double y_hi) {
        RowTops tops;
        tops.rows_per_tile = kTile;
        const std::size_t n = static_cast<std::size_t>(tiles_v_);
        tops.top.assign(n, -detail::kInf);
        const double tile_m = sp * kTile;
        auto tile_index = [&](double v, double origin, int tiles) {  // clamped to [-1, tiles]
          return static_cast<int>(std::clamp(std::floor((v - origin) / tile_m), -1.0, static_cast<double>(tiles)));
        };
        const int u0 = std::max(0, tile_index(x_lo, origin0_.x(), tiles_u_));
        const int u1 = std::min(tiles_u_ - 1, tile_index(x_hi, origin0_.x(), tiles_u_));
        const int v0 = std::max(0, tile_index(y_lo, origin0_.y(), tiles_v_));
        const int v1 = std::min(tiles_v_ - 1, tile_index(y_hi, origin0_.y(), tiles_v_));
        for (int tv = v0; tv <= v1; ++tv) {
          for (int tu = u0; tu <= u1; ++tu) {
            const TileBounds& b = tiles_[static_cast<std::size_t>(tu) + static_cast<std::size_t>(tiles_u_) * tv];
            tops.top[static_cast<std::size_t>(tv)] = std::max(tops.top[static_cast<std::size_t>(tv)], b.hi.z());
          }
        }
        tops.outward_up = tops.outward_down = tops.top;
        for (std::size_t i = n; i-- > 1;) tops.outward_up[i - 1] = std::max(tops.outward_up[i - 1], tops.outward_up[i]);
        for (std::size_t i = 1; i < n; ++i) tops.outward_down[i] = std::max(tops.outward_down[i], tops.outward_down[i - 1]);
        return tops;
      };
      // (A table shared along a chain serves sweeps anywhere along x: the whole rows.)
      const RowTops whole_rows = row_tops(-detail::kInf, detail::kInf, -detail::kInf, detail::kInf);
      auto build_rows = [&](const Sweep& s, const ChainRole& role, bool own) {
        const RowTops tops = own ? row_tops(s.lo.x(), s.hi.x(), s.lo.y(), s.hi.y()) : RowTops{};
        return section_rows_for(s, origin0_.y(), sp, nv_, own ? tops : whole_rows,
                                role.leave_ahead ? &role.ahead : nullptr, role.skip_behind ? &role.behind : nullptr);
      };
      // A tool held along a chain keeps its table from sweep to sweep and batch to batch.
      auto shared_rows_for = [&](const Sweep& s, const ChainRole& role) {
        for (std::size_t i = 0; i < section_rows.size(); ++i) {
          if (section_rows[i].same_family(s)) return static_cast<int>(i);
        }
        for (SectionRows& t : section_rows_before) {
          if (t.same_family(s)) {
            section_rows.push_back(std::move(t));
            t = SectionRows{};  // (no longer matches any sweep)
            return static_cast<int>(section_rows.size() - 1);
          }
        }
        section_rows.push_back(build_rows(s, role, false));
        return static_cast<int>(section_rows.size() - 1);
      };
      std::vector<std::size_t> own_tables;  // sweeps whose table is their own (a general junction)
      for (std::size_t k = 0; k < sweeps.size(); ++k) {
        ChainRole& role = roles[k];
        role.skip_behind = k == 0 ? have_before && chains(last_before, sweeps[0], top, &role.behind)
                                  : chains(sweeps[k - 1], sweeps[k], top, &role.behind);
        role.leave_ahead = k + 1 < sweeps.size() ? chains(sweeps[k], sweeps[k + 1], top, &role.ahead)
                                                 : !lookahead.empty() && chains(sweeps[k], lookahead.front(), top, &role.ahead);
        if (!role.skip_behind && !role.leave_ahead) continue;
        stats.chained_turning += role.leave_ahead && role.ahead.general;
        if ((role.skip_behind && role.behind.general) || (role.leave_ahead && role.ahead.general)) {
          role.rows = static_cast<int>(section_rows.size());
          section_rows.emplace_back();
          own_tables.push_back(k);
        } else {
          role.rows = shared_rows_for(sweeps[k], role);
        }
      }
      arena.execute([&] {
        tbb::parallel_for(std::size_t{0}, own_tables.size(), [&](std::size_t i) {
          const std::size_t k = own_tables[i];
          SectionRows& t = section_rows[static_cast<std::size_t>(roles[k].rows)];
          t = build_rows(sweeps[k], roles[k], true);
          t.over_first.assign(t.hit.size(), 0);
          t.over_last.assign(t.hit.size(), -1);
          for (std::size_t row = 0; row < t.hit.size(); ++row) {
            if (!over_zone_lines(sweeps[k], t, static_cast<int>(row), t.over_first[row], t.over_last[row])) {
              t.over_first[row] = 0, t.over_last[row] = -1;
            }
          }
        });
      });
      // At a general junction the two tables differ: lines the sweep before leaves must not lie
      // behind the trail of the sweep after (they would fall between the two).
      for (std::size_t k = 0; k < sweeps.size(); ++k) {
        if (!roles[k].skip_behind || !roles[k].behind.general) continue;
        const SectionRows& before = k == 0 ? carried_rows : section_rows[static_cast<std::size_t>(roles[k - 1].rows)];
        SectionRows& t = section_rows[static_cast<std::size_t>(roles[k].rows)];
        const bool forward = sweeps[k].c1.x() > sweeps[k].c0.x();
        const Sweep& previous_sweep = k == 0 ? last_before : sweeps[k - 1];
        const double frame = previous_sweep.c1.x() - sweeps[k].c0.x();  // (the lead is from its c1, the trail from c0)
        for (std::size_t i = 0; i < t.trail_x.size(); ++i) {
          const int kb = before.row(t.iv0 + static_cast<int>(i));
          if (kb < 0) continue;  // the sweep before cannot cut that row: it left nothing there
          const double lead = before.lead(kb, forward) + frame;
          t.trail_x[i] = forward ? std::min(t.trail_x[i], lead) : std::max(t.trail_x[i], lead);
        }
      }
      // Over-zone coverage at general junctions (level chains, heights known). A line in the
      // over zone of another sweep j of the chain gets j's section height m_j from j. Ahead of
      // the slope point P (slope sigma) of a sweep's tool standing at its end, its entry is at
      // least z_low + sigma * distance past P (convex along the row, and never below the row's
      // lowest point): where that is at or above m_j, the sweep need not test the line (j gives
      // it at most the sweep's own entry). The same behind the start. Lines so covered next to
      // the junction boundary move it (lines only: the boundary lands between two of them). A
      // base case: it does not rely on any other sweep's boundaries.
      auto cover = [&](std::size_t k, bool lead_side) {
        const Sweep& s = sweeps[k];
        SectionRows& t = section_rows[static_cast<std::size_t>(roles[k].rows)];
        std::vector<double>& boundary = lead_side ? t.lead_x : t.trail_x;
        const std::vector<double>& point_x = lead_side ? t.lead_point_x : t.trail_point_x;
        const std::vector<double>& point_slope = lead_side ? t.lead_slope : t.trail_slope;
        if (!t.level || boundary.empty()) return;
        const bool forward = s.c1.x() > s.c0.x();
        // Lines grow away from the sweep on its side: +x for the lead of a forward sweep.
        const bool away_up = lead_side == forward;
        const double anchor = lead_side ? s.c1.x() : s.c0.x();
        const double ox = origin0_.x(), inv_sp = 1.0 / sp;
        struct Covered {
          int first, last;
        };
        Covered covered[3];
        for (std::size_t i = 0; i < boundary.size(); ++i) {
          const double sigma = point_slope[i];
          if (!t.hit[i] || !(sigma > 0.0) || !std::isfinite(boundary[i])) continue;
          const int iv = t.iv0 + static_cast<int>(i);
          int own_first = 0, own_last = 0;
          if (!over_zone_lines_cached(s, t, static_cast<int>(i), own_first, own_last)) continue;
          const double m_low = s.c0.z() + t.z_low[i];
          const double p_abs = anchor + point_x[i], inv_sigma = 1.0 / sigma;
          // The first line not tested (in the direction away), as cut_zmap_tile rounds the strip.
          const double edge = anchor + boundary[i];
          int line = away_up ? static_cast<int>(std::floor((edge + slack - ox) / sp)) + 1
                             : static_cast<int>(std::ceil((edge - slack - ox) / sp)) - 1;
          int n = 0;
          for (int step = 1; step <= 3; ++step) {
            const std::size_t j = lead_side ? k + step : k - step;
            if (lead_side ? j >= sweeps.size() || !roles[j - 1].leave_ahead : k < static_cast<std::size_t>(step) || !roles[j + 1].skip_behind) break;
            if (roles[j].rows < 0) break;
            const SectionRows& tj = section_rows[static_cast<std::size_t>(roles[j].rows)];
            const int kj = tj.row(iv);
            int a = 0, b = 0;
            if (!tj.level || kj < 0 || !over_zone_lines_cached(sweeps[j], tj, kj, a, b)) continue;
            if (away_up ? a > line - 1 : b < line + 1) break;  // (this and the farther ones lie beyond the boundary)
            const double m_j = sweeps[j].c0.z() + tj.z_point[static_cast<std::size_t>(kj)];
            // (The margin, 1e-14 m of z, is worth far more than the rounding of the lines' x.)
            const double need = (m_j + 1e-14 - m_low) * inv_sigma;  // distance past P [m]
            if (need > 0.0) {
              if (away_up) a = std::max(a, static_cast<int>(std::ceil((p_abs + need - ox) * inv_sp)));
              else b = std::min(b, static_cast<int>(std::floor((p_abs - need - ox) * inv_sp)));
            }
            if (a <= b) covered[n++] = {a, b};
          }
          if (n == 0) continue;
          const int before = line;
          for (bool moved = true; moved;) {
            moved = false;
            for (int c = 0; c < n; ++c) {
              const int toward = away_up ? line - 1 : line + 1;  // the nearest line tested
              if (covered[c].first <= toward && toward <= covered[c].last) {
                line = away_up ? covered[c].first : covered[c].last;
                moved = true;
              }
            }
          }
          line = away_up ? std::max(line, own_last + 1) : std::min(line, own_first - 1);  // (its own over zone stays)
          if (line == before) continue;
          stats.junction_rows_covered += away_up ? line < before : line > before;
          boundary[i] = (away_up ? line - 0.5 : line + 0.5) * sp + ox - anchor;
        }
      };
      for (std::size_t k = 0; k < sweeps.size(); ++k) {
        if (roles[k].rows < 0) continue;
        if (roles[k].leave_ahead && roles[k].ahead.general) cover(k, true);
        if (roles[k].skip_behind && roles[k].behind.general) cover(k, false);
      }
      const ChainRole& last_role = roles.back();
      carried_rows = last_role.leave_ahead && last_role.ahead.general ? section_rows[static_cast<std::size_t>(last_role.rows)]
                                                                          : SectionRows{};
    }
    // A sweep in a chain can cut a tile only where its rows' strips (between the sections'
    // lowest points at c0 and c1, as cut_zmap_tile narrows them) meet the tile's columns, and
    // only above its rows' lowest section points.
    // The x-range of row k a sweep of a chain tests (without the slack): from the lines the sweep
    // before cut to those it leaves to the next.
    auto chain_strip = [](const Sweep& s, const ChainRole& role, const SectionRows& t, int k, double& lo, double& hi) {
      const bool forward = s.c1.x() > s.c0.x();
      const double behind = role.skip_behind ? s.c0.x() + t.trail(k, forward) : -detail::kInf * (forward ? 1.0 : -1.0);
      const double ahead = role.leave_ahead ? s.c1.x() + t.lead(k, forward) : detail::kInf * (forward ? 1.0 : -1.0);
      lo = forward ? behind : ahead;
      hi = forward ? ahead : behind;
    };
    auto chain_may_cut = [&](const Sweep& s, const ChainRole& role, int tu, int tv) {
      if (role.rows < 0) return true;
      const SectionRows& t = section_rows[static_cast<std::size_t>(role.rows)];
      const std::size_t tile = static_cast<std::size_t>(tu) + static_cast<std::size_t>(tiles_u_) * tv;
      const double x_lo = tiles_[tile].lo.x() - slack, x_hi = tiles_[tile].hi.x() + slack;
      const double top = tiles_[tile].hi.z();
      const int v_end = std::min(nv_, (tv + 1) * kTile);
      for (int iv = tv * kTile; iv < v_end; ++iv) {
        const int k = t.row(iv);
        if (k < 0 || (t.level && top <= s.c0.z() + t.z_low[static_cast<std::size_t>(k)])) continue;
        double lo = 0.0, hi = 0.0;
        chain_strip(s, role, t, k, lo, hi);
        if (lo <= x_hi && hi >= x_lo) return true;
      }
      return false;
    };
    auto cut_batch = [&] {
      pairs.clear();
      for (std::size_t j = 0; j < sweeps.size(); ++j) {
        const Sweep& s = sweeps[j];
        if (zmap_) {
          auto tile_range = [&](double lo, double hi, double origin, int tiles, int& a, int& b) {
            a = std::max(0, static_cast<int>(std::floor((lo - origin) / (spacing_ * kTile))));
            b = std::min(tiles - 1, static_cast<int>(std::floor((hi - origin) / (spacing_ * kTile))));
          };
          // Only tiles within the planar reach at which the sweep gets below the material's top.
          const double reach = detail::reach_below(s, material.max_W_m.z());
          if (!(reach >= 0.0)) continue;
          double x_lo = std::max(s.lo.x(), std::min(s.c0.x(), s.c1.x()) - reach);
          double x_hi = std::min(s.hi.x(), std::max(s.c0.x(), s.c1.x()) + reach);
          double y_lo = std::max(s.lo.y(), std::min(s.c0.y(), s.c1.y()) - reach);
          double y_hi = std::min(s.hi.y(), std::max(s.c0.y(), s.c1.y()) + reach);
          if (roles[j].rows >= 0) {
            // In a chain, only the rows its table can cut and the hull of their strips
            // (chain_may_cut then tests each tile's rows).
            const SectionRows& t = section_rows[static_cast<std::size_t>(roles[j].rows)];
            double strips_lo = detail::kInf, strips_hi = -detail::kInf;
            int first_row = -1, last_row = -1;
            for (int k = 0; k < static_cast<int>(t.hit.size()); ++k) {
              if (!t.hit[static_cast<std::size_t>(k)]) continue;
              double lo = 0.0, hi = 0.0;
              chain_strip(s, roles[j], t, k, lo, hi);
              strips_lo = std::min(strips_lo, lo), strips_hi = std::max(strips_hi, hi);
              if (first_row < 0) first_row = k;
              last_row = k;
            }
            if (first_row < 0) continue;
            x_lo = std::max(x_lo, strips_lo - slack), x_hi = std::min(x_hi, strips_hi + slack);
            y_lo = std::max(y_lo, origin0_.y() + (t.iv0 + first_row) * sp - slack);
            y_hi = std::min(y_hi, origin0_.y() + (t.iv0 + last_row) * sp + slack);
            if (!(x_lo <= x_hi && y_lo <= y_hi)) continue;
          }
          int u0, u1, v0, v1;
          tile_range(x_lo, x_hi, origin0_.x(), tiles_u_, u0, u1);
          tile_range(y_lo, y_hi, origin0_.y(), tiles_v_, v0, v1);
          for (int tv = v0; tv <= v1; ++tv) {
            for (int tu = u0; tu <= u1; ++tu) {
              const std::size_t t = static_cast<std::size_t>(tu) + static_cast<std::size_t>(tiles_u_) * tv;
              if (may_cut(s, tiles_[t].lo, tiles_[t].hi, true) && chain_may_cut(s, roles[j], tu, tv)) {
              pairs.emplace_back(static_cast<std::uint32_t>(t), static_cast<std::uint32_t>(j));
            }
            }
          }
        } else {
          for (std::size_t t = 0; t < tiles_.size(); ++t) {
            if (may_cut(s, tiles_[t].lo, tiles_[t].hi, false)) pairs.emplace_back(static_cast<std::uint32_t>(t), static_cast<std::uint32_t>(j));
          }
        }
      }
      // A band buffer cuts its own tiles only (every decision on a tile is the tile's own).
      if (!holds_all_tiles()) {
        std::erase_if(pairs, [&](const auto& pair) { return pair.first < band_tile_begin_ || pair.first >= band_tile_end_; });
      }
      std::sort(pairs.begin(), pairs.end());
      group_begin.clear();
      for (std::size_t k = 0; k < pairs.size(); ++k) {
        if (k == 0 || pairs[k].first != pairs[k - 1].first) group_begin.push_back(k);
      }
      group_begin.push_back(pairs.size());

      // Z-map: the lines of one tile that the sweep can lower, row by row: within the planar
      // reach where the sweep gets below the tile's highest line, ahead of the axis plane's
      // limit and, for a continuing sweep, ahead of its start; each then gets the exact cut.
      auto cut_zmap_tile = [&](const Sweep& s, const ChainRole& role, std::size_t tile, int tu, int tv, int u_end, int v_end,
                               double* tile_h, std::size_t& lowered, double& lowered_max) {
        const double z0 = origin0_.z(), top = tiles_[tile].hi.z();
        const double reach = detail::reach_below(s, top);
        if (!(reach >= 0.0)) return;
        const double dx = s.c1.x() - s.c0.x(), dy = s.c1.y() - s.c0.y();
        const bool level = s.vertical && s.c0.z() == s.c1.z();
        const bool tilted = !s.vertical && s.a.z() > 0.0;
        const bool behind = behind_is_cut(s, top);
        const double move_xy = std::hypot(s.c1.x() - s.c0.x(), s.c1.y() - s.c0.y());  // (capsule_row's, once a tile)
        const double ball_reach = s.r * s.a.z();  // ball-end: within this of c0 and c1, the ball decides
        const detail::VerticalEntry fast(s);     // tilted flat-end / bull-nose: certified entries
        detail::VerticalEntry::Warm warm;          // their warm starts along the walk
        // Tilted flat-end / bull-nose continuing with the same axis from where the last sweep left
        // it: where the bottom disc at c0 is the lowest part of the sweep (a . c0 <= a . c1), lines
        // crossing it get that disc's height as their entry, which the last sweep (holding the tool
        // at c0) already cut: they are skipped.
        const bool skip_start_disc = tilted && s.rho > 0.0 && s.continues_axis && fast.lowest_at_start();
        const SectionRows* chain_rows = role.rows >= 0 ? &section_rows[static_cast<std::size_t>(role.rows)] : nullptr;
        // Vertical ball-end changing height (3-axis finishing on slopes, plunges): the general
        // path's bound and entry, the same doubles, without its calls and generic products.
        const bool ball_ramp = detail::VerticalBallEntry::serves(s);
        const detail::VerticalBallEntry ball_entry(s);
        const double ball_exit = std::max(s.c0.z(), s.c1.z()) + s.ell + s.r - z0;  // (vertical_entry's z1)
        const double tile_x_lo = tiles_[tile].lo.x() - slack, tile_x_hi = tiles_[tile].hi.x() + slack;
        for (int iv = tv * kTile; iv < v_end; ++iv) {
          const double y = origin0_.y() + iv * sp;
          // In a chain, first the strip from the section's lowest point at c0 to the one at c1
          // (cheap, and often outside the tile's columns).
          double strip_a = -detail::kInf, strip_b = detail::kInf;
          double row_floor = -detail::kInf;  // lines no higher than this cannot be lowered (length, m)
          // Lines the section's lowest point passes over during the move: their entry is that
          // point's height (no position enters lower), the same for the whole row.
          int over_a = 0, over_b = -1;
          double over_t0 = 0.0;
          if (chain_rows) {
            const int k = chain_rows->row(iv);
            if (k < 0) continue;  // the row misses the tool, or its section lies above the material
            const std::size_t kk = static_cast<std::size_t>(k);
            if (chain_rows->level) row_floor = s.c0.z() + chain_rows->z_low[kk] - z0;
            chain_strip(s, role, *chain_rows, k, strip_a, strip_b);
            strip_a -= slack;
            strip_b += slack;
            if (strip_a > tile_x_hi || strip_b < tile_x_lo) continue;
            if (over_zone_lines_cached(s, *chain_rows, k, over_a, over_b)) over_t0 = s.c0.z() + chain_rows->z_point[kk] - z0;
          }
          double xa = 0.0, xb = 0.0;
          if (std::isfinite(strip_a) && std::isfinite(strip_b)) {
            // A sweep inside a chain: its strip, near the sections' lowest points, bounds the
            // lines (the planar reach would only drop lines its exact tests reject; three roots
            // a row and tile saved).
            xa = strip_a, xb = strip_b;
          } else if (!capsule_row(s.c0.x(), s.c0.y(), s.c1.x(), s.c1.y(), move_xy, reach + slack, y, xa, xb)) {
            continue;
          }
          if (tilted) keep_positive(s.a.y() * y - s.amin + s.a.z() * top + slack, s.a.x(), xa, xb);
          if (behind) keep_positive((y - s.c0.y()) * dy - s.c0.x() * dx + slack, dx, xa, xb);
          xa = std::max(xa, strip_a);
          xb = std::min(xb, strip_b);
          if (!(xa <= xb)) continue;
          const int ia = std::max(tu * kTile, static_cast<int>(std::ceil((xa - origin0_.x()) / sp)));
          const int ib = std::min(u_end - 1, static_cast<int>(std::floor((xb - origin0_.x()) / sp)));
          double* row = tile_h + static_cast<std::size_t>(kTile) * (iv - tv * kTile);  // == index(iu, iv)
          int skip_a = ib + 1, skip_b = ib;  // lines [skip_a, skip_b] skipped
          double sx0 = 0.0, sx1 = 0.0;
          if (skip_start_disc && fast.start_disc_row(y, slack, sx0, sx1)) {
            skip_a = static_cast<int>(std::ceil((sx0 - origin0_.x()) / sp));
            skip_b = static_cast<int>(std::floor((sx1 - origin0_.x()) / sp));
          }
          for (int iu = ia; iu <= ib; ++iu) {
            if (iu >= skip_a && iu <= skip_b) {
              iu = skip_b;
              continue;
            }
            double& h = row[iu - tu * kTile];
            if (h <= row_floor) continue;  // at or below the lowest point of the row's section
            if (iu >= over_a && iu <= over_b) {
              if (over_t0 < h) {
                lowered_max = std::max(lowered_max, h);
                h = std::max(0.0, over_t0);
                ++lowered;
              }
              continue;
            }
            const double x = origin0_.x() + iu * sp;
            double t0 = 0.0, t1 = 0.0;
            if (s.profile.active) {  // conical tools: closed form (vertical) or the general sweep
              bool hit = false;
              if (s.vertical) {
                hit = detail::vertical_entry(s, x, y, t0, t1);
                t0 -= z0;
                t1 -= z0;
              } else {
                hit = detail::line_interval(s, Eigen::Vector3d(x, y, z0), Eigen::Vector3d::UnitZ(), t0, t1);
              }
              if (!hit) continue;
            } else if (tilted && s.rho > 0.0) {  // flat-end / bull-nose, tilted: VerticalEntry decides most lines
              double z = 0.0;
              const auto result = fast.entry(x, y, z0, z0 + h, iv, iu, warm, z);
              if (result == detail::VerticalEntry::Result::above) continue;
              if (result == detail::VerticalEntry::Result::exact) {
                t0 = z - z0;  // entry exact (certified); t0 > 0, so the exit is above 0 too
                t1 = s.hi.z() - z0;
              } else {
                const Eigen::Vector3d o(x, y, z0);
                const bool hit = s.r > 0.0 ? detail::bull_interval(s, o, Eigen::Vector3d::UnitZ(), h, t0, t1)
                                           : detail::line_interval(s, o, Eigen::Vector3d::UnitZ(), t0, t1);
                if (!hit) continue;
              }
            } else if (level) {  // vertical tool, level move: the depth at the planar distance, closed form
              const double d = detail::distance_2d(x, y, s.c0.x(), s.c0.y(), s.c1.x(), s.c1.y());
              const double e = std::max(0.0, d - s.rho);
              if (e > s.r) continue;
              t0 = s.c0.z() - std::sqrt((s.r - e) * (s.r + e)) - z0;
              t1 = s.c0.z() + s.ell + s.r - z0;
            } else if (s.rho == 0.0 && s.c0.z() == s.c1.z() &&
                       std::max(std::hypot(x - s.c0.x(), y - s.c0.y()), std::hypot(x - s.c1.x(), y - s.c1.y())) <= ball_reach) {
              // Ball-end, level move, any axis: the ball's capsule gives the entry (behind_is_cut).
              const double d = detail::distance_2d(x, y, s.c0.x(), s.c0.y(), s.c1.x(), s.c1.y());
              if (d > s.r) continue;
              t0 = s.c0.z() - std::sqrt((s.r - d) * (s.r + d)) - z0;
              if (t0 >= h) continue;
              t1 = s.hi.z() - z0;
              if (t1 <= 0.0 && !detail::line_interval(s, Eigen::Vector3d(x, y, z0), Eigen::Vector3d::UnitZ(), t0, t1)) continue;
            } else if (ball_ramp) {
              if (ball_entry.cannot_lower(x, y, z0, h)) continue;
              double z = 0.0;
              if (!ball_entry.entry(x, y, z)) continue;
              t0 = z - z0;
              t1 = ball_exit;
            } else {
              const double d = detail::distance_2d(x, y, s.c0.x(), s.c0.y(), s.c1.x(), s.c1.y());
              double bound = detail::lowest_z_beyond(s, d);
              if (tilted) bound = std::max(bound, (s.amin - s.a.x() * x - s.a.y() * y) / s.a.z());
              if (bound - z0 >= h) continue;
              bool hit;
              if (s.vertical) {
                hit = detail::vertical_entry(s, x, y, t0, t1);
                t0 -= z0;
                t1 -= z0;
              } else {
                hit = detail::line_interval(s, Eigen::Vector3d(x, y, z0), Eigen::Vector3d::UnitZ(), t0, t1);
              }
              if (!hit) continue;
            }
            if (t1 > 0.0 && t0 < h) {
              lowered_max = std::max(lowered_max, h);
              h = std::max(0.0, t0);
              ++lowered;
            }
          }
        }
      };

      auto process_group = [&](std::size_t g) {
        const std::size_t tile = pairs[group_begin[g]].first;
        const int tu = static_cast<int>(tile % static_cast<std::size_t>(tiles_u_));
        const int tv = static_cast<int>(tile / static_cast<std::size_t>(tiles_u_));
        const int u_end = std::min(nu_, (tu + 1) * kTile), v_end = std::min(nv_, (tv + 1) * kTile);
        std::size_t visited = 0, lowered = 0;
        // The tile's lengths: in place (plain storage), or decoded into `scratch` and encoded
        // again after the tile's sweeps (compact storage).
        constexpr std::size_t n_tile = kTile * kTile;
        double scratch[n_tile], decoded[n_tile];
        double* tile_h = nullptr;
        if (compact_) {
          tile_lengths(tile, scratch);
          std::copy_n(scratch, n_tile, decoded);
          tile_h = scratch;
        } else {
          tile_h = &h_[(tile - band_tile_begin_) * n_tile];
        }
        const std::size_t lowered_start = lowered;
        for (std::size_t k = group_begin[g]; k < group_begin[g + 1]; ++k) {
          const Sweep& s = sweeps[pairs[k].second];
          if (!may_cut(s, tiles_[tile].lo, tiles_[tile].hi, zmap_)) continue;
          ++visited;
          const std::size_t before = lowered;
          double lowered_max = -1.0;  // the highest length lowered (the tile's bound moves only if it was the top)
          if (zmap_) {
            cut_zmap_tile(s, roles[pairs[k].second], tile, tu, tv, u_end, v_end, tile_h, lowered, lowered_max);
          } else {
            for (int iv = tv * kTile; iv < v_end; ++iv) {
              for (int iu = tu * kTile; iu < u_end; ++iu) {
                const std::size_t li = index(iu, iv);
                double& h = tile_h[li - tile * n_tile];
                double t0 = 0.0, t1 = 0.0;
                if (detail::line_interval(s, o_[li], u_[li], t0, t1) && t1 > 0.0 && t0 < h) {
                  h = std::max(0.0, t0);
                  ++lowered;
                }
              }
            }
          }
          if (lowered != before && (!zmap_ || lowered_max >= tiles_[tile].h_max)) refresh_tile(tile, tile_h);
        }
        if (compact_ && lowered != lowered_start) {
          // Encoded from the tile's base; a line's offset never rises (rounding is monotonic and
          // the old offset is a float), so a cut never adds material.
          const std::span<float> offsets = offsets_.block_or_allocate(tile, 0.0f);
          const double base = base_[tile];
          for (std::size_t k = 0; k < n_tile; ++k) {
            if (scratch[k] != decoded[k]) offsets[k] = std::min(offsets[k], static_cast<float>(scratch[k] - base));
          }
          // The bounds from the lengths as stored (see make_compact).
          tile_lengths(tile, scratch);
          refresh_tile(tile, scratch);
        }
        tiles_visited += visited;
        lines_lowered += lowered;
      };
      const std::size_t groups = group_begin.size() - 1;
      arena.execute([&] {
        tbb::parallel_for(tbb::blocked_range<std::size_t>(0, groups, 1),
                          [&](const tbb::blocked_range<std::size_t>& range) {
                            for (std::size_t g = range.begin(); g != range.end(); ++g) process_group(g);
                          });
      });
    };
    cut_batch();
    if (options.interrupted && options.interrupted(static_cast<double>(last) / static_cast<double>(segments))) {
      stats.interrupted = last < segments;
      if (stats.interrupted) {
        // The last sweep left the lines ahead of its end to the next one: the tool standing at
        // that end cuts them (a sweep of length 0).
        if (roles.back().leave_ahead) {
          const Sweep end = sweeps.back();
          sweeps.assign(1, detail::make_sweep(end.c1, end.c1, end.a, end.rho, end.r, end.ell));
          roles.assign(1, ChainRole{});
          cut_batch();
        }
        break;
      }
    }
  }
  stats.tiles_visited = tiles_visited;
  stats.lines_lowered = lines_lowered;
  return stats;
}

bool NBuffer::same_lines(const NBuffer& other) const {
  if (zmap_ != other.zmap_ || nu_ != other.nu_ || nv_ != other.nv_) return false;
  if (zmap_) return spacing_ == other.spacing_ && origin0_ == other.origin0_;
  return o_ == other.o_ && u_ == other.u_;
}

std::vector<double> difference(const NBuffer& production, const NBuffer& reference) {
  if (!production.same_lines(reference)) {
    throw std::invalid_argument("difference: the two N-buffers are not on identical lines");
  }
  if (!production.holds_all_tiles() || !reference.holds_all_tiles()) {
    throw std::invalid_argument("difference: a band buffer (gather the bands first)");
  }
  // Tile by tile in storage order, written row-major: no whole copy of either buffer.
  constexpr int n_tile = NBuffer::kTile * NBuffer::kTile;
  const int nu = production.nu(), nv = production.nv();
  std::vector<double> out(production.line_count());
  double a[n_tile], b[n_tile];
  const int tiles_u = (nu + NBuffer::kTile - 1) / NBuffer::kTile, tiles_v = (nv + NBuffer::kTile - 1) / NBuffer::kTile;
  for (int tv = 0; tv < tiles_v; ++tv) {
    for (int tu = 0; tu < tiles_u; ++tu) {
      const std::size_t tile = static_cast<std::size_t>(tu) + static_cast<std::size_t>(tiles_u) * static_cast<std::size_t>(tv);
      production.tile_lengths(tile, a);
      reference.tile_lengths(tile, b);
      const int u_end = std::min(nu, (tu + 1) * NBuffer::kTile), v_end = std::min(nv, (tv + 1) * NBuffer::kTile);
      for (int iv = tv * NBuffer::kTile; iv < v_end; ++iv) {
        for (int iu = tu * NBuffer::kTile; iu < u_end; ++iu) {
          const int k = (iu - tu * NBuffer::kTile) + NBuffer::kTile * (iv - tv * NBuffer::kTile);
          out[static_cast<std::size_t>(iu) + static_cast<std::size_t>(nu) * static_cast<std::size_t>(iv)] = a[k] - b[k];
        }
      }
    }
  }
  return out;
}

}  // namespace vmsim::removal
