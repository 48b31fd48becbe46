// Third-order feedrate planning (jerk / torque-rate limits): a sequence of linear programmes in
// the phase-plane variables x = sd^2 and u = sdd at the grid points (see feedrate.hpp for the
// method, its guarantees and its gaps).
#include <coin/ClpSimplex.hpp>

#include <algorithm>
#include <cmath>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "feedrate_detail.hpp"
#include "vmsim/common/files.hpp"

namespace vmsim::planner::detail {
namespace {

/// A share of the second-order x beyond which the constant-jerk start is not extended: beyond
/// it the optimum may already need to reduce its jerk; the linear programme plans the rest.
/// (Where the jerk keeps x far below the second-order profile, a short move, this share is no
/// bound: ThirdOrderLp::first_jerk_phase_m is.)
constexpr double kBlockShare = 0.25;
/// Row activities are normalised (the limit is 1); a row is added to the programme when its
/// activity exceeds the bound by this much.
constexpr double kRowTolerance = 1e-9;
/// A violation the scan finds and the built row does not show, above which it is a bug (slot
/// layouts disagree) rather than rounding (found by posted programs: 1e-9 .. 1e-8 at stops).
constexpr double kLayoutGuard = 1e-6;
constexpr int kMaxOuterIterations = 40;
constexpr int kMaxLazyRounds = 60;
/// Outer iterations stop when the time T improves by less than this (relative).
constexpr double kConvergence = 1e-7;
/// Nodes (grid points with columns) per time scale of the acceleration (limit / third-order
/// limit) along the second-order profile, and the longest node span in grid segments (the time
/// decides on dense grids: 32 gave a 100 000-point path 5.6x the nodes of the same path on
/// 10 000 points, and a programme 5x slower for a 0.01 % shorter T).
constexpr double kNodesPerRamp = 8.0;
constexpr std::size_t kMaxSegmentsPerNode = 256;
/// The largest relative change of the second-order sd over a node span. A jerk ramp from rest
/// has u ~ s^(1/3): a chord of u over a span is held by the jerk row at its fastest end, so
/// long spans where sd grows fast cost time (0.2 % on a straight line with time spacing alone).
constexpr double kMaxSpeedChangePerNode = 0.01;

/// The constant-jerk motion from rest (or to rest) at the ends of a stretch: s = j t^3 / 6 from
/// the stop, so x = alpha z and u = dir beta z with z = j^(2/3), alpha = (6 d)^(4/3) / 4,
/// beta = (6 d)^(1/3), d the distance to the stop. Linear in z: a column of the programme.
struct Block {
  std::size_t stop = 0;  ///< the stop point
  int dir = 1;           ///< +1: start (points stop + i), -1: end (points stop - i)
  std::size_t m = 0;     ///< grid segments covered
  double z_max = 0.0;    ///< the rows hold on every block point for every z in [0, z_max]
  std::vector<double> alpha, beta;  ///< at block point i = 0..m
  std::size_t point(std::size_t i) const { return dir > 0 ? stop + i : stop - i; }
};

/// One side of one linearised row: lo <= sum coef * column <= hi (normalised).
struct HalfRow {
  int n = 0;
  int col[3] = {0, 0, 0};
  double coef[3] = {0, 0, 0};
  double lo = -COIN_DBL_MAX, hi = COIN_DBL_MAX;
  void add(int c, double v) {
    for (int i = 0; i < n; ++i) {
      if (col[i] == c) {
        coef[i] += v;
        return;
      }
    }
    col[n] = c;
    coef[n] = v;
    ++n;
  }
};

/// Appends `h` to a row list in compressed sparse row form (CLP's addRows / matrix layout).
void append_row(const HalfRow& h, std::vector<int>& indices, std::vector<double>& elements,
                std::vector<CoinBigIndex>& starts, std::vector<double>& row_lo,
                std::vector<double>& row_hi) {
  for (int c = 0; c < h.n; ++c) {
    indices.push_back(h.col[c]);
    elements.push_back(h.coef[c]);
  }
  starts.push_back(static_cast<CoinBigIndex>(indices.size()));
  row_lo.push_back(h.lo);
  row_hi.push_back(h.hi);
}

/// A linear form in at most three columns (x or u at a grid point in terms of the node columns).
struct Form {
  int n = 0;
  int col[3] = {0, 0, 0};
  double coef[3] = {0, 0, 0};
};

class ThirdOrderLp {
 public:
  ThirdOrderLp(const Problem& p, const std::vector<std::pair<std::size_t, std::size_t>>& stretches,
               const std::vector<double>& x_upper, const std::vector<double>& c1_upper)
      : p_(p),
        x_upper_(x_upper),
        c1_upper_(c1_upper),
        points_(p.s.size()),
        per_end_(6 * p.n2 + 4 * p.n3 + 2),
        per_inside_(2 + 4 * p.n3),
        per_(per_end_ + per_inside_ + 2 * p.n3) {
    regular_.assign(p.segments(), 1);
    for (const auto& [k0, k1] : stretches) {
      const std::size_t n = k1 - k0;
      const std::size_t m_max = std::max<std::size_t>(1, n / 2 > 1 ? n / 2 - 1 : 1);
      const double stretch_m = p.s[k1] - p.s[k0];
      blocks_.push_back(make_block(k0, +1, m_max, stretch_m));
      blocks_.push_back(make_block(k1, -1, m_max, stretch_m));
    }
    for (const Block& b : blocks_) {
      for (std::size_t i = 0; i < b.m; ++i) regular_[b.dir > 0 ? b.stop + i : b.stop - i - 1] = 0;
    }
    choose_nodes();
  }

