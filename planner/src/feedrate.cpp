// Feedrate interpolation (see feedrate.hpp for the method and its conventions).
#include "vmsim/planner/feedrate.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <optional>
#include <string>

#include "vmsim/common/errors.hpp"
#include "vmsim/common/files.hpp"

namespace vmsim::planner {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
/// Third-order passes: within this relative distance below the cap, follow the cap's slope
/// rather than accelerate into it (arriving with a larger slope cannot be undone in time).
constexpr double kCapBand = 1e-4;
/// Third-order passes never go below this share of the cap in x (0.1 % in feed): never (nearly)
/// stop inside a stretch, where the time would be unbounded.
constexpr double kFloor = 1e-6;
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

double value2(const Row2& r, double x, double u) {
  return r.A * u + r.B * x + r.C + r.D * std::sqrt(std::max(x, 0.0)) + r.E;
}
double value3(const Row3& r, double x, double u, double sddd) {
  const double sd = std::sqrt(std::max(x, 0.0));
  return r.P * sddd + sd * (r.R * u + r.S * x + r.W) + r.V * x + r.Z * u;
}

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
    double a = (lo_r - c) / beta, b = (hi_r - c) / beta;
    if (beta < 0) std::swap(a, b);
    lo = std::max(lo, a);
    hi = std::min(hi, b);
  }
  bool empty() const { return bad_constant || lo > hi + 1e-12 * (std::abs(lo) + std::abs(hi)) + 1e-300; }
};

/// Smallest sd > 0 at which |p0 + p1 sd + p2 sd^2 + p3 sd^3| reaches L (0 when |p0| > L already;
/// +inf when never).
double first_exit(double p0, double p1, double p2, double p3, double L) {
  if (std::abs(p0) > L) return 0.0;
  const double p[4] = {p0, p1, p2, p3};
  int degree = 3;
  while (degree > 0 && p[degree] == 0.0) --degree;
  if (degree == 0) return kInf;
  auto f = [&](double s) { return p0 + s * (p1 + s * (p2 + s * p3)); };
  double bound = 0.0;
  for (int i = 0; i < degree; ++i) bound = std::max(bound, std::abs(p[i]) + (i == 0 ? L : 0.0));
  bound = 1.0 + bound / std::abs(p[degree]);
  // Monotone pieces between the critical points.
  std::vector<double> breaks{0.0};
  const double c1 = p1, c2 = 2.0 * p2, c3 = 3.0 * p3;
  if (c3 != 0.0) {
    const double disc = c2 * c2 - 4.0 * c3 * c1;
    if (disc >= 0.0) {
      const double r = std::sqrt(disc);
      for (double root : {(-c2 - r) / (2.0 * c3), (-c2 + r) / (2.0 * c3)}) {
        if (root > 0.0 && root < bound) breaks.push_back(root);
      }
    }
  } else if (c2 != 0.0) {
    const double root = -c1 / c2;
    if (root > 0.0 && root < bound) breaks.push_back(root);
  }
  std::sort(breaks.begin(), breaks.end());
  breaks.push_back(bound);
  for (std::size_t i = 0; i + 1 < breaks.size(); ++i) {
    const double a = breaks[i], b = breaks[i + 1];
    const double fb = f(b);
    if (std::abs(fb) < L) continue;
    const double target = fb >= L ? L : -L;
    double lo = a, hi = b;  // |f(lo)| <= L, f crosses target in (lo, hi]
    for (int it = 0; it < 200 && hi - lo > 1e-15 * hi; ++it) {
      const double mid = 0.5 * (lo + hi);
      const double fm = f(mid);
      if ((target > 0 && fm >= L) || (target < 0 && fm <= -L)) {
        hi = mid;
      } else {
        lo = mid;
      }
    }
    return lo;
  }
  return kInf;
}

// ---------------------------------------------------------------------------------------------
// The planning problem on the grid

struct Problem {
  std::size_t axes = 0;
  std::vector<double> s;         // grid points
  std::vector<std::size_t> seg;  // spline segment of each grid segment
  std::vector<double> sigma0;    // its start within the spline segment
  std::vector<bool> stop;        // exact stop at the point
  std::size_t n2 = 0, n3 = 0;    // rows per segment end
  std::vector<Row2> r2;          // ((2 k + end) * n2 + r)
  std::vector<Row2> r2mid;       // (k * n2 + r): at the middle of each segment (second order)
  std::vector<Row3> r3;
  std::vector<double> cap_end;   // x cap at (2 k + end): velocity and feed
  std::vector<double> cap_pt;    // x cap at the points (min over the ends there; 0 at stops)
  std::size_t segments() const { return s.size() - 1; }
  double delta(std::size_t k) const { return s[k + 1] - s[k]; }
  const Row2* rows2mid(std::size_t k) const { return r2mid.data() + k * n2; }
  const Row2* rows2(std::size_t k, int end) const {
    return r2.data() + (2 * k + static_cast<std::size_t>(end)) * n2;
  }
  const Row3* rows3(std::size_t k, int end) const {
    return r3.data() + (2 * k + static_cast<std::size_t>(end)) * n3;
  }
};

