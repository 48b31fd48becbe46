// Feedrate interpolation with dynamic limits on the first paper's path 1 (Mikron UCP710 sample):
// the paper's findings on the maximum feedrate profile, and the torque on the written set points
// recomputed through the dynamic model.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "feedrate_test_support.hpp"
#include "vmsim/kinematics/dynamics.hpp"
#include "vmsim/kinematics/machine_loader.hpp"
#include "vmsim/kinematics/path_kinematics.hpp"
#include "vmsim/planner/feedrate.hpp"
#include "vmsim/toolpath/toolpath.hpp"

namespace vmsim::planner {
namespace {

using test::Sample;
const auto& path1 = test::mikron_path1;  // the cut of path 1 on the Mikron sample

FeedratePlan limits_only(FeedrateOptions options) {
  options.profile_only = true;
  return plan_feedrate(path1().machine, path1().path, options);
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

TEST(Path1Dynamic, EquivalentLimitsGiveTheKinematicProfile) {
  // Eq. 10 with inertia alone (no gravity, friction or coupling): the torque-limited sd_lim
  // equals the acceleration-limited one wherever the model's inertia r^2 H_ii + J_rotor equals
  // the drive's J_eq. Compare their ratio with that inertia ratio computed independently.
  const auto& s = path1();
  FeedrateOptions kin;
  const FeedratePlan k = limits_only(kin);
  FeedrateOptions dyn;
  dyn.method = FeedrateMethod::dynamic;
  dyn.limits = DynamicLimitSource::tuned;
  dyn.effects = kinematics::EffectSet{kinematics::Effect::inertia};
  const FeedratePlan d = limits_only(dyn);
  const auto& acc = k.profile.sd_lim_by_kind[static_cast<std::size_t>(ConstraintKind::acceleration)];
  const auto& tau = d.profile.sd_lim_by_kind[static_cast<std::size_t>(ConstraintKind::torque)];
  kinematics::DynamicsModel model(s.machine);
  kinematics::DynamicsData data(model);
  // The grids differ near the stops (refined over each mode's own jerk / torque-rate ramp):
  // compare at the grid points both have.
  const auto& s_dynamic = d.profile.s_m;
  std::size_t compared = 0;
  for (std::size_t i = 0; i < acc.size(); i += 7) {
    const auto at = std::lower_bound(s_dynamic.begin(), s_dynamic.end(), k.profile.s_m[i]);
    if (at == s_dynamic.end() || *at != k.profile.s_m[i]) continue;
    const auto id = static_cast<std::size_t>(at - s_dynamic.begin());
    if (!std::isfinite(acc[i]) || !std::isfinite(tau[id])) continue;
    const int axis = k.profile.axis_by_kind[static_cast<std::size_t>(ConstraintKind::acceleration)][i];
    if (axis != d.profile.axis_by_kind[static_cast<std::size_t>(ConstraintKind::torque)][id]) continue;
    const Eigen::VectorXd q = PathSpline(s.path).position(k.profile.s_m[i]);
    kinematics::mass_matrix(model, data, q);
    const auto& drive = s.machine.axes[static_cast<std::size_t>(axis)].drive;
    const double r = model.ratio(axis);
    const double inertia = r * r * data.mass_matrix(axis, axis) + drive.rotor_inertia_kg_m2;
    const double expected = std::sqrt(drive.equivalent_inertia_kg_m2 / inertia);
    EXPECT_NEAR(tau[id] / acc[i], expected, 1e-6 * expected) << "s = " << k.profile.s_m[i];
    ++compared;
  }
  EXPECT_GT(compared, 100u);
}

TEST(Path1Dynamic, ActuatorLimitsMoreThanDoubleTheTorqueLimitedFeed) {
  FeedrateOptions tuned;
  tuned.method = FeedrateMethod::dynamic;
  tuned.limits = DynamicLimitSource::tuned;
  tuned.effects = kinematics::EffectSet{kinematics::Effect::inertia};
  FeedrateOptions actuator = tuned;
  actuator.limits = DynamicLimitSource::actuator;
  const FeedratePlan a = limits_only(tuned), b = limits_only(actuator);
  const auto& ta = a.profile.sd_lim_by_kind[static_cast<std::size_t>(ConstraintKind::torque)];
  const auto& tb = b.profile.sd_lim_by_kind[static_cast<std::size_t>(ConstraintKind::torque)];
  std::vector<double> ratio;
  for (std::size_t i = 0; i < ta.size(); ++i) {
    if (std::isfinite(ta[i]) && std::isfinite(tb[i]) && ta[i] > 0) ratio.push_back(tb[i] / ta[i]);
  }
  ASSERT_GT(ratio.size(), 100u);
  EXPECT_GT(median(ratio), 2.0);
}

TEST(Path1Dynamic, FrictionMakesTheTorqueLimitJumpAtVelocityReversals) {
  FeedrateOptions with;
  with.method = FeedrateMethod::dynamic;
  with.limits = DynamicLimitSource::tuned;
  with.effects = kinematics::EffectSet{kinematics::Effect::inertia, kinematics::Effect::friction};
  const FeedratePlan plan = limits_only(with);
  const auto& tau = plan.profile.sd_lim_by_kind[static_cast<std::size_t>(ConstraintKind::torque)];
  const PathSpline spline(plan.path);  // the planned path (points added on the programmed one)
  // Where the axis limiting the torque profile reverses (q_s changes sign), sd_lim jumps: the
  // step across the reversal is much larger than the typical step between grid points.
  std::vector<double> steps;
  double largest_at_reversal = 0.0;
  Eigen::VectorXd qs_a, qs_b;
  for (std::size_t i = 0; i + 1 < tau.size(); ++i) {
    if (!std::isfinite(tau[i]) || !std::isfinite(tau[i + 1])) continue;
    const double step = std::abs(tau[i + 1] - tau[i]) / std::max(tau[i], tau[i + 1]);
    const int axis = plan.profile.axis_by_kind[static_cast<std::size_t>(ConstraintKind::torque)][i];
    if (axis < 0) continue;
    const auto sa = spline.segment_of(plan.profile.s_m[i]);
    spline.evaluate(sa, plan.profile.s_m[i] - spline.s_m()[sa], nullptr, &qs_a, nullptr, nullptr);
    const auto sb = spline.segment_of(plan.profile.s_m[i + 1]);
    spline.evaluate(sb, plan.profile.s_m[i + 1] - spline.s_m()[sb], nullptr, &qs_b, nullptr, nullptr);
    if (qs_a(axis) * qs_b(axis) < 0.0) {
      largest_at_reversal = std::max(largest_at_reversal, step);
    } else {
      steps.push_back(step);
    }
  }
  ASSERT_FALSE(steps.empty());
  EXPECT_GT(largest_at_reversal, 20.0 * median(steps));
}

TEST(Path1Dynamic, TorqueOnTheSetPointsStaysWithinTheActuatorLimits) {
  // Second order (torque with gravity and friction): the set points are differentiated at the
  // period and the torque recomputed through the dynamic model (independently of the planner's
  // check). Allowance: 0.1 %, the difference between the torque at one sample and its mean over
  // the difference stencil, and the placement of a friction jump inside the stencil at reversals.
  const auto& s = path1();
  FeedrateOptions options;
  options.method = FeedrateMethod::dynamic;
  options.limits = DynamicLimitSource::actuator;
  options.third_order = false;
  const FeedratePlan plan = plan_feedrate(s.machine, s.path, options);
  kinematics::DynamicsModel model(s.machine);
  kinematics::DynamicsData data(model);
  const auto& sp = plan.setpoints;
  const long n = static_cast<long>(sp.t_s.size());
  const double T = sp.period_s;
  auto q = [&](long k) { return sp.q.col(std::clamp(k, 0L, n - 1)); };
  double worst = 0.0;
  for (long k = 0; k < n; ++k) {
    const Eigen::VectorXd qd = (q(k + 1) - q(k - 1)) / (2 * T);
    const Eigen::VectorXd qdd = (q(k + 1) - 2 * q(k) + q(k - 1)) / (T * T);
    const Eigen::VectorXd zero = Eigen::VectorXd::Zero(qd.size());
    kinematics::actuator_torque(model, data, q(k), qd, qdd, zero);
    for (Eigen::Index j = 0; j < qd.size(); ++j) {
      const double before = q(k)(j) - q(k - 1)(j), after = q(k + 1)(j) - q(k)(j);
      if (before * after < 0.0) continue;  // reversal inside the stencil: see below
      worst = std::max(worst, std::abs(data.tau(j)) / s.machine.axes[static_cast<std::size_t>(j)].drive.torque_max_N_m);
    }
  }
  EXPECT_LE(worst, 1.001);
  EXPECT_GT(worst, 0.9);  // the profile is torque-limited somewhere
  EXPECT_GE(plan.duration_s, plan.lower_bound_s * 0.999);
}

// Third order on path 1 (torque rate with gravity and friction). Once disabled: the rows used
// the fitted q_sss while the set points followed a quintic whose own third derivative differed,
// and the slow-down rounds took minutes; the rows now use the spline's own derivatives.
TEST(Path1Dynamic, TorqueRateOnTheSetPointsWithGravityAndFriction) {
  // Third order in dynamic mode (torque and torque rate, every effect): the joint velocities
  // cross zero on this path (dry friction steps). Torque recomputed from the set points through
  // the dynamic model, 0.1 % as above, and none at the reversals: there the dry friction is
  // given the mean of its sign under the second difference's kernel, as in the planner's check.
  const auto& s = path1();
  FeedrateOptions options;
  options.method = FeedrateMethod::dynamic;
  options.limits = DynamicLimitSource::actuator;
  const FeedratePlan plan = plan_feedrate(s.machine, s.path, options);
  kinematics::DynamicsModel model(s.machine);
  const auto check = check_setpoints(s.machine, &model, plan.limits, options, plan.setpoints);
  EXPECT_LE(check.ratio.col(static_cast<Eigen::Index>(ConstraintKind::torque)).maxCoeff(), 1.001);
  EXPECT_LE(check.ratio.col(static_cast<Eigen::Index>(ConstraintKind::torque_rate)).maxCoeff(), 1.001);
  EXPECT_GE(plan.duration_s, plan.lower_bound_s * 0.999);
  options.third_order = false;
  const FeedratePlan second = plan_feedrate(s.machine, s.path, options);
  EXPECT_GE(plan.duration_s, second.duration_s * 0.999);
}

// As above, in kinematic mode (jerk).
TEST(Path1Kinematic, ThirdOrderPlans) {
  const auto& s = path1();
  FeedrateOptions options;
  const FeedratePlan plan = plan_feedrate(s.machine, s.path, options);
  const auto r = test::finite_difference_ratios(plan.setpoints, plan.limits);
  EXPECT_LE(r.velocity, 1.0 + 1e-4);
  EXPECT_LE(r.acceleration, 1.0 + 1e-4);
  EXPECT_LE(r.jerk, 1.0 + 1e-4);
  EXPECT_GE(plan.duration_s, plan.lower_bound_s);
}

}  // namespace
}  // namespace vmsim::planner
