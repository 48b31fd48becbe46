// Feed drive simulation speed: the Mikron UCP710's five axes (X Y Z A C) with the sample's loop
// rates — velocity loop 8 kHz (125 us), position loop 500 Hz (2 ms), current loop first order
// (800 Hz bandwidth, integrated exactly with the plant at 8 kHz), set points at 4 ms — on a
// jerk-limited move of each axis. Reported: seconds of machine time simulated per second of CPU
// time, on one core (the counter `machine_s_per_wall_s`). On a shared machine the other
// processes slow some repetitions down: read the `_max` row (the least disturbed repetition).
//
//   build/bench/bench_servo --benchmark_repetitions=10 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include "vmsim/kinematics/machine_loader.hpp"
#include "vmsim/servo/servo.hpp"

namespace {

using namespace vmsim;

// A smooth (cosine-velocity) move of `length` over `duration`, after 0.1 s of rest.
servo::AxisInput move(double length, double duration, double period, double total) {
  servo::AxisInput input;
  input.period_s = period;
  const auto n = static_cast<std::size_t>(total / period) + 1;
  for (std::size_t k = 0; k < n; ++k) {
    const double u = std::clamp((static_cast<double>(k) * period - 0.1) / duration, 0.0, 1.0);
    input.values.push_back(length * (u - std::sin(2.0 * M_PI * u) / (2.0 * M_PI)));
  }
  return input;
}

void BM_MikronFiveAxes(benchmark::State& state) {
  const kinematics::MachineModel machine =
      kinematics::load_machine((std::filesystem::path(__FILE__).parent_path().parent_path() /
                                "samples/machines/mikron_ucp710.yaml").string());
  const double total_s = 10.0;
  std::vector<servo::AxisServoModel> models;
  std::vector<servo::AxisInput> inputs;
  const double lengths[] = {0.2, 0.2, -0.2, -0.5, 3.0};  // m, m, m, rad, rad
  for (int j = 0; j < 5; ++j) {
    models.push_back(servo::make_axis_servo_model(machine, j, std::vector<double>(5, 0.0)));
    inputs.push_back(move(lengths[j], 2.0, machine.interpolation_period_s, total_s));
  }
  servo::SimulationOptions options;  // recorded at the set-point period
  for (auto _ : state) {
    for (int j = 0; j < 5; ++j) {
      servo::AxisSignals signals = servo::simulate_axis(models[static_cast<std::size_t>(j)],
                                                        inputs[static_cast<std::size_t>(j)], options);
      benchmark::DoNotOptimize(signals.pos.back());
    }
  }
  state.counters["machine_s_per_wall_s"] =
      benchmark::Counter(total_s * static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_MikronFiveAxes)
    ->Unit(benchmark::kMillisecond)
    ->ComputeStatistics("max", [](const std::vector<double>& v) {
      return *std::max_element(v.begin(), v.end());
    });

// The same five axes advanced together in windows of 0.5 s of set points (MachineSimulator, as
// simulate-part streams its runs): the cost of keeping the loop state between windows and of
// releasing the records axis by axis, against BM_MikronFiveAxes.
void BM_MikronFiveAxesWindowed(benchmark::State& state) {
  const kinematics::MachineModel machine =
      kinematics::load_machine((std::filesystem::path(__FILE__).parent_path().parent_path() /
                                "samples/machines/mikron_ucp710.yaml").string());
  const double total_s = 10.0;
  const double lengths[] = {0.2, 0.2, -0.2, -0.5, 3.0};  // m, m, m, rad, rad
  const double period = machine.interpolation_period_s;
  const std::size_t n = move(1.0, 2.0, period, total_s).values.size();
  Eigen::MatrixXd q(5, static_cast<Eigen::Index>(n));
  for (int j = 0; j < 5; ++j) {
    const servo::AxisInput input = move(lengths[j], 2.0, period, total_s);
    for (std::size_t k = 0; k < n; ++k) q(j, static_cast<Eigen::Index>(k)) = input.values[k];
  }
  const auto window = static_cast<Eigen::Index>(std::lround(0.5 / period));
  for (auto _ : state) {
    servo::MachineSimulator simulator(machine, {0, 1, 2, 3, 4}, std::vector<double>(5, 0.0), 0.0, period);
    double last = 0.0;
    for (Eigen::Index first = 0; first < q.cols(); first += window) {
      const Eigen::Index count = std::min(window, q.cols() - first);
      std::vector<servo::AxisSignals> records = simulator.advance(q.middleCols(first, count));
      if (!records[0].pos.empty()) last = records[0].pos.back();
    }
    benchmark::DoNotOptimize(last);
    benchmark::DoNotOptimize(simulator.finish());
  }
  state.counters["machine_s_per_wall_s"] =
      benchmark::Counter(total_s * static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_MikronFiveAxesWindowed)
    ->Unit(benchmark::kMillisecond)
    ->ComputeStatistics("max", [](const std::vector<double>& v) {
      return *std::max_element(v.begin(), v.end());
    });

}  // namespace
