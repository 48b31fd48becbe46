// Feedrate interpolation (see feedrate.hpp for the method and its conventions).
#include "vmsim/planner/feedrate.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <numbers>
#include <optional>
#include <string>

#include "feedrate_detail.hpp"
#include "vmsim/common/errors.hpp"
#include "vmsim/common/files.hpp"

namespace vmsim::planner {
namespace {

using detail::kInf;
using detail::Problem;
using detail::Row2;
using detail::Row3;
using detail::value2;
/// Set-point check allowances (relative). Kinematic: the finite differences are exact means of
/// the continuous derivatives, so only the planner's own sampling of its rows (ends of grid
/// segments) and rounding remain: 1e-4. Dynamic: the torque is evaluated from q and the
/// differences at one sample, which differs from the mean of the torque over the stencil by
/// O((sd T / l)^2) (l the length over which the path's dynamics change) and at stops and
/// velocity reversals by the placement of the friction jump within the stencil: 1e-3.
constexpr double kCheckTolerance = 1e-4;
constexpr double kTorqueCheckTolerance = 1e-3;
using Eigen::Index;
using Eigen::VectorXd;

Index idx(std::size_t i) { return static_cast<Index>(i); }

/// Intersection of the w intervals lo_r <= c + beta w <= hi_r.
struct Interval {
  double lo = -kInf, hi = kInf;
  bool bad_constant = false;  // a row independent of w is violated
  void add(double c, double beta, double lo_r, double hi_r) {
    if (beta == 0.0) {
      const double tol = 1e-9 * (std::abs(lo_r) + std::abs(hi_r)) + 1e-300;
      if (c < lo_r - tol || c > hi_r + tol) bad_constant = true;
      return;
    }
    const double inverse = 1.0 / beta;
    double a = (lo_r - c) * inverse, b = (hi_r - c) * inverse;
    if (beta < 0) std::swap(a, b);
    lo = std::max(lo, a);
    hi = std::min(hi, b);
  }
  bool empty() const { return bad_constant || lo > hi + 1e-12 * (std::abs(lo) + std::abs(hi)) + 1e-300; }
};

/// Smallest root s > 0 of c2 s^2 + c1 s + c0 (c2 may be 0), +inf when none.
double smallest_positive_root(double c2, double c1, double c0) {
  if (c2 == 0.0) {
    if (c1 == 0.0) return kInf;
    const double root = -c0 / c1;
    return root > 0.0 ? root : kInf;
  }
  const double disc = c1 * c1 - 4.0 * c2 * c0;
  if (disc < 0.0) return kInf;
  // Without cancellation: q = -(c1 + sign(c1) sqrt(disc)) / 2, roots q / c2 and c0 / q.
  const double q = -0.5 * (c1 + std::copysign(std::sqrt(disc), c1));
  double best = kInf;
  for (const double root : {q / c2, q != 0.0 ? c0 / q : kInf}) {
    if (root > 0.0) best = std::min(best, root);
  }
  return best;
}

}  // namespace

double detail::first_exit(double p0, double p1, double p2, double p3, double L) {
  if (std::abs(p0) > L) return 0.0;
  const double p[4] = {p0, p1, p2, p3};
  int degree = 3;
  while (degree > 0 && p[degree] == 0.0) --degree;
  if (degree == 0) return kInf;
  auto f = [&](double s) { return p0 + s * (p1 + s * (p2 + s * p3)); };
  if (std::abs(p0) == L && (p0 * p1 > 0.0 || (p1 == 0.0 && p0 * p2 > 0.0))) return 0.0;  // leaving at once
  if (p1 == 0.0 && p2 == 0.0) {
    // p0 + p3 s^3 (the jerk rows' sd^3 q_sss term alone): monotone, leaves at s^3 p3 = +-L - p0.
    // The cube roots apart: with a denormal p3 (an axis that does not move, its q_sss 1e-308
    // from rounding) the quotient overflowed to inf and the exit came out 0, a speed cap of 0
    // inside a stretch that the third-order programme could not leave.
    double s = std::cbrt((p3 > 0.0 ? L : -L) - p0) / std::cbrt(p3);
    for (int step = 0; step < 64 && s > 0.0 && std::abs(f(s)) > L; ++step) s = std::nextafter(s, 0.0);
    if (std::abs(f(s)) <= L) return s;
  }
  if (degree <= 2) {
    // Closed form: the first s > 0 where f reaches +L or -L, stepped back until |f| <= L so
    // that the result is on the admissible side, as the bisection's is.
    double s = std::min(smallest_positive_root(p2, p1, p0 - L), smallest_positive_root(p2, p1, p0 + L));
    if (!std::isfinite(s)) return kInf;
    for (int step = 0; step < 64 && s > 0.0 && std::abs(f(s)) > L; ++step) s = std::nextafter(s, 0.0);
    if (std::abs(f(s)) <= L) return s;
  }
  // Fujiwara's bound on the roots of f -+ L: 2 max (|p_i| / |p_degree|)^(1 / (degree - i)), with
  // |p0| + L for i = 0. (1 + max |p_i| / |p_degree| is far too wide for a tiny leading
  // coefficient: the bisection below would not reach the root.)
  double bound = 0.0;
  for (int i = 0; i < degree; ++i) {
    const double top = std::abs(p[i]) + (i == 0 ? L : 0.0), leading = std::abs(p[degree]);
    const int order = degree - i;
    // Roots taken apart (as above: a tiny leading coefficient must not overflow the quotient).
    bound = std::max(bound, order == 1 ? top / leading
                                       : (order == 2 ? std::sqrt(top) / std::sqrt(leading)
                                                     : std::cbrt(top) / std::cbrt(leading)));
  }
  bound *= 2.0;
  // Monotone pieces between the critical points.
  double breaks[4] = {0.0, 0.0, 0.0, 0.0};
  int count = 1;
  const double c1 = p1, c2 = 2.0 * p2, c3 = 3.0 * p3;
  if (c3 != 0.0) {
    const double disc = c2 * c2 - 4.0 * c3 * c1;
    if (disc >= 0.0) {
      const double r = std::sqrt(disc);
      for (double root : {(-c2 - r) / (2.0 * c3), (-c2 + r) / (2.0 * c3)}) {
        if (root > 0.0 && root < bound) breaks[count++] = root;
      }
    }
  } else if (c2 != 0.0) {
    const double root = -c1 / c2;
    if (root > 0.0 && root < bound) breaks[count++] = root;
  }
  std::sort(breaks, breaks + count);
  breaks[count++] = bound;
  for (int i = 0; i + 1 < count; ++i) {
    const double a = breaks[i], b = breaks[i + 1];
    const double fb = f(b);
    if (std::abs(fb) < L) continue;
    const double target = fb >= L ? L : -L;
    // Newton on g = f - target, safeguarded by the bracket (a secant step of the bracket where
    // a Newton step leaves it, a bisection where that does too): f is monotone on the piece, so
    // it converges in a few steps where a bisection to 1e-15 took ~50 (10 % of a torque-rate
    // plan at 10 000 points); from the bracket's middle Newton alone took ~20.
    auto df = [&](double s) { return p1 + s * (2.0 * p2 + 3.0 * s * p3); };
    double lo = a, hi = b;  // |f(lo)| <= L, f crosses target in (lo, hi]
    double g_lo = f(a) - target, g_hi = fb - target;
    auto secant = [&] {
      const double x = g_hi != g_lo ? lo - g_lo * (hi - lo) / (g_hi - g_lo) : 0.5 * (lo + hi);
      return x > lo && x < hi ? x : 0.5 * (lo + hi);
    };
    double s = secant();
    for (int it = 0; it < 200 && hi - lo > 1e-15 * hi; ++it) {
      const double fs = f(s);
      if ((target > 0 && fs >= L) || (target < 0 && fs <= -L)) {
        hi = s, g_hi = fs - target;
      } else {
        lo = s, g_lo = fs - target;
      }
      const double slope = df(s);
      double next = slope != 0.0 ? s - (fs - target) / slope : lo;
      const bool converged = std::abs(next - s) <= 1e-15 * hi;  // a few ulps (before any clamp)
      if (!(next > lo && next < hi)) next = converged ? s : secant();
      if (converged) {
        // The admissible side within a few ulps of the crossing.
        for (int step = 0; step < 64 && next > lo && std::abs(f(next)) > L; ++step) next = std::nextafter(next, 0.0);
        if (next > lo && std::abs(f(next)) <= L) lo = next;
        break;
      }
      s = next;
    }
    return lo;
  }
  return kInf;
}

detail::RestLimits detail::rest_limits(const Row2* rows2, std::size_t n2, const Row3* rows3,
                                       std::size_t n3) {
  RestLimits out;
  for (std::size_t r = 0; r < n2; ++r) {
    const Row2& row = rows2[r];
    if (row.A != 0.0) out.sdd_max = std::min(out.sdd_max, std::max(row.L - std::abs(row.C + row.E), 0.0) / std::abs(row.A));
  }
  const double u = std::isfinite(out.sdd_max) ? out.sdd_max : 0.0;
  for (std::size_t r = 0; r < n3; ++r) {
    const Row3& row = rows3[r];
    if (row.P != 0.0) out.sddd_max = std::min(out.sddd_max, std::max(row.L - std::abs(row.Z * u), 0.0) / std::abs(row.P));
  }
  return out;
}

double detail::RestLimits::ramp_distance_m() const {
  if (!(std::isfinite(sdd_max) && std::isfinite(sddd_max) && sddd_max > 0.0)) return 0.0;
  return sdd_max * sdd_max * sdd_max / (6.0 * sddd_max * sddd_max);
}

std::vector<double> detail::middle_c1_bounds(const Problem& p, const std::vector<double>& cap,
                                             const std::vector<double>& slow) {
  std::vector<double> bound(p.segments(), kInf);
  for (std::size_t k = 0; k < bound.size(); ++k) {
    const double middle = p.cap_mid[k] * std::min(slow[k], slow[k + 1]);
    const double b = 2.0 * middle - 0.5 * (cap[k] + cap[k + 1]);
    if (std::isfinite(b)) bound[k] = std::max(b, 0.0);
  }
  return bound;
}

namespace {

struct EndData {  // path derivatives at one segment end
  VectorXd q, q_s, q_ss, q_sss;
};

/// The grid near the stops in third-order planning. From rest the optimum runs at constant
/// jerk until it reaches the acceleration it can hold (over the ramp distance d); there sd
/// grows like s^(2/3), by 10-100 % from one grid segment to the next on a fine path, and the
/// programme's u, linear in s on each segment, holds the jerk row at the segment's faster end
/// only: a line whose ramps covered 20 grid segments took 0.17 % longer than the seven-phase
/// optimum. Within d of a stop the grid points lie at the distances r_n = r_0 (1 + kStepShare)^n
/// from it instead (sd changes by 2/3 of kStepShare from one to the next), from r_0 =
/// kFirstStepShare d (the programme's exact constant-jerk start covers that first step). Lines
/// with 10 000 segments: 0.04-0.07 % over the optimum with these values (tests StraightLineJerk).
/// Where d exceeds half the stretch (a move too short to reach its acceleration: on a
/// tessellated path in exact-stop mode, nearly every stretch) the zone is half the stretch,
/// from a tenth of it, with steps of 30 %: a 0.5 mm line on 4 segments took 1.45 times the
/// optimum, now 1.004; a polygon of 600 corners 0.5 mm apart plans in 0.6 s instead of 0.4 s
/// (12 600 grid points instead of 4 800) for a cycle 14 % shorter (finer steps: 0.2 % more for
/// several times the work).
struct GridRefinement {
  static constexpr double kStepShare = 0.06;
  static constexpr double kFirstStepShare = 1.0 / 30.0;
  static constexpr double kShortStepShare = 0.3;
  static constexpr double kShortFirstStepShare = 0.1;
  double first_stop_m = 0.0, first_ramp_m = 0.0;  ///< the stretch's start and its ramp distance
  double last_stop_m = 0.0, last_ramp_m = 0.0;    ///< its end
  double max_step_m = kInf;

