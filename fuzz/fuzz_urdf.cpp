// Fuzz target: the URDF import (kinematics/src/machine_urdf.cpp, urdfdom underneath). The bytes
// are the URDF file kr180_class.urdf; beside it, the robot sample's machine file that loads it
// (samples/machines/kr180_class_urdf.yaml), read through kinematics::load_machine; a machine it
// returns must keep check_machine's laws.
#include "fuzz_support.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::filesystem::path machine = [] {
    const std::filesystem::path work = vmsim::fuzz::work_folder("urdf");
    const std::string yaml = vmsim::fuzz::read_bytes(vmsim::fuzz::source_dir() +
                                                     "/samples/machines/kr180_class_urdf.yaml");
    vmsim::fuzz::write_bytes(work / "kr180_class_urdf.yaml", yaml.data(), yaml.size());
    return work / "kr180_class_urdf.yaml";
  }();
  vmsim::fuzz::write_bytes(machine.parent_path() / "kr180_class.urdf", data, size);
  vmsim::fuzz::expect_only_typed_errors([&] {
    vmsim::fuzz::check_machine(vmsim::kinematics::load_machine(machine.string()));
  });
  return 0;
}
