// Fuzz target: the machine description loader (kinematics/src/machine_loader*.cpp),
// kinematics::load_machine as app/chain_inputs.cpp calls it. The robot sample's URDF is written
// beside the file as kr180_class.urdf, so that `structure: {urdf: kr180_class.urdf}` (the seed
// kr180_class_urdf.yaml) reaches the URDF import too. A machine it returns must keep the laws
// of check_machine.
#include "fuzz_support.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::filesystem::path folder = [] {
    const std::filesystem::path work = vmsim::fuzz::work_folder("machine_yaml");
    const std::string urdf =
        vmsim::fuzz::read_bytes(vmsim::fuzz::source_dir() + "/samples/machines/kr180_class.urdf");
    vmsim::fuzz::write_bytes(work / "kr180_class.urdf", urdf.data(), urdf.size());
    return work;
  }();
  const std::filesystem::path path = folder / "machine.yaml";
  vmsim::fuzz::write_bytes(path, data, size);
  vmsim::fuzz::expect_only_typed_errors([&] {
    vmsim::fuzz::check_machine(vmsim::kinematics::load_machine(path.string()));
  });
  return 0;
}
