// Path fidelity: the set points follow the programmed polyline (within the planner's path
// tolerance) and never leave the travel. Distances are computed here from the programmed poses
// (direct kinematics of the set points against the segments of the poses given to the
// kinematics), not taken from the planner.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include "feedrate_test_support.hpp"
#include "vmsim/common/errors.hpp"
#include "vmsim/kinematics/kinematics.hpp"
#include "vmsim/kinematics/path_kinematics.hpp"
#include "vmsim/kinematics/sample_models.hpp"
#include "vmsim/planner/feedrate.hpp"
#include "vmsim/planner/path_fidelity.hpp"

namespace vmsim::planner {
namespace {

using Eigen::Vector3d;
constexpr double kToolLength_m = 0.1;

double distance_to_segment(const Vector3d& p, const Vector3d& a, const Vector3d& b) {
  const Vector3d ab = b - a;
  const double t = ab.squaredNorm() > 0.0 ? std::clamp((p - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0) : 0.0;
  return (p - a - t * ab).norm();
}

/// The programmed polyline: tips and cumulative chord length.
struct Polyline {
  std::vector<Vector3d> tip;
  std::vector<double> s_m;
  explicit Polyline(const std::vector<kinematics::PathPose>& poses) {
    for (const auto& p : poses) {
      s_m.push_back(tip.empty() ? 0.0 : s_m.back() + (p.pose.tip_W_m - tip.back()).norm());
      tip.push_back(p.pose.tip_W_m);
    }
  }
  /// Distance of x from the segment that holds s (at least the distance to the polyline).
  double distance(double s, const Vector3d& x) const {
    auto it = std::upper_bound(s_m.begin(), s_m.end(), s);
    std::size_t i = it == s_m.begin() ? 0 : static_cast<std::size_t>(it - s_m.begin()) - 1;
    i = std::min(i, s_m.size() - 2);
    double d = distance_to_segment(x, tip[i], tip[i + 1]);
    // At a point shared by two segments either is right.
    if (i > 0 && std::abs(s - s_m[i]) < 1e-12) d = std::min(d, distance_to_segment(x, tip[i - 1], tip[i]));
    return d;
  }
  /// Brute force: the distance to the nearest segment.
  double distance_to_polyline(const Vector3d& x) const {
    double d = INFINITY;
    for (std::size_t i = 0; i + 1 < tip.size(); ++i) d = std::min(d, distance_to_segment(x, tip[i], tip[i + 1]));
    return d;
  }
};

/// Largest excursion [joint unit] of any column of q beyond an axis's travel (0 inside).
double travel_excess(const kinematics::MachineModel& machine, const Eigen::MatrixXd& q) {
  double worst = 0.0;
  for (std::size_t j = 0; j < machine.axes.size(); ++j) {
    const auto& axis = machine.axes[j];
    if (axis.type == kinematics::AxisType::rotary && axis.continuous) continue;
    for (Eigen::Index n = 0; n < q.cols(); ++n) {
      const double v = q(static_cast<Eigen::Index>(j), n);
      worst = std::max({worst, axis.travel_min - v, v - axis.travel_max});
    }
  }
  return worst;
}

kinematics::PathKinematics solve(const kinematics::MachineModel& machine,
                                 const std::vector<kinematics::PathPose>& poses) {
  Eigen::VectorXd q_start = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(machine.axis_count()));
  q_start(2) = -0.3;
  std::vector<std::string> names;
  for (const auto& p : poses) names.resize(std::max<std::size_t>(names.size(), static_cast<std::size_t>(p.block) + 1));
  for (std::size_t b = 0; b < names.size(); ++b) names[b] = "test.nc:" + std::to_string(b + 1);
  return kinematics::solve_path_kinematics(machine, poses, q_start, kToolLength_m, names);
}

/// A tip position the sample machine reaches with room in every direction (Z at -0.3 m).
Vector3d reachable_origin(const kinematics::MachineModel& machine) {
  Eigen::VectorXd q = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(machine.axis_count()));
  q(2) = -0.3;
  return kinematics::forward_kinematics(machine, q, kToolLength_m).tip_W_m;
}

/// The user's case: a 185 mm line, a half circle of radius 5 mm tessellated at 0.035 mm
/// chords, tangent to it, and a 185 mm line back; no corner between them (a 2-D pocket
/// finishing pass). Tool axis +z.
std::vector<kinematics::PathPose> line_arc_line(const Vector3d& origin) {
  std::vector<kinematics::PathPose> poses;
  const double line = 0.185, radius = 0.005, chord = 35e-6;
  const Vector3d start = origin - Vector3d(0.5 * line, radius, 0.0);
  poses.push_back({{start, Vector3d::UnitZ()}, 0});
  poses.push_back({{start + Vector3d(line, 0, 0), Vector3d::UnitZ()}, 1});
  const Vector3d centre = start + Vector3d(line, radius, 0);
  const int chords = static_cast<int>(std::ceil(std::numbers::pi * radius / chord));
  for (int k = 1; k <= chords; ++k) {
    const double phi = -0.5 * std::numbers::pi + std::numbers::pi * k / chords;
    poses.push_back({{centre + radius * Vector3d(std::cos(phi), std::sin(phi), 0), Vector3d::UnitZ()}, 2});
  }
  poses.push_back({{start + Vector3d(0, 2 * radius, 0), Vector3d::UnitZ()}, 3});
  return poses;
}

// Reproduces the issue: on the old planner the set points left the line by metres (X far
// beyond its travel) and the plan succeeded.
TEST(PathFidelity, DenseArcTangentToALongLineStaysOnThePath) {
  const auto machine = kinematics::make_table_table_sample();
  const auto poses = line_arc_line(reachable_origin(machine));
  const Polyline programmed(poses);
  const auto path = solve(machine, poses);
  ASSERT_TRUE(path.corners.empty());
  FeedrateOptions options;
  options.third_order = false;
  options.feed_m_per_s = 0.1;
  options.path_tolerance_m = 0.5e-6;
  const FeedratePlan plan = plan_feedrate(machine, path, options);
  double worst = 0.0, worst_brute = 0.0;
  for (Eigen::Index n = 0; n < plan.setpoints.q.cols(); ++n) {
    const Vector3d tip = kinematics::forward_kinematics(machine, plan.setpoints.q.col(n), kToolLength_m).tip_W_m;
    worst = std::max(worst, programmed.distance(plan.setpoints.s_m[static_cast<std::size_t>(n)], tip));
    worst_brute = std::max(worst_brute, programmed.distance_to_polyline(tip));
  }
  std::printf("line-arc-line: %zu points, %zu set points, largest tip distance %.3g um (brute force %.3g um)\n",
              path.s_m.size(), plan.setpoints.s_m.size(), worst * 1e6, worst_brute * 1e6);
  EXPECT_LE(worst, options.path_tolerance_m);
  EXPECT_LE(worst_brute, options.path_tolerance_m);
  EXPECT_LE(travel_excess(machine, plan.setpoints.q), 0.0);
}

// The same path through the spline alone, densely sampled (between the set points too).
TEST(PathFidelity, RefinedSplineOfTheDenseArcCaseStaysWithinTheTolerance) {
  const auto machine = kinematics::make_table_table_sample();
  const auto poses = line_arc_line(reachable_origin(machine));
  const Polyline programmed(poses);
  const auto path = solve(machine, poses);
  PathFidelityOptions options;
  options.tolerance_m = 0.5e-6;
  const RefinedPath refined = refine_path(machine, path, options);
  EXPECT_GT(refined.graded_points, 0u);
  // The input points keep their s.
  for (std::size_t i = 0, k = 0; k < refined.path.s_m.size(); ++k) {
    if (refined.source_point[k] == i && refined.path.s_m[k] == path.s_m[i]) ++i;
    if (k + 1 == refined.path.s_m.size()) {
      EXPECT_EQ(i, path.s_m.size());
    }
  }
  const PathSpline spline(refined.path);
  double worst = 0.0;
  Eigen::VectorXd q;
  for (std::size_t i = 0; i < spline.segment_count(); ++i) {
    const double h = spline.s_m()[i + 1] - spline.s_m()[i];
    for (int k = 0; k <= 40; ++k) {
      spline.evaluate(i, h * k / 40.0, &q, nullptr, nullptr, nullptr);
      const Vector3d tip = kinematics::forward_kinematics(machine, q, kToolLength_m).tip_W_m;
      worst = std::max(worst, programmed.distance(spline.s_m()[i] + h * k / 40.0, tip));
    }
  }
  std::printf("line-arc-line: %zu points graded in, %zu by the check; spline within %.3g um\n",
              refined.graded_points, refined.refined_points, worst * 1e6);
  EXPECT_LE(worst, options.tolerance_m);
  EXPECT_LE(refined.deviation.tip_m, options.tolerance_m);
}

// A circle of G1 chords (radius 100 mm, 2 deg apart: the circle is 15 um off its chords), as
// a program under G64 P writes it: the NC may leave the polyline by the program's contour
// tolerance there, so the spline, which follows the circle, needs no added points where that
// tolerance is larger; where it is not (the first half here), the default holds.
/// A 40 mm line, a quarter circle of radius 15 mm tessellated at 0.17 mm chords (sagitta
/// 0.24 um) tangent to it, and a 40 mm line on: sample part 1's fillet, in one plane.
std::vector<kinematics::PathPose> line_fillet_line(const Vector3d& origin, double* radius_m) {
  std::vector<kinematics::PathPose> poses;
  const double line = 0.04, radius = 0.015, chord = 170e-6;
  *radius_m = radius;
  const Vector3d start = origin - Vector3d(line, radius, 0.0);
  for (int k = 0; k <= 20; ++k) poses.push_back({{start + Vector3d(line * k / 20.0, 0, 0), Vector3d::UnitZ()}, 0});
  const Vector3d centre = start + Vector3d(line, radius, 0);
  const int chords = static_cast<int>(std::ceil(0.5 * std::numbers::pi * radius / chord));
  for (int k = 1; k <= chords; ++k) {
    const double phi = -0.5 * std::numbers::pi + 0.5 * std::numbers::pi * k / chords;
    poses.push_back({{centre + radius * Vector3d(std::cos(phi), std::sin(phi), 0), Vector3d::UnitZ()}, 1});
  }
  const Vector3d end = centre + Vector3d(radius, 0, 0);
  for (int k = 1; k <= 20; ++k) poses.push_back({{end + Vector3d(0, line * k / 20.0, 0), Vector3d::UnitZ()}, 2});
  return poses;
}

/// The largest curvature [1/m] of the tool tip's path along the spline of `path` over s in
/// [s_begin, s_end] (second differences of the direct kinematics, 20 um apart).
double largest_tip_curvature(const kinematics::MachineModel& machine, const kinematics::PathKinematics& path,
                             double s_begin, double s_end) {
  const PathSpline spline(path);
  constexpr double h = 20e-6;
  auto tip = [&](double s) { return kinematics::forward_kinematics(machine, spline.position(s), kToolLength_m).tip_W_m; };
  double largest = 0.0;
  for (double s = s_begin + h; s < s_end - h; s += 0.25 * h) {
    largest = std::max(largest, (tip(s + h) - 2.0 * tip(s) + tip(s - h)).norm() / (h * h));
  }
  return largest;
}

// A tolerance tighter than the spline's own distance from the chords adds points; they must not
// bend the path. Points put on the chords (the planner before this test) pulled the spline in
// by the whole sagitta at every added point and its curvature swung at the points' spacing (on
// sample part 1 the fillet then ran 3.6 % slower and its mark fell from 18.9 to 5.4 um). Points
// put where the spline is, drawn in only as far as needed, leave the curvature near the arc's.
TEST(PathFidelity, ATightToleranceDoesNotBendATessellatedArc) {
  const auto machine = kinematics::make_table_table_sample();
  double radius_m = 0.0;
  const auto poses = line_fillet_line(reachable_origin(machine), &radius_m);
  const auto path = solve(machine, poses);
  ASSERT_TRUE(path.corners.empty());
  PathFidelityOptions loose;
  loose.tolerance_m = 5e-6;
  const RefinedPath untouched = refine_path(machine, path, loose);
  ASSERT_EQ(untouched.refined_points, 0u);
  PathFidelityOptions tight;
  tight.tolerance_m = 0.2e-6;  // below the tessellation's sagitta: the whole arc gets points
  const RefinedPath refined = refine_path(machine, path, tight);
  EXPECT_GT(refined.refined_points, 50u);
  EXPECT_LE(refined.deviation.tip_m, tight.tolerance_m);
  // Over the arc and 2 mm of the lines on either side (the tangencies' transition).
  const double s_arc_begin = 0.04 - 0.002, s_arc_end = 0.04 + 0.5 * std::numbers::pi * radius_m + 0.002;
  const double before = largest_tip_curvature(machine, untouched.path, s_arc_begin, s_arc_end);
  const double after = largest_tip_curvature(machine, refined.path, s_arc_begin, s_arc_end);
  std::printf("fillet R %.0f mm: largest curvature %.4g 1/m untouched, %.4g 1/m with %zu points at 0.2 um\n",
              radius_m * 1e3, before, after, refined.refined_points);
  // Measured: 75 1/m untouched (the arc: 66.7), 107 with the points where the spline is, 235
  // with the points on the chords.
  EXPECT_LE(before, 1.25 / radius_m);  // the untouched spline follows the arc
  EXPECT_LE(after, 2.0 / radius_m);
}

TEST(PathFidelity, TheProgramsContourToleranceIsTheAllowanceOnItsSegmentsOnly) {
  const auto machine = kinematics::make_table_table_sample();
  const Vector3d centre = reachable_origin(machine);
  const double radius = 0.1;
  std::vector<kinematics::PathPose> poses;
  for (int k = 0; k <= 180; ++k) {
    const double phi = 2.0 * std::numbers::pi * k / 180.0;
    poses.push_back({{centre + radius * Vector3d(std::cos(phi), std::sin(phi), 0), Vector3d::UnitZ()}, k});
  }
  const Polyline programmed(poses);
  const auto path = solve(machine, poses);
  ASSERT_EQ(path.s_m.size(), poses.size());
  PathFidelityOptions options;
  options.tolerance_m = 5e-6;
  const RefinedPath tight = refine_path(machine, path, options);
  EXPECT_GT(tight.refined_points, 0u);  // the default alone: the spline is pulled onto the chords
  // G64 P0.025 on every motion: nothing to add.
  options.segment_tolerance_m.assign(poses.size(), 25e-6);
  const RefinedPath loose = refine_path(machine, path, options);
  EXPECT_EQ(loose.refined_points, 0u);
  EXPECT_GT(loose.deviation.tip_m, options.tolerance_m);  // the spline follows the circle, not the chords
  EXPECT_LE(loose.deviation.tip_m, 25e-6);
  EXPECT_TRUE(loose.unmet.empty()) << loose.unmet;
  // On the first half exact (0: the default applies), on the second half G64 P0.025.
  for (std::size_t i = 0; i <= 90; ++i) options.segment_tolerance_m[i] = 0.0;
  // (Where the allowance drops, the midpoints of the tight side kink the spline, and the kink
  // travels a segment per round along the loose side, each within its allowance but above the
  // refinement's 0.8 margin: a note in mixed.unmet, the open item of a smoother construction.)
  const RefinedPath mixed = refine_path(machine, path, options);
  const PathSpline spline(mixed.path);
  double worst_tight = 0.0, worst_loose = 0.0;
  Eigen::VectorXd q;
  for (std::size_t i = 0; i < spline.segment_count(); ++i) {
    const double h = spline.s_m()[i + 1] - spline.s_m()[i];
    const bool loose_segment = mixed.source_point[i + 1] > 90;
    for (int k = 0; k <= 40; ++k) {
      spline.evaluate(i, h * k / 40.0, &q, nullptr, nullptr, nullptr);
      const Vector3d tip = kinematics::forward_kinematics(machine, q, kToolLength_m).tip_W_m;
      const double d = programmed.distance(spline.s_m()[i] + h * k / 40.0, tip);
      (loose_segment ? worst_loose : worst_tight) = std::max(loose_segment ? worst_loose : worst_tight, d);
    }
  }
  std::printf("G1 circle: %zu points added without the contour tolerance, %zu with it on half; spline within "
              "%.3g um (default half), %.3g um (G64 P half)\n",
              tight.refined_points, mixed.refined_points, worst_tight * 1e6, worst_loose * 1e6);
  EXPECT_LE(worst_tight, options.tolerance_m);
  EXPECT_LE(worst_loose, 25e-6);
  EXPECT_GT(worst_loose, options.tolerance_m);  // the spline does follow the circle there
}

// A set point beyond the travel is an InfeasibleError naming the axis, the value, the travel
// and the block. A hand-made path (not refined) whose X runs to 400 mm (travel +-355 mm).
TEST(PathFidelity, SetPointBeyondTheTravelIsInfeasibleAndNamesAxisValueAndBlock) {
  const auto machine = kinematics::make_table_table_sample();
  auto f = [](double s, Eigen::VectorXd& q, Eigen::VectorXd& qs, Eigen::VectorXd& qss, Eigen::VectorXd& qsss) {
    q.setZero(); qs.setZero(); qss.setZero(); qsss.setZero();
    q(0) = s;
    qs(0) = 1.0;
    q(2) = -0.3;
  };
  auto path = test::sample_path(5, 0.4, 5, f);
  path.block = {0, 0, 1, 2, 3};
  path.block_names = {"a.nc:1", "a.nc:2", "a.nc:3", "a.nc:4 N40"};
  FeedrateOptions options;
  options.third_order = false;
  try {
    (void)plan_feedrate(machine, path, options);
    FAIL() << "no error";
  } catch (const InfeasibleError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("axis X"), std::string::npos) << what;
    EXPECT_NE(what.find("400 mm"), std::string::npos) << what;
    EXPECT_NE(what.find("[-355, 355] mm"), std::string::npos) << what;
    EXPECT_NE(what.find("a.nc:4 N40"), std::string::npos) << what;
  }
}

