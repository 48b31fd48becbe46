#pragma once
// Internal to the planner: the planning problem on the grid shared by feedrate.cpp (grid, rows,
// second order, set points) and feedrate_third_order.cpp (jerk / torque-rate limits).
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <optional>
#include <utility>
#include <vector>

namespace vmsim::planner::detail {

inline constexpr double kInf = std::numeric_limits<double>::infinity();

/// |A u + B x + C + D sqrt(x) + E| <= L: acceleration (A = q_s, B = q_ss) or torque.
struct Row2 {
  double A = 0, B = 0, C = 0, D = 0, E = 0, L = 0;
  int axis = 0;
};
/// |P sddd + sqrt(x) (R u + S x + W) + V x + Z u| <= L: jerk (P = q_s, R = 3 q_ss, S = q_sss)
/// or torque rate (P = a, R = a_s + 2 b, S = b_s, W = c_s, V = d_s, Z = d).
struct Row3 {
  double P = 0, R = 0, S = 0, W = 0, V = 0, Z = 0, L = 0;
  int axis = 0;
};

inline double value2(const Row2& r, double x, double u) {
  return r.A * u + r.B * x + r.C + r.D * std::sqrt(std::max(x, 0.0)) + r.E;
}
inline double value3(const Row3& r, double x, double u, double sddd) {
  const double sd = std::sqrt(std::max(x, 0.0));
  return r.P * sddd + sd * (r.R * u + r.S * x + r.W) + r.V * x + r.Z * u;
}

struct Problem {
  std::size_t axes = 0;
  std::vector<double> s;         // grid points
  std::vector<std::size_t> seg;  // spline segment of each grid segment
  std::vector<double> sigma0;    // its start within the spline segment
  std::vector<bool> stop;        // exact stop at the point
  std::size_t n2 = 0, n3 = 0;    // rows per segment end
  // Second-order rows need q, q_s and q_ss only, which the spline has alike on both sides of a
  // grid point except at a stop (a corner): one set per point, and the incoming side of stops
  // apart (half the memory of a set per segment end: the passes stream it).
  std::vector<Row2> r2;          // (i * n2 + r): at grid point i (at a stop: its outgoing side)
  std::vector<Row2> r2_in;       // (j * n2 + r): the incoming side of the j-th stop
  std::vector<long> incoming;    // per point: its j in r2_in, or -1
  std::vector<Row2> r2mid;       // (k * n2 + r): at the middle of each segment (second order)
  std::vector<Row3> r3;
  std::vector<Row3> r3mid;       // (k * n3 + r): at the middle of each segment
  std::vector<double> cap_end;   // x cap at (2 k + end): velocity and feed
  std::vector<double> cap_pt;    // x cap at the points (min over the ends there; 0 at stops)
  std::vector<double> cap_mid;   // x cap at the middle of each segment: velocity and feed
  std::size_t segments() const { return s.size() - 1; }
  double delta(std::size_t k) const { return s[k + 1] - s[k]; }
  const Row2* rows2mid(std::size_t k) const { return r2mid.data() + k * n2; }
  const Row2* rows2(std::size_t k, int end) const {
    if (end == 0) return r2.data() + k * n2;
    const long j = incoming[k + 1];
    return j >= 0 ? r2_in.data() + static_cast<std::size_t>(j) * n2 : r2.data() + (k + 1) * n2;
  }
  const Row3* rows3mid(std::size_t k) const { return r3mid.data() + k * n3; }
  const Row3* rows3(std::size_t k, int end) const {
    return r3.data() + (2 * k + static_cast<std::size_t>(end)) * n3;
  }
};

/// Smallest sd > 0 at which |p0 + p1 sd + p2 sd^2 + p3 sd^3| reaches L (0 when |p0| > L already;
/// +inf when never).
double first_exit(double p0, double p1, double p2, double p3, double L);

/// The path acceleration and jerk a move can hold at rest (x = 0) under the rows of one point:
/// sdd_max from the second-order rows (|A u + C + E| <= L), sddd_max from the third-order
/// ones with that acceleration (|P sddd + Z u| <= L); +inf where no row bounds them.
struct RestLimits {
  double sdd_max = kInf, sddd_max = kInf;
  /// The distance [m] over which a start from rest at constant jerk sddd_max reaches sdd_max:
  /// s = sddd t^3 / 6 at t = sdd / sddd (0 when either is unbounded or zero).
  double ramp_distance_m() const;
};
RestLimits rest_limits(const Row2* rows2, std::size_t n2, const Row3* rows3, std::size_t n3);

/// Duration [s] of a grid segment of length delta on which x = x0 + 2 u0 s + up s^2.
double gauss_time(double delta, double x0, double u0, double up);

/// The motion along a grid segment on which the path acceleration is linear in the arc length,
/// sdd = u0 + b sigma (the third-order programme's law between its points): sigma'' = u0 + b
/// sigma from sigma = 0 at speed v0, in closed form (cosh / sinh for b > 0, cos / sin for b < 0,
/// their series near b = 0). The set points follow it, so that what is written is what the rows
/// of the programme constrain.
struct LinearAccelerationLaw {
  double v0 = 0.0, u0 = 0.0, b = 0.0;
  double position(double tau) const;  ///< sigma(tau) [m]
  double speed(double tau) const;     ///< sigma'(tau) [m/s]
  /// The time at which sigma reaches delta: std::nullopt when the speed vanishes before it
  /// (x = v0^2 + 2 u0 sigma + b sigma^2 reaches 0 inside the segment).
  std::optional<double> duration(double delta, double estimate) const;
};

/// The third-order profile of every stretch (rest to rest between stops) on the grid.
struct ThirdOrderProfile {
  std::vector<double> x, u;  ///< at the grid points
  std::vector<double> dt;    ///< per segment: exact duration of a constant-jerk segment, else -1
  int iterations = 0;        ///< linear programmes solved (all rounds)
};

/// Plans every stretch under x <= x_upper (the second-order time-optimal profile, 0 at stops);
/// see feedrate.hpp for the method. c1_upper (per grid segment): a bound on the middle
/// Bernstein coefficient c1 = x0 + h u0 that keeps x at the segment's middle under the x cap
/// there (see middle_c1_bounds). Returns false when no linear programme could be solved.
bool plan_third_order(const Problem& p, const std::vector<std::pair<std::size_t, std::size_t>>& stretches,
                      const std::vector<double>& x_upper, const std::vector<double>& c1_upper,
                      ThirdOrderProfile& out);

/// Per grid segment, the bound on c1 under which x at the middle, (x0 + 2 c1 + x1) / 4, stays
/// below cap_mid given x0 <= cap[k] and x1 <= cap[k + 1] (the scaled point caps): c1 <=
/// 2 cap_mid - (cap[k] + cap[k + 1]) / 2, at least 0 (x = u = 0 stays feasible). Where the cap
/// is concave between the points it is looser than the chord the programme already holds;
/// where it dips (a rotary axis turning fast in a singular zone) it keeps the set points' speed
/// under it between the points.
std::vector<double> middle_c1_bounds(const Problem& p, const std::vector<double>& cap,
                                     const std::vector<double>& slow);

}  // namespace vmsim::planner::detail