  bool solve(ThirdOrderProfile& out) {
    const std::size_t segments = p_.segments();
    const std::size_t nodes = nodes_.size();
    xn_.assign(nodes, 0.0);
    un_.assign(nodes, 0.0);
    z_.assign(blocks_.size(), 0.0);
    x_.assign(points_, 0.0);
    x_unclamped_.assign(points_, 0.0);
    u_.assign(points_, 0.0);
    // The first linearisation point: the second-order profile (above every third-order one).
    lin_ = x_upper_;
    active_.assign(segments * per_, 0);
    seed_active_rows();
    // Sequential linear programming on the time itself: each programme maximises the first-order
    // gain in T = sum ds / sd at the current iterate (weights ds / x^(3/2); the first at the
    // second-order profile), then a line search on T between the previous iterate and the new
    // one (both satisfy every row of this programme, whose feasible set is convex, so each point
    // between them does: the iterates stay feasible and T decreases monotonically).
    weight_x_ = x_upper_;
    double time_now = kInf;
    bool solved = false;
    for (int outer = 0; outer < kMaxOuterIterations; ++outer) {
      const std::vector<double> xn_keep = xn_, un_keep = un_, z_keep = z_;
      build();
      bool ok = run_lp(out.iterations);
      for (int round = 0; ok && round < kMaxLazyRounds; ++round) {
        if (add_violated_rows() == 0) break;
        ok = run_lp(out.iterations);
      }
      if (!ok) {
        if (!solved) return false;
        xn_ = xn_keep, un_ = un_keep, z_ = z_keep;
        expand();
        break;
      }
      double time_new = estimated_time();
      if (solved) {
        const std::vector<double> xn_new = xn_, un_new = un_, z_new = z_;
        double best_lambda = 1.0;
        for (double lambda = 0.5; lambda > 0.06; lambda *= 0.5) {
          blend(xn_keep, un_keep, z_keep, xn_new, un_new, z_new, lambda);
          const double t = estimated_time();
          if (t < time_new) time_new = t, best_lambda = lambda;
        }
        blend(xn_keep, un_keep, z_keep, xn_new, un_new, z_new, best_lambda);
        if (!(time_new < time_now)) {  // no gain: keep the previous iterate
          xn_ = xn_keep, un_ = un_keep, z_ = z_keep;
          expand();
          break;
        }
      }
      solved = true;
      const bool converged = time_now - time_new <= kConvergence * time_new;
      time_now = time_new;
      for (std::size_t i = 0; i < points_; ++i) lin_[i] = linearisation_point(i);
      weight_x_ = x_;
      if (converged) break;
    }
    out.x = x_;
    out.u = u_;
    out.dt.assign(segments, -1.0);
    for (std::size_t b = 0; b < blocks_.size(); ++b) {
      const Block& block = blocks_[b];
      const double jerk = std::pow(std::max(z_[b], 1e-300), 1.5);
      double t_prev = 0.0;
      for (std::size_t i = 1; i <= block.m; ++i) {
        const double d = std::abs(p_.s[block.point(i)] - p_.s[block.stop]);
        const double t = std::cbrt(6.0 * d / jerk);
        out.dt[block.dir > 0 ? block.stop + i - 1 : block.stop - i] = t - t_prev;
        t_prev = t;
      }
    }
    return true;
  }

 private:
  int col_x(std::size_t c) const { return static_cast<int>(c); }
  int col_u(std::size_t c) const { return static_cast<int>(nodes_.size() + c); }
  int col_z(std::size_t b) const { return static_cast<int>(2 * nodes_.size() + b); }
  int columns() const { return static_cast<int>(2 * nodes_.size() + blocks_.size()); }

  /// The nodes: the grid points at which x and u are columns; u is linear in s between them
  /// (x quadratic), and every row is still imposed at every grid point. Fewer columns make the
  /// simplex far cheaper; the spacing follows the time scale on which the acceleration can
  /// change (limit / third-order limit of each axis) along the second-order profile, so that
  /// the jerk ramps keep several nodes. Every block point is a node.
  void choose_nodes() {
    double tau = kInf;
    for (std::size_t r3 = 0; r3 < p_.n3; ++r3) {
      const Row3& a = p_.r3.empty() ? Row3{} : p_.r3[r3];
      for (std::size_t r2 = 0; r2 < p_.n2; ++r2) {
        const Row2& b = p_.r2[r2];
        if (b.axis == a.axis && a.L > 0.0) tau = std::min(tau, b.L / a.L);
      }
    }
    const double step_t = tau / kNodesPerRamp;
    nodes_.assign(1, 0);
    double elapsed = 0.0;
    std::size_t count = 0;
    const std::size_t segments = p_.segments();
    double sd_first = 0.0;  // the second-order sd at the node span's start
    for (std::size_t k = 0; k < segments; ++k) {
      const double den = std::sqrt(std::max(x_upper_[k], 0.0)) + std::sqrt(std::max(x_upper_[k + 1], 0.0));
      elapsed += den > 0.0 ? 2.0 * p_.delta(k) / den : kInf;
      ++count;
      const bool block_edge = !regular_[k] || (k + 1 < segments && !regular_[k + 1]);
      const double sd_next = std::sqrt(std::max(x_upper_[k + 1], 0.0));
      const bool speed_change = std::abs(sd_next - sd_first) > kMaxSpeedChangePerNode * std::max(sd_next, sd_first);
      if (block_edge || k + 1 == segments || elapsed >= step_t || count >= kMaxSegmentsPerNode ||
          speed_change) {
        nodes_.push_back(k + 1);
        elapsed = 0.0;
        count = 0;
        sd_first = sd_next;
      }
    }
    node_of_segment_.resize(segments);
    node_of_point_.assign(points_, -1);
    for (std::size_t c = 0; c + 1 < nodes_.size(); ++c) {
      node_of_point_[nodes_[c]] = static_cast<long>(c);
      for (std::size_t k = nodes_[c]; k < nodes_[c + 1]; ++k) node_of_segment_[k] = c;
    }
    node_of_point_[nodes_.back()] = static_cast<long>(nodes_.size() - 1);
  }

  /// x and u at s within node segment c (sigma from its start) as linear forms.
  void forms_at(std::size_t c, double sigma, Form& x, Form& u) const {
    const double span = p_.s[nodes_[c + 1]] - p_.s[nodes_[c]];
    const double lambda = sigma / span;
    x = Form{3, {col_x(c), col_u(c), col_u(c + 1)}, {1.0, sigma * (2.0 - lambda), sigma * lambda}};
    u = Form{2, {col_u(c), col_u(c + 1), 0}, {1.0 - lambda, lambda, 0.0}};
  }

  double form_value(const Form& f) const {
    double sum = 0.0;
    for (int i = 0; i < f.n; ++i) sum += f.coef[i] * value(f.col[i]);
    return sum;
  }

  /// x and u at every grid point from the node solution.
  void expand() {
    Form fx, fu;
    for (std::size_t k = 0; k < p_.segments(); ++k) {
      const std::size_t c = node_of_segment_[k];
      forms_at(c, p_.s[k] - p_.s[nodes_[c]], fx, fu);
      x_unclamped_[k] = form_value(fx);
      x_[k] = std::max(x_unclamped_[k], 0.0);
      u_[k] = form_value(fu);
    }
    x_unclamped_[points_ - 1] = xn_.back();
    x_[points_ - 1] = std::max(xn_.back(), 0.0);
    u_[points_ - 1] = un_.back();
  }

  double linearisation_point(std::size_t i) const {
    return std::max(x_[i], 1e-9 * x_upper_[i]);
  }

