// The level-set model (level_set.hpp). The only file of the project that includes OpenVDB.
#include "vmsim/removal/level_set.hpp"

#include <openvdb/openvdb.h>
#include <openvdb/io/Stream.h>
#include <openvdb/tools/Clip.h>
#include <openvdb/tools/Interpolation.h>
#include <openvdb/tools/MeshToVolume.h>
#include <openvdb/tools/Prune.h>
#include <openvdb/tools/VolumeToMesh.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <mutex>
#include <sstream>
#include <unordered_map>

#include "level_set_sweep.hpp"
#include "sweep.hpp"
#include "vmsim/common/errors.hpp"
#include "vmsim/common/files.hpp"

namespace vmsim::removal {
namespace {

using openvdb::Coord;
using openvdb::FloatGrid;
using openvdb::FloatTree;
using LeafT = FloatTree::LeafNodeType;
using InternalLowerT = FloatTree::RootNodeType::ChildNodeType::ChildNodeType;
constexpr int kLowerSpan = InternalLowerT::DIM;  // 128 voxels
constexpr int kLeafSpan = LeafT::DIM;            // 8 voxels
constexpr double kSqrt3 = 1.7320508075688772;

void initialize_openvdb() {
  static std::once_flag once;
  std::call_once(once, [] { openvdb::initialize(); });
}

openvdb::Vec3d vdb(const Eigen::Vector3d& v) { return openvdb::Vec3d(v.x(), v.y(), v.z()); }
Eigen::Vector3d eigen(const openvdb::Vec3d& v) { return Eigen::Vector3d(v.x(), v.y(), v.z()); }

bool contains(const Box& box, const Eigen::Vector3d& p) {
  return (p.array() >= box.min_W_m.array()).all() && (p.array() <= box.max_W_m.array()).all();
}

std::string mm_text(const Eigen::Vector3d& v) {
  return "(" + format_double(v.x() * 1e3) + ", " + format_double(v.y() * 1e3) + ", " + format_double(v.z() * 1e3) + ") mm";
}

}  // namespace

void LevelSetOptions::validate() const {
  auto positive = [](const std::string& field, double value) {
    if (!std::isfinite(value) || value <= 0.0) {
      throw InputError("level set: " + field + " = " + format_double(value * 1e3) + " mm: must be > 0");
    }
  };
  positive("voxel", voxel_m);
  if (!std::isfinite(half_width_voxels) || half_width_voxels < 2.0) {
    throw InputError("level set: half width = " + format_double(half_width_voxels) + " voxels: must be >= 2");
  }
  for (std::size_t i = 0; i < regions.size(); ++i) {
    positive("regions[" + std::to_string(i) + "].voxel", regions[i].voxel_m);
    const Eigen::Vector3d size = regions[i].box_W_m.max_W_m - regions[i].box_W_m.min_W_m;
    if (!(size.minCoeff() > 0.0) || !size.allFinite()) {
      throw InputError("level set: regions[" + std::to_string(i) + "]: empty box " + mm_text(regions[i].box_W_m.min_W_m) +
                       " .. " + mm_text(regions[i].box_W_m.max_W_m));
    }
  }
}

// One grid: the coarse one over the stock (index 0) or a fine one over a region.
struct GridLevel {
  FloatGrid::Ptr grid;
  Box box;                     // where this grid is used
  double voxel = 0.0;
  openvdb::CoordBBox material;  // index box outside which there is no material
};

struct LevelSetStock::Impl {
  std::vector<GridLevel> levels;
  double half_width = 3.0;

