#pragma once
// Private: the signed distance to one constant-axis tool sweep, prepared for evaluation at many
// voxels (the level-set model's inner loop). No OpenVDB here. SI units, frame W.
#include <Eigen/Core>

#include <algorithm>
#include <cmath>

#include "sweep.hpp"

namespace vmsim::removal::detail {

/// Sweep = Disc(rho) (+) Segment(c0, c0 + ell a) (+) Segment(0, d) (+) Ball(r) (see tool.hpp).
/// Its signed distance (negative inside):
///  - d perpendicular to a (3-axis horizontal moves, any tool; tool at rest): the core is a
///    stadium prism, closed form, exact inside and outside;
///  - ball-end (rho = 0), any d: distance to the parallelogram c0 + [0,1] d + [0, ell] a minus
///    r, closed form, exact inside and outside;
///  - flat-end / bull-nose with d not perpendicular to a (ramps, tilted axes): minimum over the
///    segment of the tool's exact signed distance by golden section (convex in the segment
///    parameter), to `tolerance_m` outside; inside it is >= the exact value (a conservative
///    depth), which the cut only uses beyond the narrow band;
///  - conical tools (V, tapered; Kind::profile): closed form for a motion normal to the axis,
///    else the minimum over the motion by golden section (exact outside, as above).
struct SweepDistance {
  SweepDistance(const Sweep& sweep, double tolerance_m);

  double operator()(const Eigen::Vector3d& p) const;

  /// Kind::prism in its frame: u = (p - c0) . e1 (along the motion), v = (p - c0) . a,
  /// w = (p - c0) . e3. Inline: the cut's inner loop steps u, v, w from voxel to voxel.
  double prism(double u, double v, double w) const {
    const double du = u - std::clamp(u, 0.0, length);
    const double dr = std::sqrt(du * du + w * w) - rho;
    const double dz = std::abs(v - 0.5 * ell) - 0.5 * ell;
    const double er = std::max(dr, 0.0), ez = std::max(dz, 0.0);
    return std::sqrt(er * er + ez * ez) + std::min(std::max(dr, dz), 0.0) - r;
  }

  /// Signed distance to the tool at the start of the sweep (sigma = 0).
  double start_tool(const Eigen::Vector3d& p) const;

  /// True when, for every point of the box [lo, hi], the sweep's nearest part is the tool at the
  /// start (then the sweep's distance there is the start tool's, which the previous segment,
  /// ending with the same tool placement, already cut). Sufficient test, from the nearest point
  /// q of the start tool's core: the minimum over sigma is at 0 when (p - q) . d <= 0, and
  /// (q - c0) . d >= lambda (a . d) - rho |d_perp| with lambda the clamped axial coordinate.
  /// Needs p outside the start core: the caller checks start_core() > half-diagonal.
  bool behind_start(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) const;

  /// Signed distance to the start tool's core (Disc (+) Segment, without the ball offset r).
  double start_core(const Eigen::Vector3d& p) const;

  Eigen::Vector3d c0, d, a, e1, e3;
  double rho = 0.0, r = 0.0, ell = 0.0, length = 0.0;
  double a_dot_d = 0.0, d_perp = 0.0;
  /// profile: a conical tool (Sweep::profile), c0 its tip; golden_steps 0 for a motion normal
  /// to the axis (closed form), else the minimum over the motion by golden section.
  enum class Kind { prism, parallelogram, general, profile } kind = Kind::prism;
  Profile profile;
  Eigen::Matrix3d inverse;  // parallelogram coordinates
  int golden_steps = 0;
  Eigen::Vector3d lo, hi;   // bounding box of the sweep
};

}  // namespace vmsim::removal::detail
