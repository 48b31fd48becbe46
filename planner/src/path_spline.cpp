// Quintic Hermite interpolation of q(s) (see feedrate.hpp).
#include <algorithm>
#include <cmath>
#include <set>
#include <string>

#include "vmsim/common/errors.hpp"
#include "vmsim/common/files.hpp"
#include "vmsim/planner/feedrate.hpp"

namespace vmsim::planner {

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
      throw InputError("path point " + std::to_string(i + 1) + " (s = " +
                       format_double(s_m_[i] * 1e3) +
                       " mm) changes the tool orientation without moving the tip: a feed along "
                       "the tip's arc length is undefined there");
    }
    const auto ii = static_cast<Eigen::Index>(i);
    for (Eigen::Index j = 0; j < axes; ++j) {
      const double q0 = path.q(j, ii), v0 = path.q_s(j, ii), a0 = path.q_ss(j, ii);
      const double q1 = path.q(j, ii + 1);
      double v1 = path.q_s(j, ii + 1), a1 = path.q_ss(j, ii + 1);
      if (corner_points.count(i + 1) != 0) {  // incoming side of a corner: extrapolate
        const double j0 = path.q_sss(j, ii);
        v1 = v0 + a0 * h + 0.5 * j0 * h * h;
        a1 = a0 + j0 * h;
      }
      const double dq = q1 - q0;
      const Eigen::Index c = static_cast<Eigen::Index>(6 * i);
      coefficients_(j, c + 0) = q0;
      coefficients_(j, c + 1) = v0;
      coefficients_(j, c + 2) = 0.5 * a0;
      coefficients_(j, c + 3) =
          (20.0 * dq - (8.0 * v1 + 12.0 * v0) * h - (3.0 * a0 - a1) * h * h) / (2.0 * h * h * h);
      coefficients_(j, c + 4) = (-30.0 * dq + (14.0 * v1 + 16.0 * v0) * h +
                                 (3.0 * a0 - 2.0 * a1) * h * h) /
                                (2.0 * h * h * h * h);
      coefficients_(j, c + 5) = (12.0 * dq - 6.0 * (v1 + v0) * h + (a1 - a0) * h * h) /
                                (2.0 * h * h * h * h * h);
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
