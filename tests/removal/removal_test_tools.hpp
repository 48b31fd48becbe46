#pragma once
// Small helpers shared by the removal tests (sizes in mm, as the tests write them).
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

}  // namespace vmsim::removal::test
