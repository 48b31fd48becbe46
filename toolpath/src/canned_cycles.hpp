#pragma once
// Canned drilling cycles (G73 G74 G76 G81-G89) expanded into rapid and feed moves, as the Fanuc
// and LinuxCNC manuals describe their motion. Program coordinates [mm]; the G-code reader
// checks the words and turns the moves into path points.
#include <Eigen/Core>
#include <vector>

namespace vmsim::toolpath::detail {

struct CycleMove {
  bool rapid = true;
  Eigen::Vector3d p_mm = Eigen::Vector3d::Zero();
};

struct CycleHole {
  int code = 81;           ///< 73 74 76 81 82 83 84 85 86 87 88 89
  int u = 0, v = 1, w = 2;  ///< the plane's axes (X Y Z indices); w is the drilling axis
  Eigen::Vector3d hole_mm = Eigen::Vector3d::Zero();  ///< hole position (u, v components)
  double r_mm = 0.0;        ///< R level along w
  /// The cycle's Z point along w: the hole bottom (below R); G87: the top of the back bore
  /// (above R, which is below the part).
  double bottom_mm = 0.0;
  double initial_mm = 0.0;  ///< the initial level (w when the cycle started)
  bool return_to_initial = true;  ///< G98 (else G99: back to R)
  double peck_mm = 0.0;     ///< Q of G73 / G83 (> 0)
  double peck_clearance_mm = 0.1;
  double peck_retract_mm = 0.1;
  /// G76 / G87: the shift away from the wall [mm] (Q, or |(I, J)|), along this unit direction
  /// in the plane (u, v).
  double shift_mm = 0.0;
  Eigen::Vector2d shift_direction = Eigen::Vector2d::UnitX();
};

/// The moves of one hole from `start_mm`:
///  1. where w is below R: rapid along w up to R; then rapid in (u, v) to the hole; rapid
///     along w to R;
///  2. the hole: G81 feed to the bottom; G82 the same (its dwell is not a motion); G83 pecks of
///     Q from R, after each a rapid out to R and a rapid back to peck_clearance_mm above the
///     last depth; G73 pecks of Q, after each a rapid back-off of peck_retract_mm; G85, G89,
///     G84 and G74 feed to the bottom and feed back to R; G86 feeds to the bottom; G76 feeds to
///     the bottom, shifts (rapid) by shift_mm along shift_direction, leaves in rapid and shifts
///     back at the return level; G88 feeds to the bottom, then (the operator's manual retract,
///     taken as a rapid straight out along w) to R;
///  G87 (back boring, Fanuc) instead: where w is below the initial level, rapid up to it; rapid
///     in (u, v) to the hole, shift by shift_mm (rapid), rapid along w down to R (below the
///     part), shift back onto the hole's axis, feed up to the Z point, shift again, rapid up to
///     the initial level (always: G99 has no meaning for G87 on a Fanuc) and shift back;
///  3. the return: rapid to max(initial, R) under G98, to R under G99 (where not already there).
std::vector<CycleMove> expand_cycle(const Eigen::Vector3d& start_mm, const CycleHole& hole);

}  // namespace vmsim::toolpath::detail
