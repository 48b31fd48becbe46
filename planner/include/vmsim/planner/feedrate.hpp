#pragma once
// Feedrate interpolation (the NC's interpolator): the time law s(t) along a fixed path and the
// axis set points at the interpolation period (first paper, Sections 2-4).
//
// Units: SI inside (m, rad, s, N m). s is the arc length of the tool tip [m]; sd = ds/dt [m/s],
// sdd [m/s^2], sddd [m/s^3]; x = sd^2 and u = sdd = (1/2) dx/ds are the phase-plane variables.
//
// Constraints, per axis j (q_s, q_ss, q_sss: derivatives of the axis position along s):
//  - kinematic (Eq. 1, exact chain rule of Eq. 2):
//      |q_s sd| <= v_j,  |q_ss sd^2 + q_s sdd| <= a_j,
//      |q_sss sd^3 + 3 q_ss sd sdd + q_s sddd| <= j_j
//  - dynamic (Eq. 3-5 in the path form of kinematics::PathTorqueCoefficients, any EffectSet):
//      |a sdd + b sd^2 + c + d sd + e| <= tau_j,
//      |a sddd + (a_s + 2b) sd sdd + b_s sd^3 + c_s sd + d_s sd^2 + d sdd| <= taudot_j
//    with tau_j, taudot_j either the "tuned" equivalent limits of Eq. 10 (from the kinematic
//    limits and Drive::equivalent_inertia_kg_m2) or the "actuator" limits Drive::torque_max_N_m /
//    torque_rate_max_N_m_per_s (Table 2). The axis velocity limit v_j holds in both methods.
//  - the programmed feed: sd <= feed.
// A limit <= 0 is "no limit" for that axis and constraint.
//
// The maximum feedrate profile sd_lim(s) (Eq. 1-2, 7-9) is the paper's prediction with
// sdd = sddd = 0; the executed profile enforces the exact constraints above:
//  - second order only (third_order = false): the time-optimal profile on the grid (piecewise
//    constant sdd per grid segment, constraints at both ends of each segment), by the classic
//    backward (controllable sets, exact 2-variable feasibility by Newton on a concave piecewise
//    linear function) and forward (greatest feasible sdd) passes. No LP solver.
//  - with third-order limits (jerk / torque rate): a sequence of linear programmes (CLP, dual
//    simplex) per stretch in x and u at nodes (a subset of the grid points: spans of at most 32
//    grid segments, 1/8 of the acceleration's time scale a / j, and a 1 % change of the
//    second-order speed), u linear in s between nodes (x quadratic, x_c+1 = x_c + h (u_c +
//    u_c+1)), every row still imposed at every grid point, under x <= the second-order profile
//    (an upper bound). Rows at both ends of each grid segment (and second-order rows at its
//    middle): velocity as column bounds; acceleration / torque linear in (x, u), the viscous
//    d sqrt(x) bounded conservatively (tangent above, chord below); the third-order rows divided
//    by sd, |P u' + R u + S x + W| <= L / sqrt(x), whose convex right side is replaced by its
//    tangent at the previous iterate (a lower bound, exact there): each programme is an inner
//    approximation and the previous iterate stays feasible. Inside a grid segment x is
//    quadratic and peaks between the ends where u crosses zero downwards: there the rows are
//    imposed once more at the middle Bernstein coefficient of x, c1 = x0 + h u0
//    (min(x0, c1, x1) <= x <= max(x0, c1, x1)): 0 <= c1 <= the mean of the upper bound at the
//    ends and <= 2 cap_mid - the mean of the point caps (x at the middle under the velocity /
//    feed cap there, where it dips between the points: path 2's singular zone), and the
//    third-order rows of both ends with x = c1 (exact on a straight move; without
//    them a line on 10-50 grid segments exceeded its speed limit by 0.2 % between grid points,
//    part 1's rapids their jerk, and near stops x dipped below 0 inside a segment: a motion
//    that never reaches the next point). Each programme maximises the
//    first-order gain in T (sum of x weighted by ds / x^(3/2) at the current iterate, at the
//    second-order profile first), followed by a line search on T between the two iterates
//    (their segment is feasible: the programme's set is convex), so T decreases monotonically
//    (convex-concave procedure; stops when T gains < 1e-7). In torque-rate rows the viscous terms d_s sd + d u / sd are taken
//    at the previous iterate (not conservative; the set-point check below covers them). Rows are
//    generated lazily (the jerk row of the dominant axis first, then per node span and row
//    slot the most violated one, warm re-solves; a span is rescanned only where its nodes
//    moved). Near the stops the motion is the exact constant-jerk start s = j t^3 / 6 (and
//    its mirror): x = z (6 d)^(4/3) / 4, u = z (6 d)^(1/3) with z = j^(2/3) one column, over as
//    many grid segments as the rows allow the full jerk of the first segment, x stays below
//    1/4 of the second-order profile and the distance stays within the first jerk phase of the
//    straight-line optimum under the limits at the stop (until the acceleration limit, the
//    speed cap or, on a short move, a twelfth of it); its rows are polynomials in sqrt(z),
//    bounded exactly.
//    (A piecewise linear u cannot start from rest: x ~ s^2 would take an infinite time.)
//    The programme is feasible whenever the second-order problem is (x = u = 0), so this never
//    fails where the second order does not.
//    Near the stops the grid is refined over the constant-jerk ramp (below), where sd changes
//    fast and u linear in s holds the jerk row at a segment's faster end only.
//    Known gaps: speed in torque-rate mode (0.18-0.25 s for 10 000 points, bench_planner;
//    jerk 0.13-0.15 s); optimality within the profile class (u piecewise linear in s: on straight
//    lines 0.03-0.08 % above the seven-phase optimum on 10 000 segments, 0.9 % on 10); on
//    curved paths the rows inside a segment use the coefficients of its ends.
// Every result is then checked on the written set points (below); where a limit is exceeded
// the admissible feedrate is lowered around that place and the plan is redone, so that a
// returned plan never exceeds a limit on its set points by more than the check's allowance
// (kinematic 1e-4 relative; torque 1e-3, see feedrate.cpp). The check uses finite differences
// at the period (velocity backward, acceleration centred, jerk backward-centred): each is a
// positive weighted mean of the continuous derivative, so it never exceeds the continuous
// maximum. In dynamic mode, torque and torque rate are recomputed from q and centred
// differences through kinematics::actuator_torque_terms (the torque rate without the Dirac of
// dry friction at a velocity reversal, as in dynamics.hpp); at a reversal inside the stencil the
// dry friction gets the mean of its sign under the difference kernel, and samples whose stencil
// holds a stop (path ends, corners) are left to the rows at the stop.
//
// Corners (PathKinematics::corners, tangent discontinuities of G1 polylines): exact stop (the
// path is cut there and every stretch runs from rest to rest). Corner blending is done on the
// tool path before planning (corner_blend.hpp).
//
// Set points: s(t) on each grid segment follows the planned law in closed form: sdd linear in
// s on the third-order programme's segments (LinearAccelerationLaw: cosh / sinh or cos / sin),
// else the quintic Hermite interpolant in t of (s, sd, sdd) at its ends (exact for the
// constant-sdd and the constant-jerk segments); q(s) is the PathSpline
// (below) of the path refine_path made follow the programmed path (path_fidelity.hpp: points
// added where the spline would leave it by more than path_tolerance_m); every set point is
// checked against the axis travel. The planner's rows use q, q_s, q_ss and q_sss of that same spline, so that they
// bound what the set points do (with the fitted q_sss of solve_path_kinematics instead, the
// spline's own third derivative between the points went unseen: on sample part 1 the set points
// exceeded the X jerk by 44 % round after round).
// Grid: every path point, segments longer than max_grid_step_m subdivided, at least 4 grid
// segments per stretch; with third-order limits, within the ramp distance d of each stop
// (constant jerk from rest up to the acceleration it can hold, estimated from the rows at
// rest: d = sdd_max^3 / (6 sddd_max^2)) grid points at distances d/30 (1.06)^n from the stop,
// up to 58 per stop where the path is coarser than that (a 1.06 ratio costs the torque-rate
// bench 4 % more work for 0.03 % shorter T; 1.03 cost 13 % for 0.05 %). A stretch shorter than
// 2 d (a move that cannot reach its acceleration) gets points over its whole length instead,
// from a tenth of its half, 30 % apart.
#include <Eigen/Core>
#include <array>
#include <string>
#include <string_view>
#include <vector>

