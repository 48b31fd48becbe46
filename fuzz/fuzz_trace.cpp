// Fuzz target: the trace CSV reader (common/src/trace.cpp), vmsim::read_trace, as the servo,
// identify and diagnose commands call it: once with no axis list, once with the Mikron's axes.
// A trace it returns must keep the laws of common/trace.hpp (check_trace).
#include <cmath>
#include <set>

#include "fuzz_support.hpp"
#include "vmsim/common/trace.hpp"

namespace {

void check_trace(const vmsim::Trace& trace) {
  using vmsim::fuzz::require;
  require(trace.columns.size() == trace.values.size(), "one value vector per column");
  for (const auto& column : trace.values) {
    require(column.size() == trace.sample_count(), "columns of one length");
    for (const double value : column) require(std::isfinite(value), "values finite");
  }
  if (const auto t = trace.column_index("t")) {
    const std::vector<double>& times = trace.values[*t];
    for (std::size_t i = 1; i < times.size(); ++i) require(times[i] > times[i - 1], "t increases");
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::filesystem::path path = vmsim::fuzz::work_folder("trace") / "trace.csv";
  vmsim::fuzz::write_bytes(path, data, size);
  vmsim::fuzz::expect_only_typed_errors([&] { check_trace(vmsim::read_trace(path.string())); });
  vmsim::TraceReadOptions options;
  options.known_axes = std::set<std::string>{"X", "Y", "Z", "A", "C"};
  vmsim::fuzz::expect_only_typed_errors(
      [&] { check_trace(vmsim::read_trace(path.string(), options)); });
  return 0;
}
