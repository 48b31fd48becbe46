#include "vmsim/removal/marks.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "mark_geometry.hpp"

namespace vmsim::removal {
namespace detail {

double line_area_m2(const NBuffer& buffer, int iu, int iv) {
  if (buffer.is_zmap()) return buffer.spacing_m() * buffer.spacing_m();
  auto step = [&](int du, int dv) {
    const int u0 = std::max(0, iu - du), u1 = std::min(buffer.nu() - 1, iu + du);
    const int v0 = std::max(0, iv - dv), v1 = std::min(buffer.nv() - 1, iv + dv);
    const int span = std::max(u1 - u0, v1 - v0);
    if (span == 0) return Eigen::Vector3d(Eigen::Vector3d::Zero());
    return Eigen::Vector3d((buffer.origin(u1, v1) - buffer.origin(u0, v0)) / span);
  };
  return step(1, 0).cross(step(0, 1)).norm();
}

std::vector<int> sort_deepest_first(std::vector<Mark>& marks) {
  std::vector<int> order(marks.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = static_cast<int>(i);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    return marks[static_cast<std::size_t>(a)].depth_m > marks[static_cast<std::size_t>(b)].depth_m;
  });
  std::vector<int> new_index(order.size());
  std::vector<Mark> sorted;
  for (std::size_t k = 0; k < order.size(); ++k) {
    new_index[static_cast<std::size_t>(order[k])] = static_cast<int>(k);
    sorted.push_back(marks[static_cast<std::size_t>(order[k])]);
  }
  marks = std::move(sorted);
  return new_index;
}

}  // namespace detail

MarkMap find_marks(const NBuffer& production, const std::vector<double>& deviation_m,
                   const MarkOptions& options) {
  const int nu = production.nu();
  const int nv = production.nv();
  if (deviation_m.size() != production.line_count()) {
    throw std::invalid_argument("find_marks: " + std::to_string(deviation_m.size()) +
                                " deviations for " + std::to_string(production.line_count()) +
                                " lines");
  }
  auto sign_of = [&](std::size_t i) {
    if (deviation_m[i] < -options.threshold_m) return -1;
    if (deviation_m[i] > options.threshold_m) return 1;
    return 0;
  };
  MarkMap result;
  result.label.assign(deviation_m.size(), -1);
  std::vector<char> visited(deviation_m.size(), 0);
  std::vector<std::size_t> stack;
  std::vector<std::size_t> region;
  for (std::size_t seed = 0; seed < deviation_m.size(); ++seed) {
    const int sign = sign_of(seed);
    if (sign == 0 || visited[seed]) continue;
    // Flood fill of the 4-connected region of this sign.
    region.clear();
    stack.assign(1, seed);
    visited[seed] = 1;
    while (!stack.empty()) {
      const std::size_t i = stack.back();
      stack.pop_back();
      region.push_back(i);
      const int iu = static_cast<int>(i % static_cast<std::size_t>(nu));
      const int iv = static_cast<int>(i / static_cast<std::size_t>(nu));
      const int neighbours[4][2] = {{iu - 1, iv}, {iu + 1, iv}, {iu, iv - 1}, {iu, iv + 1}};
      for (const auto& n : neighbours) {
        if (n[0] < 0 || n[0] >= nu || n[1] < 0 || n[1] >= nv) continue;
        const std::size_t j = static_cast<std::size_t>(n[0]) + static_cast<std::size_t>(nu) * static_cast<std::size_t>(n[1]);
        if (!visited[j] && sign_of(j) == sign) {
          visited[j] = 1;
          stack.push_back(j);
        }
      }
    }
    if (region.size() < options.min_lines) continue;
    Mark mark;
    mark.kind = sign < 0 ? MarkKind::gouge : MarkKind::excess;
    mark.line_count = region.size();
    mark.iu_min = nu;
    mark.iv_min = nv;
    mark.iu_max = -1;
    mark.iv_max = -1;
    Eigen::Vector3d weighted = Eigen::Vector3d::Zero();
    for (const std::size_t i : region) {
      const int iu = static_cast<int>(i % static_cast<std::size_t>(nu));
      const int iv = static_cast<int>(i / static_cast<std::size_t>(nu));
      const double area = detail::line_area_m2(production, iu, iv);
      const Eigen::Vector3d point = production.surface_point(iu, iv);
      mark.area_m2 += area;
      weighted += area * point;
      if (std::abs(deviation_m[i]) > mark.depth_m) {
        mark.depth_m = std::abs(deviation_m[i]);
        mark.deepest_point_W_m = point;
      }
      mark.iu_min = std::min(mark.iu_min, iu);
      mark.iu_max = std::max(mark.iu_max, iu);
      mark.iv_min = std::min(mark.iv_min, iv);
      mark.iv_max = std::max(mark.iv_max, iv);
    }
    mark.centroid_W_m = mark.area_m2 > 0.0 ? Eigen::Vector3d(weighted / mark.area_m2)
                                           : mark.deepest_point_W_m;
    const int index = static_cast<int>(result.marks.size());
    for (const std::size_t i : region) result.label[i] = index;
    result.marks.push_back(mark);
  }
  // Deepest first; labels follow the new order.
  const std::vector<int> new_index = detail::sort_deepest_first(result.marks);
  for (int& label : result.label) {
    if (label >= 0) label = new_index[static_cast<std::size_t>(label)];
  }
  return result;
}

}  // namespace vmsim::removal
