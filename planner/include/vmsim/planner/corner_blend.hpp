#pragma once
// Corner blending of G1 polylines within a tolerance (continuous-path mode of an NC, Siemens
// G642 / Fanuc AI contour control), on the canonical tool path before the inverse kinematics.
//
// Which points are corners: the criterion of kinematics::solve_path_kinematics (see
// path_kinematics.hpp), so that a blended path has no corner left for the planner: the tip
// chords before and after the point turn by more than corner_angle_rad, and so do the secants
// to the points corner_baseline_m before and after it.
//
// The blend at a corner P with incoming unit direction u1, outgoing u2 and turning angle
// theta (angle between u1 and u2): the quintic Bezier curve with control points
//   P0 = P - L u1, P1 = P - alpha L u1, P2 = P - beta L u1,
//   P3 = P + beta L u2, P4 = P + alpha L u2, P5 = P + L u2,
// alpha = 0.6, beta = 0.15 + 0.35 clamp((theta - 30 deg) / 120 deg, 0, 1) (chosen, by a search
// over (alpha, beta), for a low peak of curvature and of its derivative along s for a given
// deviation; the peak curvature is within 1.2x that of a circular fillet of the same deviation
// up to 90 deg). P0, P1, P2 lie on the incoming line and P3, P4, P5 on the outgoing one, so the
// curve leaves and joins the lines tangentially with zero curvature (G2): the acceleration of
// an axis moving along it has no step, the jerk stays bounded. B'(t) is a positive
// combination of u1 and u2, never zero below 180 deg: the curvature is finite and continuous.
//  - Deviation (closed form): the curve is symmetric about the bisector and its closest point
//    to P is B(1/2), at  eps = L (1 + 5 alpha + 10 beta) sin(theta / 2) / 16.  That is the
//    largest distance between the blended path and the programmed polyline (the corner point's
//    distance to the curve; a blend point is at most eps cos(theta / 2) from the polyline).
//  - L = min(the L giving eps = tolerance_m (1 - chord_error_fraction), half of each adjacent
//    segment (consecutive blends never overlap; a corner between short segments is blended
//    with a smaller L and so a smaller deviation), the L that keeps the tool axis within
//    axis_tolerance_rad (below)).
//  - Sampling: points at parameters chosen by bisection so that each chord's sagitta (largest
//    distance of the curve from the chord, checked at 3 interior points, curvature varying
//    little over one chord) stays below chord_error_fraction * tolerance_m and the tangent turns
//    by at most max_chord_turn_rad over each chord (well below corner_angle_rad, so no chord
//    angle makes a corner). The polyline through the samples is then within tolerance_m of the
//    programmed path.
//  - Tool axis (5-axis paths): the programmed axis along each leg is the great-circle
//    interpolation between the points' axes, i.e. a rotation vector (relative to the corner's
//    axis a_P, perpendicular to it) linear in the distance from P. The blended axis is the
//    same quintic Bezier in rotation-vector space, with control points at the same distances
//    (alpha L, beta L, L) along each leg, mapped back by the exponential map: it joins each
//    leg's orientation with equal first and second derivatives along s, so rotary axes get no
//    acceleration step either. Its angle to a_P at the middle is
//      L (1 + 5 alpha + 10 beta) |rho1 + rho2| / 32
//    (rho1, rho2: rotation vectors per metre from a_P towards the previous and the next point's
//    axis; a rotation at a constant rate through the corner gives 0); L is reduced so that it stays
//    <= axis_tolerance_rad. A segment whose axis turns by more than 90 deg is not blended.
//  - Points are added on each leg at 2L, 4L, 8L, ... from the corner (up to the middle of the
//    segment), on the straight line: the derivative fits of solve_path_kinematics use a count
//    of neighbours, which then stay near the blend instead of reaching the far end of a long
//    segment.
//  - Blend points keep the block of the corner point they replace (reports name that block);
//    points before the middle carry the corner point's kind and feed, the others those of the
//    next point (the outgoing motion); the points added on a leg belong to that leg's motion.
// Corners left as exact stops (listed in CornerBlendResult::exact_stops with the reason):
//  - turning angle above max_turn_angle_rad (a reversal, 180 deg: the curve would have a cusp;
//    near it the apex radius falls below eps / 200 and the tool nearly stops anyway),
//  - a rapid on either side (rapids are not blended), a G93 inverse-time feed on either side
//    (splitting the motion would change its time),
//  - the tip not moving on either side (the tool axis turns on the spot),
//  - the tool axis turning by more than 90 deg over an adjacent segment,
//  - a dwell there (PathPoint::dwell_s > 0: G4, a cycle's dwell); points made from a point
//    (blend samples, leg points) carry no dwell,
//  - a tolerance of 0 at that corner (CornerBlendOptions::program_tolerances: G61 / G9 there,
//    or no programmed tolerance and tolerance_m = 0).
// Arc points (MotionKind::arc) are treated like any other: the tessellated arc turns by less
// than the corner angle at each point, so only a tangent jump between an arc and a line (or two
// arcs) is a corner; its blend uses the arc's chord as the leg.
#include <Eigen/Core>
#include <array>
#include <cstddef>
#include <string>
#include <vector>

