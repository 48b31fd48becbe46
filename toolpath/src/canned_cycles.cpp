// Canned drilling cycles: see canned_cycles.hpp.
#include "canned_cycles.hpp"

#include <algorithm>

namespace vmsim::toolpath::detail {

std::vector<CycleMove> expand_cycle(const Eigen::Vector3d& start_mm, const CycleHole& hole) {
  std::vector<CycleMove> moves;
  Eigen::Vector3d p = start_mm;
  const auto move = [&](bool rapid, double w_mm) {
    p[hole.w] = w_mm;
    moves.push_back({rapid, p});
  };
  const Eigen::Vector2d shift = hole.shift_mm * hole.shift_direction;
  const auto shift_by = [&](double sign) {
    p[hole.u] += sign * shift.x();
    p[hole.v] += sign * shift.y();
    moves.push_back({true, p});
  };
  const auto onto_axis = [&] {
    p[hole.u] = hole.hole_mm[hole.u];
    p[hole.v] = hole.hole_mm[hole.v];
    moves.push_back({true, p});
  };
  if (hole.code == 87) {
    // Back boring: the tool goes down through the hole shifted off its axis (the spindle
    // oriented, the cutting edge clear of the wall), cuts upwards from R below the part to the
    // Z point, and leaves shifted the same way; it never passes the part at R, so it always
    // comes back to the initial level.
    if (p[hole.w] < hole.initial_mm) move(true, hole.initial_mm);
    if (p[hole.u] != hole.hole_mm[hole.u] || p[hole.v] != hole.hole_mm[hole.v]) onto_axis();
    const bool shifted = hole.shift_mm != 0.0;
    if (shifted) shift_by(1.0);
    move(true, hole.r_mm);
    if (shifted) onto_axis();
    move(false, hole.bottom_mm);
    if (shifted) shift_by(1.0);
    move(true, hole.initial_mm);
    if (shifted) onto_axis();
    return moves;
  }
  if (p[hole.w] < hole.r_mm) move(true, hole.r_mm);
  if (p[hole.u] != hole.hole_mm[hole.u] || p[hole.v] != hole.hole_mm[hole.v]) {
    p[hole.u] = hole.hole_mm[hole.u];
    p[hole.v] = hole.hole_mm[hole.v];
    moves.push_back({true, p});
  }
  if (p[hole.w] != hole.r_mm) move(true, hole.r_mm);

  // The peck cycles: depths from R down, each at most Q deeper than the last.
  const auto next_depth = [&](double depth) { return std::max(depth - hole.peck_mm, hole.bottom_mm); };
  switch (hole.code) {
    case 83: {
      double depth = hole.r_mm;
      while (depth > hole.bottom_mm) {
        if (depth < hole.r_mm) move(true, depth + hole.peck_clearance_mm);
        depth = next_depth(depth);
        move(false, depth);
        if (depth > hole.bottom_mm) move(true, hole.r_mm);
      }
      break;
    }
    case 73: {
      double depth = hole.r_mm;
      while (depth > hole.bottom_mm) {
        depth = next_depth(depth);
        move(false, depth);
        if (depth > hole.bottom_mm) move(true, depth + hole.peck_retract_mm);
      }
      break;
    }
    case 85: case 89: case 84: case 74:
      move(false, hole.bottom_mm);
      move(false, hole.r_mm);
      break;
    case 88:
      // Boring with a manual retract: the control stops at the bottom (after the dwell, spindle
      // stopped); the operator jogs the tool out, taken here as straight out along w to R, and
      // cycle start brings it to the return level.
      move(false, hole.bottom_mm);
      move(true, hole.r_mm);
      break;
    case 76: {
      // Fine boring (Fanuc): at the bottom the spindle stops oriented and the tool moves off
      // the wall, so that it leaves without a mark; back on the hole's axis once out.
      move(false, hole.bottom_mm);
      shift_by(1.0);
      const double out_mm =
          hole.return_to_initial ? std::max(hole.initial_mm, hole.r_mm) : hole.r_mm;
      move(true, out_mm);
      onto_axis();
      return moves;
    }
    default:  // 81 82 86
      move(false, hole.bottom_mm);
      break;
  }
  const double clear_mm =
      hole.return_to_initial ? std::max(hole.initial_mm, hole.r_mm) : hole.r_mm;
  if (p[hole.w] != clear_mm) move(true, clear_mm);
  return moves;
}

}  // namespace vmsim::toolpath::detail
