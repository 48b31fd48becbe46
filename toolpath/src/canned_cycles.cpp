// Canned drilling cycles: see canned_cycles.hpp.
#include "canned_cycles.hpp"

#include <algorithm>
#include <cmath>

namespace vmsim::toolpath::detail {

namespace {
double next_stroke(const PeckDrilling& peck, double stroke) {
  if (peck.stroke_decrement_mm == 0.0) return stroke;
  const double shorter = std::max(stroke - peck.stroke_decrement_mm, peck.minimum_stroke_mm);
  return shorter > 0.0 ? shorter : stroke;
}
}  // namespace

std::vector<CycleMove> peck_moves(const Eigen::Vector3d& start_mm, const PeckDrilling& peck) {
  std::vector<CycleMove> moves;
  Eigen::Vector3d p = start_mm;
  const auto move = [&](bool rapid, double w_mm, CycleFeed feed) {
    p[peck.w] = w_mm;
    moves.push_back({rapid, p, feed});
  };
  double level = peck.reference_mm;
  double stroke = peck.first_stroke_mm;
  int breaks = 0;
  bool first = true;
  // The rapid back after full retract k of n stops between the first and the last clearance.
  const bool graded = !std::isnan(peck.reapproach_clearance_last_mm);
  const std::size_t full_retracts =
      graded && peck.chip_breaks_per_retract == 0 ? peck_stroke_count(peck, 1u << 30) - 1 : 0;
  std::size_t retract_index = 0;
  while (level > peck.bottom_mm) {
    const double target = std::max(level - stroke, peck.bottom_mm);
    if (peck.chip_break_every_mm > 0.0) {
      // Chip breaks inside the stroke: cut chip_break_every_mm, back off, go on.
      double cut_to = level - peck.chip_break_every_mm;
      while (cut_to > target) {
        move(false, cut_to, first ? peck.first_stroke_feed : CycleFeed::cutting);
        first = false;
        move(peck.chip_break_rapid, cut_to + peck.chip_break_mm, peck.chip_break_feed);
        cut_to -= peck.chip_break_every_mm;
      }
    }
    level = target;
    move(false, level, first ? peck.first_stroke_feed : CycleFeed::cutting);
    first = false;
    if (level <= peck.bottom_mm) break;
    if (peck.chip_breaks_per_retract < 0 || breaks < peck.chip_breaks_per_retract) {
      ++breaks;
      move(peck.chip_break_rapid, level + peck.chip_break_mm, peck.chip_break_feed);
    } else {
      breaks = 0;
      move(peck.retract_rapid, peck.retract_to_mm, CycleFeed::retract);
      double clearance_mm = peck.reapproach_clearance_mm;
      if (graded && full_retracts > 1) {
        const double t = static_cast<double>(retract_index) / static_cast<double>(full_retracts - 1);
        clearance_mm += t * (peck.reapproach_clearance_last_mm - peck.reapproach_clearance_mm);
      }
      ++retract_index;
      move(true, level + clearance_mm, CycleFeed::cutting);
    }
    stroke = next_stroke(peck, stroke);
  }
  return moves;
}

std::size_t peck_stroke_count(const PeckDrilling& peck, std::size_t cap) {
  std::size_t count = 0;
  double level = peck.reference_mm;
  double stroke = peck.first_stroke_mm;
  if (!(stroke > 0.0)) return cap;
  while (level > peck.bottom_mm && count < cap) {
    ++count;
    level = std::max(level - stroke, peck.bottom_mm);
    stroke = next_stroke(peck, stroke);
  }
  return count;
}

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
    moves.back().dwell_s = hole.dwell_s;
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

  // The peck cycles: strokes of Q from R down (peck_moves).
  switch (hole.code) {
    case 83:
    case 73: {
      PeckDrilling peck;
      peck.w = hole.w;
      peck.reference_mm = hole.r_mm;
      peck.bottom_mm = hole.bottom_mm;
      peck.first_stroke_mm = hole.peck_mm;
      peck.chip_breaks_per_retract = hole.code == 73 ? -1 : 0;
      peck.chip_break_mm = hole.peck_retract_mm;
      peck.retract_to_mm = hole.r_mm;
      peck.reapproach_clearance_mm = hole.peck_clearance_mm;
      for (const CycleMove& m : peck_moves(p, peck)) moves.push_back(m);
      p = moves.back().p_mm;
      break;
    }
    case 85: case 89: case 84: case 74:
      move(false, hole.bottom_mm);
      moves.back().dwell_s = hole.dwell_s;
      move(false, hole.r_mm);
      break;
    case 88:
      // Boring with a manual retract: the control stops at the bottom (after the dwell, spindle
      // stopped); the operator jogs the tool out, taken here as straight out along w to R, and
      // cycle start brings it to the return level.
      move(false, hole.bottom_mm);
      moves.back().dwell_s = hole.dwell_s;
      move(true, hole.r_mm);
      break;
    case 76: {
      // Fine boring (Fanuc): at the bottom the spindle stops oriented and the tool moves off
      // the wall, so that it leaves without a mark; back on the hole's axis once out.
      move(false, hole.bottom_mm);
      moves.back().dwell_s = hole.dwell_s;
      shift_by(1.0);
      const double out_mm =
          hole.return_to_initial ? std::max(hole.initial_mm, hole.r_mm) : hole.r_mm;
      move(true, out_mm);
      onto_axis();
      return moves;
    }
    default:  // 81 82 86
      move(false, hole.bottom_mm);
      moves.back().dwell_s = hole.dwell_s;
      break;
  }
  const double clear_mm =
      hole.return_to_initial ? std::max(hole.initial_mm, hole.r_mm) : hole.r_mm;
  if (p[hole.w] != clear_mm) move(true, clear_mm);
  return moves;
}

}  // namespace vmsim::toolpath::detail
