#include "vmsim/removal/nbuffer.hpp"

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
}

double Tool::corner_radius() const {
  switch (type) {
    case ToolType::ball: return 0.5 * diameter_m;
    case ToolType::flat: return 0.0;
    case ToolType::bull: return corner_radius_m;
  }
  return 0.0;
}

NBuffer NBuffer::zmap(const Box& stock, double spacing_m) {
  const Eigen::Vector3d size = stock.max_W_m - stock.min_W_m;
  if (!(size.minCoeff() > 0.0) || !size.allFinite()) {
    throw InputError("stock box: min must be below max on every axis");
  }
  if (!(spacing_m > 0.0) || !std::isfinite(spacing_m)) {
    throw InputError("grid spacing " + format_double(spacing_m * 1e3) + " mm: must be > 0");
  }
  const double nx = std::floor(size.x() / spacing_m * (1.0 + 1e-12)) + 1.0;
  const double ny = std::floor(size.y() / spacing_m * (1.0 + 1e-12)) + 1.0;
  if (nx * ny > 2147483647.0) {
    throw InputError("grid spacing " + format_double(spacing_m * 1e3) + " mm gives " +
                     format_double(nx * ny) + " lines over the stock: too many");
  }
  NBuffer b;
  b.zmap_ = true;
  b.nu_ = static_cast<int>(nx);
  b.nv_ = static_cast<int>(ny);
  b.spacing_ = spacing_m;
  b.origin0_ = stock.min_W_m;
  b.tiles_u_ = (b.nu_ + kTile - 1) / kTile;
  b.tiles_v_ = (b.nv_ + kTile - 1) / kTile;
  b.h_.assign(static_cast<std::size_t>(b.tiles_u_) * b.tiles_v_ * kTile * kTile, size.z());
  b.build_tiles();
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
  for (std::size_t t = 0; t < tiles_.size(); ++t) refresh_tile(t);
}

