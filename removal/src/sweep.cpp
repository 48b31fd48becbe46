#include "sweep.hpp"

#include <Eigen/Geometry>
#include <Eigen/LU>

#include <algorithm>
#include <cmath>

#include "vmsim/common/errors.hpp"

namespace vmsim::removal::detail {
namespace {

// Golden-section minimum of a convex function on [a, b]; returns the minimum value and its
// argument. 60 steps shrink the bracket by 0.618^60 ~ 3e-13.
template <class F>
double golden_min(F&& f, double a, double b, double& arg, int steps = 60) {
  constexpr double g = 0.6180339887498949;
  double x1 = b - g * (b - a), x2 = a + g * (b - a);
  double f1 = f(x1), f2 = f(x2);
  for (int i = 0; i < steps; ++i) {
    if (f1 <= f2) {
      b = x2;
      x2 = x1;
      f2 = f1;
      x1 = b - g * (b - a);
      f1 = f(x1);
    } else {
      a = x1;
      x1 = x2;
      f1 = f2;
      x2 = a + g * (b - a);
      f2 = f(x2);
    }
  }
  // The ends too: the minimum of a convex function on a closed interval may sit on an end.
  double best = f1, best_arg = x1;
  if (f2 < best) best = f2, best_arg = x2;
  arg = best_arg;
  return best;
}

template <class F>
double golden_min_with_ends(F&& f, double a, double b, double& arg) {
  double best = golden_min(f, a, b, arg);
  const double fa = f(a), fb = f(b);
  if (fa < best) best = fa, arg = a;
  if (fb < best) best = fb, arg = b;
  return best;
}

// Clips [t0, t1] by lo <= v0 + v1 t <= hi; false when empty.
bool clip(double v0, double v1, double lo, double hi, double& t0, double& t1) {
  if (v1 == 0.0) return v0 >= lo && v0 <= hi;
  double ta = (lo - v0) / v1, tb = (hi - v0) / v1;
  if (ta > tb) std::swap(ta, tb);
  t0 = std::max(t0, ta);
  t1 = std::min(t1, tb);
  return t0 <= t1;
}

void merge(bool hit, double a0, double a1, bool& any, double& t0, double& t1) {
  if (!hit) return;
  if (!any) {
    t0 = a0, t1 = a1, any = true;
  } else {
    t0 = std::min(t0, a0);
    t1 = std::max(t1, a1);
  }
}

// Signed distance to the core Disc(rho) (+) Segment(0, ell a), x relative to its base centre.
double core_sdf(const Eigen::Vector3d& x, const Eigen::Vector3d& a, double rho, double ell) {
  const double lambda = x.dot(a);
  const double radial = (x - lambda * a).norm();
  const double dr = radial - rho;
  const double dz = std::abs(lambda - 0.5 * ell) - 0.5 * ell;
  const double outside = std::hypot(std::max(dr, 0.0), std::max(dz, 0.0));
  return outside + std::min(std::max(dr, dz), 0.0);
}

double segment_distance(const Eigen::Vector3d& p, const Eigen::Vector3d& A, const Eigen::Vector3d& B) {
  const Eigen::Vector3d d = B - A;
  const double dd = d.squaredNorm();
  double s = dd > 0.0 ? (p - A).dot(d) / dd : 0.0;
  s = std::clamp(s, 0.0, 1.0);
  return (p - A - s * d).norm();
}

// Unsigned distance to the parallelogram c0 + sigma (c1 - c0) + lambda ell a.
double parallelogram_distance(const Sweep& s, const Eigen::Vector3d& p) {
  const Eigen::Vector3d e1 = s.c1 - s.c0, e2 = s.ell * s.a;
  const Eigen::Vector3d n = e1.cross(e2);
  const double nn = n.norm();
  if (nn > 1e-14 * e1.norm() * e2.norm() && nn > 0.0) {
    Eigen::Matrix3d m;
    m.col(0) = e1, m.col(1) = e2, m.col(2) = n / nn;
    const Eigen::Vector3d k = m.inverse() * (p - s.c0);
    if (k[0] >= 0.0 && k[0] <= 1.0 && k[1] >= 0.0 && k[1] <= 1.0) return std::abs(k[2]);
  }
  const Eigen::Vector3d top0 = s.c0 + e2, top1 = s.c1 + e2;
  return std::min({segment_distance(p, s.c0, s.c1), segment_distance(p, top0, top1),
                   segment_distance(p, s.c0, top0), segment_distance(p, s.c1, top1)});
}

}  // namespace

double distance_2d(double px, double py, double ax, double ay, double bx, double by) {
  const double dx = bx - ax, dy = by - ay;
  const double wx = px - ax, wy = py - ay;
  const double dd = dx * dx + dy * dy;
  double s = dd > 0.0 ? (wx * dx + wy * dy) / dd : 0.0;
  s = std::clamp(s, 0.0, 1.0);
  const double ex = wx - s * dx, ey = wy - s * dy;
  return std::sqrt(ex * ex + ey * ey);
}

Sweep make_sweep(const Eigen::Vector3d& c0, const Eigen::Vector3d& c1, const Eigen::Vector3d& a,
                 double rho, double r, double ell) {
  Sweep s;
  s.c0 = c0, s.c1 = c1, s.a = a, s.rho = rho, s.r = r, s.ell = ell;
  s.vertical = a.x() == 0.0 && a.y() == 0.0 && a.z() == 1.0;
  for (int i = 0; i < 3; ++i) {
    const double disc = rho * std::sqrt(std::max(0.0, 1.0 - a[i] * a[i]));
    const double lo0 = std::min(c0[i], c0[i] + ell * a[i]), hi0 = std::max(c0[i], c0[i] + ell * a[i]);
    const double lo1 = std::min(c1[i], c1[i] + ell * a[i]), hi1 = std::max(c1[i], c1[i] + ell * a[i]);
    s.lo[i] = std::min(lo0, lo1) - disc - r;
    s.hi[i] = std::max(hi0, hi1) + disc + r;
  }
  return s;
}

void split_segment(const Tool& tool, const Pose& pose0, const Pose& pose1, double tolerance_m,
                   std::vector<Sweep>& out) {
  const double r = tool.corner_radius(), rho = tool.disc_radius(), ell = tool.core_length();
  const Eigen::Vector3d a0 = pose0.axis_W.normalized(), a1 = pose1.axis_W.normalized();
  const Eigen::Vector3d c0 = pose0.tip_W_m + r * a0, c1 = pose1.tip_W_m + r * a1;
  const double theta = std::atan2(a0.cross(a1).norm(), a0.dot(a1));
  if (theta == 0.0) {
    out.push_back(make_sweep(c0, c1, a0, rho, r, ell));
    return;
  }
  if (theta > 3.0) {
    throw InputError("tool axis turns by " + std::to_string(theta * 180.0 / M_PI) +
                     " deg between two trajectory samples: no unique interpolation");
  }
  const double extent = std::hypot(ell, rho);
  const double steps = std::ceil(theta * extent / (2.0 * tolerance_m));
  if (steps > 1e6) {
    throw InputError("tool axis turns by " + std::to_string(theta * 180.0 / M_PI) +
                     " deg in one segment: more than 1e6 sub-steps for the orientation tolerance");
  }
  const int n = std::max(1, static_cast<int>(steps));
  const double sin_theta = std::sin(theta);
  for (int k = 0; k < n; ++k) {
    const double sa = static_cast<double>(k) / n, sb = static_cast<double>(k + 1) / n;
    const double sm = 0.5 * (sa + sb);
    const Eigen::Vector3d a =
        ((std::sin((1.0 - sm) * theta) * a0 + std::sin(sm * theta) * a1) / sin_theta).normalized();
    out.push_back(make_sweep(c0 + sa * (c1 - c0), c0 + sb * (c1 - c0), a, rho, r, ell));
  }
}

bool capsule_interval(const Eigen::Vector3d& A, const Eigen::Vector3d& B, double R,
                      const Eigen::Vector3d& o, const Eigen::Vector3d& u, double& t0, double& t1) {
  bool any = false;
  const Eigen::Vector3d m = o - A;
  // End spheres: |m + t u|^2 = R^2, the discriminant from the perpendicular part (no cancellation).
  auto sphere = [&](const Eigen::Vector3d& mm) {
    const double mu = mm.dot(u);
    const double disc = R * R - (mm - mu * u).squaredNorm();
    if (disc < 0.0) return;
    const double root = std::sqrt(disc);
    merge(true, -mu - root, -mu + root, any, t0, t1);
  };
  sphere(m);
  const Eigen::Vector3d d = B - A;
  const double dd = d.squaredNorm();
  if (dd > 0.0) {
    sphere(o - B);
    // Infinite cylinder about the axis, in the plane normal to d scaled by |d|:
    // |M + t U|^2 = dd R^2 with M = m x d, U = u x d.
    const Eigen::Vector3d M = m.cross(d), U = u.cross(d);
    const double uu = U.squaredNorm();
    double c0 = -kInf, c1 = kInf;
    bool hit = true;
    if (uu > 1e-30 * dd) {
      const double triple = m.dot(U);
      const double disc = dd * (uu * R * R - triple * triple);
      if (disc < 0.0) {
        hit = false;
      } else {
        const double b = M.dot(U), root = std::sqrt(disc);
        c0 = (-b - root) / uu;
        c1 = (-b + root) / uu;
      }
    } else {
      hit = M.squaredNorm() <= dd * R * R;
    }
    // Between the end planes: 0 <= (m + t u) . d <= dd.
    if (hit) hit = clip(m.dot(d), u.dot(d), 0.0, dd, c0, c1);
    if (hit && std::isfinite(c0) && std::isfinite(c1)) merge(true, c0, c1, any, t0, t1);
  }
  return any;
}

double signed_distance(const Sweep& s, const Eigen::Vector3d& p) {
  if (s.rho == 0.0) return parallelogram_distance(s, p) - s.r;
  const Eigen::Vector3d delta = s.c1 - s.c0, x = p - s.c0;
  double arg = 0.0;
  return golden_min_with_ends(
             [&](double t) { return core_sdf(x - t * delta, s.a, s.rho, s.ell); }, 0.0, 1.0, arg) -
         s.r;
}

bool vertical_entry(const Sweep& s, double x, double y, double& z0, double& z1) {
  z1 = std::max(s.c0.z(), s.c1.z()) + s.ell + s.r;
  if (s.rho == 0.0 && s.c0.z() == s.c1.z()) {  // ball, horizontal: the 2-D distance decides
    const double d = distance_2d(x, y, s.c0.x(), s.c0.y(), s.c1.x(), s.c1.y());
    if (d > s.r) return false;
    z0 = s.c0.z() - std::sqrt((s.r - d) * (s.r + d));
    return true;
  }
  if (s.rho == 0.0) {
    double t0 = 0.0, t1 = 0.0;
    if (!capsule_interval(s.c0, s.c1, s.r, Eigen::Vector3d(x, y, 0.0), Eigen::Vector3d::UnitZ(), t0, t1)) {
      return false;
    }
    z0 = t0;
    return true;
  }
  const double reach = s.rho + s.r;
  const double dz = s.c1.z() - s.c0.z();
  const double dx = s.c1.x() - s.c0.x(), dy = s.c1.y() - s.c0.y();
  const double wx = x - s.c0.x(), wy = y - s.c0.y();
  auto depth = [&](double radial) {  // how far below c the tool reaches at this radial distance
    const double e = std::max(0.0, radial - s.rho);
    return std::sqrt(std::max(0.0, s.r * s.r - e * e));
  };
  if (dz == 0.0) {
    const double d = distance_2d(x, y, s.c0.x(), s.c0.y(), s.c1.x(), s.c1.y());
    if (d > reach) return false;
    z0 = s.c0.z() - depth(d);
    return true;
  }
  // The s where the footprint covers (x, y): |w - s delta| <= reach.
  const double dd = dx * dx + dy * dy;
  double sa = 0.0, sb = 1.0;
  if (dd == 0.0) {
    if (std::hypot(wx, wy) > reach) return false;
  } else {
    const double wd = wx * dx + wy * dy, cross = wx * dy - wy * dx;
    const double disc = dd * reach * reach - cross * cross;
    if (disc < 0.0) return false;
    const double root = std::sqrt(disc);
    sa = std::max(0.0, (wd - root) / dd);
    sb = std::min(1.0, (wd + root) / dd);
    if (sa > sb) return false;
  }
  auto radial = [&](double t) { return std::hypot(wx - t * dx, wy - t * dy); };
  if (s.r == 0.0) {  // flat end: the bottom disc is flat, the lowest covering position wins
    z0 = s.c0.z() + (dz > 0.0 ? sa : sb) * dz;
    return true;
  }
  double arg = 0.0;
  z0 = golden_min_with_ends([&](double t) { return s.c0.z() + t * dz - depth(radial(t)); }, sa, sb, arg);
  return true;
}

bool line_interval(const Sweep& s, const Eigen::Vector3d& o, const Eigen::Vector3d& u, double& t0,
                   double& t1) {
  if (s.vertical && u.x() == 0.0 && u.y() == 0.0 && u.z() == 1.0) {
    double z0 = 0.0, z1 = 0.0;
    if (!vertical_entry(s, o.x(), o.y(), z0, z1)) return false;
    t0 = z0 - o.z();
    t1 = z1 - o.z();
    return true;
  }
  if (s.rho == 0.0) {
    bool any = false;
    auto capsule = [&](const Eigen::Vector3d& A, const Eigen::Vector3d& B) {
      double a0 = 0.0, a1 = 0.0;
      const bool hit = capsule_interval(A, B, s.r, o, u, a0, a1);
      merge(hit, a0, a1, any, t0, t1);
    };
    capsule(s.c0, s.c1);
    if (s.ell > 0.0) {
      const Eigen::Vector3d e2 = s.ell * s.a;
      capsule(s.c0 + e2, s.c1 + e2);
      capsule(s.c0, s.c0 + e2);
      capsule(s.c1, s.c1 + e2);
      // The slab over the parallelogram's interior.
      const Eigen::Vector3d e1 = s.c1 - s.c0, n = e1.cross(e2);
      const double nn = n.norm();
      if (nn > 1e-12 * e1.norm() * e2.norm() && nn > 0.0) {
        Eigen::Matrix3d m;
        m.col(0) = e1, m.col(1) = e2, m.col(2) = n / nn;
        const Eigen::Matrix3d inv = m.inverse();
        const Eigen::Vector3d k0 = inv * (o - s.c0), k1 = inv * u;
        double b0 = -kInf, b1 = kInf;
        if (clip(k0[0], k1[0], 0.0, 1.0, b0, b1) && clip(k0[1], k1[1], 0.0, 1.0, b0, b1) &&
            clip(k0[2], k1[2], -s.r, s.r, b0, b1) && std::isfinite(b0) && std::isfinite(b1)) {
          merge(true, b0, b1, any, t0, t1);
        }
      }
    }
    return any;
  }
  // Flat-end / bull-nose, general directions: S(t) = signed distance of o + t u to the sweep is
  // convex in t; its sub-zero set is the interval.
  double b0 = -kInf, b1 = kInf;
  for (int i = 0; i < 3; ++i) {
    if (!clip(o[i], u[i], s.lo[i], s.hi[i], b0, b1)) return false;
  }
  if (!std::isfinite(b0) || !std::isfinite(b1)) return false;
  auto S = [&](double t) { return signed_distance(s, o + t * u); };
  double tm = 0.0;
  const double smin = golden_min_with_ends(S, b0, b1, tm);
  if (smin > 0.0) return false;
  auto root = [&](double inside, double outside) {  // S(inside) <= 0 < S(outside)
    for (int i = 0; i < 200 && std::abs(outside - inside) > 1e-13; ++i) {
      const double mid = 0.5 * (inside + outside);
      (S(mid) <= 0.0 ? inside : outside) = mid;
    }
    return 0.5 * (inside + outside);
  };
  t0 = S(b0) <= 0.0 ? b0 : root(tm, b0);
  t1 = S(b1) <= 0.0 ? b1 : root(tm, b1);
  return true;
}

}  // namespace vmsim::removal::detail