struct EndData {  // path derivatives at one segment end
  VectorXd q, q_s, q_ss, q_sss;
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
        double a = (lo_r - alpha * x - gamma) / beta, b = (hi_r - alpha * x - gamma) / beta;
        const double slope = -alpha / beta;
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
// Third order: u continuous, piecewise linear in s; greedy forward pass with a bang-bang search

class ThirdOrder {
 public:
  /// rest_end: the motion stops at k1 (forced last step and a constant-jerk stop segment);
  /// otherwise the pass ends at k1 wherever the greedy steps lead (under the cap).
  /// With rest_end, the last `tail` segments are taken from the cap (the backward pass's own
  /// constant-jerk stop), which the pass must join exactly at k1 - tail.
  ThirdOrder(const Problem& p, std::size_t k0, std::size_t k1, const std::vector<double>& cap,
             const std::vector<double>& target, std::vector<double>& x, std::vector<double>& u,
             std::vector<double>& dt, bool rest_end, std::size_t tail = 0)
      : p_(p), k0_(k0), k1_(k1), last_(rest_end ? k1 - tail : k1), rest_end_(rest_end), cap_(cap),
        target_(target), x_(x), u_(u), dt_(dt) {}

  /// Jerk (sddd) of the rest start; the number of grid segments it covers.
  double start_jerk = 0.0;
  std::size_t analytic_segments = 0;
  /// Where the pass could not continue (when solve() returns false).
  std::size_t failed_at = 0;

  bool solve() {
    failed_at = k0_ + 1;
    if (!rest_start()) return false;
    // The search may go back into the constant-jerk start (its states are exact).
    std::vector<std::size_t> anchors{k0_ + 1};
    if (analytic_segments > 1) anchors.push_back(k0_ + analytic_segments);
    std::size_t i = k0_ + analytic_segments;
    std::vector<double> saved_x, saved_u;
    long long budget = 200LL * static_cast<long long>(k1_ - k0_) + 100000;
    while (i < last_) {
      if (rest_end_ && i + 1 == last_ ? final_step(i) : step(i, Mode::greatest)) {
        ++i;
        continue;
      }
      saved_x.assign(x_.begin() + static_cast<long>(k0_), x_.begin() + static_cast<long>(k1_) + 1);
      saved_u.assign(u_.begin() + static_cast<long>(k0_), u_.begin() + static_cast<long>(k1_) + 1);
      auto restore = [&] {
        std::copy(saved_x.begin(), saved_x.end(), x_.begin() + static_cast<long>(k0_));
        std::copy(saved_u.begin(), saved_u.end(), u_.begin() + static_cast<long>(k0_));
      };
      bool found = false;
      for (std::size_t a = anchors.size(); a-- > 0 && !found;) {
        const std::size_t anchor = anchors[a];
        std::size_t end = 0, track_end = 0;
        restore();
        if (!trial(anchor, i, end, track_end, budget)) continue;
        std::size_t good = anchor, bad = i + 1;
        while (bad - good > 1) {
          const std::size_t mid = good + (bad - good) / 2;
          restore();
          if (trial(mid, i, end, track_end, budget)) good = mid; else bad = mid;
        }
        restore();
        trial(good, i, end, track_end, budget);
        if (good < k0_ + analytic_segments) {
          for (std::size_t m = good - k0_; m < analytic_segments; ++m) dt_[k0_ + m] = -1.0;
          analytic_segments = good - k0_;
        }
        anchors.resize(a + 1);
        if (track_end > anchors.back()) anchors.push_back(track_end);
        i = end;
        found = true;
      }
      if (!found || budget < 0) {
        failed_at = i;
        return false;
      }
    }
    return true;
  }

 private:
  enum class Mode { greatest, track };

  bool rows_ok_at(std::size_t k, int end, double x, double u, double sddd,
                  double tolerance = 1e-9) const {
    const Row2* rows2 = p_.rows2(k, end);
    for (std::size_t r = 0; r < p_.n2; ++r) {
      if (std::abs(value2(rows2[r], x, u)) > rows2[r].L * (1.0 + tolerance)) return false;
    }
    const Row3* rows3 = p_.rows3(k, end);
    for (std::size_t r = 0; r < p_.n3; ++r) {
      if (std::abs(value3(rows3[r], x, u, sddd)) > rows3[r].L * (1.0 + tolerance)) return false;
    }
    return true;
  }

  /// Rest start: s = j t^3 / 6 with the greatest feasible j on the first segment, kept on as
  /// many segments as the rows allow (the constant-jerk start is the time-optimal one there; a
  /// piecewise linear sdd cannot follow sdd ~ s^(1/3) near rest).
  bool rest_start() {
    const std::size_t k = k0_;
    x_[k] = 0.0;
    u_[k] = 0.0;
    auto state = [&](double j, std::size_t point, double& x1, double& u1, double& t1) {
      t1 = std::cbrt(6.0 * (p_.s[point] - p_.s[k]) / j);
      const double sd1 = 0.5 * j * t1 * t1;
      x1 = sd1 * sd1;
      u1 = j * t1;
    };
    auto feasible = [&](double j, std::size_t m) {  // segment k + m under the cubic
      double xa = 0, ua = 0, ta = 0, xb = 0, ub = 0, tb = 0;
      if (m > 0) state(j, k + m, xa, ua, ta);
      state(j, k + m + 1, xb, ub, tb);
      return xb <= cap_[k + m + 1] && rows_ok_at(k + m, 0, xa, ua, j) &&
             rows_ok_at(k + m, 1, xb, ub, j);
    };
    double hi = 1.0;
    while (feasible(hi, 0) && hi < 1e12) hi *= 4.0;
    double lo = 0.0;
    for (int it = 0; it < 80; ++it) {
      const double mid = 0.5 * (lo + hi);
      if (feasible(mid, 0)) lo = mid; else hi = mid;
    }
    if (!(lo > 0.0)) return false;
    start_jerk = lo;
    std::size_t m = 1;
    const std::size_t limit = (last_ > k + 2 ? last_ - k - 2 : 0);
    while (m < limit && feasible(lo, m)) ++m;
    double t_prev = 0.0;
    for (std::size_t i = 1; i <= m; ++i) {
      double t1 = 0;
      state(lo, k + i, x_[k + i], u_[k + i], t1);
      dt_[k + i - 1] = t1 - t_prev;
      t_prev = t1;
    }
    analytic_segments = m;
    return true;
  }