  // The finest grid whose box holds p (grid 0 otherwise).
  std::size_t owner(const Eigen::Vector3d& p) const {
    std::size_t best = 0;
    for (std::size_t i = 1; i < levels.size(); ++i) {
      if (contains(levels[i].box, p) && levels[i].voxel < levels[best].voxel) best = i;
    }
    return best;
  }
};

LevelSetStock::LevelSetStock(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
LevelSetStock::LevelSetStock(LevelSetStock&&) noexcept = default;
LevelSetStock& LevelSetStock::operator=(LevelSetStock&&) noexcept = default;
LevelSetStock::~LevelSetStock() = default;

LevelSetStock LevelSetStock::copy() const {
  auto impl = std::make_unique<Impl>(*impl_);
  for (auto& level : impl->levels) level.grid = level.grid->deepCopy();
  return LevelSetStock(std::move(impl));
}

namespace {

openvdb::CoordBBox index_box(const Box& box, double voxel, double margin_voxels) {
  const Eigen::Vector3d lo = box.min_W_m / voxel, hi = box.max_W_m / voxel;
  const int m = static_cast<int>(std::ceil(margin_voxels));
  return openvdb::CoordBBox(Coord(static_cast<int>(std::floor(lo.x())) - m, static_cast<int>(std::floor(lo.y())) - m,
                                  static_cast<int>(std::floor(lo.z())) - m),
                            Coord(static_cast<int>(std::ceil(hi.x())) + m, static_cast<int>(std::ceil(hi.y())) + m,
                                  static_cast<int>(std::ceil(hi.z())) + m));
}

void check_index_range(const Box& box, double voxel, const std::string& what) {
  const double extent = std::max(box.max_W_m.cwiseAbs().maxCoeff(), box.min_W_m.cwiseAbs().maxCoeff());
  if (extent / voxel > 1e9) {
    throw InputError("level set: " + what + ": " + format_double(voxel * 1e3) + " mm voxels give indices beyond 1e9");
  }
}

Box intersect(const Box& a, const Box& b) {
  return Box{a.min_W_m.cwiseMax(b.min_W_m), a.max_W_m.cwiseMin(b.max_W_m)};
}

Box grow(const Box& b, double by) {
  return Box{b.min_W_m.array() - by, b.max_W_m.array() + by};
}

bool empty(const Box& b) { return !((b.max_W_m - b.min_W_m).minCoeff() > 0.0); }

}  // namespace

LevelSetStock LevelSetStock::box(const Box& stock, const LevelSetOptions& options) {
  options.validate();
  if (empty(stock) || !stock.min_W_m.allFinite() || !stock.max_W_m.allFinite()) {
    throw InputError("level set: empty stock box " + mm_text(stock.min_W_m) + " .. " + mm_text(stock.max_W_m));
  }
  initialize_openvdb();
  auto impl = std::make_unique<Impl>();
  impl->half_width = options.half_width_voxels;
  auto add = [&](const Box& where, const Box& solid, double voxel, const std::string& what, const Box* clip_to) {
    check_index_range(solid, voxel, what);
    auto xform = openvdb::math::Transform::createLinearTransform(voxel);
    const openvdb::BBoxd bbox(vdb(solid.min_W_m), vdb(solid.max_W_m));
    FloatGrid::Ptr grid = openvdb::tools::createLevelSetBox<FloatGrid>(bbox, *xform, options.half_width_voxels);
    // Drop the band of the clipping faces (they lie beyond clip_to): only the stock's own faces
    // inside the region take memory. Beyond clip_to the grid reads "outside"; it is not used there.
    if (clip_to) grid = openvdb::tools::clip(*grid, openvdb::BBoxd(vdb(clip_to->min_W_m), vdb(clip_to->max_W_m)));
    grid->setGridClass(openvdb::GRID_LEVEL_SET);
    impl->levels.push_back(GridLevel{grid, where, voxel, index_box(solid, voxel, options.half_width_voxels + 1.0)});
  };
  add(stock, stock, options.voxel_m, "stock", nullptr);
  for (std::size_t i = 0; i < options.regions.size(); ++i) {
    const LevelSetRegion& region = options.regions[i];
    // The fine grid holds the stock clipped to the region grown by twice its band, then keeps
    // only the region grown by one band and a bit: the clipping faces' band is dropped.
    const double margin = (options.half_width_voxels + 2.0) * region.voxel_m;
    const Box keep = grow(region.box_W_m, margin);
    const Box solid = intersect(stock, grow(region.box_W_m, 2.0 * margin));
    if (empty(solid)) {
      throw InputError("level set: regions[" + std::to_string(i) + "] " + mm_text(region.box_W_m.min_W_m) + " .. " +
                       mm_text(region.box_W_m.max_W_m) + " does not meet the stock");
    }
    add(region.box_W_m, solid, region.voxel_m, "regions[" + std::to_string(i) + "]", &keep);
  }
  return LevelSetStock(std::move(impl));
}

LevelSetStock LevelSetStock::mesh(const TriangleMesh& closed_mesh, const LevelSetOptions& options) {
  options.validate();
  if (closed_mesh.triangles.empty() || closed_mesh.vertices_m.empty()) throw InputError("level set: empty stock mesh");
  initialize_openvdb();
  std::vector<openvdb::Vec3s> points;
  points.reserve(closed_mesh.vertices_m.size());
  Box bounds{Eigen::Vector3d::Constant(detail::kInf), Eigen::Vector3d::Constant(-detail::kInf)};
  for (std::size_t i = 0; i < closed_mesh.vertices_m.size(); ++i) {
    const Eigen::Vector3d& v = closed_mesh.vertices_m[i];
    if (!v.allFinite()) throw InputError("level set: stock mesh vertex " + std::to_string(i) + " is not finite");
    points.emplace_back(static_cast<float>(v.x()), static_cast<float>(v.y()), static_cast<float>(v.z()));
    bounds.min_W_m = bounds.min_W_m.cwiseMin(v);
    bounds.max_W_m = bounds.max_W_m.cwiseMax(v);
  }
  std::vector<openvdb::Vec3I> triangles;
  triangles.reserve(closed_mesh.triangles.size());
  const int n = static_cast<int>(points.size());
  for (std::size_t i = 0; i < closed_mesh.triangles.size(); ++i) {
    const auto& t = closed_mesh.triangles[i];
    for (int k : t) {
      if (k < 0 || k >= n) {
        throw InputError("level set: stock mesh triangle " + std::to_string(i) + " has vertex index " +
                         std::to_string(k) + " (vertices: " + std::to_string(n) + ")");
      }
    }
    triangles.emplace_back(static_cast<unsigned>(t[0]), static_cast<unsigned>(t[1]), static_cast<unsigned>(t[2]));
  }
  if (empty(bounds)) throw InputError("level set: the stock mesh is flat (no volume)");
  auto impl = std::make_unique<Impl>();
  impl->half_width = options.half_width_voxels;
  auto add = [&](const Box& where, double voxel, const Box* clip_to, const std::string& what) {
    check_index_range(bounds, voxel, what);
    auto xform = openvdb::math::Transform::createLinearTransform(voxel);
    FloatGrid::Ptr grid = openvdb::tools::meshToLevelSet<FloatGrid>(*xform, points, triangles,
                                                                    static_cast<float>(options.half_width_voxels));
    Box solid = bounds;
    if (clip_to) {
      solid = intersect(bounds, *clip_to);
      grid = openvdb::tools::clip(*grid, openvdb::BBoxd(vdb(clip_to->min_W_m), vdb(clip_to->max_W_m)));
    }
    grid->setGridClass(openvdb::GRID_LEVEL_SET);
    impl->levels.push_back(GridLevel{grid, where, voxel, index_box(solid, voxel, options.half_width_voxels + 1.0)});
  };
  add(bounds, options.voxel_m, nullptr, "stock");
  for (std::size_t i = 0; i < options.regions.size(); ++i) {
    const LevelSetRegion& region = options.regions[i];
    const Box clip_to = grow(region.box_W_m, (options.half_width_voxels + 2.0) * region.voxel_m);
    if (empty(intersect(bounds, clip_to))) {
      throw InputError("level set: regions[" + std::to_string(i) + "] does not meet the stock mesh");
    }
    add(region.box_W_m, region.voxel_m, &clip_to, "regions[" + std::to_string(i) + "]");
  }
  return LevelSetStock(std::move(impl));
}

// ---------------------------------------------------------------------------------------------
// The cut.

namespace {

struct Piece {
  detail::SweepDistance sdf;
  bool start_covered;  // the previous piece ends with this piece's start placement
};

struct LeafTask {
  Coord origin;
  LeafT* leaf = nullptr;
  std::vector<std::uint32_t> pieces;
};

struct Counters {
  std::atomic<std::size_t> leaf_visits{0}, evaluated{0}, changed{0};
};

// Finds the leaves a batch of pieces can change in one grid (serial; creates the leaves).
class Planner {
 public:
  Planner(GridLevel& level, double band) : level_(level), acc_(level.grid->getAccessor()), band_(band), vox_(level.voxel) {}

  void add_piece(const Piece& piece, std::uint32_t index) {
    const double margin = band_ + 2.0 * vox_;
    openvdb::CoordBBox range(
        Coord(static_cast<int>(std::floor((piece.sdf.lo.x() - margin) / vox_)),
              static_cast<int>(std::floor((piece.sdf.lo.y() - margin) / vox_)),
              static_cast<int>(std::floor((piece.sdf.lo.z() - margin) / vox_))),
        Coord(static_cast<int>(std::ceil((piece.sdf.hi.x() + margin) / vox_)),
              static_cast<int>(std::ceil((piece.sdf.hi.y() + margin) / vox_)),
              static_cast<int>(std::ceil((piece.sdf.hi.z() + margin) / vox_))));
    range.intersect(level_.material);
    if (range.empty()) return;
    range_ = range;
    piece_ = &piece;
    index_ = index;
    const Coord lo = range.min() & ~(kLowerSpan - 1);
    for (int x = lo.x(); x <= range.max().x(); x += kLowerSpan) {
      for (int y = lo.y(); y <= range.max().y(); y += kLowerSpan) {
        for (int z = lo.z(); z <= range.max().z(); z += kLowerSpan) visit(Coord(x, y, z), kLowerSpan);
      }
    }
  }

  std::vector<LeafTask>& tasks() { return tasks_; }

  // Creates the leaves (interior tiles become leaves of -band values).
  void touch_leaves() {
    for (auto& task : tasks_) task.leaf = acc_.touchLeaf(task.origin);
  }

 private:
  void visit(const Coord& origin, int size) {
    const openvdb::CoordBBox box(origin, origin.offsetBy(size - 1));
    if (!box.hasOverlap(range_)) return;
    const detail::SweepDistance& s = piece_->sdf;
    const double half = 0.5 * (size - 1);
    const Eigen::Vector3d lo(origin.x() * vox_, origin.y() * vox_, origin.z() * vox_);
    const Eigen::Vector3d hi = lo.array() + (size - 1) * vox_;
    const Eigen::Vector3d centre = 0.5 * (lo + hi);
    const double hd = kSqrt3 * half * vox_;
    if (s(centre) - hd >= band_) return;  // no voxel of the box comes within the band of the sweep
    if (piece_->start_covered && s.start_core(centre) > hd && s.behind_start(lo, hi)) return;
    if (size == kLowerSpan) {
      if (acc_.template probeConstNode<InternalLowerT>(origin) == nullptr && acc_.getValue(origin) > 0.0f) return;  // empty
    }
    if (size == kLeafSpan) {
      if (!acc_.probeConstLeaf(origin) && acc_.getValue(origin) > 0.0f) return;  // no material
      auto [it, inserted] = task_of_.try_emplace(origin, tasks_.size());
      if (inserted) tasks_.push_back(LeafTask{origin, nullptr, {}});
      tasks_[it->second].pieces.push_back(index_);
      return;
    }
    const int h = size / 2;
    for (int i = 0; i < 8; ++i) visit(origin.offsetBy(i & 1 ? h : 0, i & 2 ? h : 0, i & 4 ? h : 0), h);
  }

  struct CoordHash {
    std::size_t operator()(const Coord& c) const noexcept {
      return static_cast<std::size_t>(c.x()) * 73856093u ^ static_cast<std::size_t>(c.y()) * 19349663u ^
             static_cast<std::size_t>(c.z()) * 83492791u;
    }
  };
  GridLevel& level_;
  FloatGrid::Accessor acc_;
  double band_, vox_;
  openvdb::CoordBBox range_;
  const Piece* piece_ = nullptr;
  std::uint32_t index_ = 0;
  std::vector<LeafTask> tasks_;
  std::unordered_map<Coord, std::size_t, CoordHash> task_of_;
};

// phi <- max(phi, -phi_sweep) on one leaf for its pieces, in 4^3 sub-blocks culled like the leaves.
void cut_leaf(const LeafTask& task, const std::vector<Piece>& pieces, double vox, float band, Counters& counters) {
  LeafT& leaf = *task.leaf;
  float* values = leaf.buffer().data();
  std::size_t evaluated = 0, changed = 0;
  constexpr int kSub = 4;
  const double hd = kSqrt3 * 0.5 * (kSub - 1) * vox;
  // phi <- max(phi, nv); beyond the band: the background, inactive.
  auto raise = [&](openvdb::Index n, double nv) {
    if (nv <= values[n]) return;
    ++changed;
    if (nv >= band) {
      values[n] = band;
      leaf.setValueOff(n);
    } else {
      values[n] = static_cast<float>(nv);
      leaf.setValueOn(n);
    }
  };
  for (std::uint32_t index : task.pieces) {
    const Piece& piece = pieces[index];
    const detail::SweepDistance& s = piece.sdf;
    for (int b = 0; b < 8; ++b) {
      const Coord so = task.origin.offsetBy(b & 1 ? kSub : 0, b & 2 ? kSub : 0, b & 4 ? kSub : 0);
      const Eigen::Vector3d lo(so.x() * vox, so.y() * vox, so.z() * vox);
      const Eigen::Vector3d hi = lo.array() + (kSub - 1) * vox;
      const Eigen::Vector3d centre = 0.5 * (lo + hi);
      const double dc = s(centre);
      if (dc - hd >= band) continue;
      if (piece.start_covered && s.start_core(centre) > hd && s.behind_start(lo, hi)) continue;
      const bool all_cut = dc + hd <= -band;  // every voxel deeper in the sweep than the band
      if (!all_cut && s.kind == detail::SweepDistance::Kind::prism) {
        // Closed form in the sweep's frame, stepped from voxel to voxel. Where u <= 0 the
        // nearest placement is the start: skipped when the previous piece ends there.
        const Eigen::Vector3d q = lo - s.c0;
        const Eigen::Vector3d su = vox * s.e1, sv = vox * s.a, sw = vox * s.e3;
        const double u0 = q.dot(s.e1), v0 = q.dot(s.a), w0 = q.dot(s.e3);
        for (int i = 0; i < kSub; ++i) {
          for (int j = 0; j < kSub; ++j) {
            const openvdb::Index row = LeafT::coordToOffset(so.offsetBy(i, j, 0));
            double u = u0 + i * su.x() + j * su.y(), v = v0 + i * sv.x() + j * sv.y(), w = w0 + i * sw.x() + j * sw.y();
            for (int k = 0; k < kSub; ++k, u += su.z(), v += sv.z(), w += sw.z()) {
              if (piece.start_covered && u <= 0.0) continue;
              const double nv = -s.prism(u, v, w);
              ++evaluated;
              const openvdb::Index n = row + static_cast<openvdb::Index>(k);
              raise(n, nv);
            }
          }
        }
        continue;
      }
      for (int i = 0; i < kSub; ++i) {
        for (int j = 0; j < kSub; ++j) {
          for (int k = 0; k < kSub; ++k) {
            const Coord c = so.offsetBy(i, j, k);
            const openvdb::Index n = LeafT::coordToOffset(c);
            double nv = band;
            if (!all_cut) {
              nv = -s(Eigen::Vector3d(c.x() * vox, c.y() * vox, c.z() * vox));
              ++evaluated;
            }
            raise(n, nv);
          }
        }
      }
    }
  }
  counters.leaf_visits += task.pieces.size();
  counters.evaluated += evaluated;
  counters.changed += changed;
}

}  // namespace

LevelSetCutStatistics LevelSetStock::cut(const Tool& tool, std::span<const Pose> trajectory, const LevelSetCutOptions& options) {
  tool.validate();
  for (std::size_t i = 0; i < trajectory.size(); ++i) {
    if (!(trajectory[i].axis_W.norm() > 0.0) || !trajectory[i].axis_W.allFinite() || !trajectory[i].tip_W_m.allFinite()) {
      throw InputError("trajectory sample " + std::to_string(i) + ": zero or non-finite tool axis or tip");
    }
  }
  if (!(options.orientation_tolerance_m > 0.0)) throw InputError("orientation tolerance must be > 0");
  if (options.batch_segments == 0) throw InputError("level set: batch_segments must be > 0");
  LevelSetCutStatistics stats;
  stats.segments = trajectory.size() <= 1 ? trajectory.size() : trajectory.size() - 1;
  if (trajectory.empty()) return stats;

  double finest = impl_->levels[0].voxel;
  for (const auto& level : impl_->levels) finest = std::min(finest, level.voxel);
  const double golden_tolerance = 1e-3 * finest;
  // Sub-steps at a quarter of the tolerance: skipping a start placement covered to within 2.5
  // sub-step tolerances (below; consecutive sub-steps are 2 apart) keeps the total under it.
  const double sub_tolerance = options.orientation_tolerance_m / 4.0;
  Box material{Eigen::Vector3d::Constant(detail::kInf), Eigen::Vector3d::Constant(-detail::kInf)};
  for (const auto& level : impl_->levels) {
    const openvdb::Vec3d lo = level.material.min().asVec3d() * level.voxel, hi = level.material.max().asVec3d() * level.voxel;
    material.min_W_m = material.min_W_m.cwiseMin(eigen(lo));
    material.max_W_m = material.max_W_m.cwiseMax(eigen(hi));
  }

  tbb::task_arena arena(options.threads > 0 ? options.threads : tbb::task_arena::automatic);
  Counters counters;
  std::vector<detail::Sweep> split;
  std::vector<Piece> pieces;
  bool have_previous = false;
  detail::Sweep previous;
  std::size_t segment = 0;
  auto run_batch = [&] {
    for (GridLevel& level : impl_->levels) {
      // The background (the value beyond the band), exactly: values set to it must not differ.
      const float band = level.grid->background();
      Planner planner(level, band);
      for (std::uint32_t i = 0; i < pieces.size(); ++i) planner.add_piece(pieces[i], i);
      planner.touch_leaves();
      const auto& tasks = planner.tasks();
      arena.execute([&] {
        tbb::parallel_for(tbb::blocked_range<std::size_t>(0, tasks.size(), 4), [&](const tbb::blocked_range<std::size_t>& r) {
          for (std::size_t t = r.begin(); t != r.end(); ++t) {
            cut_leaf(tasks[t], pieces, level.voxel, band, counters);
          }
        });
      });
    }
    stats.sub_segments += pieces.size();
    pieces.clear();
  };
  const std::size_t n_segments = std::max<std::size_t>(1, stats.segments);
  for (segment = 0; segment < n_segments; ++segment) {
    const Pose& p0 = trajectory[segment];
    const Pose& p1 = trajectory.size() > 1 ? trajectory[segment + 1] : trajectory[segment];
    split.clear();
    detail::split_segment(tool, p0, p1, sub_tolerance, split, &material);
    for (const detail::Sweep& s : split) {
      // The previous piece ends with this piece's start placement, to within 2.5 sub-step
      // tolerances where the axis turns (both are that close to the true tool there): the part
      // of this piece nearest to its start is then skipped (exactly when the axis is constant).
      const double moved = have_previous ? (previous.c1 - s.c0).norm() +
                                               std::hypot(std::max(previous.ell, s.ell), s.rho) * (previous.a - s.a).norm()
                                         : detail::kInf;
      // (Not for conical tools: behind_start reasons on the Disc (+) Segment core.)
      const bool covered = moved <= 2.5 * sub_tolerance && !s.profile.active;
      pieces.push_back(Piece{detail::SweepDistance(s, golden_tolerance), covered});
      previous = s;
      have_previous = true;
    }
    if (pieces.size() >= options.batch_segments || segment + 1 == n_segments) {
      run_batch();
      if (options.interrupted && options.interrupted(static_cast<double>(segment + 1) / static_cast<double>(n_segments)) &&
          segment + 1 < n_segments) {
        stats.interrupted = true;
        break;
      }
    }
  }
  // Leaves that became uniform (all outside, or interior leaves that nothing reached) become tiles.
  arena.execute([&] {
    for (GridLevel& level : impl_->levels) openvdb::tools::pruneLevelSet(level.grid->tree());
  });
  stats.leaf_visits = counters.leaf_visits;
  stats.voxels_evaluated = counters.evaluated;
  stats.voxels_changed = counters.changed;
  return stats;
}

// ---------------------------------------------------------------------------------------------
// Queries and outputs.

namespace {

template <class Sampler>
double sample(const GridLevel& level, const Eigen::Vector3d& p) {
  openvdb::tools::GridSampler<FloatGrid, Sampler> sampler(*level.grid);
  return static_cast<double>(sampler.wsSample(vdb(p)));
}

}  // namespace

double LevelSetStock::signed_distance(const Eigen::Vector3d& p_W_m, Interpolation interpolation) const {
  const GridLevel& level = impl_->levels[impl_->owner(p_W_m)];
  return interpolation == Interpolation::trilinear ? sample<openvdb::tools::BoxSampler>(level, p_W_m)
                                                   : sample<openvdb::tools::QuadraticSampler>(level, p_W_m);
}

std::vector<double> LevelSetStock::signed_distances(std::span<const Eigen::Vector3d> points_W_m,
                                                    Interpolation interpolation) const {
  std::vector<double> out(points_W_m.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, points_W_m.size(), 1024), [&](const tbb::blocked_range<std::size_t>& r) {
    // One accessor-based sampler per grid and chunk (accessors cache the tree path).
    std::vector<FloatGrid::ConstAccessor> accessors;
    for (const auto& level : impl_->levels) accessors.push_back(level.grid->getConstAccessor());
    for (std::size_t i = r.begin(); i != r.end(); ++i) {
      const std::size_t g = impl_->owner(points_W_m[i]);
      const auto& xform = impl_->levels[g].grid->transform();
      if (interpolation == Interpolation::trilinear) {
        openvdb::tools::GridSampler<FloatGrid::ConstAccessor, openvdb::tools::BoxSampler> s(accessors[g], xform);
        out[i] = s.wsSample(vdb(points_W_m[i]));
      } else {
        openvdb::tools::GridSampler<FloatGrid::ConstAccessor, openvdb::tools::QuadraticSampler> s(accessors[g], xform);
        out[i] = s.wsSample(vdb(points_W_m[i]));
      }
    }
  });
  return out;
}

TriangleMesh LevelSetStock::surface(double adaptivity) const {
  TriangleMesh mesh;
  for (std::size_t g = 0; g < impl_->levels.size(); ++g) {
    std::vector<openvdb::Vec3s> points;
    std::vector<openvdb::Vec3I> triangles;
    std::vector<openvdb::Vec4I> quads;
    openvdb::tools::volumeToMesh(*impl_->levels[g].grid, points, triangles, quads, 0.0, std::clamp(adaptivity, 0.0, 1.0));
    std::vector<int> index(points.size(), -1);
    auto vertex = [&](unsigned i) {
      if (index[i] < 0) {
        index[i] = static_cast<int>(mesh.vertices_m.size());
        mesh.vertices_m.emplace_back(points[i].x(), points[i].y(), points[i].z());
      }
      return index[i];
    };
    // volumeToMesh orients polygons clockwise seen from outside: reversed here.
    auto keep = [&](unsigned a, unsigned b, unsigned c) {
      const Eigen::Vector3d centroid =
          (eigen(points[a]) + eigen(points[b]) + eigen(points[c])) / 3.0;
      if (impl_->owner(centroid) != g) return;
      mesh.triangles.push_back({vertex(c), vertex(b), vertex(a)});
    };
    for (const auto& t : triangles) keep(t[0], t[1], t[2]);
    for (const auto& q : quads) {
      keep(q[0], q[1], q[2]);
      keep(q[0], q[2], q[3]);
    }
  }
  return mesh;
}

std::string LevelSetStock::vdb_bytes() const {
  openvdb::GridPtrVec grids;
  for (std::size_t g = 0; g < impl_->levels.size(); ++g) {
    const GridLevel& level = impl_->levels[g];
    FloatGrid::Ptr grid = level.grid->copy();  // shares the tree; own name and metadata
    grid->setName(g == 0 ? "stock" : "stock_region_" + std::to_string(g));
    grid->insertMeta("vmsim_box_min_m", openvdb::Vec3DMetadata(vdb(level.box.min_W_m)));
    grid->insertMeta("vmsim_box_max_m", openvdb::Vec3DMetadata(vdb(level.box.max_W_m)));
    grid->insertMeta("vmsim_material_min", openvdb::Vec3IMetadata(level.material.min().asVec3i()));
    grid->insertMeta("vmsim_material_max", openvdb::Vec3IMetadata(level.material.max().asVec3i()));
    grid->insertMeta("vmsim_half_width_voxels", openvdb::DoubleMetadata(impl_->half_width));
    grid->setSaveFloatAsHalf(false);
    grids.push_back(grid);
  }
  std::ostringstream out(std::ios_base::binary);
  openvdb::io::Stream(out).write(grids);
  return out.str();
}

LevelSetStock LevelSetStock::from_vdb(const std::string& bytes, const std::string& what) {
  initialize_openvdb();
  openvdb::GridPtrVecPtr grids;
  try {
    std::istringstream in(bytes, std::ios_base::binary);
    openvdb::io::Stream stream(in);
    grids = stream.getGrids();
  } catch (const openvdb::Exception& error) {
    throw InputError(what + ": not a readable OpenVDB file: " + error.what());
  }
  auto impl = std::make_unique<Impl>();
  std::vector<std::pair<std::size_t, GridLevel>> found;
  for (const auto& base : *grids) {
    FloatGrid::Ptr grid = openvdb::gridPtrCast<FloatGrid>(base);
    const std::string name = base->getName();
    if (!grid || (name != "stock" && name.rfind("stock_region_", 0) != 0)) continue;
    auto meta = [&](const char* key) {
      if (!grid->metaValue<openvdb::Vec3d>(key).isFinite()) throw InputError(what + ": grid " + name + ": bad " + key);
      return grid->metaValue<openvdb::Vec3d>(key);
    };
    GridLevel level;
    try {
      level.box = Box{eigen(meta("vmsim_box_min_m")), eigen(meta("vmsim_box_max_m"))};
      level.material = openvdb::CoordBBox(Coord(grid->metaValue<openvdb::Vec3i>("vmsim_material_min")),
                                          Coord(grid->metaValue<openvdb::Vec3i>("vmsim_material_max")));
      impl->half_width = grid->metaValue<double>("vmsim_half_width_voxels");
    } catch (const openvdb::Exception& error) {
      throw InputError(what + ": grid " + name + " lacks vmsim metadata: " + error.what());
    }
    level.voxel = grid->voxelSize()[0];
    level.grid = grid;
    found.emplace_back(name == "stock" ? 0 : std::stoul(name.substr(13)), level);
  }
  std::sort(found.begin(), found.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  if (found.empty() || found[0].first != 0) throw InputError(what + ": no float grid named 'stock'");
  for (auto& f : found) impl->levels.push_back(f.second);
  return LevelSetStock(std::move(impl));
}

std::size_t LevelSetStock::grid_count() const { return impl_->levels.size(); }
double LevelSetStock::voxel_m(std::size_t grid) const { return impl_->levels.at(grid).voxel; }
Box LevelSetStock::region_box(std::size_t grid) const { return impl_->levels.at(grid).box; }
double LevelSetStock::band_m(std::size_t grid) const { return impl_->half_width * impl_->levels.at(grid).voxel; }

std::size_t LevelSetStock::memory_bytes() const {
  std::size_t bytes = 0;
  for (const auto& level : impl_->levels) bytes += static_cast<std::size_t>(level.grid->memUsage());
  return bytes;
}

std::size_t LevelSetStock::active_voxel_count() const {
  std::size_t n = 0;
  for (const auto& level : impl_->levels) n += static_cast<std::size_t>(level.grid->activeVoxelCount());
  return n;
}

}  // namespace vmsim::removal
