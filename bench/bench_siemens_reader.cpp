// Reading speed of the Siemens 840D reader against the APT and ISO readers on the same motion:
// sample part 1 (18 860 points) as its APT file, as the 840D program of the corpus
// (tests/data/posted_840d/part1_840d, CYCLE832) and as the same blocks read as ISO G-code
// (the 840D-only lines dropped: header, G71, D1, CYCLE832). Run: build/bench/bench_siemens_reader
#include <benchmark/benchmark.h>

#include <fstream>
#include <sstream>
#include <string>

#include "vmsim/toolpath/toolpath.hpp"

namespace {

std::string text_of(const std::string& relative) {
  std::ifstream in(std::string(VMSIM_SOURCE_DIR) + "/" + relative);
  std::ostringstream out;
  out << in.rdbuf();
  return out.str();
}

const std::string& siemens_text() {
  static const std::string text = text_of("tests/data/posted_840d/part1_840d/program.mpf");
  return text;
}

/// The same blocks without what only the 840D reads (the header, D1, CYCLE832).
const std::string& iso_text() {
  static const std::string text = [] {
    std::istringstream in(siemens_text());
    std::string out, line;
    while (std::getline(in, line)) {
      if (line.find('%') != std::string::npos || line.find(';') != std::string::npos ||
          line.find("CYCLE") != std::string::npos || line.find(" D1") != std::string::npos ||
          line.find("G71") != std::string::npos) {
        continue;
      }
      out += line + "\n";
    }
    return out;
  }();
  return text;
}

vmsim::toolpath::ReaderOptions options() {
  vmsim::toolpath::ReaderOptions o;
  o.default_tool_length_mm = 60.0;
  return o;
}

void BM_Siemens840d(benchmark::State& state) {
  const auto o = options();
  for (auto _ : state) benchmark::DoNotOptimize(vmsim::toolpath::parse_siemens(siemens_text(), "part1.mpf", o));
}
void BM_IsoGcode(benchmark::State& state) {
  const auto o = options();
  for (auto _ : state) benchmark::DoNotOptimize(vmsim::toolpath::parse_gcode(iso_text(), "part1.nc", o));
}
void BM_Apt(benchmark::State& state) {
  const std::string text = text_of("samples/parts/part1_tangency/toolpath.apt");
  for (auto _ : state) benchmark::DoNotOptimize(vmsim::toolpath::parse_apt(text, "part1.apt"));
}

BENCHMARK(BM_Siemens840d)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_IsoGcode)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Apt)->Unit(benchmark::kMillisecond);

}  // namespace
