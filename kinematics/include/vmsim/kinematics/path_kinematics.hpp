#pragma once
// Axis positions along a tool path and their derivatives with respect to the arc length s of
// the tool tip (first paper, Eq. 2): q_s, q_ss, q_sss. Corners (tangent discontinuities) are
// reported, never differentiated.
#include <Eigen/Core>
#include <string>
#include <vector>

#include "vmsim/kinematics/kinematics.hpp"

namespace vmsim::kinematics {

/// A pose along a path, with the index of the tool path block that programmed it (for messages).
struct PathPose {
  ToolPose pose;
  int block = -1;
};

struct PathKinematicsOptions {
  /// A point where the tip tangent turns by more than this angle [rad] is a corner.
  double corner_angle_rad = 5.0 * 3.14159265358979323846 / 180.0;
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

struct PathKinematics {
  std::vector<double> s_m;   ///< arc length of the tool tip at each point
  Eigen::MatrixXd q;         ///< axis positions, one column per point (rows = axes)
  Eigen::MatrixXd q_s;       ///< dq/ds      [joint unit / m]
  Eigen::MatrixXd q_ss;      ///< d2q/ds2    [joint unit / m^2]
  Eigen::MatrixXd q_sss;     ///< d3q/ds3    [joint unit / m^3]
  /// Points at which the derivatives are one-sided because a corner or a path end is there.
  std::vector<Corner> corners;
  std::vector<SingularZone> singular_zones;
};

/// IKT of every pose, continuous along the path from q_start, then the derivatives.
/// Throws vmsim::InfeasibleError naming the point and block (via block_names) when a pose is
/// unreachable or violates the travel.
PathKinematics solve_path_kinematics(const MachineModel& model, const std::vector<PathPose>& path,
                                     const Eigen::VectorXd& q_start, double tool_length_m,
                                     const std::vector<std::string>& block_names,
                                     const PathKinematicsOptions& options = {});

}  // namespace vmsim::kinematics
