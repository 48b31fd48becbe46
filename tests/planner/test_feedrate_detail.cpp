// Internals of the feedrate planner against independent references: the closed-form motion the
// set points follow between grid points of the third-order profile (sdd linear in s) against a
// numerical integration of sigma'' = u0 + b sigma; first_exit (where a row's polynomial in sd
// first leaves +-L) against a fine scan.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "../../planner/src/feedrate_detail.hpp"

namespace vmsim::planner::detail {
namespace {

struct State {
  double sigma, speed;
};

/// Classical Runge-Kutta with a fixed step up to time `t`.
State integrate(const LinearAccelerationLaw& law, double t, int steps) {
  auto accel = [&](double sigma) { return law.u0 + law.b * sigma; };
  State y{0.0, law.v0};
  const double h = t / steps;
  for (int i = 0; i < steps; ++i) {
    const double k1s = y.speed, k1v = accel(y.sigma);
    const double k2s = y.speed + 0.5 * h * k1v, k2v = accel(y.sigma + 0.5 * h * k1s);
    const double k3s = y.speed + 0.5 * h * k2v, k3v = accel(y.sigma + 0.5 * h * k2s);
    const double k4s = y.speed + h * k3v, k4v = accel(y.sigma + h * k3s);
    y.sigma += h / 6.0 * (k1s + 2.0 * k2s + 2.0 * k3s + k4s);
    y.speed += h / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v);
  }
  return y;
}

TEST(LinearAccelerationLaw, MatchesANumericalIntegrationForEverySignOfTheSlope) {
  // b > 0 (cosh / sinh), b < 0 (cos / sin), b tiny (the series) and b = 0 (a parabola).
  for (const double b : {40.0, 3.0, 1e-3, 1e-9, 0.0, -1e-9, -1e-3, -3.0, -40.0}) {
    const LinearAccelerationLaw law{0.4, 1.5, b};
    for (const double t : {1e-4, 0.01, 0.05, 0.2}) {
      const State y = integrate(law, t, 4000);
      EXPECT_NEAR(law.position(t), y.sigma, 1e-13 + 1e-12 * y.sigma) << "b " << b << " t " << t;
      EXPECT_NEAR(law.speed(t), y.speed, 1e-12 * y.speed) << "b " << b << " t " << t;
    }
  }
  const LinearAccelerationLaw parabola{0.4, 1.5, 0.0};
  EXPECT_DOUBLE_EQ(parabola.position(0.2), 0.4 * 0.2 + 0.75 * 0.04);
}

TEST(LinearAccelerationLaw, DurationReachesTheSegmentEndAndAgreesWithTheQuadrature) {
  // x = v0^2 + 2 u0 sigma + b sigma^2; the duration is the integral of 1 / sqrt(x).
  const double delta = 0.03;
  for (const double b : {30.0, 1e-6, 0.0, -2.0, -30.0}) {
    const LinearAccelerationLaw law{0.5, 2.0, b};
    const auto t = law.duration(delta, 0.01);
    ASSERT_TRUE(t.has_value()) << "b " << b;
    EXPECT_NEAR(law.position(*t), delta, 1e-15);
    EXPECT_NEAR(*t, gauss_time(delta, 0.25, 2.0, b), 1e-9 * *t) << "b " << b;
    const double x1 = 0.25 + delta * (4.0 + b * delta);
    EXPECT_NEAR(law.speed(*t), std::sqrt(x1), 1e-12) << "b " << b;
  }
}

TEST(LinearAccelerationLaw, NoDurationWhereTheSpeedVanishesInsideTheSegment) {
  // Decelerating at 5 m/s^2 from 0.5 m/s stops after 25 mm: a 30 mm segment is never reached.
  EXPECT_FALSE(LinearAccelerationLaw({0.5, -5.0, 0.0}).duration(0.03, 0.1).has_value());
  // x = 0.25 - 6 sigma + b sigma^2 dips to 0.25 - 9 / b at sigma = 3 / b: above 0 with b = 40
  // (reached), below with b = 32 (at 94 mm, inside the 100 mm segment).
  EXPECT_TRUE(LinearAccelerationLaw({0.5, -3.0, 40.0}).duration(0.1, 0.2).has_value());
  EXPECT_FALSE(LinearAccelerationLaw({0.5, -3.0, 32.0}).duration(0.1, 0.2).has_value());
}

TEST(FirstExit, IsTheFirstLeavingOfTheBandForRandomPolynomials) {
  std::mt19937 random(7);
  std::uniform_real_distribution<double> coefficient(-3.0, 3.0);
  for (int n = 0; n < 3000; ++n) {
    const double L = 1.0;
    double p[4] = {0.9 * coefficient(random) / 3.0, coefficient(random), coefficient(random), coefficient(random)};
    if (n % 3 == 0) p[3] = 0.0;      // quadratics
    if (n % 9 == 0) p[2] = 0.0;      // and lines
    if (n % 27 == 0) p[1] = 0.0;
    auto f = [&](double s) { return p[0] + s * (p[1] + s * (p[2] + s * p[3])); };
    const double exit = first_exit(p[0], p[1], p[2], p[3], L);
    // Scan up to the exit (or far out): |f| <= L before it, and just after it |f| > L.
    const double end = std::isfinite(exit) ? exit : 100.0;
    for (int i = 0; i <= 2000; ++i) {
      const double s = end * i / 2000.0;
      ASSERT_LE(std::abs(f(s)), L * (1.0 + 1e-12)) << "n " << n << " s " << s << " exit " << exit;
    }
    if (std::isfinite(exit)) {
      const double after = exit * (1.0 + 1e-6) + 1e-12;
      EXPECT_GT(std::abs(f(after)), L * (1.0 - 1e-9)) << "n " << n << " exit " << exit;
      // On the band's edge, not merely near it (the root search's precision).
      EXPECT_LE(std::abs(f(exit)), L) << "n " << n;
      if (exit > 0.0) {
        EXPECT_NEAR(std::abs(f(exit)), L, 1e-12) << "n " << n << " exit " << exit;
      }
    }
  }
}

TEST(FirstExit, AtTheBoundAndLeavingAtOnceIsZero) {
  EXPECT_EQ(first_exit(1.0, 0.5, 0.0, 0.0, 1.0), 0.0);
  EXPECT_EQ(first_exit(-1.0, 0.0, -2.0, 0.0, 1.0), 0.0);
  EXPECT_EQ(first_exit(1.5, 0.0, 0.0, 0.0, 1.0), 0.0);
  // At the bound but going back inside: leaves at the other side, f = 1 - 2 s + s^2 / 2 = -1 at
  // s = 2 (a double root: touching -1 counts as leaving).
  EXPECT_NEAR(first_exit(1.0, -2.0, 0.5, 0.0, 1.0), 2.0, 1e-7);
  EXPECT_EQ(first_exit(0.5, 0.0, 0.0, 0.0, 1.0), kInf);
}

// A tiny leading coefficient (an axis that does not move: q_sss of 1e-308 from rounding in the
// spline) leaves where p3 s^3 reaches L, far out, not at 0: the quotient L / p3 overflowed to
// inf, the exit came out 0 and made a speed cap of 0 inside a stretch (posted programs found
// no third-order profile). Closed form: s = cbrt(L / |p3|), computed in long double.
TEST(FirstExit, ADenormalLeadingCoefficientLeavesFarOutNotAtOnce) {
  for (const double p3 : {-7.02044e-308, 7.02044e-308, 3e-320, -1e-300}) {
    const double expected = static_cast<double>(std::cbrt(50.0L / std::abs(static_cast<long double>(p3))));
    const double exit = first_exit(0.0, 0.0, 0.0, p3, 50.0);
    EXPECT_NEAR(exit / expected, 1.0, 1e-12) << "p3 " << p3 << " exit " << exit;
    // With a (tiny) quadratic term as well: the general branch's root bound must not overflow.
    const double general = first_exit(0.0, 0.0, 1e-300, p3, 50.0);
    EXPECT_GT(general, 1e100) << "p3 " << p3;
  }
}

}  // namespace
}  // namespace vmsim::planner::detail
