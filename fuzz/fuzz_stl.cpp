// Fuzz target: the STL reader (removal/src/stl.cpp), removal::read_stl as `vmsim remove
// --stock-stl` and the part files call it; a mesh it returns must keep the laws of
// removal/stl.hpp: finite vertices, valid indices, one source line per triangle, outward
// (volume >= 0).
#include "fuzz_support.hpp"
#include "vmsim/removal/stl.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::filesystem::path path = vmsim::fuzz::work_folder("stl") / "stock.stl";
  vmsim::fuzz::write_bytes(path, data, size);
  vmsim::fuzz::expect_only_typed_errors([&] {
    using vmsim::fuzz::require;
    const vmsim::removal::TriangleMesh mesh = vmsim::removal::read_stl(path.string());
    for (const Eigen::Vector3d& vertex : mesh.vertices_m) {
      require(vertex.allFinite(), "vertices finite");
    }
    const int vertex_count = static_cast<int>(mesh.vertices_m.size());
    for (const auto& triangle : mesh.triangles) {
      for (const int index : triangle) require(index >= 0 && index < vertex_count, "indices valid");
    }
    require(mesh.source_lines.size() == mesh.triangles.size(), "one source line per triangle");
    require(mesh.volume_m3() >= 0.0, "normals outward (volume >= 0)");
    (void)mesh.bounds();
  });
  return 0;
}