  /// Largest z for which the rows of `segment` (both ends) hold along the constant-jerk family
  /// for every z' in [0, z]: each row is a polynomial of degree <= 3 in w = sqrt(z).
  double block_bound(const Block& b, std::size_t segment, std::size_t i_left) const {
    double z = kInf;
    for (int end = 0; end < 2; ++end) {
      // Block index of this end: the segment runs from block point i_left to i_left + 1 away
      // from the stop; its end 0 is the point nearer the start of the path.
      const std::size_t i = b.dir > 0 ? i_left + static_cast<std::size_t>(end)
                                      : i_left + 1 - static_cast<std::size_t>(end);
      const double alpha = b.alpha[i], beta = b.dir * b.beta[i], root = std::sqrt(alpha);
      const Row2* rows2 = p_.rows2(segment, end);
      for (std::size_t r = 0; r < p_.n2; ++r) {
        const Row2& row = rows2[r];
        const double w = first_exit(row.C + row.E, row.D * root, row.A * beta + row.B * alpha, 0.0, row.L);
        z = std::min(z, w * w);
      }
      const Row3* rows3 = p_.rows3(segment, end);
      for (std::size_t r = 0; r < p_.n3; ++r) {
        const Row3& row = rows3[r];
        // sddd = +j on both blocks (the start accelerates, the stop decelerates with s^(3)
        // of the reversed cubic s_stop - j (t_stop - t)^3 / 6).
        const double w = first_exit(0.0, row.W * root, row.V * alpha + row.Z * beta,
                                    row.P + root * (row.R * beta + row.S * alpha), row.L);
        z = std::min(z, w * w);
      }
      if (i > 0) z = std::min(z, x_upper_[b.point(i)] / alpha);
    }
    return z;
  }

  /// The length [m] of the first constant-jerk phase of the time-optimal move from (or to) the
  /// stop under the limits there, on a straight line of the stretch's length: until the
  /// acceleration limit (the ramp distance), until the jerk must reverse to meet the speed cap
  /// without overshoot (t = sqrt(v / j): s = v^(3/2) / (6 sqrt(j))), or, on a move that reaches
  /// neither, a twelfth of it (four phases of equal time, L = 2 j t^3). The constant-jerk start
  /// must end before: beyond it the optimum already lowers its jerk, and one column z cannot
  /// follow (a 0.5 mm move on 49 segments took 3.3 times the optimum with the start held over
  /// half of it).
  double first_jerk_phase_m(std::size_t stop, int dir, double stretch_m) const {
    const std::size_t segment = dir > 0 ? stop : stop - 1;
    const int end = dir > 0 ? 0 : 1;
    const RestLimits rest = rest_limits(p_.rows2(segment, end), p_.n2, p_.rows3(segment, end), p_.n3);
    double phase = stretch_m / 12.0;
    const double ramp_m = rest.ramp_distance_m();  // 0 where the rows bound neither
    if (ramp_m > 0.0) phase = std::min(phase, ramp_m);
    const double cap = p_.cap_end[2 * segment + static_cast<std::size_t>(1 - end)];  // its other end
    if (std::isfinite(cap) && std::isfinite(rest.sddd_max) && rest.sddd_max > 0.0) {
      phase = std::min(phase, std::pow(cap, 0.75) / (6.0 * std::sqrt(rest.sddd_max)));
    }
    return phase;
  }

  Block make_block(std::size_t stop, int dir, std::size_t m_max, double stretch_m) const {
    Block b;
    b.stop = stop;
    b.dir = dir;
    auto extend = [&](std::size_t i) {  // block values at point i
      const double d = std::abs(p_.s[b.point(i)] - p_.s[stop]);
      b.alpha.push_back(std::pow(6.0 * d, 4.0 / 3.0) / 4.0);
      b.beta.push_back(std::cbrt(6.0 * d));
    };
    auto segment_of = [&](std::size_t i) { return dir > 0 ? stop + i : stop - i - 1; };
    extend(0);
    extend(1);
    b.z_max = block_bound(b, segment_of(0), 0);
    const double z_first = b.z_max;
    const double phase_m = first_jerk_phase_m(stop, dir, stretch_m);
    b.m = 1;
    // Keep the constant jerk of the first segment while the rows allow it in full and x stays
    // well under the second-order profile.
    while (b.m < m_max) {
      extend(b.m + 1);
      const double z = block_bound(b, segment_of(b.m), b.m);
      if (z < z_first * (1.0 - 1e-9) ||
          b.alpha[b.m + 1] * z_first > kBlockShare * x_upper_[b.point(b.m + 1)] ||
          std::abs(p_.s[b.point(b.m + 1)] - p_.s[stop]) > phase_m) {
        b.alpha.pop_back();
        b.beta.pop_back();
        break;
      }
      b.z_max = std::min(b.z_max, z);
      ++b.m;
    }
    return b;
  }

  /// Half-row `slot` of regular grid segment k under the current linearisation. Slot order:
  /// 2nd-order ends, 2nd-order middle, 3rd-order ends (two sides each), then 0 <= x <= x_upper
  /// at the right end when it is not a node; then the rows for the inside of the segment (see
  /// interior_half_row); then the third-order rows at the middle (the spline's q_sss is a
  /// quadratic on each path segment whose coefficients carry the rounding of q over h^3: on
  /// 30 um segments it bulges between the ends by ~1e-4 of the jerk).
  void half_row(std::size_t k, std::size_t slot, HalfRow& h) const {
    h = HalfRow{};
    const int side = static_cast<int>(slot % 2);  // 0: upper bound, 1: lower bound
    RowTerms t;
    if (slot_terms(k, slot, t)) {
      terms_half_row(t, k, nullptr, h);
      return;
    }
    if (slot >= per_end_) {
      interior_half_row(k, slot - per_end_, h);
      return;
    }
    // The x range at the right end.
    const std::size_t i = k + 1;
    if (node_of_point_[i] >= 0) return;  // a column bound there
    x_range_half_row(side, k, p_.delta(k), x_upper_[i], h);
  }

  /// A row of the second or third order at sigma in grid segment k as
  /// lo <= cx x(sigma) + cu u(sigma) + cup u' <= hi (one side bounded), u' the slope of u over
  /// the node span.
  struct RowTerms {
    bool none = false;  ///< no row: a third-order row linearised where the cap is 0 (see third_order_terms)
    double sigma = 0.0;
    double cx = 0.0, cu = 0.0, cup = 0.0;
    double lo = -COIN_DBL_MAX, hi = COIN_DBL_MAX;
  };

  /// The terms of slot `slot` of grid segment k for the rows at its ends and middle; false
  /// for the x range and the inside rows. (violations_in_segment walks the same layout.)
  bool slot_terms(std::size_t k, std::size_t slot, RowTerms& t) const {
    const int side = static_cast<int>(slot % 2);
    const std::size_t n2 = p_.n2;
    const double middle_sigma = 0.5 * p_.delta(k), middle_q = 0.5 * (lin_[k] + lin_[k + 1]);
    if (slot >= per_end_ + per_inside_) {  // third-order rows at the middle
      const std::size_t r = (slot - per_end_ - per_inside_) / 2;
      third_order_terms(p_.rows3mid(k)[r], side, middle_q, 0.5 * (u_[k] + u_[k + 1]), t);
      t.sigma = middle_sigma;
      return true;
    }
    if (slot >= per_end_ || (slot >= 6 * n2 + 4 * p_.n3)) return false;
    if (slot < 6 * n2) {
      const bool middle = slot >= 4 * n2;
      const std::size_t r = middle ? (slot - 4 * n2) / 2 : (slot / 2) % n2;
      const int end = middle ? 0 : static_cast<int>(slot / (2 * n2));
      const std::size_t i = k + static_cast<std::size_t>(end);
      if (middle) {
        second_order_terms(p_.rows2mid(k)[r], side, middle_q, 1.5 * std::max(x_upper_[k], x_upper_[k + 1]), t);
        t.sigma = middle_sigma;
      } else {
        second_order_terms(p_.rows2(k, end)[r], side, lin_[i], x_upper_[i], t);
        t.sigma = p_.s[i] - p_.s[k];
      }
      return true;
    }
    const std::size_t rest = slot - 6 * n2;
    const int end = static_cast<int>(rest / (2 * p_.n3));
    const std::size_t r = (rest / 2) % p_.n3;
    const std::size_t i = k + static_cast<std::size_t>(end);
    third_order_terms(p_.rows3(k, end)[r], side, lin_[i], u_[i], t);
    t.sigma = p_.s[i] - p_.s[k];
    return true;
  }

