// Fuzz target: Siemens 840D programs (toolpath/src/siemens_reader.cpp) through
// toolpath::read_toolpath (.mpf), with the options app/chain_inputs.cpp gives it (the Mikron
// sample's direct kinematics for axis words); a tool path it returns must keep the laws of
// toolpath/toolpath.hpp (check_toolpath). (The "gcode" target writes .nc: the G-code reader.)
#include "fuzz_support.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const vmsim::fuzz::SampleMachineReaderOptions reader;
  const std::filesystem::path path = vmsim::fuzz::work_folder("siemens") / "toolpath.mpf";
  vmsim::fuzz::write_bytes(path, data, size);
  vmsim::fuzz::expect_only_typed_errors([&] {
    vmsim::fuzz::check_toolpath(vmsim::toolpath::read_toolpath(path.string(), reader.options()));
  });
  return 0;
}
