#pragma once
// The checks that say whether a simulate-part result can be trusted, each with its figure.
//
// They are independent of the code they check: the set points are compared with the programmed
// path through the direct kinematics (not through the planner's spline), the axis positions with
// the machine file's travel, and the reference surface with the surface the planned tool path
// (the set points' geometry, itself checked against the program) cuts. A failed check that makes the result wrong is an error (the caller throws); one
// that only qualifies it is a warning in the terminal and at the top of the report.
#include <nlohmann/json.hpp>

#include <Eigen/Core>
#include <limits>
#include <string>
#include <vector>

#include "vmsim/kinematics/machine_model.hpp"
#include "vmsim/kinematics/path_kinematics.hpp"
#include "vmsim/planner/feedrate.hpp"
#include "vmsim/removal/tool.hpp"

namespace vmsim::app {

enum class CheckStatus { passed, warning, failed, not_done };

struct ValidityCheck {
  std::string id;        ///< e.g. "setpoints_on_path.production"
  std::string title;     ///< what was checked, in words
  double value = 0.0;    ///< the figure found, in `unit`
  double limit = 0.0;    ///< the figure it must not exceed, in `unit`
  std::string unit;      ///< "um", "mm", ...
  CheckStatus status = CheckStatus::not_done;
  std::string detail;    ///< where the figure was found (block, axis, s) or why not done
};

/// Largest distance from the tool tip of any set point (direct kinematics of q) to the
/// programmed polyline through the path points, measured to the segment that holds the set
/// point's s and to its two neighbours. Fails above `tolerance_m`. Set points on a rapid move
/// (`rapid_end[i]`: the segment ending at path point i is a rapid) are not checked: there the NC
/// moves each axis on its own, and the tip does not follow a line. Where the program allows
/// more (`contour_tolerance_m`, per path point: the contour tolerance on the motion that ends
/// there, ChainInputs::contour_tolerance_m; empty: none), the limit there is that tolerance: the
/// place reported is the one nearest its limit. Where the programmed tool axis turns between two
/// points the limit is at least turning_tolerance_m (FeedrateOptions::turning_path_tolerance_m).
/// Tool lengths: each segment is measured with the tool of the pose it ends at
/// (PathPose::tool_length_m, else tool_length_m), from that tool's tip at its start point.
ValidityCheck check_setpoints_on_path(const kinematics::MachineModel& machine,
                                      const std::vector<kinematics::PathPose>& path,
                                      const std::vector<bool>& rapid_end,
                                      const std::vector<double>& path_s_m, double tool_length_m,
                                      const planner::SetPoints& setpoints,
                                      const std::vector<std::string>& block_names,
                                      const std::string& run_name, double tolerance_m,
                                      const std::vector<double>& contour_tolerance_m = {},
                                      double turning_tolerance_m = 0.0);

/// Every set point of every axis with end stops against the axis's travel. The figure is the
/// smallest margin left (negative: how far beyond); fails when any set point is outside.
ValidityCheck check_setpoints_within_travel(const kinematics::MachineModel& machine,
                                            const std::vector<kinematics::PathPose>& path,
                                            const std::vector<double>& path_s_m,
                                            const planner::SetPoints& setpoints,
                                            const std::vector<std::string>& block_names,
                                            const std::string& run_name);

/// How far the actual position of an axis may lie beyond its software limit without an alarm
/// [m, rad]. A control monitors its software limits on the set points (the interpolator never
/// commands beyond them: check_setpoints_within_travel) and the actual positions with a
/// tolerance, so that a drive settling a little beyond a set point at the limit (a G28 return to
/// a reference point at the travel's end, the usual Z home) raises no alarm; the hardware limit
/// switch lies millimetres further. Beckhoff TwinCAT CNC documents it as P-AXIS-00179 "tolerance
/// range for software limit switch", default 0.1 mm (0.1 deg on rotary axes): taken here, since
/// machine files do not give it.
inline constexpr double kActualTravelTolerance_m = 0.1e-3;
inline constexpr double kActualTravelTolerance_rad = 0.1 * 3.14159265358979323846 / 180.0;

/// The simulated (actual) axis positions against the travel: a warning when a drive overshoots
/// an end stop (the set points are within it) by more than kActualTravelTolerance_m / _rad;
/// within it the check passes and its detail gives the overshoot.
ValidityCheck check_actual_within_travel(const kinematics::MachineModel& machine,
                                         const std::vector<double>& t_s, const Eigen::MatrixXd& q_actual,
                                         const std::string& run_name);

/// The drives' currents against their saturation (controller.saturation.current_A) while
/// cutting (`cutting[k]`): a warning naming the axis, its share of the cutting samples and the
/// first time when any drive sits at its limit there (the plan never asks for more torque than
/// the drive has: a saturated drive is a plan that leaves the controller no margin, or a model
/// mismatch). The figure is the largest share [%]; axes without saturation are not checked.
/// `current`: one row per axis [A], as the servo's `.cur` columns.
ValidityCheck check_drives_not_saturated(const kinematics::MachineModel& machine,
                                         const std::vector<double>& t_s, const Eigen::MatrixXd& current,
                                         const std::vector<bool>& cutting, const std::string& run_name);

/// check_setpoints_on_path set point by set point, for set points that come in windows (the
/// same verdict, figure and place as on all of them at once). The vectors are referenced, not
/// copied: they must outlive the check.
class SetpointsOnPathCheck {
 public:
  SetpointsOnPathCheck(const kinematics::MachineModel& machine, const std::vector<kinematics::PathPose>& path,
                       const std::vector<bool>& rapid_end, const std::vector<double>& path_s_m,
                       double tool_length_m, const std::vector<std::string>& block_names, std::string run_name,
                       double tolerance_m, const std::vector<double>& contour_tolerance_m,
                       double turning_tolerance_m);
  /// The next set point: its path length s [m] and axis positions (SI joint units).
  void add(double s_m, const Eigen::Ref<const Eigen::VectorXd>& q);
  ValidityCheck result() const;