  /// The half-row of `t` in the node columns (x as `x_form` instead of x(sigma) if given).
  void terms_half_row(const RowTerms& t, std::size_t k, const Form* x_form, HalfRow& h) const {
    if (t.none) return;
    const std::size_t c = node_of_segment_[k];
    if (t.cup != 0.0) {
      const double span = p_.s[nodes_[c + 1]] - p_.s[nodes_[c]];
      h.add(col_u(c + 1), t.cup / span);
      h.add(col_u(c), -t.cup / span);
    }
    Form fx, fu;
    forms_in_segment(k, t.sigma, fx, fu);
    add_form(h, fu, t.cu);
    add_form(h, x_form != nullptr ? *x_form : fx, t.cx);
    h.lo = t.lo;
    h.hi = t.hi;
  }

  /// Rows for the inside of grid segment k. u is linear there, so x is quadratic in sigma and
  /// can peak between the ends (where u crosses zero downwards): rows at the ends alone let the
  /// speed limit and the jerk (|P u'| <= L / sd on a straight move) be exceeded in between.
  /// In Bernstein form x has the coefficients x0, c1 = x0 + u0 delta, x1 and lies below their
  /// maximum, and c1 exceeds both ends only where x peaks inside; so the rows are imposed once
  /// more at the virtual point x = c1: 0 <= c1 <= the mean of x_upper at the ends (x - the chord of
  /// x_upper is quadratic too, with middle coefficient c1 - that mean), and every third-order
  /// row of either end with x = c1 and that end's u. Exact for a move whose coefficients are
  /// constant along the segment (a straight line), conservative by at most the segment's
  /// bulge.
  void interior_half_row(std::size_t k, std::size_t slot, HalfRow& h) const {
    const int side = static_cast<int>(slot % 2);
    // The third-order rows only where the iterate peaks inside (u crossing zero downwards):
    // elsewhere the ends' rows cover the inside, and rows at c1 with the ends' coefficients
    // would only add rows (twice as many in torque-rate mode) that constrain nothing real.
    if (slot >= 2 && !(u_[k] > 0.0 && u_[k + 1] < 0.0)) return;
    const double delta = p_.delta(k);
    const double c1_now = x_[k] + delta * u_[k];
    Form fx, fu;
    forms_in_segment(k, 0.0, fx, fu);
    Form c1 = fx;  // x0 + delta u0: u0's columns are among x0's
    for (int i = 0; i < fu.n; ++i) {
      for (int t = 0; t < c1.n; ++t) {
        if (c1.col[t] == fu.col[i]) c1.coef[t] += delta * fu.coef[i];
      }
    }
    if (slot < 2) {
      // Upper side: c1 <= the mean of x_upper. Lower side: c1 >= 0, so that x >= 0 all along
      // (with x ~ 0 at a grid point of a near stop, the quadratic through the ends could dip
      // below 0 inside: a motion that never reaches the next point; the set points then fell
      // back on a quintic 25 times over the jerk limit on the dense test path).
      // The upper side also holds c1 under c1_upper (x under the cap at the middle, where the
      // cap dips between the points).
      const double x_mean = 0.5 * (x_upper_[k] + x_upper_[k + 1]);
      const double scale = std::max(x_mean, 1e-300);
      add_form(h, c1, 1.0 / scale);
      if (side == 0) h.hi = std::min(x_mean, c1_upper_[k]) / scale; else h.lo = 0.0;
      return;
    }
    const std::size_t r = ((slot - 2) / 2) % p_.n3;
    const int end = static_cast<int>((slot - 2) / (2 * p_.n3));
    const std::size_t i = k + static_cast<std::size_t>(end);
    RowTerms t;
    third_order_terms(p_.rows3(k, end)[r], side, c1_now, u_[i], t);
    t.sigma = p_.s[i] - p_.s[k];  // u there; x is c1
    terms_half_row(t, k, &c1, h);
  }

  void add_form(HalfRow& h, const Form& f, double scale) const {
    for (int i = 0; i < f.n; ++i) h.add(f.col[i], scale * f.coef[i]);
  }

  /// Forms of x and u at sigma from the start of grid segment k.
  void forms_in_segment(std::size_t k, double sigma, Form& fx, Form& fu) const {
    const std::size_t c = node_of_segment_[k];
    forms_at(c, p_.s[k] + sigma - p_.s[nodes_[c]], fx, fu);
  }

  /// 0 <= x <= x_max at sigma in grid segment k (normalised by x_max).
  void x_range_half_row(int side, std::size_t k, double sigma, double x_max, HalfRow& h) const {
    Form fx, fu;
    forms_in_segment(k, sigma, fx, fu);
    const double scale = std::max(x_max, 1e-300);
    add_form(h, fx, 1.0 / scale);
    if (side == 0) h.hi = x_max / scale; else h.lo = 0.0;
  }

  /// A second-order row A u + B x + C + D sqrt(x) + E within +-L, sqrt(x) bounded linearly:
  /// above by its tangent at q, below by its chord on [0, x_max].
  void second_order_terms(const Row2& row, int side, double q, double x_max, RowTerms& t) const {
    double slope = 0.0, intercept = 0.0;
    if (row.D != 0.0) {
      if ((row.D > 0.0) == (side == 0)) {
        const double r = std::sqrt(std::max(q, 1e-300));
        slope = 0.5 / r;
        intercept = 0.5 * r;
      } else {
        slope = x_max > 0.0 ? 1.0 / std::sqrt(x_max) : 0.0;
      }
    }
    t.cx = (row.B + row.D * slope) / row.L;
    t.cu = row.A / row.L;
    const double constant = (row.C + row.E + row.D * intercept) / row.L;
    if (side == 0) t.hi = 1.0 - constant; else t.lo = -1.0 - constant;
  }