  /// The grid points strictly inside the path segment [s0, s1], as distances from s0, at most
  /// max_step apart: none where the segment lies outside both ramp zones (the caller then
  /// subdivides it uniformly).
  void cuts(double s0_m, double s1_m, std::vector<double>& out) const {
    out.clear();
    const double h = s1_m - s0_m;
    auto zone = [&](double stop_m, double ramp_m, bool forward) {
      const double half_stretch_m = 0.5 * (last_stop_m - first_stop_m);
      const bool short_move = ramp_m > half_stretch_m;
      if (short_move) ramp_m = half_stretch_m;
      const double share = short_move ? kShortStepShare : kStepShare;
      const double first = short_move ? kShortFirstStepShare : kFirstStepShare;
      const double near_m = forward ? s0_m - stop_m : stop_m - s1_m;  // the segment's distances to the stop
      const double far_m = forward ? s1_m - stop_m : stop_m - s0_m;
      if (!(ramp_m > 0.0) || near_m >= ramp_m) return;
      const double r0 = first * ramp_m, growth = std::log1p(share);
      double n = near_m > r0 ? std::floor(std::log(near_m / r0) / growth) : 0.0;
      for (;; n += 1.0) {
        const double r = r0 * std::exp(n * growth);
        if (r >= std::min(far_m, ramp_m)) break;
        // Not within half a step of the segment's ends (no slivers).
        const double sigma = forward ? stop_m + r - s0_m : stop_m - r - s0_m;
        const double margin = 0.5 * share * r;
        if (sigma > margin && sigma < h - margin) out.push_back(sigma);
      }
    };
    zone(first_stop_m, first_ramp_m, true);
    zone(last_stop_m, last_ramp_m, false);
    if (out.empty()) return;
    std::sort(out.begin(), out.end());
    // Where both zones meet (a short stretch) their points interleave: keep those at least
    // half a local step apart. Then no gap longer than max_step.
    std::vector<double> kept;
    double previous = 0.0;
    for (const double sigma : out) {
      const double to_stop = std::min(s0_m + sigma - first_stop_m, last_stop_m - s0_m - sigma);
      if (sigma - previous < 0.5 * kStepShare * to_stop) continue;
      kept.push_back(sigma);
      previous = sigma;
    }
    out.clear();
    previous = 0.0;
    kept.push_back(h);
    for (const double sigma : kept) {
      const double gap = sigma - previous;
      const auto pieces = static_cast<std::size_t>(std::ceil(gap / max_step_m - 1e-9));
      for (std::size_t m = 1; m < pieces; ++m) out.push_back(previous + gap * static_cast<double>(m) / static_cast<double>(pieces));
      out.push_back(sigma);
      previous = sigma;
    }
    out.pop_back();  // h itself
  }
};

// ---------------------------------------------------------------------------------------------
// Second order: time-optimal on the grid, sdd constant per segment

class SecondOrder {
 public:
  SecondOrder(const Problem& p, const std::vector<double>& cap) : p_(p), cap_(cap) {}

  /// Largest x at point k from which some u on segment k keeps rows at both ends and lands in
  /// [0, k_next]; -1 when none.
  double max_x(std::size_t k, double k_next) const {
    const double delta = p_.delta(k);
    double x = cap_[k];
    for (int iteration = 0; iteration < 100; ++iteration) {
      double lo = -kInf, hi = kInf, dlo = 0, dhi = 0;
      double x_new = x;
      bool x_only_violated = false, hopeless = false;
      auto add = [&](double alpha, double beta, double gamma, double lo_r, double hi_r) {
        if (beta == 0.0) {
          const double v = alpha * x + gamma;
          const double tol = 1e-9 * std::abs(hi_r - lo_r);
          if (v > hi_r + tol) {
            if (alpha > 0) x_new = std::min(x_new, (hi_r - gamma) / alpha); else hopeless = true;
            x_only_violated = true;
          } else if (v < lo_r - tol) {
            if (alpha < 0) x_new = std::min(x_new, (lo_r - gamma) / alpha); else hopeless = true;
            x_only_violated = true;
          }
          return;
        }
        const double inverse = 1.0 / beta, rest = alpha * x + gamma;
        double a = (lo_r - rest) * inverse, b = (hi_r - rest) * inverse;
        const double slope = -alpha * inverse;
        if (beta < 0) std::swap(a, b);
        if (a > lo) { lo = a; dlo = slope; }
        if (b < hi) { hi = b; dhi = slope; }
      };
      const double sd = std::sqrt(std::max(x, 0.0));
      const double sd_next = std::sqrt(std::max(k_next, 0.0));
      for (int end = 0; end < 2; ++end) {
        const Row2* rows = p_.rows2(k, end);
        for (std::size_t r = 0; r < p_.n2; ++r) {
          const Row2& row = rows[r];
          if (end == 0) {
            add(row.B, row.A, row.C + row.E + row.D * sd, -row.L, row.L);
            continue;
          }
          // Right end: sd there lies in [0, sqrt(k_next)]; take the worse value for each bound.
          const double beta = row.A + 2.0 * delta * row.B;
          if (row.D == 0.0) {  // no sqrt(x) term: one row for both bounds
            add(row.B, beta, row.C + row.E, -row.L, row.L);
            continue;
          }
          const double up = row.D > 0 ? sd_next : 0.0, down = row.D > 0 ? 0.0 : sd_next;
          add(row.B, beta, row.C + row.E + row.D * up, -kInf, row.L);
          add(row.B, beta, row.C + row.E + row.D * down, -row.L, kInf);
        }
      }
      // Middle of the segment (x there = x + delta u): catches peaks between the ends.
      const Row2* mid = p_.rows2mid(k);
      for (std::size_t r = 0; r < p_.n2; ++r) {
        const Row2& row = mid[r];
        const double beta = row.A + delta * row.B;
        if (row.D == 0.0) {
          add(row.B, beta, row.C + row.E, -row.L, row.L);
          continue;
        }
        const double up = row.D > 0 ? std::max(sd, sd_next) : 0.0;
        const double down = row.D > 0 ? 0.0 : std::max(sd, sd_next);
        add(row.B, beta, row.C + row.E + row.D * up, -kInf, row.L);
        add(row.B, beta, row.C + row.E + row.D * down, -row.L, kInf);
      }
      add(1.0, 2.0 * delta, 0.0, 0.0, k_next);
      if (hopeless) return -1.0;
      if (x_only_violated) {
        if (!(x_new < x) || x_new < 0) return -1.0;
        x = x_new;
        continue;
      }
      const double gap = hi - lo;
      if (gap >= -1e-12 * (std::abs(hi) + std::abs(lo))) return x;
      const double slope = dhi - dlo;
      if (slope >= 0.0) return -1.0;
      double next = x - gap / slope;
      if (next < 0.0) {
        if (x == 0.0) return -1.0;
        next = 0.0;
      }
      if (!(next < x)) next = x * (1.0 - 1e-12);
      x = next;
    }
    return x;
  }

  /// Greatest feasible u on segment k from x_k, landing at or below k_next.
  double best_u(std::size_t k, double x_k, double k_next) const {
    const double delta = p_.delta(k);
    double sd_right = std::sqrt(x_k);
    double u = 0.0;
    for (int pass = 0; pass < 3; ++pass) {
      Interval in;
      const double sd = std::sqrt(x_k);
      for (int end = 0; end < 2; ++end) {
        const Row2* rows = p_.rows2(k, end);
        for (std::size_t r = 0; r < p_.n2; ++r) {
          const Row2& row = rows[r];
          if (end == 0) {
            in.add(row.B * x_k + row.C + row.E + row.D * sd, row.A, -row.L, row.L);
          } else {
            in.add(row.B * x_k + row.C + row.E + row.D * sd_right, row.A + 2.0 * delta * row.B,
                   -row.L, row.L);
          }
        }
      }
      const Row2* mid = p_.rows2mid(k);
      const double sd_mid = std::sqrt(0.5 * (x_k + sd_right * sd_right));
      for (std::size_t r = 0; r < p_.n2; ++r) {
        const Row2& row = mid[r];
        in.add(row.B * x_k + row.C + row.E + row.D * sd_mid, row.A + delta * row.B, -row.L, row.L);
      }
      in.add(x_k, 2.0 * delta, 0.0, k_next);
      const double candidate = std::max(in.hi, -x_k / (2.0 * delta));
      u = pass == 0 ? candidate : std::min(u, candidate);
      sd_right = std::sqrt(std::max(0.0, x_k + 2.0 * delta * u));
    }
    return u;
  }

