#pragma once
// Private: the conical tools (V, tapered flat, tapered ball-end; tool.hpp) as a convex solid of
// revolution, and their exact line and distance computations, static and swept. SI units
// (m), frame W.
#include <Eigen/Core>

#include "vmsim/removal/tool.hpp"

namespace vmsim::removal::detail {

/// The meridian section of a conical tool. zeta [m] along the axis from the tip, rho [m] from
/// the axis. The section is the convex set (symmetric about the axis)
///   bottom: a flat of radius r_tip at zeta = 0 (r_ball = 0), or the ball |(rho, zeta - r_ball)|
///           <= r_ball (r_tip = 0) below the circle where the flank touches it;
///   flank:  rho = rho_f + (zeta - zeta_f) tan(beta) from (rho_f, zeta_f) to (rho_1, zeta_1);
///   side:   rho = rho_1 from zeta_1 up to length (none when zeta_1 = length);
///   top:    zeta = length.
/// For the ball, (rho_f, zeta_f) = r_ball (cos beta, 1 - sin beta): the flank is the cone tangent
/// to the ball, so the tool is Ball(r_ball) (+) a cone of half angle beta (Minkowski sum) cut
/// at rho_1 and length. Every function below is closed form.
struct Profile {
  bool active = false;  ///< a conical tool (else the sweep's Disc (+) Segment (+) Ball is the tool)
  double r_ball = 0.0, r_tip = 0.0;
  double tan_beta = 0.0;
  double rho_f = 0.0, zeta_f = 0.0;  ///< where the flank starts
  double rho_1 = 0.0, zeta_1 = 0.0;  ///< where it ends: the largest radius
  double length = 0.0;

  /// Height above the tip of the tool's lowest point at distance `radial` [m] from the axis
  /// (the lower envelope, convex and non-decreasing in radial); +inf beyond rho_1.
  double lower(double radial) const;
  /// Signed distance [m] (negative inside) from the point at (radial >= 0, axial) to the
  /// section: the exact distance to the tool outside it; inside, at least the exact (negative)
  /// value (exact off the ball's junction).
  double signed_distance(double radial, double axial) const;
  /// The tool with its tip at `tip` and unit axis `a` against the line o + t u (|u| = 1): the
  /// interval [t0, t1] inside; false when it misses. Closed form (planes, cylinder, cone
  /// nappe, sphere).
  bool line_interval(const Eigen::Vector3d& tip, const Eigen::Vector3d& a, const Eigen::Vector3d& o,
                     const Eigen::Vector3d& u, double& t0, double& t1) const;
};

/// The section of a conical tool (tool.conical()); validate() first.
Profile make_profile(const Tool& tool);

/// The tool of `profile` with axis a, its tip moving from tip0 to tip1 (constant axis): the
/// interval [t0, t1] of the line o + t u (|u| = 1) inside the swept volume; false when it
/// misses. The swept volume is convex and t0 (t1) is a convex (concave) function of the
/// motion's parameter sigma where the line meets the tool at sigma: its extreme by golden
/// section to 0.618^80 of the sigma range (~1e-16), the range's ends by bisection; a line that
/// meets no tool of the motion's ends and of a few guesses is decided by minimising over sigma
/// the tool's least signed distance along the line (nested golden sections): a line within
/// ~1e-13 m of grazing the sweep may be taken as a miss.
bool profile_sweep_interval(const Profile& profile, const Eigen::Vector3d& tip0, const Eigen::Vector3d& tip1,
                            const Eigen::Vector3d& a, const Eigen::Vector3d& o, const Eigen::Vector3d& u, double& t0,
                            double& t1);

/// Vertical tool (a = +z) and the vertical line through (x, y): the entry z0 (the lowest point
/// of the swept volume on the line) and an upper bound z1 of its exit; false when it misses.
/// Closed form for a level move or a plunge (the lower envelope at the planar distance from
/// the tip's path); a ramp by golden section of the convex entry over the motion (to 1e-16 of
/// it).
bool profile_vertical_entry(const Profile& profile, const Eigen::Vector3d& tip0, const Eigen::Vector3d& tip1, double x,
                            double y, double& z0, double& z1);

/// Signed distance from p to the swept volume: the minimum over the motion of the tool's
/// signed distance (convex in the motion's parameter; golden section, `steps` steps): exact
/// outside to the golden section's tolerance, inside at least the exact value.
double profile_sweep_distance(const Profile& profile, const Eigen::Vector3d& tip0, const Eigen::Vector3d& tip1,
                              const Eigen::Vector3d& a, const Eigen::Vector3d& p, int steps = 60);

}  // namespace vmsim::removal::detail
