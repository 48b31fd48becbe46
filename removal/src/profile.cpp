#include "profile.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "sweep.hpp"

namespace vmsim::removal::detail {
namespace {

// Golden-section minimum of a convex function on [a, b], the ends included; returns the value
// and sets its argument. 80 steps shrink the bracket by 0.618^80 ~ 2e-17.
template <class F>
double golden_min_ends(F&& f, double a, double b, double& arg, int steps = 80) {
  constexpr double g = 0.6180339887498949;
  const double fa = f(a), fb = f(b);
  double lo = a, hi = b;
  double x1 = hi - g * (hi - lo), x2 = lo + g * (hi - lo);
  double f1 = f(x1), f2 = f(x2);
  for (int i = 0; i < steps && hi - lo > 0.0; ++i) {
    if (f1 <= f2) {
      hi = x2, x2 = x1, f2 = f1;
      x1 = hi - g * (hi - lo);
      f1 = f(x1);
    } else {
      lo = x1, x1 = x2, f1 = f2;
      x2 = lo + g * (hi - lo);
      f2 = f(x2);
    }
  }
  double best = f1;
  arg = x1;
  if (f2 < best) best = f2, arg = x2;
  if (fa < best) best = fa, arg = a;
  if (fb < best) best = fb, arg = b;
  return best;
}

// {t : A t^2 + B t + C <= 0} as up to two intervals [lo[k], hi[k]]; returns their count.
int quadratic_at_most_zero(double A, double B, double C, double lo[2], double hi[2]) {
  if (A == 0.0) {
    if (B > 0.0) return lo[0] = -kInf, hi[0] = -C / B, 1;
    if (B < 0.0) return lo[0] = -C / B, hi[0] = kInf, 1;
    return C <= 0.0 ? (lo[0] = -kInf, hi[0] = kInf, 1) : 0;
  }
  const double disc = B * B - 4.0 * A * C;
  if (disc < 0.0) {
    if (A > 0.0) return 0;
    return lo[0] = -kInf, hi[0] = kInf, 1;
  }
  // Roots without cancellation.
  const double q = -0.5 * (B + std::copysign(std::sqrt(disc), B));
  double r1 = q != 0.0 ? q / A : 0.0, r2 = q != 0.0 ? C / q : 0.0;
  if (r1 > r2) std::swap(r1, r2);
  if (A > 0.0) return lo[0] = r1, hi[0] = r2, 1;
  lo[0] = -kInf, hi[0] = r1, lo[1] = r2, hi[1] = kInf;
  return 2;
}

// [lo, hi] narrowed to {t : v0 + v1 t >= 0}; false when empty.
bool keep_nonnegative(double v0, double v1, double& lo, double& hi) {
  if (v1 > 0.0) {
    lo = std::max(lo, -v0 / v1);
  } else if (v1 < 0.0) {
    hi = std::min(hi, -v0 / v1);
  } else if (v0 < 0.0) {
    return false;
  }
  return lo <= hi;
}

// Signed distance from q to the segment p0 p1 of a convex counter-clockwise polygon: the
// distance, and whether q is on the inner side of the edge's line.
double segment_distance_2d(const Eigen::Vector2d& q, const Eigen::Vector2d& p0, const Eigen::Vector2d& p1) {
  const Eigen::Vector2d e = p1 - p0, w = q - p0;
  const double ee = e.squaredNorm();
  const double s = ee > 0.0 ? std::clamp(w.dot(e) / ee, 0.0, 1.0) : 0.0;
  return (w - s * e).norm();
}

}  // namespace

Profile make_profile(const Tool& tool) {
  Profile p;
  p.active = true;
  p.length = tool.length_m;
  const double R = 0.5 * tool.diameter_m;
  const double beta = tool.type == ToolType::v ? 0.5 * tool.tip_angle_rad : tool.taper_angle_rad;
  p.tan_beta = std::tan(beta);
  if (tool.type == ToolType::tapered_ball) {
    p.r_ball = 0.5 * tool.tip_diameter_m;
    p.rho_f = p.r_ball * std::cos(beta);
    p.zeta_f = p.r_ball * (1.0 - std::sin(beta));
  } else {
    p.r_tip = 0.5 * tool.tip_diameter_m;
    p.rho_f = p.r_tip;
    p.zeta_f = 0.0;
  }
  // The flank ends at the diameter D, or at the length if it gets there first.
  const double zeta_R = p.tan_beta > 0.0 ? p.zeta_f + (R - p.rho_f) / p.tan_beta : kInf;
  if (zeta_R <= p.length) {
    p.rho_1 = R, p.zeta_1 = zeta_R;
  } else {
    p.zeta_1 = p.length;
    p.rho_1 = p.rho_f + (p.length - p.zeta_f) * p.tan_beta;
  }
  return p;
}

double Profile::lower(double radial) const {
  if (radial > rho_1) return kInf;
  if (radial <= rho_f) return r_ball > 0.0 ? r_ball - std::sqrt((r_ball - radial) * (r_ball + radial)) : 0.0;
  return zeta_f + (radial - rho_f) / tan_beta;  // (rho_1 > rho_f: tan_beta > 0)
}

double Profile::signed_distance(double radial, double axial) const {
  // The polygon part, symmetric about the axis, counter-clockwise (rho right, zeta up); for the
  // ball its bottom edge is the flank's start circle (the ball's cap below it added after).
  const Eigen::Vector2d v[6] = {{-rho_f, zeta_f}, {rho_f, zeta_f}, {rho_1, zeta_1},
                                {rho_1, length},  {-rho_1, length}, {-rho_1, zeta_1}};
  const Eigen::Vector2d q(radial, axial);
  double d = kInf;
  bool inside = true;
  for (int i = 0; i < 6; ++i) {
    const Eigen::Vector2d& p0 = v[i];
    const Eigen::Vector2d& p1 = v[(i + 1) % 6];
    d = std::min(d, segment_distance_2d(q, p0, p1));
    const Eigen::Vector2d e = p1 - p0, w = q - p0;
    if (e.x() * w.y() - e.y() * w.x() < 0.0) inside = false;  // (a zero-length edge never says outside)
  }
  double sd = inside ? -d : d;
  if (r_ball > 0.0) sd = std::min(sd, std::hypot(radial, axial - r_ball) - r_ball);
  return sd;
}

bool Profile::line_interval(const Eigen::Vector3d& tip, const Eigen::Vector3d& a, const Eigen::Vector3d& o,
                            const Eigen::Vector3d& u, double& t0, double& t1) const {
  const Eigen::Vector3d w = o - tip;
  const double wa = w.dot(a), ua = u.dot(a);
  const Eigen::Vector3d wp = w - wa * a, up = u - ua * a;
  const double uu = up.squaredNorm(), wu = wp.dot(up), ww = wp.squaredNorm();
  bool any = false;
  // The part above the flank's start circle: zeta_f <= zeta <= length, rho <= rho_1, and the
  // cone nappe rho <= m = rho_f + (zeta - zeta_f) tan(beta) (with m >= 0).
  double lo = -kInf, hi = kInf;
  bool hit = keep_nonnegative(wa - zeta_f, ua, lo, hi) && keep_nonnegative(length - wa, -ua, lo, hi);
  double qlo[2], qhi[2];
  if (hit) {
    const int n = quadratic_at_most_zero(uu, 2.0 * wu, ww - rho_1 * rho_1, qlo, qhi);
    hit = n == 1 && (lo = std::max(lo, qlo[0]), hi = std::min(hi, qhi[0]), lo <= hi);
  }
  if (hit && rho_1 > rho_f) {
    const double m0 = rho_f + (wa - zeta_f) * tan_beta, m1 = ua * tan_beta;
    const int n = quadratic_at_most_zero(uu - m1 * m1, 2.0 * (wu - m0 * m1), ww - m0 * m0, qlo, qhi);
    double clo = kInf, chi = -kInf;  // the nappe m >= 0 (a convex set: one interval)
    for (int k = 0; k < n; ++k) {
      double a0 = qlo[k], a1 = qhi[k];
      if (keep_nonnegative(m0, m1, a0, a1)) clo = std::min(clo, a0), chi = std::max(chi, a1);
    }
    lo = std::max(lo, clo), hi = std::min(hi, chi);
    hit = lo <= hi;
  }
  if (hit) t0 = lo, t1 = hi, any = true;
  if (r_ball > 0.0) {
    // The ball (its cap below the flank's start circle; the rest lies inside the part above).
    const Eigen::Vector3d m = w - r_ball * a;
    const double mu = m.dot(u);
    const double disc = r_ball * r_ball - (m - mu * u).squaredNorm();
    if (disc >= 0.0) {
      const double root = std::sqrt(disc);
      if (any) {
        t0 = std::min(t0, -mu - root), t1 = std::max(t1, -mu + root);
      } else {
        t0 = -mu - root, t1 = -mu + root;
      }
      any = true;
    }
  }
  return any;
}

bool profile_sweep_interval(const Profile& profile, const Eigen::Vector3d& tip0, const Eigen::Vector3d& tip1,
                            const Eigen::Vector3d& a, const Eigen::Vector3d& o, const Eigen::Vector3d& u, double& t0,
                            double& t1) {
  const Eigen::Vector3d d = tip1 - tip0;
  auto at = [&](double sigma, double& e, double& x) { return profile.line_interval(tip0 + sigma * d, a, o, u, e, x); };
  if (d.squaredNorm() == 0.0) return at(0.0, t0, t1);
  // Every tool of the motion lies in this capsule (its axis' middle swept, the half-diagonal).
  const double half = 0.5 * profile.length;
  double ca = 0.0, cb = 0.0;
  if (!capsule_interval(tip0 + half * a, tip1 + half * a, std::hypot(profile.rho_1, half), o, u, ca, cb)) return false;
  double e = 0.0, x = 0.0;
  double s_in = std::numeric_limits<double>::quiet_NaN();
  for (double sigma : {0.0, 1.0, 0.5, 0.25, 0.75}) {
    if (at(sigma, e, x)) {
      s_in = sigma;
      break;
    }
  }
  if (std::isnan(s_in)) {
    // g(sigma), the least signed distance along the line of the tool at sigma, is convex and
    // |d|-Lipschitz in sigma: on [s0, s1] it stays above (g(s0) + g(s1) - |d| (s1 - s0)) / 2,
    // so intervals where that is positive hold no tool the line meets (branch and bound);
    // a negative value found is a tool the line meets. The inner minimum over t (convex too)
    // stops at the first negative value.
    const double lip = d.norm();
    auto along = [&](double sigma) {
      const Eigen::Vector3d tip = tip0 + sigma * d;
      auto sd = [&](double t) {
        const Eigen::Vector3d w = o + t * u - tip;
        const double axial = w.dot(a);
        return profile.signed_distance((w - axial * a).norm(), axial);
      };
      constexpr double g = 0.6180339887498949;
      double lo = ca, hi = cb, x1 = hi - g * (hi - lo), x2 = lo + g * (hi - lo);
      double f1 = sd(x1), f2 = sd(x2);
      double best = std::min({f1, f2, sd(ca), sd(cb)});
      for (int i = 0; i < 70 && best >= 0.0; ++i) {
        if (f1 <= f2) {
          hi = x2, x2 = x1, f2 = f1, x1 = hi - g * (hi - lo), f1 = sd(x1);
        } else {
          lo = x1, x1 = x2, f1 = f2, x2 = lo + g * (hi - lo), f2 = sd(x2);
        }
        best = std::min({best, f1, f2});
      }
      return best;
    };
    struct Piece {
      double s0, s1, g0, g1;
    };
    std::vector<Piece> pieces = {{0.0, 1.0, along(0.0), along(1.0)}};
    for (int evaluations = 0; !pieces.empty() && std::isnan(s_in);) {
      const Piece p = pieces.back();
      pieces.pop_back();
      if (0.5 * (p.g0 + p.g1 - lip * (p.s1 - p.s0)) > 0.0) continue;
      if (++evaluations > 400) {  // (grazing: the bound cannot close) a miss within ~1e-13 m
        pieces.clear();
        break;
      }
      const double mid = 0.5 * (p.s0 + p.s1), gm = along(mid);
      if (gm < 0.0) {
        if (at(mid, e, x)) s_in = mid;
        break;
      }
      pieces.push_back({p.s0, mid, p.g0, gm});
      pieces.push_back({mid, p.s1, gm, p.g1});
    }
    if (std::isnan(s_in)) return false;
  }
  // The sigma range whose tools the line meets (an interval: the sweep is convex).
  auto range_end = [&](double inside, double outside) {
    if (at(outside, e, x)) return outside;
    for (int i = 0; i < 64 && inside != outside; ++i) {
      const double mid = 0.5 * (inside + outside);
      if (mid == inside || mid == outside) break;
      (at(mid, e, x) ? inside : outside) = mid;
    }
    return inside;
  };
  const double s_lo = range_end(s_in, 0.0), s_hi = range_end(s_in, 1.0);
  double arg = 0.0;
  t0 = golden_min_ends([&](double sigma) { return at(sigma, e, x) ? e : kInf; }, s_lo, s_hi, arg);
  t1 = -golden_min_ends([&](double sigma) { return at(sigma, e, x) ? -x : kInf; }, s_lo, s_hi, arg);
  return t0 <= t1;
}

bool profile_vertical_entry(const Profile& profile, const Eigen::Vector3d& tip0, const Eigen::Vector3d& tip1, double x,
                            double y, double& z0, double& z1) {
  z1 = std::max(tip0.z(), tip1.z()) + profile.length;
  const double px = x - tip0.x(), py = y - tip0.y();
  const double dx = tip1.x() - tip0.x(), dy = tip1.y() - tip0.y(), dz = tip1.z() - tip0.z();
  if (dz == 0.0 || (dx == 0.0 && dy == 0.0)) {
    // Level move (the lowest tool over the line is the one nearest to it) or plunge.
    const double f = profile.lower(distance_2d(x, y, tip0.x(), tip0.y(), tip1.x(), tip1.y()));
    if (!std::isfinite(f)) return false;
    z0 = std::min(tip0.z(), tip1.z()) + f;
    return true;
  }
  // Ramp: the tools over the line are those with |p - sigma d_xy| <= rho_1 (a quadratic in
  // sigma); the entry z(sigma) + lower(|p - sigma d_xy|) is convex there.
  double lo[2], hi[2];
  const double dd = dx * dx + dy * dy, pd = px * dx + py * dy;
  if (quadratic_at_most_zero(dd, -2.0 * pd, px * px + py * py - profile.rho_1 * profile.rho_1, lo, hi) != 1) return false;
  const double s_a = std::max(0.0, lo[0]), s_b = std::min(1.0, hi[0]);
  if (!(s_a <= s_b)) return false;
  double arg = 0.0;
  z0 = tip0.z() + golden_min_ends(
                      [&](double sigma) {
                        const double radial = std::min(profile.rho_1, std::hypot(px - sigma * dx, py - sigma * dy));
                        return sigma * dz + profile.lower(radial);
                      },
                      s_a, s_b, arg);
  return true;
}

double profile_sweep_distance(const Profile& profile, const Eigen::Vector3d& tip0, const Eigen::Vector3d& tip1,
                              const Eigen::Vector3d& a, const Eigen::Vector3d& p, int steps) {
  auto tool = [&](double sigma) {
    const Eigen::Vector3d w = p - tip0 - sigma * (tip1 - tip0);
    const double axial = w.dot(a);
    return profile.signed_distance((w - axial * a).norm(), axial);
  };
  if (tip0 == tip1) return tool(0.0);
  double arg = 0.0;
  return golden_min_ends(tool, 0.0, 1.0, arg, steps);
}

}  // namespace vmsim::removal::detail
