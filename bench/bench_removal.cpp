// Material removal speed: tool-segment updates per second of the N-buffer Z-map.
// Realistic finishing: zig-zag passes at 0.1 mm stepover, segments of 0.15 mm, depth 0.05 mm
// below the previous pass level (so the culling decides the cost), on 1 and 2 threads.
//   cmake --build <build> --target bench_removal && <build>/bench/bench_removal
#include <benchmark/benchmark.h>

#include <cmath>
#include <vector>

#include "vmsim/removal/nbuffer.hpp"

namespace {

using vmsim::removal::Box;
using vmsim::removal::CutOptions;
using vmsim::removal::NBuffer;
using vmsim::removal::Pose;
using vmsim::removal::Tool;
using vmsim::removal::ToolType;

// Zig-zag over a w x w mm square: passes along x, `step_mm` segments, `stepover_mm` apart.
std::vector<Pose> zigzag(double w, double step_mm, double stepover_mm, double z_mm, double tilt_rad = 0.0,
                         double axis_turn_per_segment = 0.0) {
  std::vector<Pose> path;
  const int passes = static_cast<int>(w / stepover_mm);
  const int steps = static_cast<int>(w / step_mm);
  double phase = 0.0;
  for (int k = 0; k < passes; ++k) {
    for (int s = 0; s <= steps; ++s) {
      const double x = (k % 2 == 0 ? s : steps - s) * step_mm;
      Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();
      if (tilt_rad > 0.0) {
        phase += axis_turn_per_segment;
        axis = Eigen::Vector3d(std::sin(tilt_rad) * std::cos(phase), std::sin(tilt_rad) * std::sin(phase), std::cos(tilt_rad));
      }
      path.push_back(Pose{Eigen::Vector3d(x, k * stepover_mm, z_mm) * 1e-3, axis});
    }
  }
  return path;
}

void run(benchmark::State& state, double diameter_mm, double grid_mm, bool five_axis) {
  Tool tool;
  tool.type = ToolType::ball;
  tool.diameter_m = diameter_mm * 1e-3;
  tool.length_m = 3 * diameter_mm * 1e-3;
  const double w = 10.0;
  const Box stock{Eigen::Vector3d(-6, -6, 0) * 1e-3, Eigen::Vector3d(16, 16, 10) * 1e-3};
  // 5-axis: tilted 15 deg, the axis turning 0.2 mrad per segment (orientation sub-steps).
  const std::vector<Pose> path = zigzag(w, 0.15, 0.1, 9.95, five_axis ? 0.26 : 0.0, five_axis ? 2e-4 : 0.0);
  CutOptions options;
  options.threads = static_cast<int>(state.range(0));
  std::size_t segments = 0, sub = 0;
  for (auto _ : state) {
    state.PauseTiming();
    NBuffer buffer = NBuffer::zmap(stock, grid_mm * 1e-3);
    state.ResumeTiming();
    const auto stats = buffer.cut(tool, path, options);
    segments += stats.segments;
    sub += stats.sub_segments;
    benchmark::DoNotOptimize(buffer.length(100, 100));
  }
  state.counters["segments_per_s"] = benchmark::Counter(static_cast<double>(segments), benchmark::Counter::kIsRate);
  state.counters["sub_per_segment"] = static_cast<double>(sub) / static_cast<double>(segments);
}

void BM_ZMap_Ball6_10um(benchmark::State& s) { run(s, 6, 0.01, false); }
void BM_ZMap_Ball10_10um(benchmark::State& s) { run(s, 10, 0.01, false); }
void BM_ZMap_Ball6_10um_5axis(benchmark::State& s) { run(s, 6, 0.01, true); }
void BM_ZMap_Ball6_50um(benchmark::State& s) { run(s, 6, 0.05, false); }

BENCHMARK(BM_ZMap_Ball6_10um)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_ZMap_Ball10_10um)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_ZMap_Ball6_10um_5axis)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_ZMap_Ball6_50um)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
