#pragma once
// Cutter radius compensation (G41 / G42) in one plane, on a small list of 2-D elements: the
// geometry the G-code and Siemens 840D readers use under G41 / G42, kept apart so that it can be
// tested alone.
// Lengths in mm, in the plane's two axes (u, v) = (X, Y) under G17; w is the axis normal to the
// plane (Z), carried along (a helix or a ramp keeps its w motion). The rules are LinuxCNC's
// (docs "Cutter Compensation", interp_convert.cc):
//  - Side: G41 keeps the tool centre on the left of the programmed contour, looking along the
//    motion from the plane normal's positive end; G42 on the right. Each line and arc is offset
//    by the tool radius r to that side (a line shifted along its normal; an arc keeps its centre
//    and its radius grows or shrinks by r: the left of a counter-clockwise arc is its inside).
//    An arc whose offset radius would be <= 0 (an inside arc not larger than the tool) is an error.
//  - Joints: where two offset elements meet at a programmed corner P, a tangent joint (same
//    direction) joins them as they are; a concave (inside) corner ends the first and starts the
//    second at the intersection of the two offset elements (line-line, line-arc, arc-arc; the
//    one nearest the corner); a convex (outside) corner keeps both offset ends and the tool
//    rolls from one to the other on an arc of radius r about P (also G0: the tool stays off the
//    contour everywhere).
//  - Entry: the first move in the plane after G41 / G42 must be a line (an arc is an error) longer
//    than r. It goes from where the tool is to the point T at distance r from its programmed end
//    P where it is tangent to the circle of radius r about P, the tool on the chosen side (the
//    tool touches P there); its joint with the next element is then as any other.
//    EntryRule::normal_to_next (Siemens 840D NORM, the default there): the entry move goes
//    straight to the next element's offset start, r from P along that element's normal.
//  - Exit (finish(), G40): the last element ends at its own offset end; the move after G40 goes
//    from there to the programmed point (the reader's part).
//  - Moves along w only (a Z plunge or retract inside the contour) keep the plane position: they
//    are made where the previous element ends, once the next element says where that is.
//  - Gouges: an offset element that runs backwards once its ends are cut back at concave corners
//    (the offset of a slot or step narrower than the tool), and a concave corner whose offset
//    elements do not meet, are errors, as LinuxCNC refuses them.
#include <Eigen/Core>

#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace vmsim::toolpath {

/// G41: the tool on the left of the programmed contour; G42: on the right.
enum class CompensationSide { left, right };

/// Where the entry move (the first move in the plane) ends: LinuxCNC's tangent point on the tool
/// circle about its programmed end, or (Siemens NORM) the next element's offset start.
enum class EntryRule { tangent_to_tool_circle, normal_to_next };

/// A programmed element in the compensation plane [mm]: a line, or an arc about `centre`
/// sweeping `sweep_rad` (> 0 counter-clockwise, |sweep| <= 2 pi; start == end with 2 pi: a full
/// circle). `start` is where the previous element ended.
struct PlaneElement {
  bool arc = false;
  Eigen::Vector2d start = Eigen::Vector2d::Zero();
  Eigen::Vector2d end = Eigen::Vector2d::Zero();
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  double sweep_rad = 0.0;
  double start_w_mm = 0.0;  ///< the axis normal to the plane at the start
  double end_w_mm = 0.0;    ///< and at the end
  int tag = 0;              ///< the caller's: handed back with the moves the element gives
};

/// A move of the tool centre [mm]: a line, or an arc about `centre` sweeping `sweep_rad` (> 0
/// counter-clockwise) from `start` to `end`; w goes linearly from start_w_mm to end_w_mm.
struct CompensatedMove {
  bool arc = false;
  bool corner = false;  ///< an arc inserted to roll around a convex corner
  Eigen::Vector2d start = Eigen::Vector2d::Zero();
  Eigen::Vector2d end = Eigen::Vector2d::Zero();
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  double sweep_rad = 0.0;
  double start_w_mm = 0.0;
  double end_w_mm = 0.0;
  int tag = 0;  ///< the element's (a corner arc: the element after the corner)
};

