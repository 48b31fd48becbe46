#pragma once
// The free rotation of a robot's tool about its own axis (the sixth degree of freedom of a 6-axis
// robot that holds a spindle: a tool path gives the tip and the tool axis only, five degrees of
// freedom). Frames and units: see machine_model.hpp.
#include <Eigen/Core>
#include <optional>
#include <vector>

#include "vmsim/kinematics/kinematics.hpp"
#include "vmsim/kinematics/machine_model.hpp"
#include "vmsim/kinematics/path_kinematics.hpp"

namespace vmsim::kinematics {

/// How far a configuration is from the two things the free rotation can steer away from.
struct RedundancyMargins {
  /// The smallest distance of a joint to an end of its travel, as a fraction of that joint's
  /// travel (0 at an end stop, 0.5 at mid-travel; continuous rotary axes count 0.5).
  double travel_margin = 0.0;
  /// Inverse condition number sigma_min / sigma_max of the 6 x n tool Jacobian (tip rows in m,
  /// rotation rows in rad: a 1 m lever): 0 at a singularity (wrist, elbow, shoulder).
  double inverse_condition = 0.0;
  /// The smaller of the two: what choose_tool_roll maximises.
  double score() const { return travel_margin < inverse_condition ? travel_margin : inverse_condition; }
};

RedundancyMargins redundancy_margins(const MachineModel& model, const Eigen::VectorXd& q, double tool_length_m);

struct ToolRollChoice {
  Eigen::VectorXd q;      ///< joint positions at the pose with the chosen roll
  double roll_rad = 0.0;  ///< x_S turned about the tool axis from the reference direction
  RedundancyMargins margins;
  /// The same at the 5-dof solution nearest the seed (what the path would start from without
  /// this choice), for the report.
  RedundancyMargins seed_margins;
  int rolls_tried = 0;
  int rolls_solved = 0;  ///< reached the pose, within travel
};

/// For a machine with at least six moving joints in its tool chain (a robot): the rotation
/// about the tool axis at `pose` that keeps the arm furthest from its joint limits and from
/// singularities (largest RedundancyMargins::score), over rolls every `step_rad` of a full
/// turn. The rolls are followed along the self-motion from the 5-dof solution nearest `q_seed`
/// (each roll solved from the previous one: the same arm configuration, elbow and wrist), by
/// damped least-squares Newton steps on the full 6-dof frame. The reference direction of the
/// roll is the x axis of W projected on the plane normal to the tool axis (y of W where the
/// axis is along x). nullopt where the 5-dof pose is not reachable from q_seed, or no roll is.
std::optional<ToolRollChoice> choose_tool_roll(const MachineModel& model, const ToolPose& pose,
                                               const Eigen::VectorXd& q_seed, double tool_length_m,
                                               double step_rad = 0.2617993877991494);

/// The roll of a configuration: the angle [rad, in (-pi, pi]] of x_S about the tool axis from
/// the reference direction (choose_tool_roll).
double tool_roll_of(const MachineModel& model, const Eigen::VectorXd& q);

/// The 6-dof inverse kinematics of a robot: tip and tool axis of `pose` and x_S at `roll_rad`
/// from the reference direction, by damped least-squares Newton steps from q_previous (so the
/// arm keeps the configuration of q_previous: elbow, wrist). nullopt when it does not converge.
/// The result may lie outside the travel (the caller checks).
std::optional<Eigen::VectorXd> inverse_kinematics_with_roll(const MachineModel& model, const ToolPose& pose,
                                                            double roll_rad, const Eigen::VectorXd& q_previous,
                                                            double tool_length_m);

/// The roll profile along a path (choose_tool_roll_along_path).
struct RollProfileOptions {
  /// The rolls tried at each sample: a full turn every grid_step_rad (5 deg).
  double grid_step_rad = 0.08726646259971647;
  /// Samples along the path: the path points and poses on each segment (tip on the chord, tool
  /// axis on the great circle) at most this far apart [m] (a turn in place counts
  /// kReorientationLever_m per rad) ...
  double sample_spacing_m = 0.01;
  /// ... widened so that there are at most this many (the cost is samples x rolls Newton solves).
  int max_samples = 3000;
  /// Largest rate of the roll along the path [rad per m of path]: 0.5 deg/mm, so that at
  /// 6 m/min the roll adds at most 50 deg/s to the wrist joints.
  double max_roll_rate_rad_per_m = 8.726646259971648;
  /// Length of the Gaussian smoothing (its standard deviation) [m] that makes the roll C-infinity
  /// in s: the planner's fits and splines need q(s) C2 within each stretch.
  double smoothing_length_m = 0.01;
  /// A score at or above this counts as far enough from limits and singularities: above it the
  /// choice only keeps the roll still.
  double comfortable_score = 0.1;
  /// Weight of the roll's motion against the score's shortfall [m / rad^2] (see the cost).
  double roll_motion_weight_m_per_rad2 = 1e-3;
  /// Largest change of any joint between two neighbouring samples [rad]: a larger one is a jump
  /// to another branch (wrist or elbow flip), never taken.
  double max_joint_step_rad = 0.35;
};

struct RollProfile {
  /// Per path point: the roll [rad, unwrapped: continuous along the path] (PathPose::roll_rad).
  std::vector<double> roll_rad;
  /// The joint positions at the first path point with its roll (solve_path_kinematics' q_start).
  Eigen::VectorXd q_start;
  /// The smallest RedundancyMargins::score over the samples with this profile, and where [m].
  double min_score = 0.0;
  double min_score_s_m = 0.0;
  /// The same without the choice along the path: the first pose's roll (choose_tool_roll), then
  /// the least joint motion of the 5-dof inverse kinematics (what the path did before). Negative
  /// where that path leaves the travel or finds no solution.
  double min_score_free = 0.0;
  double min_score_free_s_m = 0.0;
  double roll_min_rad = 0.0, roll_max_rad = 0.0;
  double max_rate_rad_per_m = 0.0;  ///< largest |d roll / ds| between neighbouring samples
  std::size_t samples = 0;
  int rolls = 0;  ///< rolls per sample
};

/// The rotation about the tool axis along a whole path, for a robot (at least six moving joints
/// in the tool chain; no PathPose::q_given), chosen to keep the arm away from joint limits and
/// singularities (RedundancyMargins::score) all along, not only at the first pose.
///
/// Method (dynamic programming over a grid of rolls at samples along the path):
///  1. Samples: the path points, and poses on each segment at most sample_spacing_m apart, with
///     the path parameter s (tip chord length; turns in place as in solve_path_kinematics).
///  2. Lanes: at the first sample, rolls every grid_step_rad over a full turn, each followed
///     along the self-motion from the 5-dof solution nearest q_seed (the same arm
///     configuration); each lane is then continued at constant roll from sample to sample by
///     inverse_kinematics_with_roll from its own previous solution. A lane ends where the solver
///     fails or a joint jumps by more than max_joint_step_rad (a branch change). Each node
///     (sample, lane) has its score (negative outside the travel).
///  3. Transitions between lanes happen at stations, samples at least grid_step_rad /
///     max_roll_rate_rad_per_m (10 mm) apart (closer samples could never move one grid step),
///     within the rate bound (|d roll| <= max_roll_rate x ds since the last station) and without
///     a joint jump; between stations a lane keeps its roll.
///  4. First pass: the largest smallest score any allowed sequence keeps (max-min DP), B*.
///     Second pass, over nodes scoring at least min(B*, comfortable_score): least cost
///       sum ds max(0, 1 - score / comfortable_score) + w sum (d roll)^2 / ds
///     (time spent below the comfortable score, then least roll motion: a roll that needs not
///     move stays still), w = roll_motion_weight_m_per_rad2.
///  5. The chosen roll at the stations, piecewise linear in s between them, convolved with a Gaussian of standard
///     deviation smoothing_length_m (in closed form: erf and exp per piece): smooth in s, and its
///     rate stays within the bound (a convolution does not raise a Lipschitz constant).
///  6. Check: every sample solved with the smoothed roll from its predecessor, within travel,
///     no joint jump; the smallest score measured there is min_score.
/// Why not a continuation steered where the score drops: it sees a singularity only when it is
/// near, while a large roll change may be needed long before (the rate bound); the DP sees the
/// whole path.
/// Limits: the reference direction of the roll switches from x_W to y_W where the tool axis
/// passes along x_W (a jump of the roll's origin there); the lanes start from the branch of the
/// 5-dof solution nearest q_seed (another elbow or wrist configuration is not searched).
/// nullopt when the model has fewer than six axes, the path is empty, holds q_given, or the
/// check in 6 fails (the caller then keeps the first-pose choice).
std::optional<RollProfile> choose_tool_roll_along_path(const MachineModel& model, const std::vector<PathPose>& path,
                                                       const Eigen::VectorXd& q_seed, double tool_length_m,
                                                       const RollProfileOptions& options = {});

}  // namespace vmsim::kinematics