  /// Solves [k0, k1] from rest to rest; x at the points, u per segment. Returns the first point
  /// at which even rest is infeasible, or nullopt.
  std::optional<std::size_t> solve(std::size_t k0, std::size_t k1, std::vector<double>& x,
                                   std::vector<double>& u, std::vector<double>& controllable,
                                   bool start_at_rest = true) const {
    controllable[k1] = 0.0;
    for (std::size_t k = k1; k-- > k0;) {
      const double value = max_x(k, controllable[k + 1]);
      if (value < 0.0) return k;
      controllable[k] = value;
    }
    x[k0] = start_at_rest ? 0.0 : controllable[k0];
    for (std::size_t k = k0; k < k1; ++k) {
      const double delta = p_.delta(k);
      double uk = best_u(k, x[k], controllable[k + 1]);
      double next = std::clamp(x[k] + 2.0 * delta * uk, 0.0, controllable[k + 1]);
      if (k + 1 == k1) next = 0.0;
      u[k] = (next - x[k]) / (2.0 * delta);
      x[k + 1] = next;
    }
    return std::nullopt;
  }

 private:
  const Problem& p_;
  const std::vector<double>& cap_;
};

// ---------------------------------------------------------------------------------------------

}  // namespace

double detail::gauss_time(double delta, double x0, double u0, double up) {
  // integral over [0, delta] of 1 / sqrt(x0 + 2 u0 s + up s^2), 8-point Gauss-Legendre.
  // Where the quadratic dips well below both ends inside the segment (sdd changing sign on a
  // short segment), the duration of the linear-x segment through the same end points is used
  // instead: the set-point check judges the result either way.
  const double x1 = x0 + delta * (2.0 * u0 + up * delta);
  if (up > 0.0 && u0 < 0.0 && -u0 / up < delta) {
    const double x_min = x0 - u0 * u0 / up;
    if (x_min < 0.25 * std::min(x0, x1)) {
      return 2.0 * delta / (std::sqrt(std::max(x0, 0.0)) + std::sqrt(std::max(x1, 0.0)));
    }
  }
  static const double nodes[4] = {0.1834346424956498, 0.5255324099163290, 0.7966664774136267,
                                  0.9602898564975363};
  static const double weights[4] = {0.3626837833783620, 0.3137066458778873, 0.2223810344533745,
                                    0.1012285362903763};
  double sum = 0.0;
  for (int i = 0; i < 4; ++i) {
    for (double sign : {-1.0, 1.0}) {
      const double s = 0.5 * delta * (1.0 + sign * nodes[i]);
      const double x = std::max(x0 + s * (2.0 * u0 + up * s), 1e-300);
      sum += weights[i] / std::sqrt(x);
    }
  }
  return 0.5 * delta * sum;
}

namespace {

/// sinh(y) / y with y^2 = b tau^2 (sin(y) / y for b < 0), by its series where y is small.
double sinhc(double b, double tau) {
  const double y2 = b * tau * tau;
  if (std::abs(y2) < 1e-3) {
    return 1.0 + y2 / 6.0 * (1.0 + y2 / 20.0 * (1.0 + y2 / 42.0 * (1.0 + y2 / 72.0)));
  }
  const double y = std::sqrt(std::abs(y2));
  return (y2 > 0.0 ? std::sinh(y) : std::sin(y)) / y;
}

}  // namespace

// With k^2 = b: sigma = u0 (cosh k tau - 1) / b + v0 sinh(k tau) / k; cosh - 1 = 2 sinh^2(k tau / 2)
// keeps it free of cancellation.
double detail::LinearAccelerationLaw::position(double tau) const {
  const double h = sinhc(b, 0.5 * tau);
  return u0 * 0.5 * tau * tau * h * h + v0 * tau * sinhc(b, tau);
}

double detail::LinearAccelerationLaw::speed(double tau) const {
  const double h = sinhc(b, 0.5 * tau);
  return u0 * tau * sinhc(b, tau) + v0 * (1.0 + b * 0.5 * tau * tau * h * h);
}

std::optional<double> detail::LinearAccelerationLaw::duration(double delta, double estimate) const {
  // x(sigma) = v0^2 + 2 u0 sigma + b sigma^2 must stay positive on [0, delta] (up to rounding:
  // near stops end segments with x ~ 1e-11).
  const double x0 = v0 * v0;
  const double x1 = x0 + delta * (2.0 * u0 + b * delta);
  const double rounding = 1e-9 * std::max({x0, std::abs(x1), std::abs(u0) * delta, std::abs(b) * delta * delta});
  if (!(x1 >= -rounding) || (x0 <= 0.0 && u0 <= 0.0)) return std::nullopt;
  if (b > 0.0 && u0 < 0.0 && -u0 / b < delta && x0 - u0 * u0 / b < -rounding) return std::nullopt;
  // Until the end is reached the motion goes forward; with b < 0 it is periodic, and the speed
  // vanishes within the first half period pi / sqrt(-b).
  const double half_period = b < 0.0 ? std::numbers::pi / std::sqrt(-b) : kInf;
  auto reached = [&](double tau) { return position(tau) >= delta || speed(tau) <= 0.0; };
  const double sd_sum = std::sqrt(x0) + std::sqrt(std::max(x1, 0.0));
  double lo = 0.0;
  double hi = std::min(sd_sum > 0.0 ? 2.0 * delta / sd_sum : std::max(estimate, 1e-300), half_period);
  for (int i = 0; !reached(hi); ++i) {
    if (i == 200 || !std::isfinite(hi)) return std::nullopt;
    lo = hi;
    hi = std::min(2.0 * hi, half_period);
  }
  // Safeguarded Newton on sigma(tau) = delta within [lo, hi].
  double tau = std::clamp(estimate, lo, hi);
  if (!(tau > lo && tau < hi)) tau = 0.5 * (lo + hi);
  for (int i = 0; i < 200; ++i) {
    const double f = position(tau) - delta;
    const double v = speed(tau);
    if (std::abs(f) <= 1e-15 * delta && v > 0.0) return tau;
    (reached(tau) ? hi : lo) = tau;
    if (hi - lo <= 4.0 * std::numeric_limits<double>::epsilon() * hi) break;
    double next = v > 0.0 ? tau - f / v : 0.5 * (lo + hi);
    if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
    tau = next;
  }
  return hi;
}

namespace {

/// Quintic Hermite in t through (0, v0, a0) and (d, v1, a1) over duration h, evaluated at t.
double quintic(double d, double v0, double a0, double v1, double a1, double h, double t) {
  const double c3 = (20.0 * d - (8.0 * v1 + 12.0 * v0) * h - (3.0 * a0 - a1) * h * h) / (2.0 * h * h * h);
  const double c4 = (-30.0 * d + (14.0 * v1 + 16.0 * v0) * h + (3.0 * a0 - 2.0 * a1) * h * h) /
                    (2.0 * h * h * h * h);
  const double c5 = (12.0 * d - 6.0 * (v1 + v0) * h + (a1 - a0) * h * h) / (2.0 * h * h * h * h * h);
  return t * (v0 + t * (0.5 * a0 + t * (c3 + t * (c4 + t * c5))));
}

struct Executed {
  std::vector<double> x;              // at points
  std::vector<double> sdd_l, sdd_r;   // per segment, at its ends
  std::vector<char> linear_law;       // per segment: sdd linear in s (else the quintic in t)
  std::vector<double> dt;             // per segment
  std::vector<double> t;              // at points
};

}  // namespace

void SetPointLaw::locate(std::size_t n, std::size_t& cursor, std::size_t& grid_segment, double& sigma_m) const {
  const std::size_t segs = segments();
  const double t = sample_t_s(n);
  // The last grid segment starting at or before t (segments of zero duration are passed over):
  // from the cursor when t is in its segment or the next, else by bisection.
  if (cursor >= segs || t_s[cursor] > t || (cursor + 2 < segs && t_s[cursor + 2] <= t)) {
    const auto it = std::upper_bound(t_s.begin(), t_s.begin() + static_cast<std::ptrdiff_t>(segs), t);
    cursor = it == t_s.begin() ? 0 : static_cast<std::size_t>(it - t_s.begin()) - 1;
  }
  std::size_t k = cursor;
  while (k + 1 < segs && t_s[k + 1] <= t) ++k;
  cursor = k;
  if (t >= duration_s) {
    grid_segment = segs - 1;
    sigma_m = grid_s_m[segs] - grid_s_m[segs - 1];
    return;
  }
  const double tau = std::clamp(t - t_s[k], 0.0, dt_s[k]);
  const double delta = grid_s_m[k + 1] - grid_s_m[k];
  const double v0 = std::sqrt(x[k]);
  const double position =
      linear_law[k] ? detail::LinearAccelerationLaw{v0, sdd_start[k], (sdd_end[k] - sdd_start[k]) / delta}.position(tau)
                    : quintic(delta, v0, sdd_start[k], std::sqrt(x[k + 1]), sdd_end[k], dt_s[k], tau);
  grid_segment = k;
  sigma_m = std::clamp(position, 0.0, delta);
}

double SetPointLaw::sample_s_m(std::size_t n, std::size_t& cursor) const {
  std::size_t grid_segment = 0;
  double sigma = 0.0;
  locate(n, cursor, grid_segment, sigma);
  // At and after the end: the last grid point itself (not its start plus its length).
  return sample_t_s(n) >= duration_s ? grid_s_m.back() : grid_s_m[grid_segment] + sigma;
}

double SetPointLaw::s_at_time(double t) const {
  std::size_t cursor = 0;
  if (samples == 0) return 0.0;
  if (t <= sample_t_s(0)) return sample_s_m(0, cursor);
  if (t >= sample_t_s(samples - 1)) return sample_s_m(samples - 1, cursor);
  // k: the first sample after t (as std::upper_bound on the samples' times).
  auto k = static_cast<std::size_t>(std::max(0.0, std::floor(t / period_s))) + 1;
  while (k > 1 && sample_t_s(k - 1) > t) --k;
  while (sample_t_s(k) <= t) ++k;
  const double t0 = sample_t_s(k - 1), t1 = sample_t_s(k);
  const double s0 = sample_s_m(k - 1, cursor), s1 = sample_s_m(k, cursor);
  const double f = (t - t0) / (t1 - t0);
  return s0 + f * (s1 - s0);
}

namespace {

/// Set points first .. first + count - 1 (count clamped to the end) of `law` on `spline` into
/// `window` (SetPointGenerator::fill; the planner's windowed checks).
void fill_setpoints(const SetPointLaw& law, const PathSpline& spline, std::size_t& cursor, std::size_t first,
                    std::size_t count, SetPoints& window) {
  count = first < law.samples ? std::min(count, law.samples - first) : 0;
  window.period_s = law.period_s;
  window.t_s.resize(count);
  window.s_m.resize(count);
  window.q.resize(static_cast<Index>(spline.axis_count()), idx(count));
  VectorXd qv;
  for (std::size_t i = 0; i < count; ++i) {
    const std::size_t n = first + i;
    std::size_t grid_segment = 0;
    double sigma = 0.0;
    law.locate(n, cursor, grid_segment, sigma);
    window.t_s[i] = law.sample_t_s(n);
    window.s_m[i] = window.t_s[i] >= law.duration_s ? law.grid_s_m.back() : law.grid_s_m[grid_segment] + sigma;
    spline.evaluate(law.spline_segment[grid_segment], law.spline_sigma0_m[grid_segment] + sigma, &qv, nullptr,
                    nullptr, nullptr);
    window.q.col(idx(i)) = qv;
  }
}

}  // namespace

SetPointGenerator::SetPointGenerator(const FeedratePlan& plan) : law_(plan.law), spline_(plan.path) {}

void SetPointGenerator::fill(std::size_t first, std::size_t count, SetPoints& window) {
  fill_setpoints(law_, spline_, cursor_, first, count, window);
}

std::string_view constraint_name(ConstraintKind kind) {
  switch (kind) {
    case ConstraintKind::feed: return "feed";
    case ConstraintKind::velocity: return "velocity";
    case ConstraintKind::acceleration: return "acceleration";
    case ConstraintKind::jerk: return "jerk";
    case ConstraintKind::torque: return "torque";
    case ConstraintKind::torque_rate: return "torque_rate";
  }
  return "?";
}

void FeedrateOptions::validate() const {
  auto bad = [](const std::string& field, double value, const std::string& what) {
    throw InputError("feedrate options: " + field + " = " + format_double(value) + ": " + what);
  };
  if (!(feed_m_per_s >= 0.0) || !std::isfinite(feed_m_per_s)) bad("feed_m_per_s", feed_m_per_s, "must be >= 0");
  if (!(max_grid_step_m >= 0.0)) bad("max_grid_step_m", max_grid_step_m, "must be >= 0");
  if (!(period_s >= 0.0)) bad("period_s", period_s, "must be >= 0");
  if (check_window_samples < 1) bad("check_window_samples", 0.0, "must be >= 1");
  if (!(path_tolerance_m > 0.0) || !std::isfinite(path_tolerance_m)) bad("path_tolerance_m", path_tolerance_m, "must be > 0");
  if (!(turning_path_tolerance_m > 0.0) || !std::isfinite(turning_path_tolerance_m)) {
    bad("turning_path_tolerance_m", turning_path_tolerance_m, "must be > 0");
  }
  if (!(path_axis_tolerance_rad > 0.0) || !std::isfinite(path_axis_tolerance_rad)) {
    bad("path_axis_tolerance_rad", path_axis_tolerance_rad, "must be > 0");
  }
  for (std::size_t i = 0; i < point_feed_m_per_s.size(); ++i) {
    if (!(point_feed_m_per_s[i] >= 0.0)) {
      bad("point_feed_m_per_s[" + std::to_string(i) + "]", point_feed_m_per_s[i], "must be >= 0");
    }
  }
  for (std::size_t i = 0; i < point_dwell_s.size(); ++i) {
    if (!(point_dwell_s[i] >= 0.0) || !std::isfinite(point_dwell_s[i])) {
      bad("point_dwell_s[" + std::to_string(i) + "]", point_dwell_s[i], "must be >= 0 and finite");
    }
  }
}

double SetPointCheck::worst() const { return ratio.size() == 0 ? 0.0 : ratio.maxCoeff(); }

std::vector<AxisLimitValues> limit_values(const kinematics::MachineModel& machine,
                                          const FeedrateOptions& options) {
  std::vector<AxisLimitValues> out(machine.axes.size());
  for (std::size_t j = 0; j < machine.axes.size(); ++j) {
    const auto& axis = machine.axes[j];
    AxisLimitValues& l = out[j];
    l.velocity = axis.limits.velocity_max;
    l.acceleration = axis.limits.acceleration_max;
    l.jerk = axis.limits.jerk_max;
    if (options.limits == DynamicLimitSource::tuned) {
      const auto eq = kinematics::equivalent_actuator_limits(axis);
      l.torque_N_m = eq.torque_N_m;
      l.torque_rate_N_m_per_s = eq.torque_rate_N_m_per_s;
    } else {
      l.torque_N_m = axis.drive.torque_max_N_m;
      l.torque_rate_N_m_per_s = axis.drive.torque_rate_max_N_m_per_s;
    }
  }
  return out;
}

namespace {

/// The set-point check one sample after another (see the header notes): sample k from q at
/// k - 2 .. k + 2, clamped to the run (the motion held at rest before the first and after the
/// last sample). The whole set and the windows (keep_setpoints = false) run the same code.
class SampleChecker {
 public:
  SampleChecker(const kinematics::DynamicsModel* dynamics, const std::vector<AxisLimitValues>& limits,
                const FeedrateOptions& options, double period_s, Index axes, std::size_t samples)
      : dynamics_(dynamics), limits_(limits), options_(options), T_(period_s), axes_(axes), n_(samples),
        dynamic_(options.method == FeedrateMethod::dynamic), qd_(axes), qdd_(axes), qddd_(axes) {
    check.ratio = Eigen::MatrixXd::Zero(axes, kConstraintKindCount);
    if (dynamic_ && dynamics != nullptr) data_ = std::make_unique<kinematics::DynamicsData>(*dynamics);
  }

