// The circle figures (app/circle_figures.hpp) on paths whose figures are known in closed form.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "circle_figures.hpp"

namespace vmsim::app::circle {
namespace {

constexpr double kPi = std::numbers::pi;

// A CCW or CW run: lead-in, 450 degrees at a uniform angular speed (45 degrees of overrun each
// side of the data arc starting at 0), lead-out; the tip at the actual angle t has the radius
// R + deviation(t, direction) about the nominal centre shifted by (cu, cv).
template <typename Deviation>
PlanePath run(double radius, double cu, double cv, bool ccw, Deviation deviation) {
  PlanePath path;
  const double sign = ccw ? 1.0 : -1.0;
  double t = 0.0;
  const auto push = [&](double r, double angle) {
    path.t_s.push_back(t);
    path.u_m.push_back(cu + r * std::cos(angle));
    path.v_m.push_back(cv + r * std::sin(angle));
    t += 1e-3;
  };
  const double start = -sign * kPi / 4.0;
  for (int k = 0; k <= 20; ++k) push(radius - 2e-3 + k * 1e-4, start);
  const int n = 9000;  // 0.05 deg a sample
  for (int k = 0; k <= n; ++k) {
    const double angle = start + sign * 2.5 * kPi * k / n;
    push(radius + deviation(angle), angle);
  }
  return path;
}

TEST(CircleFigures, LeastSquaresCircleEllipseAndGOfAKnownCurve) {
  const double radius = 0.1, a2 = 3e-6, b2 = -4e-6, change = -2e-6;
  // The path about a centre offset by (5, -3) um: its polar angle about the nominal centre
  // differs slightly, so the deviation is given about the offset centre and the figures must
  // find that centre.
  const auto shape = [&](double t) { return change + a2 * std::cos(2 * t) + b2 * std::sin(2 * t); };
  for (const bool ccw : {true, false}) {
    const std::vector<DataArc> arcs = find_data_arcs(run(radius, 5e-6, -3e-6, ccw, shape), radius, 1e-3);
    ASSERT_EQ(arcs.size(), 1u);
    EXPECT_EQ(arcs[0].direction, ccw ? Direction::ccw : Direction::cw);
    // 360 degrees of the 450: the middle.
    // 450 deg in 9 s (the angle about the nominal centre differs by the offset / R: 5e-5).
    EXPECT_NEAR(arcs[0].angular_speed_rad_per_s, 2.5 * kPi / 9.0, 1e-7);
    const CircleFigures f = circle_figures(arcs[0], radius);
    EXPECT_NEAR(f.lsc_centre_u_m, 5e-6, 1e-9);
    EXPECT_NEAR(f.lsc_centre_v_m, -3e-6, 1e-9);
    EXPECT_NEAR(f.mean_radius_deviation_m, change, 1e-9);
    EXPECT_NEAR(f.ellipse_size_m, 2.0 * std::hypot(a2, b2), 1e-9);
    // a2 cos 2t + b2 sin 2t is largest at t = atan2(b2, a2) / 2 (mod 180 deg).
    EXPECT_NEAR(f.ellipse_major_axis_deg, std::fmod(0.5 * std::atan2(b2, a2) * 180 / kPi + 180, 180), 0.01);
    // G: the range of the harmonic, 2 sqrt(a2^2 + b2^2).
    EXPECT_NEAR(f.circular_deviation_G_m, 2.0 * std::hypot(a2, b2), 2e-9);
  }
}

TEST(CircleFigures, BacklashStepAndReversalSpikeOfKnownSize) {
  const double radius = 0.05, gap = 8e-6, spike = 3e-6;
  // The u axis lags by half the gap against its motion: while u decreases (CCW: 0 < t < pi) the
  // table is gap / 2 further out along +u, while it increases gap / 2 back; radially that is
  // +-gap / 2 cos t. After each u reversal a spike decays over 2 degrees of travel.
  for (const bool ccw : {true, false}) {
    const double sign = ccw ? 1.0 : -1.0;
    const auto shape = [&](double t) {
      const double u_lag = (std::sin(t) * sign > 0.0 ? 0.5 : -0.5) * gap;
      double d = u_lag * std::cos(t);
      for (double reversal : {0.0, kPi}) {
        const double travelled = std::remainder(t - reversal, 2 * kPi) * sign;
        if (travelled > 0.0 && travelled < 2.0 * kPi / 180.0) d += spike * std::sin(travelled / (2.0 * kPi / 180.0) * kPi);
      }
      return d;
    };
    const std::vector<DataArc> arcs = find_data_arcs(run(radius, 0.0, 0.0, ccw, shape), radius, 1e-3);
    ASSERT_EQ(arcs.size(), 1u);
    const CircleFigures f = circle_figures(arcs[0], radius);
    // The lost motion fitted over the whole arc (the spikes leak a little into it), and no
    // ellipse left by the steps' second harmonic.
    EXPECT_NEAR(f.lost_motion_m[0], gap, 0.05 * gap);
    EXPECT_NEAR(f.lost_motion_m[1], 0.0, 0.02 * gap);
    EXPECT_LT(f.ellipse_size_m, 0.05 * gap);
    ASSERT_EQ(f.reversals.size(), 4u);
    for (const Reversal& r : f.reversals) {
      ASSERT_TRUE(r.valid);
      if (r.axis == 0) {
        // The step: from -gap / 2 to +gap / 2 at both u reversals (outwards); the lines are
        // fitted to gap / 2 cos t over 10 degrees: curvature of 1 - cos(11 deg) ~ 2 %.
        EXPECT_NEAR(r.step_m, gap, 0.03 * gap) << r.angle_rad;
        EXPECT_NEAR(r.spike_m, spike, 0.05 * spike) << r.angle_rad;
      } else {
        EXPECT_NEAR(r.step_m, 0.0, 0.02 * gap) << r.angle_rad;
        EXPECT_NEAR(r.spike_m, 0.0, 0.02 * spike) << r.angle_rad;
      }
    }
  }
}

TEST(CircleFigures, HysteresisIsTheLargestDifferenceBetweenTheDirections) {
  const double radius = 0.05;
  const auto ccw_shape = [](double t) { return 1e-6 * std::cos(2 * t); };
  const auto cw_shape = [](double t) { return -1e-6 * std::cos(2 * t) + 0.5e-6; };
  const DataArc ccw = find_data_arcs(run(radius, 0, 0, true, ccw_shape), radius, 1e-3).at(0);
  const DataArc cw = find_data_arcs(run(radius, 0, 0, false, cw_shape), radius, 1e-3).at(0);
  // |2 cos 2t - 0.5| um is largest at cos 2t = -1: 2.5 um.
  EXPECT_NEAR(circular_hysteresis_m(ccw, cw, radius), 2.5e-6, 1e-9);
}

}  // namespace
}  // namespace vmsim::app::circle
