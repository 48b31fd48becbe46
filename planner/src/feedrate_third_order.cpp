// Third-order feedrate planning (jerk / torque-rate limits): a sequence of linear programmes in
// the phase-plane variables x = sd^2 and u = sdd at the grid points (see feedrate.hpp for the
// method, its guarantees and its gaps).
#include <coin/ClpSimplex.hpp>

#include <algorithm>
#include <cmath>
#include <memory>
#include <vector>

#include "feedrate_detail.hpp"

namespace vmsim::planner::detail {
namespace {

/// A share of the second-order x beyond which the constant-jerk start is not extended: beyond
/// it the optimum may already need to reduce its jerk (a short move's switching point lies
/// where x is at least 0.32 of the acceleration-limited triangle); the linear programme plans
/// the rest.
constexpr double kBlockShare = 0.25;
/// Row activities are normalised (the limit is 1); a row is added to the programme when its
/// activity exceeds the bound by this much.
constexpr double kRowTolerance = 1e-9;
constexpr int kMaxOuterIterations = 40;
constexpr int kMaxLazyRounds = 60;
/// Outer iterations stop when the objective improves by less than this (relative).
constexpr double kConvergence = 1e-7;

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

class ThirdOrderLp {
 public:
  ThirdOrderLp(const Problem& p, const std::vector<std::pair<std::size_t, std::size_t>>& stretches,
               const std::vector<double>& x_upper)
      : p_(p), x_upper_(x_upper), points_(p.s.size()), per_(6 * p.n2 + 4 * p.n3) {
    regular_.assign(p.segments(), 1);
    for (const auto& [k0, k1] : stretches) {
      const std::size_t n = k1 - k0;
      const std::size_t m_max = std::max<std::size_t>(1, n / 2 > 1 ? n / 2 - 1 : 1);
      blocks_.push_back(make_block(k0, +1, m_max));
      blocks_.push_back(make_block(k1, -1, m_max));
    }
    for (const Block& b : blocks_) {
      for (std::size_t i = 0; i < b.m; ++i) regular_[b.dir > 0 ? b.stop + i : b.stop - i - 1] = 0;
    }
  }

