#pragma once
// Canned drilling cycles (G73 G74 G76 G81-G89) expanded into rapid and feed moves, as the Fanuc
// and LinuxCNC manuals describe their motion, and the peck drilling they share with the TNC's
// cycles 200 / 203 and the 840D's CYCLE83. Program coordinates [mm]; the readers check the
// words and turn the moves into path points.
#include <Eigen/Core>
#include <cstddef>
#include <limits>
#include <vector>

namespace vmsim::toolpath::detail {

/// Which feed a cycle's feed move runs at (the reader knows the values).
enum class CycleFeed {
  cutting,       ///< the cycle's drilling feed (G-code F, TNC Q206, 840D F)
  retract,       ///< the retraction feed (TNC Q208)
  first_stroke,  ///< the first stroke's (840D CYCLE83: F * FRF)
};

struct CycleMove {
  bool rapid = true;
  Eigen::Vector3d p_mm = Eigen::Vector3d::Zero();
  CycleFeed feed = CycleFeed::cutting;  ///< for a feed move
  double dwell_s = 0.0;  ///< the dwell at its end (PathPoint::dwell_s)
};

/// Peck drilling along the axis w, downwards (bottom_mm below reference_mm): strokes cut from
/// the level reached, each ended by a chip break (a short retract) or a full retract to
/// retract_to_mm and a rapid back to reapproach_clearance_mm above the depth reached.
///  G83: strokes Q from R, a full rapid retract after each; G73: chip breaks only (rapid);
///  TNC 200: Q202 from the surface, full rapid retracts; TNC 203: Q202 decreasing by Q212 down
///  to Q205, Q213 chip breaks (Q256 at Q208) between full retracts (at Q208); 840D CYCLE83:
///  VARI=1 full rapid retracts, VARI=0 chip breaks at F, DAM the decrement; TNC 205: strokes
///  as 203, chip breaks every Q257 within a stroke, full rapid retracts after each stroke, the
///  rapid back stopping Q258 (first) .. Q259 (last) above the depth reached.
struct PeckDrilling {
  int w = 2;                  ///< the drilling axis (X Y Z index)
  double reference_mm = 0.0;  ///< the level the strokes are counted from (R, the surface)
  double bottom_mm = 0.0;     ///< the hole bottom, below reference_mm
  double first_stroke_mm = 1.0;       ///< the first stroke's depth below reference_mm (> 0)
  double stroke_decrement_mm = 0.0;   ///< each stroke this much shorter than the one before
  /// Strokes are not made shorter than this; a decrement that would make a stroke shorter
  /// than this (or not positive where this is 0) leaves it as it was.
  double minimum_stroke_mm = 0.0;
  /// Chip breaks between two full retracts: 0 a full retract after every stroke; < 0 never a
  /// full retract (chip breaks only).
  int chip_breaks_per_retract = 0;
  double chip_break_mm = 0.1;  ///< the chip break's retract [mm]
  bool chip_break_rapid = true;  ///< else at CycleFeed::chip_break_feed
  CycleFeed chip_break_feed = CycleFeed::retract;
  double retract_to_mm = 0.0;    ///< where a full retract goes (R, set-up clearance)
  bool retract_rapid = true;     ///< else at CycleFeed::retract
  double reapproach_clearance_mm = 0.1;  ///< the rapid back stops this far above the depth reached
  /// TNC 205 (Q258 / Q259): where not NaN, the rapid back after the last full retract stops
  /// this far above the depth reached, after the first reapproach_clearance_mm, the ones between
  /// changing linearly with the retract's index; NaN: all at reapproach_clearance_mm.
  double reapproach_clearance_last_mm = std::numeric_limits<double>::quiet_NaN();
  /// TNC 205 (Q257): within a stroke, a chip break after each this much of cutting (0: none).
  double chip_break_every_mm = 0.0;
  CycleFeed first_stroke_feed = CycleFeed::cutting;
};

/// The moves of peck drilling from `start_mm` (on the hole's axis, w at or above the reference
/// level): the strokes and their retracts, ending at the bottom (the retract out of the hole
/// is the caller's). Requires first_stroke_mm > 0 and bottom_mm < reference_mm.
std::vector<CycleMove> peck_moves(const Eigen::Vector3d& start_mm, const PeckDrilling& peck);

/// The number of strokes peck_moves makes, counted up to `cap` (for the size checks before the
/// moves are made: a tiny stroke would make millions).
std::size_t peck_stroke_count(const PeckDrilling& peck, std::size_t cap);

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
  /// The dwell at the bottom (the Z point: G87's top) [s]: P of G74 G76 G82 G84 G87 G88 G89.
  double dwell_s = 0.0;
};

/// The moves of one hole from `start_mm`:
///  1. where w is below R: rapid along w up to R; then rapid in (u, v) to the hole; rapid
///     along w to R;
///  2. the hole (a dwell of dwell_s on the move that reaches the bottom): G81 feed to the
///     bottom; G82 the same; G83 pecks of
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