/// The ends of `segments` equal chords of a compensated arc (u, v, w) [mm], evenly in angle, w
/// linear; the last exactly the move's end. The readers emit a compensated arc's points from it
/// (the chord count from their arc tessellation tolerance).
std::vector<Eigen::Vector3d> arc_chord_ends_mm(const CompensatedMove& move, long segments);

/// A programmed contour the compensation cannot follow; what() says why (the caller adds where).
class CompensationError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Compensates one stretch of a program between G41 / G42 and G40. Each programmed element
/// is offset when it comes; its end is fixed (and its moves handed out) when the next element,
/// or finish(), comes: one element of look-ahead, as on the control.
class CutterCompensator {
 public:
  /// Compensation switched on with the tool centre at tool_mm (w: tool_w_mm); radius_mm > 0.
  CutterCompensator(CompensationSide side, double radius_mm, const Eigen::Vector2d& tool_mm,
                    double tool_w_mm, EntryRule entry_rule = EntryRule::tangent_to_tool_circle);

  /// The next programmed element (its start is the previous element's programmed end; the
  /// first one's, the tool position). Returns the moves fixed by it, in order. Throws
  /// CompensationError for an arc as the entry move, an entry move not longer than the radius,
  /// an inside arc not larger than the tool, or a gouge.
  std::vector<CompensatedMove> add(const PlaneElement& element);
  /// A move along w only (to end_w_mm): made where the previous element ends. Returns the moves
  /// fixed (before the entry move: this one, at the tool position).
  std::vector<CompensatedMove> add_normal_move(double end_w_mm, int tag);
  /// G40: the pending element ends at its offset end point. Returns the last moves; the
  /// compensator takes no further element.
  std::vector<CompensatedMove> finish();

  /// Where the tool centre is after the moves handed out so far [mm].
  const Eigen::Vector2d& tool_mm() const { return tool_mm_; }
  double tool_w_mm() const { return tool_w_mm_; }
  /// True once the entry move has come.
  bool entered() const { return pending_.has_value(); }

 private:
  /// An offset element whose start is fixed and whose end waits for the next element.
  struct Pending {
    bool arc = false;
    Eigen::Vector2d corner = Eigen::Vector2d::Zero();     ///< the programmed end point
    Eigen::Vector2d off_start = Eigen::Vector2d::Zero();  ///< the offset element's own start
    Eigen::Vector2d off_end = Eigen::Vector2d::Zero();    ///< and end (untrimmed)
    Eigen::Vector2d centre = Eigen::Vector2d::Zero();     ///< arcs
    double radius = 0.0;     ///< arcs: the offset radius
    double sweep_rad = 0.0;  ///< arcs: the programmed (and offset) sweep
    Eigen::Vector2d start = Eigen::Vector2d::Zero();  ///< the fixed start (off_start or a concave intersection)
    Eigen::Vector2d end_tangent = Eigen::Vector2d::UnitX();  ///< unit direction of motion at the end
    double start_w_mm = 0.0, end_w_mm = 0.0;
    int tag = 0;
    bool normal_entry = false;  ///< EntryRule::normal_to_next: ends where the next one starts
  };
  struct NormalMove {
    double end_w_mm;
    int tag;
  };

  Pending offset_of(const PlaneElement& element) const;
  /// The move of `element` from its fixed start to `end`; throws if it runs backwards.
  CompensatedMove move_to(const Pending& element, const Eigen::Vector2d& end) const;
  void flush_normal_moves(std::vector<CompensatedMove>& moves, const Eigen::Vector2d& at);
  void push(std::vector<CompensatedMove>& moves, const CompensatedMove& move);

  double side_sign_;  ///< +1 left (G41), -1 right (G42)
  double radius_mm_;
  Eigen::Vector2d tool_mm_;
  double tool_w_mm_;
  EntryRule entry_rule_;
  bool finished_ = false;
  std::optional<Pending> pending_;
  std::vector<NormalMove> normal_moves_;
};

}  // namespace vmsim::toolpath
