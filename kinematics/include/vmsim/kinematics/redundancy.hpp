#pragma once
// The free rotation of a robot's tool about its own axis (the sixth degree of freedom of a 6-axis
// robot that holds a spindle: a tool path gives the tip and the tool axis only, five degrees of
// freedom). Frames and units: see machine_model.hpp.
#include <Eigen/Core>
#include <optional>

#include "vmsim/kinematics/kinematics.hpp"
#include "vmsim/kinematics/machine_model.hpp"

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

}  // namespace vmsim::kinematics