// ---------------------------------------------------------------------------------------------
// Property: random CAM-like paths.

struct RandomPath {
  std::vector<kinematics::PathPose> poses;
  bool rotary = false;
};

/// Lines and finely tessellated arcs, spacings from 10 um to 100 mm (ratios up to 1e4), joined
/// tangentially or turning by up to 4 degrees (below the 5 degree corner angle); with `rotary`
/// the tool axis tilts and turns about z along the path (A and C move).
RandomPath random_path(std::mt19937_64& rng, const Vector3d& origin, bool rotary) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  auto log_uniform = [&](double lo, double hi) { return lo * std::pow(hi / lo, unit(rng)); };
  RandomPath out;
  out.rotary = rotary;
  const double scale = rotary ? 0.3 : 1.0;  // shorter paths where the workpiece tilts
  Vector3d p = origin;
  double heading = 2.0 * std::numbers::pi * unit(rng);
  const double tilt0 = rotary ? 0.1 + 0.4 * unit(rng) : 0.0, tilt1 = rotary ? 0.1 + 0.4 * unit(rng) : 0.0;
  const double azimuth0 = 2.0 * std::numbers::pi * unit(rng), turn = rotary ? (unit(rng) - 0.5) * 2.0 : 0.0;
  std::vector<Vector3d> tips{p};
  const int pieces = 2 + static_cast<int>(unit(rng) * 3.0);
  int block = 0;
  std::vector<int> blocks{0};
  for (int piece = 0; piece < pieces && tips.size() < 60; ++piece, ++block) {
    if (piece > 0 && unit(rng) < 0.5) heading += (unit(rng) - 0.5) * 2.0 * 4.0 * std::numbers::pi / 180.0;
    if (unit(rng) < 0.45) {  // a line, one or a few segments
      const double length = scale * log_uniform(1e-4, 0.1);
      const int segments = unit(rng) < 0.7 ? 1 : 1 + static_cast<int>(unit(rng) * 4.0);
      const double dz = (unit(rng) < 0.3 ? (unit(rng) - 0.5) * 0.2 : 0.0) * length;
      for (int k = 1; k <= segments; ++k) {
        tips.push_back(p + k / double(segments) * Vector3d(length * std::cos(heading), length * std::sin(heading), dz));
        blocks.push_back(block);
      }
      p = tips.back();
    } else {  // an arc of radius 1-20 mm at chords 10-100 um, turning either way
      const double radius = log_uniform(1e-3, 2e-2);
      const double chord = log_uniform(1e-5, 1e-4);
      const int chords = 5 + static_cast<int>(unit(rng) * 30.0);
      const double side = unit(rng) < 0.5 ? 1.0 : -1.0;
      const double dphi = 2.0 * std::asin(0.5 * chord / radius);
      const double dz = unit(rng) < 0.3 ? (unit(rng) - 0.5) * chord : 0.0;  // a helix now and then
      const Vector3d centre = p + radius * Vector3d(-std::sin(heading), std::cos(heading), 0) * side;
      const double phi0 = std::atan2(p.y() - centre.y(), p.x() - centre.x());
      for (int k = 1; k <= chords; ++k) {
        const double phi = phi0 + side * dphi * k;
        tips.push_back(centre + radius * Vector3d(std::cos(phi), std::sin(phi), 0) + Vector3d(0, 0, dz * k));
        blocks.push_back(block);
      }
      heading += side * dphi * chords;
      p = tips.back();
    }
  }
  double length = 0.0;
  for (std::size_t i = 1; i < tips.size(); ++i) length += (tips[i] - tips[i - 1]).norm();
  double s = 0.0;
  for (std::size_t i = 0; i < tips.size(); ++i) {
    if (i > 0) s += (tips[i] - tips[i - 1]).norm();
    Vector3d axis = Vector3d::UnitZ();
    if (rotary) {
      const double f = length > 0.0 ? s / length : 0.0;
      const double tilt = tilt0 + (tilt1 - tilt0) * f, azimuth = azimuth0 + turn * f;
      axis = Vector3d(std::sin(tilt) * std::cos(azimuth), std::sin(tilt) * std::sin(azimuth), std::cos(tilt));
    }
    out.poses.push_back({{tips[i], axis}, blocks[i]});
  }
  return out;
}