  /// Checks sample k at s [m] and t [s]. column(i) gives q of sample i for every i in
  /// [k - 2, k + 2] clamped to [0, samples - 1]. Sets sample_worst and sample_order.
  template <class Column>
  void check_sample(std::size_t k, const Column& column, double s_m, double t_s) {
    auto q = [&](long i) { return column(static_cast<std::size_t>(std::clamp(i, 0L, static_cast<long>(n_) - 1))); };
    const double T = T_;
    sample_worst = 0.0;
    sample_order = 0;
    auto note = [&](Index axis, ConstraintKind kind, double value, double limit, int order) {
      if (!(limit > 0.0)) return;
      const double r = std::abs(value) / limit;
      double& cell = check.ratio(axis, static_cast<Index>(kind));
      if (r > largest_) {
        largest_ = r;
        worst_sample = k;
        worst_axis = axis;
        worst_kind = kind;
        worst_s_m = s_m;
        worst_t_s = t_s;
      }
      cell = std::max(cell, r);
      if (r > sample_worst) {
        sample_worst = r;
        sample_order = order;
      }
    };
    const long i = static_cast<long>(k);
    for (Index j = 0; j < axes_; ++j) {
      const auto& l = limits_[static_cast<std::size_t>(j)];
      note(j, ConstraintKind::velocity, (q(i)(j) - q(i - 1)(j)) / T, l.velocity, 1);
      if (k + 1 == n_) note(j, ConstraintKind::velocity, (q(i + 1)(j) - q(i)(j)) / T, l.velocity, 1);
      if (!dynamic_) {
        note(j, ConstraintKind::acceleration,
             (q(i + 1)(j) - 2.0 * q(i)(j) + q(i - 1)(j)) / (T * T), l.acceleration, 2);
        if (options_.third_order) {
          note(j, ConstraintKind::jerk,
               (q(i + 1)(j) - 3.0 * q(i)(j) + 3.0 * q(i - 1)(j) - q(i - 2)(j)) / (T * T * T),
               l.jerk, 3);
          if (k + 1 == n_) {
            note(j, ConstraintKind::jerk,
                 (q(i + 2)(j) - 3.0 * q(i + 1)(j) + 3.0 * q(i)(j) - q(i - 1)(j)) / (T * T * T),
                 l.jerk, 3);
          }
        }
      }
    }
    if (!(dynamic_ && data_)) return;
    qd_ = (q(i + 1) - q(i - 1)) / (2.0 * T);
    qdd_ = (q(i + 1) - 2.0 * q(i) + q(i - 1)) / (T * T);
    qddd_ = (q(i + 2) - 2.0 * q(i + 1) + 2.0 * q(i - 1) - q(i - 2)) / (2.0 * T * T * T);
    kinematics::actuator_torque_terms(*dynamics_, *data_, q(i), qd_, qdd_, qddd_, options_.effects);
    for (Index j = 0; j < axes_; ++j) {
      const auto& l = limits_[static_cast<std::size_t>(j)];
      double torque = data_->terms.total_torque_N_m(j);
      const double before = q(i)(j) - q(i - 1)(j), after = q(i + 1)(j) - q(i)(j);
      if (options_.effects.contains(kinematics::Effect::friction) && (before == 0.0) != (after == 0.0)) {
        // A stop or a start inside the stencil (path ends, exact stops at corners): the
        // difference mixes motion at the torque limit with rest, where the dry friction
        // vanishes (sign(0) = 0); the torque there is checked by the rows at the stop itself.
        continue;
      }
      if (options_.effects.contains(kinematics::Effect::friction) && before * after < 0.0) {
        // A velocity reversal inside the stencil: the dry friction jumps there (Sec. 3.3).
        // The second difference is the mean of the acceleration under the hat kernel
        // (1 - |t|/T)/T on [-T, T]; the dry friction term is given the same mean, with the
        // reversal placed where the linearly interpolated velocity crosses zero.
        const double rest = torque - data_->terms.torque_N_m(j, static_cast<Index>(kinematics::Effect::friction));
        const double viscous = dynamics_->friction_viscous_N_m_s(j) * qd_(j);
        const double dry = dynamics_->friction_dry_N_m(j);
        const double f = before / (before - after);  // in [0, 1]
        const double tc = (f - 0.5);                    // crossing time / T, in [-1/2, 1/2]
        const double H = tc <= 0.0 ? 0.5 * (1.0 + tc) * (1.0 + tc) : 1.0 - 0.5 * (1.0 - tc) * (1.0 - tc);
        const double sign_before = before > 0 ? 1.0 : (before < 0 ? -1.0 : (after > 0 ? -1.0 : 1.0));
        torque = rest + viscous + dry * sign_before * (2.0 * H - 1.0);
      }
      note(j, ConstraintKind::torque, torque, l.torque_N_m, 2);
      if (options_.third_order) {
        note(j, ConstraintKind::torque_rate, data_->terms.total_torque_rate_N_m_per_s(j),
             l.torque_rate_N_m_per_s, 3);
      }
    }
  }

