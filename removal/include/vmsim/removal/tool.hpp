#pragma once
// Milling tools and tool poses for material removal. SI units (m), frame W (workpiece).
#include <Eigen/Core>

namespace vmsim::removal {

enum class ToolType { ball, flat, bull };

/// A rotating mill, seen as the solid of revolution it sweeps.
///
/// Shape: the body is Disc(rho) (+) Segment(c, c + ell a) (+) Ball(r), a Minkowski sum, with
/// r the corner radius, rho = D/2 - r, c = tip + r a the centre of the corner circles' plane and
/// ell = length - 2 r. That is exactly the ball-end (rho = 0), flat-end (r = 0) or bull-nose
/// (torus corner) mill from the tip up to `length_m`, with the top edge rounded like the bottom
/// one. The holder is not modelled; give a length that covers the engaged part.
struct Tool {
  ToolType type = ToolType::ball;
  double diameter_m = 10e-3;        ///< cutting diameter D [m], > 0
  /// Corner radius r [m]: ball: D/2 (any value given is replaced); flat: 0; bull: 0 < r < D/2.
  double corner_radius_m = 5e-3;
  double length_m = 30e-3;          ///< from the tip to the top of the cutting body [m], >= D

  /// Throws vmsim::InputError naming the field and value when the tool is not valid.
  void validate() const;
  double corner_radius() const;     ///< r [m] after the type rule above
  double disc_radius() const { return 0.5 * diameter_m - corner_radius(); }  ///< rho [m]
  double core_length() const { return length_m - 2.0 * corner_radius(); }     ///< ell [m]
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