  /// A third-order row divided by sd: |P u' + R u + S x + W + V sd + Z u / sd| <= L / sd. The
  /// right side is convex in x: its tangent at q is a lower bound (the row is tightened, exact
  /// at q). The viscous terms V sd + Z u / sd are taken at the current iterate (x = q,
  /// u = u_now).
  void third_order_terms(const Row3& row, int side, double q, double u_now, RowTerms& t) const {
    // A point inside a stretch where the second-order cap is 0 (a blended corner too sharp to
    // pass moving): the motion stops there, where |P sddd| <= L / sd bounds nothing, and the
    // tangent of L / sqrt(x) at 0 does not exist (its coefficients were infinite: CLP refused
    // the programme as a bad element and posted programs found no third-order profile). The
    // rows at the neighbouring points hold the jerk into and out of the stop.
    if (!(q > 0.0)) {
      t.none = true;
      return;
    }
    const double rq = std::sqrt(q);
    const double inverse_scale = rq / row.L;  // 1 / the limit at q
    const double viscous = row.V * rq + (row.Z != 0.0 ? row.Z * u_now / rq : 0.0);
    t.cup = row.P * inverse_scale;
    t.cu = row.R * inverse_scale;
    const double constant = (row.W + viscous) * inverse_scale;
    // Tangent of L / sqrt(x) at q, over the scale: 1.5 - 0.5 x / q.
    const double sign = side == 0 ? 1.0 : -1.0;
    t.cx = row.S * inverse_scale + sign * 0.5 / q;
    if (side == 0) t.hi = 1.5 - constant; else t.lo = -1.5 - constant;
  }

  double activity(const HalfRow& h) const {
    double sum = 0.0;
    for (int c = 0; c < h.n; ++c) sum += h.coef[c] * value(h.col[c]);
    return sum;
  }
  double value(int column) const {
    const auto c = static_cast<std::size_t>(column);
    const std::size_t nodes = nodes_.size();
    if (c < nodes) return xn_[c];
    if (c < 2 * nodes) return un_[c - nodes];
    return z_[c - 2 * nodes];
  }

  /// Before the first programme: on every regular node segment, the jerk row (both sides) of
  /// the axis with the largest |P| / L at its last grid segment's right end (it bounds u'
  /// there). The rest is added as violated: few rows keep each simplex iteration cheap.
  void seed_active_rows() {
    if (p_.n3 == 0) return;
    for (std::size_t c = 0; c + 1 < nodes_.size(); ++c) {
      const std::size_t k = nodes_[c + 1] - 1;
      if (!regular_[k]) continue;
      std::size_t best = 0;
      double weight = -1.0;
      for (std::size_t r = 0; r < p_.n3; ++r) {
        const Row3& row = p_.rows3(k, 1)[r];
        if (std::abs(row.P) / row.L > weight) {
          weight = std::abs(row.P) / row.L;
          best = r;
        }
      }
      const std::size_t slot = 6 * p_.n2 + (p_.n3 + best) * 2;
      active_[k * per_ + slot] = 1;
      active_[k * per_ + slot + 1] = 1;
    }
  }

  std::size_t row_key(std::size_t k, std::size_t slot) const {
    return block_rows_ + nodes_.size() + k * per_ + slot;
  }

  /// (Re)builds the programme: the equalities, then the active half-rows in their order;
  /// the previous basis is kept (same columns and rows, new rows basic).
  void build() {
    full_scan_ = true;  // a new linearisation: every row changes
    const int ncols = columns();
    const std::size_t nodes = nodes_.size();
    std::vector<double> col_lo(static_cast<std::size_t>(ncols)), col_hi(col_lo.size()),
        objective(col_lo.size(), 0.0);
    for (std::size_t c = 0; c < nodes; ++c) {
      const std::size_t i = nodes_[c];
      col_lo[c] = 0.0;
      col_hi[c] = std::max(x_upper_[i], 0.0);
      const bool stop = x_upper_[i] <= 0.0;
      const double u_bound = stop ? 0.0 : u_bound_at(i);
      col_lo[nodes + c] = -u_bound;
      col_hi[nodes + c] = u_bound;
    }
    // Maximise sum w x over the grid points with w the time's sensitivity at the second-order
    // profile, ds / x^(3/2) (bounded where x is tiny), normalised to a mean of 1 (CLP's dual
    // tolerance, 1e-7, is absolute: with weights summing to 1 most re-solves ended "optimal
    // when scaled, dual infeasible unscaled" and CLP cleaned up each with a primal simplex, a
    // quarter of the torque-rate bench's work); x at the grid points is a
    // form in the node columns.
    std::vector<double> weights(points_, 0.0);
    double total = 0.0;
    for (std::size_t i = 0; i < points_; ++i) {
      if (x_upper_[i] <= 0.0) continue;
      const double ds = 0.5 * (p_.s[std::min(i + 1, points_ - 1)] - p_.s[i > 0 ? i - 1 : 0]);
      const double x_ref = std::max(weight_x_[i], 1e-4 * max_upper());
      weights[i] = ds / (x_ref * std::sqrt(x_ref));
      total += weights[i];
    }
    Form fx, fu;
    for (std::size_t i = 0; i < points_; ++i) {
      weights[i] *= static_cast<double>(points_) / total;
      if (weights[i] == 0.0) continue;
      if (node_of_point_[i] >= 0) {
        objective[static_cast<std::size_t>(node_of_point_[i])] += weights[i];
        continue;
      }
      const std::size_t c = node_of_segment_[i];
      forms_at(c, p_.s[i] - p_.s[nodes_[c]], fx, fu);
      for (int t = 0; t < fx.n; ++t) objective[static_cast<std::size_t>(fx.col[t])] += weights[i] * fx.coef[t];
    }
    for (std::size_t b = 0; b < blocks_.size(); ++b) {
      col_lo[2 * nodes + b] = 0.0;
      col_hi[2 * nodes + b] = blocks_[b].z_max;
    }
    std::vector<double> row_lo, row_hi, elements;
    std::vector<int> indices;
    std::vector<CoinBigIndex> starts{0};
    auto row = [&](std::initializer_list<std::pair<int, double>> terms, double lo, double hi) {
      for (const auto& [c, v] : terms) {
        indices.push_back(c);
        elements.push_back(v);
      }
      starts.push_back(static_cast<CoinBigIndex>(indices.size()));
      row_lo.push_back(lo);
      row_hi.push_back(hi);
    };
    // Rows in path order (the block rows first): the constraint matrix is banded, which the
    // factorisations profit from. Each row has a key, under which its basis status is kept.
    if (model_) save_status();
    row_keys_.clear();
    for (std::size_t b = 0; b < blocks_.size(); ++b) {
      const Block& block = blocks_[b];
      for (std::size_t i = 1; i <= block.m; ++i) {
        const auto c = static_cast<std::size_t>(node_of_point_[block.point(i)]);
        row({{col_x(c), 1.0}, {col_z(b), -block.alpha[i]}}, 0.0, 0.0);
        row_keys_.push_back(row_keys_.size());
        row({{col_u(c), 1.0}, {col_z(b), -block.dir * block.beta[i]}}, 0.0, 0.0);
        row_keys_.push_back(row_keys_.size());
      }
    }
    block_rows_ = row_keys_.size();
    HalfRow h;
    for (std::size_t c = 0; c + 1 < nodes; ++c) {
      const std::size_t k0 = nodes_[c], k1 = nodes_[c + 1];
      if (!regular_[k0]) continue;
      const double span = p_.s[k1] - p_.s[k0];  // x_c+1 = x_c + span (u_c + u_c+1)
      row({{col_x(c + 1), 1.0}, {col_x(c), -1.0}, {col_u(c), -span}, {col_u(c + 1), -span}}, 0.0, 0.0);
      row_keys_.push_back(block_rows_ + c);
      for (std::size_t k = k0; k < k1; ++k) {
        for (std::size_t slot = 0; slot < per_; ++slot) {
          if (!active_[k * per_ + slot]) continue;
          half_row(k, slot, h);
          if (h.n == 0) continue;
          append_row(h, indices, elements, starts, row_lo, row_hi);
          row_keys_.push_back(row_key(k, slot));
        }
      }
    }
    const int nrows = static_cast<int>(row_lo.size());
    CoinPackedMatrix matrix(false, ncols, nrows, static_cast<CoinBigIndex>(elements.size()),
                            elements.data(), indices.data(), starts.data(), nullptr);
    std::vector<unsigned char> status;
    if (model_) {
      // Keep the basis: the columns', and each row's under its key (new rows basic).
      status.assign(column_status_.begin(), column_status_.end());
      for (const std::size_t key : row_keys_) status.push_back(key < row_status_.size() ? row_status_[key] : 1);
    }
    model_ = std::make_unique<ClpSimplex>();
    model_->setLogLevel(0);
    // The node equalities x_c+1 = x_c + h (u_c + u_c+1) must hold closer than CLP's default
    // 1e-7: x ~ 1e-4 m^2/s^2 where the speed nearly stops, and a mismatch there is a jump of the
    // set points' speed between grid segments (a 0.5 mm corner blend on part 2 exceeded the X
    // jerk by 11-26 % for 8 slow-down rounds). 1e-8 is enough there; 1e-9 costs 15-50 % more
    // simplex time.
    model_->setPrimalTolerance(1e-8);
    model_->loadProblem(matrix, col_lo.data(), col_hi.data(), objective.data(), row_lo.data(),
                        row_hi.data());
    model_->setOptimizationDirection(-1.0);
    if (!status.empty()) model_->copyinStatus(status.data());
  }