  bool solve(ThirdOrderProfile& out) {
    const std::size_t segments = p_.segments();
    x_.assign(points_, 0.0);
    u_.assign(points_, 0.0);
    // The first linearisation point: the second-order profile (above every third-order one).
    lin_ = x_upper_;
    active_.assign(segments * per_, 0);
    active_list_.clear();
    seed_active_rows();
    double previous = -1.0;
    bool solved = false;
    for (int outer = 0; outer < kMaxOuterIterations; ++outer) {
      std::vector<double> x_keep = x_, u_keep = u_, z_keep = z_;
      build();
      bool ok = run_lp(out.iterations);
      for (int round = 0; ok && round < kMaxLazyRounds; ++round) {
        if (add_violated_rows() == 0) break;
        ok = run_lp(out.iterations);
      }
      if (!ok) {
        if (!solved) return false;
        x_ = x_keep, u_ = u_keep, z_ = z_keep;
        break;
      }
      solved = true;
      const double objective = objective_value();
      for (std::size_t i = 0; i < points_; ++i) lin_[i] = linearisation_point(i);
      if (outer > 0 && objective - previous <= kConvergence * std::abs(objective)) break;
      previous = objective;
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
  int col_x(std::size_t i) const { return static_cast<int>(i); }
  int col_u(std::size_t i) const { return static_cast<int>(points_ + i); }
  int col_z(std::size_t b) const { return static_cast<int>(2 * points_ + b); }
  int columns() const { return static_cast<int>(2 * points_ + blocks_.size()); }

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

  Block make_block(std::size_t stop, int dir, std::size_t m_max) const {
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
    b.m = 1;
    // Keep the constant jerk of the first segment while the rows allow it in full and x stays
    // well under the second-order profile.
    while (b.m < m_max) {
      extend(b.m + 1);
      const double z = block_bound(b, segment_of(b.m), b.m);
      if (z < z_first * (1.0 - 1e-9) ||
          b.alpha[b.m + 1] * z_first > kBlockShare * x_upper_[b.point(b.m + 1)]) {
        b.alpha.pop_back();
        b.beta.pop_back();
        break;
      }
      b.z_max = std::min(b.z_max, z);
      ++b.m;
    }
    return b;
  }

  /// Half-row `slot` of regular segment k under the current linearisation (see the slot order
  /// in the constructor: 2nd-order ends, 2nd-order middle, 3rd-order ends; two sides each).
  void half_row(std::size_t k, std::size_t slot, HalfRow& h) const {
    h = HalfRow{};
    const double delta = p_.delta(k);
    const int side = static_cast<int>(slot % 2);  // 0: upper bound, 1: lower bound
    const std::size_t n2 = p_.n2;
    // sqrt(x) bounded linearly: above by its tangent at q, below by its chord on [0, x_max].
    auto sqrt_bound = [](bool above, double q, double x_max, double& slope, double& intercept) {
      if (above) {
        const double r = std::sqrt(std::max(q, 1e-300));
        slope = 0.5 / r;
        intercept = 0.5 * r;
      } else {
        slope = x_max > 0.0 ? 1.0 / std::sqrt(x_max) : 0.0;
        intercept = 0.0;
      }
    };
    if (slot < 6 * n2) {
      const bool middle = slot >= 4 * n2;
      const std::size_t r = middle ? (slot - 4 * n2) / 2 : (slot / 2) % n2;
      const int end = middle ? 0 : static_cast<int>(slot / (2 * n2));
      const Row2& row = middle ? p_.rows2mid(k)[r] : p_.rows2(k, end)[r];
      const std::size_t i = k + static_cast<std::size_t>(end);
      double q = lin_[i], x_max = x_upper_[i];
      if (middle) {
        q = 0.5 * (lin_[k] + lin_[k + 1]);
        x_max = 1.5 * std::max(x_upper_[k], x_upper_[k + 1]);
      }
      double slope = 0.0, intercept = 0.0;
      if (row.D != 0.0) sqrt_bound((row.D > 0.0) == (side == 0), q, x_max, slope, intercept);
      const double B = (row.B + row.D * slope) / row.L;
      const double A = row.A / row.L;
      const double constant = (row.C + row.E + row.D * intercept) / row.L;
      if (middle) {  // x = x_k + (3 u_k + u_k+1) delta / 4, u = (u_k + u_k+1) / 2
        h.add(col_x(k), B);
        h.add(col_u(k), 0.5 * A + 0.75 * delta * B);
        h.add(col_u(k + 1), 0.5 * A + 0.25 * delta * B);
      } else {
        h.add(col_x(i), B);
        h.add(col_u(i), A);
      }
      if (side == 0) h.hi = 1.0 - constant; else h.lo = -1.0 - constant;
      return;
    }
    const std::size_t rest = slot - 6 * n2;
    const int end = static_cast<int>(rest / (2 * p_.n3));
    const std::size_t r = (rest / 2) % p_.n3;
    const Row3& row = p_.rows3(k, end)[r];
    const std::size_t i = k + static_cast<std::size_t>(end);
    // Divided by sd: |P u' + R u + S x + W + V sd + Z u / sd| <= L / sd. The right side is
    // convex in x: its tangent at q is a lower bound (the row is tightened, exact at q). The
    // viscous terms V sd + Z u / sd are taken at the current iterate.
    const double q = lin_[i];
    const double rq = std::sqrt(q);
    const double scale = row.L / rq;  // the limit at q
    const double viscous = row.V * rq + row.Z * u_[i] / rq;
    h.add(col_u(k + 1), row.P / delta / scale);
    h.add(col_u(k), -row.P / delta / scale);
    h.add(col_u(i), row.R / scale);
    const double constant = (row.W + viscous) / scale;
    // Tangent of L / sqrt(x) at q, over the scale: 1.5 - 0.5 x / q.
    if (side == 0) {
      h.add(col_x(i), row.S / scale + 0.5 / q);
      h.hi = 1.5 - constant;
    } else {
      h.add(col_x(i), row.S / scale - 0.5 / q);
      h.lo = -1.5 - constant;
    }
  }

  double activity(const HalfRow& h) const {
    double sum = 0.0;
    for (int c = 0; c < h.n; ++c) sum += h.coef[c] * value(h.col[c]);
    return sum;
  }
  double value(int column) const {
    const auto c = static_cast<std::size_t>(column);
    if (c < points_) return x_[c];
    if (c < 2 * points_) return u_[c - points_];
    return z_[c - 2 * points_];
  }

  /// Before the first programme: on every regular segment, the jerk row (both sides) of the
  /// axis with the largest |P| / L at its right end (it bounds u' there). The rest is added as
  /// violated: few rows keep each simplex iteration cheap.
  void seed_active_rows() {
    if (p_.n3 == 0) return;
    for (std::size_t k = 0; k < p_.segments(); ++k) {
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
      activate(k * per_ + slot);
      activate(k * per_ + slot + 1);
    }
  }

  void activate(std::size_t key) {
    if (active_[key]) return;
    active_[key] = 1;
    active_list_.push_back(key);
  }

  /// (Re)builds the programme: the equalities, then the active half-rows in their order;
  /// the previous basis is kept (same columns and rows, new rows basic).
  void build() {
    const int ncols = columns();
    std::vector<double> col_lo(static_cast<std::size_t>(ncols)), col_hi(col_lo.size()),
        objective(col_lo.size(), 0.0);
    double total = 0.0;
    for (std::size_t i = 0; i < points_; ++i) {
      col_lo[i] = 0.0;
      col_hi[i] = std::max(x_upper_[i], 0.0);
      const bool stop = x_upper_[i] <= 0.0;
      const double u_bound = stop ? 0.0 : u_bound_at(i);
      col_lo[points_ + i] = -u_bound;
      col_hi[points_ + i] = u_bound;
      // Maximise sum w x with w the time's sensitivity at the second-order profile,
      // ds / x^(3/2) (bounded where x is tiny), normalised.
      const double ds = 0.5 * (p_.s[std::min(i + 1, points_ - 1)] - p_.s[i > 0 ? i - 1 : 0]);
      const double x_ref = std::max(x_upper_[i], 1e-4 * max_upper());
      objective[i] = stop ? 0.0 : ds / (x_ref * std::sqrt(x_ref));
      total += objective[i];
    }
    for (std::size_t i = 0; i < points_; ++i) objective[i] /= total;
    weights_.assign(objective.begin(), objective.begin() + static_cast<long>(points_));
    for (std::size_t b = 0; b < blocks_.size(); ++b) {
      col_lo[2 * points_ + b] = 0.0;
      col_hi[2 * points_ + b] = blocks_[b].z_max;
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
    const std::size_t stride = per_ + 1;
    for (std::size_t b = 0; b < blocks_.size(); ++b) {
      const Block& block = blocks_[b];
      for (std::size_t i = 1; i <= block.m; ++i) {
        const std::size_t pt = block.point(i);
        row({{col_x(pt), 1.0}, {col_z(b), -block.alpha[i]}}, 0.0, 0.0);
        row_keys_.push_back(row_keys_.size());
        row({{col_u(pt), 1.0}, {col_z(b), -block.dir * block.beta[i]}}, 0.0, 0.0);
        row_keys_.push_back(row_keys_.size());
      }
    }
    const std::size_t block_rows = row_keys_.size();
    block_rows_ = block_rows;
    HalfRow h;
    for (std::size_t k = 0; k < p_.segments(); ++k) {
      if (!regular_[k]) continue;
      const double delta = p_.delta(k);  // x_k+1 = x_k + delta (u_k + u_k+1)
      row({{col_x(k + 1), 1.0}, {col_x(k), -1.0}, {col_u(k), -delta}, {col_u(k + 1), -delta}}, 0.0, 0.0);
      row_keys_.push_back(block_rows + k * stride);
      for (std::size_t slot = 0; slot < per_; ++slot) {
        if (!active_[k * per_ + slot]) continue;
        half_row(k, slot, h);
        append_row(h, indices, elements, starts, row_lo, row_hi);
        row_keys_.push_back(block_rows + k * stride + 1 + slot);
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
    model_->dual();
    if (model_->status() != 0) {
      // Numerical trouble: once more from the slack basis with the primal simplex.
      model_->allSlackBasis(true);
      model_->primal();
      if (model_->status() != 0) return false;
    }
    const double* solution = model_->primalColumnSolution();
    for (std::size_t i = 0; i < points_; ++i) {
      x_[i] = std::clamp(solution[i], 0.0, std::max(x_upper_[i], 0.0));
      u_[i] = solution[points_ + i];
    }
    z_.assign(solution + 2 * points_, solution + 2 * points_ + blocks_.size());
    return true;
  }

  /// Adds every violated half-row to the programme; returns how many.
  std::size_t add_violated_rows() {
    std::vector<double> row_lo, row_hi, elements;
    std::vector<int> indices;
    std::vector<CoinBigIndex> starts{0};
    HalfRow h;
    for (std::size_t k = 0; k < p_.segments(); ++k) {
      if (!regular_[k]) continue;
      for (std::size_t slot = 0; slot < per_; ++slot) {
        const std::size_t key = k * per_ + slot;
        if (active_[key]) continue;
        half_row(k, slot, h);
        const double a = activity(h);
        if (a <= h.hi + kRowTolerance && a >= h.lo - kRowTolerance) continue;
        activate(key);
        row_keys_.push_back(block_rows_ + k * (per_ + 1) + 1 + slot);
        append_row(h, indices, elements, starts, row_lo, row_hi);
      }
    }
    if (!row_lo.empty()) {
      model_->addRows(static_cast<int>(row_lo.size()), row_lo.data(), row_hi.data(), starts.data(),
                      indices.data(), elements.data());
    }
    return row_lo.size();
  }

  double objective_value() const {
    double sum = 0.0;
    for (std::size_t i = 0; i < points_; ++i) sum += weights_[i] * x_[i];
    return sum;
  }

  const Problem& p_;
  const std::vector<double>& x_upper_;
  std::size_t points_;
  std::size_t per_;  // half-row slots per regular segment
  std::vector<char> regular_;
  std::vector<Block> blocks_;
  std::vector<double> x_, u_, z_, lin_, weights_;
  std::vector<char> active_;
  std::vector<std::size_t> active_list_;
  std::vector<std::size_t> row_keys_;  // per model row
  std::vector<unsigned char> column_status_, row_status_;
  mutable double max_upper_ = -1.0;
  std::unique_ptr<ClpSimplex> model_;
  std::size_t block_rows_ = 0;
};

}  // namespace

bool plan_third_order(const Problem& p, const std::vector<std::pair<std::size_t, std::size_t>>& stretches,
                      const std::vector<double>& x_upper, ThirdOrderProfile& out) {
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
    local.r2.assign(p.r2.begin() + from(2 * k0 * p.n2), p.r2.begin() + from(2 * k1 * p.n2));
    local.r2mid.assign(p.r2mid.begin() + from(k0 * p.n2), p.r2mid.begin() + from(k1 * p.n2));
    local.r3.assign(p.r3.begin() + from(2 * k0 * p.n3), p.r3.begin() + from(2 * k1 * p.n3));
    const std::vector<double> upper(x_upper.begin() + from(k0), x_upper.begin() + from(k1) + 1);
    ThirdOrderProfile part;
    ThirdOrderLp lp(local, {{0, k1 - k0}}, upper);
    if (!lp.solve(part)) return false;
    out.iterations += part.iterations;
    std::copy(part.x.begin(), part.x.end(), out.x.begin() + from(k0));
    std::copy(part.u.begin(), part.u.end(), out.u.begin() + from(k0));
    std::copy(part.dt.begin(), part.dt.end(), out.dt.begin() + from(k0));
  }
  return true;
}

}  // namespace vmsim::planner::detail
