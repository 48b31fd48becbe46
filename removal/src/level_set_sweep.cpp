#include "level_set_sweep.hpp"

#include <Eigen/Geometry>
#include <Eigen/LU>

#include <algorithm>
#include <cmath>

namespace vmsim::removal::detail {
namespace {

// Signed distance to the core Disc(rho) (+) Segment(0, ell a) given the radial distance from its
// axis (or, for a prism, from its centre segment) and the axial coordinate v.
inline double core_distance(double radial, double v, double rho, double ell) {
  const double dr = radial - rho;
  const double dz = std::abs(v - 0.5 * ell) - 0.5 * ell;
  const double er = std::max(dr, 0.0), ez = std::max(dz, 0.0);  // sqrt: std::hypot is slow here
  return std::sqrt(er * er + ez * ez) + std::min(std::max(dr, dz), 0.0);
}

inline double segment_distance(const Eigen::Vector3d& p, const Eigen::Vector3d& A, const Eigen::Vector3d& e) {
  const double ee = e.squaredNorm();
  const double s = ee > 0.0 ? std::clamp((p - A).dot(e) / ee, 0.0, 1.0) : 0.0;
  return (p - A - s * e).norm();
}

}  // namespace

SweepDistance::SweepDistance(const Sweep& s, double tolerance_m)
    : c0(s.c0), d(s.c1 - s.c0), a(s.a), rho(s.rho), r(s.r), ell(s.ell), lo(s.lo), hi(s.hi) {
  a_dot_d = a.dot(d);
  const double dn = d.norm();
  d_perp = (d - a_dot_d * a).norm();
  if (s.profile.active) {
    // A conical tool: its section's signed distance is non-decreasing in the radius, so for a
    // motion normal to the axis the nearest tool is the one whose axis passes nearest (closed
    // form); else golden section as for `general`.
    kind = Kind::profile;
    profile = s.profile;
    golden_steps = std::abs(a_dot_d) <= 1e-9 * dn ? 0
                   : dn > tolerance_m
                       ? static_cast<int>(std::ceil(std::log(tolerance_m / dn) / std::log(0.6180339887498949)))
                       : 1;
    return;
  }
  // Perpendicular enough: projecting d on the plane normal to a moves the sweep by |a.d|.
  if (std::abs(a_dot_d) <= 1e-9 * dn) {
    kind = Kind::prism;
    Eigen::Vector3d dp = d - a_dot_d * a;
    length = dp.norm();
    if (length > 0.0) {
      e1 = dp / length;
    } else {  // at rest: any direction normal to a
      e1 = a.unitOrthogonal();
    }
    e3 = e1.cross(a);
  } else if (rho == 0.0) {
    kind = Kind::parallelogram;
    const Eigen::Vector3d e2 = ell * a, n = d.cross(e2);
    const double nn = n.norm();
    if (nn > 1e-14 * dn * e2.norm() && nn > 0.0) {
      Eigen::Matrix3d m;
      m.col(0) = d, m.col(1) = e2, m.col(2) = n / nn;
      inverse = m.inverse();
    } else {
      inverse.setZero();  // degenerate: the four edges cover it
      inverse(0, 0) = std::numeric_limits<double>::quiet_NaN();
    }
  } else {
    kind = Kind::general;
    // Bracket after n golden steps: |d| 0.618^n; the value is |d|-Lipschitz in sigma.
    golden_steps = dn > tolerance_m
                       ? static_cast<int>(std::ceil(std::log(tolerance_m / dn) / std::log(0.6180339887498949)))
                       : 1;
  }
}

double SweepDistance::start_core(const Eigen::Vector3d& p) const {
  const Eigen::Vector3d q = p - c0;
  const double v = q.dot(a);
  return core_distance((q - v * a).norm(), v, rho, ell);
}

double SweepDistance::start_tool(const Eigen::Vector3d& p) const { return start_core(p) - r; }

double SweepDistance::operator()(const Eigen::Vector3d& p) const {
  const Eigen::Vector3d q = p - c0;
  switch (kind) {
    case Kind::profile: {
      if (golden_steps == 0) {
        const double axial = q.dot(a);
        const Eigen::Vector3d w = q - axial * a;
        const double dd = d.squaredNorm();
        const double sigma = dd > 0.0 ? std::clamp(w.dot(d) / dd, 0.0, 1.0) : 0.0;
        return profile.signed_distance((w - sigma * d).norm(), axial);
      }
      return profile_sweep_distance(profile, c0, c0 + d, a, p, golden_steps);
    }
    case Kind::prism: {
      return prism(q.dot(e1), q.dot(a), q.dot(e3));
    }
    case Kind::parallelogram: {
      const Eigen::Vector3d e2 = ell * a;
      if (!std::isnan(inverse(0, 0))) {
        const Eigen::Vector3d k = inverse * q;
        if (k[0] >= 0.0 && k[0] <= 1.0 && k[1] >= 0.0 && k[1] <= 1.0) return std::abs(k[2]) - r;
      }
      const double dist = std::min({segment_distance(p, c0, d), segment_distance(p, c0 + e2, d),
                                    segment_distance(p, c0, e2), segment_distance(p, c0 + d, e2)});
      return dist - r;
    }
    case Kind::general: {
      auto f = [&](double sigma) {
        const Eigen::Vector3d x = q - sigma * d;
        const double v = x.dot(a);
        return core_distance((x - v * a).norm(), v, rho, ell);
      };
      constexpr double g = 0.6180339887498949;
      double lo_s = 0.0, hi_s = 1.0;
      double x1 = hi_s - g, x2 = g;
      double f1 = f(x1), f2 = f(x2);
      for (int i = 0; i < golden_steps; ++i) {
        if (f1 <= f2) {
          hi_s = x2, x2 = x1, f2 = f1;
          x1 = hi_s - g * (hi_s - lo_s);
          f1 = f(x1);
        } else {
          lo_s = x1, x1 = x2, f1 = f2;
          x2 = lo_s + g * (hi_s - lo_s);
          f2 = f(x2);
        }
      }
      return std::min({f1, f2, f(0.0), f(1.0)}) - r;
    }
  }
  return 0.0;
}

bool SweepDistance::behind_start(const Eigen::Vector3d& box_lo, const Eigen::Vector3d& box_hi) const {
  double max_proj = -c0.dot(d), ax_lo = -c0.dot(a), ax_hi = ax_lo;
  for (int i = 0; i < 3; ++i) {
    max_proj += std::max(box_lo[i] * d[i], box_hi[i] * d[i]);
    ax_lo += std::min(box_lo[i] * a[i], box_hi[i] * a[i]);
    ax_hi += std::max(box_lo[i] * a[i], box_hi[i] * a[i]);
  }
  const double lam_lo = std::clamp(ax_lo, 0.0, ell), lam_hi = std::clamp(ax_hi, 0.0, ell);
  const double bound = std::min(lam_lo * a_dot_d, lam_hi * a_dot_d) - rho * d_perp;
  return max_proj <= bound;
}

}  // namespace vmsim::removal::detail
