#include "vmsim/kinematics/redundancy.hpp"

#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <numbers>

namespace vmsim::kinematics {
namespace {

Eigen::Matrix3d spindle_rotation_W(const MachineModel& model, const Eigen::VectorXd& q) {
  return (workpiece_frame_B(model, q).inverse() * spindle_frame_B(model, q)).linear();
}

Eigen::Matrix3d target_rotation(const Eigen::Vector3d& axis_W, double roll) {
  const Eigen::Vector3d z = axis_W.normalized();
  Eigen::Vector3d reference = Eigen::Vector3d::UnitX() - z.x() * z;
  if (reference.norm() < 1e-6) reference = Eigen::Vector3d::UnitY() - z.y() * z;
  reference.normalize();
  const Eigen::Vector3d x = Eigen::AngleAxisd(roll, z) * reference;
  Eigen::Matrix3d R;
  R.col(0) = x;
  R.col(1) = z.cross(x);
  R.col(2) = z;
  return R;
}

double roll_of(const Eigen::Matrix3d& R) {
  const Eigen::Vector3d z = R.col(2);
  const Eigen::Matrix3d R0 = target_rotation(z, 0.0);
  return std::atan2(R.col(0).dot(R0.col(1)), R.col(0).dot(R0.col(0)));
}

// Damped least-squares Newton on the full frame (tip position and rotation).
std::optional<Eigen::VectorXd> solve_frame(const MachineModel& model, const Eigen::Vector3d& tip_W,
                                           const Eigen::Matrix3d& R_target, Eigen::VectorXd q,
                                           double tool_length_m) {
  Eigen::Matrix3Xd Jp, Jr;
  for (int iteration = 0; iteration < 200; ++iteration) {
    const ToolPose now = forward_kinematics(model, q, tool_length_m);
    const Eigen::Matrix3d R = spindle_rotation_W(model, q);
    Eigen::Matrix<double, 6, 1> e;
    e.head<3>() = tip_W - now.tip_W_m;
    Eigen::Vector3d er = Eigen::Vector3d::Zero();
    for (int i = 0; i < 3; ++i) er += 0.5 * R.col(i).cross(R_target.col(i));
    e.tail<3>() = er;
    if (e.head<3>().norm() < 1e-11 && er.norm() < 1e-11) return q;
    // Limit the task step (0.05 m, 0.2 rad) so that the self-motion is followed.
    const double scale = std::min({1.0, 0.05 / std::max(e.head<3>().norm(), 1e-300), 0.2 / std::max(er.norm(), 1e-300)});
    tool_jacobian_W(model, q, tool_length_m, Jp, Jr);
    Eigen::MatrixXd J(6, q.size());
    J.topRows(3) = Jp;
    J.bottomRows(3) = Jr;
    const double lambda2 = 1e-8;
    const Eigen::MatrixXd A = J * J.transpose() + lambda2 * Eigen::MatrixXd::Identity(6, 6);
    q += J.transpose() * A.ldlt().solve(scale * e);
  }
  return std::nullopt;
}

}  // namespace

RedundancyMargins redundancy_margins(const MachineModel& model, const Eigen::VectorXd& q, double tool_length_m) {
  RedundancyMargins m;
  m.travel_margin = 0.5;
  for (std::size_t i = 0; i < model.axes.size(); ++i) {
    const Axis& axis = model.axes[i];
    if (axis.type == AxisType::rotary && axis.continuous) continue;
    const double range = axis.travel_max - axis.travel_min;
    if (!(range > 0.0)) continue;
    const double qi = q[static_cast<Eigen::Index>(i)];
    m.travel_margin = std::min(m.travel_margin, std::min(qi - axis.travel_min, axis.travel_max - qi) / range);
  }
  Eigen::Matrix3Xd Jp, Jr;
  tool_jacobian_W(model, q, tool_length_m, Jp, Jr);
  Eigen::MatrixXd J(6, q.size());
  J.topRows(3) = Jp;
  J.bottomRows(3) = Jr;
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(J);
  const auto& s = svd.singularValues();
  m.inverse_condition = s.size() >= 6 && s(0) > 0.0 ? s(5) / s(0) : 0.0;
  return m;
}

std::optional<ToolRollChoice> choose_tool_roll(const MachineModel& model, const ToolPose& pose,
                                               const Eigen::VectorXd& q_seed, double tool_length_m,
                                               double step_rad) {
  if (model.axes.size() < 6 || !(step_rad > 0.0)) return std::nullopt;
  const auto start = inverse_kinematics(model, pose, q_seed, tool_length_m);
  if (!start) return std::nullopt;
  ToolRollChoice best;
  best.q = start->q;
  best.seed_margins = redundancy_margins(model, start->q, tool_length_m);
  best.margins = best.seed_margins;
  best.roll_rad = roll_of(spindle_rotation_W(model, start->q));
  const double roll0 = best.roll_rad;
  const int count = static_cast<int>(std::ceil(2.0 * std::numbers::pi / step_rad - 1e-9));
  // Both ways round from the seed's roll, each roll solved from its neighbour.
  for (const double direction : {1.0, -1.0}) {
    Eigen::VectorXd q = start->q;
    for (int k = 1; k <= count / 2; ++k) {
      ++best.rolls_tried;
      const double roll = roll0 + direction * k * step_rad;
      const auto solved = solve_frame(model, pose.tip_W_m, target_rotation(pose.axis_W, roll), q, tool_length_m);
      if (!solved) break;  // the self-motion ends (a singularity or out of reach): stop this way
      q = *solved;
      if (!within_travel(model, q)) continue;
      ++best.rolls_solved;
      const RedundancyMargins m = redundancy_margins(model, q, tool_length_m);
      if (m.score() > best.margins.score()) {
        best.margins = m;
        best.q = q;
        best.roll_rad = std::remainder(roll, 2.0 * std::numbers::pi);
      }
    }
  }
  return best;
}

}  // namespace vmsim::kinematics
