#pragma once
// N-buffer material removal (second paper, Section 4: "Nbuffer material removing model").
//
// The part is a set of lines ("dexels"), each with an origin o, a unit direction u pointing out
// of the material, and a remaining length h [m]: the material on the line is o + [0, h] u. A
// Z-map is the special case o = (x_i, y_j, z_bottom), u = +z on a regular xy grid: h + z_bottom
// is the height of the part at (x_i, y_j). General buffers take one origin and direction per
// line (lines along the normals of a curved reference surface, for 5-axis parts).
//
// Heights are exact doubles: a cut sets h to the exact entry of the line into the tool's swept
// volume, so the height accuracy does not depend on the line spacing (the spacing only decides
// which features are sampled). Cut rule: where the swept volume meets the line at [t0, t1] with
// t1 > 0, h becomes max(0, min(h, t0)): what lies beyond the entry point on the line is taken as
// cut (the usual Z-map rule; material cannot be left above a tool).
//
// Motion between two poses (a segment): the point c = tip + r a moves linearly and the axis
// turns at a constant rate in the plane of a0 and a1 (slerp). The cut is the exact swept volume
// of the tool over the segment, never stepped positions:
//  - constant axis (3-axis, or tilted but fixed): the sweep is Disc(rho) (+) Parallelogram(c0,
//    c1, ell a) (+) Ball(r). Ball-end: closed form for any line direction (4 capsules and a
//    slab). Flat-end: closed form for any line direction (the section of the swept cylinder by
//    the plane of the line and the motion is an ellipse cut by a parallelogram). Flat and
//    bull-nose with the axis along a Z-map's lines: closed form for level moves and plunges, a
//    convex 1-D minimisation for ramps. Bull-nose otherwise: regula falsi on the convex signed
//    distance between closed-form flat-end brackets (to ~1e-13 m).
//  - changing axis: n sub-steps, each with the constant axis of its middle; a point of the tool
//    at distance <= sqrt(ell^2 + rho^2) from c moves by at most that times theta / (2 n), theta
//    the angle between a0 and a1, and n is chosen so that this stays under
//    CutOptions::orientation_tolerance_m (the ball of a ball-end mill turns about its centre and
//    has no such error; a bull-nose's sub-steps move its tip along the tip's line, c = tip + r a
//    of the sub-step's axis, which adds r to that distance and r (1 - cos(theta / 2)) to the
//    bound, detail::SubStepPath). ell is the part of the tool that can reach the material: above the
//    box that holds every line's material no pose of the segment can cut, so the tool is taken
//    as ending there (exactly the same cut inside the box; far fewer sub-steps for a long tool).
//    The bound is on the distance between the true and the modelled swept volumes; along a
//    line it is divided by the cosine of the angle between the line and the surface normal.
//
// Work per segment follows the newly cut strip: lines are grouped in tiles of 16 x 16; on a
// Z-map only the tiles and, row by row, the lines within the planar reach at which the sweep
// can get below the tile's highest line are visited (the tool's lower envelope by planar
// distance, exact for vertical tools and a tilted capsule's for tilted ones, and the plane of
// the tool's bottom); a sweep that continues the previous one from the same point skips the
// lines behind its start, which the previous one already cut at least as low (vertical tools
// moving level or up; ball-ends within r cos(tilt) of the move; tilted flat-end and bull-nose
// mills, same axis, over their bottom disc at the start). Each remaining line gets the exact cut
// (ball and flat bottoms in closed form; tilted flat-end and bull-nose mills on a Z-map first
// through a supporting-plane bound from the neighbouring line's contact, then certified closed
// forms or a warm-started rim search, removal/README.md "Accuracy"). General buffers test every line of the
// tiles whose box the sweep meets. Parallel with TBB over tiles, with segments in batches; a
// cut is a min and every culling decision depends only on the tile's own lines and the sweep
// order, so the result does not depend on the number of threads (bit for bit).
#include <Eigen/Core>
#include <cstddef>
#include <functional>
#include <span>
#include <utility>
#include <vector>

#include "vmsim/removal/tile_store.hpp"
#include "vmsim/removal/tool.hpp"

