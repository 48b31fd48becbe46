// Feedrate interpolation, single thread, 10 000 and 100 000 path points (the argument) on the
// 5-axis table-table sample: velocity + acceleration; torque with gravity and friction (second
// order); jerk and torque rate (third order). Each figure includes the set points at the
// interpolation period and their check.
//   <build>/bench/bench_planner [--benchmark_filter='/10000$']
#include <benchmark/benchmark.h>

#include <cmath>
#include <exception>
#include <numbers>

#include "vmsim/common/memory.hpp"
#include "vmsim/kinematics/sample_models.hpp"
#include "vmsim/planner/feedrate.hpp"

namespace {

// The allocator set as the vmsim program sets it (see memory.hpp: with glibc's defaults the
// figures at 10 000 points include the page faults of mapping the work arrays afresh each call,
// about as much again).
const bool kFreedMemoryKept = (vmsim::keep_freed_memory_in_process(), true);

using vmsim::kinematics::MachineModel;
using vmsim::kinematics::PathKinematics;

/// A smooth 5-axis path: all axes move (X, Y, Z sinusoids, A and C slow swings).
PathKinematics path(std::size_t points) {
  PathKinematics p;
  const double length = 0.3;
  p.q = Eigen::MatrixXd::Zero(5, static_cast<Eigen::Index>(points));
  p.q_s = p.q_ss = p.q_sss = p.q;
  const double amplitude[5] = {0.05, 0.03, 0.01, 0.2, 0.5};
  const double wavelength[5] = {0.3, 0.1, 0.05, 0.15, 0.3};
  for (std::size_t i = 0; i < points; ++i) {
    const double s = length * static_cast<double>(i) / static_cast<double>(points - 1);
    p.s_m.push_back(s);
    for (Eigen::Index j = 0; j < 5; ++j) {
      const double w = 2.0 * std::numbers::pi / wavelength[j];
      const double a = amplitude[j] / w;
      const auto c = static_cast<Eigen::Index>(i);
      p.q(j, c) = (j == 0 ? 0.8 * s : 0.0) + a * std::sin(w * s) + (j == 2 ? -0.2 : 0.0);
      p.q_s(j, c) = (j == 0 ? 0.8 : 0.0) + a * w * std::cos(w * s);
      p.q_ss(j, c) = -a * w * w * std::sin(w * s);
      p.q_sss(j, c) = -a * w * w * w * std::cos(w * s);
    }
  }
  return p;
}

void run(benchmark::State& state, vmsim::planner::FeedrateOptions options) {
  MachineModel machine = vmsim::kinematics::make_table_table_sample();
  for (auto& axis : machine.axes) {
    axis.drive.torque_max_N_m = 65.0;
    axis.drive.torque_rate_max_N_m_per_s = 1000.0;
  }
  const PathKinematics p = path(static_cast<std::size_t>(state.range(0)));
  options.max_grid_step_m = 1.0;  // the path points are the grid
  double duration = 0.0, rounds = 0.0, grid_points = 0.0;
  for (auto _ : state) {
    try {
      auto plan = vmsim::planner::plan_feedrate(machine, p, options);
      duration = plan.duration_s;
      rounds = plan.slowdown_rounds;
      grid_points = static_cast<double>(plan.profile.s_m.size());
    } catch (const std::exception& error) {
      state.SkipWithError(error.what());
      break;
    }
    benchmark::DoNotOptimize(duration);
  }
  state.counters["T_s"] = duration;
  state.counters["slowdown_rounds"] = rounds;
  state.counters["grid_points"] = grid_points;  // the path points and the refinement near stops
}

void VelocityAcceleration(benchmark::State& state) {
  vmsim::planner::FeedrateOptions o;
  o.third_order = false;
  run(state, o);
}
void TorqueGravityFriction(benchmark::State& state) {
  vmsim::planner::FeedrateOptions o;
  o.method = vmsim::planner::FeedrateMethod::dynamic;
  o.limits = vmsim::planner::DynamicLimitSource::actuator;
  o.third_order = false;
  run(state, o);
}
void Jerk(benchmark::State& state) {
  vmsim::planner::FeedrateOptions o;
  run(state, o);
}
void TorqueRate(benchmark::State& state) {
  vmsim::planner::FeedrateOptions o;
  o.method = vmsim::planner::FeedrateMethod::dynamic;
  o.limits = vmsim::planner::DynamicLimitSource::actuator;
  run(state, o);
}

BENCHMARK(VelocityAcceleration)->Arg(10000)->Arg(100000)->Unit(benchmark::kMillisecond);
BENCHMARK(TorqueGravityFriction)->Arg(10000)->Arg(100000)->Unit(benchmark::kMillisecond);
BENCHMARK(Jerk)->Arg(10000)->Arg(100000)->Unit(benchmark::kMillisecond);
BENCHMARK(TorqueRate)->Arg(10000)->Arg(100000)->Unit(benchmark::kMillisecond);

}  // namespace
