// Material removal speed: tool-segment updates per second of the N-buffer Z-map.
//   cmake --build <build> --target bench_removal && <build>/bench/bench_removal
// Each case runs on 1 thread (/1: rates per CPU second of the one thread doing the work, so a
// loaded machine does not hide the per-core figure) and on 2 threads (/2: rates per wall-clock
// second). Counters: segments_per_s (trajectory segments), sub_per_segment (orientation
// sub-steps), lines_lowered_per_segment.
//  - Finishing zig-zags: passes along x, 0.15 mm segments, 0.1 mm stepover, 0.05 mm below the
//    stock top (the culling decides the cost), ball D6 / D10 on a 10 um grid; 5-axis: the axis
//    tilted 15 deg and turning 0.2 mrad per segment (orientation sub-steps); tilted flat-end and
//    bull-nose (3+2: constant 10 deg tilt; and 5-axis: turning).
//  - CAMotics' case (shared/FIELD-NOTES.md: 567 s there): a 10 x 10 mm zig-zag of 5 151 moves of
//    0.1 mm, 0.2 mm stepover, ball D6, 0.05 mm grid (and the same on a 10 um grid), 0.5 mm deep.
//  - A 300 000-sample finishing run: 30 x 30 mm, 0.1 mm stepover, 0.03 mm samples (301 x 1001), ball D6 on a
//    20 um grid, over a wavy surface (every segment a ramp).
//  - The die of issue 21 (sample part 1's profile swept in y): ball D10, one-way passes along x
//    over a plane, a concave R15 arc and a 30 deg slope, 0.25 mm stepover, tip poses every 40 um
//    with 1 nm of noise in z (a servo's: every segment a ramp, up or down), plunging outside the
//    stock and retracting, from a box stock 1 mm above the highest tip point; 20 x 5 mm of
//    passes (21 x 501 poses) on a 20 um and a 10 um grid.
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdint>
#include <vector>

#include "vmsim/removal/nbuffer.hpp"