  /// The w-interval for u[k+1] from (x[k], u[k]) with sqrt(x[k+1]) taken as sd_right.
  Interval interval(std::size_t k, double sd_right) const {
    const double delta = p_.delta(k);
    const double xk = x_[k], uk = u_[k];
    const double sd = std::sqrt(xk);
    const double x0 = xk + delta * uk;  // x[k+1] = x0 + delta w
    Interval in;
    const Row2* left2 = p_.rows2(k, 0);
    const Row2* right2 = p_.rows2(k, 1);
    for (std::size_t r = 0; r < p_.n2; ++r) {
      in.add(value2(left2[r], xk, uk), 0.0, -left2[r].L * (1 + 1e-9), left2[r].L * (1 + 1e-9));
      const Row2& row = right2[r];
      in.add(row.B * x0 + row.C + row.D * sd_right + row.E, row.A + row.B * delta, -row.L, row.L);
    }
    const Row3* left3 = p_.rows3(k, 0);
    const Row3* right3 = p_.rows3(k, 1);
    for (std::size_t r = 0; r < p_.n3; ++r) {
      const Row3& a = left3[r];
      in.add(-a.P * sd * uk / delta + sd * (a.R * uk + a.S * xk + a.W) + a.V * xk + a.Z * uk,
             a.P * sd / delta, -a.L, a.L);
      const Row3& b = right3[r];
      in.add(-b.P * sd_right * uk / delta + sd_right * (b.S * x0 + b.W) + b.V * x0,
             b.P * sd_right / delta + sd_right * (b.R + b.S * delta) + b.V * delta + b.Z, -b.L,
             b.L);
    }
    // Never (nearly) stop inside a stretch: a stop there would take an unbounded time.
    const double floor = std::isfinite(cap_[k + 1]) ? std::max(1e-14, kFloor * cap_[k + 1]) : 1e-14;
    in.add(x0, delta, floor, cap_[k + 1]);
    return in;
  }

  bool exact_ok(std::size_t k, double w) const {
    const double delta = p_.delta(k);
    const double x1 = x_[k] + delta * (u_[k] + w);
    if (x1 <= 0.0 || x1 > cap_[k + 1] * (1.0 + 1e-12)) return false;
    const double up = (w - u_[k]) / delta;
    // The rows are linear in w only for a given sqrt(x[k+1]); 1e-6 absorbs the fixed point's
    // residual (the set-point check is exact).
    return rows_ok_at(k, 0, x_[k], u_[k], std::sqrt(x_[k]) * up, 1e-6) &&
           rows_ok_at(k, 1, x1, w, std::sqrt(x1) * up, 1e-6);
  }

  bool step(std::size_t k, Mode mode) {
    const double delta = p_.delta(k);
    if (mode == Mode::greatest && x_[k] >= cap_[k] * (1.0 - kCapBand) && k + 1 < last_ &&
        std::isfinite(cap_[k + 1])) {
      // On the cap: take its next point and slope when the rows allow (the cap is itself a
      // feasible profile when it comes from the backward pass; the mismatch is within the band).
      const double x1 = cap_[k + 1], w = target_[k + 1];
      const double up = (w - u_[k]) / delta;
      if (x1 > 0.0 && rows_ok_at(k, 0, x_[k], u_[k], std::sqrt(x_[k]) * up, 1e-6) &&
          rows_ok_at(k, 1, x1, w, std::sqrt(x1) * up, 1e-6)) {
        u_[k + 1] = w;
        x_[k + 1] = x1;
        last_track_reached_ = false;
        return true;
      }
    }
    double sd_right = std::sqrt(std::max(x_[k], 1e-300));
    double w = 0.0;
    Interval in;
    for (int pass = 0; pass < 8; ++pass) {
      in = interval(k, sd_right);
      if (in.empty()) return false;
      const bool on_cap = x_[k] >= cap_[k] * (1.0 - kCapBand) ||
                          x_[k] + delta * (u_[k] + in.hi) >= cap_[k + 1] * (1.0 - kCapBand);
      if (mode == Mode::track) {
        // Steer towards the cap's slope where the greedy pass failed, or its slope here when
        // steeper (joining a deceleration curve that keeps steepening).
        track_value_ = std::min(track_value_, target_[k + 1]);
        w = std::clamp(track_value_, in.lo, in.hi);
      } else if (on_cap) {
        // Merge onto the cap in two steps: this step's w, then the cap's own slope, land on it.
        double merge = target_[k + 1];
        if (k + 2 <= k1_) {
          const double d2 = p_.delta(k + 1);
          const double cap2 = std::isfinite(cap_[k + 2]) ? cap_[k + 2] : cap_[k + 1];
          merge = (cap2 - x_[k] - delta * u_[k] - d2 * target_[k + 2]) / (delta + d2);
        }
        w = std::clamp(merge, in.lo, in.hi);
      } else {
        w = in.hi;
      }
      const double x1 = x_[k] + delta * (u_[k] + w);
      const double next = std::sqrt(std::max(x1, 0.0));
      if (std::abs(next - sd_right) <= 1e-12 * next && exact_ok(k, w)) break;
      sd_right = next;
    }
    if (!exact_ok(k, w)) {
      // Move the smallest step towards the middle of the interval that makes the rows hold.
      const double mid = 0.5 * (in.lo + in.hi);
      bool ok = false;
      for (int it = 20; it >= 0 && !ok; --it) {
        const double trial_w = w + (mid - w) * std::ldexp(1.0, -it);
        if (exact_ok(k, trial_w)) {
          w = trial_w;
          ok = true;
        }
      }
      if (!ok) return false;
    }
    u_[k + 1] = w;
    x_[k + 1] = x_[k] + delta * (u_[k] + w);
    last_track_reached_ = std::abs(w - track_value_) <= 1e-12 * (1.0 + std::abs(w));
    return true;
  }