namespace vmsim::removal {

struct TriangleMesh;  // stl.hpp

/// How a closed mesh was turned into Z-map lines (NBuffer::zmap(const TriangleMesh&, ...)).
struct MeshZmapReport {
  std::size_t lines_missing = 0;  ///< lines outside the mesh's outline: length 0
  /// Lines the Z-map fills below their top because one interval per line cannot hold the mesh:
  /// more than one material interval (cavities, overhangs), or a lowest entry above the
  /// grid's bottom (material added beneath). Their top is exact; what is below it is solid.
  std::size_t lines_filled = 0;
};

struct CutOptions {
  /// Largest distance between the modelled and the true swept volume on segments where the
  /// tool axis turns [m] (sub-step count, see above). Default 0.05 um.
  double orientation_tolerance_m = 0.05e-6;
  /// Threads: 0 = TBB's default, else at most this many.
  int threads = 0;
  /// Segments cut together (one parallel pass over the tiles per batch).
  std::size_t batch_segments = 512;
  /// A batch also ends once it holds this many sub-segments whose tool axis differs from the
  /// one before (turning 5-axis moves): each gets its own table of section points (~55 kB for
  /// a D10 bull-nose on a 10 um grid), which the tiles' cut reads again and again, so a batch's
  /// tables should stay in the cache (32: about 2 MB).
  std::size_t batch_turning_sweeps = 32;
  /// Called after each batch with the fraction done in [0, 1]; returning true stops the run
  /// (the buffer then holds every batch already cut, never half a batch).
  std::function<bool(double fraction_done)> interrupted;
};

/// What a run did (counts, for benchmarks and reports).
struct CutStatistics {
  std::size_t segments = 0;        ///< segments given
  std::size_t sub_segments = 0;    ///< after the orientation sub-steps
  std::size_t tiles_visited = 0;   ///< (tile, sub-segment) pairs not culled by the tile bounds
  std::size_t lines_lowered = 0;   ///< line updates that lowered a line
  /// Z-map chains (removal/README.md): sub-segments that left lines to the next one across a
  /// junction where the tool differs (the axis turned, or the move is not exactly along x).
  std::size_t chained_turning = 0;
  /// Of those junctions, the rows whose boundary moved over lines that other sweeps' section
  /// lowest points pass over (the over-zone coverage, removal/README.md).
  std::size_t junction_rows_covered = 0;
  bool interrupted = false;
};

class NBuffer {
 public:
  static constexpr int kTile = 16;  ///< lines per tile side

  /// Z-map over a stock box: lines at x = min.x + i * spacing (i = 0 .. nx - 1, the last not
  /// beyond max.x), likewise in y, from z = min.z up to max.z. Throws vmsim::InputError when
  /// the box is empty or the spacing is not positive or gives more than 2^31 lines.
  static NBuffer zmap(const Box& stock, double spacing_m);
  /// The same Z-map made compact at once (make_compact()'s result bit for bit): a base a tile,
  /// no offsets, about 0.3 bytes a line (tile bounds and bases), never the 8 bytes a line of
  /// the plain buffer on the way (3.2 GB for an 80 x 500 mm die at 10 um; every MPI rank
  /// builds the whole uncut view).
  static NBuffer compact_zmap(const Box& stock, double spacing_m);

  /// Z-map over a closed mesh (stl.hpp): the grid of zmap(mesh.bounds(), spacing_m); each
  /// line's length reaches from the bottom of the bounds to the highest exit of the vertical
  /// line from the mesh (ray-triangle crossings, edges and vertices counted once), i.e. the
  /// material interval [lowest entry, highest exit] widened down to the grid bottom; a line
  /// that misses the mesh gets length 0. One interval per line: gaps between several
  /// intervals are filled (counted in `report`). Throws as zmap(Box, ...).
  static NBuffer zmap(const TriangleMesh& stock, double spacing_m, MeshZmapReport* report = nullptr);

  /// General lines on an nu x nv grid of a reference surface, row-major (index = iu + nu * iv):
  /// origins [m], directions (normalised here; out of the material), initial lengths [m].
  /// Neighbouring indices should be neighbours on the surface (tiles group 16 x 16 of them).
  /// Throws std::invalid_argument on size mismatch, a zero direction or a negative length.
  static NBuffer lines(int nu, int nv, std::vector<Eigen::Vector3d> origins,
                       std::vector<Eigen::Vector3d> directions, std::vector<double> lengths);

