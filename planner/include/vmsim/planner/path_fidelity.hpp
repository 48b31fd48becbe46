#pragma once
// Path fidelity: the axis positions between the path points follow the programmed path.
//
// The programmed path is a polyline of tool poses: between two path points the tip moves on the
// straight segment and the tool axis turns on the great circle between the two axes (as an NC's
// linear interpolation, with TRAORI on a 5-axis machine). PathSpline interpolates q(s) instead
// (a C2 cubic through the points, per stretch between corners): between the points its tip
// leaves the segment. Where dense points meet a long segment without a corner between them (a
// finely tessellated arc tangent to a 185 mm line) the clamped spline carries the dense side's
// curvature into the long segment and leaves it by metres (a user's Fusion 360 pocket: X at
// -178 m). refine_path adds points on the programmed path until the spline stays within a
// tolerance of it:
//  1. grading: a segment more than 4 times longer than the spacing next to it gets points whose
//     spacing grows from the shorter side's by at most spacing_ratio per point (a size field
//     that grows by (ratio - 1) per unit of arc length from each point's shorter segment);
//     and the end slopes of every stretch are taken from the programmed motion (the fits'
//     slopes, smoothed over 2 mm, hooked the spline where a long segment ends a stretch);
//  2. check and refine: the tip of the spline's q at interior samples of every segment (direct
//     kinematics with the path's tool length) is compared with the programmed segment, and the
//     tool axis with the programmed one (great-circle interpolation at the same fraction of the
//     segment); a segment off by more than the tolerance gets a point at its middle, and the
//     spline is rebuilt, until every segment is within it. That point goes where the spline
//     already is, drawn towards the programmed segment (the tip across it, the tool axis towards
//     the programmed one) only as far as the worst sample must come in: a point inserted on an
//     interpolating spline leaves it unchanged, so the spline moves by the excess alone and a
//     tessellated arc keeps its curvature (points on the chords bent it at their spacing).
// A grading point lies on the programmed geometry (the tip on the segment), a check point within
// the tolerance of it; either keeps s of every point. q comes from the inverse kinematics seeded
// by the linear interpolation of the neighbours' q (continuity, rotary axes unwrapped). Every
// stretch stays C2 (the third-order planner bounds q_sss); corners are not touched.
// Only paths with fitted derivatives (kinematics::solve_path_kinematics) are refined: a path made
// by hand carries the exact derivatives of a smooth curve, not a polyline.
#include <Eigen/Core>
#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include "vmsim/kinematics/machine_model.hpp"
#include "vmsim/kinematics/path_kinematics.hpp"

