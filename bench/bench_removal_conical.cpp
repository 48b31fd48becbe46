// Removal speed with a conical tool (V and tapered ball-end) on a tilted straight move.
//   cmake --build <build> --target bench_removal_conical && <build>/bench/bench_removal_conical
//  - BM_SweepInterval_*: the exact line / swept-tool interval (removal/src/profile.hpp,
//    profile_sweep_interval) for the vertical lines of a 20 um grid over the move and around
//    it; counter evaluations_per_s (line evaluations per CPU second), hit_fraction (lines the
//    sweep meets, to show the work is real).
//  - BM_ZmapCut_*: the whole Z-map cut of the same move on a 10 um grid (NBuffer::cut, 1
//    thread), counter lines_per_s (grid lines of the stock per CPU second) and lines_lowered.
// The move: tip (-2, -0.5, 4.6) mm to (2, 0.5, 4.2) mm, axis (0.2, -0.1, 1) normalised (12.6 deg
// from z), stock top 5 mm. Tools: V D3 90 deg; tapered ball-end D3, tip D0.8, 6 deg per side.
#include <benchmark/benchmark.h>

#include <cmath>
#include <vector>

#include "../removal/src/profile.hpp"
#include "vmsim/removal/nbuffer.hpp"

namespace {

using vmsim::removal::Box;
using vmsim::removal::CutOptions;
using vmsim::removal::NBuffer;
using vmsim::removal::Pose;
using vmsim::removal::Tool;
using vmsim::removal::ToolType;

constexpr double kMm = 1e-3;
constexpr double kDeg = M_PI / 180.0;

Tool v_tool() {
  Tool t;
  t.type = ToolType::v;
  t.diameter_m = 3 * kMm;
  t.length_m = 20 * kMm;
  t.tip_angle_rad = 90 * kDeg;
  return t;
}

Tool tapered_ball_tool() {
  Tool t;
  t.type = ToolType::tapered_ball;
  t.diameter_m = 3 * kMm;
  t.length_m = 20 * kMm;
  t.tip_diameter_m = 0.8 * kMm;
  t.taper_angle_rad = 6 * kDeg;
  return t;
}

const Eigen::Vector3d kTip0_m = Eigen::Vector3d(-2.0, -0.5, 4.6) * kMm;
const Eigen::Vector3d kTip1_m = Eigen::Vector3d(2.0, 0.5, 4.2) * kMm;
const Eigen::Vector3d kAxis = Eigen::Vector3d(0.2, -0.1, 1.0).normalized();
const Box kStock{Eigen::Vector3d(-4, -3, 0) * kMm, Eigen::Vector3d(4, 3, 5) * kMm};

void sweep_interval(benchmark::State& state, const Tool& tool) {
  tool.validate();
  const vmsim::removal::detail::Profile profile = vmsim::removal::detail::make_profile(tool);
  constexpr double kGrid_m = 0.02 * kMm;
  const int nx = static_cast<int>(std::lround((kStock.max_W_m.x() - kStock.min_W_m.x()) / kGrid_m));
  const int ny = static_cast<int>(std::lround((kStock.max_W_m.y() - kStock.min_W_m.y()) / kGrid_m));
  const Eigen::Vector3d down(0.0, 0.0, -1.0);
  std::size_t evaluations = 0, hits = 0;
  for (auto _ : state) {
    for (int j = 0; j < ny; ++j) {
      for (int i = 0; i < nx; ++i) {
        const Eigen::Vector3d origin(kStock.min_W_m.x() + (i + 0.5) * kGrid_m, kStock.min_W_m.y() + (j + 0.5) * kGrid_m,
                                     kStock.max_W_m.z());
        double t0 = 0.0, t1 = 0.0;
        hits += vmsim::removal::detail::profile_sweep_interval(profile, kTip0_m, kTip1_m, kAxis, origin, down, t0, t1);
        benchmark::DoNotOptimize(t0);
        ++evaluations;
      }
    }
  }
  state.counters["evaluations_per_s"] =
      benchmark::Counter(static_cast<double>(evaluations), benchmark::Counter::kIsRate);
  state.counters["hit_fraction"] = static_cast<double>(hits) / static_cast<double>(evaluations);
}

void zmap_cut(benchmark::State& state, const Tool& tool) {
  const std::vector<Pose> path = {Pose{kTip0_m, kAxis}, Pose{kTip1_m, kAxis}};
  CutOptions options;
  options.threads = 1;
  std::size_t lines = 0, lowered = 0;
  for (auto _ : state) {
    state.PauseTiming();
    NBuffer buffer = NBuffer::zmap(kStock, 0.01 * kMm);
    state.ResumeTiming();
    const auto stats = buffer.cut(tool, path, options);
    lowered += stats.lines_lowered;
    lines += static_cast<std::size_t>(buffer.nu()) * static_cast<std::size_t>(buffer.nv());
    benchmark::DoNotOptimize(buffer.length(buffer.nu() / 2, buffer.nv() / 2));
  }
  state.counters["lines_per_s"] = benchmark::Counter(static_cast<double>(lines), benchmark::Counter::kIsRate);
  state.counters["lines_lowered"] = static_cast<double>(lowered) / static_cast<double>(state.iterations());
}

void BM_SweepInterval_V90(benchmark::State& s) { sweep_interval(s, v_tool()); }
void BM_SweepInterval_TaperedBall(benchmark::State& s) { sweep_interval(s, tapered_ball_tool()); }
void BM_ZmapCut_V90(benchmark::State& s) { zmap_cut(s, v_tool()); }
void BM_ZmapCut_TaperedBall(benchmark::State& s) { zmap_cut(s, tapered_ball_tool()); }

BENCHMARK(BM_SweepInterval_V90)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_SweepInterval_TaperedBall)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ZmapCut_V90)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ZmapCut_TaperedBall)->Unit(benchmark::kMillisecond);

}  // namespace
