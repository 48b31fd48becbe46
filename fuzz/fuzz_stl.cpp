// Fuzz target: the STL reader (removal/src/stl.cpp), removal::read_stl as `vmsim remove
// --stock-stl` and the part files call it; then the mesh's bounds and volume, which the app
// uses next.
#include "fuzz_support.hpp"
#include "vmsim/removal/stl.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::filesystem::path path = vmsim::fuzz::work_folder("stl") / "stock.stl";
  vmsim::fuzz::write_bytes(path, data, size);
  vmsim::fuzz::expect_only_typed_errors([&] {
    const vmsim::removal::TriangleMesh mesh = vmsim::removal::read_stl(path.string());
    (void)mesh.bounds();
    (void)mesh.volume_m3();
  });
  return 0;
}