namespace {

using vmsim::removal::Box;
using vmsim::removal::CutOptions;
using vmsim::removal::NBuffer;
using vmsim::removal::Pose;
using vmsim::removal::Tool;
using vmsim::removal::ToolType;

struct ZigZag {
  double width_mm = 10.0;      // square side
  double step_mm = 0.15;       // segment length along a pass
  double stepover_mm = 0.1;
  double z_mm = 9.95;          // tip height (stock top 10 mm)
  double tilt_rad = 0.0;       // tool axis tilt from z
  double turn_per_segment = 0.0;  // axis precession per segment [rad of azimuth]
  double wave_mm = 0.0;        // amplitude of z = z_mm + wave sin(x) sin(y) (x, y in mm)
};

// Zig-zag over the square: passes along x, `step_mm` segments, `stepover_mm` apart.
std::vector<Pose> zigzag(const ZigZag& z) {
  std::vector<Pose> path;
  const int passes = static_cast<int>(std::lround(z.width_mm / z.stepover_mm)) + 1;
  const int steps = static_cast<int>(std::lround(z.width_mm / z.step_mm));
  double phase = 0.0;
  for (int k = 0; k < passes; ++k) {
    for (int s = 0; s <= steps; ++s) {
      const double x = (k % 2 == 0 ? s : steps - s) * z.step_mm, y = k * z.stepover_mm;
      Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();
      if (z.tilt_rad > 0.0) {
        phase += z.turn_per_segment;
        axis = Eigen::Vector3d(std::sin(z.tilt_rad) * std::cos(phase), std::sin(z.tilt_rad) * std::sin(phase),
                               std::cos(z.tilt_rad));
      }
      const double height = z.z_mm + z.wave_mm * std::sin(x) * std::sin(y);
      path.push_back(Pose{Eigen::Vector3d(x, y, height) * 1e-3, axis});
    }
  }
  return path;
}

Tool make_tool(ToolType type, double diameter_mm, double corner_mm = 0.0) {
  Tool tool;
  tool.type = type;
  tool.diameter_m = diameter_mm * 1e-3;
  tool.corner_radius_m = corner_mm * 1e-3;
  tool.length_m = 3 * diameter_mm * 1e-3;
  return tool;
}

// Part 1's profile in x [mm]: plane z = 0, concave arc R15 (centre x = 0, z = 15) up to x = 7.5,
// then the 30 deg slope tangent to it.
double die_profile_mm(double x) {
  if (x <= 0.0) return 0.0;
  if (x <= 7.5) return 15.0 - std::sqrt(225.0 - x * x);
  return 15.0 - std::sqrt(225.0 - 7.5 * 7.5) + (x - 7.5) * std::tan(M_PI / 6.0);
}

// One-way passes along x from -8 to 12 mm, y = 0 .. 5 mm; the tip on the profile plus servo noise.
std::vector<Pose> die_passes() {
  std::vector<Pose> path;
  std::uint64_t state = 12345;
  auto noise_mm = [&] {  // [-1e-6, 1e-6] mm, a fixed sequence
    state = state * 6364136223846793005ULL + 1442695040888963407ULL;
    return (static_cast<double>(state >> 11) * 0x1p-53 * 2.0 - 1.0) * 1e-6;
  };
  auto add = [&](double x, double y, double z) { path.push_back(Pose{Eigen::Vector3d(x, y, z) * 1e-3, Eigen::Vector3d::UnitZ()}); };
  for (int pass = 0; pass <= 20; ++pass) {
    const double y = 0.25 * pass;
    add(-8.0, y, 10.0);  // plunge outside the stock
    for (int i = 0; i <= 500; ++i) {
      const double x = -8.0 + 0.04 * i;
      add(x, y, die_profile_mm(x) + noise_mm());
    }
    add(12.0, y, 10.0);  // retract
  }
  return path;
}

void run_path(benchmark::State& state, const Tool& tool, const std::vector<Pose>& path, const Box& stock, double grid_mm) {
  CutOptions options;
  options.threads = static_cast<int>(state.range(0));
  std::size_t segments = 0, sub = 0, lowered = 0, tiles = 0;
  for (auto _ : state) {
    state.PauseTiming();
    NBuffer buffer = NBuffer::zmap(stock, grid_mm * 1e-3);
    state.ResumeTiming();
    const auto stats = buffer.cut(tool, path, options);
    segments += stats.segments;
    sub += stats.sub_segments;
    lowered += stats.lines_lowered;
    tiles += stats.tiles_visited;
    benchmark::DoNotOptimize(buffer.length(100, 100));
  }
  state.counters["tiles_visited_per_segment"] = static_cast<double>(tiles) / static_cast<double>(segments);
  state.counters["segments"] = static_cast<double>(path.size() - 1);
  state.counters["segments_per_s"] = benchmark::Counter(static_cast<double>(segments), benchmark::Counter::kIsRate);
  state.counters["sub_per_segment"] = static_cast<double>(sub) / static_cast<double>(segments);
  state.counters["lines_lowered_per_segment"] = static_cast<double>(lowered) / static_cast<double>(segments);
}

void run(benchmark::State& state, const Tool& tool, const ZigZag& z, double grid_mm) {
  const double margin = 0.5 * tool.diameter_m * 1e3 + 1.0;
  const Box stock{Eigen::Vector3d(-margin, -margin, 0) * 1e-3,
                  Eigen::Vector3d(z.width_mm + margin, z.width_mm + margin, 10) * 1e-3};
  run_path(state, tool, zigzag(z), stock, grid_mm);
}

void run_die(benchmark::State& state, double grid_mm) {
  const Box stock{Eigen::Vector3d(-2, -6, -6) * 1e-3, Eigen::Vector3d(18, 11, die_profile_mm(12.0) + 1.0) * 1e-3};
  run_path(state, make_tool(ToolType::ball, 10), die_passes(), stock, grid_mm);
}

const ZigZag kFinish{};
const ZigZag kFiveAxis{10.0, 0.15, 0.1, 9.95, 0.26, 2e-4};
const ZigZag kTilted{10.0, 0.15, 0.1, 9.95, 0.1745, 0.0};
const ZigZag kTiltedTurning{10.0, 0.15, 0.1, 9.95, 0.1745, 2e-4};
const ZigZag kCamotics{10.0, 0.1, 0.2, 9.5};
const ZigZag kLongRun{30.0, 0.03, 0.1, 9.9, 0.0, 0.0, 0.05};

void BM_Ball6_10um(benchmark::State& s) { run(s, make_tool(ToolType::ball, 6), kFinish, 0.01); }
void BM_Ball10_10um(benchmark::State& s) { run(s, make_tool(ToolType::ball, 10), kFinish, 0.01); }
void BM_Ball6_10um_5axis(benchmark::State& s) { run(s, make_tool(ToolType::ball, 6), kFiveAxis, 0.01); }
void BM_Flat10_10um_tilted(benchmark::State& s) { run(s, make_tool(ToolType::flat, 10), kTilted, 0.01); }
void BM_Bull10r2_10um_tilted(benchmark::State& s) { run(s, make_tool(ToolType::bull, 10, 2), kTilted, 0.01); }
void BM_Flat10_10um_5axis(benchmark::State& s) { run(s, make_tool(ToolType::flat, 10), kTiltedTurning, 0.01); }
void BM_Bull10r2_10um_5axis(benchmark::State& s) { run(s, make_tool(ToolType::bull, 10, 2), kTiltedTurning, 0.01); }
void BM_Camotics_Ball6_50um(benchmark::State& s) { run(s, make_tool(ToolType::ball, 6), kCamotics, 0.05); }
void BM_Camotics_Ball6_10um(benchmark::State& s) { run(s, make_tool(ToolType::ball, 6), kCamotics, 0.01); }
void BM_Run300k_Ball6_20um(benchmark::State& s) { run(s, make_tool(ToolType::ball, 6), kLongRun, 0.02); }
void BM_Die_Ball10_20um(benchmark::State& s) { run_die(s, 0.02); }
void BM_Die_Ball10_10um(benchmark::State& s) { run_die(s, 0.01); }

// /1: CPU time of the one working thread; /2: wall clock.
#define VMSIM_REMOVAL_BENCH(name)                                                   \
  BENCHMARK(name)->Arg(1)->Unit(benchmark::kMillisecond)->Iterations(1);            \
  BENCHMARK(name)->Arg(2)->Unit(benchmark::kMillisecond)->Iterations(1)->UseRealTime()

VMSIM_REMOVAL_BENCH(BM_Ball6_10um);
VMSIM_REMOVAL_BENCH(BM_Ball10_10um);
VMSIM_REMOVAL_BENCH(BM_Ball6_10um_5axis);
VMSIM_REMOVAL_BENCH(BM_Flat10_10um_tilted);
VMSIM_REMOVAL_BENCH(BM_Bull10r2_10um_tilted);
VMSIM_REMOVAL_BENCH(BM_Flat10_10um_5axis);
VMSIM_REMOVAL_BENCH(BM_Bull10r2_10um_5axis);
VMSIM_REMOVAL_BENCH(BM_Camotics_Ball6_50um);
VMSIM_REMOVAL_BENCH(BM_Camotics_Ball6_10um);
VMSIM_REMOVAL_BENCH(BM_Run300k_Ball6_20um);
VMSIM_REMOVAL_BENCH(BM_Die_Ball10_20um);
VMSIM_REMOVAL_BENCH(BM_Die_Ball10_10um);

}  // namespace
