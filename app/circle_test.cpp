// circle-test: the ISO 230-4 circular test, simulated and measured, explained by the drive model.
#include "circle_test.hpp"

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <functional>
#include <map>
#include <numbers>
#include <sstream>

#include "chain_inputs.hpp"
#include "circle_figures.hpp"
#include "json_text.hpp"
#include "vmsim/common/errors.hpp"
#include "vmsim/common/files.hpp"
#include "vmsim/common/output_folder.hpp"
#include "vmsim/common/trace.hpp"
#include "vmsim/kinematics/kinematics.hpp"
#include "vmsim/kinematics/machine_loader.hpp"
#include "vmsim/planner/feedrate.hpp"
#include "vmsim/servo/servo.hpp"
#include "vmsim/viz/display.hpp"
#include "vmsim/viz/plot.hpp"

namespace vmsim::app {
namespace {

using Json = nlohmann::json;
using circle::CircleFigures;
using circle::DataArc;
using circle::Direction;
using circle::PlanePath;

constexpr double kPi = std::numbers::pi;
constexpr double kDeg = kPi / 180.0;
constexpr std::array<Direction, 2> kDirections{Direction::ccw, Direction::cw};

double rounded(double value, double step) { return std::round(value / step) / std::round(1.0 / step) + 0.0; }  // no -0
double um(double metres, double step = 0.01) { return rounded(metres * 1e6, step); }
double mm_per_min(double m_per_s) { return rounded(m_per_s * 6e4, 0.1); }
std::string text_of(double value) { return format_double(value); }
std::string feed_label(double m_per_s) { return text_of(std::round(m_per_s * 6e4)); }

// The plane of two linear axes, with the nominal centre and the directions of the axes in W.
struct PlaneSetup {
  std::string name;  // "XY", "YZ", "ZX"
  int u = -1;        // machine axis index of the first axis
  int v = -1;
  Eigen::VectorXd q_centre;
  Eigen::Vector3d tip_centre_W = Eigen::Vector3d::Zero();
  Eigen::Vector3d e_u_W = Eigen::Vector3d::UnitX();
  Eigen::Vector3d e_v_W = Eigen::Vector3d::UnitY();
};

// The program of one test (both directions share it, mirrored).
struct ProgramSpec {
  double radius_m = 0.0;
  double lead_in_m = 0.0;
  double overrun_rad = 0.0;
  double data_start_rad = 22.5 * kDeg;  // off the reversals and off the diagonals
};

// The drive effects of the plane that the attribution switches off one at a time.
struct Effect {
  std::string name;    // "dry friction of X"
  std::string detail;  // the parameters, for the JSON
  std::function<void(kinematics::MachineModel&)> switch_off;
  /// Nonlinear (dry friction, backlash, cogging, pitch error): what departs from the linear
  /// loops, all switched off together for the attribution's reference.
  bool nonlinear = false;
};

// What a run gives: the tip in the plane, actual and commanded.
struct SimulatedRun {
  PlanePath actual;
  PlanePath commanded;
};

// The features the attribution explains, for one plane and feed (both directions).
struct Features {
  double radius_change_m = 0.0;  // mean of the two directions' LSC radius deviation
  double ellipse_m = 0.0;        // mean of the two directions' ellipse size
  double G_m = 0.0;              // mean of the two directions' G
  double H_m = 0.0;
  std::array<double, 2> spike_m{};  // per axis: mean |spike| over its reversals
  std::array<double, 2> step_m{};   // per axis: mean signed step over its reversals
};

Features features_of(const std::array<CircleFigures, 2>& figures, double hysteresis_m) {
  Features f;
  f.H_m = hysteresis_m;
  std::array<int, 2> count{};
  for (const CircleFigures& figure : figures) {
    f.radius_change_m += 0.5 * figure.mean_radius_deviation_m;
    f.ellipse_m += 0.5 * figure.ellipse_size_m;
    f.G_m += 0.5 * figure.circular_deviation_G_m;
    for (const circle::Reversal& reversal : figure.reversals) {
      if (!reversal.valid) continue;
      f.spike_m[static_cast<std::size_t>(reversal.axis)] += std::abs(reversal.spike_m);
      f.step_m[static_cast<std::size_t>(reversal.axis)] += reversal.step_m;
      ++count[static_cast<std::size_t>(reversal.axis)];
    }
  }
  for (std::size_t a = 0; a < 2; ++a) {
    if (count[a] > 0) f.spike_m[a] /= count[a], f.step_m[a] /= count[a];
  }
  return f;
}

const std::map<std::string, std::pair<std::string, std::string>>& plane_axes() {
  static const std::map<std::string, std::pair<std::string, std::string>> planes{
      {"XY", {"X", "Y"}}, {"YZ", {"Y", "Z"}}, {"ZX", {"Z", "X"}}};
  return planes;
}

std::vector<std::string> planes_asked(const std::string& plane) {
  std::string upper = plane;
  for (char& c : upper) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  if (upper == "ALL") return {"XY", "YZ", "ZX"};
  if (upper == "YX") upper = "XY";
  if (upper == "ZY") upper = "YZ";
  if (upper == "XZ") upper = "ZX";
  if (!plane_axes().count(upper)) {
    throw InputError("--plane '" + plane + "': not a plane of the circular test; one of XY, YZ, ZX, all");
  }
  return {upper};
}

// Position of a linear axis at the circle's centre: given, or the middle of its travel.
double centre_of(const kinematics::Axis& axis, const std::optional<std::vector<double>>& given, int xyz) {
  if (given) return (*given)[static_cast<std::size_t>(xyz)];
  if (axis.continuous || !(axis.travel_max > axis.travel_min)) return axis.home;
  return 0.5 * (axis.travel_min + axis.travel_max);
}

std::string mm_text(double m) { return text_of(rounded(m * 1e3, 0.001)); }

PlaneSetup make_plane(const kinematics::MachineModel& machine, const std::string& name,
                      const CircleTestOptions& options, double lead_in_m) {
  PlaneSetup plane;
  plane.name = name;
  const auto& [u_name, v_name] = plane_axes().at(name);
  plane.u = machine.axis_index(u_name);
  plane.v = machine.axis_index(v_name);
  for (const auto& [index, axis_name] : {std::pair{plane.u, u_name}, std::pair{plane.v, v_name}}) {
    if (index < 0 || machine.axes[static_cast<std::size_t>(index)].type != kinematics::AxisType::linear) {
      throw InputError(machine.source_file + ": plane " + name + " needs a linear axis named " + axis_name +
                       "; the machine has none (--plane chooses another plane)");
    }
  }
  plane.q_centre = machine.home_positions();
  const std::string xyz = "XYZ";
  for (int k = 0; k < 3; ++k) {
    const int index = machine.axis_index(std::string(1, xyz[static_cast<std::size_t>(k)]));
    if (index < 0 || machine.axes[static_cast<std::size_t>(index)].type != kinematics::AxisType::linear) continue;
    const kinematics::Axis& axis = machine.axes[static_cast<std::size_t>(index)];
    plane.q_centre(index) = centre_of(axis, options.centre_m, k);
    if (!axis.continuous && (plane.q_centre(index) < axis.travel_min - 1e-12 || plane.q_centre(index) > axis.travel_max + 1e-12)) {
      throw InputError(machine.source_file + ": axis " + axis.name + ", travel [" + mm_text(axis.travel_min) + ", " +
                       mm_text(axis.travel_max) + "] mm: --centre-mm puts " + axis.name + " at " +
                       mm_text(plane.q_centre(index)) + " mm, outside it");
    }
  }
  // The circle (and the lead-in inside it) within the travel of both axes.
  for (int index : {plane.u, plane.v}) {
    const kinematics::Axis& axis = machine.axes[static_cast<std::size_t>(index)];
    const double low = plane.q_centre(index) - options.radius_m;
    const double high = plane.q_centre(index) + options.radius_m;
    if (axis.continuous) continue;
    if (low < axis.travel_min - 1e-12 || high > axis.travel_max + 1e-12) {
      throw InputError(machine.source_file + ": axis " + axis.name + ", travel [" + mm_text(axis.travel_min) +
                       ", " + mm_text(axis.travel_max) + "] mm: the circle of --radius-mm " +
                       mm_text(options.radius_m) + " in plane " + name + " around " + axis.name + " = " +
                       mm_text(plane.q_centre(index)) + " mm needs " + axis.name + " from " + mm_text(low) +
                       " to " + mm_text(high) + " mm (a smaller --radius-mm, or --centre-mm)");
    }
  }
  (void)lead_in_m;
  const auto tip = [&](const Eigen::VectorXd& q) { return kinematics::forward_kinematics(machine, q, 0.0).tip_W_m; };
  plane.tip_centre_W = tip(plane.q_centre);
  const double step = 1e-3;
  Eigen::VectorXd q = plane.q_centre;
  q(plane.u) += step;
  plane.e_u_W = (tip(q) - plane.tip_centre_W) / step;
  q = plane.q_centre;
  q(plane.v) += step;
  plane.e_v_W = (tip(q) - plane.tip_centre_W) / step;
  if (std::abs(plane.e_u_W.norm() - 1.0) > 1e-6 || std::abs(plane.e_v_W.norm() - 1.0) > 1e-6 ||
      std::abs(plane.e_u_W.dot(plane.e_v_W)) > 1e-6) {
    throw InputError(machine.source_file + ": axes " + u_name + " and " + v_name +
                     " do not move the tool tip along two orthogonal directions at the circle's centre: "
                     "the circular test needs a Cartesian plane of two linear axes");
  }
  return plane;
}

// Overrun angle: the axes reach the feed and settle (5 / Kv) before the data arc; at least 45
// degrees, in whole degrees.
double overrun_rad(const kinematics::MachineModel& machine, const PlaneSetup& plane, double feed_m_per_s,
                   double radius_m) {
  double acceleration = 0.0, jerk = 0.0, kv = 0.0;
  for (int index : {plane.u, plane.v}) {
    const kinematics::Axis& axis = machine.axes[static_cast<std::size_t>(index)];
    const auto smallest = [](double current, double value) {
      return value > 0.0 ? (current > 0.0 ? std::min(current, value) : value) : current;
    };
    acceleration = smallest(acceleration, axis.limits.acceleration_max);
    jerk = smallest(jerk, axis.limits.jerk_max);
    kv = smallest(kv, axis.controller.position_gain_kv_per_s);
  }
  // The feed the axes can hold on the circle (centripetal acceleration v^2 / R, jerk v^3 / R^2
  // of each axis's sinusoid): the planner slows the circle to it.
  double v = feed_m_per_s;
  if (acceleration > 0.0) v = std::min(v, std::sqrt(acceleration * radius_m));
  if (jerk > 0.0) v = std::min(v, std::cbrt(jerk * radius_m * radius_m));
  double distance = 0.0;
  if (acceleration > 0.0) distance += v * v / (2.0 * acceleration);
  if (acceleration > 0.0 && jerk > 0.0) distance += v * acceleration / jerk;
  if (kv > 0.0) distance += 5.0 * v / kv;
  const double angle = std::max(45.0 * kDeg, 1.5 * distance / radius_m);
  return std::ceil(angle / kDeg) * kDeg;
}

// The circle program of one direction as a path with exact derivatives (the planner's quintic
// Hermite through them follows the circle to rounding): radial lead-in from R - lead_in to R,
// the arc (overrun, 360-degree data arc, overrun) every degree, radial lead-out.
kinematics::PathKinematics circle_path(const kinematics::MachineModel& machine, const PlaneSetup& plane,
                                       const ProgramSpec& spec, Direction direction) {
  const double sign = direction == Direction::ccw ? 1.0 : -1.0;
  const double r = spec.radius_m;
  const double start = spec.data_start_rad - sign * spec.overrun_rad;
  const double sweep = 2.0 * kPi + 2.0 * spec.overrun_rad;
  const int steps = static_cast<int>(std::ceil(sweep / kDeg - 1e-9));
  const double step = sweep / steps;
  const double end = start + sign * sweep;
  const auto axes = static_cast<Eigen::Index>(machine.axes.size());
  const auto n = static_cast<Eigen::Index>(steps + 3);
  kinematics::PathKinematics path;
  path.q = path.q_s = path.q_ss = path.q_sss = Eigen::MatrixXd::Zero(axes, n);
  for (Eigen::Index k = 0; k < n; ++k) path.q.col(k) = plane.q_centre;
  const auto set = [&](Eigen::Index k, double s, double radius, double angle, Eigen::Vector2d d1,
                       Eigen::Vector2d d2, Eigen::Vector2d d3, int block) {
    path.s_m.push_back(s);
    path.q(plane.u, k) += radius * std::cos(angle);
    path.q(plane.v, k) += radius * std::sin(angle);
    path.q_s(plane.u, k) = d1(0), path.q_s(plane.v, k) = d1(1);
    path.q_ss(plane.u, k) = d2(0), path.q_ss(plane.v, k) = d2(1);
    path.q_sss(plane.u, k) = d3(0), path.q_sss(plane.v, k) = d3(1);
    path.block.push_back(block);
  };
  const auto radial = [](double angle) { return Eigen::Vector2d(std::cos(angle), std::sin(angle)); };
  // On the arc, theta(s) = start + sign s / R: q' = sign (-sin, cos), q'' = -(cos, sin) / R,
  // q''' = sign (sin, -cos) / R^2.
  const auto arc_point = [&](Eigen::Index k, double s_on_arc, int block) {
    const double angle = start + sign * s_on_arc / r;
    set(k, spec.lead_in_m + s_on_arc, r, angle, sign * Eigen::Vector2d(-std::sin(angle), std::cos(angle)),
        -radial(angle) / r, sign * Eigen::Vector2d(std::sin(angle), -std::cos(angle)) / (r * r), block);
  };
  set(0, 0.0, r - spec.lead_in_m, start, radial(start), Eigen::Vector2d::Zero(), Eigen::Vector2d::Zero(), 0);
  arc_point(1, 0.0, 0);  // the corner: the outgoing (arc) derivatives
  for (int i = 1; i < steps; ++i) arc_point(i + 1, r * step * i, 1);
  // The arc's end, a corner: the outgoing (lead-out) derivatives.
  set(steps + 1, spec.lead_in_m + r * sweep, r, end, -radial(end), Eigen::Vector2d::Zero(),
      Eigen::Vector2d::Zero(), 1);
  set(steps + 2, 2.0 * spec.lead_in_m + r * sweep, r - spec.lead_in_m, end, -radial(end),
      Eigen::Vector2d::Zero(), Eigen::Vector2d::Zero(), 2);
  path.turns_in_place.assign(static_cast<std::size_t>(n), false);
  path.derivatives_fitted = false;
  path.corners.push_back({1, path.s_m[1], kPi / 2.0});
  path.corners.push_back({static_cast<std::size_t>(steps + 1), path.s_m[static_cast<std::size_t>(steps + 1)], kPi / 2.0});
  path.tool_length_m = 0.0;
  path.block_names = {"circle lead-in", "circle arc", "circle lead-out"};
  return path;
}

planner::FeedratePlan plan_circle(const kinematics::MachineModel& machine, const kinematics::PathKinematics& path,
                                  double feed_m_per_s, std::vector<std::string>& notes) {
  planner::FeedrateOptions options;
  options.feed_m_per_s = feed_m_per_s;
  try {
    return planner::plan_feedrate(machine, path, options);
  } catch (const InfeasibleError& error) {
    // As simulate-part: the third-order planner does not yet hold on every path.
    options.third_order = false;
    notes.push_back(std::string("jerk limits not applied (third-order planning failed: ") + error.what() + ")");
    return planner::plan_feedrate(machine, path, options);
  }
}

// Record period: at most 0.05 degrees of arc per sample, a whole multiple of every simulated
// axis's fastest loop, never longer than the interpolation period.
double record_period_s(const kinematics::MachineModel& machine, const PlaneSetup& plane, double angular_speed) {
  double base = 0.0;
  for (int index : {plane.u, plane.v}) {
    base = std::max(base, servo::base_period_s(machine.axes[static_cast<std::size_t>(index)].controller));
  }
  const double wanted = 0.05 * kDeg / angular_speed;
  const double multiple = std::max(1.0, std::floor(wanted / base + 1e-9));
  const double ipo_multiple = std::max(1.0, std::floor(machine.interpolation_period_s / base + 1e-9));
  return base * std::min(multiple, ipo_multiple);
}

// Tip in the plane relative to the nominal centre, from the axis positions q (SI).
void push_tip(const kinematics::MachineModel& machine, const PlaneSetup& plane, const Eigen::VectorXd& q,
              double t_s, PlanePath& path) {
  const Eigen::Vector3d d = kinematics::forward_kinematics(machine, q, 0.0).tip_W_m - plane.tip_centre_W;
  path.t_s.push_back(t_s);
  path.u_m.push_back(plane.e_u_W.dot(d));
  path.v_m.push_back(plane.e_v_W.dot(d));
}

SimulatedRun simulate_circle(const kinematics::MachineModel& machine, const PlaneSetup& plane,
                             const planner::SetPoints& setpoints, double record_s) {
  Trace input;
  input.add_column("t", setpoints.t_s);
  for (int index : {plane.u, plane.v}) {
    const kinematics::Axis& axis = machine.axes[static_cast<std::size_t>(index)];
    std::vector<double> column(setpoints.t_s.size());
    for (std::size_t k = 0; k < column.size(); ++k) {
      column[k] = to_trace_unit(axis, setpoints.q(index, static_cast<Eigen::Index>(k)));
    }
    input.add_column(axis.name + ".cmd", std::move(column));
  }
  servo::SimulationOptions options;
  options.record_period_s = record_s;
  const Trace output = servo::simulate_machine(machine, input, "circle-test set points", options);
  const auto& t = output.column("t");
  const auto actual_column = [&](int index) -> const std::vector<double>& {
    const std::string& name = machine.axes[static_cast<std::size_t>(index)].name;
    const auto load = output.column_index(name + ".pos2");  // the table, where it differs
    return load ? output.values[*load] : output.column(name + ".pos");
  };
  const auto& u_pos = actual_column(plane.u);
  const auto& v_pos = actual_column(plane.v);
  const auto& u_cmd = output.column(machine.axes[static_cast<std::size_t>(plane.u)].name + ".cmd");
  const auto& v_cmd = output.column(machine.axes[static_cast<std::size_t>(plane.v)].name + ".cmd");
  SimulatedRun run;
  Eigen::VectorXd q = plane.q_centre;
  for (std::size_t k = 0; k < t.size(); ++k) {
    q(plane.u) = u_pos[k] * 1e-3, q(plane.v) = v_pos[k] * 1e-3;
    push_tip(machine, plane, q, t[k], run.actual);
    q(plane.u) = u_cmd[k] * 1e-3, q(plane.v) = v_cmd[k] * 1e-3;
    push_tip(machine, plane, q, t[k], run.commanded);
  }
  return run;
}

// Mean lag of the actual tip behind the commanded one over the data arc [s].
double lag_s(const DataArc& arc, const SimulatedRun& run) {
  const double sign = arc.direction == Direction::ccw ? 1.0 : -1.0;
  double sum = 0.0;
  for (std::size_t i = 0; i < arc.t_s.size(); ++i) {
    const auto at = std::lower_bound(run.commanded.t_s.begin(), run.commanded.t_s.end(), arc.t_s[i]);
    const auto k = static_cast<std::size_t>(at - run.commanded.t_s.begin());
    const double commanded = std::atan2(run.commanded.v_m[k], run.commanded.u_m[k]);
    sum += std::remainder(commanded - arc.angle_rad[i], 2.0 * kPi) * sign;
  }
  return arc.t_s.empty() || !(arc.angular_speed_rad_per_s > 0.0)
             ? 0.0
             : sum / static_cast<double>(arc.t_s.size()) / arc.angular_speed_rad_per_s;
}

circle::FigureOptions figure_options(const kinematics::MachineModel& machine, const PlaneSetup& plane,
                                     double angular_speed) {
  double kv = 0.0;
  for (int index : {plane.u, plane.v}) {
    const double k = machine.axes[static_cast<std::size_t>(index)].controller.position_gain_kv_per_s;
    if (k > 0.0) kv = kv > 0.0 ? std::min(kv, k) : k;
  }
  circle::FigureOptions options;
  // A reversal's transient decays with the position loop: 4 / Kv of travel, 3 to 30 degrees.
  const double settle = kv > 0.0 ? angular_speed * 4.0 / kv : 5.0 * kDeg;
  options.settle_rad = std::clamp(settle, 3.0 * kDeg, 30.0 * kDeg);
  return options;
}

// ---- the drive effects of a plane --------------------------------------------------------------

std::vector<std::pair<std::string, double>> loop_signature(const kinematics::Axis& axis) {
  const kinematics::Controller& c = axis.controller;
  const double bandwidth = c.velocity_gain_N_m_s_per_rad / axis.drive.equivalent_inertia_kg_m2;
  return {{"Kv [1/s]", c.position_gain_kv_per_s},
          {"velocity-loop gain / J_eq [1/s]", bandwidth},
          {"velocity integral time [ms]", c.velocity_integral_time_s * 1e3},
          {"position period [ms]", c.position_period_s * 1e3},
          {"velocity period [us]", c.velocity_period_s * 1e6},
          {"position output delay [samples]", c.position_output_delay_samples},
          {"position output dead time [ms]", c.position_output_dead_time_s * 1e3},
          {"velocity output delay [samples]", c.velocity_output_delay_samples},
          {"velocity filter [ms]", c.velocity_filter_time_s * 1e3},
          {"velocity feedforward weight", c.velocity_feedforward ? c.velocity_feedforward_weight : 0.0},
          {"torque feedforward weight", c.torque_feedforward ? c.torque_feedforward_weight : 0.0},
          {"balancing time [ms]", c.balancing_type == kinematics::BalancingType::none ? 0.0 : c.balancing_time_s * 1e3},
          {"delay [ms]", c.delay_s * 1e3}};
}

std::vector<Effect> plane_effects(const kinematics::MachineModel& machine, const PlaneSetup& plane) {
  std::vector<Effect> effects;
  for (int index : {plane.u, plane.v}) {
    const auto i = static_cast<std::size_t>(index);
    const kinematics::Axis& axis = machine.axes[i];
    const kinematics::DriveEffects& e = axis.effects;
    const bool dry = axis.drive.friction_dry_A > 0.0 || e.stribeck.enabled ||
                     (e.asymmetric_friction.enabled &&
                      (e.asymmetric_friction.dry_positive_A > 0.0 || e.asymmetric_friction.dry_negative_A > 0.0));
    if (dry) {
      std::string detail = "b " + text_of(axis.drive.friction_dry_A) + " A";
      if (e.stribeck.enabled) detail += ", Stribeck static " + text_of(e.stribeck.static_friction_A) + " A";
      if (e.asymmetric_friction.enabled) {
        detail += ", asymmetric " + text_of(e.asymmetric_friction.dry_positive_A) + " / " +
                  text_of(e.asymmetric_friction.dry_negative_A) + " A";
      }
      effects.push_back({"dry friction of " + axis.name, detail, [i](kinematics::MachineModel& m) {
                           m.axes[i].drive.friction_dry_A = 0.0;
                           m.axes[i].effects.stribeck.enabled = false;
                           m.axes[i].effects.asymmetric_friction.dry_positive_A = 0.0;
                           m.axes[i].effects.asymmetric_friction.dry_negative_A = 0.0;
                         }, true});
    }
    const bool viscous = axis.drive.friction_viscous_A_per_joint_unit_per_s > 0.0 ||
                         (e.asymmetric_friction.enabled &&
                          (e.asymmetric_friction.viscous_positive_A_per_joint_unit_per_s > 0.0 ||
                           e.asymmetric_friction.viscous_negative_A_per_joint_unit_per_s > 0.0));
    if (viscous) {
      effects.push_back({"viscous friction of " + axis.name,
                         "a " + text_of(axis.drive.friction_viscous_A_per_joint_unit_per_s) + " A s/m",
                         [i](kinematics::MachineModel& m) {
                           m.axes[i].drive.friction_viscous_A_per_joint_unit_per_s = 0.0;
                           m.axes[i].effects.asymmetric_friction.viscous_positive_A_per_joint_unit_per_s = 0.0;
                           m.axes[i].effects.asymmetric_friction.viscous_negative_A_per_joint_unit_per_s = 0.0;
                         }});
    }
    if (e.backlash.enabled) {
      effects.push_back({"backlash of " + axis.name, "gap " + text_of(um(e.backlash.gap)) + " um",
                         [i](kinematics::MachineModel& m) { m.axes[i].effects.backlash.enabled = false; }, true});
    }
    if (e.cogging.enabled) {
      effects.push_back({"cogging of " + axis.name, text_of(e.cogging.amplitude_N_m) + " N m",
                         [i](kinematics::MachineModel& m) { m.axes[i].effects.cogging.enabled = false; }, true});
    }
    if (e.pitch_error.enabled) {
      effects.push_back({"pitch error of " + axis.name, text_of(um(e.pitch_error.amplitude)) + " um",
                         [i](kinematics::MachineModel& m) { m.axes[i].effects.pitch_error.enabled = false; }, true});
    }
    if (e.compliance.enabled) {
      effects.push_back({"compliance of " + axis.name, "k " + text_of(e.compliance.stiffness) + " N/m",
                         [i](kinematics::MachineModel& m) { m.axes[i].effects.compliance.enabled = false; }});
    }
  }
  // Servo mismatch: the second axis's loops made the first's (the velocity gain scaled by the
  // inertias, so that both velocity loops have the same bandwidth).
  const kinematics::Axis& first = machine.axes[static_cast<std::size_t>(plane.u)];
  const kinematics::Axis& second = machine.axes[static_cast<std::size_t>(plane.v)];
  const auto a = loop_signature(first), b = loop_signature(second);
  std::string differences;
  for (std::size_t k = 0; k < a.size(); ++k) {
    if (std::abs(a[k].second - b[k].second) > 1e-6 * std::max(1.0, std::abs(a[k].second))) {
      differences += (differences.empty() ? "" : ", ") + a[k].first + " " + text_of(rounded(b[k].second, 1e-4)) +
                     " vs " + text_of(rounded(a[k].second, 1e-4));
    }
  }
  if (!differences.empty()) {
    const auto u = static_cast<std::size_t>(plane.u), v = static_cast<std::size_t>(plane.v);
    effects.push_back({"servo mismatch of " + second.name + " against " + first.name, differences,
                       [u, v](kinematics::MachineModel& m) {
                         const kinematics::Controller& from = m.axes[u].controller;
                         kinematics::Controller& to = m.axes[v].controller;
                         const kinematics::Controller own = to;
                         to = from;
                         to.velocity_gain_N_m_s_per_rad = from.velocity_gain_N_m_s_per_rad *
                                                           m.axes[v].drive.equivalent_inertia_kg_m2 /
                                                           m.axes[u].drive.equivalent_inertia_kg_m2;
                         // The current loop, saturations and encoder stay the axis's own.
                         to.current_model = own.current_model;
                         to.current_bandwidth_hz = own.current_bandwidth_hz;
                         to.current_gain_V_per_A = own.current_gain_V_per_A;
                         to.current_integral_time_s = own.current_integral_time_s;
                         to.current_period_s = own.current_period_s;
                         to.current_output_delay_samples = own.current_output_delay_samples;
                         to.resistance_ohm = own.resistance_ohm;
                         to.inductance_H = own.inductance_H;
                         to.back_emf_V_s_per_rad = own.back_emf_V_s_per_rad;
                         to.voltage_max_V = own.voltage_max_V;
                         to.current_max_A = own.current_max_A;
                         to.velocity_max_rad_per_s = own.velocity_max_rad_per_s;
                         to.encoder_counts_per_rev = own.encoder_counts_per_rev;
                         to.position_feedback = own.position_feedback;
                         to.load_encoder_resolution = own.load_encoder_resolution;
                       }});
  }
  if (first.controller.velocity_feedforward || first.controller.torque_feedforward ||
      second.controller.velocity_feedforward || second.controller.torque_feedforward) {
    const auto u = static_cast<std::size_t>(plane.u), v = static_cast<std::size_t>(plane.v);
    effects.push_back({"feedforward of " + first.name + " and " + second.name,
                       "velocity / torque feedforward and balancing off", [u, v](kinematics::MachineModel& m) {
                         for (std::size_t i : {u, v}) {
                           m.axes[i].controller.velocity_feedforward = false;
                           m.axes[i].controller.torque_feedforward = false;
                           m.axes[i].controller.balancing_type = kinematics::BalancingType::none;
                         }
                       }});
  }
  return effects;
}

// ---- JSON and sentences --------------------------------------------------------------------

Json figures_json(const CircleFigures& f, const PlaneSetup& plane, const kinematics::MachineModel& machine,
                  double radius_m, std::optional<double> lag) {
  Json j;
  j["direction"] = circle::direction_name(f.direction);
  j["feed_mm_per_min"] = mm_per_min(f.angular_speed_rad_per_s * radius_m);
  j["circular_deviation_G_um"] = um(f.circular_deviation_G_m);
  j["mean_radius_deviation_um"] = um(f.mean_radius_deviation_m);
  j["lsc_centre_offset_um"] = {um(f.lsc_centre_u_m), um(f.lsc_centre_v_m)};
  j["ellipse"] = {{"size_um", um(f.ellipse_size_m)}, {"major_axis_deg", rounded(f.ellipse_major_axis_deg, 0.1)}};
  if (lag) j["lag_ms"] = rounded(*lag * 1e3, 0.001);
  j["lost_motion_fit_um"] = {{machine.axes[static_cast<std::size_t>(plane.u)].name, um(f.lost_motion_m[0])},
                             {machine.axes[static_cast<std::size_t>(plane.v)].name, um(f.lost_motion_m[1])}};
  Json reversals = Json::array();
  for (const circle::Reversal& r : f.reversals) {
    const int index = r.axis == 0 ? plane.u : plane.v;
    Json item{{"axis", machine.axes[static_cast<std::size_t>(index)].name},
              {"angle_deg", rounded(r.angle_rad / kDeg, 0.1)}};
    if (r.valid) {
      item["spike_um"] = um(r.spike_m);
      item["step_um"] = um(r.step_m);
    } else {
      item["spike_um"] = nullptr;
      item["step_um"] = nullptr;
    }
    reversals.push_back(item);
  }
  j["reversals"] = reversals;
  return j;
}

// One feature and what each effect makes of it.
struct Attribution {
  std::string feature;  // "reversal spikes of X"
  std::string where;    // "at 0 and 180 deg"
  double value_m = 0.0;
  std::vector<std::pair<const Effect*, double>> shares;  // effect, share [m]
  /// The feature with every nonlinear effect off at once (the linear loops alone): what
  /// the one-at-a-time shares leave to effects acting together (a largest-value feature such
  /// as H or G is not a sum of shares).
  double all_off_m = 0.0;
};

std::string sentence_of(const std::string& context, const Attribution& a) {
  std::ostringstream out;
  out << context << ": " << a.feature << " " << text_of(um(a.value_m)) << " um" << (a.where.empty() ? "" : " " + a.where);
  std::vector<std::pair<const Effect*, double>> shares = a.shares;
  std::sort(shares.begin(), shares.end(),
            [](const auto& x, const auto& y) { return std::abs(x.second) > std::abs(y.second); });
  const double threshold = std::max(0.01e-6, 0.05 * std::abs(a.value_m));
  std::string listed;
  double same_sign_sum = 0.0;  // of the listed shares that make the feature (not work against it)
  int same_sign_count = 0;
  for (const auto& [effect, share] : shares) {
    if (std::abs(share) < threshold) continue;
    if (share * a.value_m > 0.0) same_sign_sum += std::abs(share), ++same_sign_count;
    listed += (listed.empty() ? "" : ", ") + effect->name + " (" + (share > 0 ? "+" : "") + text_of(um(share)) + " um";
    // An effect that works against the feature: say what it would be without it.
    if (share * a.value_m < 0.0 || std::abs(share) > std::abs(a.value_m)) {
      listed += "; without it " + text_of(um(a.value_m - share)) + " um";
    }
    listed += ")";
  }
  if (listed.empty()) {
    out << ": no single effect of the drive model makes 5 % of it";
  } else {
    out << ": " << listed;
    // Shares that add up to far more than the feature: the effects make it together (backlash
    // steps at a reversal need the friction that holds the table on a flank).
    if (same_sign_count > 1 && same_sign_sum > 1.5 * std::abs(a.value_m)) {
      out << " (acting together: each one off removes most of it)";
    }
  }
  out << "; linear loops alone " << text_of(um(a.all_off_m)) << " um";
  return out.str();
}

// ---- measured trace ------------------------------------------------------------------------

struct MeasuredArcs {
  std::string plane;
  std::vector<DataArc> arcs;
  std::string columns;  // which columns were read, for the JSON
};

MeasuredArcs read_measured(const kinematics::MachineModel& machine, const CircleTestOptions& options,
                           const std::vector<std::string>& planes_given, double band_m) {
  TraceReadOptions read_options;
  read_options.known_axes.emplace();
  for (const auto& axis : machine.axes) read_options.known_axes->insert(axis.name);
  const Trace trace = read_trace(options.trace_path, read_options);
  // The position of each linear axis X, Y, Z: the load side (.pos2) where logged, else .pos.
  std::map<std::string, const std::vector<double>*> position;
  std::map<std::string, std::string> column_used;
  for (const std::string name : {"X", "Y", "Z"}) {
    for (const std::string signal : {".pos2", ".pos"}) {
      if (const auto index = trace.column_index(name + signal); index && !position.count(name)) {
        position[name] = &trace.values[*index];
        column_used[name] = name + signal;
      }
    }
  }
  const auto range = [](const std::vector<double>& v) {
    return v.empty() ? 0.0 : *std::max_element(v.begin(), v.end()) - *std::min_element(v.begin(), v.end());
  };
  // The plane: the two axes that move most.
  std::vector<std::pair<double, std::string>> moves;
  for (const auto& [name, values] : position) moves.emplace_back(range(*values), name);
  std::sort(moves.rbegin(), moves.rend());
  if (moves.size() < 2 || !(moves[1].first > 0.0)) {
    throw InputError(options.trace_path + ": a circle test needs the positions of two moving linear axes "
                     "(columns X.pos, Y.pos or Z.pos, or .pos2); found " + std::to_string(moves.size()));
  }
  std::string plane_name;
  for (const auto& [name, axes] : plane_axes()) {
    if ((axes.first == moves[0].second && axes.second == moves[1].second) ||
        (axes.first == moves[1].second && axes.second == moves[0].second)) {
      plane_name = name;
    }
  }
  if (!planes_given.empty() && std::find(planes_given.begin(), planes_given.end(), plane_name) == planes_given.end()) {
    throw InputError(options.trace_path + ": the trace's circle is in plane " + plane_name + " (axes " +
                     moves[0].second + " and " + moves[1].second + " move), not in --plane " + options.plane);
  }
  const PlaneSetup plane = make_plane(machine, plane_name, options, 0.0);
  const auto& t = trace.column("t");
  PlanePath path;
  Eigen::VectorXd q = plane.q_centre;
  for (std::size_t k = 0; k < t.size(); ++k) {
    for (const auto& [name, values] : position) q(machine.axis_index(name)) = (*values)[k] * 1e-3;
    push_tip(machine, plane, q, t[k], path);
  }
  MeasuredArcs measured;
  measured.plane = plane_name;
  measured.arcs = circle::find_data_arcs(path, options.radius_m, band_m);
  for (const auto& [name, column] : column_used) measured.columns += (measured.columns.empty() ? "" : ", ") + column;
  if (measured.arcs.empty()) {
    std::string centre;
    for (int index : {plane.u, plane.v}) {
      centre += (centre.empty() ? "" : ", ") + machine.axes[static_cast<std::size_t>(index)].name + " " +
                mm_text(plane.q_centre(index)) + " mm";
    }
    throw InputError(options.trace_path + ": no run sweeping 360 degrees within " + mm_text(band_m) +
                     " mm of the radius " + mm_text(options.radius_m) + " mm around " + centre + " (plane " +
                     plane_name + "; --radius-mm and --centre-mm must be those of the measured test)");
  }
  return measured;
}

// ---- one plane and feed ----------------------------------------------------------------------

struct DirectionResult {
  DataArc arc;
  CircleFigures figures;
  double lag_s = 0.0;
};

struct TestResult {
  std::array<DirectionResult, 2> simulated;
  double hysteresis_m = 0.0;
  Features features;
};

std::array<DirectionResult, 2> run_directions(const kinematics::MachineModel& machine, const PlaneSetup& plane,
                                              const ProgramSpec& spec,
                                              const std::array<planner::FeedratePlan, 2>& plans, double feed) {
  std::array<DirectionResult, 2> results;
  const double angular_speed = feed / spec.radius_m;
  for (std::size_t d = 0; d < 2; ++d) {
    const SimulatedRun run =
        simulate_circle(machine, plane, plans[d].setpoints, record_period_s(machine, plane, angular_speed));
    std::vector<DataArc> arcs = circle::find_data_arcs(run.actual, spec.radius_m, 0.5 * spec.lead_in_m);
    // One run, one data arc (the run sweeps 360 degrees plus the overruns).
    const auto found = std::find_if(arcs.begin(), arcs.end(),
                                    [&](const DataArc& arc) { return arc.direction == kDirections[d]; });
    if (found == arcs.end()) {
      throw InfeasibleError("circle-test: plane " + plane.name + ", " + feed_label(feed) + " mm/min " +
                            circle::direction_name(kDirections[d]) +
                            ": the simulated tip does not sweep 360 degrees within " + mm_text(0.5 * spec.lead_in_m) +
                            " mm of the circle (the drives cannot follow it)");
    }
    results[d].arc = std::move(*found);
    results[d].figures = circle::circle_figures(
        results[d].arc, spec.radius_m, figure_options(machine, plane, results[d].arc.angular_speed_rad_per_s));
    results[d].lag_s = lag_s(results[d].arc, run);
  }
  return results;
}

TestResult evaluate(const kinematics::MachineModel& machine, const PlaneSetup& plane, const ProgramSpec& spec,
                    const std::array<planner::FeedratePlan, 2>& plans, double feed) {
  TestResult result;
  result.simulated = run_directions(machine, plane, spec, plans, feed);
  result.hysteresis_m = circle::circular_hysteresis_m(result.simulated[0].arc, result.simulated[1].arc, spec.radius_m);
  result.features = features_of({result.simulated[0].figures, result.simulated[1].figures}, result.hysteresis_m);
  return result;
}

std::vector<Attribution> attribute(const kinematics::MachineModel& machine, const PlaneSetup& plane,
                                   const Features& all, const std::vector<Effect>& effects,
                                   const std::vector<Features>& without, const Features& all_off) {
  const std::string u = machine.axes[static_cast<std::size_t>(plane.u)].name;
  const std::string v = machine.axes[static_cast<std::size_t>(plane.v)].name;
  std::vector<Attribution> list;
  const auto add = [&](std::string feature, std::string where, double value, auto pick) {
    Attribution a;
    a.feature = std::move(feature);
    a.where = std::move(where);
    a.value_m = value;
    for (std::size_t k = 0; k < effects.size(); ++k) a.shares.emplace_back(&effects[k], value - pick(without[k]));
    a.all_off_m = pick(all_off);
    list.push_back(std::move(a));
  };
  add("reversal spikes of " + u, "at 0 and 180 deg (mean height)", all.spike_m[0], [](const Features& f) { return f.spike_m[0]; });
  add("reversal spikes of " + v, "at 90 and 270 deg (mean height)", all.spike_m[1], [](const Features& f) { return f.spike_m[1]; });
  add("backlash step of " + u, "at 0 and 180 deg (mean, outwards +)", all.step_m[0], [](const Features& f) { return f.step_m[0]; });
  add("backlash step of " + v, "at 90 and 270 deg (mean, outwards +)", all.step_m[1], [](const Features& f) { return f.step_m[1]; });
  add("servo-mismatch ellipse", "(major minus minor semi-axis, mean of CCW and CW)", all.ellipse_m, [](const Features& f) { return f.ellipse_m; });
  add("radius change (lag)", "(least-squares radius minus nominal, mean of CCW and CW)", all.radius_change_m,
      [](const Features& f) { return f.radius_change_m; });
  add("circular hysteresis H", "", all.H_m, [](const Features& f) { return f.H_m; });
  add("circular deviation G", "(mean of CCW and CW)", all.G_m, [](const Features& f) { return f.G_m; });
  return list;
}

// Radial deviation on a 0.5-degree grid.
std::vector<double> half_degree_grid() {
  std::vector<double> grid(720);
  for (std::size_t i = 0; i < grid.size(); ++i) grid[i] = static_cast<double>(i) * 0.5 * kDeg;
  return grid;
}

}  // namespace

Json run_circle_test(const CircleTestOptions& options, const ProgressSink& progress) {
  const auto started = std::chrono::steady_clock::now();
  // Options first: nothing is read or written for a bad one.
  const std::vector<std::string> planes_given = options.plane.empty() ? std::vector<std::string>{} : planes_asked(options.plane);
  if (!(options.radius_m > 0.0) || !std::isfinite(options.radius_m)) {
    throw InputError("--radius-mm " + mm_text(options.radius_m) + ": must be > 0");
  }
  std::vector<double> feeds = options.feeds_m_per_s.empty() ? std::vector<double>{500.0 / 6e4, 2000.0 / 6e4, 5000.0 / 6e4}
                                                            : options.feeds_m_per_s;
  for (double feed : feeds) {
    if (!(feed > 0.0) || !std::isfinite(feed)) {
      throw InputError("--feeds-mm-min: " + text_of(feed * 6e4) + " is not a feed (must be > 0)");
    }
  }
  if (options.centre_m && options.centre_m->size() != 3) {
    throw InputError("--centre-mm: give x,y,z (three values), not " + std::to_string(options.centre_m->size()));
  }
  kinematics::MachineModel machine = kinematics::load_machine(options.machine_path);
  ProgramSpec spec;
  spec.radius_m = options.radius_m;
  spec.lead_in_m = std::min(2e-3, 0.2 * options.radius_m);

  // The measured trace fixes the plane when --plane is not given.
  std::optional<MeasuredArcs> measured;
  if (!options.trace_path.empty()) {
    measured = read_measured(machine, options, planes_given, 0.5 * spec.lead_in_m);
  }
  std::vector<std::string> planes = planes_given;
  if (planes.empty()) planes = {measured ? measured->plane : std::string("XY")};
  std::vector<PlaneSetup> setups;
  for (const std::string& name : planes) setups.push_back(make_plane(machine, name, options, spec.lead_in_m));
  // A measured feed that is none of the requested ones is simulated too.
  if (measured) {
    for (const DataArc& arc : measured->arcs) {
      const double feed = arc.angular_speed_rad_per_s * options.radius_m;
      const bool known = std::any_of(feeds.begin(), feeds.end(), [&](double f) { return std::abs(f - feed) <= 0.03 * f; });
      if (!known) feeds.push_back(std::round(feed * 6e4) / 6e4);
    }
  }
  std::sort(feeds.begin(), feeds.end());
  feeds.erase(std::unique(feeds.begin(), feeds.end(), [](double a, double b) { return std::abs(a - b) < 1e-9; }), feeds.end());

  std::vector<std::string> inputs{options.machine_path};
  if (!options.trace_path.empty()) inputs.push_back(options.trace_path);
  OutputFolder output(options.out_dir, inputs, {"circle-test", VMSIM_VERSION});
  const std::filesystem::path folder = output.staging();

  std::string why_no_renders;
  const bool renders = options.renders && viz::display_available(why_no_renders);
  if (!options.renders) why_no_renders = "--no-renders";

  Json report;
  report["command_line"] = options.command_line;
  report["machine"] = std::filesystem::path(options.machine_path).filename().string();
  report["radius_mm"] = rounded(options.radius_m * 1e3, 1e-6);
  report["conventions"] =
      "angles from the plane's first axis towards its second (XY: X to Y, YZ: Y to Z, ZX: Z to X), CCW = growing "
      "angle; radial deviation = distance of the tool tip (spindle gauge point) from the nominal centre minus the "
      "nominal radius, positive outwards; G about the least-squares circle's centre (ISO 230-4), H and the CSV about "
      "the nominal centre; an effect's share = the feature with every effect minus the feature with that effect off; "
      "'linear loops alone' = the feature with every nonlinear effect (dry friction, backlash, cogging, pitch error) off";
  Json tests = Json::array();
  std::vector<std::string> explanations;
  std::vector<std::string> warnings;  // printed by the command as warnings
  for (const std::string& warning : machine.warnings) warnings.push_back(warning);
  std::ostringstream csv;
  csv << "plane,source,direction,feed_mm_per_min,angle_deg,radial_deviation_um\n";
  const std::vector<double> grid = half_degree_grid();
  const auto csv_rows = [&](const std::string& plane, const std::string& source, const DataArc& arc, double feed) {
    const std::vector<double> deviation = circle::deviation_on_grid(arc, options.radius_m, grid);
    for (std::size_t i = 0; i < grid.size(); ++i) {
      csv << plane << ',' << source << ',' << circle::direction_name(arc.direction) << ',' << feed_label(feed) << ','
          << text_of(rounded(grid[i] / kDeg, 0.01)) << ',' << text_of(um(deviation[i], 0.001)) << '\n';
    }
  };

  for (const PlaneSetup& plane : setups) {
    const std::string u = machine.axes[static_cast<std::size_t>(plane.u)].name;
    const std::string v = machine.axes[static_cast<std::size_t>(plane.v)].name;
    const std::vector<Effect> effects = options.attribute ? plane_effects(machine, plane) : std::vector<Effect>{};
    for (double feed : feeds) {
      const std::string context = plane.name + " at " + feed_label(feed) + " mm/min";
      progress(context + ": plan and simulate ...");
      ProgramSpec test_spec = spec;
      test_spec.overrun_rad = overrun_rad(machine, plane, feed, options.radius_m);
      std::vector<std::string> notes;
      std::array<planner::FeedratePlan, 2> plans;
      for (std::size_t d = 0; d < 2; ++d) {
        plans[d] = plan_circle(machine, circle_path(machine, plane, test_spec, kDirections[d]), feed, notes);
      }
      const TestResult result = evaluate(machine, plane, test_spec, plans, feed);
      Json test;
      test["plane"] = plane.name;
      test["axes"] = {u, v};
      test["feed_mm_per_min"] = mm_per_min(feed);
      Json centre;
      for (int index : {plane.u, plane.v}) {
        centre[machine.axes[static_cast<std::size_t>(index)].name] = rounded(plane.q_centre(index) * 1e3, 1e-6);
      }
      test["program"] = {{"centre_mm", centre},
                         {"lead_in_mm", rounded(test_spec.lead_in_m * 1e3, 1e-6)},
                         {"overrun_deg", rounded(test_spec.overrun_rad / kDeg, 0.01)},
                         {"data_arc_start_deg", rounded(test_spec.data_start_rad / kDeg, 0.01)},
                         {"duration_s", {rounded(plans[0].duration_s, 0.001), rounded(plans[1].duration_s, 0.001)}}};
      if (!notes.empty()) {
        test["program"]["notes"] = notes;
        warnings.push_back(context + ": " + notes.front());
      }
      Json simulated;
      for (std::size_t d = 0; d < 2; ++d) {
        const DirectionResult& r = result.simulated[d];
        simulated[circle::direction_name(kDirections[d])] = figures_json(r.figures, plane, machine, options.radius_m, r.lag_s);
        csv_rows(plane.name, "simulated", r.arc, feed);
      }
      simulated["circular_hysteresis_H_um"] = um(result.hysteresis_m);
      const double arc_feed = result.simulated[0].arc.angular_speed_rad_per_s * options.radius_m;
      if (arc_feed < 0.98 * feed) {
        const std::string note = context + ": the planned circle runs at " + feed_label(arc_feed) +
                                 " mm/min, below the feed: the axes' acceleration or jerk limits (v^2 / R, v^3 / R^2) "
                                 "do not allow more on R " + mm_text(options.radius_m) + " mm";
        test["program"]["notes"].push_back(note);
        warnings.push_back(note);
      }
      test["simulated"] = simulated;
      std::string line = "  " + context + ": H " + text_of(um(result.hysteresis_m)) + " um";
      for (std::size_t d = 0; d < 2; ++d) {
        const CircleFigures& f = result.simulated[d].figures;
        line += "; " + circle::direction_name(kDirections[d]) + " G " + text_of(um(f.circular_deviation_G_m)) +
                " um, radius " + text_of(um(f.mean_radius_deviation_m)) + " um, ellipse " +
                text_of(um(f.ellipse_size_m)) + " um at " + text_of(rounded(f.ellipse_major_axis_deg, 1.0)) + " deg";
      }
      progress(line);

      // Measured arcs of this plane and feed.
      std::array<const DataArc*, 2> measured_arc{nullptr, nullptr};
      if (measured && measured->plane == plane.name) {
        for (const DataArc& arc : measured->arcs) {
          const double measured_feed = arc.angular_speed_rad_per_s * options.radius_m;
          if (std::abs(measured_feed - feed) > 0.03 * feed) continue;
          const std::size_t d = arc.direction == Direction::ccw ? 0 : 1;
          if (!measured_arc[d]) measured_arc[d] = &arc;
        }
        Json measured_json;
        for (std::size_t d = 0; d < 2; ++d) {
          if (!measured_arc[d]) continue;
          const CircleFigures f = circle::circle_figures(
              *measured_arc[d], options.radius_m,
              figure_options(machine, plane, measured_arc[d]->angular_speed_rad_per_s));
          measured_json[circle::direction_name(kDirections[d])] = figures_json(f, plane, machine, options.radius_m, std::nullopt);
          csv_rows(plane.name, "measured", *measured_arc[d], feed);
        }
        if (measured_arc[0] && measured_arc[1]) {
          measured_json["circular_hysteresis_H_um"] =
              um(circle::circular_hysteresis_m(*measured_arc[0], *measured_arc[1], options.radius_m));
        }
        if (!measured_json.is_null()) {
          measured_json["trace"] = std::filesystem::path(options.trace_path).filename().string();
          measured_json["columns"] = measured->columns;
          test["measured"] = measured_json;
        }
      }

      // Attribution: every effect off in turn, the same set points.
      if (!effects.empty()) {
        std::vector<Features> without;
        for (const Effect& effect : effects) {
          kinematics::MachineModel variant = machine;
          effect.switch_off(variant);
          without.push_back(evaluate(variant, plane, test_spec, plans, feed).features);
        }
        kinematics::MachineModel linear = machine;
        for (const Effect& effect : effects) {
          if (effect.nonlinear) effect.switch_off(linear);
        }
        const Features all_off = evaluate(linear, plane, test_spec, plans, feed).features;
        Json attribution = Json::array();
        for (const Attribution& a : attribute(machine, plane, result.features, effects, without, all_off)) {
          Json item{{"feature", a.feature}, {"where", a.where}, {"value_um", um(a.value_m)},
                    {"linear_loops_alone_um", um(a.all_off_m)}};
          Json shares = Json::array();
          for (const auto& [effect, share] : a.shares) {
            shares.push_back({{"effect", effect->name}, {"parameters", effect->detail}, {"share_um", um(share)}});
          }
          item["shares"] = shares;
          item["sentence"] = sentence_of(context, a);
          // Features of a size worth explaining get a sentence in the summary.
          if (std::abs(a.value_m) >= 0.05e-6) explanations.push_back(item["sentence"]);
          attribution.push_back(item);
        }
        test["attribution"] = attribution;
        Json effect_list = Json::array();
        for (const Effect& effect : effects) effect_list.push_back({{"effect", effect.name}, {"parameters", effect.detail}});
        test["effects_switched"] = effect_list;
      }

      // The polar plot.
      const std::string png = "polar_" + plane.name + "_F" + feed_label(feed) + ".png";
      if (renders) {
        viz::PolarDeviationPlotInput plot;
        plot.title = "Circular test " + plane.name + ", R " + mm_text(options.radius_m) + " mm, F " + feed_label(feed) +
                     " mm/min";
        plot.u_name = u;
        plot.v_name = v;
        plot.nominal_radius_m = options.radius_m;
        const std::array<viz::Rgb, 2> simulated_colour{viz::Rgb{0.1, 0.3, 0.85}, viz::Rgb{0.85, 0.15, 0.1}};
        const std::array<viz::Rgb, 2> measured_colour{viz::Rgb{0.0, 0.55, 0.25}, viz::Rgb{0.9, 0.55, 0.0}};
        for (std::size_t d = 0; d < 2; ++d) {
          const DataArc& arc = result.simulated[d].arc;
          plot.curves.push_back({"simulated " + circle::direction_name(kDirections[d]), grid,
                                 circle::deviation_on_grid(arc, options.radius_m, grid), viz::LineStyle::solid,
                                 simulated_colour[d]});
        }
        for (std::size_t d = 0; d < 2; ++d) {
          if (!measured_arc[d]) continue;
          plot.curves.push_back({"measured " + circle::direction_name(kDirections[d]), grid,
                                 circle::deviation_on_grid(*measured_arc[d], options.radius_m, grid),
                                 viz::LineStyle::dashed, measured_colour[d]});
        }
        viz::plot_polar_deviation((folder / png).string(), plot);
        test["plot"] = png;
      } else {
        test["plot"] = nullptr;
      }
      tests.push_back(test);
    }
  }
  if (measured) {
    // Measured arcs whose plane was not simulated cannot happen (the plane is the trace's); a
    // measured arc never matched to a feed would be a bug in the feed list above.
    report["measured_trace"] = {{"file", std::filesystem::path(options.trace_path).filename().string()},
                                {"plane", measured->plane},
                                {"data_arcs", measured->arcs.size()},
                                {"columns", measured->columns}};
  }
  report["tests"] = tests;
  report["explanations"] = explanations;
  report["warnings"] = warnings;
  if (!renders) report["renders_skipped"] = why_no_renders;
  report["run_time_s"] = rounded(std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count(), 0.01);
  write_file_atomically((folder / "circle_deviation.csv").string(), csv.str());
  write_file_atomically((folder / "circle_test.json").string(), json_file_text(report));
  output.commit();
  return report;
}

}  // namespace vmsim::app
