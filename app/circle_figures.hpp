#pragma once
// The figures of a circular test (ISO 230-4) and the features a ballbar analysis shows, from the
// path of the tool tip in the plane of two axes. Pure computation: no machine, no files, SI.
//
// Conventions (README, "Circular test"): the plane has a first axis u and a second axis v (XY:
// u = X, v = Y; YZ: u = Y, v = Z; ZX: u = Z, v = X, as ISO 230-4 names the planes). Angles are
// polar angles of the actual tip about the nominal centre, from +u towards +v; counter-clockwise
// (CCW) is the direction of growing angle. The radial deviation is the distance from the nominal
// centre minus the nominal radius (positive: outside the circle). Axis u reverses at 0 and 180
// degrees, axis v at 90 and 270 degrees.
#include <array>
#include <string>
#include <vector>

namespace vmsim::app::circle {

enum class Direction { ccw, cw };

/// "CCW" or "CW".
std::string direction_name(Direction direction);

/// Tip positions in the test plane relative to the nominal centre [m], in time order.
struct PlanePath {
  std::vector<double> t_s;
  std::vector<double> u_m;
  std::vector<double> v_m;
};

/// The samples of one direction's 360-degree data arc.
struct DataArc {
  Direction direction = Direction::ccw;
  std::vector<double> t_s;
  std::vector<double> angle_rad;  ///< polar angle in [0, 2 pi), time order
  std::vector<double> radius_m;   ///< distance from the nominal centre
  double angular_speed_rad_per_s = 0.0;  ///< mean |d angle / dt| over the arc
};

/// The runs of one direction in `path` that sweep at least 360 degrees, each cut to the 360
/// degrees in its middle (the overruns at both ends, where the motion starts and stops, left
/// out). Samples farther than `band_m` from the nominal radius (lead-in, lead-out) are ignored;
/// a run ends where the angle turns back by more than 10 degrees. In time order.
std::vector<DataArc> find_data_arcs(const PlanePath& path, double radius_m, double band_m);

/// What happens at one axis reversal. The steady lines are straight lines fitted to the
/// deviation (LSC centre removed) over `line_window` before the reversal (ending `gap` before
/// it) and after it (starting `settle` after it), as functions of the angle travelled.
struct Reversal {
  int axis = 0;            ///< 0: u, 1: v
  double angle_rad = 0.0;  ///< 0, pi / 2, pi or 3 pi / 2
  /// Signed peak of the deviation beyond both steady lines (above the higher, below the
  /// lower), within `settle` after the reversal [m] (a reversal spike: positive outwards).
  double spike_m = 0.0;
  /// Jump of the steady line across the reversal, the line after minus the line before, both
  /// extended to the reversal [m] (a backlash step: positive outwards).
  double step_m = 0.0;
  bool valid = false;  ///< false when a window holds fewer than 2 samples
};

struct FigureOptions {
  double settle_rad = 5.0 * 3.14159265358979323846 / 180.0;  ///< spike window after a reversal
  double line_window_rad = 10.0 * 3.14159265358979323846 / 180.0;
  double gap_rad = 1.0 * 3.14159265358979323846 / 180.0;
};

struct CircleFigures {
  Direction direction = Direction::ccw;
  /// ISO 230-4 circular deviation G: radial range of the path about the least-squares circle's
  /// centre [m].
  double circular_deviation_G_m = 0.0;
  /// Least-squares circle radius minus the nominal radius [m] (negative: the circle shrinks,
  /// the servo lag's radius reduction).
  double mean_radius_deviation_m = 0.0;
  /// Least-squares circle centre relative to the nominal one [m].
  double lsc_centre_u_m = 0.0;
  double lsc_centre_v_m = 0.0;
  /// The servo-mismatch ellipse from the second harmonic a2 cos 2t + b2 sin 2t of the radial
  /// deviation: major minus minor semi-axis = 2 sqrt(a2^2 + b2^2) [m], and the angle of the
  /// major axis in [0, 180) degrees from +u. Fitted together with the lost motion below (a
  /// backlash's steps have a second harmonic at 45 / 135 degrees of 0.85 times the gap).
  double ellipse_size_m = 0.0;
  double ellipse_major_axis_deg = 0.0;
  /// Lost motion of each axis (u, v) fitted over the whole arc [m]: the table lagging its
  /// motion by g / 2 on that axis (a backlash of g), i.e. a radial deviation of g / 2 cos t
  /// (u) or g / 2 sin t (v) whose sign changes at that axis's reversals. Positive: lagging.
  std::array<double, 2> lost_motion_m{};
  std::vector<Reversal> reversals;  ///< at 0, 90, 180, 270 degrees
  double angular_speed_rad_per_s = 0.0;
};

/// The figures of one data arc about a circle of `radius_m` around the nominal centre.
/// The fits weigh each sample by the angle it covers (half the gaps to its neighbours in angle),
/// so that an uneven sampling does not bias them.
CircleFigures circle_figures(const DataArc& arc, double radius_m, const FigureOptions& options = {});

/// The radial deviation (radius - radius_m) at each angle of `grid_rad` [m], linear between the
/// samples sorted by angle (cyclic).
std::vector<double> deviation_on_grid(const DataArc& arc, double radius_m,
                                      const std::vector<double>& grid_rad);

/// ISO 230-4 circular hysteresis H: the largest radial difference between the CCW and the CW
/// path at the same angle (both about the nominal centre), on a 0.25-degree grid [m].
double circular_hysteresis_m(const DataArc& ccw, const DataArc& cw, double radius_m);

}  // namespace vmsim::app::circle
