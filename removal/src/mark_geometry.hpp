#pragma once
// What a line of a mark stands for, shared by find_marks and the streamed mark finder.
#include <vector>

#include "vmsim/removal/marks.hpp"
#include "vmsim/removal/nbuffer.hpp"

namespace vmsim::removal::detail {

/// Area a line stands for [m^2]: spacing^2 on a Z-map; on a general buffer, the parallelogram
/// of the neighbouring origins (one-sided at the borders).
double line_area_m2(const NBuffer& buffer, int iu, int iv);

/// Sorts `marks` deepest first, ties in their present order; returns each mark's new index by
/// its old one (for the labels to follow).
std::vector<int> sort_deepest_first(std::vector<Mark>& marks);

}  // namespace vmsim::removal::detail
