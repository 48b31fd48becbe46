// Reading speed of the Heidenhain TNC reader against the G-code reader on the same motion: a
// relief raster of 9 000 rows of 18 lines joined by 9 000 half circles (R 0.025 mm), written as
// a TNC program (L, CC / C DR+-) and as G-code (G1, G2 / G3 I J): 171 000 blocks each. Counters:
// blocks, points, blocks per second.
//   <build>/bench/bench_toolpath_read_heidenhain
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <string>

#include "vmsim/toolpath/heidenhain_reader.hpp"
#include "vmsim/toolpath/toolpath.hpp"

namespace {

double relief_mm(double x, double y) {
  return 5.0 + 2.0 * std::sin(std::numbers::pi * x / 17.0) * std::cos(2.0 * std::numbers::pi * y / 40.0);
}

/// Writes the raster as TNC (tnc) or G-code; returns its block count.
std::size_t write_program(const std::filesystem::path& file, bool tnc) {
  std::ofstream out(file);
  char line[160];
  std::size_t blocks = 0;
  auto put = [&](const char* text) {
    if (tnc) {
      out << blocks << ' ';
    }
    out << text << '\n';
    ++blocks;
  };
  put(tnc ? "BEGIN PGM RELIEF MM" : "G21 G90 G94 G17");
  put(tnc ? "TOOL CALL 1 Z S10000" : "T1 M6");
  put(tnc ? "L X+0 Y-225 Z+20 R0 FMAX" : "G0 X0 Y-225 Z20");
  std::snprintf(line, sizeof line, tnc ? "L Z%+.4f F3000" : "G1 Z%.4f F3000", relief_mm(0, -225.0));
  put(line);
  const double step_y = 0.05;
  for (int row = 0; row < 9000; ++row) {
    const double y = -225.0 + row * step_y;
    const bool forward = row % 2 == 0;
    for (int k = 1; k <= 18; ++k) {
      const double x = 17.0 * (forward ? k : 18 - k) / 18;
      std::snprintf(line, sizeof line, tnc ? "L X%+.4f Y%+.4f Z%+.4f" : "G1 X%.4f Y%.4f Z%.4f", x, y, relief_mm(x, y));
      put(line);
    }
    const double x_end = forward ? 17.0 : 0.0;
    if (tnc) {
      std::snprintf(line, sizeof line, "CC X%+.4f Y%+.4f", x_end, y + step_y / 2.0);
      put(line);
      std::snprintf(line, sizeof line, "C X%+.4f Y%+.4f DR%s", x_end, y + step_y, forward ? "+" : "-");
    } else {
      std::snprintf(line, sizeof line, "%s X%.4f Y%.4f I0 J%.4f", forward ? "G3" : "G2", x_end, y + step_y, step_y / 2.0);
    }
    put(line);
  }
  put(tnc ? "END PGM RELIEF MM" : "M30");
  return blocks;
}

void read(benchmark::State& state, bool tnc) {
  const std::filesystem::path file =
      std::filesystem::temp_directory_path() / (tnc ? "vmsim_bench_relief.h" : "vmsim_bench_relief_iso.nc");
  const std::size_t blocks = write_program(file, tnc);
  double points = 0;
  for (auto _ : state) {
    const vmsim::toolpath::Toolpath path = vmsim::toolpath::read_toolpath(file.string());
    points = static_cast<double>(path.points.size());
    benchmark::DoNotOptimize(path.points.data());
  }
  state.counters["blocks"] = static_cast<double>(blocks);
  state.counters["points"] = points;
  state.counters["blocks_per_s"] =
      benchmark::Counter(static_cast<double>(blocks), benchmark::Counter::kIsIterationInvariantRate);
  std::filesystem::remove(file);
}

void BM_ReadHeidenhain(benchmark::State& state) { read(state, true); }
void BM_ReadGcode(benchmark::State& state) { read(state, false); }
BENCHMARK(BM_ReadHeidenhain)->Unit(benchmark::kSecond)->Iterations(2)->UseRealTime();
BENCHMARK(BM_ReadGcode)->Unit(benchmark::kSecond)->Iterations(2)->UseRealTime();

}  // namespace