  /// A box for u at point i implied by one second-order row there (any x in [0, x_upper]):
  /// the columns are then boxed, which the dual simplex starts from far better than free ones.
  double u_bound_at(std::size_t i) const {
    double bound = COIN_DBL_MAX;
    const double xm = std::max(x_upper_[i], 0.0);
    auto take = [&](const Row2& row) {
      if (std::abs(row.A) < 1e-12 * (std::abs(row.B) * xm + row.L)) return;
      const double reach = row.L + std::abs(row.B) * xm + std::abs(row.C + row.E) +
                           std::abs(row.D) * std::sqrt(xm);
      bound = std::min(bound, reach / std::abs(row.A));
    };
    for (int end = 0; end < 2; ++end) {
      if (end == 0 && i >= p_.segments()) continue;
      if (end == 1 && i == 0) continue;
      const Row2* rows = p_.rows2(end == 0 ? i : i - 1, end);
      for (std::size_t r = 0; r < p_.n2; ++r) take(rows[r]);
    }
    return bound;
  }

  /// Copies the model's basis status into column_status_ and row_status_ (by row key).
  void save_status() {
    const unsigned char* st = model_->statusArray();
    const int ncols = model_->numberColumns();
    column_status_.assign(st, st + ncols);
    std::size_t largest = 0;
    for (const std::size_t key : row_keys_) largest = std::max(largest, key + 1);
    row_status_.assign(largest, 1);
    for (std::size_t r = 0; r < row_keys_.size(); ++r) row_status_[row_keys_[r]] = st[ncols + static_cast<int>(r)];
  }

  double max_upper() const {
    if (max_upper_ < 0.0) {
      max_upper_ = 0.0;
      for (double v : x_upper_) max_upper_ = std::max(max_upper_, v);
    }
    return max_upper_;
  }

  bool run_lp(int& count) {
    ++count;
    // Cold starts were tried with barrier (+ crossover), primal, crash and initialSolve: the
    // dual simplex from the slack basis with boxed u was the fastest (see the notes).
    // An iteration limit: on a degenerate programme the dual simplex can stall (a 100 000-point
    // torque-rate plan once took a million iterations, 160 s, where its neighbours took < 1 000);
    // the primal simplex then goes on from where it stopped.
    const int limit = 2 * (model_->numberRows() + model_->numberColumns()) + 1000;
    model_->setMaximumIterations(limit);
    model_->dual();
    if (model_->status() == 3) model_->primal();  // from the basis where the dual stopped
    if (model_->status() != 0) {
      // Numerical trouble: once more from the slack basis with the primal simplex.
      model_->allSlackBasis(true);
      model_->primal();
      if (model_->status() != 0) return false;
    }
    const double* solution = model_->primalColumnSolution();
    const std::size_t nodes = nodes_.size();
    for (std::size_t c = 0; c < nodes; ++c) {
      xn_[c] = std::clamp(solution[c], 0.0, std::max(x_upper_[nodes_[c]], 0.0));
      un_[c] = solution[nodes + c];
    }
    z_.assign(solution + 2 * nodes, solution + 2 * nodes + blocks_.size());
    expand();
    return true;
  }

