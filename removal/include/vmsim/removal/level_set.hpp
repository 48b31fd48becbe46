#pragma once
// Level-set material removal (OpenVDB): the stock as a narrow-band signed distance field,
// machined by the exact swept volumes of the tool between consecutive poses. For general 5-axis
// shapes, images of the stock, and parts where one N-buffer direction does not see every face.
// OpenVDB stays behind this header (its headers are heavy: shared/DEBIAN-NOTES.md trap 6).
//
// Field. phi(p) [m] is the signed distance from p to the stock's surface, negative inside the
// material, stored on voxels of a sparse grid (OpenVDB FloatGrid, voxel centres at integer
// multiples of the voxel size in W) within a narrow band |phi| < half_width * voxel; beyond it
// only the sign is kept (the value is +-band).
//
// Cut. For each constant-axis piece of the motion (detail::split_segment: the exact swept
// volume of a segment with a fixed axis; where the axis turns, sub-steps whose swept volume is
// within LevelSetCutOptions::orientation_tolerance_m of the true one), phi <- max(phi,
// -phi_sweep), the CSG difference, with phi_sweep the sweep's signed distance evaluated at
// each voxel (closed form for ball-end mills and for any tool moving normal to its axis; a
// 1-D convex minimisation to 1e-3 voxel otherwise: level_set_sweep.hpp). Only voxels near the
// sweep's surface and in or near the material are visited: octree culling by the distance at
// block centres, and the part of the sweep whose nearest tool placement is the segment's start
// (already cut by the previous segment, which ends with the same placement) is skipped. Work
// per segment follows the newly cut front. Parallel over leaf nodes (TBB); a max is commutative,
// so the result is the same for any thread count.
//
// Exactness. The max of two exact signed distances is exact inside the remaining material (the
// nearest boundary point is on one of the two surfaces) and a lower bound outside it: in the
// cut region near a crease (where the tool's surface meets a previous surface: trough edges,
// scallop cusps) the stored value is smaller than the true distance, by up to (1 - sin(alpha/2))
// times the distance for a crease of opening angle alpha. The sign, hence the surface, is exact
// at voxels; between voxels the surface is where the trilinear interpolation of phi is zero:
// on smooth parts within ~ voxel^2 / (8 R) of the true surface (R its radius of curvature), at
// creases rounded over about one voxel. No re-normalisation is needed for the cut itself.
//
// Resolution. A coarse grid covers the whole stock; finer grids cover given boxes (corners,
// tangency zones). Every grid is cut; queries and the extracted surface use, at each point, the
// finest grid whose box contains it. So memory follows the fine boxes' areas, not the part's.
#include <Eigen/Core>

#include <array>
#include <cstddef>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "vmsim/removal/stl.hpp"  // TriangleMesh, read_stl, mesh_stl
#include "vmsim/removal/tool.hpp"

