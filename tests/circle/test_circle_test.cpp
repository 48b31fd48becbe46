// vmsim circle-test against closed forms and an independent simulation written here.
//
// - The steady radius reduction of two equal linear cascades is R (1 - |G(j w)|), w = v / R, with
//   G the position loop's closed-loop response evaluated here from the machine file's gains (a
//   continuous model of the loops with their sampling as half-period delays).
// - Two axes with different Kv draw an ellipse whose size and orientation follow from G_X and
//   G_Y (computed here from the ellipse the two responses trace, not from the program's fit).
// - Dry friction on one axis makes spikes at that axis's reversals only; backlash a step there;
//   the attribution names the effect.
// - A measured trace made by a first-order simulation written here: the figures recover its
//   closed-form ellipse.
// - Bad input: exit 3, located message, nothing written.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdlib>
#include <complex>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <sstream>
#include <string>

#include "../app/cli_runner.hpp"

namespace vmsim::test {
namespace {

using Json = nlohmann::json;
constexpr double kPi = std::numbers::pi;

// ---- the test machine ----------------------------------------------------------------------

struct AxisSpec {
  double kv_per_s = 20.0;
  double dry_friction_A = 0.0;
  double viscous_A_s_per_m = 1.0;
  double backlash_um = 0.0;
  /// P velocity loop of this bandwidth [Hz] instead of the PI at 100 Hz (0: the PI).
  double p_velocity_loop_hz = 0.0;
};

// Drive values shared by all axes (the closed form below reads the same numbers).
constexpr double kLead_m = 0.010;
constexpr double kInertia = 1.0e-3;       // J_eq [kg m^2]
constexpr double kRotorInertia = 5.0e-4;  // motor side, for backlash
constexpr double kTorqueConstant = 1.0;   // N m / A
constexpr double kVelocityGain = 2.0 * kPi * 100.0 * kInertia;  // velocity loop about 100 Hz
constexpr double kIntegralTime_s = 0.005;
constexpr double kPeriod_s = 125e-6;  // position and velocity loops

std::string axis_yaml(const std::string& name, const std::string& travel, const AxisSpec& spec) {
  std::ostringstream out;
  out << "  - name: " << name << "\n    type: linear\n    travel_mm: " << travel << "\n    home_mm: 0\n"
      << "    limits: {velocity_m_per_min: 20, acceleration_m_per_s2: 2, jerk_m_per_s3: 50}\n"
      << "    drive:\n      screw_lead_mm: " << kLead_m * 1e3 << "\n      equivalent_inertia_kg_m2: " << kInertia
      << "\n      rotor_inertia_kg_m2: " << kRotorInertia << "\n      torque_constant_N_m_per_A: " << kTorqueConstant
      << "\n      friction_viscous_A_s_per_m: " << spec.viscous_A_s_per_m
      << "\n      friction_dry_A: " << spec.dry_friction_A
      << "\n      torque_max_N_m: 50\n      torque_rate_max_N_m_per_s: 5000\n"
      << "    controller:\n"
      << "      position: {kv_per_s: " << spec.kv_per_s << ", period_us: 125, output_delay_samples: 0}\n"
      << (spec.p_velocity_loop_hz > 0.0
              ? "      velocity: {type: P, gain_N_m_s_per_rad: " + std::to_string(2.0 * kPi * spec.p_velocity_loop_hz * kInertia) +
                    ", period_us: 125, output_delay_samples: 0}\n"
              : "      velocity: {type: PI, gain_N_m_s_per_rad: " + std::to_string(kVelocityGain) +
                    ", integral_time_ms: " + std::to_string(kIntegralTime_s * 1e3) +
                    ", period_us: 125, output_delay_samples: 0}\n")
      << "      current: {model: ideal}\n"
      << "      saturation: {current_A: 100, motor_speed_rev_per_min: 6000}\n";
  if (spec.backlash_um > 0.0) out << "    effects:\n      backlash: {gap_um: " << spec.backlash_um << "}\n";
  return out.str();
}

std::string write_machine(const std::filesystem::path& folder, const AxisSpec& x, const AxisSpec& y) {
  std::ostringstream out;
  out << "name: circle test machine\nkind: machine_tool\ninterpolation_period_ms: 1\n"
      << "gravity_m_per_s2: [0, 0, -9.81]\naxes:\n"
      << axis_yaml("X", "[-200, 200]", x) << axis_yaml("Y", "[-200, 200]", y)
      << axis_yaml("Z", "[-300, 0]", AxisSpec{})
      << "structure:\n  workpiece_chain:\n    - fixed: workpiece\n  tool_chain:\n"
      << "    - joint: X\n      direction: [1, 0, 0]\n      body: {mass_kg: 10, com_mm: [0, 0, 0], inertia_kg_m2: {ixx: 0.1, iyy: 0.1, izz: 0.1}}\n"
      << "    - joint: Y\n      direction: [0, 1, 0]\n      body: {mass_kg: 10, com_mm: [0, 0, 0], inertia_kg_m2: {ixx: 0.1, iyy: 0.1, izz: 0.1}}\n"
      << "    - joint: Z\n      direction: [0, 0, 1]\n      body: {mass_kg: 10, com_mm: [0, 0, 0], inertia_kg_m2: {ixx: 0.1, iyy: 0.1, izz: 0.1}}\n"
      << "    - fixed: spindle\n      origin_mm: [0, 0, 300]\n";
  const std::filesystem::path path = folder / "machine.yaml";
  std::ofstream(path) << out.str();
  return path.string();
}

Json read_json(const std::filesystem::path& path) {
  std::ifstream in(path);
  return Json::parse(in);
}

const Json& test_at(const Json& report, const std::string& plane, double feed_mm_per_min) {
  for (const Json& test : report["tests"]) {
    if (test["plane"] == plane && std::abs(test["feed_mm_per_min"].get<double>() - feed_mm_per_min) < 0.5) return test;
  }
  throw std::runtime_error("no test " + plane + " at " + std::to_string(feed_mm_per_min));
}

// ---- the closed form -----------------------------------------------------------------------

// Closed-loop response q / q_cmd of one axis: position P loop (Kv) around a PI velocity loop on
// the drive inertia with viscous friction; the loops' sampling as delays (a zero-order hold:
// half a period forward; the velocity differenced over one period: half a period in feedback).
std::complex<double> position_response(double kv_per_s, double viscous_A_s_per_m, double w_rad_per_s,
                                       double p_velocity_loop_hz = 0.0) {
  const std::complex<double> s(0.0, w_rad_per_s);
  const double ratio = kLead_m / (2.0 * kPi);  // m per motor rad
  const double damping = kTorqueConstant * viscous_A_s_per_m * ratio;  // N m per motor rad/s
  const auto delay = [&](double time_s) { return std::exp(-s * time_s); };
  // The gains as written into the machine file (std::to_string: 6 decimals).
  const double gain = std::stod(std::to_string(p_velocity_loop_hz > 0.0 ? 2.0 * kPi * p_velocity_loop_hz * kInertia : kVelocityGain));
  const std::complex<double> controller =
      p_velocity_loop_hz > 0.0 ? std::complex<double>(gain) : gain * (1.0 + 1.0 / (s * kIntegralTime_s));
  const std::complex<double> plant = 1.0 / (kInertia * s + damping);
  const std::complex<double> forward = controller * delay(0.5 * kPeriod_s) * plant;
  const std::complex<double> velocity_loop = forward / (1.0 + forward * delay(0.5 * kPeriod_s));
  const std::complex<double> open = kv_per_s * delay(0.5 * kPeriod_s) * velocity_loop / s;
  return open / (1.0 + open);
}

// The ellipse two responses draw: command (R cos wt, +-R sin wt), actual (R |G_u| cos(wt - p_u),
// +-R |G_v| sin(wt - p_v)); the radial deviation against the actual angle, its second harmonic
// by a sum over one period (weighted by the angle each sample covers).
struct Ellipse {
  double size_m = 0.0;
  double major_axis_deg = 0.0;
  double mean_radius_deviation_m = 0.0;
};

Ellipse closed_form_ellipse(std::complex<double> g_u, std::complex<double> g_v, double radius_m, bool ccw) {
  const int n = 20000;
  std::vector<double> angle(n), deviation(n);
  for (int k = 0; k < n; ++k) {
    const double wt = 2.0 * kPi * k / n;
    const double u = radius_m * std::abs(g_u) * std::cos(wt + std::arg(g_u));
    const double v = (ccw ? 1.0 : -1.0) * radius_m * std::abs(g_v) * std::sin(wt + std::arg(g_v));
    angle[static_cast<std::size_t>(k)] = std::atan2(v, u);
    deviation[static_cast<std::size_t>(k)] = std::hypot(u, v) - radius_m;
  }
  double a0 = 0.0, a2 = 0.0, b2 = 0.0, total = 0.0;
  for (int k = 0; k < n; ++k) {
    const auto i = static_cast<std::size_t>(k);
    const double next = angle[static_cast<std::size_t>((k + 1) % n)];
    const double previous = angle[static_cast<std::size_t>((k + n - 1) % n)];
    const double weight = std::abs(std::remainder(next - previous, 2.0 * kPi)) / 2.0;
    a0 += weight * deviation[i];
    a2 += weight * deviation[i] * std::cos(2.0 * angle[i]);
    b2 += weight * deviation[i] * std::sin(2.0 * angle[i]);
    total += weight;
  }
  Ellipse e;
  e.mean_radius_deviation_m = a0 / total;
  a2 *= 2.0 / total, b2 *= 2.0 / total;
  e.size_m = 2.0 * std::hypot(a2, b2);
  e.major_axis_deg = std::fmod(0.5 * std::atan2(b2, a2) * 180.0 / kPi + 180.0, 180.0);
  return e;
}

double axis_difference_deg(double a, double b) {
  const double d = std::fmod(std::abs(a - b), 180.0);
  return std::min(d, 180.0 - d);
}

// ---- tests -----------------------------------------------------------------------------------

TEST(CircleTest, RadiusReductionOfTheLinearCascadeIsOneMinusTheClosedLoopMagnitude) {
  const auto folder = fresh_folder("circle_radius");
  // A P velocity loop at 40 Hz with viscous friction: its lag is a visible part of the radius
  // reduction (a PI loop's is of second order: it would go unseen).
  AxisSpec axis;
  axis.p_velocity_loop_hz = 40.0;
  axis.viscous_A_s_per_m = 5.0;
  const std::string machine = write_machine(folder, axis, axis);
  const auto out = folder / "out";
  const RunResult run = run_vmsim_with_env("env -u DISPLAY", "circle-test --machine " + machine + " --out " + out.string() +
                                           " --radius-mm 50 --feeds-mm-min 2000,4000 --no-attribution");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const Json report = read_json(out / "circle_test.json");
  for (double feed_mm_per_min : {2000.0, 4000.0}) {
    const double radius = 0.05;
    const double w = feed_mm_per_min / 6e4 / radius;
    const double expected = radius * (std::abs(position_response(20.0, 5.0, w, 40.0)) - 1.0);
    // Without the velocity loop (Kv / (s + Kv)) the reduction would differ by several percent:
    // the comparison resolves it.
    const double first_order = radius * (20.0 / std::hypot(20.0, w) - 1.0);
    ASSERT_GT(std::abs(expected - first_order), 0.1 * std::abs(expected)) << expected << " " << first_order;
    for (const char* direction : {"CCW", "CW"}) {
      const Json& f = test_at(report, "XY", feed_mm_per_min)["simulated"][direction];
      const double simulated = f["mean_radius_deviation_um"].get<double>() * 1e-6;
      EXPECT_NEAR(simulated, expected, 0.01 * std::abs(expected) + 0.02e-6)
          << direction << " at " << feed_mm_per_min << " mm/min; closed form " << expected * 1e6 << " um";
      // Equal axes: a circle, no ellipse, no spikes.
      EXPECT_LT(f["ellipse"]["size_um"].get<double>(), 0.05) << direction;
      EXPECT_LT(f["circular_deviation_G_um"].get<double>(), 0.1) << direction;
    }
  }
  // The CSV: 720 angles per curve, 2 feeds x 2 directions.
  std::ifstream csv(out / "circle_deviation.csv");
  int rows = 0;
  for (std::string line; std::getline(csv, line);) ++rows;
  EXPECT_EQ(rows, 1 + 2 * 2 * 720);
}

TEST(CircleTest, DifferentPositionGainsGiveTheClosedFormEllipse) {
  const auto folder = fresh_folder("circle_ellipse");
  AxisSpec x, y;
  x.kv_per_s = 20.0;
  y.kv_per_s = 30.0;
  const std::string machine = write_machine(folder, x, y);
  const auto out = folder / "out";
  const RunResult run = run_vmsim_with_env("env -u DISPLAY", "circle-test --machine " + machine + " --out " + out.string() +
                                           " --radius-mm 50 --feeds-mm-min 2000");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const Json report = read_json(out / "circle_test.json");
  const Json& test = test_at(report, "XY", 2000.0);
  const double radius = 0.05, w = 2000.0 / 6e4 / radius;
  const auto g_x = position_response(20.0, 1.0, w), g_y = position_response(30.0, 1.0, w);
  for (const bool ccw : {true, false}) {
    const Ellipse expected = closed_form_ellipse(g_x, g_y, radius, ccw);
    // X lags more: the first-order closed form puts the major axis at 45 deg going CCW, 135 CW.
    EXPECT_LT(axis_difference_deg(expected.major_axis_deg, ccw ? 45.0 : 135.0), 3.0);
    const Json& f = test["simulated"][ccw ? "CCW" : "CW"];
    EXPECT_NEAR(f["ellipse"]["size_um"].get<double>() * 1e-6, expected.size_m, 0.02 * expected.size_m)
        << (ccw ? "CCW" : "CW") << " closed form " << expected.size_m * 1e6 << " um";
    EXPECT_LT(axis_difference_deg(f["ellipse"]["major_axis_deg"].get<double>(), expected.major_axis_deg), 1.0)
        << "closed form " << expected.major_axis_deg << " deg";
  }
  // The attribution names the servo mismatch for the ellipse.
  bool named = false;
  for (const Json& item : test["attribution"]) {
    if (item["feature"] != "servo-mismatch ellipse") continue;
    double largest = 0.0;
    std::string effect;
    for (const Json& share : item["shares"]) {
      if (std::abs(share["share_um"].get<double>()) > std::abs(largest)) {
        largest = share["share_um"].get<double>();
        effect = share["effect"];
      }
    }
    EXPECT_EQ(effect, "servo mismatch of Y against X") << item["sentence"];
    EXPECT_GT(largest, 0.9 * item["value_um"].get<double>()) << item["sentence"];
    named = true;
  }
  EXPECT_TRUE(named);
}

// The effect with the largest share of a feature, and that share [um].
std::pair<std::string, double> main_cause(const Json& test, const std::string& feature) {
  for (const Json& item : test["attribution"]) {
    if (item["feature"] != feature) continue;
    std::pair<std::string, double> best{"", 0.0};
    for (const Json& share : item["shares"]) {
      if (std::abs(share["share_um"].get<double>()) > std::abs(best.second)) best = {share["effect"], share["share_um"]};
    }
    return best;
  }
  return {"(feature not found)", 0.0};
}

double reversal_value(const Json& figures, double angle_deg, const char* key) {
  for (const Json& r : figures["reversals"]) {
    if (std::abs(r["angle_deg"].get<double>() - angle_deg) < 0.01) return r[key].get<double>();
  }
  return std::nan("");
}

TEST(CircleTest, DryFrictionOfXMakesSpikesAtXReversalsOnly) {
  const auto folder = fresh_folder("circle_friction");
  AxisSpec x;
  x.dry_friction_A = 2.0;
  const std::string machine = write_machine(folder, x, AxisSpec{});
  const auto out = folder / "out";
  const RunResult run = run_vmsim_with_env("env -u DISPLAY", "circle-test --machine " + machine + " --out " + out.string() +
                                           " --radius-mm 50 --feeds-mm-min 1000");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const Json report = read_json(out / "circle_test.json");
  const Json& test = test_at(report, "XY", 1000.0);
  for (const char* direction : {"CCW", "CW"}) {
    const Json& f = test["simulated"][direction];
    // X reverses at 0 and 180 deg (X = R cos t has its extremes there); the spike points outwards.
    for (double angle : {0.0, 180.0}) EXPECT_GT(reversal_value(f, angle, "spike_um"), 1.0) << direction << angle;
    const double x_spike = std::min(reversal_value(f, 0.0, "spike_um"), reversal_value(f, 180.0, "spike_um"));
    for (double angle : {90.0, 270.0}) {
      EXPECT_LT(std::abs(reversal_value(f, angle, "spike_um")), 0.1 * x_spike) << direction << angle;
    }
  }
  const auto [effect, share] = main_cause(test, "reversal spikes of X");
  EXPECT_EQ(effect, "dry friction of X");
  double value = 0.0;
  for (const Json& item : test["attribution"]) if (item["feature"] == "reversal spikes of X") value = item["value_um"];
  EXPECT_GT(share, 0.8 * value);
  EXPECT_NE(run.output.find("reversal spikes of X"), std::string::npos) << run.output;
}

TEST(CircleTest, BacklashOfYMakesAStepAtYReversals) {
  const auto folder = fresh_folder("circle_backlash");
  // Friction on the table (far above the force that accelerates it on the circle) keeps the
  // table on one flank until Y reverses: the gap is crossed at the reversal, as on a machine.
  AxisSpec y;
  y.backlash_um = 10.0;
  y.dry_friction_A = 0.5;
  const std::string machine = write_machine(folder, AxisSpec{}, y);
  const auto out = folder / "out";
  const RunResult run = run_vmsim_with_env("env -u DISPLAY", "circle-test --machine " + machine + " --out " + out.string() +
                                           " --radius-mm 50 --feeds-mm-min 1000");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const Json report = read_json(out / "circle_test.json");
  const Json& test = test_at(report, "XY", 1000.0);
  for (const char* direction : {"CCW", "CW"}) {
    const Json& f = test["simulated"][direction];
    // After Y reverses, the table lags by the gap on the other flank: the path steps out by
    // about the gap at 90 and 270 deg, not at X's reversals.
    for (double angle : {90.0, 270.0}) EXPECT_NEAR(reversal_value(f, angle, "step_um"), 10.0, 2.5) << direction << angle;
    for (double angle : {0.0, 180.0}) EXPECT_LT(std::abs(reversal_value(f, angle, "step_um")), 1.0) << direction << angle;
    // Fitted over the whole arc: the lost motion of Y, and no ellipse made of the steps.
    EXPECT_NEAR(f["lost_motion_fit_um"]["Y"].get<double>(), 10.0, 2.5) << direction;
    EXPECT_LT(std::abs(f["lost_motion_fit_um"]["X"].get<double>()), 1.0) << direction;
  }
  // Backlash and the friction that holds the table on a flank make the step together: each
  // one off removes most of it.
  for (const Json& item : test["attribution"]) {
    if (item["feature"] != "backlash step of Y") continue;
    for (const Json& share : item["shares"]) {
      if (share["effect"] == "backlash of Y") {
        EXPECT_GT(share["share_um"].get<double>(), 0.8 * item["value_um"].get<double>());
      }
      if (share["effect"] == "viscous friction of X") {
        EXPECT_LT(std::abs(share["share_um"].get<double>()), 0.5);
      }
    }
    EXPECT_NE(item["sentence"].get<std::string>().find("backlash of Y"), std::string::npos);
  }
  // The gap crossing (between the two levels) is no inward spike; the table's impact on the
  // flank may overshoot outwards.
  const Json& ccw = test["simulated"]["CCW"];
  EXPECT_GT(reversal_value(ccw, 90.0, "spike_um"), -0.5);
}

// A measured trace from a simulation written here: each axis a first-order lag x' = Kv (x_c - x)
// (solved exactly for a command linear between samples), CCW then CW, with a radial lead-in,
// 90-degree overruns and a lead-out; sampled at 1 ms.
void append_run(std::ostream& out, double& t, double kv_x, double kv_y, double radius, double feed, bool ccw) {
  const double dt = 1e-3, w = feed / radius, sign = ccw ? 1.0 : -1.0;
  const double start = (22.5 - sign * 90.0) * kPi / 180.0;
  const double sweep = 2.0 * kPi + kPi;  // 360 + 2 x 90 deg
  const double lead = 0.002, lead_time = lead / feed;
  const auto command = [&](double time) -> std::pair<double, double> {
    double r = radius, angle = start;
    if (time < lead_time) {
      r = radius - lead + feed * time;
    } else if (time < lead_time + sweep / w) {
      angle = start + sign * w * (time - lead_time);
    } else {
      angle = start + sign * sweep;
      r = std::max(radius - lead, radius - feed * (time - lead_time - sweep / w));
    }
    return {r * std::cos(angle), r * std::sin(angle)};
  };
  auto [x, y] = command(0.0);
  const double duration = 2.0 * lead_time + sweep / w + 0.5;
  auto previous = command(0.0);
  for (double local = 0.0; local <= duration; local += dt) {
    const auto now = command(local);
    // Exact response over one step of x' = k (c - x) with c linear from previous to now.
    const auto step = [&](double state, double c0, double c1, double k) {
      const double e = std::exp(-k * dt), slope = (c1 - c0) / dt;
      return c1 - slope / k + (state - c0 + slope / k) * e;
    };
    if (local > 0.0) {
      x = step(x, previous.first, now.first, kv_x);
      y = step(y, previous.second, now.second, kv_y);
    }
    previous = now;
    out << t << ',' << now.first * 1e3 << ',' << x * 1e3 << ',' << now.second * 1e3 << ',' << y * 1e3 << '\n';
    t += dt;
  }
}

TEST(CircleTest, MeasuredTraceFiguresRecoverAKnownEllipse) {
  const auto folder = fresh_folder("circle_measured");
  const std::string machine = write_machine(folder, AxisSpec{}, AxisSpec{});
  const double radius = 0.05, feed = 2000.0 / 6e4, kv_x = 15.0, kv_y = 25.0;
  {
    std::ofstream trace(folder / "measured.csv");
    trace << "# source: first-order axes written in the test\nt,X.cmd,X.pos,Y.cmd,Y.pos\n";
    trace.precision(12);
    double t = 0.0;
    append_run(trace, t, kv_x, kv_y, radius, feed, true);
    append_run(trace, t, kv_x, kv_y, radius, feed, false);
  }
  const auto out = folder / "out";
  const RunResult run = run_vmsim_with_env(
      "env -u DISPLAY", "circle-test --machine " + machine + " --out " + out.string() + " --radius-mm 50 --trace " +
                            (folder / "measured.csv").string() + " --feeds-mm-min 2000 --no-attribution");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const Json report = read_json(out / "circle_test.json");
  const Json& test = test_at(report, "XY", 2000.0);
  ASSERT_TRUE(test.contains("measured")) << test.dump();
  const double w = feed / radius;
  const std::complex<double> g_x = kv_x / std::complex<double>(kv_x, w), g_y = kv_y / std::complex<double>(kv_y, w);
  for (const bool ccw : {true, false}) {
    const Ellipse expected = closed_form_ellipse(g_x, g_y, radius, ccw);
    const Json& f = test["measured"][ccw ? "CCW" : "CW"];
    EXPECT_NEAR(f["ellipse"]["size_um"].get<double>() * 1e-6, expected.size_m, 0.01 * expected.size_m);
    EXPECT_LT(axis_difference_deg(f["ellipse"]["major_axis_deg"].get<double>(), expected.major_axis_deg), 0.5);
    EXPECT_NEAR(f["mean_radius_deviation_um"].get<double>() * 1e-6, expected.mean_radius_deviation_m,
                0.01 * std::abs(expected.mean_radius_deviation_m));
    EXPECT_NEAR(f["feed_mm_per_min"].get<double>(), 2000.0, 2.0);
  }
  // Measured rows in the CSV beside the simulated ones.
  std::ifstream csv(out / "circle_deviation.csv");
  int measured_rows = 0;
  for (std::string line; std::getline(csv, line);) measured_rows += line.find(",measured,") != std::string::npos;
  EXPECT_EQ(measured_rows, 2 * 720);
}

// Under a display (ctest runs it once more under xvfb-run): the polar plot is a PNG.
TEST(CircleTest, PolarPlotIsAPngUnderADisplay) {
  if (!std::getenv("DISPLAY")) GTEST_SKIP() << "no display (ctest runs this under xvfb-run)";
  const auto folder = fresh_folder("circle_png");
  const std::string machine = write_machine(folder, AxisSpec{}, AxisSpec{});
  const auto out = folder / "out";
  const RunResult run = run_vmsim("circle-test --machine " + machine + " --out " + out.string() +
                                  " --radius-mm 50 --feeds-mm-min 3000 --no-attribution");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  std::ifstream png(out / "polar_XY_F3000.png", std::ios::binary);
  std::string magic(8, '\0');
  png.read(magic.data(), 8);
  EXPECT_EQ(magic, std::string("\x89PNG\r\n\x1a\n", 8));
  EXPECT_EQ(read_json(out / "circle_test.json")["tests"][0]["plot"], "polar_XY_F3000.png");
}

TEST(CircleTest, BadInputIsLocatedAndWritesNothing) {
  const auto folder = fresh_folder("circle_bad");
  const std::string machine = write_machine(folder, AxisSpec{}, AxisSpec{});
  const auto out = folder / "out";
  RunResult run = run_vmsim("circle-test --machine " + machine + " --out " + out.string() + " --plane XQ");
  EXPECT_EQ(run.exit_code, 3) << run.output;
  EXPECT_NE(run.output.find("--plane 'XQ'"), std::string::npos) << run.output;
  EXPECT_FALSE(std::filesystem::exists(out));
  run = run_vmsim("circle-test --machine " + machine + " --out " + out.string() + " --radius-mm 250");
  EXPECT_EQ(run.exit_code, 3) << run.output;
  EXPECT_NE(run.output.find("machine.yaml: axis X, travel [-200, 200] mm"), std::string::npos) << run.output;
  EXPECT_NE(run.output.find("--radius-mm 250"), std::string::npos) << run.output;
  EXPECT_FALSE(std::filesystem::exists(out));
  // Nothing beside it either (no staging folder left).
  std::size_t entries = 0;
  for ([[maybe_unused]] const auto& entry : std::filesystem::directory_iterator(folder)) ++entries;
  EXPECT_EQ(entries, 1u);  // machine.yaml
}

}  // namespace
}  // namespace vmsim::test
