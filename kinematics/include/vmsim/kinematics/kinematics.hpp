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
  Eigen::VectorXd q;  ///< axis positions, joint units, rotary axes unwrapped next to q_previous
  /// True where the pose is at (or within the singular-zone tolerance of) a singularity of the
  /// transformation. Closed form: the tool axis within options.singular_angle_rad of the
  /// rotary axis whose rotation does not change it (table-table AC: the C axis). Iterative:
  /// the 5-row task Jacobian at the solution has a singular value below
  /// 1e-6 times its largest (rows in m and rad).
  bool singular = false;
};

struct InverseOptions {
  /// Within this angle [rad] of the singular direction a pose counts as singular; the free
  /// rotary axis then keeps its previous value instead of spinning (closed form). Inside this
  /// zone the tool axis is reached only to within this angle (the other rotary axis takes the
  /// best-fitting value); the tip position is still exact.
  double singular_angle_rad = 1e-3;
  /// Robots (iterative solver): stop criteria, reached on both together.
  double position_tolerance_m = 1e-12;
  double axis_tolerance_rad = 1e-12;
  int max_iterations = 200;
  /// Robots: largest task-space correction aimed at in one Newton step (step limiting, so that
  /// far poses, e.g. home -> first pose of a path, are approached along a sensible route).
  double max_step_m = 0.1;
  double max_step_rad = 0.3;
};

/// IKT: tool pose in W -> axis positions, chosen next to q_previous (continuity along a path,
/// rotary axes unwrapped without 360 degree jumps, least joint motion for the free rotation of a
/// robot's tool). pose.axis_W need not be exactly unit (it is normalised); a zero axis is
/// unreachable.
///
/// Closed form, for any model whose moving joints are three prismatic and two revolute ones
/// with non-parallel rotary directions (table-table, head-head or mixed): the tool axis in W
/// depends on the two rotary angles only, a_W = Rot(w1, phi1) Rot(w2, phi2) v, solved as
/// Paden-Kahan subproblem 2 (up to two solutions); the tip is then affine in the linear axes,
/// a 3x3 linear system. Rotary angles are unwrapped: the multiple of 2 pi nearest q_previous
/// (within the travel for a limited axis). The solution within travel whose rotary axes are
/// closest to q_previous (Euclidean, rad) is returned. Singular pose (tool axis within
/// options.singular_angle_rad of w1, or the model's v along w2): the free rotary axis keeps its
/// q_previous value and the result is flagged.
///
/// Iterative, for every other structure (robots): damped least-squares Newton steps on the
/// 5-dof task (tip position, tool-axis direction; the rotation about the tool axis is free),
/// minimum-norm in joint space, so that the redundancy goes to least joint motion from
/// q_previous; task steps limited by options.max_step_m / max_step_rad, joint steps to 0.5
/// joint unit, backtracking, Levenberg-Marquardt damping (so near-singular poses converge). A
/// solution found beyond the travel is moved along the self-motion (null space) back into it
/// where the structure allows. A seed far from the pose may converge to another branch (elbow,
/// wrist flip) than the nearest one.
///
/// Returns std::nullopt when the pose is unreachable, the solver does not converge, or no
/// solution lies within the travel; the caller names the tool path block (see
/// solve_path_kinematics). Throws std::invalid_argument when q_previous has the wrong size.
std::optional<InverseResult> inverse_kinematics(const MachineModel& model, const ToolPose& pose,
                                                const Eigen::VectorXd& q_previous,
                                                double tool_length_m,
                                                const InverseOptions& options = {});

/// IKT with the rotary axes given, as an NC in tool-centre-point mode (G43.4, TRAORI with
/// A B C words) runs them: the rotary axes ARE the programmed values, only the linear axes are
/// solved for the tip (the tip is affine in them). q_given: one entry per axis [joint unit];
/// a rotary entry that is NaN keeps its q_previous value, linear entries are ignored. For
/// machines of three prismatic and two revolute axes (the closed-form structure).
///
/// Returns std::nullopt with `why` filled (when given) when the machine is not of that
/// structure, the given rotary axes do not give pose.axis_W (angle above
/// axis_tolerance_rad), the linear axes cannot reach the tip, or an axis leaves its travel.
/// Throws std::invalid_argument when q_given or q_previous has the wrong size.
std::optional<InverseResult> inverse_kinematics_given_rotary(
    const MachineModel& model, const ToolPose& pose, const Eigen::VectorXd& q_given,
    const Eigen::VectorXd& q_previous, double tool_length_m, double axis_tolerance_rad = 1e-6,
    std::string* why = nullptr);

/// Every IKT solution of a pose that lies within the travel (machine tools: up to two; robots:
/// the one found from q_previous), the one closest to q_previous first. For tests and for
/// choosing a start configuration.
std::vector<InverseResult> inverse_kinematics_all(const MachineModel& model, const ToolPose& pose,
                                                  const Eigen::VectorXd& q_previous,
                                                  double tool_length_m,
                                                  const InverseOptions& options = {});

/// Why inverse_kinematics found no solution, in words, for error messages: the pose out of
/// reach, or the axis (with its value and travel, in mm or deg) that the nearest solution
/// violates.
std::string explain_unreachable(const MachineModel& model, const ToolPose& pose,
                                const Eigen::VectorXd& q_previous, double tool_length_m,
                                const InverseOptions& options = {});

/// True when q lies within every axis's travel (continuous rotary axes excepted), with
/// `tolerance` in joint units on each bound. False when q has the wrong size.
bool within_travel(const MachineModel& model, const Eigen::VectorXd& q, double tolerance = 1e-12);

/// Geometric Jacobian of the tool in W at q [3 x n each, n = axis count]: column j is the
/// velocity of the tool tip relative to W (tip_jacobian, m per joint unit) and the angular
/// velocity of S relative to W (rotation_jacobian, rad per joint unit), both expressed in W,
/// for a unit velocity of axis j. The tool axis moves as d(axis_W) = (rotation_jacobian dq) x axis_W.
void tool_jacobian_W(const MachineModel& model, const Eigen::VectorXd& q, double tool_length_m,
                     Eigen::Matrix3Xd& tip_jacobian, Eigen::Matrix3Xd& rotation_jacobian);

}  // namespace vmsim::kinematics
