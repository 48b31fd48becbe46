#include "vmsim/removal/nbuffer.hpp"

#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <stdexcept>
#include <string>

#include "sweep.hpp"
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
  for (int iv = tv * kTile; iv < v_end; ++iv) {
    for (int iu = tu * kTile; iu < u_end; ++iu) {
      const std::size_t s = index(iu, iv);
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
  auto point_box = [&](double px, double py) {
    const double dx = std::max({x0 - px, 0.0, px - x1}), dy = std::max({y0 - py, 0.0, py - y1});
    return std::sqrt(dx * dx + dy * dy);
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
  return std::min({point_box(ax, ay), point_box(bx, by),
                   detail::distance_2d(x0, y0, ax, ay, bx, by), detail::distance_2d(x1, y0, ax, ay, bx, by),
                   detail::distance_2d(x0, y1, ax, ay, bx, by), detail::distance_2d(x1, y1, ax, ay, bx, by)});
}

}  // namespace

// Whether the sweep might lower a line of the tile (false: it cannot).
static bool may_cut(const Sweep& s, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, bool zmap) {
  for (int i = 0; i < 3; ++i) {
    if (s.hi[i] < lo[i] || s.lo[i] > hi[i]) return false;
  }
  if (zmap && s.vertical) {
    const double d = box_segment_distance(lo.x(), lo.y(), hi.x(), hi.y(), s.c0.x(), s.c0.y(), s.c1.x(), s.c1.y());
    const double reach = s.rho + s.r;
    if (d > reach) return false;
    const double e = std::max(0.0, d - s.rho);
    const double lowest = std::min(s.c0.z(), s.c1.z()) - std::sqrt(std::max(0.0, s.r * s.r - e * e));
    if (lowest >= hi.z()) return false;
  }
  return true;
}

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

  for (std::size_t first = 0; first < segments; first += batch) {
    const std::size_t last = std::min(segments, first + batch);
    sweeps.clear();
    for (std::size_t i = first; i < last; ++i) {
      const Pose& p0 = trajectory[i];
      const Pose& p1 = trajectory.size() == 1 ? trajectory[0] : trajectory[i + 1];
      detail::split_segment(tool, p0, p1, options.orientation_tolerance_m, sweeps);
    }
    stats.sub_segments += sweeps.size();
    pairs.clear();
    for (std::size_t j = 0; j < sweeps.size(); ++j) {
      const Sweep& s = sweeps[j];
      if (zmap_) {
        auto tile_range = [&](double lo, double hi, double origin, int tiles, int& a, int& b) {
          a = std::max(0, static_cast<int>(std::floor((lo - origin) / (spacing_ * kTile))));
          b = std::min(tiles - 1, static_cast<int>(std::floor((hi - origin) / (spacing_ * kTile))));
        };
        int u0, u1, v0, v1;
        tile_range(s.lo.x(), s.hi.x(), origin0_.x(), tiles_u_, u0, u1);
        tile_range(s.lo.y(), s.hi.y(), origin0_.y(), tiles_v_, v0, v1);
        for (int tv = v0; tv <= v1; ++tv) {
          for (int tu = u0; tu <= u1; ++tu) {
            const std::size_t t = static_cast<std::size_t>(tu) + static_cast<std::size_t>(tiles_u_) * tv;
            if (may_cut(s, tiles_[t].lo, tiles_[t].hi, true)) pairs.emplace_back(static_cast<std::uint32_t>(t), static_cast<std::uint32_t>(j));
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

    auto process_group = [&](std::size_t g) {
      const std::size_t tile = pairs[group_begin[g]].first;
      const int tu = static_cast<int>(tile % static_cast<std::size_t>(tiles_u_));
      const int tv = static_cast<int>(tile / static_cast<std::size_t>(tiles_u_));
      const int u_end = std::min(nu_, (tu + 1) * kTile), v_end = std::min(nv_, (tv + 1) * kTile);
      std::size_t visited = 0, lowered = 0;
      bool changed = false;
      for (std::size_t k = group_begin[g]; k < group_begin[g + 1]; ++k) {
        const Sweep& s = sweeps[pairs[k].second];
        if (changed) {
          refresh_tile(tile);
          changed = false;
        }
        if (!may_cut(s, tiles_[tile].lo, tiles_[tile].hi, zmap_)) continue;
        ++visited;
        for (int iv = tv * kTile; iv < v_end; ++iv) {
          for (int iu = tu * kTile; iu < u_end; ++iu) {
            const std::size_t li = index(iu, iv);
            double& h = h_[li];
            double t0 = 0.0, t1 = 0.0;
            bool hit;
            if (zmap_) {
              const double x = origin0_.x() + iu * spacing_, y = origin0_.y() + iv * spacing_;
              if (s.vertical) {
                // Cheap bound first: the lowest the sweep can reach at this line's distance.
                const double d = detail::distance_2d(x, y, s.c0.x(), s.c0.y(), s.c1.x(), s.c1.y());
                const double e = std::max(0.0, d - s.rho);
                if (e > s.r) continue;
                if (std::min(s.c0.z(), s.c1.z()) - std::sqrt((s.r - e) * (s.r + e)) - origin0_.z() >= h) continue;
                hit = detail::vertical_entry(s, x, y, t0, t1);
                t0 -= origin0_.z();
                t1 -= origin0_.z();
              } else {
                hit = detail::line_interval(s, Eigen::Vector3d(x, y, origin0_.z()), Eigen::Vector3d::UnitZ(), t0, t1);
              }
            } else {
              hit = detail::line_interval(s, o_[li], u_[li], t0, t1);
            }
            if (hit && t1 > 0.0 && t0 < h) {
              h = std::max(0.0, t0);
              ++lowered;
              changed = true;
            }
          }
        }
      }
      if (changed) refresh_tile(tile);
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
    if (options.interrupted && options.interrupted(static_cast<double>(last) / static_cast<double>(segments))) {
      stats.interrupted = last < segments;
      if (stats.interrupted) break;
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
