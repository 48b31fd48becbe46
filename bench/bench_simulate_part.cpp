// The main job end to end: sample part 1 (the README's first command, without the renders) at
// the production and the reference feed, plan -> servo -> direct kinematics -> removal ->
// comparison. Aim (issue #8): under 60 s on 2 cores. Each stage's time is a counter (seconds),
// from the report's own stage clock.
#include <benchmark/benchmark.h>

#include <filesystem>

#include "simulate_part.hpp"

namespace {

void BM_SimulatePart1(benchmark::State& state) {
  vmsim::app::SimulatePartOptions options;
  options.part_path = std::string(VMSIM_SOURCE_DIR) + "/samples/parts/part1_tangency/part.yaml";
  options.out_dir = (std::filesystem::temp_directory_path() / "vmsim_bench_simulate_part").string();
  options.renders = false;
  options.threads = static_cast<int>(state.range(0));
  nlohmann::json report;
  for (auto _ : state) {
    report = vmsim::app::simulate_part(options, [](const std::string&) {});
  }
  const auto& stages = report["stage_seconds"];
  for (const char* run : {"production", "reference"}) {
    for (const auto& [stage, seconds] : stages[run].items()) {
      state.counters[std::string(run) + "." + stage + "_s"] = seconds.get<double>();
    }
  }
  state.counters["comparison_s"] = stages["comparison"].get<double>();
  state.counters["marks"] = static_cast<double>(report["marks"].size());
  if (!report["marks"].empty()) state.counters["deepest_mark_um"] = report["marks"][0]["depth_um"].get<double>();
  std::filesystem::remove_all(options.out_dir);
}
BENCHMARK(BM_SimulatePart1)->Arg(1)->Arg(2)->Iterations(1)->Unit(benchmark::kSecond)->UseRealTime();

}  // namespace
