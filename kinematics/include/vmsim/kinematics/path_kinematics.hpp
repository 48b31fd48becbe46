#pragma once
// Axis positions along a tool path and their derivatives with respect to the arc length s of
// the tool tip (first paper, Eq. 2): q_s, q_ss, q_sss. Corners (tangent discontinuities) are
// reported, never differentiated.
#include <Eigen/Core>
#include <limits>
#include <string>
#include <vector>

#include "vmsim/kinematics/kinematics.hpp"

namespace vmsim::kinematics {

/// A pose along a path, with the index of the tool path block that programmed it (for messages).
struct PathPose {
  ToolPose pose;
  int block = -1;
  /// Axis values the program gives (NC rotary words under tool-centre-point programming),
  /// one entry per axis [joint unit], NaN where not given; empty = none (the IKT chooses).
  /// Where given, solve_path_kinematics keeps them (inverse_kinematics_given_rotary).
  Eigen::VectorXd q_given = Eigen::VectorXd();
  /// Robots: the rotation of x_S about the tool axis [rad] from the reference direction
  /// (redundancy.hpp, choose_tool_roll_along_path); NaN = free (the inverse kinematics takes the
  /// least joint motion). Where given, solve_path_kinematics solves the full 6-dof frame
  /// (inverse_kinematics_with_roll) from the previous point.
  double roll_rad = std::numeric_limits<double>::quiet_NaN();
  /// The length of the tool in the spindle on the motion that ends here, gauge point to tip [m]
  /// (a T / M6 tool change switches it); NaN = the length solve_path_kinematics is given.
  double tool_length_m = std::numeric_limits<double>::quiet_NaN();
};

/// The tool length of a path pose [m]: its own where given, else `default_m`.
inline double pose_tool_length_m(const PathPose& pose, double default_m) {
  return pose.tool_length_m == pose.tool_length_m ? pose.tool_length_m : default_m;
}

/// Where the tip of a tool `to_length_m` long is at the machine position that puts the tip of a
/// tool `from_length_m` long at `tip_W_m` with unit axis `axis_W` (tip = gauge - length x axis).
inline Eigen::Vector3d tip_with_tool_length(const Eigen::Vector3d& tip_W_m, const Eigen::Vector3d& axis_W,
                                            double from_length_m, double to_length_m) {
  return from_length_m == to_length_m ? tip_W_m : Eigen::Vector3d(tip_W_m + (from_length_m - to_length_m) * axis_W);
}

/// How the derivatives are estimated (see solve_path_kinematics).
struct PathKinematicsOptions {
  /// A point where the tip tangent turns by more than this angle [rad] is a corner.
  double corner_angle_rad = 5.0 * 3.14159265358979323846 / 180.0;
  /// Local least-squares polynomial fit of q(s) around each point: at least this many
  /// neighbours on each side (interior points) ...
  int fit_half_window_points = 3;
  /// ... and at least this arc length on each side [m]: on dense polylines the window widens to
  /// this length, which makes it a smoothing length (see solve_path_kinematics).
  double fit_half_window_m = 2e-3;
  /// Degree of the local polynomial (3 or more for q_sss; lowered where a stretch between
  /// corners has too few points).
  int fit_degree = 4;
  InverseOptions inverse;
};

struct Corner {
  std::size_t point = 0;  ///< index of the path point
  double s_m = 0.0;
  double angle_rad = 0.0;  ///< turning angle of the tip tangent
};

/// A stretch of consecutive points whose IKT is singular (table-table: tool axis along C).
struct SingularZone {
  std::size_t first_point = 0;
  std::size_t last_point = 0;
  double s_begin_m = 0.0;
  double s_end_m = 0.0;
};

/// The path parameter of a motion that turns the tool about a fixed tip (a re-orientation at
/// a safe height): s grows by this lever times the rotary axes' motion (Euclidean, rad) there.
inline constexpr double kReorientationLever_m = 0.1;

struct PathKinematics {
  /// Path parameter at each point: the arc length of the tool tip, except on motions that turn
  /// the tool about a fixed tip (turns_in_place), which count kReorientationLever_m per rad of
  /// rotary motion.
  std::vector<double> s_m;
  /// Per point: the motion ending here turns the tool about a fixed tip (a stretch of its own,
  /// corners at both ends, so it runs from rest to rest on the axes' own limits).
  std::vector<bool> turns_in_place;
  Eigen::MatrixXd q;         ///< axis positions, one column per point (rows = axes)
  Eigen::MatrixXd q_s;       ///< dq/ds      [joint unit / m]
  Eigen::MatrixXd q_ss;      ///< d2q/ds2    [joint unit / m^2]
  Eigen::MatrixXd q_sss;     ///< d3q/ds3    [joint unit / m^3]
  /// True when q_s, q_ss, q_sss are estimates from local fits (solve_path_kinematics), false
  /// when they are exact (paths made by hand): the planner's PathSpline then interpolates q
  /// alone, since a quintic through q and fitted derivatives wiggles between the points where
  /// the fits smooth a feature (e.g. the curvature jump of a tangency).
  bool derivatives_fitted = false;
  /// Points at which the derivatives are one-sided because a corner or a path end is there.
  std::vector<Corner> corners;
  std::vector<SingularZone> singular_zones;
  /// What the points were solved with, so that points can be added on the programmed path
  /// later (planner::refine_path): the tool length [m] (direct kinematics of q gives the
  /// programmed tips), the IKT options, and per point the tool path block (PathPose::block,
  /// -1 unknown) with the block names (for messages; may be empty).
  double tool_length_m = 0.0;
  /// Per point, the tool length of the motion that ends there [m] (PathPose::tool_length_m),
  /// where the path changes tools of different lengths; empty: tool_length_m everywhere. The
  /// segment from point i to i + 1 runs with length_into(i + 1): its start tip is that tool's
  /// at q of point i (tip_with_tool_length), and point i is a corner (the change is at rest).
  std::vector<double> point_tool_length_m;
  double length_into(std::size_t i) const {
    return point_tool_length_m.empty() ? tool_length_m : point_tool_length_m[i];
  }
  InverseOptions inverse;
  std::vector<int> block;
  std::vector<std::string> block_names;
};

/// IKT of every pose, continuous along the path from q_start, then the derivatives.
///
/// Poses with PathPose::q_given: the rotary axes are the given values (the NC moves them to the
/// programmed words), the linear axes are solved (inverse_kinematics_given_rotary); a pose
/// whose given axes do not give its tool axis, or leave the travel, is an InfeasibleError
/// naming the block.
///
/// q: inverse_kinematics of pose i with q_previous = q of pose i-1 (q_start for the first), so
/// rotary axes are unwrapped and a table-table C axis holds still through a singular zone.
/// Tool lengths: each pose is solved with its own (PathPose::tool_length_m, else
/// tool_length_m). Where the length changes from point i to i + 1 (a tool change), the chord of
/// that motion starts at the new tool's tip at q of point i, and point i is a corner.
/// s: cumulative chord length of the programmed tips (s_m[0] = 0); a motion where the tip stays
/// (chord < 1e-12 m) but the rotary axes turn counts kReorientationLever_m times their motion
/// (rad) and is a stretch of its own (corners at both ends, angle 0).
/// Corners: a point where the angle between the incoming and the outgoing chord exceeds
/// options.corner_angle_rad (and so does the angle between the secants to the points
/// fit_half_window_m before and after it, so that rounding noise is not a corner), or where the tip does not move (a chord shorter than 1e-12 m,
/// reported with the angle between the chords around it). The path is cut at corners into
/// stretches; derivatives never look across a cut.
/// Derivatives: at each point, a least-squares polynomial of degree options.fit_degree in
/// (s - s_i) is fitted to q over a window of the same stretch holding at least
/// fit_half_window_points points and fit_half_window_m of arc on each side (shifted to one side
/// at corners and path ends: one-sided there); q_s, q_ss, q_sss are its derivatives at s_i. At a
/// corner point they are those of the outgoing stretch (of the incoming one at the last point).
/// A stretch of n points gets a degree of at most n - 1: a two-point stretch has q_ss = q_sss =
/// 0, a single point all derivatives 0.
/// Accuracy on a smooth path sampled every h with windows of 2k+1 points (fit_half_window_m
/// not larger): the errors are O(h^2) relative to the path's length scale l for q_s, q_ss and
/// q_sss, a few times larger at the k one-sided points next to corners and ends; s being the
/// chord length adds kappa^2 h^2 / 24 (kappa the tip's curvature). Measured on a helix with
/// l = 30 mm at h = 1 mm: 4e-5, 8e-5, 8e-4 relative (one-sided: 4e-5, 1.3e-4, 5e-3).
/// Dense CAM polylines (thousands of points, only tangent-continuous, coordinates rounded): the
/// window widens to +- fit_half_window_m (2 mm by default), so the result is the derivative of
/// a local least-squares polynomial over that length, i.e. of the polyline smoothed at that
/// scale: a noise e on the points gives errors of order e / L^k (L the half window) instead of
/// e / h^k, and features shorter than L are flattened. Measured on the same helix every 20 um,
/// rounded to 1 um: q_s 4e-4, q_ss 1 %, q_sss 20 % of their scales (without the window length:
/// q_sss wrong by a factor 1e5). Corners on such data are found only where the secants over
/// fit_half_window_m turn by more than corner_angle_rad as well as the chords.
/// A singular zone (InverseResult::singular) is reported as a range of points; the fit goes
/// through it (a C axis that swings at its exit shows as large derivatives there).
///
/// Throws vmsim::InfeasibleError naming the point index and block (block_names[block] when
/// available, else its number) and the reason (out of reach, or the axis leaving its travel)
/// when a pose has no solution. Throws std::invalid_argument when q_start has the wrong size.
PathKinematics solve_path_kinematics(const MachineModel& model, const std::vector<PathPose>& path,
                                     const Eigen::VectorXd& q_start, double tool_length_m,
                                     const std::vector<std::string>& block_names,
                                     const PathKinematicsOptions& options = {});

}  // namespace vmsim::kinematics
