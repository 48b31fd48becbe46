#pragma once
// NC block compressor (Siemens 840D COMPCAD / COMPCURV / COMPON): runs of short G1 blocks that a
// CAM system writes for a curved contour are replaced by one smooth curve within a tolerance, on
// the canonical tool path before corner blending and the planner (README, "Siemens 840D programs
// and NC modes").
//
// The model (one for all three G codes; the 840D's own differ in degree and in how many blocks
// one polynomial takes, README):
//  - Runs: consecutive motions that are all G1 (MotionKind::linear; no rapid, no arc point), with
//    a feed per minute (G93 inverse time is not compressed: it fixes each block's time), at most
//    max_block_length_m long (the 840D's MD20170 COMPRESS_BLOCK_PATH_LIMIT: longer blocks are not
//    compressed), the compressor on with one tolerance (PathPoint::compressor_tolerance_m > 0, or
//    CompressorOptions::override_tolerance_m), the same tool, the same jerk / feedforward modes,
//    the same tool axis and rotary words (a run whose tool axis turns is left as programmed: the
//    orientation is not compressed). A run is broken at an exact stop (corner_tolerance_m == 0 at
//    an inner point: G60 / G9), at a dwell (PathPoint::dwell_s) and at a corner whose chords
//    turn by more than corner_angle_rad (the 840D's corner limit angle of COMPCAD,
//    $SC_CRIT_SPLINE_ANGLE); runs of fewer than min_run_blocks motions are left as they are.
//  - Curve: a cubic B-spline in the chord-length parameter u in [0, 1] (C2: continuous curvature
//    along the run), through the run's first and last points, fitted to the programmed points by
//    penalised least squares (P-spline: second differences of the control points weighted by
//    lambda; about one control point per two blocks, evenly spaced knots; where that cannot
//    meet the tolerance, one per block with knots at the points' parameters). lambda starts large (a very smooth curve) and is lowered tenfold until the curve is
//    within (1 - sampling_fraction) * tolerance of every programmed point AND the programmed
//    polyline is within that of the curve (checked at several points per block); then the
//    smoothest lambda that still passes (a half-decade step) is kept. Where the run meets other
//    cutting motion tangentially (within corner_angle_rad), the curve's end tangent is that of
//    the neighbouring motion (of the bisector of both chords where the neighbour is another
//    run): no kink where the run joins uncompressed geometry. The curvature at the ends is the
//    fit's own. A run no fit holds within the tolerance is left as programmed (counted).
//  - Sampling: the curve is replaced by points evenly spaced in u (as many intervals as blocks)
//    and, between them, at parameters chosen by bisection so that each
//    chord's sagitta is below sampling_fraction * tolerance (and max_sagitta_m, below the
//    planner's path tolerance) and the tangent turns by at most
//    max_chord_turn_rad over a chord: the polyline through the samples stays within the
//    tolerance of the programmed points and polyline. The planner then follows these points
//    (its path tolerance, 0.5 um) with its own C2 spline.
//  - Each sample carries the fields (block, feed, modes, tool) of the programmed point that ends
//    the block its parameter falls in; the run's first and last points are the programmed ones.
#include <Eigen/Core>
#include <cstddef>
#include <limits>
#include <vector>

#include <unsupported/Eigen/Splines>

#include "vmsim/toolpath/toolpath.hpp"

namespace vmsim::planner {

struct CompressorOptions {
  /// NaN: each point's PathPoint::compressor_tolerance_m (the program's COMPCAD / CYCLE832);
  /// 0: the compressor off everywhere; > 0: on everywhere with this tolerance [m] (a command
  /// line override).
  double override_tolerance_m = std::numeric_limits<double>::quiet_NaN();
  /// Longest block compressed [m] (MD20170 COMPRESS_BLOCK_PATH_LIMIT; an assumed value).
  double max_block_length_m = 5e-3;
  /// Corner limit angle [rad]: chords turning by more break a run (an assumed value).
  double corner_angle_rad = 30.0 * 3.14159265358979323846 / 180.0;
  /// Runs of fewer blocks are left alone.
  std::size_t min_run_blocks = 3;
  /// Share of the tolerance left to the sampling chords' sagitta; in (0, 0.5].
  double sampling_fraction = 0.1;
  /// ... and at most this [m]: below the planner's path tolerance (0.5 um), so that its spline
  /// through the samples follows the curve (where a chord's sagitta exceeded it, the planner
  /// added points on the chords and followed the polygon: a rounded circle compressed with
  /// 0.3 mm chords planned in 5.25 s, with 0.25 mm ones in 1.38 s, as programmed 6.18 s).
  double max_sagitta_m = 0.2e-6;
  /// Largest turn of the tangent over one sampling chord [rad].
  double max_chord_turn_rad = 2.0 * 3.14159265358979323846 / 180.0;
  /// Throws vmsim::InputError naming the field and value.
  void validate() const;
};

using CompressorSpline = Eigen::Spline<double, 3, 3>;

struct CompressedRun {
  std::size_t first_point = 0;  ///< index of the run's first point in the input path
  std::size_t last_point = 0;   ///< its last point (the run has last - first blocks)
  double tolerance_m = 0.0;
  double length_m = 0.0;        ///< the programmed polyline's length (u = arc length / length_m)
  double lambda = 0.0;          ///< the penalty weight kept
  double deviation_m = 0.0;     ///< largest distance found by the fit's check (both ways)
  bool start_tangent_fixed = false, end_tangent_fixed = false;
  std::size_t samples = 0;      ///< points that replace the run's inner points and end point
  CompressorSpline curve;       ///< tip [m] over u in [0, 1]
};

/// What the compressor did, in numbers (the run's report says it).
struct CompressionSummary {
  std::size_t runs = 0;  ///< runs replaced by a curve
  /// Runs the compressor was on for but no fit met the tolerance (left as programmed).
  std::size_t runs_left = 0;
  /// Short G1 blocks under the compressor left as programmed because the tool axis (or a rotary
  /// word) changes over them: the orientation is not compressed.
  std::size_t orientation_blocks_left = 0;
  std::size_t blocks_compressed = 0;  ///< programmed blocks inside the runs replaced
  std::size_t points_in = 0, points_out = 0;
  double deviation_max_m = 0.0;  ///< largest CompressedRun::deviation_m
};

struct CompressorResult {
  toolpath::Toolpath toolpath;  ///< blocks, warnings, tool and stock copied
  std::vector<CompressedRun> runs;
  CompressionSummary summary;
};

/// Compresses the runs of short G1 blocks of `path` (see the header notes). Throws
/// vmsim::InputError for bad options.
CompressorResult compress_polylines(const toolpath::Toolpath& path, const CompressorOptions& options);

}  // namespace vmsim::planner