namespace vmsim::planner {

struct PathFidelityOptions {
  /// Largest distance [m] of the tool tip from its programmed segment between the path points,
  /// where the tool axis keeps its direction (3-axis and 3+2 motion). 0.5 um by default, within
  /// which an NC's linear interpolation holds G1 points. The check's insertions (step 2 above)
  /// sit where the spline already is, drawn in only as far as needed, so a tight tolerance does
  /// not bend the path: on sample part 1 (0.49 um from its chords, the tessellation's sagitta
  /// and the tangency's ring) 0.5 um adds 82 points and leaves the duration (104.27 s against
  /// 104.06 s) and the tangency mark (18.87 um against 18.9) as they were; with the points put
  /// on the chords it took 115.97 s and the mark fell to 5.4 um.
  double tolerance_m = 0.5e-6;
  /// The same [m] on segments where the tool axis turns (simultaneous 5-axis motion). A joint
  /// space spline bends the tip off the chord there (sample part 3: 2.7 um); holding it tighter
  /// makes the joints follow the IKT's kinks at every point and costs time that no NC spends
  /// (part 3: T 32.0 s at 5 um, 50.6 s at 1 um, 88.4 s at 0.5 um): an NC with tool-centre-point
  /// control blends those kinks within its contour tolerance, which this spline does not model.
  double turning_tolerance_m = 5e-6;
  /// Largest angle [rad] between the tool axis and the programmed one between the path points
  /// (at least the IKT's singular_angle_rad inside singular zones, where the IKT reaches the axis
  /// only to within that angle).
  double axis_tolerance_rad = 1e-4;
  /// Per path point: the segment that ends there is free (a rapid that does not turn the tool
  /// about a fixed tip): not checked nor refined, its end slopes those of the axes' straight line
  /// (FeedrateOptions::rapid_end). Empty: none.
  std::vector<bool> free_end;
  /// Per path point: the allowance [m] for the segment that ends there where the program allows
  /// more than tolerance_m (a contour tolerance: G64 P, G5.1, CYCLE832 ...: the NC itself may
  /// leave the programmed polyline by that much there). The larger of the two is used. Empty:
  /// tolerance_m everywhere.
  std::vector<double> segment_tolerance_m;
  /// Largest ratio of neighbouring segment lengths the grading leaves (> 1).
  double spacing_ratio = 1.5;
  /// Rounds of "check, insert midpoints" before giving up (each halves the offending segments).
  int max_rounds = 40;
  /// Interior samples per segment in the check.
  int samples_per_segment = 8;
  /// Throws vmsim::InputError naming the field and value.
  void validate() const;
};

/// The largest deviation from the programmed path, and where.
struct PathDeviation {
  double tip_m = 0.0;      ///< largest distance of the tip from its programmed segment [m]
  double tip_s_m = 0.0;    ///< s where it is [m]
  std::size_t tip_point = 0;  ///< the path point that ends that segment
  double axis_rad = 0.0;   ///< largest angle of the tool axis from the programmed one [rad]
  double axis_s_m = 0.0;
  std::size_t axis_point = 0;
};

struct RefinedPath {
  kinematics::PathKinematics path;  ///< the input path with the points added
  /// Per point of `path`: the input path point that ends its segment (itself for an input point).
  std::vector<std::size_t> source_point;
  std::size_t graded_points = 0;   ///< points added by the grading
  std::size_t refined_points = 0;  ///< points added by the check
  int rounds = 0;                  ///< check rounds that added points
  /// The largest deviation of the final spline at the check's samples.
  PathDeviation deviation;
  /// Empty, or where the tolerance was not met after max_rounds (within 10 times it).
  std::string unmet;
};

/// Refines `path` (see the header notes). Throws vmsim::InputError for bad options;
/// vmsim::InfeasibleError naming the path point and block when an inserted pose has no inverse
/// kinematic solution, or when a segment is still more than 10 times the tolerance off after
/// options.max_rounds rounds (less: RefinedPath::unmet says where).
RefinedPath refine_path(const kinematics::MachineModel& machine,
                        const kinematics::PathKinematics& path,
                        const PathFidelityOptions& options = {});

/// The largest deviation from the programmed polyline of `path` (tips and axes by direct
/// kinematics of its points) of the poses of q's columns at arc lengths s_m: each against the
/// segment that holds its s. free_end (per point of `path`, or empty): the segment ending there
/// is a rapid the NC does not hold to the line (PathFidelityOptions::free_end; a turn about a
/// fixed tip, path.turns_in_place, is held all the same); poses on it are not counted.
PathDeviation pose_deviation(const kinematics::MachineModel& machine,
                             const kinematics::PathKinematics& path,
                             const std::vector<double>& s_m, const Eigen::MatrixXd& q,
                             const std::vector<bool>& free_end = {});

namespace detail {
struct ProgrammedPolyline;
}

/// pose_deviation pose after pose (set points taken window by window): add the poses in the
/// order of pose_deviation's columns and result() is what pose_deviation gives on them all, bit
/// for bit. References machine and path, which must outlive it.
class PoseDeviationTracker {
 public:
  PoseDeviationTracker(const kinematics::MachineModel& machine, const kinematics::PathKinematics& path,
                       std::vector<bool> free_end = {});
  ~PoseDeviationTracker();
  PoseDeviationTracker(const PoseDeviationTracker&) = delete;
  PoseDeviationTracker& operator=(const PoseDeviationTracker&) = delete;
  /// The pose of axis positions q at arc length s [m].
  void add(double s_m, const Eigen::VectorXd& q);
  const PathDeviation& result() const { return out_; }

 private:
  const kinematics::MachineModel& machine_;
  const kinematics::PathKinematics& path_;
  std::vector<bool> free_end_;
  std::unique_ptr<const detail::ProgrammedPolyline> programmed_;
  PathDeviation out_;
};

/// "block 'file:line N..'" (or "block #k", or "no block") of path point `point`.
std::string path_point_label(const kinematics::PathKinematics& path, std::size_t point);

}  // namespace vmsim::planner