  /// The step onto the start of the copied tail: it must land on the cap with its slope.
  bool final_step(std::size_t k) {
    const double delta = p_.delta(k);
    const double x1 = cap_[k + 1], w = target_[k + 1];
    const double landed = x_[k] + delta * (u_[k] + w);
    if (!(x1 > 0.0) || std::abs(landed - x1) > kCapBand * x1) return false;
    const double up = (w - u_[k]) / delta;
    if (!rows_ok_at(k, 0, x_[k], u_[k], std::sqrt(x_[k]) * up, 1e-6) ||
        !rows_ok_at(k, 1, x1, w, std::sqrt(x1) * up, 1e-6)) {
      return false;
    }
    u_[k + 1] = w;
    x_[k + 1] = x1;
    return true;
  }

  /// From the state at k: steer u towards the target as fast as allowed, then greatest steps
  /// until past `beyond` (or the end). `end` = the point reached.
  bool trial(std::size_t k, std::size_t beyond, std::size_t& end, std::size_t& track_end,
             long long& budget) {
    std::size_t i = k;
    bool tracking = true;
    track_end = k;
    // Steer sdd towards the slope of the cap where the greedy pass failed.
    const std::size_t at = std::min(beyond + 1, k1_);
    track_value_ = std::min(target_[beyond], target_[at]);
    while (i < last_ && (i <= beyond || tracking)) {
      --budget;
      if (budget < 0) return false;
      bool ok = false;
      if (rest_end_ && i + 1 == last_) {
        ok = final_step(i);
      } else {
        ok = step(i, tracking ? Mode::track : Mode::greatest);
        if (ok && tracking && last_track_reached_) {
          tracking = false;
          track_end = i + 1;
        }
      }
      if (!ok) return false;
      ++i;
    }
    end = i;
    return true;
  }

