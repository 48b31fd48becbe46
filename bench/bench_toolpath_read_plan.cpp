// Read + inverse kinematics + feedrate plan of a long 3-axis finishing program, as a CAM system
// posts it: 169 000 lines, a raster over a relief with 9 000 rows of 17-18 G1 moves each, the
// rows joined by 9 000 G2/G3 half circles (R 0.1 mm, 0.2 mm stepover). One pass of the chain
// before the drives, as simulate-part runs it (kinematic, second order, programmed F), on the
// Mikron sample machine (tool 100 mm). The figures the issue asks: the whole under 60 s on
// 2 cores; counters give the points and the stages' seconds.
//   <build>/bench/bench_toolpath_read_plan
#include <benchmark/benchmark.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <string>

#include "vmsim/common/memory.hpp"
#include "vmsim/kinematics/machine_loader.hpp"
#include "vmsim/kinematics/path_kinematics.hpp"
#include "vmsim/planner/feedrate.hpp"
#include "vmsim/toolpath/toolpath.hpp"

namespace {

const bool kFreedMemoryKept = (vmsim::keep_freed_memory_in_process(), true);

// The relief z(x, y) [mm]: zero slope change at the row ends (x = 0 and 17 mm), where the arcs
// join the rows at z = 5 mm.
double relief_mm(double x, double y) {
  return 5.0 + 2.0 * std::sin(std::numbers::pi * x / 17.0) * std::cos(2.0 * std::numbers::pi * y / 40.0);
}

// Writes the program; returns its line count.
std::size_t write_program(const std::filesystem::path& file) {
  std::ofstream out(file);
  char line[128];
  std::size_t lines = 0;
  auto put = [&](const char* text) {
    out << text << '\n';
    ++lines;
  };
  put("%");
  put("(relief raster: 9000 rows, 160000 G1, 9000 arcs)");
  put("G21 G90 G94 G17");
  put("G0 X0 Y-225 Z20");
  std::snprintf(line, sizeof line, "G1 Z%.4f F3000", relief_mm(0, -225.0));
  put(line);
  const double step_y = 0.05;  // 9000 rows in 450 mm: within Y's travel of +-275 mm
  for (int row = 0; row < 9000; ++row) {
    const double y = -225.0 + row * step_y;
    const int moves = row < 7000 ? 18 : 17;  // 7000 x 18 + 2000 x 17 = 160 000
    const bool forward = row % 2 == 0;
    for (int k = 1; k <= moves; ++k) {
      const double x = 17.0 * (forward ? k : moves - k) / moves;
      std::snprintf(line, sizeof line, "G1 X%.4f Y%.4f Z%.4f", x, y, relief_mm(x, y));
      put(line);
    }
    // The half circle to the next row, turning outwards: G3 at x = 17 (counter-clockwise seen
    // from +z, going +y), G2 at x = 0.
    std::snprintf(line, sizeof line, "%s X%.4f Y%.4f I0 J%.4f", forward ? "G3" : "G2", forward ? 17.0 : 0.0,
                  y + step_y, step_y / 2.0);
    put(line);
  }
  put("G0 Z20");
  put("M30");
  return lines;
}

void BM_ToolpathReadPlan(benchmark::State& state) {
  const std::filesystem::path file = std::filesystem::temp_directory_path() / "vmsim_bench_relief.nc";
  const std::size_t lines = write_program(file);
  const vmsim::kinematics::MachineModel machine =
      vmsim::kinematics::load_machine(std::string(VMSIM_SOURCE_DIR) + "/samples/machines/mikron_ucp710.yaml");
  const double tool_length_m = 0.1;
  using Clock = std::chrono::steady_clock;
  auto seconds = [](Clock::time_point from) { return std::chrono::duration<double>(Clock::now() - from).count(); };
  double read_s = 0, kinematics_s = 0, plan_s = 0, points = 0, duration_s = 0;
  for (auto _ : state) {
    auto clock = Clock::now();
    const vmsim::toolpath::Toolpath path = vmsim::toolpath::read_toolpath(file.string());
    read_s = seconds(clock);
    clock = Clock::now();
    std::vector<vmsim::kinematics::PathPose> poses;
    std::vector<double> feeds;
    poses.reserve(path.points.size());
    for (const auto& point : path.points) {
      if (!poses.empty() && (poses.back().pose.tip_W_m - point.tip_W_m).norm() < 1e-12) continue;
      poses.push_back({{point.tip_W_m, point.axis_W}, point.block});
      feeds.push_back(point.kind == vmsim::toolpath::MotionKind::rapid ? 0.0 : point.feed_m_per_s);
    }
    const vmsim::kinematics::PathKinematics kinematics = vmsim::kinematics::solve_path_kinematics(
        machine, poses, machine.home_positions(), tool_length_m, {});
    kinematics_s = seconds(clock);
    clock = Clock::now();
    vmsim::planner::FeedrateOptions options;
    options.third_order = false;  // simulate-part's default
    options.point_feed_m_per_s = feeds;
    const vmsim::planner::FeedratePlan plan = vmsim::planner::plan_feedrate(machine, kinematics, options);
    plan_s = seconds(clock);
    points = static_cast<double>(poses.size());
    duration_s = plan.duration_s;
    benchmark::DoNotOptimize(plan.duration_s);
  }
  state.counters["lines"] = static_cast<double>(lines);
  state.counters["points"] = points;
  state.counters["read_s"] = read_s;
  state.counters["kinematics_s"] = kinematics_s;
  state.counters["plan_s"] = plan_s;
  state.counters["machining_time_s"] = duration_s;
  std::filesystem::remove(file);
}
BENCHMARK(BM_ToolpathReadPlan)->Unit(benchmark::kSecond)->Iterations(1)->UseRealTime();

}  // namespace
