#pragma once
// Milling tools and tool poses for material removal. SI units (m), frame W (workpiece).
#include <Eigen/Core>

#include <cmath>

namespace vmsim::removal {

/// ball, flat, bull: Disc (+) Segment (+) Ball (below). v, tapered_flat, tapered_ball: conical
/// tools (a convex solid of revolution with a straight flank, below).
enum class ToolType { ball, flat, bull, v, tapered_flat, tapered_ball };

/// A rotating mill, seen as the solid of revolution it sweeps.
///
/// Shape: the body is Disc(rho) (+) Segment(c, c + ell a) (+) Ball(r), a Minkowski sum, with
/// r the corner radius, rho = D/2 - r, c = tip + r a the centre of the corner circles' plane and
/// ell = length - 2 r. That is exactly the ball-end (rho = 0), flat-end (r = 0) or bull-nose
/// (torus corner) mill from the tip up to `length_m`, with the top edge rounded like the bottom
/// one. The holder is not modelled; give a length that covers the engaged part.
///
/// Conical tools (the solid of revolution about the axis of the section below; zeta along the
/// axis from the tip, rho from the axis):
///  - v (engraving / chamfer mill): a flat tip of diameter `tip_diameter_m` (0: sharp point),
///    then a cone of included angle `tip_angle_rad` (flank at tip_angle / 2 from the axis) up
///    to the diameter D, then a cylinder of D up to `length_m`;
///  - tapered_flat: a flat end of diameter `tip_diameter_m` (> 0), the flank at the side angle
///    `taper_angle_rad` from the axis up to D (or to `length_m` if it gets there first), then a
///    cylinder of D;
///  - tapered_ball: a ball of diameter `tip_diameter_m` (> 0, <= D; corner radius = its
///    radius) at the tip, the flank the cone tangent to that ball at the side angle
///    `taper_angle_rad`, i.e. Ball (+) Cone (Minkowski), up to D, then a cylinder of D.
/// The top is flat (not rounded). Exact: closed-form lower envelope, signed distance and
/// line intersection (removal/src/profile.hpp).
struct Tool {
  ToolType type = ToolType::ball;
  double diameter_m = 10e-3;        ///< cutting diameter D [m], > 0
  /// Corner radius r [m]: ball: D/2 (any value given is replaced); flat: 0; bull: 0 < r < D/2.
  double corner_radius_m = 5e-3;
  double length_m = 30e-3;          ///< from the tip to the top of the cutting body [m], >= D
  /// Conical tools only (above): the tip's flat (v, tapered_flat) or ball (tapered_ball)
  /// diameter [m], 0 <= it < D (v), 0 < it < D (tapered_flat), 0 < it <= D (tapered_ball).
  double tip_diameter_m = 0.0;
  double tip_angle_rad = M_PI / 2.0;  ///< v: included angle of the cone [rad], in (0, pi)
  double taper_angle_rad = 0.0;       ///< tapered_*: flank angle from the axis per side [rad], in [0, pi/4)

  /// True for v, tapered_flat, tapered_ball.
  bool conical() const { return type == ToolType::v || type == ToolType::tapered_flat || type == ToolType::tapered_ball; }

  /// Throws vmsim::InputError naming the field and value when the tool is not valid.
  void validate() const;
  /// r [m] after the type rule above (conical: the tip ball's radius for tapered_ball, else 0)
  double corner_radius() const;
  /// rho [m] (conical tools: D / 2, the cylinder that holds them)
  double disc_radius() const { return conical() ? 0.5 * diameter_m : 0.5 * diameter_m - corner_radius(); }
  /// ell [m] (conical tools: the length, the cylinder that holds them)
  double core_length() const { return conical() ? length_m : length_m - 2.0 * corner_radius(); }
};

/// A tool pose in W: what a tool path (or the direct kinematics) gives.
struct Pose {
  Eigen::Vector3d tip_W_m = Eigen::Vector3d::Zero();  ///< tool tip (lowest point on the axis)
  Eigen::Vector3d axis_W = Eigen::Vector3d::UnitZ();  ///< unit tool axis, tip -> spindle
};

/// An axis-aligned box in W [m], e.g. the stock.
struct Box {
  Eigen::Vector3d min_W_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d max_W_m = Eigen::Vector3d::Zero();
};

}  // namespace vmsim::removal
