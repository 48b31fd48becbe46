// The per-sample work of the chain's "direct kinematics" stage (app/simulate_part.cpp ChainSink):
// the following errors' summary with the tool tip's contour error (FollowingErrorSummary) and
// the thinning of the actual poses (removal::TrajectoryThinner), per servo sample on the Mikron
// sample machine along a slow circle of a few mm (the actual positions 5 samples behind the
// command and a little off), at 0.5 ms (the contour error searches 200 samples either side) and
// at 4 ms a sample. Items per second: samples.
#include <benchmark/benchmark.h>

#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include "following_errors.hpp"
#include "vmsim/kinematics/kinematics.hpp"
#include "vmsim/kinematics/machine_loader.hpp"
#include "vmsim/removal/trajectory.hpp"

namespace {

struct Samples {
  vmsim::kinematics::MachineModel machine;
  std::vector<double> t_s;
  Eigen::MatrixXd q_cmd, q_actual;
};

Samples circle_samples(double period_s, std::size_t n) {
  Samples s{vmsim::kinematics::load_machine(std::string(VMSIM_SOURCE_DIR) + "/samples/machines/mikron_ucp710.yaml"), {}, {}, {}};
  const auto axes = static_cast<Eigen::Index>(s.machine.axes.size());
  std::mt19937 random(7);
  std::normal_distribution<double> noise(0.0, 1.0);
  s.q_cmd.resize(axes, static_cast<Eigen::Index>(n));
  s.q_actual = s.q_cmd;
  for (std::size_t k = 0; k < n; ++k) {
    const auto i = static_cast<Eigen::Index>(k);
    s.t_s.push_back(period_s * static_cast<double>(k));
    const double angle = 2.0 * std::numbers::pi * s.t_s.back() / 20.0;  // 20 s a turn
    for (Eigen::Index j = 0; j < axes; ++j) s.q_cmd(j, i) = j < 3 ? 0.004 * std::cos(angle + static_cast<double>(j)) : 0.05 * std::sin(angle);
    const Eigen::Index behind = i - std::min<Eigen::Index>(i, 5);
    for (Eigen::Index j = 0; j < axes; ++j) s.q_actual(j, i) = s.q_cmd(j, behind) + 1e-7 * noise(random);
  }
  return s;
}

void BM_FollowingErrorSummaryPerSample(benchmark::State& state) {
  const double period_s = static_cast<double>(state.range(0)) * 1e-4;
  const Samples s = circle_samples(period_s, 20000);
  for (auto _ : state) {
    vmsim::app::FollowingErrorSummary summary(s.machine, 0.06, true, false);
    for (std::size_t k = 0; k < s.t_s.size(); ++k) {
      const auto i = static_cast<Eigen::Index>(k);
      summary.add(s.t_s[k], s.q_cmd.col(i), s.q_actual.col(i), s.q_actual.col(i), true);
    }
    benchmark::DoNotOptimize(summary.finish([](double t) { return t; }));
  }
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(s.t_s.size()));
}
BENCHMARK(BM_FollowingErrorSummaryPerSample)->Arg(5)->Arg(40)->Unit(benchmark::kMillisecond);

void BM_TrajectoryThinnerPerSample(benchmark::State& state) {
  const double period_s = static_cast<double>(state.range(0)) * 1e-4;
  const Samples s = circle_samples(period_s, 20000);
  std::vector<vmsim::removal::Pose> poses;
  for (std::size_t k = 0; k < s.t_s.size(); ++k) {
    // The commanded positions: a smooth motion, as the servo's output mostly is.
    const auto pose = vmsim::kinematics::forward_kinematics(s.machine, s.q_cmd.col(static_cast<Eigen::Index>(k)), 0.06);
    poses.push_back({pose.tip_W_m, pose.axis_W});
  }
  std::size_t kept = 0;
  for (auto _ : state) {
    kept = 0;
    vmsim::removal::TrajectoryThinner thinner(0.06, 0.05e-6, [&](std::size_t, const vmsim::removal::Pose&) { ++kept; });
    for (const auto& pose : poses) thinner.push(pose);
    thinner.finish();
  }
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(poses.size()));
  state.counters["kept"] = static_cast<double>(kept);
}
BENCHMARK(BM_TrajectoryThinnerPerSample)->Arg(5)->Arg(40)->Unit(benchmark::kMillisecond);

}  // namespace
