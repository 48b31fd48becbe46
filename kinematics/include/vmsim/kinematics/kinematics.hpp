#pragma once
// Direct (DKT) and inverse (IKT) kinematic transformations of a MachineModel.
// Frames and units: see machine_model.hpp (SI; W workpiece, S spindle gauge, T tool tip).
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <optional>
#include <string>
#include <vector>

#include "vmsim/kinematics/machine_model.hpp"

namespace vmsim::kinematics {

/// Tool pose in the workpiece frame: what a tool path programs.
struct ToolPose {
  Eigen::Vector3d tip_W_m = Eigen::Vector3d::Zero();  ///< tool tip position
  Eigen::Vector3d axis_W = Eigen::Vector3d::UnitZ();  ///< unit tool axis, tip -> spindle
};

/// Poses of the chain ends, X_BW(q) and X_BS(q).
Eigen::Isometry3d workpiece_frame_B(const MachineModel& model, const Eigen::VectorXd& q);
Eigen::Isometry3d spindle_frame_B(const MachineModel& model, const Eigen::VectorXd& q);

/// DKT: axis positions -> tool tip and tool axis in W. tool_length_m is the distance from the
/// spindle gauge frame S to the tool tip along -z_S.
ToolPose forward_kinematics(const MachineModel& model, const Eigen::VectorXd& q,
                            double tool_length_m);

/// Result of one IKT call.
struct InverseResult {
  Eigen::VectorXd q;
  /// True where the pose is at (or within the singular-zone tolerance of) a singularity of the
  /// transformation: for a table-table machine, the tool axis parallel to the last rotary axis.
  bool singular = false;
};

struct InverseOptions {
  /// Within this angle [rad] of the singular direction a pose counts as singular; the free
  /// rotary axis then keeps its previous value instead of spinning.
  double singular_angle_rad = 1e-3;
  /// Robots: stop criteria of the iterative solver.
  double position_tolerance_m = 1e-12;
  double axis_tolerance_rad = 1e-12;
  int max_iterations = 100;
};

/// IKT: tool pose in W -> axis positions, chosen next to q_previous (continuity along a path,
/// rotary axes unwrapped without 360 degree jumps, least joint motion for the free rotation of a
/// robot's tool). Machine tools with three linear and two rotary axes: closed form, both
/// solutions considered. Robots (and any other structure): iterative, from q_previous.
/// Returns std::nullopt when the pose is unreachable or no solution lies within the travel; the
/// caller names the tool path block (see solve_path_inverse).
std::optional<InverseResult> inverse_kinematics(const MachineModel& model, const ToolPose& pose,
                                                const Eigen::VectorXd& q_previous,
                                                double tool_length_m,
                                                const InverseOptions& options = {});

/// Every IKT solution of a pose that lies within the travel (machine tools: up to two; robots:
/// the one found from q_previous). For tests and for choosing a start configuration.
std::vector<InverseResult> inverse_kinematics_all(const MachineModel& model, const ToolPose& pose,
                                                  const Eigen::VectorXd& q_previous,
                                                  double tool_length_m,
                                                  const InverseOptions& options = {});

/// True when q lies within every axis's travel (continuous rotary axes excepted).
bool within_travel(const MachineModel& model, const Eigen::VectorXd& q, double tolerance = 1e-12);

}  // namespace vmsim::kinematics