  bool is_zmap() const { return zmap_; }
  int nu() const { return nu_; }
  int nv() const { return nv_; }
  std::size_t line_count() const { return static_cast<std::size_t>(nu_) * static_cast<std::size_t>(nv_); }
  /// Z-map geometry (meaningful when is_zmap()).
  double spacing_m() const { return spacing_; }
  Eigen::Vector3d zmap_origin_m() const { return origin0_; }

  Eigen::Vector3d origin(int iu, int iv) const;
  Eigen::Vector3d direction(int iu, int iv) const;
  /// Remaining length h [m] of line (iu, iv); for a Z-map the height is h + zmap_origin_m().z().
  double length(int iu, int iv) const {
    return compact_ ? compact_length(index(iu, iv)) : h_[stored_index(iu, iv)];
  }
  /// The surface point o + h u [m, W].
  Eigen::Vector3d surface_point(int iu, int iv) const;
  /// All lengths, row-major (index = iu + nu * iv).
  std::vector<double> lengths() const;

  /// Cuts the swept volume of `tool` along the trajectory (segments between consecutive poses;
  /// a single pose cuts the tool at rest). Throws vmsim::InputError on an invalid tool or a
  /// zero tool axis. Returns the statistics (interrupted = true when the callback stopped it).
  CutStatistics cut(const Tool& tool, std::span<const Pose> trajectory, const CutOptions& options = {});

  /// True when both buffers have the same lines (same grid, origins and directions, bit for bit).
  bool same_lines(const NBuffer& other) const;

  /// Compact storage (for Z-maps and buffers too large for one double a line): each tile of
  /// 16 x 16 lines keeps a base length (double: its largest length when made compact) and,
  /// once a cut lowers one of its lines, one float offset a line from that base; a tile whose
  /// lines all equal its base (uncut stock) holds no offsets at all, so the memory follows the
  /// work: 4 bytes a line where a tool reached, about 0.13 bytes a line elsewhere. Lengths stay
  /// exact where they equal the base; elsewhere a stored length is within
  /// compact_bound_m(base - h) of the exact one (float rounding of the offset: 2^-24 of the
  /// depth below the tile's base, 0.6 nm at 10 mm), and a cut never raises a stored length.
  /// The cut is computed in double on the tile's lines as in plain storage (each tile is
  /// decoded, cut and encoded again); every decision is the tile's own, so the result does not
  /// depend on the thread count. Converting a plain buffer is exact for lines equal to their
  /// tile's largest length and within the bound otherwise. The offsets go to memory-mapped files
  /// past the process's budget (tile_store.hpp, set_spill_settings).
  void make_compact();
  bool is_compact() const { return compact_; }
  /// Tiles holding offsets (compact storage); all tiles in plain storage.
  std::size_t allocated_tiles() const;
  std::size_t tile_count() const { return tiles_.size(); }
  /// Bytes held for the lengths (plain: 8 a stored line; compact: offsets plus the bases).
  std::size_t length_bytes() const;
  /// Largest difference between a compact length and the exact one for a depth [m] below
  /// its tile's base: the float rounding of the offset plus that of the double sum.
  static double compact_bound_m(double depth_m) { return depth_m * 0x1p-24 + 1e-15; }

