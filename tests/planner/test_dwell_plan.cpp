// Dwells in the planner (FeedrateOptions::point_dwell_s): a dwell at an exact stop makes the plan
// exactly that much longer (to the set points' period), and the set points hold the point's
// axis positions all that time; a dwell on a straight line makes the point a stop.
#include <gtest/gtest.h>

#include <cmath>

#include "vmsim/common/errors.hpp"
#include "vmsim/kinematics/kinematics.hpp"
#include "vmsim/kinematics/machine_loader.hpp"
#include "vmsim/kinematics/path_kinematics.hpp"
#include "vmsim/planner/feedrate.hpp"

namespace vmsim::planner {
namespace {

const std::string kRoot = VMSIM_SOURCE_DIR;

struct Square {
  kinematics::MachineModel machine = kinematics::load_machine(kRoot + "/samples/machines/mikron_ucp710.yaml");
  kinematics::PathKinematics path;
  Square() {
    std::vector<kinematics::PathPose> poses;
    int block = 0;
    for (const Eigen::Vector3d& tip : {Eigen::Vector3d(-0.02, -0.02, 0.02), Eigen::Vector3d(0.02, -0.02, 0.02),
                                       Eigen::Vector3d(0.02, 0.02, 0.02), Eigen::Vector3d(-0.02, 0.02, 0.02)}) {
      poses.push_back({{tip, Eigen::Vector3d::UnitZ()}, block++});
    }
    path = kinematics::solve_path_kinematics(machine, poses, machine.home_positions(), 0.06, {}, {});
  }
};

/// The longest run of consecutive set points equal to q_hold (to 1e-12 m / rad).
std::size_t longest_hold(const SetPoints& sp, const Eigen::VectorXd& q_hold) {
  std::size_t longest = 0, run = 0;
  for (Eigen::Index k = 0; k < sp.q.cols(); ++k) {
    run = (sp.q.col(k) - q_hold).cwiseAbs().maxCoeff() < 1e-12 ? run + 1 : 0;
    longest = std::max(longest, run);
  }
  return longest;
}

TEST(DwellPlan, HalfASecondAtACornerAddsHalfASecondAndHoldsTheSetPoints) {
  const Square square;
  for (const bool third_order : {false, true}) {
    SCOPED_TRACE(third_order ? "third order" : "second order");
    FeedrateOptions options;
    options.feed_m_per_s = 10.0 / 60.0;
    options.third_order = third_order;
    const FeedratePlan plain = plan_feedrate(square.machine, square.path, options);
    options.point_dwell_s = {0.0, 0.0, 0.5, 0.0};  // at the second corner, (0.02, 0.02)
    const FeedratePlan dwelling = plan_feedrate(square.machine, square.path, options);
    const double period = dwelling.setpoints.period_s;
    EXPECT_NEAR(dwelling.duration_s - plain.duration_s, 0.5, period);
    EXPECT_NEAR(static_cast<double>(dwelling.setpoints.t_s.size()) - static_cast<double>(plain.setpoints.t_s.size()),
                0.5 / period, 1.0);
    // The corner's axis positions, from the inverse kinematics of the path (not the plan).
    const Eigen::VectorXd corner = square.path.q.col(2);
    const std::size_t held = longest_hold(dwelling.setpoints, corner);
    EXPECT_GE(static_cast<double>(held), std::floor(0.5 / period)) << held;
    EXPECT_LT(static_cast<double>(longest_hold(plain.setpoints, corner)), 0.1 / period);
    EXPECT_LE(dwelling.check.worst(), 1.0 + 1e-4);
  }
}

TEST(DwellPlan, ADwellAtTheEndsHoldsThereAndBadDwellsAreErrors) {
  const Square square;
  FeedrateOptions options;
  options.feed_m_per_s = 10.0 / 60.0;
  options.third_order = false;
  const FeedratePlan plain = plan_feedrate(square.machine, square.path, options);
  options.point_dwell_s = {0.25, 0.0, 0.0, 0.3};
  const FeedratePlan ends = plan_feedrate(square.machine, square.path, options);
  EXPECT_NEAR(ends.duration_s - plain.duration_s, 0.55, ends.setpoints.period_s);
  EXPECT_GE(static_cast<double>(longest_hold(ends.setpoints, square.path.q.col(0))), std::floor(0.25 / ends.setpoints.period_s));
  EXPECT_GE(static_cast<double>(longest_hold(ends.setpoints, square.path.q.col(3))), std::floor(0.3 / ends.setpoints.period_s));
  // Wrong sizes and values are errors.
  options.point_dwell_s = {0.0, 0.1};
  EXPECT_THROW(plan_feedrate(square.machine, square.path, options), InputError);
  options.point_dwell_s = {0.0, -0.1, 0.0, 0.0};
  EXPECT_THROW(plan_feedrate(square.machine, square.path, options), InputError);
}

}  // namespace
}  // namespace vmsim::planner