TEST(PathFidelity, RandomCamPathsStayWithinTheToleranceAndTheTravel) {
  const auto machine = kinematics::make_table_table_sample();
  const Vector3d origin = reachable_origin(machine);
  std::mt19937_64 rng(20261202);
  PathFidelityOptions fidelity;
  fidelity.tolerance_m = 0.5e-6;  // the default, and on the rotary paths too (tighter than their default)
  fidelity.turning_tolerance_m = 0.5e-6;
  constexpr int kPaths = 10000, kPlanned = 300, kRotaryEvery = 20;
  double worst_spline = 0.0, worst_setpoints = 0.0, worst_axis = 0.0, worst_travel = 0.0;
  std::size_t points = 0, added = 0, planned = 0;
  double largest_ratio = 1.0;
  int worst_path = -1;
  for (int n = 0; n < kPaths; ++n) {
    const bool rotary = n % kRotaryEvery == 0;
    const RandomPath random = random_path(rng, origin, rotary);
    const Polyline programmed(random.poses);
    for (std::size_t i = 1; i + 1 < programmed.s_m.size(); ++i) {
      const double a = programmed.s_m[i] - programmed.s_m[i - 1], b = programmed.s_m[i + 1] - programmed.s_m[i];
      largest_ratio = std::max(largest_ratio, std::max(a / b, b / a));
    }
    const auto path = solve(machine, random.poses);
    points += path.s_m.size();
    if (n % (kPaths / kPlanned) == 0) {
      FeedrateOptions options;
      options.third_order = false;
      options.path_tolerance_m = fidelity.tolerance_m;
      options.turning_path_tolerance_m = fidelity.turning_tolerance_m;
      const FeedratePlan plan = plan_feedrate(machine, path, options);
      ++planned;
      added += plan.points_added;
      for (Eigen::Index k = 0; k < plan.setpoints.q.cols(); ++k) {
        const auto pose = kinematics::forward_kinematics(machine, plan.setpoints.q.col(k), kToolLength_m);
        const double d = programmed.distance(plan.setpoints.s_m[static_cast<std::size_t>(k)], pose.tip_W_m);
        if (d > worst_setpoints) worst_setpoints = d, worst_path = n;
      }
      worst_travel = std::max(worst_travel, travel_excess(machine, plan.setpoints.q));
      continue;
    }
    const RefinedPath refined = refine_path(machine, path, fidelity);
    added += refined.graded_points + refined.refined_points;
    const PathSpline spline(refined.path);
    Eigen::VectorXd q;
    Eigen::MatrixXd samples(static_cast<Eigen::Index>(machine.axis_count()), 1);
    constexpr int kSamples = 12;
    for (std::size_t i = 0; i < spline.segment_count(); ++i) {
      const double h = spline.s_m()[i + 1] - spline.s_m()[i];
      for (int k = 1; k < kSamples; ++k) {
        const double sigma = h * k / kSamples;
        spline.evaluate(i, sigma, &q, nullptr, nullptr, nullptr);
        const auto pose = kinematics::forward_kinematics(machine, q, kToolLength_m);
        const double d = programmed.distance(spline.s_m()[i] + sigma, pose.tip_W_m);
        if (d > worst_spline) worst_spline = d, worst_path = n;
        samples.col(0) = q;
        worst_travel = std::max(worst_travel, travel_excess(machine, samples));
      }
    }
    worst_axis = std::max(worst_axis, refined.deviation.axis_rad);
  }
  std::printf("%d random paths (%zu through the planner), %zu points, spacing ratios up to %.3g, %zu points added; "
              "largest tip distance: spline %.3g um, set points %.3g um (path %d); tool axis %.3g deg; travel "
              "excess %.3g\n",
              kPaths, planned, points, largest_ratio, added, worst_spline * 1e6, worst_setpoints * 1e6, worst_path,
              worst_axis * 180.0 / std::numbers::pi, worst_travel);
  EXPECT_LE(worst_spline, fidelity.tolerance_m);
  EXPECT_LE(worst_setpoints, fidelity.tolerance_m);
  EXPECT_LE(worst_axis, fidelity.axis_tolerance_rad);
  EXPECT_LE(worst_travel, 0.0);
  EXPECT_GT(largest_ratio, 1e3);
}

}  // namespace
}  // namespace vmsim::planner
