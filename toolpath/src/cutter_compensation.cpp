// Cutter radius compensation in one plane (vmsim/toolpath/cutter_compensation.hpp).
#include "vmsim/toolpath/cutter_compensation.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "toolpath_detail.hpp"

namespace vmsim::toolpath {
namespace {

constexpr double kPi = std::numbers::pi;
/// Directions whose sine differs by less than this meet tangentially (no corner).
constexpr double kTangentSine = 1e-9;
/// Lengths below this [mm] are no motion; an offset element may run backwards by this much
/// (rounding) before it is a gouge; curves that miss each other by this much touch.
constexpr double kLengthMm = 1e-9;
constexpr double kTouchMm = 1e-6;

double cross(const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  return a.x() * b.y() - a.y() * b.x();
}
Eigen::Vector2d left_normal(const Eigen::Vector2d& d) { return {-d.y(), d.x()}; }
double angle_of(const Eigen::Vector2d& v) { return std::atan2(v.y(), v.x()); }
/// An angle brought into (-pi, pi].
double wrapped(double a) {
  while (a > kPi) a -= 2.0 * kPi;
  while (a <= -kPi) a += 2.0 * kPi;
  return a;
}
std::string mm(double value) { return detail::format_number(std::round(value * 1e6) / 1e6); }

}  // namespace

CutterCompensator::CutterCompensator(CompensationSide side, double radius_mm,
                                     const Eigen::Vector2d& tool_mm, double tool_w_mm, EntryRule entry_rule)
    : side_sign_(side == CompensationSide::left ? 1.0 : -1.0),
      radius_mm_(radius_mm),
      tool_mm_(tool_mm),
      tool_w_mm_(tool_w_mm),
      entry_rule_(entry_rule) {
  if (!(radius_mm > 0.0) || !std::isfinite(radius_mm)) {
    throw CompensationError("the cutter radius must be positive, got " + mm(radius_mm) + " mm");
  }
}

CutterCompensator::Pending CutterCompensator::offset_of(const PlaneElement& element) const {
  Pending p;
  p.arc = element.arc;
  p.corner = element.end;
  p.start_w_mm = element.start_w_mm;
  p.end_w_mm = element.end_w_mm;
  p.tag = element.tag;
  if (!element.arc) {
    const Eigen::Vector2d d = (element.end - element.start).normalized();
    const Eigen::Vector2d shift = side_sign_ * radius_mm_ * left_normal(d);
    p.off_start = element.start + shift;
    p.off_end = element.end + shift;
    p.end_tangent = d;
    p.start = p.off_start;
    return p;
  }
  const double programmed_radius = (element.start - element.centre).norm();
  const double turn = element.sweep_rad > 0.0 ? 1.0 : -1.0;
  // The left of a counter-clockwise arc is its inside.
  p.radius = programmed_radius - side_sign_ * turn * radius_mm_;
  if (!(p.radius > kLengthMm)) {
    throw CompensationError("tool radius larger than arc radius: the tool (radius " + mm(radius_mm_) +
                            " mm) runs inside an arc of radius " + mm(programmed_radius) +
                            " mm, which it does not fit");
  }
  p.centre = element.centre;
  p.sweep_rad = element.sweep_rad;
  p.off_start = element.centre + p.radius * (element.start - element.centre).normalized();
  p.off_end = element.centre + p.radius * (element.end - element.centre).normalized();
  p.end_tangent = turn * left_normal((element.end - element.centre).normalized());
  p.start = p.off_start;
  return p;
}

CompensatedMove CutterCompensator::move_to(const Pending& element, const Eigen::Vector2d& end) const {
  CompensatedMove move;
  move.start = element.start;
  move.end = end;
  move.start_w_mm = element.start_w_mm;
  move.end_w_mm = element.end_w_mm;
  move.tag = element.tag;
  bool backwards = false;
  if (element.normal_entry) {
    // Straight to wherever the next element starts.
  } else if (!element.arc) {
    const Eigen::Vector2d d = element.end_tangent;
    backwards = (end - element.off_start).dot(d) < (element.start - element.off_start).dot(d) - kLengthMm;
  } else {
    // Positions along the arc as angles in the direction of motion: the start near 0 (the
    // offset start), the end near |sweep| (the offset end).
    const double turn = element.sweep_rad > 0.0 ? 1.0 : -1.0;
    const double start_along =
        turn * wrapped(angle_of(element.start - element.centre) - angle_of(element.off_start - element.centre));
    const double end_along = std::abs(element.sweep_rad) +
                             turn * wrapped(angle_of(end - element.centre) - angle_of(element.off_end - element.centre));
    backwards = end_along < start_along - kLengthMm / element.radius;
    move.arc = true;
    move.centre = element.centre;
    move.sweep_rad = turn * std::max(0.0, end_along - start_along);
  }
  if (backwards) {
    throw CompensationError(
        "cutter compensation gouges: the tool (radius " + mm(radius_mm_) +
        " mm) would run backwards along this element's offset (the programmed contour has a slot, step or "
        "corner narrower than the tool)");
  }
  return move;
}

void CutterCompensator::push(std::vector<CompensatedMove>& moves, const CompensatedMove& move) {
  const bool moves_in_plane = (move.end - move.start).norm() > kLengthMm ||
                              (move.arc && std::abs(move.sweep_rad) * radius_mm_ > kLengthMm);
  if (moves_in_plane || std::abs(move.end_w_mm - move.start_w_mm) > 0.0) {
    CompensatedMove m = move;
    m.start = tool_mm_;  // continuous: tiny gaps (rounding, skipped corners) are closed here
    m.start_w_mm = tool_w_mm_;
    if (!moves_in_plane) m.arc = false;
    moves.push_back(m);
  }
  tool_mm_ = move.end;
  tool_w_mm_ = move.end_w_mm;
}

void CutterCompensator::flush_normal_moves(std::vector<CompensatedMove>& moves, const Eigen::Vector2d& at) {
  for (const NormalMove& normal : normal_moves_) {
    CompensatedMove move;
    move.start = at;
    move.end = at;
    move.start_w_mm = tool_w_mm_;
    move.end_w_mm = normal.end_w_mm;
    move.tag = normal.tag;
    push(moves, move);
  }
  normal_moves_.clear();
}

std::vector<CompensatedMove> CutterCompensator::add_normal_move(double end_w_mm, int tag) {
  if (finished_) throw CompensationError("cutter compensation is finished");
  std::vector<CompensatedMove> moves;
  normal_moves_.push_back({end_w_mm, tag});
  if (!pending_) flush_normal_moves(moves, tool_mm_);  // before the entry: where the tool is
  return moves;
}

namespace {

/// The curve an offset element runs on: a line (point, unit direction) or a circle.
struct Curve {
  bool circle = false;
  Eigen::Vector2d point;  ///< a point of the line, or the centre
  Eigen::Vector2d direction;
  double radius = 0.0;
};

std::vector<Eigen::Vector2d> line_circle(const Curve& line, const Curve& circle) {
  const Eigen::Vector2d f = line.point - circle.point;
  const double b = f.dot(line.direction);
  double discriminant = b * b - (f.squaredNorm() - circle.radius * circle.radius);
  if (discriminant < 0.0) {
    // A line that misses the circle by a rounding error touches it.
    const double miss = std::abs(cross(f, line.direction)) - circle.radius;
    if (miss > kTouchMm) return {};
    discriminant = 0.0;
  }
  const double root = std::sqrt(discriminant);
  return {line.point + (-b - root) * line.direction, line.point + (-b + root) * line.direction};
}

std::vector<Eigen::Vector2d> intersections(const Curve& a, const Curve& b) {
  if (!a.circle && !b.circle) {
    const double denominator = cross(a.direction, b.direction);
    if (denominator == 0.0) return {};
    const double t = cross(b.point - a.point, b.direction) / denominator;
    return {a.point + t * a.direction};
  }
  if (!a.circle) return line_circle(a, b);
  if (!b.circle) return line_circle(b, a);
  const Eigen::Vector2d between = b.point - a.point;
  const double d = between.norm();
  if (d == 0.0) return {};
  // Circles that miss each other by a rounding error touch.
  if (d > a.radius + b.radius + kTouchMm || d < std::abs(a.radius - b.radius) - kTouchMm) return {};
  const double along = (d * d + a.radius * a.radius - b.radius * b.radius) / (2.0 * d);
  const double across = std::sqrt(std::max(0.0, a.radius * a.radius - along * along));
  const Eigen::Vector2d u = between / d;
  const Eigen::Vector2d base = a.point + along * u;
  return {base + across * left_normal(u), base - across * left_normal(u)};
}

}  // namespace

std::vector<CompensatedMove> CutterCompensator::add(const PlaneElement& element) {
  if (finished_) throw CompensationError("cutter compensation is finished");
  if (!element.arc && (element.end - element.start).norm() <= kLengthMm) {
    return add_normal_move(element.end_w_mm, element.tag);
  }
  std::vector<CompensatedMove> moves;
  if (!pending_) {
    // The entry move: from the tool to the point where it is tangent to the circle of radius r
    // about its programmed end, the tool on the chosen side (LinuxCNC's convert_straight_comp1).
    if (element.arc) {
      throw CompensationError("the move that starts cutter compensation must be a line (G0 / G1), not an arc");
    }
    const Eigen::Vector2d& p = element.end;
    const double distance = (p - tool_mm_).norm();
    if (entry_rule_ == EntryRule::normal_to_next) {
      Pending entry;
      entry.corner = p;
      entry.off_start = tool_mm_;
      // Without a next element (G40 at once): r to the side of the entry itself.
      entry.off_end = p + side_sign_ * radius_mm_ * left_normal((p - tool_mm_).normalized());
      entry.start = tool_mm_;
      entry.end_tangent = (p - tool_mm_).normalized();
      entry.start_w_mm = element.start_w_mm;
      entry.end_w_mm = element.end_w_mm;
      entry.tag = element.tag;
      entry.normal_entry = true;
      pending_ = entry;
      return moves;
    }
    if (!(distance > radius_mm_)) {
      throw CompensationError("the move that starts cutter compensation is " + mm(distance) +
                              " mm long in the plane, not longer than the tool radius " + mm(radius_mm_) + " mm");
    }
    const double theta = std::acos(radius_mm_ / distance);
    const double alpha = angle_of(tool_mm_ - p) - side_sign_ * theta;
    Pending entry;
    entry.corner = p;
    entry.off_start = tool_mm_;
    entry.off_end = p + radius_mm_ * Eigen::Vector2d(std::cos(alpha), std::sin(alpha));
    entry.start = tool_mm_;
    entry.end_tangent = (entry.off_end - entry.off_start).normalized();
    entry.start_w_mm = element.start_w_mm;
    entry.end_w_mm = element.end_w_mm;
    entry.tag = element.tag;
    pending_ = entry;
    return moves;
  }

  Pending& a = *pending_;
  Pending b = offset_of(element);
  const Eigen::Vector2d& corner = a.corner;
  const Eigen::Vector2d start_tangent =
      !element.arc ? b.end_tangent
                   : Eigen::Vector2d((element.sweep_rad > 0.0 ? 1.0 : -1.0) *
                                     left_normal((element.start - element.centre).normalized()));
  const double turn_sine = cross(a.end_tangent, start_tangent);
  const double turn_cosine = a.end_tangent.dot(start_tangent);
  std::optional<CompensatedMove> corner_arc;
  Eigen::Vector2d a_end = a.off_end;
  if (a.normal_entry) {
    a_end = b.off_start;
    b.start = b.off_start;
  } else if (std::abs(turn_sine) <= kTangentSine && turn_cosine > 0.0) {
    b.start = b.off_start;  // tangent: the offset ends meet (to rounding)
  } else if (side_sign_ * turn_sine > 0.0 && turn_cosine > -1.0 + kTangentSine) {
    // Concave: both end at the intersection of their offset curves nearest the corner.
    const auto curve_of = [](const Pending& p) {
      Curve c;
      c.circle = p.arc;
      c.point = p.arc ? p.centre : p.off_start;
      c.direction = p.arc ? Eigen::Vector2d::UnitX() : p.end_tangent;
      c.radius = p.radius;
      return c;
    };
    const Eigen::Vector2d near = 0.5 * (a.off_end + b.off_start);
    double best = std::numeric_limits<double>::infinity();
    for (const Eigen::Vector2d& q : intersections(curve_of(a), curve_of(b))) {
      if ((q - near).norm() < best) {
        best = (q - near).norm();
        a_end = q;
      }
    }
    if (!std::isfinite(best)) {
      throw CompensationError("cutter compensation gouges: the tool (radius " + mm(radius_mm_) +
                              " mm) does not fit into the inside corner at (" + mm(corner.x()) + ", " +
                              mm(corner.y()) + ")");
    }
    b.start = a_end;
  } else {
    // Convex (or a reversal): the tool rolls about the corner from one offset end to the other,
    // clockwise with the tool on the left (G41), counter-clockwise on the right.
    const double roll = -side_sign_;
    const Eigen::Vector2d u = a.off_end - corner, v = b.off_start - corner;
    double sweep = std::atan2(cross(u, v), u.dot(v));
    if (roll * sweep < 0.0) sweep = std::abs(sweep) > 0.5 * kPi ? sweep + roll * 2.0 * kPi : 0.0;
    b.start = b.off_start;
    if (std::abs(sweep) * radius_mm_ > kLengthMm) {
      CompensatedMove arc;
      arc.arc = true;
      arc.corner = true;
      arc.start = a.off_end;
      arc.end = b.off_start;
      arc.centre = corner;
      arc.sweep_rad = sweep;
      arc.start_w_mm = b.start_w_mm;
      arc.end_w_mm = b.start_w_mm;
      arc.tag = b.tag;
      corner_arc = arc;
    }
  }
  push(moves, move_to(a, a_end));
  flush_normal_moves(moves, a_end);
  if (corner_arc) push(moves, *corner_arc);
  pending_ = b;
  return moves;
}

std::vector<CompensatedMove> CutterCompensator::finish() {
  std::vector<CompensatedMove> moves;
  if (finished_) return moves;
  finished_ = true;
  if (!pending_) {
    flush_normal_moves(moves, tool_mm_);
    return moves;
  }
  const Eigen::Vector2d end = pending_->off_end;
  push(moves, move_to(*pending_, end));
  flush_normal_moves(moves, end);
  pending_.reset();
  return moves;
}

std::vector<Eigen::Vector3d> arc_chord_ends_mm(const CompensatedMove& move, long segments) {
  segments = std::max(1L, segments);
  const double radius = (move.start - move.centre).norm();
  const double a0 = angle_of(move.start - move.centre);
  std::vector<Eigen::Vector3d> ends;
  ends.reserve(static_cast<std::size_t>(segments));
  for (long k = 1; k < segments; ++k) {
    const double t = static_cast<double>(k) / static_cast<double>(segments);
    const double angle = a0 + t * move.sweep_rad;
    ends.emplace_back(move.centre.x() + radius * std::cos(angle), move.centre.y() + radius * std::sin(angle),
                      move.start_w_mm + t * (move.end_w_mm - move.start_w_mm));
  }
  ends.emplace_back(move.end.x(), move.end.y(), move.end_w_mm);
  return ends;
}

}  // namespace vmsim::toolpath
