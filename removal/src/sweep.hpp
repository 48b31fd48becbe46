#pragma once
// Private: the exact line-versus-swept-tool computations shared by the N-buffer and the
// OpenVDB model. SI units, frame W.
#include <Eigen/Core>
#include <cmath>
#include <limits>
#include <vector>

#include "vmsim/removal/tool.hpp"

namespace vmsim::removal::detail {

inline constexpr double kInf = std::numeric_limits<double>::infinity();

/// One segment with a constant tool axis: the core point c goes from c0 to c1; the body is
/// Disc(rho) (+) Segment(c, c + ell a) (+) Ball(r).
struct Sweep {
  Eigen::Vector3d c0, c1, a;
  double rho = 0.0, r = 0.0, ell = 0.0;
  Eigen::Vector3d lo, hi;  // bounding box of the swept volume
  bool vertical = false;   // a is exactly +z
};

Sweep make_sweep(const Eigen::Vector3d& c0, const Eigen::Vector3d& c1, const Eigen::Vector3d& a,
                 double rho, double r, double ell);

/// Splits the motion pose0 -> pose1 into constant-axis sweeps whose error is below tolerance_m
/// (see nbuffer.hpp). Appends to `out`.
void split_segment(const Tool& tool, const Pose& pose0, const Pose& pose1, double tolerance_m,
                   std::vector<Sweep>& out);

/// Interval [t0, t1] where the line o + t u (|u| = 1) meets the swept volume; false if it
/// misses. Exact (closed form) for rho = 0 and for vertical sweeps on vertical lines; otherwise
/// nested convex minimisations converged to ~1e-12 m.
bool line_interval(const Sweep& s, const Eigen::Vector3d& o, const Eigen::Vector3d& u, double& t0,
                   double& t1);

/// Vertical sweep, vertical line through (x, y): lowest point of the swept volume (entry z)
/// and an upper bound of its highest point; false if the line misses.
bool vertical_entry(const Sweep& s, double x, double y, double& z0, double& z1);

/// Signed distance from p to the swept volume (exact outside for rho = 0; for rho > 0 the
/// minimum over the segment of the tool's signed distance, exact outside to ~1e-12 m).
double signed_distance(const Sweep& s, const Eigen::Vector3d& p);

/// Distance in the plane from (px, py) to the 2-D segment (ax, ay)-(bx, by).
double distance_2d(double px, double py, double ax, double ay, double bx, double by);

/// Capsule (segment A-B, radius R) against a line: the interval of t; false if it misses.
bool capsule_interval(const Eigen::Vector3d& A, const Eigen::Vector3d& B, double R,
                      const Eigen::Vector3d& o, const Eigen::Vector3d& u, double& t0, double& t1);

}  // namespace vmsim::removal::detail
