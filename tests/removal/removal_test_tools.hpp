#pragma once
// Small helpers shared by the removal tests (sizes in mm, as the tests write them).
#include <algorithm>
#include <cmath>
#include <vector>

#include "vmsim/removal/nbuffer.hpp"
#include "vmsim/removal/tool.hpp"

namespace vmsim::removal::test {

inline Tool make_tool(ToolType type, double d_mm, double r_mm = 0.0, double length_mm = 30.0) {
  Tool t;
  t.type = type;
  t.diameter_m = d_mm * 1e-3;
  t.corner_radius_m = r_mm * 1e-3;
  t.length_m = length_mm * 1e-3;
  return t;
}

/// The same lines as a Z-map, as a general N-buffer (NBuffer::lines): the general cut is the
/// reference the Z-map's fast paths are compared with.
inline NBuffer general_lines_like(const NBuffer& zmap) {
  std::vector<Eigen::Vector3d> origins, directions;
  std::vector<double> lengths;
  for (int j = 0; j < zmap.nv(); ++j) {
    for (int i = 0; i < zmap.nu(); ++i) {
      origins.push_back(zmap.origin(i, j));
      directions.push_back(Eigen::Vector3d::UnitZ());
      lengths.push_back(zmap.length(i, j));
    }
  }
  return NBuffer::lines(zmap.nu(), zmap.nv(), origins, directions, lengths);
}

/// How two buffers on the same lines differ: the largest |length difference| [m], and how many
/// lines of `a` are shorter than `below_m` (lowered from a stock of that height).
struct BufferDifference {
  double worst_m = 0.0;
  std::size_t lowered = 0;
};
inline BufferDifference compare_lines(const NBuffer& a, const NBuffer& b, double below_m) {
  BufferDifference d;
  for (int j = 0; j < a.nv(); ++j) {
    for (int i = 0; i < a.nu(); ++i) {
      d.worst_m = std::max(d.worst_m, std::abs(a.length(i, j) - b.length(i, j)));
      d.lowered += a.length(i, j) < below_m;
    }
  }
  return d;
}

}  // namespace vmsim::removal::test