  /// Bands (several processes, each cutting a part of the lines; nbuffer_band.cpp). A band is a
  /// range of tile rows [tile_row_begin, tile_row_end) (tiles of kTile x kTile lines, tile row
  /// tv holding lines iv in [tv kTile, (tv + 1) kTile)); its tiles are contiguous in storage.
  /// A band buffer keeps the whole grid's geometry and every tile's bounds (upper bounds of the
  /// lines it does not hold), but holds the lengths of its band's tiles only: cut() cuts those
  /// tiles only, each exactly as the whole buffer's cut would (a tile's cut depends on the tile's
  /// own lines and the sweeps), so gathering the bands gives the whole buffer's lengths bit for
  /// bit. length(), lengths(), difference() and the outputs need a buffer that holds all tiles.
  int tile_rows() const { return tiles_v_; }
  bool holds_all_tiles() const { return band_tile_begin_ == 0 && band_tile_end_ == tiles_.size(); }
  /// The tile rows held: [first, second).
  std::pair<int, int> band_tile_rows() const {
    return {static_cast<int>(band_tile_begin_ / static_cast<std::size_t>(tiles_u_)),
            static_cast<int>(band_tile_end_ / static_cast<std::size_t>(tiles_u_))};
  }
  /// A copy holding the lengths of tile rows [tile_row_begin, tile_row_end) only (of a buffer
  /// that holds them). Throws std::invalid_argument on an empty or out-of-range band.
  NBuffer band(int tile_row_begin, int tile_row_end) const;
  /// The band's lengths as stored, packed in doubles (plain: the lengths, tile-major; compact:
  /// per tile its base, then 0 or kTile * kTile float offsets widened to double, with a count).
  std::vector<double> pack_band() const;
  /// The same for tile rows [tile_row_begin, tile_row_end) of the rows held (a piece of the
  /// band: gathering a band piece by piece bounds what the pack holds at once).
  std::vector<double> pack_rows(int tile_row_begin, int tile_row_end) const;
  /// Sets tile rows [tile_row_begin, tile_row_end) of this buffer (which holds all tiles, same
  /// grid and storage as the band's) from a band's pack_band() or pack_rows(), and their bounds.
  void unpack_band(int tile_row_begin, int tile_row_end, std::span<const double> packed);
  /// Every tile's bounds packed (7 doubles a tile), and set from such a pack for the tiles this
  /// buffer does not hold: a band buffer then sees the bounds the whole buffer has (its cut's
  /// culling and its material box, which decides the 5-axis sub-steps, are then the same).
  std::vector<double> pack_tile_bounds() const;
  void set_foreign_tile_bounds(std::span<const double> packed);

 private:
  /// A Z-map's grid over the box (checked as zmap() says), no lengths or tiles yet.
  static NBuffer zmap_grid(const Box& stock, double spacing_m);
  std::size_t index(int iu, int iv) const;
  void build_tiles();
  /// Recomputes the bounds of `tile` from its kTile * kTile lengths (in storage order) at `h`.
  void refresh_tile(std::size_t tile, const double* h);
  double compact_length(std::size_t stored) const;
  /// The lengths of a tile in storage order (compact storage decoded).
  void tile_lengths(std::size_t tile, double* out) const;

  bool zmap_ = false;
  int nu_ = 0, nv_ = 0, tiles_u_ = 0, tiles_v_ = 0;
  double spacing_ = 0.0;
  Eigen::Vector3d origin0_ = Eigen::Vector3d::Zero();
  // Storage is tile-major: lines of one tile are contiguous.
  std::vector<double> h_;  // plain storage
  // Compact storage: per tile, its base length and its offsets (empty: every line at the base).
  bool compact_ = false;
  std::vector<double> base_;
  TileOffsetStore offsets_{kTile * kTile};
  std::vector<Eigen::Vector3d> o_, u_;  // general buffers only
  struct TileBounds {
    Eigen::Vector3d lo, hi;  // box of the material segments of the tile's lines
    double h_max = 0.0;      // largest remaining length in the tile
  };
  std::vector<TileBounds> tiles_;
  // The tiles whose lengths are held (a band; all by default): h_ starts at tile
  // band_tile_begin_ (compact storage keeps every tile's slot; out-of-band tiles stay empty).
  std::size_t band_tile_begin_ = 0, band_tile_end_ = 0;
  std::size_t stored_index(int iu, int iv) const { return index(iu, iv) - band_tile_begin_ * kTile * kTile; }
  friend struct NBufferAccess;
  friend std::vector<double> difference(const NBuffer& production, const NBuffer& reference);
};

/// Run-versus-run difference, line by line: production minus reference lengths [m], row-major
/// (index = iu + nu * iv). Negative where the production run cut deeper (a mark), positive where
/// it left material. Both runs must be on identical lines (same grid), so that grid and scallop
/// effects cancel exactly; throws std::invalid_argument otherwise. Computed tile by tile (no
/// copy of either buffer's lengths); either buffer may be compact.
std::vector<double> difference(const NBuffer& production, const NBuffer& reference);

}  // namespace vmsim::removal
