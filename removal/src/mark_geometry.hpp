#pragma once
// What a line of a mark stands for, shared by find_marks and the streamed mark finder.
#include "vmsim/removal/nbuffer.hpp"

namespace vmsim::removal::detail {

/// Area a line stands for [m^2]: spacing^2 on a Z-map; on a general buffer, the parallelogram
/// of the neighbouring origins (one-sided at the borders).
double line_area_m2(const NBuffer& buffer, int iu, int iv);

}  // namespace vmsim::removal::detail
