// The set points window by window from the plan's law (SetPointGenerator, SetPointLaw): the
// same values bit for bit as the whole set the planner writes, for windows of every size, and
// s(t) between them as a linear interpolation in the stored set points.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "feedrate_test_support.hpp"
#include "vmsim/planner/feedrate.hpp"

namespace vmsim::planner {
namespace {

using test::Sample;
const auto& path1 = test::mikron_path1;  // the cut of path 1 on the Mikron sample

bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

// Every window of `window` set points against the stored ones, bit for bit.
void expect_windows_equal_the_stored_set_points(const FeedratePlan& plan, std::size_t window) {
  const SetPoints& stored = plan.setpoints;
  SetPointGenerator generator(plan);
  ASSERT_EQ(generator.size(), stored.t_s.size());
  SetPoints part;
  std::size_t compared = 0, differing = 0;
  for (std::size_t first = 0; first < generator.size(); first += window) {
    generator.fill(first, window, part);
    ASSERT_EQ(part.t_s.size(), std::min(window, generator.size() - first));
    EXPECT_EQ(part.period_s, stored.period_s);
    for (std::size_t k = 0; k < part.t_s.size(); ++k) {
      const std::size_t n = first + k;
      differing += !same_bits(part.t_s[k], stored.t_s[n]) || !same_bits(part.s_m[k], stored.s_m[n]);
      for (Eigen::Index j = 0; j < stored.q.rows(); ++j) {
        differing += !same_bits(part.q(j, static_cast<Eigen::Index>(k)), stored.q(j, static_cast<Eigen::Index>(n)));
      }
      ++compared;
    }
  }
  EXPECT_EQ(compared, stored.t_s.size());
  EXPECT_EQ(differing, 0u) << "window " << window;
}

void expect_every_window_size(const FeedrateOptions& options) {
  const FeedratePlan plan = plan_feedrate(path1().machine, path1().path, options);
  const std::size_t n = plan.setpoints.t_s.size();
  ASSERT_GT(n, 100u);
  for (std::size_t window : {std::size_t{1}, std::size_t{2}, std::size_t{7}, std::size_t{101}, n / 2, n, 3 * n}) {
    expect_windows_equal_the_stored_set_points(plan, window);
  }
}

TEST(SetPointGenerator, ThirdOrderPlanWindowsAreTheStoredSetPoints) {
  FeedrateOptions options;  // jerk limits: the linear-acceleration law and the quintic segments
  expect_every_window_size(options);
}

TEST(SetPointGenerator, SecondOrderPlanWindowsAreTheStoredSetPoints) {
  FeedrateOptions options;
  options.third_order = false;
  expect_every_window_size(options);
}

TEST(SetPointGenerator, DynamicPlanWindowsAreTheStoredSetPoints) {
  FeedrateOptions options;
  options.method = FeedrateMethod::dynamic;
  expect_every_window_size(options);
}

// Windows out of order (the generator's cursor goes back) give the same values too.
TEST(SetPointGenerator, WindowsInAnyOrder) {
  FeedrateOptions options;
  const FeedratePlan plan = plan_feedrate(path1().machine, path1().path, options);
  const SetPoints& stored = plan.setpoints;
  SetPointGenerator generator(plan);
  std::mt19937 random(7);
  SetPoints part;
  for (int trial = 0; trial < 50; ++trial) {
    const std::size_t first = random() % stored.t_s.size();
    generator.fill(first, 1 + random() % 40, part);
    for (std::size_t k = 0; k < part.t_s.size(); ++k) {
      ASSERT_TRUE(same_bits(part.s_m[k], stored.s_m[first + k]));
      ASSERT_TRUE(same_bits(part.q(0, static_cast<Eigen::Index>(k)), stored.q(0, static_cast<Eigen::Index>(first + k))));
    }
  }
  generator.fill(stored.t_s.size() + 3, 5, part);  // past the end: nothing
  EXPECT_TRUE(part.t_s.empty());
}

// A plan that drops its set points keeps the same law: the generator still gives them.
TEST(SetPointGenerator, PlanWithoutStoredSetPointsGeneratesTheSameOnes) {
  FeedrateOptions options;
  const FeedratePlan kept = plan_feedrate(path1().machine, path1().path, options);
  options.keep_setpoints = false;
  const FeedratePlan dropped = plan_feedrate(path1().machine, path1().path, options);
  EXPECT_TRUE(dropped.setpoints.t_s.empty());
  EXPECT_EQ(dropped.setpoints.q.size(), 0);
  EXPECT_EQ(dropped.setpoints.period_s, kept.setpoints.period_s);
  EXPECT_EQ(dropped.path_deviation_max_m, kept.path_deviation_max_m);
  expect_windows_equal_the_stored_set_points(
      [&] {
        FeedratePlan combined = dropped;
        combined.setpoints = kept.setpoints;
        return combined;
      }(),
      64);
}

// s(t): the stored samples interpolated linearly (std::upper_bound on their times), bit for bit,
// at random times, at the samples' own times and outside the run.
TEST(SetPointLaw, SAtTimeIsTheLinearInterpolationOfTheStoredSetPoints) {
  FeedrateOptions options;
  const FeedratePlan plan = plan_feedrate(path1().machine, path1().path, options);
  const auto& t = plan.setpoints.t_s;
  const auto& s = plan.setpoints.s_m;
  const auto interpolated = [&](double time) {
    if (time <= t.front()) return s.front();
    if (time >= t.back()) return s.back();
    const auto k = static_cast<std::size_t>(std::upper_bound(t.begin(), t.end(), time) - t.begin());
    const double f = (time - t[k - 1]) / (t[k] - t[k - 1]);
    return s[k - 1] + f * (s[k] - s[k - 1]);
  };
  std::mt19937 random(11);
  std::uniform_real_distribution<double> when(-0.1, t.back() + 0.1);
  std::vector<double> times{-1.0, 0.0, t.back(), t.back() + 1.0, t[1], t[t.size() / 2], t[t.size() - 2]};
  for (int k = 0; k < 2000; ++k) times.push_back(when(random));
  for (double time : times) {
    EXPECT_TRUE(same_bits(plan.law.s_at_time(time), interpolated(time))) << "t = " << time;
  }
}

}  // namespace
}  // namespace vmsim::planner