void NBuffer::refresh_tile(std::size_t tile) {
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
      b.h_max = std::max(b.h_max, h_[s]);
      if (!zmap_) {
        const Eigen::Vector3d end = o_[s] + h_[s] * u_[s];
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
bool capsule_row(double ax, double ay, double bx, double by, double R, double y, double& x0, double& x1) {
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
  const double dx = bx - ax, dy = by - ay, len = std::hypot(dx, dy);
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
// (same axis, radii and length). Over a chain the entry of a vertical line at (x, y) is a
// convex function of the tool's position, smallest where the line passes the lowest point of
// the tool's section by the plane through the line (detail::section_lowest_x). So a sweep of a
// chain leaves the lines ahead of that point at its end to the next sweep (which holds the
// tool there, so it cuts them at least as low), and skips the lines behind that point at its
// start (the sweep before it cut them: they were not ahead of its end). Both sides use the same
// table of section points, with the slack on opposite sides, so no line falls between two
// sweeps. A sweep then tests about the strip its lowest points cross, not the footprint ahead.
bool level_along_x(const Sweep& s) {
  return s.c0.y() == s.c1.y() && s.c0.z() == s.c1.z() && s.c0.x() != s.c1.x() && !s.vertical && s.rho > 0.0 &&
         s.a.z() > 0.0 && std::abs(s.a.x()) >= detail::kSectionMinAx;
}

// Whether `next` continues `s` in a chain.
bool chains(const Sweep& s, const Sweep& next) {
  return level_along_x(s) && level_along_x(next) && s.c1 == next.c0 && s.a == next.a && s.rho == next.rho &&
         s.r == next.r && s.ell == next.ell && (s.c1.x() > s.c0.x()) == (next.c1.x() > next.c0.x());
}

// The section points of one tool pose family (axis, radii, length, core y and z) for the grid rows
// it can reach: [lo, hi] of x relative to the core point, or no hit (the row misses the tool).
struct SectionRows {
  Eigen::Vector3d a = Eigen::Vector3d::Zero();
  double rho = 0.0, r = 0.0, ell = 0.0, c_y = 0.0, c_z = 0.0;  // (c_z decides the rows: the reach)
  int iv0 = 0;
  std::vector<double> lo, hi;
  std::vector<double> z_low;    // below the section's lowest point, from the core point's z
  std::vector<double> z_point;  // that point's z where known within kSectionZError, else NaN
  std::vector<char> hit;
  bool same_family(const Sweep& s) const {
    return a == s.a && rho == s.rho && r == s.r && ell == s.ell && c_y == s.c0.y() && c_z == s.c0.z();
  }
};

// What a sweep does in its chain.
struct ChainRole {
  bool skip_behind = false;  // the sweep before it is in its chain
  bool leave_ahead = false;  // the sweep after it is in its chain
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
  const double sp = spacing_;
  const double slack = 1e-9;  // [m] widening of the row ranges against rounding: the exact test decides

  for (std::size_t first = 0; first < segments; first += batch) {
    const std::size_t last = std::min(segments, first + batch);
    sweeps.clear();
    for (std::size_t i = first; i < last; ++i) {
      const Pose& p0 = trajectory[i];
      const Pose& p1 = trajectory.size() == 1 ? trajectory[0] : trajectory[i + 1];
      detail::split_segment(tool, p0, p1, options.orientation_tolerance_m, sweeps, &material);
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
      previous = s;
      have_previous = true;
    }
    stats.sub_segments += sweeps.size();
    roles.assign(sweeps.size(), ChainRole{});
    if (zmap_ && !sweeps.empty()) {
      lookahead.clear();
      if (last < segments) {
        detail::split_segment(tool, trajectory[last], trajectory[last + 1], options.orientation_tolerance_m, lookahead,
                              &material);
      }
      section_rows_before.swap(section_rows);
      section_rows.clear();
      // The section points for the rows the sweep can reach (those within its planar reach at
      // the material's top; cut_zmap_tile asks for no others), kept from batch to batch.
      auto rows_for = [&](const Sweep& s) {
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
        SectionRows t;
        t.a = s.a, t.rho = s.rho, t.r = s.r, t.ell = s.ell, t.c_y = s.c0.y(), t.c_z = s.c0.z();
        const double reach = detail::reach_below(s, material.max_W_m.z());
        if (reach >= 0.0) {
          t.iv0 = std::max(0, static_cast<int>(std::floor((t.c_y - reach - origin0_.y()) / sp)) - 1);
          const int iv1 = std::min(nv_ - 1, static_cast<int>(std::ceil((t.c_y + reach - origin0_.y()) / sp)) + 1);
          for (int iv = t.iv0; iv <= iv1; ++iv) {
            const double y = origin0_.y() + iv * sp;  // as cut_zmap_tile computes it
            double lo = 0.0, hi = 0.0, z_low = 0.0, z_point = 0.0;
            t.hit.push_back(detail::section_lowest_x(s, y - t.c_y, lo, hi, &z_low, &z_point));
            t.lo.push_back(lo);
            t.hi.push_back(hi);
            t.z_low.push_back(z_low);
            t.z_point.push_back(z_point);
          }
        }
        section_rows.push_back(std::move(t));
        return static_cast<int>(section_rows.size() - 1);
      };
      for (std::size_t k = 0; k < sweeps.size(); ++k) {
        ChainRole& role = roles[k];
        role.skip_behind = k == 0 ? have_before && chains(last_before, sweeps[0]) : chains(sweeps[k - 1], sweeps[k]);
        role.leave_ahead = k + 1 < sweeps.size() ? chains(sweeps[k], sweeps[k + 1])
                                                 : !lookahead.empty() && chains(sweeps[k], lookahead.front());
        if (role.skip_behind || role.leave_ahead) role.rows = rows_for(sweeps[k]);
      }
    }
    // A sweep in a chain can cut a tile only where its rows' strips (between the sections'
    // lowest points at c0 and c1, as cut_zmap_tile narrows them) meet the tile's columns, and
    // only above its rows' lowest section points.
    auto chain_may_cut = [&](const Sweep& s, const ChainRole& role, int tu, int tv) {
      if (role.rows < 0) return true;
      const SectionRows& t = section_rows[static_cast<std::size_t>(role.rows)];
      const std::size_t tile = static_cast<std::size_t>(tu) + static_cast<std::size_t>(tiles_u_) * tv;
      const double x_lo = tiles_[tile].lo.x() - slack, x_hi = tiles_[tile].hi.x() + slack;
      const double top = tiles_[tile].hi.z();
      const bool forward = s.c1.x() > s.c0.x();
      const int v_end = std::min(nv_, (tv + 1) * kTile);
      for (int iv = tv * kTile; iv < v_end; ++iv) {
        const int k = iv - t.iv0;
        if (k < 0 || k >= static_cast<int>(t.hit.size())) return true;  // not in the table: no narrowing
        if (!t.hit[k] || top <= s.c0.z() + t.z_low[k]) continue;
        const double lo = forward ? (role.skip_behind ? s.c0.x() + t.lo[k] : -detail::kInf)
                                  : (role.leave_ahead ? s.c1.x() + t.lo[k] : -detail::kInf);
        const double hi = forward ? (role.leave_ahead ? s.c1.x() + t.hi[k] : detail::kInf)
                                  : (role.skip_behind ? s.c0.x() + t.hi[k] : detail::kInf);
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
          const double x_lo = std::max(s.lo.x(), std::min(s.c0.x(), s.c1.x()) - reach);
          const double x_hi = std::min(s.hi.x(), std::max(s.c0.x(), s.c1.x()) + reach);
          const double y_lo = std::max(s.lo.y(), std::min(s.c0.y(), s.c1.y()) - reach);
          const double y_hi = std::min(s.hi.y(), std::max(s.c0.y(), s.c1.y()) + reach);
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
                               std::size_t& lowered, double& lowered_max) {
        const double z0 = origin0_.z(), top = tiles_[tile].hi.z();
        const double reach = detail::reach_below(s, top);
        if (!(reach >= 0.0)) return;
        const double dx = s.c1.x() - s.c0.x(), dy = s.c1.y() - s.c0.y();
        const bool level = s.vertical && s.c0.z() == s.c1.z();
        const bool tilted = !s.vertical && s.a.z() > 0.0;
        const bool behind = behind_is_cut(s, top);
        const double ball_reach = s.r * s.a.z();  // ball-end: within this of c0 and c1, the ball decides
        const detail::VerticalEntry fast(s);     // tilted flat-end / bull-nose: certified entries
        detail::VerticalEntry::Warm warm;          // their warm starts along the walk
        // Tilted flat-end / bull-nose continuing with the same axis from where the last sweep left
        // it: where the bottom disc at c0 is the lowest part of the sweep (a . c0 <= a . c1), lines
        // crossing it get that disc's height as their entry, which the last sweep (holding the tool
        // at c0) already cut: they are skipped.
        const bool skip_start_disc = tilted && s.rho > 0.0 && s.continues_axis && fast.lowest_at_start();
        const SectionRows* chain_rows = role.rows >= 0 ? &section_rows[static_cast<std::size_t>(role.rows)] : nullptr;
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
            const int k = iv - chain_rows->iv0;
            if (k >= 0 && k < static_cast<int>(chain_rows->hit.size())) {
              if (!chain_rows->hit[k]) continue;  // the row misses the tool
              row_floor = s.c0.z() + chain_rows->z_low[k] - z0;
              const double lo = chain_rows->lo[k], hi = chain_rows->hi[k];
              if (dx > 0.0) {
                if (role.skip_behind) strip_a = s.c0.x() + lo - slack;
                if (role.leave_ahead) strip_b = s.c1.x() + hi + slack;
              } else {
                if (role.leave_ahead) strip_a = s.c1.x() + lo - slack;
                if (role.skip_behind) strip_b = s.c0.x() + hi + slack;
              }
              if (strip_a > tile_x_hi || strip_b < tile_x_lo) continue;
              if (std::isfinite(chain_rows->z_point[k])) {
                const double x_start = std::min(s.c0.x(), s.c1.x()), x_end = std::max(s.c0.x(), s.c1.x());
                over_a = static_cast<int>(std::ceil((x_start + hi + slack - origin0_.x()) / sp));
                over_b = static_cast<int>(std::floor((x_end + lo - slack - origin0_.x()) / sp));
                over_t0 = s.c0.z() + chain_rows->z_point[k] - z0;
              }
            }
          }
          double xa = 0.0, xb = 0.0;
          if (!capsule_row(s.c0.x(), s.c0.y(), s.c1.x(), s.c1.y(), reach + slack, y, xa, xb)) continue;
          if (tilted) keep_positive(s.a.y() * y - s.amin + s.a.z() * top + slack, s.a.x(), xa, xb);
          if (behind) keep_positive((y - s.c0.y()) * dy - s.c0.x() * dx + slack, dx, xa, xb);
          xa = std::max(xa, strip_a);
          xb = std::min(xb, strip_b);
          if (!(xa <= xb)) continue;
          const int ia = std::max(tu * kTile, static_cast<int>(std::ceil((xa - origin0_.x()) / sp)));
          const int ib = std::min(u_end - 1, static_cast<int>(std::floor((xb - origin0_.x()) / sp)));
          double* row = &h_[tile * kTile * kTile + static_cast<std::size_t>(kTile) * (iv - tv * kTile)];  // == index(iu, iv)
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
            if (tilted && s.rho > 0.0) {  // flat-end / bull-nose, tilted: VerticalEntry decides most lines
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
        for (std::size_t k = group_begin[g]; k < group_begin[g + 1]; ++k) {
          const Sweep& s = sweeps[pairs[k].second];
          if (!may_cut(s, tiles_[tile].lo, tiles_[tile].hi, zmap_)) continue;
          ++visited;
          const std::size_t before = lowered;
          double lowered_max = -1.0;  // the highest length lowered (the tile's bound moves only if it was the top)
          if (zmap_) {
            cut_zmap_tile(s, roles[pairs[k].second], tile, tu, tv, u_end, v_end, lowered, lowered_max);
          } else {
            for (int iv = tv * kTile; iv < v_end; ++iv) {
              for (int iu = tu * kTile; iu < u_end; ++iu) {
                const std::size_t li = index(iu, iv);
                double& h = h_[li];
                double t0 = 0.0, t1 = 0.0;
                if (detail::line_interval(s, o_[li], u_[li], t0, t1) && t1 > 0.0 && t0 < h) {
                  h = std::max(0.0, t0);
                  ++lowered;
                }
              }
            }
          }
          if (lowered != before && (!zmap_ || lowered_max >= tiles_[tile].h_max)) refresh_tile(tile);
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
  std::vector<double> a = production.lengths();
  const std::vector<double> b = reference.lengths();
  for (std::size_t i = 0; i < a.size(); ++i) a[i] -= b[i];
  return a;
}

}  // namespace vmsim::removal
