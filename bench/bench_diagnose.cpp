// Diagnosis speed (issue 20): a 20 s single-axis trace at 1 kHz from the independent truth
// simulator of the tests (tests/identify/truth_sim_independent.cpp: direct scale, 4 kHz PI
// velocity loop, held feedforward) with one hidden effect (a Coulomb friction 2.5x the model's),
// diagnosed with the whole catalogue and the default options. Aim: under 30 s on 2 cores.
//
//   build/bench/bench_diagnose --benchmark_repetitions=3
//
// VMSIM_BENCH_DIAGNOSE_FILES=DIR also writes the trace and the machine file into DIR (trace.csv,
// machine.yaml), to time the program itself:
//   /usr/bin/time -v build/app/vmsim diagnose --machine DIR/machine.yaml --trace DIR/trace.csv --out D
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "../tests/identify/truth_sim_independent.hpp"
#include "vmsim/identify/diagnose.hpp"
#include "vmsim/kinematics/machine_loader.hpp"

namespace {

using namespace vmsim;

void BM_DiagnoseTwentySeconds(benchmark::State& state) {
  identify::test::IndependentDrive nominal;
  std::size_t from = 0, to = 0;
  const std::vector<double> sp = identify::test::independent_excitation(
      nominal.position_period_s, from, to, 3);
  to = std::min(to, from + static_cast<std::size_t>(20.0 / nominal.trace_period_s));
  identify::test::IndependentDrive truth = nominal;
  truth.coulomb_A *= 2.5;
  const Trace trace = identify::test::simulate_independent(truth, sp, from, to, 7);
  const kinematics::MachineModel machine = kinematics::parse_machine(
      identify::test::independent_machine_yaml(nominal), "independent.yaml");
  const auto data = identify::extract_measurements(machine, trace, "bench");
  if (const char* folder = std::getenv("VMSIM_BENCH_DIAGNOSE_FILES")) {
    std::filesystem::create_directories(folder);
    write_trace((std::filesystem::path(folder) / "trace.csv").string(), trace);
    std::ofstream(std::filesystem::path(folder) / "machine.yaml")
        << identify::test::independent_machine_yaml(nominal);
  }
  std::size_t found = 0;
  std::string names;
  for (auto _ : state) {
    const identify::Diagnosis d = identify::diagnose(machine, data, {});
    found = d.axes.at(0).found.size();
    names.clear();
    for (const auto& c : d.axes.at(0).found) names += (names.empty() ? "" : ",") + c.effect;
    benchmark::DoNotOptimize(found);
  }
  state.SetLabel("found: " + names);
  state.counters["trace_s"] = static_cast<double>(data.at(0).t.size()) * nominal.trace_period_s;
  state.counters["effects_found"] = static_cast<double>(found);
}
BENCHMARK(BM_DiagnoseTwentySeconds)->Unit(benchmark::kSecond)->Iterations(1);

}  // namespace