 private:
  const kinematics::MachineModel& machine_;
  const std::vector<kinematics::PathPose>& path_;
  const std::vector<bool>& rapid_end_;
  const std::vector<double>& path_s_m_;
  double tool_length_m_;
  const std::vector<std::string>& block_names_;
  std::string run_name_;
  double tolerance_m_;
  const std::vector<double>& contour_tolerance_m_;
  double turning_tolerance_m_;
  std::size_t count_ = 0;
  double worst_m_ = 0.0, worst_s_m_ = 0.0, worst_limit_m_;
  double worst_ratio_ = 0.0;  ///< distance / limit: the place nearest its limit is the one reported
  bool contour_limit_used_ = false;
  bool worst_turns_ = false;  ///< the worst place's limit is the turning tolerance
};

/// check_setpoints_within_travel set point by set point (the same verdict, figure and place as
/// on all of them at once). The vectors are referenced: they must outlive the check.
class SetpointsWithinTravelCheck {
 public:
  SetpointsWithinTravelCheck(const kinematics::MachineModel& machine, const std::vector<kinematics::PathPose>& path,
                             const std::vector<double>& path_s_m, const std::vector<std::string>& block_names,
                             std::string run_name);
  /// The next set point: its path length s [m] and axis positions (SI joint units).
  void add(double s_m, const Eigen::Ref<const Eigen::VectorXd>& q);
  ValidityCheck result() const;

 private:
  struct Axis {
    double worst_beyond = 0.0;  ///< largest excess [mm or deg]
    double worst_q = 0.0, worst_s_m = 0.0;  ///< the first set point with it
    double min = std::numeric_limits<double>::infinity(), max = -std::numeric_limits<double>::infinity();
  };
  const kinematics::MachineModel& machine_;
  const std::vector<kinematics::PathPose>& path_;
  const std::vector<double>& path_s_m_;
  const std::vector<std::string>& block_names_;
  std::string run_name_;
  std::vector<Axis> axes_;
  std::size_t count_ = 0;
};

/// check_actual_within_travel sample by sample, for a run streamed in windows (the same verdict,
/// figure and place as on the whole run at once).
class ActualTravelCheck {
 public:
  ActualTravelCheck(const kinematics::MachineModel& machine, std::string run_name);
  /// One sample: its time [s] and the actual position of every axis (SI joint units).
  void add(double t_s, const Eigen::Ref<const Eigen::VectorXd>& q_actual);
  ValidityCheck result() const;

 private:
  const kinematics::MachineModel* machine_;
  std::string run_name_;
  std::vector<double> worst_;      ///< per axis, the largest overshoot [mm or deg]
  std::vector<double> worst_t_s_;  ///< and the first time it was reached
  bool beyond_tolerance_ = false;  ///< some overshoot beyond kActualTravelTolerance_m / _rad
};

/// check_drives_not_saturated sample by sample (the same verdict and figure as on the whole run).
class DriveSaturationCheck {
 public:
  DriveSaturationCheck(const kinematics::MachineModel& machine, std::string run_name);
  /// One sample: its time [s], the current of every axis [A] (the machine's axes, in order;
  /// fewer rows: the rest not checked) and whether its motion is a cutting move.
  void add(double t_s, const Eigen::Ref<const Eigen::VectorXd>& current_A, bool cutting);
  ValidityCheck result() const;