namespace vmsim::removal {

/// A box of the stock resolved with a finer voxel.
struct LevelSetRegion {
  Box box_W_m;             ///< where the fine grid is used [m, W]
  double voxel_m = 20e-6;  ///< its voxel size [m], > 0
};

struct LevelSetOptions {
  double voxel_m = 0.2e-3;              ///< voxel of the grid over the whole stock [m], > 0
  std::vector<LevelSetRegion> regions;  ///< finer grids (boxes should not overlap)
  double half_width_voxels = 3.0;       ///< narrow band on each side of the surface, >= 2
  /// Throws vmsim::InputError naming the field and value.
  void validate() const;
};

struct LevelSetCutOptions {
  /// Largest distance between the modelled and the true swept volume where the tool axis turns
  /// within a segment [m]: sub-steps at a quarter of it (see nbuffer.hpp), and a sub-step's
  /// start placement, covered by the previous one to within 5/8 of it, is not cut again. Default
  /// 1 um (1/20 of a 20 um voxel, below the interpolation error). Constant axis: exact.
  double orientation_tolerance_m = 1e-6;
  int threads = 0;                  ///< 0 = TBB's default, else at most this many
  std::size_t batch_segments = 64;  ///< sub-segments per parallel pass over the leaves
  /// Called after each batch with the fraction done in [0, 1]; returning true stops the run (the
  /// grids then hold every batch already cut, never half a batch).
  std::function<bool(double fraction_done)> interrupted;
};

struct LevelSetCutStatistics {
  std::size_t segments = 0;           ///< segments given
  std::size_t sub_segments = 0;       ///< after the orientation sub-steps
  std::size_t leaf_visits = 0;        ///< (leaf, sub-segment) pairs visited, all grids
  std::size_t voxels_evaluated = 0;   ///< sweep distances evaluated
  std::size_t voxels_changed = 0;     ///< voxel updates that raised phi
  bool interrupted = false;
};

enum class Interpolation { trilinear, triquadratic };

class LevelSetStock {
 public:
  /// A box stock. Throws vmsim::InputError on an empty box or invalid options.
  static LevelSetStock box(const Box& stock, const LevelSetOptions& options);
  /// A closed, consistently oriented triangle mesh (e.g. read_stl). Fine grids are
  /// voxelised from the whole mesh and then clipped to their boxes (transient memory: the whole
  /// surface at the fine voxel). Throws vmsim::InputError on an empty mesh or a bad index.
  static LevelSetStock mesh(const TriangleMesh& closed_mesh, const LevelSetOptions& options);
  /// Reads what vdb_bytes() wrote (an OpenVDB .vdb file). Throws vmsim::InputError naming
  /// `what` when it is not one.
  static LevelSetStock from_vdb(const std::string& bytes, const std::string& what = "vdb data");

  LevelSetStock(LevelSetStock&&) noexcept;
  LevelSetStock& operator=(LevelSetStock&&) noexcept;
  ~LevelSetStock();
  LevelSetStock copy() const;  ///< deep copy (e.g. a state to compare with)

  /// Cuts the swept volume of `tool` along the trajectory (a single pose cuts the tool at rest).
  /// Throws vmsim::InputError on an invalid tool or option.
  LevelSetCutStatistics cut(const Tool& tool, std::span<const Pose> trajectory, const LevelSetCutOptions& options = {});

  /// phi at p [m]: signed distance to the machined surface, negative inside the material,
  /// interpolated between voxels of the finest grid whose box holds p; +-band_m() beyond the band.
  /// At a design point: > 0 where the cut went deeper than the point (overcut), < 0 where
  /// material is left above it.
  double signed_distance(const Eigen::Vector3d& p_W_m, Interpolation interpolation = Interpolation::trilinear) const;
  std::vector<double> signed_distances(std::span<const Eigen::Vector3d> points_W_m,
                                       Interpolation interpolation = Interpolation::trilinear) const;

  /// The zero surface (openvdb::tools::volumeToMesh) of every grid, each kept inside its box
  /// (triangles by centroid; at a box's border the coarse and the fine surfaces may leave a gap
  /// of up to a coarse voxel). adaptivity in [0, 1]: 0 keeps every voxel's polygons.
  TriangleMesh surface(double adaptivity = 0.0) const;

  /// The grids as an OpenVDB file (.vdb): "stock" (the coarse grid), "stock_region_<i>", with
  /// their boxes as metadata.
  std::string vdb_bytes() const;

  std::size_t grid_count() const;             ///< 1 + number of regions
  double voxel_m(std::size_t grid) const;
  Box region_box(std::size_t grid) const;      ///< grid 0: the stock's box
  double band_m(std::size_t grid = 0) const;   ///< half width of the narrow band [m]
  std::size_t memory_bytes() const;            ///< all grids (OpenVDB memUsage)
  std::size_t active_voxel_count() const;      ///< all grids

 private:
  struct Impl;
  explicit LevelSetStock(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

/// VTK XML PolyData (.vtp, ASCII) of a mesh, points in m; `point_values` (one per vertex,
/// optional) become a point-data array named `values_name`.
std::string mesh_vtp(const TriangleMesh& mesh, const std::vector<double>* point_values = nullptr,
                     const std::string& values_name = "value");

}  // namespace vmsim::removal
