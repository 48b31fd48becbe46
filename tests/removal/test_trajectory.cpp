// The streamed trajectory thinning (TrajectoryThinner, one sample at a time as the direct
// kinematics produces them) against the whole-trajectory thinning the chain used before
// (written out here as it was: every sample in memory, the greedy scan), on random
// trajectories: the same samples kept, hence the same poses cut and the same surface bit for bit.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "removal_test_tools.hpp"
#include "vmsim/removal/nbuffer.hpp"
#include "vmsim/removal/trajectory.hpp"

namespace vmsim::removal {
namespace {

constexpr double mm = 1e-3;

// The whole-trace thinning as app/simulate_part.cpp had it before the chain streamed.
std::vector<std::size_t> thin_whole(const std::vector<Pose>& poses, double tool_length_m, double tolerance_m) {
  constexpr std::size_t kMaxWindow = 256;
  std::vector<std::size_t> kept{0};
  if (poses.size() < 2) return kept;
  auto deviation = [&](std::size_t a, std::size_t b, std::size_t k) {
    const double f = static_cast<double>(k - a) / static_cast<double>(b - a);
    const Eigen::Vector3d tip = (1 - f) * poses[a].tip_W_m + f * poses[b].tip_W_m;
    const Eigen::Vector3d top = tip + tool_length_m * ((1 - f) * poses[a].axis_W + f * poses[b].axis_W);
    const Eigen::Vector3d top_k = poses[k].tip_W_m + tool_length_m * poses[k].axis_W;
    return std::max((poses[k].tip_W_m - tip).norm(), (top_k - top).norm());
  };
  std::size_t anchor = 0;
  while (anchor + 1 < poses.size()) {
    std::size_t end = anchor + 1;
    while (end + 1 < poses.size() && end + 1 - anchor <= kMaxWindow) {
      const std::size_t candidate = end + 1;
      bool ok = true;
      for (std::size_t k = anchor + 1; k < candidate && ok; ++k) ok = deviation(anchor, candidate, k) <= tolerance_m;
      if (!ok) break;
      end = candidate;
    }
    kept.push_back(end);
    anchor = end;
  }
  return kept;
}

// A servo-like trajectory: long straight stretches (sampled finely, as a low feed is), arcs,
// stops (repeated samples), small noise, a turning axis in places.
std::vector<Pose> random_trajectory(std::mt19937& rng, std::size_t samples) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::vector<Pose> poses;
  Eigen::Vector3d p(-4, -3, 6);
  double heading = 0.0, tilt = 0.0;
  while (poses.size() < samples) {
    const int kind = static_cast<int>(unit(rng) * 4);
    const int n = 20 + static_cast<int>(unit(rng) * 600);
    const double turn = kind == 1 ? (unit(rng) - 0.5) * 0.02 : 0.0;
    const double step = kind == 2 ? 0.0 : 0.002 + 0.01 * unit(rng);
    const double tilt_rate = kind == 3 ? 2e-4 : 0.0;
    for (int k = 0; k < n && poses.size() < samples; ++k) {
      heading += turn;
      tilt += tilt_rate;
      p += step * Eigen::Vector3d(std::cos(heading), std::sin(heading), 0.05 * std::sin(3 * heading));
      const Eigen::Vector3d noise = 2e-5 * Eigen::Vector3d(unit(rng) - 0.5, unit(rng) - 0.5, unit(rng) - 0.5);
      poses.push_back({(p + noise) * mm, Eigen::Vector3d(std::sin(tilt), 0.0, std::cos(tilt))});
    }
  }
  return poses;
}

TEST(TrajectoryThinner, KeepsTheSamplesTheWholeTraceThinningKeeps) {
  for (unsigned seed = 0; seed < 8; ++seed) {
    std::mt19937 rng(seed);
    const std::size_t samples = 2 + seed * 1500;
    const std::vector<Pose> poses = random_trajectory(rng, samples);
    for (double tolerance : {0.05e-6, 1e-6, 20e-6}) {
      const std::vector<std::size_t> whole = thin_whole(poses, 30 * mm, tolerance);
      std::vector<std::size_t> streamed;
      std::vector<Pose> streamed_poses;
      TrajectoryThinner thinner(30 * mm, tolerance, [&](std::size_t k, const Pose& pose) {
        streamed.push_back(k);
        streamed_poses.push_back(pose);
      });
      for (const Pose& pose : poses) thinner.push(pose);
      thinner.finish();
      ASSERT_EQ(streamed, whole) << "seed " << seed << ", tolerance " << tolerance;
      for (std::size_t i = 0; i < streamed.size(); ++i) {
        ASSERT_EQ(streamed_poses[i].tip_W_m, poses[streamed[i]].tip_W_m);
        ASSERT_EQ(streamed_poses[i].axis_W, poses[streamed[i]].axis_W);
      }
      EXPECT_EQ(thin_trajectory(poses, 30 * mm, tolerance), whole);
      if (samples > 1000) {
        EXPECT_LT(whole.size(), samples);  // it thins
      }
    }
  }
}

TEST(TrajectoryThinner, WindowedChainCutsTheSameSurface) {
  // The surface cut from the streamed thinning equals the one from the whole-trace thinning
  // bit for bit, plain and compact.
  std::mt19937 rng(42);
  const std::vector<Pose> poses = random_trajectory(rng, 6000);
  const std::vector<std::size_t> whole = thin_whole(poses, 30 * mm, 0.05e-6);
  std::vector<Pose> whole_poses, streamed_poses;
  for (std::size_t k : whole) whole_poses.push_back(poses[k]);
  TrajectoryThinner thinner(30 * mm, 0.05e-6, [&](std::size_t, const Pose& pose) { streamed_poses.push_back(pose); });
  for (const Pose& pose : poses) thinner.push(pose);
  thinner.finish();
  const Box stock{Eigen::Vector3d(-8, -8, 0) * mm, Eigen::Vector3d(8, 8, 6.2) * mm};
  const Tool ball = test::make_tool(ToolType::ball, 2, 1);
  for (bool compact : {false, true}) {
    NBuffer a = NBuffer::zmap(stock, 0.04 * mm), b = a;
    if (compact) a.make_compact(), b.make_compact();
    a.cut(ball, whole_poses);
    b.cut(ball, streamed_poses);
    const std::vector<double> la = a.lengths(), lb = b.lengths();
    std::size_t cut = 0;
    for (double h : la) cut += h < 6.2 * mm ? 1 : 0;
    EXPECT_GT(cut, 1000u);
    EXPECT_EQ(la, lb);
  }
}

// The thinner checks a sample again only when the candidate's drift may have taken it out of
// the tolerance (removal/trajectory.hpp). Against the plain scan (thin_whole: every sample at
// every candidate) where the decisions are closest: slow and fast stretches whose speed varies
// from sample to sample (the drift grows), a wobble of nearly the tolerance, coordinates
// far from the origin (1 to 40 m, a larger margin scale), and tool changes (restart_from: the
// stretch after it is thinned from the moved anchor, which the plain scan gets as its first pose).
TEST(TrajectoryThinner, SkippedChecksChangeNoDecision) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::size_t kept_total = 0, samples_total = 0;
  for (unsigned seed = 0; seed < 24; ++seed) {
    std::mt19937 rng(100 + seed);
    const double tolerance = seed % 3 == 0 ? 0.05e-6 : seed % 3 == 1 ? 1e-6 : 10e-6;
    const double length = 0.02 + 0.1 * unit(rng);
    const Eigen::Vector3d origin = (1.0 + 39.0 * unit(rng) * (seed % 2)) * Eigen::Vector3d(1.0, -0.5, 0.25);
    // Stretches between tool changes, each its own plain thinning.
    std::vector<std::vector<Pose>> stretches(1 + seed % 4);
    Eigen::Vector3d p = origin;
    double heading = 0.0, tilt = 0.1, speed = 1e-4;
    for (auto& stretch : stretches) {
      const std::size_t n = 200 + static_cast<std::size_t>(unit(rng) * 1500);
      for (std::size_t k = 0; k < n; ++k) {
        if (k % 97 == 0) speed = std::pow(10.0, -7.0 + 4.0 * unit(rng));  // 0.1 um to 1 mm a sample
        speed *= 1.0 + 0.02 * (unit(rng) - 0.5);
        heading += 0.002 * (unit(rng) - 0.5);
        tilt += 1e-5 * (unit(rng) - 0.3);
        p += speed * Eigen::Vector3d(std::cos(heading), std::sin(heading), 0.1);
        const Eigen::Vector3d wobble = 0.4 * tolerance * Eigen::Vector3d(unit(rng) - 0.5, unit(rng) - 0.5, unit(rng) - 0.5);
        stretch.push_back({p + wobble, Eigen::Vector3d(std::sin(tilt), 0.0, std::cos(tilt))});
      }
    }
    // The plain scan, stretch by stretch; a later stretch starts from the last pose of the one
    // before moved 5 mm down (the new tool's tip), not reported again.
    std::vector<std::size_t> expected;
    std::size_t offset = 0;
    for (std::size_t s = 0; s < stretches.size(); ++s) {
      std::vector<Pose> poses = stretches[s];
      if (s > 0) {
        Pose anchor = stretches[s - 1].back();
        anchor.tip_W_m.z() -= 5e-3;
        poses.insert(poses.begin(), anchor);
      }
      const std::vector<std::size_t> kept = thin_whole(poses, length, tolerance);
      for (std::size_t i = s > 0 ? 1 : 0; i < kept.size(); ++i) expected.push_back(kept[i] + offset - (s > 0 ? 1 : 0));
      offset += stretches[s].size();
    }
    std::vector<std::size_t> streamed;
    TrajectoryThinner thinner(length, tolerance, [&](std::size_t k, const Pose&) { streamed.push_back(k); });
    for (std::size_t s = 0; s < stretches.size(); ++s) {
      if (s > 0) {
        Pose anchor = stretches[s - 1].back();
        anchor.tip_W_m.z() -= 5e-3;
        thinner.restart_from(anchor);
      }
      for (const Pose& pose : stretches[s]) thinner.push(pose);
    }
    thinner.finish();
    ASSERT_EQ(streamed, expected) << "seed " << seed;
    kept_total += streamed.size();
    samples_total += offset;
  }
  EXPECT_LT(kept_total, samples_total * 7 / 10);  // it thins: most decisions are to go on
}

