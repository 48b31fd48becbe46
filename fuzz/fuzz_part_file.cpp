// Fuzz target: the part file reader (app/part_file.cpp), app::load_part. Beside the part file:
// a small closed STL as stock.stl (the name part 3's seed gives `stock: {stl: ...}`), so that the
// stock mesh branch is reached without reading the sample's 1.6 MB mesh on every run. The
// machine and tool path named in the file are only resolved by load_part, not read. A part it
// returns must have finite tool and stock numbers (check_part).
#include <cmath>

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

void check_part(const vmsim::app::PartDescription& part) {
  using vmsim::fuzz::require;
  const vmsim::app::ToolDescription& tool = part.tool;
  require(std::isfinite(tool.diameter_m) && tool.diameter_m > 0.0, "tool diameter finite, > 0");
  require(std::isfinite(tool.length_m) && tool.length_m > 0.0, "tool length finite, > 0");
  // Its range is checked where the tool is built (removal::Tool), not here.
  require(std::isfinite(tool.corner_radius_m), "tool corner radius finite");
  require(std::isfinite(tool.cutting_length_m) && tool.cutting_length_m >= 0.0,
          "tool cutting length finite, >= 0");
  if (part.stock) {
    require(part.stock->min_W_m.allFinite() && part.stock->max_W_m.allFinite(), "stock box finite");
  }
  require(std::isfinite(part.production_feed_m_per_s) && part.production_feed_m_per_s > 0.0,
          "production feed finite, > 0");
  require(std::isfinite(part.reference_feed_m_per_s) && part.reference_feed_m_per_s > 0.0,
          "reference feed finite, > 0");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::filesystem::path folder = [] {
    const std::filesystem::path work = vmsim::fuzz::work_folder("part_file");
    vmsim::fuzz::write_bytes(work / "stock.stl", kStockStl, sizeof kStockStl - 1);
    return work;
  }();
  const std::filesystem::path path = folder / "part.yaml";
  vmsim::fuzz::write_bytes(path, data, size);
  vmsim::fuzz::expect_only_typed_errors([&] { check_part(vmsim::app::load_part(path.string())); });
  return 0;
}
