// Level-set (OpenVDB) material removal: tool-segment updates per second for a ball-end finishing
// raster at 20 um voxels, 1 and 2 threads; the memory of a 100 x 100 mm part with a coarse grid
// and fine regions.
//
//   build-dir/bench/bench_removal_level_set --benchmark_min_time=2
//
// Finishing raster: a 10 x 10 x 3 mm box stock, lines along x at 0.1 mm samples, 0.1 mm below
// the top, stepover 0.3 mm (ball D6) or 0.5 mm (ball D10), zig-zag. Each iteration cuts the
// whole raster on a fresh copy of the stock (the copy is not timed).
#include <benchmark/benchmark.h>

#include <vector>

#include "vmsim/removal/level_set.hpp"

namespace {

using namespace vmsim::removal;
constexpr double mm = 1e-3;

Tool ball(double d_mm) {
  Tool t;
  t.type = ToolType::ball;
  t.diameter_m = d_mm * mm;
  t.corner_radius_m = 0.5 * d_mm * mm;
  t.length_m = 30 * mm;
  return t;
}

std::vector<Pose> raster(double x0, double x1, double y0, double y1, double z, double stepover, double sample) {
  std::vector<Pose> path;
  const int lines = static_cast<int>((y1 - y0) / stepover) + 1;
  const int samples = static_cast<int>((x1 - x0) / sample);
  for (int j = 0; j < lines; ++j) {
    for (int i = 0; i <= samples; ++i) {
      const double s = static_cast<double>(j % 2 ? samples - i : i) / samples;
      path.push_back(Pose{Eigen::Vector3d(x0 + s * (x1 - x0), y0 + j * stepover, z), Eigen::Vector3d::UnitZ()});
    }
  }
  return path;
}

void finishing(benchmark::State& state, double d_mm, double stepover_mm) {
  LevelSetOptions options;
  options.voxel_m = 20e-6;
  const LevelSetStock stock = LevelSetStock::box(Box{Eigen::Vector3d::Zero(), Eigen::Vector3d(10, 10, 3) * mm}, options);
  const std::vector<Pose> path = raster(1 * mm, 9 * mm, 2 * mm, 8 * mm, 2.9 * mm, stepover_mm * mm, 0.1 * mm);
  const Tool tool = ball(d_mm);
  LevelSetCutOptions cut;
  cut.threads = static_cast<int>(state.range(0));
  LevelSetCutStatistics stats;
  for (auto _ : state) {
    state.PauseTiming();
    LevelSetStock s = stock.copy();
    state.ResumeTiming();
    stats = s.cut(tool, path, cut);
    benchmark::DoNotOptimize(stats);
    state.PauseTiming();
    s = LevelSetStock::box(Box{Eigen::Vector3d::Zero(), Eigen::Vector3d::Constant(1 * mm)}, options);  // free untimed
    state.ResumeTiming();
  }
  state.counters["segments/s"] =
      benchmark::Counter(static_cast<double>(path.size() - 1), benchmark::Counter::kIsIterationInvariantRate);
  state.counters["voxels_evaluated/segment"] =
      static_cast<double>(stats.voxels_evaluated) / static_cast<double>(path.size() - 1);
  state.counters["voxels_changed/segment"] = static_cast<double>(stats.voxels_changed) / static_cast<double>(path.size() - 1);
}

void BM_LevelSetBallD6Finishing20um(benchmark::State& state) { finishing(state, 6, 0.3); }
void BM_LevelSetBallD10Finishing20um(benchmark::State& state) { finishing(state, 10, 0.5); }
BENCHMARK(BM_LevelSetBallD6Finishing20um)->Arg(1)->Arg(2)->UseRealTime()->Unit(benchmark::kMillisecond);
BENCHMARK(BM_LevelSetBallD10Finishing20um)->Arg(1)->Arg(2)->UseRealTime()->Unit(benchmark::kMillisecond);

// A 100 x 100 x 30 mm part: 0.2 mm voxels over the whole stock, 20 um voxels in four 10 x 10 mm
// boxes at the top (corners, tangency zones), after one ball D10 raster line across two of them.
void BM_LevelSetMemory100mmPart(benchmark::State& state) {
  LevelSetOptions options;
  options.voxel_m = 0.2e-3;
  for (double x : {10.0, 45.0}) {
    for (double y : {10.0, 80.0}) {
      options.regions.push_back(LevelSetRegion{Box{Eigen::Vector3d(x, y, 25) * mm, Eigen::Vector3d(x + 10, y + 10, 31) * mm}, 20e-6});
    }
  }
  std::size_t bytes = 0, voxels = 0;
  for (auto _ : state) {
    LevelSetStock s = LevelSetStock::box(Box{Eigen::Vector3d::Zero(), Eigen::Vector3d(100, 100, 30) * mm}, options);
    const std::vector<Pose> line = raster(5 * mm, 95 * mm, 15 * mm, 15 * mm, 29.8 * mm, 1 * mm, 0.1 * mm);
    s.cut(ball(10), line);
    bytes = s.memory_bytes();
    voxels = s.active_voxel_count();
  }
  state.counters["memory_MB"] = static_cast<double>(bytes) / 1e6;
  state.counters["active_voxels"] = static_cast<double>(voxels);
}
BENCHMARK(BM_LevelSetMemory100mmPart)->Iterations(1)->Unit(benchmark::kSecond);

}  // namespace