  SetPointCheck check;
  /// The last checked sample's worst ratio and the order of the constraint that gave it (1
  /// velocity, 2 acceleration / torque, 3 jerk / torque rate; 0: none).
  double sample_worst = 0.0;
  int sample_order = 0;
  /// Where the largest ratio of all is (for error messages): the first sample that reached it.
  std::size_t worst_sample = 0;
  Index worst_axis = 0;
  ConstraintKind worst_kind = ConstraintKind::velocity;
  double worst_s_m = 0.0, worst_t_s = 0.0;

 private:
  const kinematics::DynamicsModel* dynamics_;
  const std::vector<AxisLimitValues>& limits_;
  const FeedrateOptions& options_;
  double T_;
  Index axes_;
  std::size_t n_;
  bool dynamic_;
  double largest_ = 0.0;
  std::unique_ptr<kinematics::DynamicsData> data_;
  VectorXd qd_, qdd_, qddd_;
};

/// Per sample of a whole set: the worst ratio and the order of the constraint that gave it.
struct SampleCheck {
  SetPointCheck check;
  std::vector<double> worst;  // per sample
  std::vector<int> order;     // 1 velocity, 2 acceleration / torque, 3 jerk / torque rate
  // Where the largest ratio of all is (for error messages).
  std::size_t worst_sample = 0;
  Index worst_axis = 0;
  ConstraintKind worst_kind = ConstraintKind::velocity;
};

SampleCheck check_samples(const kinematics::MachineModel& machine,
                          const kinematics::DynamicsModel* dynamics,
                          const std::vector<AxisLimitValues>& limits, const FeedrateOptions& options,
                          const SetPoints& sp) {
  const std::size_t n = sp.t_s.size();
  SampleChecker checker(dynamics, limits, options, sp.period_s, sp.q.rows(), n);
  SampleCheck out;
  out.worst.assign(n, 0.0);
  out.order.assign(n, 0);
  const auto column = [&](std::size_t i) { return sp.q.col(idx(i)); };
  for (std::size_t k = 0; k < n; ++k) {
    checker.check_sample(k, column, sp.s_m[k], sp.t_s[k]);
    out.worst[k] = checker.sample_worst;
    out.order[k] = checker.sample_order;
  }
  out.check = checker.check;
  out.worst_sample = checker.worst_sample;
  out.worst_axis = checker.worst_axis;
  out.worst_kind = checker.worst_kind;
  (void)machine;
  return out;
}

/// The slow-down the set-point check drives: around every sample over the allowance, the
/// admissible speed of the grid points from s 5 samples before to 4 after is scaled down (the
/// smallest factor wins). Samples are given in increasing order.
class SlowDownSpans {
 public:
  SlowDownSpans(const std::vector<double>& grid_s_m, bool dynamic)
      : factor(grid_s_m.size(), 1.0), grid_s_m_(grid_s_m), dynamic_(dynamic) {}
  /// Sample with worst ratio `worst` of order `order`; s_before_m, s_after_m: s of the samples 5
  /// before and 4 after it (clamped to the run).
  void add(double worst, int order, double s_before_m, double s_after_m) {
    const double allowed = dynamic_ && order >= 2 ? kTorqueCheckTolerance : kCheckTolerance;
    if (!(worst > 1.0 + allowed)) return;
    violated = true;
    const std::size_t points = grid_s_m_.size();
    const double f = std::clamp(std::pow(worst, -2.0 / order) * 0.99, 0.5, 0.99);
    while (g_ > 0 && grid_s_m_[g_] > s_before_m) --g_;
    while (g_ + 1 < points && grid_s_m_[g_ + 1] <= s_before_m) ++g_;
    for (std::size_t i = g_; i < points && grid_s_m_[i] <= s_after_m; ++i) {
      factor[i] = std::min(factor[i], f);
      if (i + 1 < points) factor[i + 1] = std::min(factor[i + 1], f);
    }
  }
  /// The span's sample offsets (before, after) around the violating sample.
  static constexpr std::size_t kBefore = 5, kAfter = 4;
  std::vector<double> factor;  ///< per grid point
  bool violated = false;

 private:
  const std::vector<double>& grid_s_m_;
  bool dynamic_;
  std::size_t g_ = 0;
};

}  // namespace

SetPointCheck check_setpoints(const kinematics::MachineModel& machine,
                              const kinematics::DynamicsModel* dynamics,
                              const std::vector<AxisLimitValues>& limits,
                              const FeedrateOptions& options, const SetPoints& setpoints) {
  return check_samples(machine, dynamics, limits, options, setpoints).check;
}

namespace {

/// The largest step [joint unit] a set point may stand beyond an end stop: rounding only.
constexpr double kTravelRounding = 1e-9;

/// The InfeasibleError for a set point (at s [m], t [s]) whose axis `axis` stands at `value`
/// outside its travel.
[[noreturn]] void throw_outside_travel(const kinematics::MachineModel& machine,
                                       const kinematics::PathKinematics& path, std::size_t axis_index,
                                       double value, double s, double t) {
  const kinematics::Axis& axis = machine.axes[axis_index];
  const bool rotary = axis.type == kinematics::AxisType::rotary;
  const double f = rotary ? 180.0 / std::numbers::pi : 1e3;
  const std::string unit = rotary ? " deg" : " mm";
  const auto it = std::upper_bound(path.s_m.begin(), path.s_m.end(), s);
  std::size_t point = static_cast<std::size_t>(it - path.s_m.begin());
  point = std::clamp<std::size_t>(point, 1, path.s_m.size() - 1);
  throw InfeasibleError("set point at t = " + format_double(t) + " s, s = " + format_double(s * 1e3) + " mm (" +
                        path_point_label(path, point) + "): axis " + axis.name + " at " + format_double(value * f) +
                        unit + ", outside its travel [" + format_double(axis.travel_min * f) + ", " +
                        format_double(axis.travel_max * f) + "]" + unit);
}

/// Throws vmsim::InfeasibleError for the set point farthest beyond an axis's travel (the first
/// axis, then the first sample, where several are as far).
void check_travel(const kinematics::MachineModel& machine, const kinematics::PathKinematics& path,
                  const SetPoints& sp) {
  double worst_excess = 0.0;
  std::size_t worst_axis = 0, worst_sample = 0;
  for (std::size_t j = 0; j < machine.axes.size(); ++j) {
    const kinematics::Axis& axis = machine.axes[j];
    if (axis.type == kinematics::AxisType::rotary && axis.continuous) continue;
    for (Index n = 0; n < sp.q.cols(); ++n) {
      const double value = sp.q(idx(j), n);
      const double excess = std::max(axis.travel_min - value, value - axis.travel_max);
      if (excess > kTravelRounding && excess > worst_excess) {
        worst_excess = excess, worst_axis = j, worst_sample = static_cast<std::size_t>(n);
      }
    }
  }
  if (worst_excess == 0.0) return;
  throw_outside_travel(machine, path, worst_axis, sp.q(idx(worst_axis), idx(worst_sample)),
                       sp.s_m[worst_sample], sp.t_s[worst_sample]);
}

/// check_travel window by window (windows in the order of the samples): per axis the first
/// sample farthest beyond its travel, then the first such axis.
class TravelCheck {
 public:
  explicit TravelCheck(const kinematics::MachineModel& machine) : machine_(machine), worst_(machine.axes.size()) {}
  void add(const SetPoints& window) {
    for (std::size_t j = 0; j < machine_.axes.size(); ++j) {
      const kinematics::Axis& axis = machine_.axes[j];
      if (axis.type == kinematics::AxisType::rotary && axis.continuous) continue;
      Worst& worst = worst_[j];
      for (Index n = 0; n < window.q.cols(); ++n) {
        const double value = window.q(idx(j), n);
        const double excess = std::max(axis.travel_min - value, value - axis.travel_max);
        if (excess > kTravelRounding && excess > worst.excess) {
          worst = {excess, value, window.s_m[static_cast<std::size_t>(n)], window.t_s[static_cast<std::size_t>(n)]};
        }
      }
    }
  }
  /// Throws as check_travel on the set points added.
  void finish(const kinematics::PathKinematics& path) const {
    std::size_t worst_axis = 0;
    for (std::size_t j = 1; j < worst_.size(); ++j) {
      if (worst_[j].excess > worst_[worst_axis].excess) worst_axis = j;
    }
    if (worst_.empty() || worst_[worst_axis].excess == 0.0) return;
    const Worst& w = worst_[worst_axis];
    throw_outside_travel(machine_, path, worst_axis, w.value, w.s_m, w.t_s);
  }