  /// Calls found(slot, violation) for every inactive half-row of regular grid segment k that
  /// its x and u violate: the rows of slot_terms evaluated family by family, both sides of a
  /// row at once (the same values as slot_terms' terms, without decoding each slot), the
  /// others built. With `next_shares_point` (the next grid segment is in the same node span) the
  /// second-order rows of the right end are left to that segment's left end: the same rows at
  /// the same point in the same columns.
  template <class Found>
  void violations_in_segment(std::size_t k, bool next_shares_point, HalfRow& h, Found&& found) const {
    const std::size_t n2 = p_.n2, n3 = p_.n3;
    const char* active = &active_[k * per_];
    const double delta = p_.delta(k);
    const double b = (u_[k + 1] - u_[k]) / delta;
    const std::size_t c = node_of_segment_[k];
    const double u_slope = (un_[c + 1] - un_[c]) / (p_.s[nodes_[c + 1]] - p_.s[nodes_[c]]);
    // x as the rows see it (the node forms, not clamped at 0): an iterate whose x dips below 0
    // between the nodes (before the x-range rows there are added) would otherwise be judged
    // at x = 0, and near a stop, where the third-order rows divide by x, the two differ
    // by far more than rounding (posted programs: 6e-7 below 0 at a cap of 3.4e-5).
    auto x_at = [&](double sigma) { return x_unclamped_[k] + sigma * (2.0 * u_[k] + b * sigma); };
    const double x_ends[2] = {x_at(0.0), x_at(delta)};
    const double u_ends[2] = {u_[k], u_[k] + b * delta};
    const double x_middle = x_at(0.5 * delta), u_middle = u_[k] + b * 0.5 * delta;
    const double middle_q = 0.5 * (lin_[k] + lin_[k + 1]);
    // Second-order rows, both sides at once (second_order_terms: sqrt(x) by its tangent at q on
    // the side where that tightens the row, by its chord on [0, x_max] on the other).
    auto check2 = [&](std::size_t slot0, const Row2* rows, double q, double x_max, double x, double u) {
      const double root = std::sqrt(std::max(q, 1e-300));
      const double tangent = 0.5 * x / root + 0.5 * root, chord = x_max > 0.0 ? x / std::sqrt(x_max) : 0.0;
      for (std::size_t r = 0; r < n2; ++r) {
        const std::size_t slot = slot0 + 2 * r;
        if (active[slot] && active[slot + 1]) continue;
        const Row2& row = rows[r];
        const double linear = row.A * u + row.B * x + row.C + row.E;
        const double upper = (linear + row.D * (row.D > 0.0 ? tangent : chord)) / row.L;
        const double lower = (linear + row.D * (row.D < 0.0 ? tangent : chord)) / row.L;
        if (!active[slot] && upper - 1.0 > kRowTolerance) found(slot, upper - 1.0);
        if (!active[slot + 1] && -1.0 - lower > kRowTolerance) found(slot + 1, -1.0 - lower);
      }
    };
    for (int end = 0; end < 2; ++end) {
      const std::size_t i = k + static_cast<std::size_t>(end);
      if (end == 1 && next_shares_point && p_.incoming[i] < 0) break;
      check2(static_cast<std::size_t>(end) * 2 * n2, p_.rows2(k, end), lin_[i], x_upper_[i], x_ends[end], u_ends[end]);
    }
    check2(4 * n2, p_.rows2mid(k), middle_q, 1.5 * std::max(x_upper_[k], x_upper_[k + 1]), x_middle, u_middle);
    // Third-order rows, both sides at once (third_order_terms: the sides differ only in the
    // tangent's sign and the bound).
    auto check3 = [&](std::size_t slot0, const Row3* rows, double q, double u_now, double x, double u) {
      if (!(q > 0.0)) return;  // no row there (third_order_terms)
      const double rq = std::sqrt(q), tangent = 0.5 * x / q;
      for (std::size_t r = 0; r < n3; ++r) {
        const std::size_t slot = slot0 + 2 * r;
        if (active[slot] && active[slot + 1]) continue;
        const Row3& row = rows[r];
        const double inverse_scale = rq / row.L;
        const double viscous = row.V * rq + (row.Z != 0.0 ? row.Z * u_now / rq : 0.0);
        const double base = inverse_scale * (row.P * u_slope + row.R * u + row.S * x + row.W + viscous);
        const double over = base + tangent - 1.5, under = -1.5 - (base - tangent);
        if (!active[slot] && over > kRowTolerance) found(slot, over);
        if (!active[slot + 1] && under > kRowTolerance) found(slot + 1, under);
      }
    };
    for (int end = 0; end < 2; ++end) {
      const std::size_t i = k + static_cast<std::size_t>(end);
      check3(6 * n2 + static_cast<std::size_t>(end) * 2 * n3, p_.rows3(k, end), lin_[i], u_[i], x_ends[end], u_ends[end]);
    }
    check3(per_end_ + per_inside_, p_.rows3mid(k), middle_q, 0.5 * (u_[k] + u_[k + 1]), x_middle, u_middle);
    // The x range at the right end and the rows for the inside: built (the inside's
    // third-order rows exist only where u crosses zero downwards).
    const bool peaks_inside = u_[k] > 0.0 && u_[k + 1] < 0.0;
    for (std::size_t slot = 6 * n2 + 4 * n3; slot < per_end_ + per_inside_; ++slot) {
      if (active[slot]) continue;
      if (slot >= per_end_ + 2 && !peaks_inside) break;
      half_row(k, slot, h);
      if (h.n == 0) continue;
      const double a = activity(h);
      const double violation = std::max(a - h.hi, h.lo - a);
      if (violation > kRowTolerance) found(slot, violation);
    }
  }

  /// Adds violated half-rows to the programme; returns how many. Per node span and slot only
  /// the most violated grid segment's row: the rows of one slot along a span are nearly
  /// parallel forms in the same few columns (neighbouring grid points), so adding all of them
  /// (on dense grids, tens per span) makes the programme several times larger and degenerate
  /// for little gain; the next round adds any neighbour still violated.
  std::size_t add_violated_rows() {
    std::vector<double> row_lo, row_hi, elements;
    std::vector<int> indices;
    std::vector<CoinBigIndex> starts{0};
    HalfRow h;
    std::vector<double> worst(per_);
    std::vector<std::size_t> worst_k(per_);
    std::vector<int> violated(per_);  // violated rows per slot in the span
    const std::size_t nodes = nodes_.size();
    if (scanned_xn_.size() != nodes) full_scan_ = true;
    auto moved = [&](std::size_t c) {
      const double scale = 1e-14 * std::max(x_upper_[nodes_[c]], 1e-300);
      return std::abs(xn_[c] - scanned_xn_[c]) > scale ||
             std::abs(un_[c] - scanned_un_[c]) > 1e-14 * (std::abs(un_[c]) + std::abs(scanned_un_[c])) + 1e-300;
    };
    std::vector<char> node_moved(nodes, 1);
    if (!full_scan_) {
      for (std::size_t c = 0; c < nodes; ++c) node_moved[c] = moved(c);
    }
    span_pending_.resize(nodes, 1);
    for (std::size_t c = 0; c + 1 < nodes; ++c) {
      const std::size_t k0 = nodes_[c], k1 = nodes_[c + 1];
      if (!regular_[k0]) continue;
      // A span whose nodes did not move since its last scan, where every violated row was
      // added, has none: its rows depend on its two nodes and the linearisation only.
      if (!node_moved[c] && !node_moved[c + 1] && !span_pending_[c]) continue;
      span_pending_[c] = 0;
      std::fill(worst.begin(), worst.end(), 0.0);
      std::fill(violated.begin(), violated.end(), 0);
      for (std::size_t k = k0; k < k1; ++k) {
        violations_in_segment(k, k + 1 < k1, h, [&](std::size_t slot, double violation) {
          ++violated[slot];
          if (violation > worst[slot]) {
            worst[slot] = violation;
            worst_k[slot] = k;
          }
        });
      }
      for (std::size_t slot = 0; slot < per_; ++slot) {
        if (worst[slot] == 0.0) continue;
        const std::size_t k = worst_k[slot];
        if (violated[slot] > 1) span_pending_[c] = 1;  // others left out: scan it again
        half_row(k, slot, h);
        // The scan evaluates the slots family by family: the row built from the slot must be
        // the one it found violated (a guard for the two slot layouts).
        const double a = activity(h);
        if (!(std::max(a - h.hi, h.lo - a) > 0.5 * kRowTolerance)) {
          // The scan evaluates the row in closed form, the half-row through the node forms: at
          // a violation within rounding of the tolerance (third-order rows divide by sqrt(x)
          // near a stop) the two may disagree, and the row is not worth adding. Beyond that
          // they cannot, except through a slot layout bug.
          if (worst[slot] < kLayoutGuard) continue;
          throw std::logic_error("third-order planner: the scan and half_row disagree on slot " + std::to_string(slot) +
                                 " (scan " + format_double(worst[slot]) + ", row " +
                                 format_double(std::max(a - h.hi, h.lo - a)) + ")");
        }
        active_[k * per_ + slot] = 1;
        row_keys_.push_back(row_key(k, slot));
        append_row(h, indices, elements, starts, row_lo, row_hi);
      }
    }
    if (!row_lo.empty()) {
      model_->addRows(static_cast<int>(row_lo.size()), row_lo.data(), row_hi.data(), starts.data(),
                      indices.data(), elements.data());
    }
    scanned_xn_ = xn_;
    scanned_un_ = un_;
    full_scan_ = false;
    return row_lo.size();
  }

