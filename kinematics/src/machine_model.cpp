#include "vmsim/kinematics/machine_model.hpp"

namespace vmsim::kinematics {

int MachineModel::axis_index(const std::string& axis_name) const {
  for (std::size_t i = 0; i < axes.size(); ++i) {
    if (axes[i].name == axis_name) return static_cast<int>(i);
  }
  return -1;
}

Eigen::VectorXd MachineModel::home_positions() const {
  Eigen::VectorXd q(static_cast<Eigen::Index>(axes.size()));
  for (std::size_t i = 0; i < axes.size(); ++i) q[static_cast<Eigen::Index>(i)] = axes[i].home;
  return q;
}

}  // namespace vmsim::kinematics