 private:
  struct Worst {
    double excess = 0.0, value = 0.0, s_m = 0.0, t_s = 0.0;
  };
  const kinematics::MachineModel& machine_;
  std::vector<Worst> worst_;
};

FeedratePlan plan_refined_path(const kinematics::MachineModel& machine, const kinematics::PathKinematics& path,
                               const FeedrateOptions& options);

}  // namespace

FeedratePlan plan_feedrate(const kinematics::MachineModel& machine,
                           const kinematics::PathKinematics& path, const FeedrateOptions& options) {
  options.validate();
  if (static_cast<std::size_t>(path.q.rows()) != machine.axes.size()) {
    throw InputError("feedrate interpolation: the path has " + std::to_string(path.q.rows()) +
                     " axes, the machine " + std::to_string(machine.axes.size()));
  }
  if (path.s_m.size() < 2) throw InputError("feedrate interpolation needs a path of at least 2 points");
  PathFidelityOptions fidelity;
  fidelity.tolerance_m = options.path_tolerance_m;
  fidelity.turning_tolerance_m = options.turning_path_tolerance_m;
  fidelity.axis_tolerance_rad = options.path_axis_tolerance_rad;
  fidelity.free_end = options.rapid_end;
  fidelity.segment_tolerance_m = options.point_path_tolerance_m;
  if (!options.point_dwell_s.empty() && options.point_dwell_s.size() != path.s_m.size()) {
    throw InputError("feedrate interpolation: " + std::to_string(options.point_dwell_s.size()) + " dwells for " +
                     std::to_string(path.s_m.size()) + " path points");
  }
  RefinedPath refined = refine_path(machine, path, fidelity);
  const std::size_t added = refined.graded_points + refined.refined_points;
  FeedratePlan plan;
  if (added > 0 && (!options.point_feed_m_per_s.empty() || !options.point_dwell_s.empty())) {
    // An added point's feed is that of the input point that ends its segment; a dwell stays at
    // the input point itself (the last point of its source).
    FeedrateOptions mapped = options;
    if (!options.point_feed_m_per_s.empty()) mapped.point_feed_m_per_s.assign(refined.source_point.size(), 0.0);
    if (!options.point_dwell_s.empty()) mapped.point_dwell_s.assign(refined.source_point.size(), 0.0);
    for (std::size_t k = 0; k < refined.source_point.size(); ++k) {
      const std::size_t source = refined.source_point[k];
      if (source < options.point_feed_m_per_s.size()) mapped.point_feed_m_per_s[k] = options.point_feed_m_per_s[source];
      const bool input_point = k + 1 == refined.source_point.size() || refined.source_point[k + 1] != source;
      if (input_point && source < options.point_dwell_s.size()) mapped.point_dwell_s[k] = options.point_dwell_s[source];
    }
    plan = plan_refined_path(machine, refined.path, mapped);
  } else {
    plan = plan_refined_path(machine, refined.path, options);
  }
  plan.points_added = added;
  if (!refined.unmet.empty()) plan.notes.push_back(refined.unmet);
  plan.path = std::move(refined.path);
  if (!options.profile_only) {
    const kinematics::PathKinematics& planned = plan.path;
    // Path fidelity on the set points: paths with fitted derivatives only. Rapids are not held
    // to their line (no point is added on them: their end is an input point).
    const bool check_fidelity = planned.derivatives_fitted && planned.s_m.size() >= 3;
    std::vector<bool> free_end;
    if (check_fidelity && options.rapid_end.size() == path.s_m.size()) {
      free_end.resize(refined.source_point.size());
      for (std::size_t k = 0; k < free_end.size(); ++k) free_end[k] = options.rapid_end[refined.source_point[k]];
    }
    PathDeviation d;
    if (options.keep_setpoints) {
      check_travel(machine, planned, plan.setpoints);
      if (check_fidelity) d = pose_deviation(machine, planned, plan.setpoints.s_m, plan.setpoints.q, free_end);
    } else {
      // One pass over the set points, window by window from the plan (neither check needs
      // neighbours).
      TravelCheck travel(machine);
      std::optional<PoseDeviationTracker> deviation;
      if (check_fidelity) deviation.emplace(machine, planned, free_end);
      SetPointGenerator generator(plan);
      SetPoints window;
      VectorXd column;
      for (std::size_t first = 0; first < generator.size(); first += options.check_window_samples) {
        generator.fill(first, options.check_window_samples, window);
        travel.add(window);
        if (!deviation) continue;
        for (std::size_t k = 0; k < window.s_m.size(); ++k) {
          column = window.q.col(idx(k));
          deviation->add(window.s_m[k], column);
        }
      }
      travel.finish(planned);
      if (deviation) d = deviation->result();
    }
    if (check_fidelity) {
      if (refined.deviation.tip_m > d.tip_m) {
        d.tip_m = refined.deviation.tip_m, d.tip_s_m = refined.deviation.tip_s_m, d.tip_point = refined.deviation.tip_point;
      }
      d.axis_rad = std::max(d.axis_rad, refined.deviation.axis_rad);
      plan.path_fidelity_checked = true;
      plan.path_deviation_max_m = d.tip_m;
      plan.path_deviation_s_m = d.tip_s_m;
      plan.path_deviation_block = path_point_label(planned, d.tip_point);
      plan.path_axis_deviation_max_rad = d.axis_rad;
    }
  }
  if (!options.keep_setpoints) plan.setpoints = SetPoints{plan.setpoints.period_s, {}, {}, {}};
  return plan;
}

namespace {

FeedratePlan plan_refined_path(const kinematics::MachineModel& machine, const kinematics::PathKinematics& path,
                               const FeedrateOptions& options) {
  const PathSpline spline(path);
  const std::size_t axes = machine.axes.size();
  if (static_cast<std::size_t>(path.q.rows()) != axes) {
    throw InputError("feedrate interpolation: the path has " + std::to_string(path.q.rows()) +
                     " axes, the machine " + std::to_string(axes));
  }
  const bool dynamic = options.method == FeedrateMethod::dynamic;
  FeedratePlan plan;
  plan.limits = limit_values(machine, options);
  const double period = options.period_s > 0.0 ? options.period_s : machine.interpolation_period_s;
  if (!(period > 0.0)) throw InputError("the machine's interpolation period must be > 0");
  std::unique_ptr<kinematics::DynamicsModel> dyn_model;
  std::unique_ptr<kinematics::DynamicsData> dyn_data;
  if (dynamic) {
    dyn_model = std::make_unique<kinematics::DynamicsModel>(machine);
    dyn_data = std::make_unique<kinematics::DynamicsData>(*dyn_model);
  }

  // ---- the constrained axes and their rows.
  Problem p;
  p.axes = axes;
  const auto& L = plan.limits;
  std::vector<std::size_t> axes2, axes3;
  for (std::size_t j = 0; j < axes; ++j) {
    if ((dynamic ? L[j].torque_N_m : L[j].acceleration) > 0.0) axes2.push_back(j);
    if (options.third_order && (dynamic ? L[j].torque_rate_N_m_per_s : L[j].jerk) > 0.0) axes3.push_back(j);
    if (!((dynamic ? L[j].torque_N_m : L[j].acceleration) > 0.0)) {
      plan.notes.push_back("axis " + machine.axes[j].name + ": no " +
                           (dynamic ? "torque" : "acceleration") + " limit");
    }
  }
  p.n2 = axes2.size();
  p.n3 = axes3.size();
  const kinematics::PathTorqueCoefficients no_coefficients;  // kinematic mode (a reference, not a copy per row)
  // The second- and third-order rows r where the spline's derivatives are d (and, dynamic, the
  // path torque coefficients c).
  auto row2 = [&](const kinematics::PathTorqueCoefficients& c, const EndData& d, std::size_t r) {
    const Index j = idx(axes2[r]);
    return dynamic ? Row2{c.a(j), c.b(j), c.c(j), c.d(j), c.e(j), L[axes2[r]].torque_N_m, static_cast<int>(j)}
                   : Row2{d.q_s(j), d.q_ss(j), 0, 0, 0, L[axes2[r]].acceleration, static_cast<int>(j)};
  };
  auto row3 = [&](const kinematics::PathTorqueCoefficients& c, const EndData& d, std::size_t r) {
    const Index j = idx(axes3[r]);
    const AxisLimitValues& limit = L[axes3[r]];
    if (dynamic) {
      return Row3{c.a(j), c.a_s(j) + 2.0 * c.b(j), c.b_s(j), c.c_s(j), c.d_s(j), c.d(j),
                  limit.torque_rate_N_m_per_s, static_cast<int>(j)};
    }
    return Row3{d.q_s(j), 3.0 * d.q_ss(j), d.q_sss(j), 0, 0, 0, limit.jerk, static_cast<int>(j)};
  };
  // Spline derivatives (and, dynamic, the path torque coefficients) at sigma on spline segment
  // `segment`.
  auto evaluate_at = [&](std::size_t segment, double sigma, EndData& d) {
    spline.evaluate(segment, sigma, &d.q, &d.q_s, &d.q_ss, &d.q_sss);
    if (dynamic) {
      kinematics::path_torque_coefficients(*dyn_model, *dyn_data, d.q, d.q_s, d.q_ss, d.q_sss,
                                           options.effects, options.third_order);
    }
  };
  // The distance [m] over which the time-optimal start from rest at spline segment `segment`,
  // sigma (or the stop there), runs at constant jerk before it reaches the acceleration it can
  // hold (detail::RestLimits; an estimate for the grid spacing only). 0 without third-order
  // rows.
  std::vector<Row2> rest_rows2(p.n2);
  std::vector<Row3> rest_rows3(p.n3);
  auto ramp_distance_m = [&](std::size_t segment, double sigma) {
    if (p.n3 == 0) return 0.0;
    EndData d;
    evaluate_at(segment, sigma, d);
    const auto& c = dynamic ? dyn_data->coefficients : no_coefficients;
    for (std::size_t r = 0; r < p.n2; ++r) rest_rows2[r] = row2(c, d, r);
    for (std::size_t r = 0; r < p.n3; ++r) rest_rows3[r] = row3(c, d, r);
    return detail::rest_limits(rest_rows2.data(), p.n2, rest_rows3.data(), p.n3).ramp_distance_m();
  };

  // ---- grid: every path point, long segments subdivided (finer near stops, GridRefinement);
  // stops at corners and ends.
  const double length = spline.length_m();
  const double max_step = options.max_grid_step_m > 0.0 ? options.max_grid_step_m : length / 4000.0;
  std::vector<bool> corner_point(path.s_m.size(), false);
  for (const auto& c : path.corners) corner_point[c.point] = true;
  corner_point.front() = corner_point.back() = true;
  // A dwell holds the point at rest: it is a stop.
  const auto dwell_at = [&](std::size_t i) { return options.point_dwell_s.empty() ? 0.0 : options.point_dwell_s[i]; };
  for (std::size_t i = 0; i < path.s_m.size(); ++i) {
    if (dwell_at(i) > 0.0) corner_point[i] = true;
  }
  // Stretch lengths in path segments, to keep at least 4 grid segments per stretch.
  std::vector<std::size_t> stretch_segments(path.s_m.size(), 0);
  {
    std::size_t first = 0;
    for (std::size_t i = 1; i < path.s_m.size(); ++i) {
      if (corner_point[i]) {
        for (std::size_t m = first; m < i; ++m) stretch_segments[m] = i - first;
        first = i;
      }
    }
  }
  // Per path segment, the stops that bound its stretch (path point indices) and the ramp
  // distances there (see GridRefinement).
  std::vector<std::size_t> stretch_first(path.s_m.size(), 0), stretch_last(path.s_m.size(), 0);
  std::vector<double> ramp_out(path.s_m.size(), 0.0), ramp_in(path.s_m.size(), 0.0);
  {
    std::size_t first = 0;
    for (std::size_t i = 1; i < path.s_m.size(); ++i) {
      if (!corner_point[i]) continue;
      for (std::size_t m = first; m < i; ++m) stretch_first[m] = first, stretch_last[m] = i;
      ramp_out[first] = ramp_distance_m(first, 0.0);
      ramp_in[i] = ramp_distance_m(i - 1, path.s_m[i] - path.s_m[i - 1]);
      first = i;
    }
  }
  p.s.push_back(0.0);
  p.stop.push_back(true);
  std::vector<double> grid_dwell_s = {dwell_at(0)};  // per grid point
  std::vector<double> cuts;
  for (std::size_t i = 0; i + 1 < path.s_m.size(); ++i) {
    const double h = path.s_m[i + 1] - path.s_m[i];
    std::size_t pieces = static_cast<std::size_t>(std::ceil(h / max_step - 1e-9));
    pieces = std::max<std::size_t>(pieces, 1);
    if (stretch_segments[i] < 4) pieces = std::max<std::size_t>(pieces, 4 / stretch_segments[i] + 1);
    const GridRefinement refinement{path.s_m[stretch_first[i]], ramp_out[stretch_first[i]],
                                    path.s_m[stretch_last[i]], ramp_in[stretch_last[i]], max_step};
    refinement.cuts(path.s_m[i], path.s_m[i + 1], cuts);
    if (cuts.size() + 1 < pieces) {  // uniform pieces
      cuts.clear();
      for (std::size_t m = 1; m < pieces; ++m) cuts.push_back(h * static_cast<double>(m) / static_cast<double>(pieces));
    }
    cuts.push_back(h);
    double sigma_start = 0.0;
    for (std::size_t m = 0; m < cuts.size(); ++m) {
      p.seg.push_back(i);
      p.sigma0.push_back(sigma_start);
      const bool last = m + 1 == cuts.size();
      p.s.push_back(last ? path.s_m[i + 1] : path.s_m[i] + cuts[m]);
      p.stop.push_back(last && corner_point[i + 1]);
      grid_dwell_s.push_back(last ? dwell_at(i + 1) : 0.0);
      sigma_start = cuts[m];
    }
  }
  const std::size_t points = p.s.size();
  const std::size_t segments = points - 1;

  // ---- rows at both ends of every grid segment.
  p.r2.resize(points * p.n2);
  p.incoming.assign(points, -1);
  std::size_t stops_with_incoming = 0;
  for (std::size_t i = 1; i < points; ++i) {
    if (p.stop[i]) p.incoming[i] = static_cast<long>(stops_with_incoming++);
  }
  p.r2_in.resize(stops_with_incoming * p.n2);
  p.r2mid.resize(segments * p.n2);
  p.r3.resize(2 * segments * p.n3);
  p.r3mid.resize(segments * p.n3);
  p.cap_end.assign(2 * segments, kInf);
  p.cap_mid.assign(segments, kInf);
  auto feed_of_segment = [&](std::size_t k) {
    if (options.feed_m_per_s > 0.0) return options.feed_m_per_s;
    const std::size_t point = p.seg[k] + 1;
    if (point < options.point_feed_m_per_s.size() && options.point_feed_m_per_s[point] > 0.0) {
      return options.point_feed_m_per_s[point];
    }
    return kInf;
  };
  for (auto& v : plan.profile.sd_lim_by_kind) v.assign(points, kInf);
  for (auto& v : plan.profile.axis_by_kind) v.assign(points, -1);
  EndData e, e_right;  // e_right: at the previous segment's right end
  std::vector<double> sd3_max(p.n3, kInf);  // per third-order row at the current end: its sd_lim (sdd = sddd = 0)
  std::vector<long> row3_of_axis(axes, -1);
  for (std::size_t r = 0; r < p.n3; ++r) row3_of_axis[axes3[r]] = static_cast<long>(r);
  kinematics::PathTorqueCoefficients c_right;
  // The x cap of the feed and the axis velocities on grid segment k where the derivatives are d.
  auto speed_cap = [&](std::size_t k, const EndData& d) {
    const double feed = feed_of_segment(k);
    double cap = feed * feed;
    for (std::size_t j = 0; j < axes; ++j) {
      const double qs = std::abs(d.q_s(idx(j)));
      if (L[j].velocity > 0.0 && qs > 0.0) cap = std::min(cap, (L[j].velocity / qs) * (L[j].velocity / qs));
    }
    return cap;
  };
  for (std::size_t k = 0; k < segments; ++k) {
    {
      const double sigma = p.sigma0[k] + 0.5 * p.delta(k);
      evaluate_at(p.seg[k], sigma, e);
      const auto& c = dynamic ? dyn_data->coefficients : no_coefficients;
      Row2* rows = p.r2mid.data() + k * p.n2;
      for (std::size_t r = 0; r < p.n2; ++r) rows[r] = row2(c, e, r);
      Row3* rows3 = p.r3mid.data() + k * p.n3;
      for (std::size_t r = 0; r < p.n3; ++r) rows3[r] = row3(c, e, r);
      p.cap_mid[k] = speed_cap(k, e);
    }
    for (int end = 0; end < 2; ++end) {
      const double sigma = p.sigma0[k] + (end == 0 ? 0.0 : p.delta(k));
      // The spline's own derivatives, q_sss included: the rows then bound what the set points
      // (on the same spline) really do; see PathSpline. The left end is the previous segment's
      // right end where both lie on one polynomial of the spline (or, in second order, where
      // q_sss does not matter and the spline is C2 there: not at a corner).
      const bool shared = end == 0 && k > 0 && !p.stop[k] && (p.seg[k] == p.seg[k - 1] || !options.third_order);
      if (shared) {
        e = e_right;
        if (dynamic) dyn_data->coefficients = c_right;
      } else {
        evaluate_at(p.seg[k], sigma, e);
      }
      if (end == 1) {
        e_right = e;
        if (dynamic) c_right = dyn_data->coefficients;
      }
      const auto& c = dynamic ? dyn_data->coefficients : no_coefficients;
      const std::size_t point = k + static_cast<std::size_t>(end);
      Row2* rows2 = end == 1 && p.incoming[point] >= 0
                        ? p.r2_in.data() + static_cast<std::size_t>(p.incoming[point]) * p.n2
                        : p.r2.data() + point * p.n2;
      Row3* rows3 = p.r3.data() + (2 * k + static_cast<std::size_t>(end)) * p.n3;
      for (std::size_t r = 0; r < p.n2; ++r) rows2[r] = row2(c, e, r);
      for (std::size_t r = 0; r < p.n3; ++r) rows3[r] = row3(c, e, r);
      const double feed = feed_of_segment(k);
      double cap = speed_cap(k, e);
      // Third order: the paper's sd_lim for jerk / torque rate (sdd = sddd = 0) caps x too, so
      // that the second-order profile the third-order passes steer by already slows down where
      // sd^3 q_sss (or its torque-rate counterpart) alone reaches the limit.
      // (At a shared end, the rows and so their sd_max are the previous right end's.)
      for (std::size_t r = 0; r < p.n3; ++r) {
        const Row3& row = rows3[r];
        if (!shared) sd3_max[r] = detail::first_exit(0.0, row.W, row.V, row.S, row.L);
        if (std::isfinite(sd3_max[r])) cap = std::min(cap, sd3_max[r] * sd3_max[r]);
      }
      p.cap_end[2 * k + static_cast<std::size_t>(end)] = cap;

      // sd_lim (Eq. 1-2, 7-9) at the point where this end is the left end (and the last point).
      if (end == 1 && k + 1 != segments) continue;
      auto put = [&](ConstraintKind kind, double value, int axis) {
        auto& slot = plan.profile.sd_lim_by_kind[static_cast<std::size_t>(kind)][point];
        if (value < slot) {
          slot = value;
          plan.profile.axis_by_kind[static_cast<std::size_t>(kind)][point] = axis;
        }
      };
      put(ConstraintKind::feed, feed, -1);
      for (std::size_t j = 0; j < axes; ++j) {
        const Index jj = idx(j);
        const int a = static_cast<int>(j);
        const double qs = std::abs(e.q_s(jj)), qss = std::abs(e.q_ss(jj)), qsss = std::abs(e.q_sss(jj));
        if (L[j].velocity > 0.0 && qs > 0.0) put(ConstraintKind::velocity, L[j].velocity / qs, a);
        if (!dynamic) {
          if (L[j].acceleration > 0.0 && qss > 0.0) put(ConstraintKind::acceleration, std::sqrt(L[j].acceleration / qss), a);
          if (options.third_order && L[j].jerk > 0.0 && qsss > 0.0) put(ConstraintKind::jerk, std::cbrt(L[j].jerk / qsss), a);
        } else {
          if (L[j].torque_N_m > 0.0) {
            put(ConstraintKind::torque, detail::first_exit(c.c(jj) + c.e(jj), c.d(jj), c.b(jj), 0.0, L[j].torque_N_m), a);
          }
          if (options.third_order && L[j].torque_rate_N_m_per_s > 0.0) {
            // The row's own polynomial (row3: W = c_s, V = d_s, S = b_s), solved just above.
            put(ConstraintKind::torque_rate, sd3_max[static_cast<std::size_t>(row3_of_axis[j])], a);
          }
        }
      }
    }
  }
  FeedrateProfile& prof = plan.profile;
  prof.s_m = p.s;
  prof.stop = p.stop;
  prof.sd_lim.assign(points, kInf);
  prof.limiting_kind.assign(points, ConstraintKind::feed);
  prof.limiting_axis.assign(points, -1);
  for (std::size_t i = 0; i < points; ++i) {
    for (int kind = 0; kind < kConstraintKindCount; ++kind) {
      const double v = prof.sd_lim_by_kind[static_cast<std::size_t>(kind)][i];
      if (v < prof.sd_lim[i]) {
        prof.sd_lim[i] = v;
        prof.limiting_kind[i] = static_cast<ConstraintKind>(kind);
        prof.limiting_axis[i] = prof.axis_by_kind[static_cast<std::size_t>(kind)][i];
      }
    }
  }
  for (std::size_t i = 0; i + 1 < points; ++i) {
    const double a = prof.sd_lim[i], b = prof.sd_lim[i + 1];
    plan.lower_bound_s += 0.5 * (p.s[i + 1] - p.s[i]) * (1.0 / std::max(a, 1e-300) + 1.0 / std::max(b, 1e-300));
  }
  if (!std::isfinite(plan.lower_bound_s)) {
    throw InputError("feedrate interpolation: no limit bounds the feed (no feed, no axis "
                     "velocity limit): give a feed");
  }

  if (options.profile_only) return plan;

  p.cap_pt.assign(points, kInf);
  for (std::size_t k = 0; k < segments; ++k) {
    p.cap_pt[k] = std::min(p.cap_pt[k], p.cap_end[2 * k]);
    p.cap_pt[k + 1] = std::min(p.cap_pt[k + 1], p.cap_end[2 * k + 1]);
  }
  for (std::size_t i = 0; i < points; ++i) {
    if (p.stop[i]) p.cap_pt[i] = 0.0;
  }

  // ---- plan, check the set points, slow down where needed, plan again.
  std::vector<double> slow(points, 1.0), cap(points), x2(points), u2(points), controllable(points);
  detail::ThirdOrderProfile third;
  std::vector<std::pair<std::size_t, std::size_t>> stretches;
  {
    std::size_t first = 0;
    for (std::size_t i = 1; i < points; ++i) {
      if (p.stop[i]) {
        stretches.emplace_back(first, i);
        first = i;
      }
    }
  }
  Executed ex;
  for (int round = 0;; ++round) {
    bool third_order_failed = false;
    for (std::size_t i = 0; i < points; ++i) cap[i] = p.cap_pt[i] * slow[i];
    const SecondOrder second(p, cap);
    ex.x.assign(points, 0.0);
    ex.sdd_l.assign(segments, 0.0);
    ex.sdd_r.assign(segments, 0.0);
    ex.dt.assign(segments, 0.0);
    ex.linear_law.assign(segments, 0);
    for (const auto& [k0, k1] : stretches) {
      const auto failed = second.solve(k0, k1, x2, u2, controllable);
      if (failed) {
        const std::size_t k = *failed;
        std::string axis_name;
        double worst = 0.0;
        for (int end = 0; end < 2; ++end) {
          const Row2* rows = p.rows2(k, end);
          for (std::size_t r = 0; r < p.n2; ++r) {
            const double ratio = std::abs(value2(rows[r], 0.0, 0.0)) / rows[r].L;
            if (ratio > worst) {
              worst = ratio;
              axis_name = machine.axes[static_cast<std::size_t>(rows[r].axis)].name;
            }
          }
        }
        throw InfeasibleError("feedrate interpolation: no admissible motion at s = " +
                              format_double(p.s[k] * 1e3) + " mm" +
                              (axis_name.empty() ? std::string()
                                                 : ": axis " + axis_name + " needs " +
                                                       format_double(worst) +
                                                       " times its limit at rest"));
      }
      for (std::size_t k = k0; k < k1; ++k) {
        ex.x[k] = x2[k];
        ex.sdd_l[k] = ex.sdd_r[k] = u2[k];
        const double den = std::sqrt(x2[k]) + std::sqrt(x2[k + 1]);
        ex.dt[k] = 2.0 * p.delta(k) / std::max(den, 1e-300);
      }
      ex.x[k1] = 0.0;
      x2[k1] = 0.0;
    }
    if (p.n3 > 0) {
      // Third order under the second-order profile (an upper bound), every stretch at once.
      if (!detail::plan_third_order(p, stretches, x2, detail::middle_c1_bounds(p, cap, slow), third)) {
        if (round + 1 >= options.max_verification_rounds) {
          throw InfeasibleError(
              "feedrate interpolation: no jerk/torque-rate admissible profile found (the linear "
              "programme failed)");
        }
        for (std::size_t i = 0; i < points; ++i) slow[i] *= 0.7;
        third_order_failed = true;
      } else {
        for (std::size_t k = 0; k < segments; ++k) {
          ex.x[k] = third.x[k];
          ex.sdd_l[k] = third.u[k];
          ex.sdd_r[k] = third.u[k + 1];
          const double delta = p.delta(k);
          if (third.dt[k] >= 0.0) {  // constant jerk from or to a stop: the quintic is exact
            ex.dt[k] = third.dt[k];
            continue;
          }
          const double slope = (third.u[k + 1] - third.u[k]) / delta;
          ex.dt[k] = detail::gauss_time(delta, third.x[k], third.u[k], slope);
          const detail::LinearAccelerationLaw law{std::sqrt(third.x[k]), third.u[k], slope};
          if (const auto exact = law.duration(delta, ex.dt[k])) {
            ex.dt[k] = *exact;
            ex.linear_law[k] = 1;
          }
        }
        ex.x[segments] = 0.0;
      }
    }
    if (third_order_failed) {
      ++plan.slowdown_rounds;
      continue;
    }
    ex.t.assign(points, grid_dwell_s[0]);
    for (std::size_t k = 0; k < segments; ++k) ex.t[k + 1] = ex.t[k] + ex.dt[k] + grid_dwell_s[k + 1];

    // Set points: the law sampled at the period, q from the spline.
    SetPoints& sp = plan.setpoints;
    sp.period_s = period;
    const double total = ex.t.back();
    if (!(std::isfinite(total) && total / period < 1e8)) {
      throw InfeasibleError("feedrate interpolation: the planned motion takes " +
                            format_double(total) + " s (a near stop inside a stretch)");
    }
    const auto samples = static_cast<std::size_t>(std::ceil(total / period - 1e-9)) + 1;
    SetPointLaw& law = plan.law;
    law.period_s = period;
    law.duration_s = total;
    law.samples = samples;
    law.grid_s_m = p.s;
    law.spline_segment = p.seg;
    law.spline_sigma0_m = p.sigma0;
    law.x = ex.x;
    law.sdd_start = ex.sdd_l;
    law.sdd_end = ex.sdd_r;
    law.linear_law = ex.linear_law;
    law.dt_s = ex.dt;
    law.t_s = ex.t;
    plan.duration_s = total;
    SampleChecker checker(dyn_model.get(), plan.limits, options, period, idx(axes), samples);
    SlowDownSpans slowdown(p.s, dynamic);
    if (options.keep_setpoints) {
      // The whole set, kept in the plan.
      sp.t_s.resize(samples);
      sp.s_m.resize(samples);
      sp.q.resize(idx(axes), idx(samples));
      VectorXd qv;
      std::size_t cursor = 0;
      for (std::size_t n = 0; n < samples; ++n) {
        std::size_t grid_segment = 0;
        double sigma = 0.0;
        law.locate(n, cursor, grid_segment, sigma);
        sp.t_s[n] = law.sample_t_s(n);
        sp.s_m[n] = sp.t_s[n] >= total ? p.s.back() : p.s[grid_segment] + sigma;
        spline.evaluate(p.seg[grid_segment], p.sigma0[grid_segment] + sigma, &qv, nullptr, nullptr, nullptr);
        sp.q.col(idx(n)) = qv;
      }
      // Checked as a whole (check_samples runs a SampleChecker of its own); its results go
      // where the windowed branch leaves them.
      const SampleCheck sc = check_samples(machine, dyn_model.get(), plan.limits, options, sp);
      checker.check = sc.check;
      checker.worst_axis = sc.worst_axis;
      checker.worst_kind = sc.worst_kind;
      checker.worst_s_m = sp.s_m[sc.worst_sample];
      checker.worst_t_s = sp.t_s[sc.worst_sample];
      for (std::size_t n = 0; n < samples; ++n) {
        slowdown.add(sc.worst[n], sc.order[n], sp.s_m[n >= SlowDownSpans::kBefore ? n - SlowDownSpans::kBefore : 0],
                     sp.s_m[std::min(n + SlowDownSpans::kAfter, samples - 1)]);
      }
    } else {
      // Window by window from the law: each window of check_window_samples set points with the
      // neighbours the slow-down span needs (5 before, 4 after; they cover the differences'
      // 2 on either side), generated again for the next window.
      const std::size_t window = options.check_window_samples;
      SetPoints part;
      std::size_t cursor = 0;
      for (std::size_t first = 0; first < samples; first += window) {
        const std::size_t last = std::min(first + window, samples);  // checked: [first, last)
        const std::size_t lo = first >= SlowDownSpans::kBefore ? first - SlowDownSpans::kBefore : 0;
        const std::size_t hi = std::min(last + SlowDownSpans::kAfter, samples);
        fill_setpoints(law, spline, cursor, lo, hi - lo, part);
        const auto column = [&](std::size_t i) { return part.q.col(idx(i - lo)); };
        for (std::size_t n = first; n < last; ++n) {
          checker.check_sample(n, column, part.s_m[n - lo], part.t_s[n - lo]);
          slowdown.add(checker.sample_worst, checker.sample_order,
                       part.s_m[(n >= SlowDownSpans::kBefore ? n - SlowDownSpans::kBefore : 0) - lo],
                       part.s_m[std::min(n + SlowDownSpans::kAfter, samples - 1) - lo]);
        }
      }
    }
    plan.check = checker.check;
    if (!slowdown.violated) break;
    if (round + 1 >= options.max_verification_rounds) {
      throw InfeasibleError("feedrate interpolation: the set points still exceed a limit by " +
                            format_double((checker.check.worst() - 1.0) * 100.0) + " % after " +
                            std::to_string(round + 1) + " slow-down rounds (axis " +
                            machine.axes[static_cast<std::size_t>(checker.worst_axis)].name + ", " +
                            std::string(constraint_name(checker.worst_kind)) + ", at s = " +
                            format_double(checker.worst_s_m * 1e3) + " mm, t = " +
                            format_double(checker.worst_t_s) + " s)");
    }
    const std::vector<double>& factor = slowdown.factor;
    for (std::size_t i = 0; i < points; ++i) slow[i] *= factor[i];
    ++plan.slowdown_rounds;
  }

  prof.t_s = ex.t;
  prof.sd.resize(points);
  prof.sdd.assign(points, 0.0);
  prof.sd_cap.resize(points);
  for (std::size_t i = 0; i < points; ++i) {
    prof.sd[i] = std::sqrt(ex.x[i]);
    if (i < segments) prof.sdd[i] = ex.sdd_l[i];
    prof.sd_cap[i] = std::min(prof.sd_lim[i], std::sqrt(p.cap_pt[i] * slow[i]));
    if (p.stop[i]) prof.sd_cap[i] = 0.0;
  }
  return plan;
}

}  // namespace

}  // namespace vmsim::planner