#include "vmsim/kinematics/dynamics.hpp"
#include "vmsim/kinematics/machine_model.hpp"
#include "vmsim/kinematics/path_kinematics.hpp"
#include "vmsim/planner/path_fidelity.hpp"

namespace vmsim::planner {

// ---------------------------------------------------------------------------------------------
// q(s) between path points

/// q(s) between the path points, C2 within each stretch between corners.
///  - Paths from solve_path_kinematics (PathKinematics::derivatives_fitted): per stretch, the
///    clamped cubic spline through the points, end slopes from the fits. Its derivatives are
///    its own: a quintic through the points with the fitted derivatives wiggles between them
///    where the fits smooth a feature (on sample part 1's tangency, Z's q_ss swung by +-100 /m
///    inside 0.2 mm segments and the set points exceeded the X jerk by 44 %). A cubic's q_sss
///    is constant per segment, so the rows at both segment ends see it whole; rounding noise e
///    of the points shows as about e / h^3 in it (the planner slows down for it, honestly).
///  - Hand-made paths (exact derivatives): the quintic Hermite through (q, q_s, q_ss).
/// At a corner the incoming side ends with the derivatives extrapolated from the point before
/// (q_s + q_ss h + q_sss h^2 / 2, q_ss + q_sss h), so that it is not bent towards the outgoing
/// direction.
class PathSpline {
 public:
  /// Throws vmsim::InputError when two consecutive points share s (an orientation change
  /// without tip motion cannot be parameterised by s) or when there are fewer than 2 points.
  explicit PathSpline(const kinematics::PathKinematics& path);

