// Feedrate interpolation on hard paths: dense, only velocity-continuous, with axis reversals and
// near-zero path velocity; the singular zone of the table-table machine (path 2). And the
// quintic interpolation of q(s) the set points use.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <string>

#include "feedrate_test_support.hpp"
#include "vmsim/kinematics/machine_loader.hpp"
#include "vmsim/kinematics/sample_models.hpp"
#include "vmsim/planner/feedrate.hpp"
#include "vmsim/toolpath/toolpath.hpp"

namespace vmsim::planner {
namespace {

using test::finite_difference_ratios;
using test::sample_path;

TEST(PathSpline, ReproducesAQuinticAndItsDerivatives) {
  // q(s) = 1 + 2 s - s^2 + 3 s^3 - 4 s^4 + 5 s^5 on [0, 1], sampled at 7 points.
  auto f = [](double s, Eigen::VectorXd& q, Eigen::VectorXd& qs, Eigen::VectorXd& qss,
              Eigen::VectorXd& qsss) {
    q.setZero(); qs.setZero(); qss.setZero(); qsss.setZero();
    q(0) = 1 + 2 * s - s * s + 3 * s * s * s - 4 * std::pow(s, 4) + 5 * std::pow(s, 5);
    qs(0) = 2 - 2 * s + 9 * s * s - 16 * std::pow(s, 3) + 25 * std::pow(s, 4);
    qss(0) = -2 + 18 * s - 48 * s * s + 100 * std::pow(s, 3);
    qsss(0) = 18 - 96 * s + 300 * s * s;
  };
  const auto path = sample_path(1, 1.0, 7, f);
  const PathSpline spline(path);
  Eigen::VectorXd q(1), qs(1), qss(1), qsss(1), a, b, c, d;
  for (double s = 0.0; s <= 1.0; s += 0.0137) {
    f(s, q, qs, qss, qsss);
    const auto seg = spline.segment_of(s);
    spline.evaluate(seg, s - spline.s_m()[seg], &a, &b, &c, &d);
    EXPECT_NEAR(a(0), q(0), 1e-12);
    EXPECT_NEAR(b(0), qs(0), 1e-10);
    EXPECT_NEAR(c(0), qss(0), 1e-9);
    EXPECT_NEAR(d(0), qsss(0), 1e-7);
  }
}

// On micrometre segments the quintic's q_sss must not carry the rounding of q over h^3: a
// sinusoid plus a ramp far from q = 0 (q ~ 0.24 m) on 3 um segments, where 1 ulp of q is 5e-17 m
// and h^3 = 2.7e-17 m^3 (the quintic through the rounded q had q_sss errors of up to 100 against
// a true 22). Positions stay within a few ulps at the knots.
TEST(PathSpline, MicrometreSegmentsKeepTheThirdDerivative) {
  const double w = 2.0 * std::numbers::pi / 0.3, a = 0.05 / w;
  auto f = [&](double s, Eigen::VectorXd& q, Eigen::VectorXd& qs, Eigen::VectorXd& qss,
               Eigen::VectorXd& qsss) {
    q(0) = 0.8 * s + a * std::sin(w * s);
    qs(0) = 0.8 + a * w * std::cos(w * s);
    qss(0) = -a * w * w * std::sin(w * s);
    qsss(0) = -a * w * w * w * std::cos(w * s);
  };
  const std::size_t points = 100001;
  const auto path = sample_path(1, 0.3, points, f);
  const PathSpline spline(path);
  Eigen::VectorXd q(1), qs(1), qss(1), qsss(1), p, v, acc, jerk;
  double worst_jerk = 0.0, worst_q = 0.0;
  for (std::size_t i = 60000; i + 1 < points; i += 7) {  // near s = 0.18 m: q ~ 0.15 m
    for (double lambda : {0.0, 0.5, 1.0}) {
      const double h = spline.s_m()[i + 1] - spline.s_m()[i];
      f(spline.s_m()[i] + lambda * h, q, qs, qss, qsss);
      spline.evaluate(i, lambda * h, &p, &v, &acc, &jerk);
      worst_jerk = std::max(worst_jerk, std::abs(jerk(0) - qsss(0)));
      worst_q = std::max(worst_q, std::abs(p(0) - q(0)));
    }
  }
  EXPECT_LT(worst_jerk, 1e-3 * a * w * w * w) << "q_sss off by " << worst_jerk;
  EXPECT_LT(worst_q, 1e-15);
}

// Paths with fitted derivatives (from solve_path_kinematics) get the clamped cubic spline through
// the points: it reproduces a cubic exactly from its values and end slopes alone (the fitted
// q_ss, q_sss in between are ignored: wrong values are given here on purpose), on uneven spacing.
TEST(PathSpline, FittedPathsAreTheClampedCubicThroughThePoints) {
  auto f = [](double s) { return 1 + 2 * s - s * s + 3 * s * s * s; };
  auto f_s = [](double s) { return 2 - 2 * s + 9 * s * s; };
  const std::vector<double> s_points{0.0, 0.07, 0.2, 0.26, 0.5, 0.61, 0.8, 0.93, 1.0};
  kinematics::PathKinematics path;
  path.s_m = s_points;
  const auto n = static_cast<Eigen::Index>(s_points.size());
  path.q.resize(1, n);
  path.q_s = Eigen::MatrixXd::Constant(1, n, 123.0);
  path.q_ss = Eigen::MatrixXd::Constant(1, n, -45.0);
  path.q_sss = Eigen::MatrixXd::Constant(1, n, 6.0e3);
  for (Eigen::Index i = 0; i < n; ++i) path.q(0, i) = f(s_points[static_cast<std::size_t>(i)]);
  path.q_s(0, 0) = f_s(0.0);
  path.q_s(0, n - 1) = f_s(1.0);
  path.derivatives_fitted = true;
  const PathSpline spline(path);
  Eigen::VectorXd a, b, c, d;
  for (double s = 0.0; s <= 1.0; s += 0.0137) {
    const auto seg = spline.segment_of(s);
    spline.evaluate(seg, s - spline.s_m()[seg], &a, &b, &c, &d);
    EXPECT_NEAR(a(0), f(s), 1e-12);
    EXPECT_NEAR(b(0), f_s(s), 1e-11);
    EXPECT_NEAR(c(0), -2 + 18 * s, 1e-10);
    EXPECT_NEAR(d(0), 18.0, 1e-8);
  }
}

/// Dense path (0.12 m; 12 000 or 36 000 points), only velocity-continuous: Y is piecewise
/// quadratic in s (its q_ss jumps every 10 mm), it reverses several times, and X nearly stops
/// (q_s of X down to 1e-3), so that the path velocity limit from X is large there while Y
/// limits it.
void dense(double s, Eigen::VectorXd& q, Eigen::VectorXd& qs, Eigen::VectorXd& qss,
           Eigen::VectorXd& qsss) {
  q.setZero(); qs.setZero(); qss.setZero(); qsss.setZero();
  const double piece = 0.01;
  const int k = static_cast<int>(std::floor(s / piece));
  const double c = (k % 2 == 0 ? 40.0 : -40.0);  // curvature of Y, alternating
  // Y: integrate piecewise-constant curvature, velocity-continuous; starts with slope 0.3.
  double y = 0.0, ys = 0.3;
  for (int i = 0; i < k; ++i) {
    const double ci = (i % 2 == 0 ? 40.0 : -40.0);
    y += ys * piece + 0.5 * ci * piece * piece;
    ys += ci * piece;
  }
  const double r = s - k * piece;
  q(1) = y + ys * r + 0.5 * c * r * r;
  qs(1) = ys + c * r;
  qss(1) = c;
  // X: smooth, q_s between 1e-3 and 1.
  const double w = 2.0 * std::numbers::pi / 0.06;
  q(0) = 0.5005 * s - 0.4995 * std::sin(w * s) / w;
  qs(0) = 0.5005 - 0.4995 * std::cos(w * s);
  qss(0) = 0.4995 * w * std::sin(w * s);
  qsss(0) = 0.4995 * w * w * std::cos(w * s);
}

kinematics::MachineModel limited_machine() {
  auto m = kinematics::make_table_table_sample();
  for (auto& axis : m.axes) axis.limits = {0.5, 2.5, 50.0};
  m.interpolation_period_s = 0.002;
  return m;
}

// At 12 000 points and at 36 000 (TOPP-RA, the reference open solver, fails outright at 30 000
// points of such a path and overshoots the acceleration 2.5-12 times below that).
class DensePath : public ::testing::TestWithParam<int> {};

TEST_P(DensePath, SecondOrderNeverOvershoots) {
  const auto machine = limited_machine();
  const auto path = sample_path(5, 0.12, static_cast<std::size_t>(GetParam()), dense);
  FeedrateOptions options;
  options.third_order = false;
  options.max_grid_step_m = 1.0;
  const FeedratePlan plan = plan_feedrate(machine, path, options);
  const auto r = finite_difference_ratios(plan.setpoints, plan.limits);
  // Allowance 1e-4: the planner checks its rows at both ends of each grid segment and its set
  // points at that level (finite differences are exact means, so rounding is far below).
  EXPECT_LE(r.velocity, 1.0 + 1e-4);
  EXPECT_LE(r.acceleration, 1.0 + 1e-4);
  EXPECT_GT(r.acceleration, 0.9);
  EXPECT_GE(plan.duration_s, plan.lower_bound_s);
}

// Third order on the same path: the jerk rows, not the second-order profile, force the slow-downs
// at the curvature jumps and the reversals of Y (x ~ 1e-11 m^2/s^2 at some grid points there).
// 5-6 s for either size; it took 7.5 minutes of slow-down rounds before the set points followed
// the planned law and x was kept >= 0 inside each grid segment (the quadratic through a near
// stop dipped below 0, and the fallback quintic exceeded the jerk 25 times).
TEST_P(DensePath, ThirdOrderNeverOvershoots) {
  const auto machine = limited_machine();
  const auto path = sample_path(5, 0.12, static_cast<std::size_t>(GetParam()), dense);
  FeedrateOptions options;
  options.max_grid_step_m = 1.0;
  const FeedratePlan plan = plan_feedrate(machine, path, options);
  const auto r = finite_difference_ratios(plan.setpoints, plan.limits);
  EXPECT_LE(r.velocity, 1.0 + 1e-4);
  EXPECT_LE(r.acceleration, 1.0 + 1e-4);
  EXPECT_LE(r.jerk, 1.0 + 1e-4);
  EXPECT_GE(plan.duration_s, plan.lower_bound_s);
}

INSTANTIATE_TEST_SUITE_P(Points, DensePath, ::testing::Values(12001, 36001));

// Sample path 2 (blade-like, passing 1.06 deg from the table-table machine's singularity) on
// the Mikron sample, tool length 60 mm.
kinematics::PathKinematics path2_blade(const kinematics::MachineModel& machine) {
  const toolpath::Toolpath tp = toolpath::read_apt(std::string(VMSIM_SOURCE_DIR) + "/samples/parts/path2_blade/toolpath.apt");
  std::vector<kinematics::PathPose> poses;
  for (const auto& p : tp.points) {
    if (!poses.empty() && (poses.back().pose.tip_W_m - p.tip_W_m).norm() < 1e-12) continue;
    poses.push_back({{p.tip_W_m, p.axis_W}, p.block});
  }
  return kinematics::solve_path_kinematics(machine, poses, machine.home_positions(), 0.060, {});
}

TEST(Path2Blade, SingularZoneSecondOrder) {
  const auto machine = kinematics::load_machine(std::string(VMSIM_SOURCE_DIR) + "/samples/machines/mikron_ucp710.yaml");
  const auto path = path2_blade(machine);
  FeedrateOptions options;
  options.third_order = false;
  options.feed_m_per_s = 10.0 / 60.0;
  const FeedratePlan plan = plan_feedrate(machine, path, options);
  const auto r = finite_difference_ratios(plan.setpoints, plan.limits);
  EXPECT_LE(r.velocity, 1.0 + 1e-4);
  EXPECT_LE(r.acceleration, 1.0 + 1e-4);
  EXPECT_TRUE(std::isfinite(plan.duration_s));
}

// Third order through the singular zone (about 7 s: slow-down rounds where C swings).
TEST(Path2Blade, SingularZoneThirdOrder) {
  // The table-table machine's singular zone (the C axis swings fast where the tool axis passes
  // the A axis): the path velocity nearly vanishes there; jerk limits on every axis.
  const auto machine = kinematics::load_machine(std::string(VMSIM_SOURCE_DIR) + "/samples/machines/mikron_ucp710.yaml");
  const auto path = path2_blade(machine);
  FeedrateOptions options;
  options.feed_m_per_s = 10.0 / 60.0;
  const FeedratePlan plan = plan_feedrate(machine, path, options);
  const auto r = finite_difference_ratios(plan.setpoints, plan.limits);
  EXPECT_LE(r.velocity, 1.0 + 1e-4);
  EXPECT_LE(r.acceleration, 1.0 + 1e-4);
  EXPECT_LE(r.jerk, 1.0 + 1e-4);
  EXPECT_GE(plan.duration_s, plan.lower_bound_s);
}

}  // namespace
}  // namespace vmsim::planner