 private:
  struct Axis {
    std::size_t at_limit = 0;  ///< cutting samples at the limit
    double first_t_s = 0.0;    ///< the first of them
    double peak_A = 0.0;       ///< largest |current| while cutting
  };
  const kinematics::MachineModel* machine_;
  std::string run_name_;
  std::vector<Axis> axes_;
  std::size_t cutting_count_ = 0;
};

/// The reference surface against the surface the planned tool path cuts: the reference must
/// not differ from it by more than `limit_m` (the mark threshold), or marks could hide in it.
ValidityCheck check_reference_against_commanded(double worst_m, const Eigen::Vector3d& where_W_m,
                                                double limit_m);

/// Neighbouring lines whose heights differ by at most k line spacings (the steep-line rule,
/// surface_views.hpp: k = kSteepStepPerSpacing) lie on a surface of slope at most atan(k) for
/// the view; on such a surface two swept volumes d apart (Hausdorff) give line heights at most
/// d / cos(slope) <= d * sqrt(1 + k^2) apart (the offset by d along the normal, measured along
/// the line). sqrt(10) = 3.16 for k = 3.
double steep_line_factor(double steep_step_per_spacing);

/// How far the reference run's actual tool strays from its commanded path (issue 21: where it
/// stays close enough, the commanded path's surface is the reference and the reference run is
/// not cut). Fed sample by sample with the commanded and the actual tool pose (direct
/// kinematics of the set point and of the simulated position at the same time), it measures in
/// both directions the distance from each pose to the other path's polyline, searched within
/// `window_samples` samples either side of the same time (the drives follow with a delay along
/// the path, which leaves no trace in the swept volume): every actual pose lies within
/// deviation_m() of a commanded one and every commanded pose within it of an actual one, so
/// the two swept volumes are within that Hausdorff distance. The distance between two poses is
/// |tip difference| + (angle between the axes) x tool_reach_m: no point of an axisymmetric tool
/// (its cutting body: length L, radius R from the tip, reach = sqrt(L^2 + R^2)) moves further.
/// A search that misses the nearest point only overestimates: the figure is an upper bound (up
/// to the chord sagitta between samples, nanometres at a reference feed). Poses whose tool's
/// box is clear of `stock` (rapids above the part) remove nothing in either run and are not
/// matched.
class CommandedPathDeviation {
 public:
  CommandedPathDeviation(double tool_reach_m, double tool_radius_m, double tool_length_m,
                         const removal::Box& stock, std::size_t window_samples);
  void add(double t_s, const removal::Pose& commanded, const removal::Pose& actual);
  /// After the last sample.
  void finish();
  double deviation_m() const { return worst_m_; }
  double worst_t_s() const { return worst_t_s_; }  ///< where it was found
  bool worst_actual() const { return worst_actual_; }  ///< from an actual pose (else a commanded one)
  std::size_t poses_matched() const { return matched_; }  ///< poses not clear of the stock, both paths

 private:
  struct Entry {
    removal::Pose pose;
    bool clear = false;
  };
  bool clear_of_stock(const removal::Pose& pose) const;
  // Smallest pose distance from `query` to the segments [i, i + 1] of `path` for i in [first,
  // last) (absolute indices); returns it and sets `best` to the segment's index.
  double nearest(const removal::Pose& query, const std::vector<Entry>& path, std::size_t first, std::size_t last,
                 std::size_t& best) const;
  void process(std::size_t n, std::size_t known);
  double reach_m_, radius_m_, length_m_;
  removal::Box stock_;
  std::size_t window_;
  std::vector<Entry> commanded_, actual_;
  std::vector<double> t_s_;
  std::size_t dropped_ = 0;  ///< entries dropped at the front (same for all three vectors)
  std::size_t count_ = 0, next_ = 0;
  std::size_t best_commanded_ = 0, best_actual_ = 0;  ///< previous matches (the search starts there)
  double worst_m_ = 0.0, worst_t_s_ = 0.0;
  bool worst_actual_ = true;
  std::size_t matched_ = 0;
};

/// The reference's validity from that bound (the commanded path's surface is the reference, or
/// the simulated reference needs no cut of the commanded path to be checked): passed when the
/// line-height bound `surface_bound_m` is within `limit_m` (the mark threshold), failed beyond.
/// `detail`: what was used and why.
ValidityCheck check_reference_by_bound(double surface_bound_m, double limit_m, const std::string& detail);

/// One line for the terminal: "check ok|WARNING|FAILED|not done: <title>: <value> <unit> (limit ...); <where>".
std::string check_line(const ValidityCheck& check);
nlohmann::json check_json(const ValidityCheck& check);
const char* status_name(CheckStatus status);

/// Index of the path point whose segment holds s (the segment [s_i, s_i+1]).
std::size_t path_segment_at(const std::vector<double>& path_s_m, double s_m);

}  // namespace vmsim::app