  std::size_t segment_count() const { return s_m_.size() - 1; }
  std::size_t axis_count() const { return static_cast<std::size_t>(coefficients_.rows()); }
  const std::vector<double>& s_m() const { return s_m_; }
  double length_m() const { return s_m_.back(); }
  /// The segment holding s (the last one for s >= length).
  std::size_t segment_of(double s_m) const;
  /// q and its derivatives at sigma [m] from the start of `segment` (any of the outputs may
  /// be nullptr).
  void evaluate(std::size_t segment, double sigma_m, Eigen::VectorXd* q, Eigen::VectorXd* q_s,
                Eigen::VectorXd* q_ss, Eigen::VectorXd* q_sss) const;
  /// q at s [m].
  Eigen::VectorXd position(double s_m) const;

 private:
  std::vector<double> s_m_;
  /// Per segment, 6 columns of polynomial coefficients in sigma per axis row.
  Eigen::MatrixXd coefficients_;  // rows = axes, cols = 6 * segments
};

// ---------------------------------------------------------------------------------------------
// Options and results

enum class FeedrateMethod { kinematic, dynamic };
enum class DynamicLimitSource { tuned, actuator };

/// The constraint kinds, in the column order of the limits file.
enum class ConstraintKind : int {
  feed = 0,
  velocity = 1,
  acceleration = 2,
  jerk = 3,
  torque = 4,
  torque_rate = 5,
};
inline constexpr int kConstraintKindCount = 6;
/// "feed", "velocity", "acceleration", "jerk", "torque", "torque_rate".
std::string_view constraint_name(ConstraintKind kind);

struct FeedrateOptions {
  FeedrateMethod method = FeedrateMethod::kinematic;
  DynamicLimitSource limits = DynamicLimitSource::tuned;
  kinematics::EffectSet effects = kinematics::EffectSet::all();
  /// Third-order limits (jerk in kinematic mode, torque rate in dynamic mode).
  bool third_order = true;
  /// Programmed feed [m/s] for the whole path; 0 = use point_feed_m_per_s (or no feed limit).
  double feed_m_per_s = 0.0;
  /// Programmed feed per path point [m/s] for the motion that ends there (0 = none, e.g. a
  /// rapid); empty = none. Ignored when feed_m_per_s > 0.
  std::vector<double> point_feed_m_per_s;
  /// Per path point: the motion that ends there is a rapid (G0, APT RAPID); empty = none. A
  /// rapid is not held to the programmed line (as on an NC, G0 moves each axis on its own: a
  /// rotary turn outside tool-centre-point mode is linear in the axes, not a line in W), so the
  /// path fidelity refinement leaves its segment alone.
  std::vector<bool> rapid_end;
  /// Per path point: a dwell [s] after the motion that ends there (G4, a cycle's dwell): the
  /// point is an exact stop and the set points hold it at rest that long (SetPointLaw: the grid
  /// point's time includes it). Empty: none; else one value >= 0 per path point.
  std::vector<double> point_dwell_s;
  /// Largest planning grid step [m]: longer path segments are subdivided (with third-order
  /// limits, finer near the stops). 0 = automatic (the path length / 4000).
  double max_grid_step_m = 0.0;
  /// Set-point period [s]; 0 = MachineModel::interpolation_period_s.
  double period_s = 0.0;
  /// Rounds of "check the set points, slow down where a limit is exceeded, plan again".
  int max_verification_rounds = 200;
  /// Stop after the maximum feedrate profile (FeedratePlan::profile's grid, sd_lim_* and
  /// lower_bound_s only; no executed profile, no set points).
  bool profile_only = false;
  /// Path fidelity (path_fidelity.hpp): between the path points the tool tip stays within this
  /// distance [m] of the programmed segment (points are added on the programmed path until the
  /// spline does), as an NC's linear interpolation does to within its rounding.
  double path_tolerance_m = PathFidelityOptions{}.tolerance_m;
  /// The same [m] on segments where the tool axis turns (PathFidelityOptions::turning_tolerance_m).
  double turning_path_tolerance_m = PathFidelityOptions{}.turning_tolerance_m;
  /// Per path point: the program's contour tolerance [m] for the segment ending there where it
  /// allows more than path_tolerance_m (PathFidelityOptions::segment_tolerance_m). Empty: none.
  std::vector<double> point_path_tolerance_m;
  /// ... and the tool axis within this angle [rad] of the programmed one (great-circle
  /// interpolation between the points).
  double path_axis_tolerance_rad = PathFidelityOptions{}.axis_tolerance_rad;
  /// Keep FeedratePlan::setpoints after planning. false: the planner never holds the whole set:
  /// its check rounds (check_setpoints and the slow-down spans), the travel and the
  /// path-fidelity checks take the set points window by window from the plan's law
  /// (check_window_samples at a time, with the few neighbours each check's stencil needs), with
  /// the same results bit for bit (the same plan, worst values and places, errors);
  /// SetPointGenerator makes them again for the caller. Memory then grows with the program
  /// (grid, path), not with its duration.
  bool keep_setpoints = true;
  /// Set points per window of those checks when keep_setpoints is false (>= 1): each window
  /// holds this many plus 9 set points (2 before and after for the finite differences, 5 before
  /// and 4 after for the slow-down span).
  std::size_t check_window_samples = 4096;
  /// Throws vmsim::InputError naming the field and value.
  void validate() const;
};

/// The limit values in force, per axis (SI, joint units); 0 = no limit.
struct AxisLimitValues {
  double velocity = 0.0, acceleration = 0.0, jerk = 0.0;
  double torque_N_m = 0.0, torque_rate_N_m_per_s = 0.0;
};

/// The planning grid with the maximum feedrate profile (Eq. 1-2 / 7-9) and the executed one.
struct FeedrateProfile {
  std::vector<double> s_m;  ///< grid (every path point, plus subdivisions)
  /// sd_lim per constraint kind [m/s] (minimum over the axes), +inf where none applies.
  std::array<std::vector<double>, kConstraintKindCount> sd_lim_by_kind;
  /// The axis giving sd_lim_by_kind (-1 where none, and for the feed).
  std::array<std::vector<int>, kConstraintKindCount> axis_by_kind;
  std::vector<double> sd_lim;  ///< minimum over every kind in force [m/s]
  std::vector<ConstraintKind> limiting_kind;
  std::vector<int> limiting_axis;  ///< -1 for the feed
  /// Executed profile at the grid points: time [s] (dwells included: SetPointLaw::t_s), sd
  /// [m/s], sdd [m/s^2] (the value on the segment that starts there; the last point: 0).
  std::vector<double> t_s, sd, sdd;
  /// Admissible sd [m/s] after the set-point checks lowered it (equal to sd_lim where no
  /// slow-down was needed).
  std::vector<double> sd_cap;
  std::vector<bool> stop;  ///< exact stop (path ends and corners)
};

struct SetPoints {
  double period_s = 0.0;
  std::vector<double> t_s;  ///< k * period_s, from 0 to the first multiple >= the duration
  std::vector<double> s_m;
  Eigen::MatrixXd q;  ///< axis positions, one column per sample (SI joint units)
};

/// The executed time law s(t) on the planning grid, which the set points sample: per grid
/// segment sdd linear in s (LinearAccelerationLaw) or the quintic Hermite in t (see the header
/// notes). s at a sample needs the law alone; q needs the plan's spline too (SetPointGenerator).
struct SetPointLaw {
  double period_s = 0.0;
  double duration_s = 0.0;
  std::size_t samples = 0;  ///< set points: k * period_s from 0 to the first multiple >= duration_s
  std::vector<double> grid_s_m;           ///< the planning grid (points)
  std::vector<std::size_t> spline_segment;  ///< per grid segment: the PathSpline segment holding it
  std::vector<double> spline_sigma0_m;    ///< per grid segment: its start within that segment
  std::vector<double> x;                  ///< sd^2 at the grid points [m^2/s^2]
  std::vector<double> sdd_start, sdd_end;  ///< per grid segment: sdd at its ends [m/s^2]
  std::vector<char> linear_law;           ///< per grid segment: sdd linear in s (else the quintic)
  std::vector<double> dt_s;               ///< per grid segment: its duration (the motion)
  /// At the grid points: when the motion reaching it ends plus the dwell held there
  /// (FeedrateOptions::point_dwell_s): t_s[k + 1] = t_s[k] + dt_s[k] + dwell at k + 1, and
  /// t_s[0] is the dwell at the start. Between the motion's end and t_s[k + 1] the set points
  /// stay at grid point k + 1.
  std::vector<double> t_s;
  std::size_t segments() const { return grid_s_m.empty() ? 0 : grid_s_m.size() - 1; }
  double sample_t_s(std::size_t n) const { return static_cast<double>(n) * period_s; }
  /// The grid segment and the distance sigma [m] into it of sample n. `cursor`: the grid segment
  /// of the previous call (0 at first); calls in increasing n cost O(1) each.
  void locate(std::size_t n, std::size_t& cursor, std::size_t& grid_segment, double& sigma_m) const;
  /// s [m] of sample n (the value SetPoints::s_m holds there).
  double sample_s_m(std::size_t n, std::size_t& cursor) const;
  /// s [m] at time t: linear between the samples around t (the samples' first / last value
  /// outside them).
  double s_at_time(double t_s) const;
};

struct FeedratePlan;

/// The set points of a plan, window by window, from its law and spline: the same values bit
/// for bit as FeedratePlan::setpoints (which a plan planned with keep_setpoints = false does
/// not hold). References the plan, which must outlive it.
class SetPointGenerator {
 public:
  explicit SetPointGenerator(const FeedratePlan& plan);
  std::size_t size() const { return law_.samples; }
  /// Set points first .. first + count - 1 (count clamped to the end) into `window`
  /// (t_s, s_m, q resized to them; period_s set).
  void fill(std::size_t first, std::size_t count, SetPoints& window);

