// The planner's own checks window by window (FeedrateOptions::keep_setpoints = false): the
// set-point check rounds with their slow-down spans, the travel check and the path-fidelity
// check take the set points from the plan's law in windows of check_window_samples; the plan,
// its check ratios, its path deviation and any error (the limit, axis and place named) must be
// those of the checks on the whole set (keep_setpoints = true), bit for bit, for windows of every
// size: 1, 2, 7, 101, n / 2, n and 3 n set points.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <iostream>
#include <numbers>
#include <optional>
#include <string>
#include <vector>

#include "feedrate_test_support.hpp"
#include "vmsim/common/errors.hpp"
#include "vmsim/kinematics/machine_loader.hpp"
#include "vmsim/kinematics/path_kinematics.hpp"
#include "vmsim/kinematics/sample_models.hpp"
#include "vmsim/planner/feedrate.hpp"
#include "vmsim/toolpath/toolpath.hpp"

namespace vmsim::planner {
namespace {

using test::path1_on;
using test::Sample;

const auto& mikron = test::mikron_path1;

bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

// Counts the entries of a and b that differ in any bit (or in size).
std::size_t differing(const std::vector<double>& a, const std::vector<double>& b) {
  if (a.size() != b.size()) return std::max(a.size(), b.size()) + 1;
  std::size_t count = 0;
  for (std::size_t i = 0; i < a.size(); ++i) count += !same_bits(a[i], b[i]);
  return count;
}

// A plan, or the error that planning threw.
struct Outcome {
  std::optional<FeedratePlan> plan;
  std::string error;
};

Outcome plan_with(const Sample& sample, FeedrateOptions options, bool keep, std::size_t window = 4096) {
  options.keep_setpoints = keep;
  options.check_window_samples = window;
  Outcome out;
  try {
    out.plan = plan_feedrate(sample.machine, sample.path, options);
  } catch (const InfeasibleError& error) {
    out.error = error.what();
  }
  return out;
}

// Everything the checks decide or report, bit for bit.
void expect_same_outcome(const Outcome& whole, const Outcome& windowed, const std::string& label) {
  EXPECT_EQ(whole.error, windowed.error) << label;
  ASSERT_EQ(whole.plan.has_value(), windowed.plan.has_value()) << label;
  if (!whole.plan) return;
  const FeedratePlan& a = *whole.plan;
  const FeedratePlan& b = *windowed.plan;
  EXPECT_EQ(a.slowdown_rounds, b.slowdown_rounds) << label;
  EXPECT_TRUE(same_bits(a.duration_s, b.duration_s)) << label;
  EXPECT_EQ(a.law.samples, b.law.samples) << label;
  // The law the set points sample: equal when every slow-down decision was the same.
  EXPECT_EQ(differing(a.law.x, b.law.x), 0u) << label;
  EXPECT_EQ(differing(a.law.t_s, b.law.t_s), 0u) << label;
  EXPECT_EQ(differing(a.law.sdd_start, b.law.sdd_start), 0u) << label;
  EXPECT_EQ(differing(a.law.sdd_end, b.law.sdd_end), 0u) << label;
  EXPECT_EQ(differing(a.profile.sd_cap, b.profile.sd_cap), 0u) << label;
  // The check's worst ratios per axis and kind.
  ASSERT_EQ(a.check.ratio.rows(), b.check.ratio.rows()) << label;
  ASSERT_EQ(a.check.ratio.cols(), b.check.ratio.cols()) << label;
  for (Eigen::Index i = 0; i < a.check.ratio.size(); ++i) {
    EXPECT_TRUE(same_bits(a.check.ratio.data()[i], b.check.ratio.data()[i])) << label << " ratio " << i;
  }
  // Path fidelity on the set points: the largest deviations and where.
  EXPECT_EQ(a.path_fidelity_checked, b.path_fidelity_checked) << label;
  EXPECT_TRUE(same_bits(a.path_deviation_max_m, b.path_deviation_max_m)) << label;
  EXPECT_TRUE(same_bits(a.path_deviation_s_m, b.path_deviation_s_m)) << label;
  EXPECT_EQ(a.path_deviation_block, b.path_deviation_block) << label;
  EXPECT_TRUE(same_bits(a.path_axis_deviation_max_rad, b.path_axis_deviation_max_rad)) << label;
  EXPECT_TRUE(b.setpoints.t_s.empty()) << label;
  EXPECT_EQ(b.setpoints.q.size(), 0) << label;
}

// The whole-set checks against the windowed ones with windows of 1, 2, 7, 101, n / 2, n and 3 n
// set points (n: the whole plan's set points, or `n_if_failing` when it fails). Returns the
// whole-set outcome.
Outcome expect_every_window_size(const Sample& sample, const FeedrateOptions& options,
                                 std::size_t n_if_failing = 0) {
  const Outcome whole = plan_with(sample, options, true);
  const std::size_t n = whole.plan ? whole.plan->setpoints.t_s.size() : n_if_failing;
  EXPECT_GT(n, 100u);
  if (whole.plan) std::cout << n << " set points, " << whole.plan->slowdown_rounds << " slow-down rounds\n";
  for (std::size_t window : {std::size_t{1}, std::size_t{2}, std::size_t{7}, std::size_t{101}, n / 2, n, 3 * n}) {
    expect_same_outcome(whole, plan_with(sample, options, false, window), "window " + std::to_string(window));
  }
  return whole;
}

TEST(WindowedChecks, ThirdOrderPlanIsTheWholeSetsPlan) {
  const Outcome whole = expect_every_window_size(mikron(), FeedrateOptions{});
  ASSERT_TRUE(whole.plan);
  EXPECT_TRUE(whole.plan->path_fidelity_checked);
}

TEST(WindowedChecks, SecondOrderPlanIsTheWholeSetsPlan) {
  FeedrateOptions options;
  options.third_order = false;
  expect_every_window_size(mikron(), options);
}

TEST(WindowedChecks, DynamicTunedPlanIsTheWholeSetsPlan) {
  FeedrateOptions options;
  options.method = FeedrateMethod::dynamic;
  expect_every_window_size(mikron(), options);
}

// Torque-limited at the actuators' limits (gravity, friction, coupling): the torque check's
// friction at velocity reversals and stops inside the stencil.
TEST(WindowedChecks, DynamicActuatorPlanIsTheWholeSetsPlan) {
  FeedrateOptions options;
  options.method = FeedrateMethod::dynamic;
  options.limits = DynamicLimitSource::actuator;
  expect_every_window_size(mikron(), options);
}

// The same path on the KR180-class robot (six revolute axes), torque-limited as in the paper.
TEST(WindowedChecks, RobotDynamicPlanIsTheWholeSetsPlan) {
  static const Sample robot = path1_on("kr180_class.yaml");
  FeedrateOptions options;
  options.method = FeedrateMethod::dynamic;
  options.limits = DynamicLimitSource::actuator;
  expect_every_window_size(robot, options);
}

// The speed cap (v / |q_s|)^2 dipping between grid points (q_s = 1 + A sin(w s), a half wave per
// 30 mm grid segment), planned in second order, which leaves such dips to the set-point check
// (test VelocityCap in test_feedrate_kinematic.cpp): the first plan exceeds the X speed by 5 %
// and the check slows it down. The windowed check must place the same slow-down spans (the
// same law afterwards).
Sample velocity_dips() {
  const double length = 0.3, amplitude = 0.05;
  const std::size_t points = 11;
  const double w = std::numbers::pi * static_cast<double>(points - 1) / length;
  Sample out;
  out.path = test::sample_path(5, length, points, [&](double s, Eigen::VectorXd& q, Eigen::VectorXd& q_s,
                                                      Eigen::VectorXd& q_ss, Eigen::VectorXd& q_sss) {
    q.setZero();
    q_s.setZero();
    q_ss.setZero();
    q_sss.setZero();
    q(0) = s + amplitude / w * (1.0 - std::cos(w * s));
    q_s(0) = 1.0 + amplitude * std::sin(w * s);
    q_ss(0) = amplitude * w * std::cos(w * s);
    q_sss(0) = -amplitude * w * w * std::sin(w * s);
  });
  out.machine = kinematics::make_table_table_sample();
  for (auto& axis : out.machine.axes) axis.limits = {100.0, 1000.0, 1e5};
  out.machine.axes[0].limits = {0.5, 25.0, 1000.0};  // the speed limit decides
  out.machine.axes[0].travel_min = -2.0;
  out.machine.axes[0].travel_max = 2.0;
  out.machine.interpolation_period_s = 0.002;
  return out;
}

FeedrateOptions second_order_on_the_path_segments() {
  FeedrateOptions options;
  options.third_order = false;
  options.max_grid_step_m = 1.0;  // the path segments are the grid
  return options;
}

TEST(WindowedChecks, SlowDownRoundsTakeTheSameDecisions) {
  const Outcome whole = expect_every_window_size(velocity_dips(), second_order_on_the_path_segments());
  ASSERT_TRUE(whole.plan);
  EXPECT_GT(whole.plan->slowdown_rounds, 0) << "the case must exercise the slow-down";
}

// The same with a single round allowed: the check fails, and the error names the same limit,
// axis, excess and place (s, t).
TEST(WindowedChecks, AFailedCheckIsLocatedAtTheSamePlace) {
  FeedrateOptions options = second_order_on_the_path_segments();
  options.max_verification_rounds = 1;
  const Outcome passing = plan_with(velocity_dips(), second_order_on_the_path_segments(), true);
  ASSERT_TRUE(passing.plan);
  const Outcome whole = expect_every_window_size(velocity_dips(), options, passing.plan->setpoints.t_s.size());
  EXPECT_FALSE(whole.plan);
  EXPECT_NE(whole.error.find("still exceed a limit"), std::string::npos) << whole.error;
  EXPECT_NE(whole.error.find("axis X, velocity"), std::string::npos) << whole.error;
}

// A travel that the set points leave: the same set point (axis, value, s, t, block) is named.
TEST(WindowedChecks, ASetPointOutsideTheTravelIsTheSameOne) {
  Sample narrowed = mikron();
  // Z's travel ends 1 mm below the highest Z the path reaches.
  const auto z = std::find_if(narrowed.machine.axes.begin(), narrowed.machine.axes.end(),
                              [](const kinematics::Axis& axis) { return axis.name == "Z"; });
  ASSERT_NE(z, narrowed.machine.axes.end());
  const auto j = static_cast<Eigen::Index>(z - narrowed.machine.axes.begin());
  z->travel_max = narrowed.path.q.row(j).maxCoeff() - 0.001;
  const Outcome passing = plan_with(mikron(), FeedrateOptions{}, true);
  ASSERT_TRUE(passing.plan);
  const Outcome whole = expect_every_window_size(narrowed, FeedrateOptions{}, passing.plan->setpoints.t_s.size());
  EXPECT_FALSE(whole.plan);
  EXPECT_NE(whole.error.find("outside its travel"), std::string::npos) << whole.error;
  EXPECT_NE(whole.error.find("axis Z"), std::string::npos) << whole.error;
}

// A window of 0 set points is refused, naming the option.
TEST(WindowedChecks, AnEmptyWindowIsRefused) {
  FeedrateOptions options;
  options.check_window_samples = 0;
  EXPECT_THROW(
      {
        try {
          options.validate();
        } catch (const InputError& error) {
          EXPECT_NE(std::string(error.what()).find("check_window_samples"), std::string::npos);
          throw;
        }
      },
      InputError);
}

}  // namespace
}  // namespace vmsim::planner