TEST(TrajectoryThinner, SingleAndTwoSamples) {
  std::vector<std::size_t> kept;
  TrajectoryThinner one(0.03, 1e-6, [&](std::size_t k, const Pose&) { kept.push_back(k); });
  one.push({});
  one.finish();
  EXPECT_EQ(kept, std::vector<std::size_t>{0});
  kept.clear();
  TrajectoryThinner two(0.03, 1e-6, [&](std::size_t k, const Pose&) { kept.push_back(k); });
  two.push({});
  two.push({Eigen::Vector3d(1, 0, 0), Eigen::Vector3d::UnitZ()});
  two.finish();
  EXPECT_EQ(kept, (std::vector<std::size_t>{0, 1}));
}

}  // namespace
}  // namespace vmsim::removal

namespace vmsim::removal {
namespace {

// A tool change to a tool 35 mm longer after sample 9 of a straight line (samples 10..19 have
// their tips 35 mm lower, the axes moving on): the thinner keeps sample 9 and thins on from it
// seen with the new tool, so the second stretch is one segment from that anchor to sample 19.
// Thinned across the change, samples 10..18 would lie up to 35 mm off the interpolation.
TEST(TrajectoryThinnerToolChange, KeepsTheSampleBeforeTheChangeAndThinsOnFromItWithTheNewTool) {
  const Eigen::Vector3d z = Eigen::Vector3d::UnitZ();
  const double drop = 35e-3;
  std::vector<std::size_t> kept;
  std::vector<Pose> kept_poses;
  TrajectoryThinner thinner(20e-3, 0.05e-6, [&](std::size_t k, const Pose& pose) {
    kept.push_back(k);
    kept_poses.push_back(pose);
  });
  for (int k = 0; k < 20; ++k) {
    const Eigen::Vector3d tip(k * 1e-3, 0.0, k < 10 ? 0.0 : -drop);
    if (k == 10) thinner.restart_from({Eigen::Vector3d(9e-3, 0.0, -drop), z});
    thinner.push({tip, z});
  }
  thinner.finish();
  EXPECT_EQ(kept, (std::vector<std::size_t>{0, 9, 19}));
  EXPECT_NEAR(kept_poses[1].tip_W_m.z(), 0.0, 1e-15);  // reported with the old tool
  // Without the restart, the samples after the change are kept one by one near the jump.
  std::vector<std::size_t> plain;
  TrajectoryThinner across(20e-3, 0.05e-6, [&](std::size_t k, const Pose&) { plain.push_back(k); });
  for (int k = 0; k < 20; ++k) across.push({Eigen::Vector3d(k * 1e-3, 0.0, k < 10 ? 0.0 : -drop), z});
  across.finish();
  EXPECT_EQ(plain, (std::vector<std::size_t>{0, 9, 10, 19}));
}

}  // namespace
}  // namespace vmsim::removal