  /// T = sum over the grid segments of 2 delta / (sd_k + sd_k+1) at the current x (the
  /// line search's measure; exact for x linear in s).
  double estimated_time() const {
    double sum = 0.0;
    for (std::size_t k = 0; k + 1 < points_; ++k) {
      const double den = std::sqrt(x_[k]) + std::sqrt(x_[k + 1]);
      sum += den > 0.0 ? 2.0 * p_.delta(k) / den : kInf;
    }
    return sum;
  }

  /// The iterate (1 - lambda) a + lambda b, expanded to the grid points.
  void blend(const std::vector<double>& xa, const std::vector<double>& ua, const std::vector<double>& za,
             const std::vector<double>& xb, const std::vector<double>& ub, const std::vector<double>& zb,
             double lambda) {
    for (std::size_t c = 0; c < xn_.size(); ++c) {
      xn_[c] = (1.0 - lambda) * xa[c] + lambda * xb[c];
      un_[c] = (1.0 - lambda) * ua[c] + lambda * ub[c];
    }
    for (std::size_t b = 0; b < z_.size(); ++b) z_[b] = (1.0 - lambda) * za[b] + lambda * zb[b];
    expand();
  }

  const Problem& p_;
  const std::vector<double>& x_upper_;
  const std::vector<double>& c1_upper_;  // per grid segment: c1 keeps x under the cap at the middle
  std::size_t points_;
  std::size_t per_end_;  // half-row slots per regular grid segment at its ends and middle
  std::size_t per_inside_;  // half-row slots of interior_half_row
  std::size_t per_;         // half-row slots per regular grid segment (ends, middle, inside)
  std::vector<char> regular_;
  std::vector<Block> blocks_;
  std::vector<std::size_t> nodes_;             // grid points that carry columns
  std::vector<std::size_t> node_of_segment_;   // node segment of each grid segment
  std::vector<long> node_of_point_;            // node index of a grid point, -1 if none
  std::vector<double> xn_, un_, z_;            // the programme's solution
  std::vector<double> x_unclamped_;  // x at the grid points before clamping at 0 (the rows' x)
  std::vector<double> x_, u_, lin_, weight_x_;  // at the grid points (weight_x_: where the objective's weights are taken)
  std::vector<char> active_;
  std::vector<std::size_t> row_keys_;  // per model row
  std::vector<unsigned char> column_status_, row_status_;
  mutable double max_upper_ = -1.0;
  std::unique_ptr<ClpSimplex> model_;
  std::size_t block_rows_ = 0;
  // The node values at the last scan for violated rows, and the spans where a violated row
  // was left out (only the worst per slot is added); a full scan after each build.
  std::vector<double> scanned_xn_, scanned_un_;
  std::vector<char> span_pending_;
  bool full_scan_ = true;
};

}  // namespace

bool plan_third_order(const Problem& p, const std::vector<std::pair<std::size_t, std::size_t>>& stretches,
                      const std::vector<double>& x_upper, const std::vector<double>& c1_upper,
                      ThirdOrderProfile& out) {
  // One programme per stretch (they only meet at stops, where x = u = 0): the simplex's work
  // grows faster than the size, so many small programmes beat one large.
  out.x.assign(p.s.size(), 0.0);
  out.u.assign(p.s.size(), 0.0);
  out.dt.assign(p.segments(), -1.0);
  Problem local;
  local.axes = p.axes;
  local.n2 = p.n2;
  local.n3 = p.n3;
  for (const auto& [k0, k1] : stretches) {
    const auto from = [](std::size_t i) { return static_cast<std::ptrdiff_t>(i); };
    local.s.assign(p.s.begin() + from(k0), p.s.begin() + from(k1) + 1);
    local.r2.assign(p.r2.begin() + from(k0 * p.n2), p.r2.begin() + from((k1 + 1) * p.n2));
    // Inside a stretch no point is a stop: only its last point has an incoming side.
    const auto last_in = static_cast<std::size_t>(p.incoming[k1]);
    local.r2_in.assign(p.r2_in.begin() + from(last_in * p.n2), p.r2_in.begin() + from((last_in + 1) * p.n2));
    local.incoming.assign(k1 - k0 + 1, -1);
    local.incoming.back() = 0;
    local.r2mid.assign(p.r2mid.begin() + from(k0 * p.n2), p.r2mid.begin() + from(k1 * p.n2));
    local.r3.assign(p.r3.begin() + from(2 * k0 * p.n3), p.r3.begin() + from(2 * k1 * p.n3));
    local.r3mid.assign(p.r3mid.begin() + from(k0 * p.n3), p.r3mid.begin() + from(k1 * p.n3));
    local.cap_end.assign(p.cap_end.begin() + from(2 * k0), p.cap_end.begin() + from(2 * k1));
    const std::vector<double> upper(x_upper.begin() + from(k0), x_upper.begin() + from(k1) + 1);
    const std::vector<double> c1_bound(c1_upper.begin() + from(k0), c1_upper.begin() + from(k1));
    ThirdOrderProfile part;
    ThirdOrderLp lp(local, {{0, k1 - k0}}, upper, c1_bound);
    if (!lp.solve(part)) return false;
    out.iterations += part.iterations;
    std::copy(part.x.begin(), part.x.end(), out.x.begin() + from(k0));
    std::copy(part.u.begin(), part.u.end(), out.u.begin() + from(k0));
    std::copy(part.dt.begin(), part.dt.end(), out.dt.begin() + from(k0));
  }
  return true;
}

}  // namespace vmsim::planner::detail
