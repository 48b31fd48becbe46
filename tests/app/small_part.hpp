#pragma once
// A small job for the chain's tests: the first passes of sample part 1 on the Mikron.
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "vmsim/common/files.hpp"

namespace vmsim::test {

/// Writes a part file with the first `passes` passes of sample part 1 and a stock strip around
/// them (the box, or `stock_line` in its place) into `folder`; returns its path.
inline std::string small_part(const std::filesystem::path& folder, int passes,
                              const std::string& stock_line = "stock: {box: {min_mm: [-12, -5, 0], max_mm: [16, -4.5, 40]}}") {
  const std::string root = VMSIM_SOURCE_DIR;
  std::istringstream apt(read_file(root + "/samples/parts/part1_tangency/toolpath.apt"));
  std::ostringstream out;
  int rapids = 0;
  for (std::string line; std::getline(apt, line);) {
    if (line == "RAPID" && ++rapids > 2 * passes) break;
    out << line << '\n';
  }
  out << "FINI\n";
  std::ofstream(folder / "toolpath.apt") << out.str();
  std::ofstream(folder / "part.yaml")
      << "name: part1_three_passes\n"
         "description: the first passes of sample part 1\n"
         "machine: " << root << "/samples/machines/mikron_ucp710.yaml\n"
         "toolpath: toolpath.apt\n"
         "tool: {type: ball, diameter_mm: 10, corner_radius_mm: 5, length_mm: 60}\n"
      << stock_line << "\n"
         "feeds: {production_mm_per_min: 10000, reference_mm_per_min: 100}\n";
  return (folder / "part.yaml").string();
}

}  // namespace vmsim::test
