// Fuzz target: the trace CSV reader (common/src/trace.cpp), vmsim::read_trace, as the servo,
// identify and diagnose commands call it: once with no axis list, once with the Mikron's axes.
#include <set>

#include "fuzz_support.hpp"
#include "vmsim/common/trace.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::filesystem::path path = vmsim::fuzz::work_folder("trace") / "trace.csv";
  vmsim::fuzz::write_bytes(path, data, size);
  vmsim::fuzz::expect_only_typed_errors([&] { vmsim::read_trace(path.string()); });
  vmsim::TraceReadOptions options;
  options.known_axes = std::set<std::string>{"X", "Y", "Z", "A", "C"};
  vmsim::fuzz::expect_only_typed_errors([&] { vmsim::read_trace(path.string(), options); });
  return 0;
}