  const Problem& p_;
  std::size_t k0_, k1_, last_;
  bool rest_end_;
  const std::vector<double>& cap_;
  const std::vector<double>& target_;
  std::vector<double>& x_;
  std::vector<double>& u_;
  std::vector<double>& dt_;
  bool last_track_reached_ = false;
  double track_value_ = 0.0;
};

/// The stretch [k0, k1] seen from its end: local point i is global point k1 - i; x is the same,
/// u and the odd coefficients change sign (u_local = -u, sddd and u' unchanged).
Problem mirror(const Problem& p, std::size_t k0, std::size_t k1) {
  Problem m;
  m.axes = p.axes;
  m.n2 = p.n2;
  m.n3 = p.n3;
  const std::size_t n = k1 - k0;
  m.s.resize(n + 1);
  for (std::size_t i = 0; i <= n; ++i) m.s[i] = p.s[k1] - p.s[k1 - i];
  m.r2.resize(2 * n * p.n2);
  m.r3.resize(2 * n * p.n3);
  for (std::size_t local = 0; local < n; ++local) {
    const std::size_t k = k1 - 1 - local;
    for (int end = 0; end < 2; ++end) {
      const Row2* from2 = p.rows2(k, 1 - end);
      Row2* to2 = m.r2.data() + (2 * local + static_cast<std::size_t>(end)) * p.n2;
      for (std::size_t r = 0; r < p.n2; ++r) {
        to2[r] = from2[r];
        to2[r].A = -from2[r].A;
      }
      const Row3* from3 = p.rows3(k, 1 - end);
      Row3* to3 = m.r3.data() + (2 * local + static_cast<std::size_t>(end)) * p.n3;
      for (std::size_t r = 0; r < p.n3; ++r) {
        to3[r] = from3[r];
        to3[r].R = -from3[r].R;
        to3[r].Z = -from3[r].Z;
      }
    }
  }
  return m;
}

// ---------------------------------------------------------------------------------------------

double gauss_time(double delta, double x0, double u0, double up) {
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
  std::vector<double> dt;             // per segment
  std::vector<double> t;              // at points
};

}  // namespace

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
  if (!(corner_tolerance_m >= 0.0)) bad("corner_tolerance_m", corner_tolerance_m, "must be >= 0");
  if (corner_tolerance_m > 0.0) {
    bad("corner_tolerance_m", corner_tolerance_m,
        "corner blending is not implemented yet: use 0 (exact stop at corners)");
  }
  for (std::size_t i = 0; i < point_feed_m_per_s.size(); ++i) {
    if (!(point_feed_m_per_s[i] >= 0.0)) {
      bad("point_feed_m_per_s[" + std::to_string(i) + "]", point_feed_m_per_s[i], "must be >= 0");
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

/// Per sample: the worst ratio and the order of the constraint that gave it.
struct SampleCheck {
  SetPointCheck check;
  std::vector<double> worst;  // per sample
  std::vector<int> order;     // 1 velocity, 2 acceleration / torque, 3 jerk / torque rate
};

SampleCheck check_samples(const kinematics::MachineModel& machine,
                          const kinematics::DynamicsModel* dynamics,
                          const std::vector<AxisLimitValues>& limits, const FeedrateOptions& options,
                          const SetPoints& sp) {
  const std::size_t n = sp.t_s.size();
  const Index axes = sp.q.rows();
  const double T = sp.period_s;
  SampleCheck out;
  out.check.ratio = Eigen::MatrixXd::Zero(axes, kConstraintKindCount);
  out.worst.assign(n, 0.0);
  out.order.assign(n, 0);
  if (n == 0) return out;
  auto q = [&](long k) {
    const long clamped = std::clamp(k, 0L, static_cast<long>(n) - 1);
    return sp.q.col(static_cast<Index>(clamped));
  };
  auto note = [&](std::size_t k, Index axis, ConstraintKind kind, double value, double limit, int order) {
    if (!(limit > 0.0)) return;
    const double r = std::abs(value) / limit;
    double& cell = out.check.ratio(axis, static_cast<Index>(kind));
    cell = std::max(cell, r);
    if (r > out.worst[k]) {
      out.worst[k] = r;
      out.order[k] = order;
    }
  };
  const bool dynamic = options.method == FeedrateMethod::dynamic;
  std::unique_ptr<kinematics::DynamicsData> data;
  if (dynamic && dynamics != nullptr) data = std::make_unique<kinematics::DynamicsData>(*dynamics);
  VectorXd qd(axes), qdd(axes), qddd(axes);
  for (std::size_t k = 0; k < n; ++k) {
    const long i = static_cast<long>(k);
    for (Index j = 0; j < axes; ++j) {
      const auto& l = limits[static_cast<std::size_t>(j)];
      note(k, j, ConstraintKind::velocity, (q(i)(j) - q(i - 1)(j)) / T, l.velocity, 1);
      if (k + 1 == n) note(k, j, ConstraintKind::velocity, (q(i + 1)(j) - q(i)(j)) / T, l.velocity, 1);
      if (!dynamic) {
        note(k, j, ConstraintKind::acceleration,
             (q(i + 1)(j) - 2.0 * q(i)(j) + q(i - 1)(j)) / (T * T), l.acceleration, 2);
        if (options.third_order) {
          note(k, j, ConstraintKind::jerk,
               (q(i + 1)(j) - 3.0 * q(i)(j) + 3.0 * q(i - 1)(j) - q(i - 2)(j)) / (T * T * T),
               l.jerk, 3);
          if (k + 1 == n) {
            note(k, j, ConstraintKind::jerk,
                 (q(i + 2)(j) - 3.0 * q(i + 1)(j) + 3.0 * q(i)(j) - q(i - 1)(j)) / (T * T * T),
                 l.jerk, 3);
          }
        }
      }
    }
    if (dynamic && data) {
      qd = (q(i + 1) - q(i - 1)) / (2.0 * T);
      qdd = (q(i + 1) - 2.0 * q(i) + q(i - 1)) / (T * T);
      qddd = (q(i + 2) - 2.0 * q(i + 1) + 2.0 * q(i - 1) - q(i - 2)) / (2.0 * T * T * T);
      kinematics::actuator_torque_terms(*dynamics, *data, q(i), qd, qdd, qddd, options.effects);
      for (Index j = 0; j < axes; ++j) {
        const auto& l = limits[static_cast<std::size_t>(j)];
        double torque = data->terms.total_torque_N_m(j);
        const double before = q(i)(j) - q(i - 1)(j), after = q(i + 1)(j) - q(i)(j);
        if (options.effects.contains(kinematics::Effect::friction) && (before == 0.0) != (after == 0.0)) {
          // A stop or a start inside the stencil (path ends, exact stops at corners): the
          // difference mixes motion at the torque limit with rest, where the dry friction
          // vanishes (sign(0) = 0); the torque there is checked by the rows at the stop itself.
          continue;
        }
        if (options.effects.contains(kinematics::Effect::friction) && before * after < 0.0) {
          // A velocity reversal inside the stencil: the dry friction jumps there (Sec. 3.3).
          // The second difference is the mean of the acceleration under the hat kernel
          // (1 - |t|/T)/T on [-T, T]; the dry friction term is given the same mean, with the
          // reversal placed where the linearly interpolated velocity crosses zero.
          const double rest = torque - data->terms.torque_N_m(j, static_cast<Index>(kinematics::Effect::friction));
          const double viscous = dynamics->friction_viscous_N_m_s(j) * qd(j);
          const double dry = dynamics->friction_dry_N_m(j);
          const double f = before / (before - after);  // in [0, 1]
          const double tc = (f - 0.5);                    // crossing time / T, in [-1/2, 1/2]
          const double H = tc <= 0.0 ? 0.5 * (1.0 + tc) * (1.0 + tc) : 1.0 - 0.5 * (1.0 - tc) * (1.0 - tc);
          const double sign_before = before > 0 ? 1.0 : (before < 0 ? -1.0 : (after > 0 ? -1.0 : 1.0));
          torque = rest + viscous + dry * sign_before * (2.0 * H - 1.0);
        }
        note(k, j, ConstraintKind::torque, torque, l.torque_N_m, 2);
        if (options.third_order) {
          note(k, j, ConstraintKind::torque_rate, data->terms.total_torque_rate_N_m_per_s(j),
               l.torque_rate_N_m_per_s, 3);
        }
      }
    }
  }
  (void)machine;
  return out;
}

}  // namespace

SetPointCheck check_setpoints(const kinematics::MachineModel& machine,
                              const kinematics::DynamicsModel* dynamics,
                              const std::vector<AxisLimitValues>& limits,
                              const FeedrateOptions& options, const SetPoints& setpoints) {
  return check_samples(machine, dynamics, limits, options, setpoints).check;
}

FeedratePlan plan_feedrate(const kinematics::MachineModel& machine,
                           const kinematics::PathKinematics& path, const FeedrateOptions& options) {
  options.validate();
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

  // ---- grid: every path point, long segments subdivided; stops at corners and ends.
  Problem p;
  p.axes = axes;
  const double length = spline.length_m();
  const double max_step = options.max_grid_step_m > 0.0 ? options.max_grid_step_m : length / 4000.0;
  std::vector<bool> corner_point(path.s_m.size(), false);
  for (const auto& c : path.corners) corner_point[c.point] = true;
  corner_point.front() = corner_point.back() = true;
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
  p.s.push_back(0.0);
  p.stop.push_back(true);
  for (std::size_t i = 0; i + 1 < path.s_m.size(); ++i) {
    const double h = path.s_m[i + 1] - path.s_m[i];
    std::size_t pieces = static_cast<std::size_t>(std::ceil(h / max_step - 1e-9));
    pieces = std::max<std::size_t>(pieces, 1);
    if (stretch_segments[i] < 4) pieces = std::max<std::size_t>(pieces, 4 / stretch_segments[i] + 1);
    for (std::size_t m = 0; m < pieces; ++m) {
      p.seg.push_back(i);
      p.sigma0.push_back(h * static_cast<double>(m) / static_cast<double>(pieces));
      p.s.push_back(m + 1 == pieces ? path.s_m[i + 1]
                                    : path.s_m[i] + h * static_cast<double>(m + 1) / static_cast<double>(pieces));
      p.stop.push_back(m + 1 == pieces && corner_point[i + 1]);
    }
  }
  const std::size_t points = p.s.size();
  const std::size_t segments = points - 1;

  // ---- rows at both ends of every grid segment.
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
  p.r2.resize(2 * segments * p.n2);
  p.r2mid.resize(segments * p.n2);
  p.r3.resize(2 * segments * p.n3);
  p.cap_end.assign(2 * segments, kInf);
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
  EndData e;
  for (std::size_t k = 0; k < segments; ++k) {
    {
      const double sigma = p.sigma0[k] + 0.5 * p.delta(k);
      spline.evaluate(p.seg[k], sigma, &e.q, &e.q_s, &e.q_ss, nullptr);
      const std::size_t a = p.seg[k];
      const double h = path.s_m[a + 1] - path.s_m[a];
      const double lambda = corner_point[a + 1] ? 0.0 : sigma / h;
      e.q_sss = (1.0 - lambda) * path.q_sss.col(idx(a)) + lambda * path.q_sss.col(idx(a + 1));
      if (dynamic) {
        kinematics::path_torque_coefficients(*dyn_model, *dyn_data, e.q, e.q_s, e.q_ss, e.q_sss,
                                             options.effects);
      }
      const auto& c = dyn_data ? dyn_data->coefficients : kinematics::PathTorqueCoefficients{};
      Row2* rows = p.r2mid.data() + k * p.n2;
      for (std::size_t r = 0; r < p.n2; ++r) {
        const Index j = idx(axes2[r]);
        rows[r] = dynamic ? Row2{c.a(j), c.b(j), c.c(j), c.d(j), c.e(j), L[axes2[r]].torque_N_m, static_cast<int>(j)}
                          : Row2{e.q_s(j), e.q_ss(j), 0, 0, 0, L[axes2[r]].acceleration, static_cast<int>(j)};
      }
    }
    for (int end = 0; end < 2; ++end) {
      const double sigma = p.sigma0[k] + (end == 0 ? 0.0 : p.delta(k));
      spline.evaluate(p.seg[k], sigma, &e.q, &e.q_s, &e.q_ss, &e.q_sss);
      {
        // q_sss: the fitted values of solve_path_kinematics, linear between the path points
        // (the quintic's own third derivative carries the mismatch between the raw positions
        // and the fitted derivatives, e / h^3; see path_kinematics.hpp on dense polylines).
        const std::size_t a = p.seg[k];
        const double h = path.s_m[a + 1] - path.s_m[a];
        const double lambda = corner_point[a + 1] ? 0.0 : sigma / h;
        e.q_sss = (1.0 - lambda) * path.q_sss.col(idx(a)) + lambda * path.q_sss.col(idx(a + 1));
      }
      if (dynamic) {
        // The left end of a segment is usually the right end of the one before (q, q_s, q_ss
        // and the interpolated q_sss are continuous): reuse its coefficients then.
        {
          kinematics::path_torque_coefficients(*dyn_model, *dyn_data, e.q, e.q_s, e.q_ss, e.q_sss,
                                               options.effects);
        }
      }
      const auto& c = dynamic ? dyn_data->coefficients : kinematics::PathTorqueCoefficients{};
      Row2* rows2 = p.r2.data() + (2 * k + static_cast<std::size_t>(end)) * p.n2;
      Row3* rows3 = p.r3.data() + (2 * k + static_cast<std::size_t>(end)) * p.n3;
      for (std::size_t r = 0; r < p.n2; ++r) {
        const Index j = idx(axes2[r]);
        Row2& row = rows2[r];
        row.axis = static_cast<int>(j);
        if (dynamic) {
          row = {c.a(j), c.b(j), c.c(j), c.d(j), c.e(j), L[axes2[r]].torque_N_m, row.axis};
        } else {
          row = {e.q_s(j), e.q_ss(j), 0, 0, 0, L[axes2[r]].acceleration, row.axis};
        }
      }
      for (std::size_t r = 0; r < p.n3; ++r) {
        const Index j = idx(axes3[r]);
        Row3& row = rows3[r];
        row.axis = static_cast<int>(j);
        if (dynamic) {
          row = {c.a(j), c.a_s(j) + 2.0 * c.b(j), c.b_s(j), c.c_s(j), c.d_s(j), c.d(j),
                 L[axes3[r]].torque_rate_N_m_per_s, row.axis};
        } else {
          row = {e.q_s(j), 3.0 * e.q_ss(j), e.q_sss(j), 0, 0, 0, L[axes3[r]].jerk, row.axis};
        }
      }
      double cap = kInf;
      const double feed = feed_of_segment(k);
      cap = std::min(cap, feed * feed);
      for (std::size_t j = 0; j < axes; ++j) {
        const double qs = std::abs(e.q_s(idx(j)));
        if (L[j].velocity > 0.0 && qs > 0.0) cap = std::min(cap, (L[j].velocity / qs) * (L[j].velocity / qs));
      }
      // Third order: the paper's sd_lim for jerk / torque rate (sdd = sddd = 0) caps x too, so
      // that the second-order profile the third-order passes steer by already slows down where
      // sd^3 q_sss (or its torque-rate counterpart) alone reaches the limit.
      for (std::size_t r = 0; r < p.n3; ++r) {
        const Row3& row = rows3[r];
        const double sd_max = first_exit(0.0, row.W, row.V, row.S, row.L);
        if (std::isfinite(sd_max)) cap = std::min(cap, sd_max * sd_max);
      }
      p.cap_end[2 * k + static_cast<std::size_t>(end)] = cap;

      // sd_lim (Eq. 1-2, 7-9) at the point where this end is the left end (and the last point).
      if (end == 1 && k + 1 != segments) continue;
      const std::size_t point = k + static_cast<std::size_t>(end);
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
            put(ConstraintKind::torque, first_exit(c.c(jj) + c.e(jj), c.d(jj), c.b(jj), 0.0, L[j].torque_N_m), a);
          }
          if (options.third_order && L[j].torque_rate_N_m_per_s > 0.0) {
            put(ConstraintKind::torque_rate,
                first_exit(0.0, c.c_s(jj), c.d_s(jj), c.b_s(jj), L[j].torque_rate_N_m_per_s), a);
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
  std::vector<double> target(points), x3(points), u3(points);
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
      const bool third = p.n3 > 0;
      if (!third) {
        for (std::size_t k = k0; k < k1; ++k) {
          ex.x[k] = x2[k];
          ex.sdd_l[k] = ex.sdd_r[k] = u2[k];
          const double den = std::sqrt(x2[k]) + std::sqrt(x2[k + 1]);
          ex.dt[k] = 2.0 * p.delta(k) / std::max(den, 1e-300);
        }
        ex.x[k1] = 0.0;
        continue;
      }
      // Backward pass (from the end, at rest, under the controllable set), then the forward
      // pass from the start under the backward profile.
      const std::size_t n = k1 - k0;
      const Problem back = mirror(p, k0, k1);
      std::vector<double> cap_b(n + 1), target_b(n + 1), xb(n + 1), ub(n + 1);
      // Its cap: the second-order profile that need not start at rest (a cap that drops
      // faster than the second-order limits allow cannot be followed).
      std::vector<double> x_free(points), u_free(points), k_free(points), cap_free(cap);
      cap_free[k0] = p.cap_end[2 * k0] * slow[k0];
      const SecondOrder free_start(p, cap_free);
      free_start.solve(k0, k1, x_free, u_free, k_free, false);
      for (std::size_t i = 0; i <= n; ++i) cap_b[i] = x_free[k1 - i];
      cap_b[0] = 0.0;
      cap_b[n] = cap_b[n - 1];  // the global start is reached by the forward pass, not this one
      auto slope_targets = [](const std::vector<double>& s, const std::vector<double>& x,
                              std::vector<double>& t) {
        const std::size_t m = x.size() - 1;
        for (std::size_t i = 0; i <= m; ++i) {
          const std::size_t a = i > 0 ? i - 1 : 0, b = i < m ? i + 1 : m;
          t[i] = 0.5 * (x[b] - x[a]) / (s[b] - s[a]);
        }
      };
      slope_targets(back.s, cap_b, target_b);
      cap_b[n] = kInf;
      bool ok = false;
      std::vector<double> dt_b(n + 1, -1.0), dt3(points, -1.0);
      std::size_t tail = 0;
      // One attempt per round; where a pass cannot continue, the admissible feed is lowered
      // around that place (through the second-order profile, so the dip has admissible
      // flanks) and the round is planned again, like a set-point violation.
      std::size_t failed_at = points;
      {
        ThirdOrder backward(back, 0, n, cap_b, target_b, xb, ub, dt_b, false);
        ok = backward.solve();
        // The forward pass joins the backward one at k1 - tail: leave it room.
        tail = std::min(backward.analytic_segments, n / 2);
        if (!ok) failed_at = k1 - std::min(backward.failed_at, n);
      }
      std::vector<double> cap3(points, 0.0);
      if (ok) {
        for (std::size_t i = 0; i <= n; ++i) {
          cap3[k1 - i] = xb[i];
          target[k1 - i] = -ub[i];
        }
        cap3[k0] = 0.0;
        ThirdOrder forward(p, k0, k1, cap3, target, x3, u3, dt3, true, tail);
        ok = forward.solve();
        if (!ok) failed_at = std::min(forward.failed_at, k1);
        if (ok) {  // the backward pass's constant-jerk stop
          for (std::size_t i = 0; i < tail; ++i) {
            x3[k1 - i] = cap3[k1 - i];
            u3[k1 - i] = target[k1 - i];
            dt3[k1 - 1 - i] = dt_b[i];
          }
        }
      }
      if (!ok) {
        if (round + 1 >= options.max_verification_rounds) {
          throw InfeasibleError(
              "feedrate interpolation: no jerk/torque-rate admissible profile found between s = " +
              format_double(p.s[k0] * 1e3) + " and " + format_double(p.s[k1] * 1e3) +
              " mm (the third-order passes are not yet robust on such paths; planning without "
              "third-order limits, vmsim plan --no-third-order, limits velocity, acceleration "
              "and torque only)");
        }
        const std::size_t width = std::max<std::size_t>(10, (k1 - k0) / 50);
        const std::size_t from = failed_at > k0 + width ? failed_at - width : k0;
        const std::size_t to = std::min(k1, failed_at + width);
        for (std::size_t i = from; i <= to; ++i) slow[i] *= 0.7;
        third_order_failed = true;
        break;
      }
      for (std::size_t k = k0; k < k1; ++k) {
        ex.x[k] = x3[k];
        ex.sdd_l[k] = u3[k];
        ex.sdd_r[k] = u3[k + 1];
        const double delta = p.delta(k);
        if (dt3[k] >= 0.0) {
          ex.dt[k] = dt3[k];
        } else {
          ex.dt[k] = gauss_time(delta, x3[k], u3[k], (u3[k + 1] - u3[k]) / delta);
        }
      }
      ex.x[k1] = 0.0;
    }
    if (third_order_failed) {
      ++plan.slowdown_rounds;
      continue;
    }
    ex.t.assign(points, 0.0);
    for (std::size_t k = 0; k < segments; ++k) ex.t[k + 1] = ex.t[k] + ex.dt[k];

    // Set points.
    SetPoints& sp = plan.setpoints;
    sp.period_s = period;
    const double total = ex.t.back();
    if (!(std::isfinite(total) && total / period < 1e8)) {
      throw InfeasibleError("feedrate interpolation: the planned motion takes " +
                            format_double(total) + " s (a near stop inside a stretch)");
    }
    const auto samples = static_cast<std::size_t>(std::ceil(total / period - 1e-9)) + 1;
    sp.t_s.resize(samples);
    sp.s_m.resize(samples);
    sp.q.resize(idx(axes), idx(samples));
    VectorXd qv;
    std::size_t k = 0;
    for (std::size_t n = 0; n < samples; ++n) {
      const double t = static_cast<double>(n) * period;
      sp.t_s[n] = t;
      while (k + 1 < segments && ex.t[k + 1] <= t) ++k;
      double s = 0.0;
      std::size_t grid_segment = k;
      double sigma = 0.0;
      if (t >= total) {
        grid_segment = segments - 1;
        sigma = p.delta(grid_segment);
        s = p.s.back();
      } else {
        const double tau = std::clamp(t - ex.t[k], 0.0, ex.dt[k]);
        const double delta = p.delta(k);
        sigma = std::clamp(quintic(delta, std::sqrt(ex.x[k]), ex.sdd_l[k], std::sqrt(ex.x[k + 1]),
                                   ex.sdd_r[k], ex.dt[k], tau),
                           0.0, delta);
        s = p.s[k] + sigma;
      }
      sp.s_m[n] = s;
      spline.evaluate(p.seg[grid_segment], p.sigma0[grid_segment] + sigma, &qv, nullptr, nullptr, nullptr);
      sp.q.col(idx(n)) = qv;
    }
    plan.duration_s = total;

    const SampleCheck sc = check_samples(machine, dyn_model.get(), plan.limits, options, sp);
    plan.check = sc.check;
    std::vector<double> factor(points, 1.0);
    bool violated = false;
    std::size_t g = 0;
    for (std::size_t n = 0; n < samples; ++n) {
      const double allowed = options.method == FeedrateMethod::dynamic && sc.order[n] >= 2
                                 ? kTorqueCheckTolerance
                                 : kCheckTolerance;
      if (!(sc.worst[n] > 1.0 + allowed)) continue;
      violated = true;
      const double s_lo = sp.s_m[n >= 5 ? n - 5 : 0];
      const double s_hi = sp.s_m[std::min(n + 4, samples - 1)];
      const double f = std::clamp(std::pow(sc.worst[n], -2.0 / sc.order[n]) * 0.99, 0.5, 0.99);
      while (g > 0 && p.s[g] > s_lo) --g;
      while (g + 1 < points && p.s[g + 1] <= s_lo) ++g;
      for (std::size_t i = g; i < points && p.s[i] <= s_hi; ++i) {
        factor[i] = std::min(factor[i], f);
        if (i + 1 < points) factor[i + 1] = std::min(factor[i + 1], f);
      }
    }
    if (!violated) break;
    if (round + 1 >= options.max_verification_rounds) {
      throw InfeasibleError("feedrate interpolation: the set points still exceed a limit by " +
                            format_double((sc.check.worst() - 1.0) * 100.0) + " % after " +
                            std::to_string(round + 1) + " slow-down rounds");
    }
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

}  // namespace vmsim::planner