#include "vmsim/kinematics/path_kinematics.hpp"
#include "vmsim/toolpath/toolpath.hpp"

namespace vmsim::planner {

// The canonical motion the readers produce (toolpath/), which the planner consumes.
using toolpath::MotionKind;
using toolpath::PathPoint;
using toolpath::Toolpath;


struct CornerBlendOptions {
  /// Largest distance between the blended and the programmed path [m]; > 0, or >= 0 with
  /// program_tolerances (0: corners the program says nothing about stay exact stops).
  double tolerance_m = 0.0;
  /// Per corner, the tolerance the program asks there (PathPoint::corner_tolerance_m of the
  /// corner point, from G61 / G9 = 0: exact stop, G64 P / G5.1: blend within it) instead of
  /// tolerance_m, which then holds only where the program says nothing (NaN).
  bool program_tolerances = false;
  /// Largest angle between the blended tool axis and the corner's programmed axis [rad]; > 0.
  double axis_tolerance_rad = 1.0 * 3.14159265358979323846 / 180.0;
  /// Corner criterion, as in kinematics::PathKinematicsOptions (corner_angle_rad and the
  /// secant baseline fit_half_window_m): keep them equal to the planner's.
  double corner_angle_rad = kinematics::PathKinematicsOptions{}.corner_angle_rad;
  double corner_baseline_m = kinematics::PathKinematicsOptions{}.fit_half_window_m;
  /// Corners turning by more than this [rad] stay exact stops; < pi.
  double max_turn_angle_rad = 176.0 * 3.14159265358979323846 / 180.0;
  /// Sagitta of the sampling chords, as a fraction of tolerance_m; in (0, 0.5].
  double chord_error_fraction = 0.01;
  /// Largest turn of the tangent over one sampling chord [rad]; in (0, corner_angle_rad).
  double max_chord_turn_rad = 2.0 * 3.14159265358979323846 / 180.0;
  /// Throws vmsim::InputError naming the field and the value.
  void validate() const;
};

/// The quintic Bezier blend of one corner (control points in W) and its tool axis.
struct CornerBlendCurve {
  Eigen::Vector3d corner_W_m = Eigen::Vector3d::Zero();  ///< the programmed corner point P
  std::array<Eigen::Vector3d, 6> control_W_m{};           ///< P0 .. P5 (see above)
  Eigen::Vector3d corner_axis_W = Eigen::Vector3d::UnitZ();  ///< a_P
  /// Control points of the tool axis as rotation vectors relative to a_P [rad].
  std::array<Eigen::Vector3d, 6> axis_control_rad{};
  /// Tip at parameter t in [0, 1].
  Eigen::Vector3d tip(double t) const;
  /// Tip derivative dB/dt [m].
  Eigen::Vector3d tip_derivative(double t) const;
  /// Unit tool axis at parameter t.
  Eigen::Vector3d axis(double t) const;
};

struct BlendedCorner {
  std::size_t point = 0;        ///< index of the corner point in the input tool path
  int block = -1;               ///< its block (index into Toolpath::blocks)
  double turn_angle_rad = 0.0;  ///< theta
  double leg_length_m = 0.0;    ///< L
  double deviation_m = 0.0;     ///< eps (closed form above)
  double axis_deviation_rad = 0.0;  ///< angle of the blended axis to a_P at the middle
  std::size_t samples = 0;      ///< points that replace the corner point
  CornerBlendCurve curve;
};

struct KeptCorner {
  std::size_t point = 0;  ///< index of the corner point in the input tool path
  int block = -1;         ///< its block (index into Toolpath::blocks)
  double turn_angle_rad = 0.0;
  std::string reason;
};

struct CornerBlendResult {
  Toolpath toolpath;  ///< the blended path (blocks, warnings and tool copied)
  std::vector<BlendedCorner> blended;
  std::vector<KeptCorner> exact_stops;
  /// The fit window (kinematics::PathKinematicsOptions::fit_half_window_m) to differentiate
  /// the blended path with: default_m, or a quarter of the shortest blend leg L when smaller.
  /// With the default 2 mm window the derivatives of a blend a fraction of a millimetre long
  /// are smoothed away, the planner underestimates its acceleration and the set-point checks
  /// slow it down (the blended square of the tests: slower than exact stop).
  double fit_half_window_m(double default_m) const;
};

/// Blends the corners of `path` (see the header notes). Throws vmsim::InputError for bad
/// options (naming the field and value).
CornerBlendResult blend_corners(const Toolpath& path, const CornerBlendOptions& options);

}  // namespace vmsim::planner
