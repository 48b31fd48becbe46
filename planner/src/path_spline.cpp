// Quintic Hermite interpolation of q(s) (see feedrate.hpp).
#include <algorithm>
#include <cmath>
#include <limits>
#include <set>
#include <string>

#include "vmsim/common/errors.hpp"
#include "vmsim/common/files.hpp"
#include "vmsim/planner/feedrate.hpp"

namespace vmsim::planner {

namespace {

/// Quintic Hermite coefficients in sigma on [0, h] through (q, q_s, q_ss) at both ends, the
/// right end's q given as the increment dq = q1 - q0.
void hermite(double h, double q0, double v0, double a0, double dq, double v1, double a1, double* c) {
  c[0] = q0;
  c[1] = v0;
  c[2] = 0.5 * a0;
  c[3] = (20.0 * dq - (8.0 * v1 + 12.0 * v0) * h - (3.0 * a0 - a1) * h * h) / (2.0 * h * h * h);
  c[4] = (-30.0 * dq + (14.0 * v1 + 16.0 * v0) * h + (3.0 * a0 - 2.0 * a1) * h * h) / (2.0 * h * h * h * h);
  c[5] = (12.0 * dq - 6.0 * (v1 + v0) * h + (a1 - a0) * h * h) / (2.0 * h * h * h * h * h);
}

/// Clamped C2 cubic spline through y at s[a..b] with end slopes v_start, v_end: its slopes and
/// second derivatives at the points (Thomas algorithm on the moment equations).
void clamped_cubic(const std::vector<double>& s, std::size_t a, std::size_t b, const std::vector<double>& y,
                   double v_start, double v_end, std::vector<double>& slope, std::vector<double>& second) {
  const std::size_t n = b - a + 1;
  std::vector<double> lower(n, 0.0), diag(n, 0.0), upper(n, 0.0), rhs(n, 0.0);
  auto h = [&](std::size_t i) { return s[a + i + 1] - s[a + i]; };
  auto d = [&](std::size_t i) { return (y[i + 1] - y[i]) / h(i); };
  diag[0] = 2.0 * h(0);
  upper[0] = h(0);
  rhs[0] = 6.0 * (d(0) - v_start);
  for (std::size_t i = 1; i + 1 < n; ++i) {
    lower[i] = h(i - 1);
    diag[i] = 2.0 * (h(i - 1) + h(i));
    upper[i] = h(i);
    rhs[i] = 6.0 * (d(i) - d(i - 1));
  }
  lower[n - 1] = h(n - 2);
  diag[n - 1] = 2.0 * h(n - 2);
  rhs[n - 1] = 6.0 * (v_end - d(n - 2));
  for (std::size_t i = 1; i < n; ++i) {  // forward elimination (diagonally dominant)
    const double m = lower[i] / diag[i - 1];
    diag[i] -= m * upper[i - 1];
    rhs[i] -= m * rhs[i - 1];
  }
  second.assign(n, 0.0);
  second[n - 1] = rhs[n - 1] / diag[n - 1];
  for (std::size_t i = n - 1; i-- > 0;) second[i] = (rhs[i] - upper[i] * second[i + 1]) / diag[i];
  slope.assign(n, 0.0);
  for (std::size_t i = 0; i + 1 < n; ++i) slope[i] = d(i) - h(i) * (2.0 * second[i] + second[i + 1]) / 6.0;
  slope[n - 1] = d(n - 2) + h(n - 2) * (second[n - 2] + 2.0 * second[n - 1]) / 6.0;
}

}  // namespace

PathSpline::PathSpline(const kinematics::PathKinematics& path) : s_m_(path.s_m) {
  const std::size_t n = s_m_.size();
  if (n < 2) throw InputError("feedrate interpolation needs a path of at least 2 points");
  const Eigen::Index axes = path.q.rows();
  std::set<std::size_t> corner_points;
  for (const auto& corner : path.corners) corner_points.insert(corner.point);
  coefficients_.resize(axes, static_cast<Eigen::Index>(6 * (n - 1)));
  for (std::size_t i = 0; i + 1 < n; ++i) {
    const double h = s_m_[i + 1] - s_m_[i];
    if (!(h > 1e-12)) {
      std::string where;
      if (i + 1 < path.block.size() && path.block[i + 1] >= 0) {
        const auto block = static_cast<std::size_t>(path.block[i + 1]);
        where = block < path.block_names.size() ? ", " + path.block_names[block]
                                                : ", block #" + std::to_string(block);
      }
      throw InputError("path point " + std::to_string(i + 1) + where + " (s = " +
                       format_double(s_m_[i] * 1e3) +
                       " mm) changes the tool orientation without moving the tip: a feed along "
                       "the tip's arc length is undefined there");
    }
  }
  // Incoming side of a corner: the derivatives extrapolated from the point before (the
  // stored ones at a corner point belong to the outgoing stretch).
  auto incoming = [&](Eigen::Index j, std::size_t i, double& v1, double& a1) {
    const auto ii = static_cast<Eigen::Index>(i);
    const double h = s_m_[i + 1] - s_m_[i];
    const double a0 = path.q_ss(j, ii), j0 = path.q_sss(j, ii);
    v1 = path.q_s(j, ii) + a0 * h + 0.5 * j0 * h * h;
    a1 = a0 + j0 * h;
  };
  if (!path.derivatives_fitted) {
    // Hand-made paths with exact derivatives: the quintic through (q, q_s, q_ss).
    for (std::size_t i = 0; i + 1 < n; ++i) {
      const auto ii = static_cast<Eigen::Index>(i);
      for (Eigen::Index j = 0; j < axes; ++j) {
        double v1 = path.q_s(j, ii + 1), a1 = path.q_ss(j, ii + 1);
        if (corner_points.count(i + 1) != 0) incoming(j, i, v1, a1);
        double c[6];
        const double h = s_m_[i + 1] - s_m_[i];
        const double q0 = path.q(j, ii), q1 = path.q(j, ii + 1), v0 = path.q_s(j, ii), a0 = path.q_ss(j, ii);
        double j1 = path.q_sss(j, ii + 1);
        if (corner_points.count(i + 1) != 0) j1 = path.q_sss(j, ii);
        // The quintic's q_sss is ~ (q1 - q0 - ...) / h^3: on micrometre segments the rounding
        // of q (1e-16 of |q|) alone gave it errors several times the true q_sss (100 m/m^3
        // against 22 on 3 um segments), which the jerk rows then obeyed. Where q1 - q0 agrees
        // with the derivatives' own increment to within that rounding, the increment is taken
        // from the derivatives (exact to O(h^7), and computed from small numbers); the knot
        // then moves by at most a few ulps of q.
        const double increment = 0.5 * h * (v0 + v1) - 0.1 * h * h * (a1 - a0) +
                                 h * h * h * (path.q_sss(j, ii) + j1) / 120.0;
        const double rounding = 8.0 * (std::abs(q0) + std::abs(q1)) * std::numeric_limits<double>::epsilon();
        const double dq = std::abs((q1 - q0) - increment) <= rounding ? increment : q1 - q0;
        hermite(h, q0, v0, a0, dq, v1, a1, c);
        for (int m = 0; m < 6; ++m) coefficients_(j, static_cast<Eigen::Index>(6 * i) + m) = c[m];
      }
    }
    return;
  }
  // Paths from solve_path_kinematics: per stretch between corners, the clamped C2 cubic
  // spline through the points (end slopes from the fits). Its derivatives are its own, so the
  // planner's rows see the q_sss the set points really have.
  std::vector<std::size_t> ends{0};
  for (std::size_t i = 1; i + 1 < n; ++i) {
    if (corner_points.count(i) != 0) ends.push_back(i);
  }
  ends.push_back(n - 1);
  std::vector<double> y, slope, second;
  for (std::size_t e = 0; e + 1 < ends.size(); ++e) {
    const std::size_t a = ends[e], b = ends[e + 1];
    for (Eigen::Index j = 0; j < axes; ++j) {
      y.resize(b - a + 1);
      for (std::size_t i = a; i <= b; ++i) y[i - a] = path.q(j, static_cast<Eigen::Index>(i));
      double v_end = path.q_s(j, static_cast<Eigen::Index>(b)), unused = 0.0;
      if (corner_points.count(b) != 0) incoming(j, b - 1, v_end, unused);
      clamped_cubic(s_m_, a, b, y, path.q_s(j, static_cast<Eigen::Index>(a)), v_end, slope, second);
      for (std::size_t i = a; i < b; ++i) {
        double c[6];
        const std::size_t k = i - a;
        hermite(s_m_[i + 1] - s_m_[i], y[k], slope[k], second[k], y[k + 1] - y[k], slope[k + 1], second[k + 1], c);
        for (int m = 0; m < 6; ++m) coefficients_(j, static_cast<Eigen::Index>(6 * i) + m) = c[m];
      }
    }
  }
}

std::size_t PathSpline::segment_of(double s) const {
  const auto it = std::upper_bound(s_m_.begin(), s_m_.end(), s);
  if (it == s_m_.begin()) return 0;
  const auto index = static_cast<std::size_t>(it - s_m_.begin()) - 1;
  return std::min(index, segment_count() - 1);
}

void PathSpline::evaluate(std::size_t segment, double t, Eigen::VectorXd* q, Eigen::VectorXd* q_s,
                          Eigen::VectorXd* q_ss, Eigen::VectorXd* q_sss) const {
  const auto c = static_cast<Eigen::Index>(6 * segment);
  const auto k = coefficients_.middleCols(c, 6);
  if (q != nullptr) {
    *q = k.col(0) + t * (k.col(1) + t * (k.col(2) + t * (k.col(3) + t * (k.col(4) + t * k.col(5)))));
  }
  if (q_s != nullptr) {
    *q_s = k.col(1) +
           t * (2.0 * k.col(2) + t * (3.0 * k.col(3) + t * (4.0 * k.col(4) + t * 5.0 * k.col(5))));
  }
  if (q_ss != nullptr) {
    *q_ss = 2.0 * k.col(2) + t * (6.0 * k.col(3) + t * (12.0 * k.col(4) + t * 20.0 * k.col(5)));
  }
  if (q_sss != nullptr) *q_sss = 6.0 * k.col(3) + t * (24.0 * k.col(4) + t * 60.0 * k.col(5));
}

Eigen::VectorXd PathSpline::position(double s) const {
  const std::size_t segment = segment_of(s);
  Eigen::VectorXd q;
  evaluate(segment, s - s_m_[segment], &q, nullptr, nullptr, nullptr);
  return q;
}

}  // namespace vmsim::planner
