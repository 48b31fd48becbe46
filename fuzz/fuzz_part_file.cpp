// Fuzz target: the part file reader (app/part_file.cpp), app::load_part. Beside the part file:
// a small closed STL as stock.stl (the name part 3's seed gives `stock: {stl: ...}`), so that the
// stock mesh branch is reached without reading the sample's 1.6 MB mesh on every run. The
// machine and tool path named in the file are only resolved by load_part, not read.
#include "fuzz_support.hpp"
#include "part_file.hpp"

namespace {

// A closed tetrahedron, outward normals, in mm.
constexpr char kStockStl[] =
    "solid tetra\n"
    "facet normal 0 0 -1\n outer loop\n  vertex 0 0 0\n  vertex 0 10 0\n  vertex 10 0 0\n"
    " endloop\nendfacet\n"
    "facet normal 0 -1 0\n outer loop\n  vertex 0 0 0\n  vertex 10 0 0\n  vertex 0 0 10\n"
    " endloop\nendfacet\n"
    "facet normal -1 0 0\n outer loop\n  vertex 0 0 0\n  vertex 0 0 10\n  vertex 0 10 0\n"
    " endloop\nendfacet\n"
    "facet normal 1 1 1\n outer loop\n  vertex 10 0 0\n  vertex 0 10 0\n  vertex 0 0 10\n"
    " endloop\nendfacet\n"
    "endsolid tetra\n";

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::filesystem::path folder = [] {
    const std::filesystem::path work = vmsim::fuzz::work_folder("part_file");
    vmsim::fuzz::write_bytes(work / "stock.stl", kStockStl, sizeof kStockStl - 1);
    return work;
  }();
  const std::filesystem::path path = folder / "part.yaml";
  vmsim::fuzz::write_bytes(path, data, size);
  vmsim::fuzz::expect_only_typed_errors([&] { vmsim::app::load_part(path.string()); });
  return 0;
}