 private:
  const SetPointLaw& law_;
  PathSpline spline_;
  std::size_t cursor_ = 0;
};

/// The largest |value| / limit found on the set points, per constraint kind and axis.
struct SetPointCheck {
  Eigen::MatrixXd ratio;  ///< rows = axes, cols = kConstraintKindCount (feed column: tip feed)
  double worst() const;
};

struct FeedratePlan {
  std::vector<AxisLimitValues> limits;  ///< per axis
  FeedrateProfile profile;
  SetPoints setpoints;  ///< empty when planned with FeedrateOptions::keep_setpoints = false
  SetPointLaw law;      ///< what the set points sample (SetPointGenerator)
  SetPointCheck check;
  double duration_s = 0.0;     ///< T
  double lower_bound_s = 0.0;  ///< T_lb = integral ds / sd_lim(s) (trapezoid on the grid)
  int slowdown_rounds = 0;     ///< set-point checks that led to a slow-down
  /// The path planned: the input with the points refine_path added on the programmed path
  /// (profile.s_m and the set points refer to it; s of the input points is unchanged).
  kinematics::PathKinematics path;
  std::size_t points_added = 0;  ///< points refine_path added (grading and check)
  /// Largest distance [m] of a set point's tool tip (or of the spline at the refinement's
  /// check samples) from its programmed segment, where it is (s [m], the block of the segment's
  /// end point) and the largest tool-axis angle [rad] from the programmed one. Only for paths
  /// from solve_path_kinematics (path_fidelity_checked); within path_tolerance_m by
  /// construction.
  bool path_fidelity_checked = false;
  double path_deviation_max_m = 0.0;
  double path_deviation_s_m = 0.0;
  std::string path_deviation_block;
  double path_axis_deviation_max_rad = 0.0;
  std::vector<std::string> notes;  ///< what the user should know (e.g. unlimited axes)
};

/// Plans the feedrate along `path` (from kinematics::solve_path_kinematics on `machine`).
/// First refine_path adds points on the programmed path where the spline would leave it by
/// more than path_tolerance_m (paths with fitted derivatives only); after planning every set
/// point of every axis with end stops is checked against the travel.
/// Throws vmsim::InputError for bad options or a path that cannot be parameterised by s;
/// vmsim::InfeasibleError (naming s and the axis) where the machine cannot hold the path even
/// at rest (e.g. gravity above the torque limit), when no admissible plan is found, when the
/// path tolerance cannot be met (refine_path), or when a set point leaves an axis's travel
/// (naming the axis, the value and the travel in mm or deg, s, and the block).
FeedratePlan plan_feedrate(const kinematics::MachineModel& machine,
                           const kinematics::PathKinematics& path,
                           const FeedrateOptions& options = {});

/// The limit values in force for each axis under `options` (Eq. 10 for tuned dynamic limits).
std::vector<AxisLimitValues> limit_values(const kinematics::MachineModel& machine,
                                          const FeedrateOptions& options);

/// Set-point check (see the header notes): finite differences of q at the period, the motion
/// held at rest before the first and after the last sample.
SetPointCheck check_setpoints(const kinematics::MachineModel& machine,
                              const kinematics::DynamicsModel* dynamics,
                              const std::vector<AxisLimitValues>& limits,
                              const FeedrateOptions& options, const SetPoints& setpoints);

}  // namespace vmsim::planner
