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

// Brent's minimisation (golden section with parabolic steps) of a convex function on [a, b]
// to an argument tolerance tol; returns the minimum value and its argument.
template <class F>
double brent_min(F&& f, double a, double b, double tol, double& arg) {
  constexpr double cgold = 0.3819660112501051;
  double x = a + cgold * (b - a), w = x, v = x;
  double fx = f(x), fw = fx, fv = fx;
  double d = 0.0, e = 0.0;
  for (int iter = 0; iter < 200; ++iter) {
    const double xm = 0.5 * (a + b), tol2 = 2.0 * tol;
    if (std::abs(x - xm) <= tol2 - 0.5 * (b - a)) break;
    bool golden = true;
    if (std::abs(e) > tol) {
      const double r = (x - w) * (fx - fv);
      double q = (x - v) * (fx - fw);
      double p = (x - v) * q - (x - w) * r;
      q = 2.0 * (q - r);
      if (q > 0.0) p = -p;
      else q = -q;
      const double etemp = e;
      e = d;
      if (!(std::abs(p) >= std::abs(0.5 * q * etemp) || p <= q * (a - x) || p >= q * (b - x))) {
        d = p / q;
        const double u = x + d;
        if (u - a < tol2 || b - u < tol2) d = xm - x >= 0.0 ? tol : -tol;
        golden = false;
      }
    }
    if (golden) {
      e = x >= xm ? a - x : b - x;
      d = cgold * e;
    }
    const double u = std::abs(d) >= tol ? x + d : x + (d >= 0.0 ? tol : -tol);
    const double fu = f(u);
    if (fu <= fx) {
      (u >= x ? a : b) = x;
      v = w, w = x, x = u;
      fv = fw, fw = fx, fx = fu;
    } else {
      (u < x ? a : b) = u;
      if (fu <= fw || w == x) {
        v = w, w = u, fv = fw, fw = fu;
      } else if (fu <= fv || v == x || v == w) {
        v = u, fv = fu;
      }
    }
  }
  arg = x;
  return fx;
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
  const double er = std::max(dr, 0.0), ez = std::max(dz, 0.0);
  const double outside = std::sqrt(er * er + ez * ez);  // (std::hypot is several times slower)
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

double distance_2d_squared(double px, double py, double ax, double ay, double bx, double by) {
  const double dx = bx - ax, dy = by - ay;
  const double wx = px - ax, wy = py - ay;
  const double dd = dx * dx + dy * dy;
  double s = dd > 0.0 ? (wx * dx + wy * dy) / dd : 0.0;
  s = std::clamp(s, 0.0, 1.0);
  const double ex = wx - s * dx, ey = wy - s * dy;
  return ex * ex + ey * ey;
}

double distance_2d(double px, double py, double ax, double ay, double bx, double by) {
  return std::sqrt(distance_2d_squared(px, py, ax, ay, bx, by));
}

Sweep make_sweep(const Eigen::Vector3d& c0, const Eigen::Vector3d& c1, const Eigen::Vector3d& a,
                 double rho, double r, double ell) {
  Sweep s;
  s.c0 = c0, s.c1 = c1, s.a = a, s.rho = rho, s.r = r, s.ell = ell;
  s.vertical = a.x() == 0.0 && a.y() == 0.0 && a.z() == 1.0;
  s.cz_min = std::min(c0.z(), c1.z());
  s.tilt_sin = std::hypot(a.x(), a.y());
  s.amin = std::min(a.dot(c0), a.dot(c1)) - r;
  for (int i = 0; i < 3; ++i) {
    const double disc = rho * std::sqrt(std::max(0.0, 1.0 - a[i] * a[i]));
    const double lo0 = std::min(c0[i], c0[i] + ell * a[i]), hi0 = std::max(c0[i], c0[i] + ell * a[i]);
    const double lo1 = std::min(c1[i], c1[i] + ell * a[i]), hi1 = std::max(c1[i], c1[i] + ell * a[i]);
    s.lo[i] = std::min(lo0, lo1) - disc - r;
    s.hi[i] = std::max(hi0, hi1) + disc + r;
  }
  return s;
}

double lowest_z_beyond(const Sweep& s, double d) {
  const double cz = s.a.z(), sn = s.tilt_sin, r = s.r;
  if (cz < 0.0) return -kInf;
  // p = c + lambda a + q + b (q in the disc, b in the ball): |q_xy| <= rho and q_z >= -rho sn,
  // so the disc reduces to the ball-end case at distance e = d - rho, lowered by rho sn. For
  // the ball-end, z - c_z >= lambda cz - sqrt(r^2 - e_b^2) with e_b >= e - lambda sn; the
  // minimum over lambda >= 0 is at e_b = r cz (the tilted capsule's lower envelope).
  const double e = std::max(0.0, d - s.rho);
  const double base = s.cz_min - s.rho * sn;
  if (sn == 0.0) return e > r ? kInf : base - std::sqrt((r - e) * (r + e));
  if (e > r + s.ell * sn) return kInf;
  if (e <= r * cz) return base - std::sqrt((r - e) * (r + e));
  if (cz == 0.0) return base - r * sn;
  return base + (e - r * cz) * cz / sn - r * sn;
}

double reach_below(const Sweep& s, double z) {
  const double cz = s.a.z(), sn = s.tilt_sin, r = s.r;
  if (cz < 0.0) return kInf;
  const double g = z - (s.cz_min - s.rho * sn);  // lowest_z_beyond - base must stay below g
  if (g <= -r) return -1.0;
  double e = 0.0;
  if (sn == 0.0) {
    e = g >= 0.0 ? r : std::sqrt((r + g) * (r - g));
  } else {
    if (g <= -r * sn) {
      e = std::sqrt((r + g) * (r - g));
    } else {
      e = cz == 0.0 ? kInf : r * cz + (g + r * sn) * sn / cz;
    }
    e = std::min(e, r + s.ell * sn);
  }
  return s.rho + e;
}

namespace {

// The largest axial position of the core (lambda in [0, ell]) at which a tool of the motion
// c0 -> c1, a0 -> a1 (slerp by theta) can meet the box: along each face normal n the tool's
// points at lambda satisfy n . p >= min n . c + lambda min n . a - rho |n - (n . a) a| - r, and
// over the arc n . a >= na = min(n . a0, n . a1) - (1 - cos(theta / 2)) (the arc's sagitta;
// with na > 0 the arc's least n . a is at an end), so |n - (n . a) a| = sqrt(1 - (n . a)^2) <=
// sqrt(1 - na^2): the disc of a tool steep to the face reaches it by far less than rho (a
// 10 deg tilted disc dips 0.17 rho below its centre), which shortens the tool and so the
// sub-step count. `core_offset_m`: how far the core points of the sub-steps may lie from the
// line c0 -> c1 (SubStepPath::tip).
double reachable_length(const Box& box, const Eigen::Vector3d& c0, const Eigen::Vector3d& c1,
                        const Eigen::Vector3d& a0, const Eigen::Vector3d& a1, double theta, double rho,
                        double r, double ell, double core_offset_m) {
  const double sag = 1.0 - std::cos(0.5 * theta);
  double best = ell;
  for (int i = 0; i < 3; ++i) {
    for (double sign : {1.0, -1.0}) {
      const double face = sign > 0.0 ? box.max_W_m[i] : -box.min_W_m[i];
      const double na = std::min(sign * a0[i], sign * a1[i]) - sag;
      if (na <= 0.0) continue;
      const double nc = std::min(sign * c0[i], sign * c1[i]) - core_offset_m;
      const double reach = rho * std::sqrt(std::max(0.0, (1.0 - na) * (1.0 + na))) + r;
      best = std::min(best, std::max(0.0, (face + reach - nc) / na));
    }
  }
  return best;
}

}  // namespace

namespace {
void split_segment_core(const Tool& tool, const Pose& pose0, const Pose& pose1, double tolerance_m,
                        std::vector<Sweep>& out, const Box* material, SubStepPath path);
}  // namespace

void split_segment(const Tool& tool, const Pose& pose0, const Pose& pose1, double tolerance_m,
                   std::vector<Sweep>& out, const Box* material, SubStepPath path) {
  const std::size_t before = out.size();
  split_segment_core(tool, pose0, pose1, tolerance_m, out, material, path);
  if (tool.conical()) {
    const Profile profile = make_profile(tool);
    for (std::size_t k = before; k < out.size(); ++k) out[k].profile = profile;
  }
}

namespace {
// A conical tool is split as the cylinder Disc(D / 2) (+) Segment(tip, tip + length a) that
// holds it (c = tip): the sub-step bound holds for every point of it.
void split_segment_core(const Tool& tool, const Pose& pose0, const Pose& pose1, double tolerance_m,
                        std::vector<Sweep>& out, const Box* material, SubStepPath path) {
  const double r = tool.conical() ? 0.0 : tool.corner_radius(), rho = tool.disc_radius();
  double ell = tool.core_length();
  const Eigen::Vector3d a0 = pose0.axis_W.normalized(), a1 = pose1.axis_W.normalized();
  const Eigen::Vector3d c0 = pose0.tip_W_m + r * a0, c1 = pose1.tip_W_m + r * a1;
  const double theta = std::atan2(a0.cross(a1).norm(), a0.dot(a1));
  const bool vertical = a0 == Eigen::Vector3d::UnitZ() && a1 == Eigen::Vector3d::UnitZ();
  // Sub-steps along the tip's line: each core point lies within r (delta / 2 + (1 - cos(theta /
  // 2))) of the motion's (the axis within delta / 2 of the sub-step's, the chord of the arc
  // within 1 - cos(theta / 2) of it), which adds r to the rotation's lever and that chord term.
  const double chord = 1.0 - std::cos(0.5 * theta);
  const bool along_tip = path == SubStepPath::tip && theta > 0.0 && rho > 0.0 && r > 0.0 &&
                         r * chord < 0.5 * tolerance_m;
  if (material && !vertical) {
    ell = reachable_length(*material, c0, c1, a0, a1, theta, rho, r, ell, along_tip ? r * (0.5 * theta + chord) : 0.0);
  }
  if (theta == 0.0) {
    out.push_back(make_sweep(c0, c1, a0, rho, r, ell));
    return;
  }
  if (theta > 3.0) {
    throw InputError("tool axis turns by " + std::to_string(theta * 180.0 / M_PI) +
                     " deg between two trajectory samples: no unique interpolation");
  }
  const double extent = std::hypot(ell, rho) + (along_tip ? r : 0.0);
  const double budget = tolerance_m - (along_tip ? r * chord : 0.0);
  const double steps = std::ceil(theta * extent / (2.0 * budget));
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
    if (along_tip) {
      const Eigen::Vector3d tip_a = pose0.tip_W_m + sa * (pose1.tip_W_m - pose0.tip_W_m);
      const Eigen::Vector3d tip_b = pose0.tip_W_m + sb * (pose1.tip_W_m - pose0.tip_W_m);
      out.push_back(make_sweep(tip_a + r * a, tip_b + r * a, a, rho, r, ell));
    } else {
      out.push_back(make_sweep(c0 + sa * (c1 - c0), c0 + sb * (c1 - c0), a, rho, r, ell));
    }
  }
}

}  // namespace

bool section_point_x(const Sweep& s, double eta, double slope, double& x_lo, double& x_hi, SectionWarm* warm,
                     double* z_low, double* z_point) {
  const double ax = s.a.x(), ay = s.a.y(), az = s.a.z();
  if (!(az > 0.0) || !(std::abs(ax) >= kSectionMinAx)) return false;
  // The points of the section y = eta where the lower envelope's x-slope is `slope` are the
  // support points x(n) of the normals n(b) = m / |m|, m = (slope cos b, sin b, -cos b), b in
  // [-pi/2, pi/2], whose y is eta: x(n) = rho (n - (n . a) a) / |n - (n . a) a| + ell [n . a > 0]
  // a + r n (the whole segment over ell where n . a = 0). The normals run over a great circle
  // through y, so their y grows with b (the projection on its plane is convex): a bracket of b
  // holds every such point. |n . a| <= |slope a_x| + |a - a_x x| bounds |n - (n . a) a| from
  // below (|a_x| for slope 0). b is taken through u = tan(b / 2) in [-1, 1] (sin b = 2 u / (1 +
  // u^2), cos b = (1 - u^2) / (1 + u^2): no trigonometry; |db / du| <= 2).
  struct Point {
    double x_core, y_core, z_core, y_low, y_high, na;  // y over the support set (a segment when n . a ~ 0)
  };
  auto point = [&](double u) {
    // n = m / M, m = (slope (1 - u^2), 2 u, -(1 - u^2)) (the normal times 1 + u^2), M = |m|.
    // With ma = m . a: n - (n . a) a = (m - ma a) / M and |n - (n . a) a| = sqrt(M^2 - ma^2) / M,
    // so the disc's term is rho (m - ma a) / sqrt(M^2 - ma^2): its root and 1 / M do not wait
    // for each other (the rows' walks are latency-bound).
    const double uu = u * u, c = 1.0 - uu, q = 1.0 + uu;
    const double mx = slope * c, my = 2.0 * u, mz = -c;
    const double m2 = slope == 0.0 ? q * q : q * q + mx * mx;
    const double ma = mx * ax + my * ay + mz * az;
    const double inv = slope == 0.0 ? 1.0 / q : 1.0 / std::sqrt(m2);
    const double rho_perp = s.rho / std::sqrt(std::max(0.0, m2 - ma * ma));
    const double r_inv = s.r * inv;
    Point p;
    p.na = ma * inv;
    p.x_core = (mx - ma * ax) * rho_perp + r_inv * mx;
    const double y = (my - ma * ay) * rho_perp + r_inv * my;
    p.y_core = y;
    p.z_core = (mz - ma * az) * rho_perp + r_inv * mz;
    const double y_top = y + s.ell * ay;
    const bool both = std::abs(p.na) <= 1e-9;
    const double y_one = p.na > 0.0 ? y_top : y;
    p.y_low = both ? std::min(y, y_top) : y_one;
    p.y_high = both ? std::max(y, y_top) : y_one;
    return p;
  };
  constexpr double tau = 1e-15;  // [m] far above the rounding of y (~1e-17 m)
  // The constants of this tool section and slope (a chain of square roots and divisions: kept in
  // `warm` for the rows after the first; they depend on a_x, rho, r and the slope only).
  SectionWarm::Constants constants;
  const SectionWarm::Constants* known = warm ? &warm->constants : nullptr;
  if (known && known->slope == slope && known->ax == ax && known->rho == s.rho && known->r == s.r) {
    constants = *known;
  } else {
    const double na_max = std::abs(slope * ax) + std::sqrt(std::max(0.0, (1.0 - ax) * (1.0 + ax)));
    const double perp_min = std::sqrt(std::max(0.0, (1.0 - na_max) * (1.0 + na_max)));
    if (!(perp_min > 0.0)) return false;
    constants.slope = slope, constants.ax = ax, constants.rho = s.rho, constants.r = s.r;
    constants.slope_norm = std::sqrt(1.0 + slope * slope);
    constants.lip = 2.0 * constants.slope_norm * (s.rho / perp_min + s.r);  // |dx_core / du|, |dz_core / du|
    // Bracket width (in u): 1e-8 m of x for slopes other than 0 (only bounds of x are used).
    // For the lowest point its height is used too: with a corner radius the height follows
    // from the bracket's end to second order (below), so a bracket of a few nm of y is enough;
    // without one, the width is worth 0.1 kSectionZError of z.
    const double lowest_width_m = s.r > 0.0 ? std::sqrt(0.4 * kSectionZError * s.r * kSectionCos3) : 0.1 * kSectionZError;
    constants.width = (slope == 0.0 ? lowest_width_m : 1e-8) / constants.lip;
    if (warm) warm->constants = constants;
  }
  const double lip = constants.lip, width = constants.width;
  const double end = 1.0;  // u at b = pi / 2
  double b1 = 0.0, b2 = 0.0;
  Point p1, p2;
  bool bracketed = false;
  // One-sided bracket (a bull-nose, off the flank's segment): the normals n(b) run over a
  // great circle in the plane of y and (slope, 0, -1); the tool's projection on that plane is
  // convex with curvature radius >= r, so the support point's y grows with its normal's angle
  // theta in that plane as dy / dtheta >= r cos theta, which gives dy / du >= 2 r cos b / ((1 +
  // u^2) sqrt(1 + slope^2)) (for slope 0: the core's support point moves along dn / db, the
  // ball's by r). So one point p(u) at |y - eta| = e holds the root within e / that bound on one
  // side: a single evaluation per row once the Newton guess is close. p1 = p2 = that point.
  bool one_sided = false;
  double u_p1 = 0.0;  // where p1 was evaluated
  auto cos_b = [](double u) { return (1.0 - u * u) / (1.0 + u * u); };
  const double slope_norm = constants.slope_norm, r_norm = s.r / slope_norm;
  double cos_far_c = 0.0, cos_far_q = 1.0;  // the least cos b over a one-sided bracket: c / q
  constexpr double kOneSidedX = 5e-8;        // [m] the x precision of a one-sided bracket
  // The guess from the neighbouring rows (warm): their tangent, bent through the row before
  // (second order). The rows lie equally apart, so 1 / step and 1 / back^2 are kept, to 1e-9
  // (only the guesses use them).
  auto warm_guess = [&](double rate) {
    const double step = eta - warm->eta, back = warm->eta_before - warm->eta;
    if (!(std::abs(step - warm->step) <= 1e-9 * std::abs(step))) warm->step = step, warm->inv_step = 1.0 / step;
    double bend = 0.0;
    if (std::isfinite(warm->u_before) && back != 0.0) {
      if (!(std::abs(back - warm->back) <= 1e-9 * std::abs(back))) warm->back = back, warm->inv_back2 = 1.0 / (back * back);
      bend = (warm->u_before - warm->u - rate * back) * warm->inv_back2;
    }
    return std::clamp(warm->u + step * rate + step * step * bend, -end, end);
  };
  if (s.r > 0.0 && warm && std::isfinite(warm->u) && std::isfinite(warm->du_deta) && warm->du_deta != 0.0) {
    double rate = warm->du_deta;
    const double step = eta - warm->eta, back = warm->eta_before - warm->eta;
    double b = warm_guess(rate);
    double b_before = 0.0, f_before = 0.0;
    for (int k = 0; k < 3; ++k) {
      const Point p = point(b);
      if (!(p.na < -1e-6)) break;  // near the flank's segment (y not one value): two-sided
      const double f = p.y_core - eta;
      // l_min: half the bound at b, room for its change over the bracket (cos b = (1 - u^2) /
      // (1 + u^2); the tests below are multiplied out: no division).
      const double q_b = 1.0 + b * b, q_b2 = q_b * q_b, l_min_q = r_norm * (1.0 - b * b);  // l_min = l_min_q / q_b2
      // Accepted when x is known within 5e-8 m (lip w <= 5e-8, w = (|f| + tau) / l_min: a line
      // that near is left to the exact test) and, for the lowest point, the height within 0.4
      // kSectionZError (z_point below: e^2 / (2 r cos^3 b)); the bracket's far end |u| + w is
      // taken at its largest, |u| + 5e-8 / lip, so that no test waits for the division.
      const double e = std::abs(f) + tau;
      const double far = std::abs(b) + kOneSidedX / lip, q_far = 1.0 + far * far, c_far = 1.0 - far * far;  // cos = c / q
      if (l_min_q > 0.0 && lip * e * q_b2 <= kOneSidedX * l_min_q && far < end &&
          2.0 * r_norm * c_far * q_b2 >= l_min_q * q_far * q_far &&
          (slope != 0.0 || f * f * q_far * q_far * q_far <= 0.8 * kSectionZError * s.r * c_far * c_far * c_far) &&
          p.na * l_min_q < -(2.0 * slope_norm * e * q_b2 + 1e-9 * l_min_q)) {
        const double w = e * q_b2 / l_min_q;
        cos_far_c = c_far, cos_far_q = q_far;
        b1 = f < 0.0 ? b : b - w;
        b2 = f < 0.0 ? b + w : b;
        p1 = p2 = p;
        u_p1 = b;
        one_sided = bracketed = true;
        // The next row's warm start: the root's estimate and the slope of u over the rows
        // (the parabola through this row and the two before). (Not clamped to the bracket:
        // any guess is rigorous, and the next row then need not wait for w's division.)
        const double root = std::clamp(b - f * rate, -end, end);
        double rate_here = (root - warm->u) * warm->inv_step;
        if (std::isfinite(warm->u_before) && std::abs(step + back) <= 1e-9 * std::abs(step)) {  // (equally apart)
          rate_here = (3.0 * root - 4.0 * warm->u + warm->u_before) * (0.5 * warm->inv_step);
        } else if (std::isfinite(warm->u_before) && back != 0.0 && step != back) {
          const double e0 = warm->eta_before, e1 = warm->eta, e2 = eta;
          rate_here = warm->u_before * (e2 - e1) / ((e0 - e1) * (e0 - e2)) + warm->u * (e2 - e0) / ((e1 - e0) * (e1 - e2)) +
                      root * (2.0 * e2 - e0 - e1) / ((e2 - e0) * (e2 - e1));
        }
        warm->u_before = warm->u, warm->eta_before = warm->eta;
        warm->u = root, warm->du_deta = std::isfinite(rate_here) && rate_here != 0.0 ? rate_here : rate, warm->eta = eta;
        break;
      }
      if (k > 0 && f != f_before) rate = (b - b_before) / (f - f_before);
      b_before = b, f_before = f;
      b = std::clamp(b - f * rate, -end, end);
    }
  }
  // Warm start (neighbouring row): Newton steps on y(u) = eta with the rate du / deta of the
  // neighbours, then a bracket of the width around the root, accepted only when both ends
  // check (y monotone in b): a few evaluations instead of two bisections.
  if (!one_sided && warm && std::isfinite(warm->u) && std::isfinite(warm->du_deta) && warm->du_deta != 0.0) {
    double rate = warm->du_deta;
    double b = warm_guess(rate);
    auto half_width = [&] { return std::max(0.5 * width, 1.5 * tau * std::abs(rate)); };
    auto accept = [&](double root) {
      const double w = half_width();
      b1 = std::max(-end, root - w), b2 = std::min(end, root + w);
      p1 = point(b1), p2 = point(b2);
      bracketed = b1 > -end && b2 < end && p1.y_high < eta - tau && p2.y_low > eta + tau;
      return bracketed;
    };
    auto mid_y = [](const Point& p) { return 0.5 * (p.y_low + p.y_high); };
    // Away from the lowest point only bounds of x are wanted (the bracket is worth 1e-8 m of
    // x): the guess's error is far below that width, so its bracket is tried before any
    // evaluation; the bracket's ends give the rate and the root for the next row.
    if ((slope != 0.0 || s.r > 0.0) && accept(b)) {
      const double dy = mid_y(p2) - mid_y(p1);
      if (dy > 0.0) {
        rate = (b2 - b1) / dy;
        b = std::clamp(b1 + (eta - mid_y(p1)) * rate, b1, b2);
      }
    } else {
      Point p = point(b);
      double last_step = 0.0;
      for (int k = 0; k < 4; ++k) {
        const double f = mid_y(p) - eta;
        if (std::abs(f) <= 0.25 * half_width() / std::abs(rate)) break;
        const double next = std::clamp(b - f * rate, -end, end);
        // Secant steps: the error after this one about the product of this step and the one
        // before (times y'' / 2 y', taken up to 1e3): when that is far inside the bracket, its
        // bracket is tried before evaluating the point itself.
        if (k > 0 && 1e3 * std::abs(next - b) * last_step <= 0.25 * half_width() && accept(next)) {
          b = next;
          break;
        }
        const Point q = point(next);
        const double dy = mid_y(q) - mid_y(p);
        if (dy != 0.0 && next != b) rate = (next - b) / dy;
        last_step = std::abs(next - b);
        b = next, p = q;
      }
      if (!bracketed) accept(b);
    }
    if (bracketed) {
      warm->u_before = warm->u, warm->eta_before = warm->eta;
      warm->u = b, warm->du_deta = rate, warm->eta = eta;
    }
  }
  if (!bracketed) {
    // b1: every u at or below it has all its y < eta (so the points lie above b1).
    double lo = -end, hi = end;
    if (point(lo).y_high >= eta - tau) {
      hi = lo;
    } else {
      if (point(hi).y_high < eta - tau) return false;  // the plane lies beyond the tool's +y side
      while (hi - lo > width) {
        const double mid = 0.5 * (lo + hi);
        (point(mid).y_high < eta - tau ? lo : hi) = mid;
      }
    }
    b1 = lo;
    // b2: every u at or above it has all its y > eta.
    lo = b1, hi = end;
    if (point(hi).y_low <= eta + tau) {
      lo = hi;
      if (point(-end).y_low > eta + tau) return false;
    } else {
      if (point(lo).y_low > eta + tau) return false;  // beyond the tool's -y side
      while (hi - lo > width) {
        const double mid = 0.5 * (lo + hi);
        (point(mid).y_low > eta + tau ? hi : lo) = mid;
      }
    }
    b2 = hi;
    p1 = point(b1), p2 = point(b2);
    if (warm) {
      // The rate for the next row's warm start, from this bracket's y.
      const double b = 0.5 * (b1 + b2), h = std::max(1e-7, b2 - b1);
      const Point pa = point(std::max(-end, b - h)), pb = point(std::min(end, b + h));
      const double dy = pb.y_core - pa.y_core;
      warm->u_before = std::nan("");
      warm->u = b, warm->eta = eta;
      warm->du_deta = dy != 0.0 ? (std::min(end, b + h) - std::max(-end, b - h)) / dy : std::nan("");
    }
  }
  if (!one_sided) u_p1 = b1;
  // Over [b1, b2] (in u): x_core within lip (b2 - b1) / 2 of the nearer end (of the one end
  // evaluated, one-sided); the top end's ell a_x where n . a may reach 0 (|d(n . a) / du| <=
  // |dn / du| <= 2 sqrt(1 + slope^2)).
  const double reach_u = one_sided ? 2.0 * (b2 - b1) : b2 - b1;
  const double spread = 0.5 * lip * reach_u + 1e-12;
  const double na_reach = slope_norm * reach_u + 1e-9;
  // (The top end's z is higher by ell a_z > 0: the bottom's bounds the point from below.)
  if (z_low) {
    *z_low = std::min(p1.z_core, p2.z_core) - spread;
    if (slope == 0.0) {
      // Each end's normal n(b) = (0, sin b, -cos b) gives a supporting plane, n . p <= n . p_end,
      // so on the plane y = eta every point has z >= z_end + tan b (eta - y_end).
      for (int end_index = 0; end_index < (one_sided ? 1 : 2); ++end_index) {  // (one-sided: one point)
        const Point& p = end_index == 0 ? p1 : p2;
        const double u = end_index == 0 ? u_p1 : b2;
        if (!(std::abs(u) < 1.0)) continue;
        const double tan_b = 2.0 * u / ((1.0 - u) * (1.0 + u));
        // (y, z) of a support point: the segment's top end where n . a > 0.
        const double lift = p.na > 0.0 ? s.ell : 0.0;
        const double y_support = p.y_core + lift * ay, z_support = p.z_core + lift * az;
        *z_low = std::max(*z_low, z_support + tan_b * (eta - y_support) - 1e-15 * (1.0 + std::abs(tan_b)));
      }
    }
  }
  if (z_point) {
    const bool off_flank = !(s.ell > 0.0) || std::max(p1.na, p2.na) < -na_reach;
    *z_point = std::nan("");
    if (off_flank && s.r > 0.0) {
      // Along the curve of the lowest points (normals n = (0, sin b, -cos b)) z is convex in y
      // with dz / dy = tan b, and dy / db >= r cos b (the core's support point moves along
      // dn / db, the ball's by r), so 0 <= d2z / dy2 <= 1 / (r cos^3 b): from the bracket's low
      // point p1 (y1 within the bracket's y of eta) the height at eta is z1 + tan b1 (eta - y1) +
      // [0, (eta - y1)^2 / (2 r cos^3 b)], b over the bracket.
      const double cos_min = one_sided ? cos_far_c / cos_far_q : std::min(cos_b(b1), cos_b(b2));
      const double dy = eta - p1.y_core;
      if (cos_min > 0.0) {
        const double spread_z = dy * dy / (2.0 * s.r * cos_min * cos_min * cos_min);
        const double tan_b1 = 2.0 * u_p1 / ((1.0 - u_p1) * (1.0 + u_p1));
        if (spread_z <= 0.5 * kSectionZError) *z_point = p1.z_core + tan_b1 * dy + 0.5 * spread_z;
      }
    } else if (off_flank && lip * (b2 - b1) <= kSectionZError) {  // (z_core within lip (b2 - b1) of the bracket's end)
      *z_point = p1.z_core;
    }
  }
  x_lo = std::min(p1.x_core, p2.x_core) - spread;
  x_hi = std::max(p1.x_core, p2.x_core) + spread;
  if (s.ell > 0.0 && std::min(p1.na, p2.na) > na_reach) {  // the top end throughout
    x_lo += s.ell * ax;
    x_hi += s.ell * ax;
  } else if (s.ell > 0.0 && std::max(p1.na, p2.na) >= -na_reach) {
    // On the flank's segment c + x_core + lambda a, lambda in [0, ell]: where it is not
    // parallel to the plane, the plane's y picks lambda (y_core moves by at most `spread`).
    double l0 = 0.0, l1 = s.ell;
    if (std::abs(ay) > 1e-6) {
      const double ya = std::min(p1.y_core, p2.y_core) - spread - tau, yb = std::max(p1.y_core, p2.y_core) + spread + tau;
      const double la = (eta - ya) / ay, lb = (eta - yb) / ay;
      l0 = std::clamp(std::min(la, lb), 0.0, s.ell);
      l1 = std::clamp(std::max(la, lb), 0.0, s.ell);
    }
    x_lo += std::min(l0 * ax, l1 * ax);
    x_hi += std::max(l0 * ax, l1 * ax);
  }
  return true;
}

bool section_lowest_x(const Sweep& s, double eta, double& x_lo, double& x_hi, double* z_low, double* z_point) {
  return section_point_x(s, eta, 0.0, x_lo, x_hi, nullptr, z_low, z_point);
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

namespace {

// signed_distance for rho > 0 by Brent's method: the minimum over the motion to 1e-13 m of
// argument (the core's signed distance is 1-Lipschitz, so the value is as close).
double signed_distance_fast(const Sweep& s, const Eigen::Vector3d& p) {
  const Eigen::Vector3d delta = s.c1 - s.c0, x = p - s.c0;
  const double length = delta.norm();
  if (length == 0.0) return core_sdf(x, s.a, s.rho, s.ell) - s.r;
  double arg = 0.0;
  return brent_min([&](double t) { return core_sdf(x - t * delta, s.a, s.rho, s.ell); }, 0.0, 1.0,
                   1e-13 / length, arg) -
         s.r;
}

}  // namespace

double signed_distance(const Sweep& s, const Eigen::Vector3d& p) {
  if (s.profile.active) return profile_sweep_distance(s.profile, s.c0, s.c1, s.a, p);
  if (s.rho == 0.0) return parallelogram_distance(s, p) - s.r;
  const Eigen::Vector3d delta = s.c1 - s.c0, x = p - s.c0;
  double arg = 0.0;
  return golden_min_with_ends(
             [&](double t) { return core_sdf(x - t * delta, s.a, s.rho, s.ell); }, 0.0, 1.0, arg) -
         s.r;
}

bool vertical_entry(const Sweep& s, double x, double y, double& z0, double& z1) {
  if (s.profile.active) return profile_vertical_entry(s.profile, s.c0, s.c1, x, y, z0, z1);
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

VerticalEntry::VerticalEntry(const Sweep& s) : s_(s) {
  e1_ = s.c1 - s.c0;
  eu_ = s.a.unitOrthogonal();
  ev_ = s.a.cross(eu_);
  ae_ = s.a.dot(e1_);
  dd_ = e1_.x() * e1_.x() + e1_.y() * e1_.y();
  if (dd_ > 0.0) {
    inv_dd_ = 1.0 / dd_;
    slope_ = e1_.z() / (std::sqrt(dd_) * std::sqrt(dd_ + e1_.z() * e1_.z()));
  }
  // flat_rim: rho (cos phi U + sin phi V) + sigma D = q in the plane; the cross product with D
  // removes sigma: rho (alpha cos phi + beta sin phi) = gamma, so with (alpha, beta) = m (cos b,
  // sin b) the roots are phi = b +- acos(gamma / (rho m)), i.e. w = c U' +- sqrt(1 - c^2) V'.
  const double alpha = eu_.x() * e1_.y() - eu_.y() * e1_.x(), beta = ev_.x() * e1_.y() - ev_.y() * e1_.x();
  rim_m_ = std::sqrt(alpha * alpha + beta * beta);
  if (rim_m_ > 0.0) {
    rim_u_ = (alpha * eu_ + beta * ev_) / rim_m_;
    rim_v_ = (alpha * ev_ - beta * eu_) / rim_m_;
  }
  // bottom: the plane a . p = amin, and the disc at the end where a . c is least.
  const double a0 = s.a.dot(s.c0), a1 = s.a.dot(s.c1);
  plane_motion_ = a0 == a1;
  start_lowest_ = !(a1 < a0);
  b0_ = s.c0 - s.r * s.a;
  b1_ = s.c1 - s.r * s.a;
  b_low_ = start_lowest_ ? b0_ : b1_;
  // start_disc_row: |p - b0|^2 <= rho^2 with p on the disc's plane over (x, y), times a_z^2.
  const double ax = s.a.x(), ay = s.a.y(), az = s.a.z();
  usable_ = s.rho > 0.0 && az > 0.0;
  if (s.r > 0.0) inv_r_ = 1.0 / s.r;
  if (usable_) k0_ = s.amin / az, kx_ = ax / az, ky_ = ay / az;
  qa_ = az * az + ax * ax;
  qb_ = ax * ay;
  qc_ = az * az + ay * ay;
}

bool VerticalEntry::bottom(double x, double y, double& z) const {
  if (s_.rho == 0.0 || !(s_.a.z() > 0.0)) return false;
  z = k0_ - kx_ * x - ky_ * y;
  return in_bottom(x, y, z);
}

bool VerticalEntry::in_stadium(double x, double y, double z) const {
  return segment_distance(Eigen::Vector3d(x, y, z), b0_, b1_) <= s_.rho;
}

bool VerticalEntry::start_disc_row(double y, double margin, double& x0, double& x1) const {
  if (s_.rho == 0.0 || !(s_.a.z() > 0.0)) return false;
  const double Y = y - b0_.y(), az = s_.a.z();
  const double b = qb_ * Y, c = qc_ * Y * Y - s_.rho * s_.rho * az * az;
  const double disc = b * b - qa_ * c;
  if (!(disc > 0.0)) return false;
  const double root = std::sqrt(disc);
  x0 = b0_.x() + (-b - root) / qa_ + margin;
  x1 = b0_.x() + (-b + root) / qa_ - margin;
  return x0 <= x1;
}

double VerticalEntry::support(const Eigen::Vector3d& n) const {
  const double na = n.dot(s_.a), nn = n.squaredNorm();
  return n.dot(s_.c0) + s_.rho * std::sqrt(std::max(0.0, nn - na * na)) + s_.ell * std::max(0.0, na) +
         std::max(0.0, n.dot(e1_)) + s_.r * std::sqrt(nn);
}

void VerticalEntry::set_plane(const Eigen::Vector3d& n, Warm& warm) const { set_plane(n, support(n), warm); }

void VerticalEntry::set_plane(const Eigen::Vector3d& n, double hn, Warm& warm) const {
  // Only planes that are not too steep: the bound divides by -n_z.
  if (!(n.z() < -1e-3 * n.norm())) return;
  warm.plane = true;
  warm.nx = n.x(), warm.ny = n.y(), warm.inv_nz = -1.0 / n.z(), warm.hn = hn;
}

VerticalEntry::Result VerticalEntry::entry_off_bottom(double x, double y, double zp, double floor, double top,
                                                      int row, int col, Warm& warm, double& z) const {
  constexpr double margin = kPlaneMargin;
  auto capsule_bound = [&] {  // the tilted capsule's envelope by planar distance, and the bottom plane
    return std::max(zp, lowest_z_beyond(s_, distance_2d(x, y, s_.c0.x(), s_.c0.y(), s_.c1.x(), s_.c1.y())));
  };
  Eigen::Vector3d n;
  if (s_.r == 0.0) {
    if (flat_rim(x, y, z, &n)) {
      // n = sign (ae w - we a) with w . a = 0 and sign we >= 0: n . a <= 0, |n - (n . a) a| = |ae|
      // and n . e1 = 0, so h(n) = n . c0 + rho |ae| (no square root).
      set_plane(n, n.dot(s_.c0) + s_.rho * std::abs(ae_), warm);
      return z > floor ? Result::exact : Result::undecided;
    }
    if (capsule_bound() >= top) return Result::above;
    // Off the swept bottom: the flank, if anything. The flank of the tool at either end where
    // the line enters it, if certified (delta = 0 exactly where its normal faces along the
    // motion at c1, against it at c0: then that end's tool is the sweep's lowest on the line).
    for (const Eigen::Vector3d* c : {&s_.c1, &s_.c0}) {
      if (flank(x, y, *c, z, n) && support(n) - n.dot(Eigen::Vector3d(x, y, z)) <= -1e-11 * n.z()) {
        set_plane(n, warm);
        return z > floor ? Result::exact : Result::undecided;
      }
    }
    // Else the flank's supporting plane along the radial direction of the line at the bottom's
    // plane (midway along the motion) bounds the entry.
    const Eigen::Vector3d bm = 0.5 * (b0_ + b1_);
    const double z_mid = bm.z() - (s_.a.x() * (x - bm.x()) + s_.a.y() * (y - bm.y())) / s_.a.z();
    const Eigen::Vector3d v(x - bm.x(), y - bm.y(), z_mid - bm.z());
    const double len = v.norm();
    if (len > 0.0) {
      set_plane(v / len, warm);
      if (warm.plane && (warm.nx * x + warm.ny * y - warm.hn) * warm.inv_nz >= top + margin) return Result::above;
    }
    return Result::undecided;
  }
  // Bull-nose: the rim direction extrapolated from the neighbours found before (unit complex
  // numbers: a turn repeated is a ratio): along the row (two to the left), across the rows
  // (left, up and up-left; or two up), else the nearest one, else the last one found.
  auto slot = [](int r, int c) { return static_cast<unsigned>(r) % 3u * 16u + (static_cast<unsigned>(c) & 15u); };
  auto at = [&](int r, int c) -> const Eigen::Vector2d* {
    if (r < 0 || c < 0) return nullptr;
    const Warm::Found& f = warm.found[slot(r, c)];
    return f.row == r && f.col == c ? &f.dir : nullptr;
  };
  auto mul = [](const Eigen::Vector2d& p, const Eigen::Vector2d& q) {
    return Eigen::Vector2d(p.x() * q.x() - p.y() * q.y(), p.x() * q.y() + p.y() * q.x());
  };
  auto div = [](const Eigen::Vector2d& p, const Eigen::Vector2d& q) {  // p / q for |q| = 1
    return Eigen::Vector2d(p.x() * q.x() + p.y() * q.y(), p.y() * q.x() - p.x() * q.y());
  };
  Eigen::Vector2d dir = warm.last;
  const Eigen::Vector2d* left = at(row, col - 1);
  const Eigen::Vector2d* left2 = left ? at(row, col - 2) : nullptr;
  // (Products of unit numbers: one Newton step of 1 / |d| restores the unit length to rounding,
  // no root.)
  auto unit = [](const Eigen::Vector2d& d) { return Eigen::Vector2d(d * (1.5 - 0.5 * d.squaredNorm())); };
  if (left && left2) {
    dir = unit(div(mul(*left, *left), *left2));
  } else {
    const Eigen::Vector2d* up = at(row - 1, col);
    const Eigen::Vector2d* up_left = left && up ? at(row - 1, col - 1) : nullptr;
    const Eigen::Vector2d* up2 = up && !up_left ? at(row - 2, col) : nullptr;
    if (up_left) {
      dir = unit(div(mul(*left, *up), *up_left));
    } else if (up2) {
      dir = unit(div(mul(*up, *up), *up2));
    } else if (left || up) {
      dir = left ? *left : *up;
    }
  }
  // With a direction from the neighbours the rim search comes first (it certifies its entry,
  // above the top or not): the capsule's bound only rejects lines off the tool's footprint, and
  // costs a distance and a root on every line the sweep cuts. Without one, the bound first.
  const bool from_neighbours = dir.allFinite();
  double bound = std::nan("");
  if (!from_neighbours) {
    bound = capsule_bound();
    if (bound >= top) return Result::above;
  }
  double hn = 0.0;
  if (bull_rim(x, y, bound, dir, z, &n, &hn)) {
    Warm::Found& f = warm.found[slot(row, col)];
    f.dir = dir, f.row = row, f.col = col;
    warm.last = dir;
    set_plane(n, hn, warm);
    return z > floor ? Result::exact : Result::undecided;
  }
  warm.last = Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN());
  if (from_neighbours && capsule_bound() >= top) return Result::above;
  return Result::undecided;
}

bool VerticalEntry::flank(double x, double y, const Eigen::Vector3d& c, double& z, Eigen::Vector3d& n) const {
  // The cylinder |q - (q . a) a| = rho about the axis through c, q = (X, Y, zeta) relative to c:
  // (1 - a_z^2) zeta^2 - 2 a_z (Q . a) zeta + |Q|^2 - (Q . a)^2 - rho^2 = 0, Q = (X, Y, 0). The
  // lower root is the line's entry into the flank when it lies between the bottom and the top
  // (0 <= q . a <= ell) and the flank faces down there.
  const double ax = s_.a.x(), ay = s_.a.y(), az = s_.a.z();
  const double A = ax * ax + ay * ay;
  if (!(A > 0.0)) return false;
  const double X = x - c.x(), Y = y - c.y(), qa = X * ax + Y * ay;
  const double B = -az * qa, C = X * X + Y * Y - qa * qa - s_.rho * s_.rho;
  const double disc = B * B - A * C;
  if (!(disc >= 0.0)) return false;
  const double zeta = (-B - std::sqrt(disc)) / A;
  const double lambda = qa + zeta * az;
  if (!(lambda >= 0.0 && lambda <= s_.ell)) return false;
  const Eigen::Vector3d q(X, Y, zeta);
  n = (q - lambda * s_.a) / s_.rho;
  if (!(n.z() < -1e-3)) return false;
  z = c.z() + zeta;
  return true;
}

bool VerticalEntry::flat_rim(double x, double y, double& z, Eigen::Vector3d* n) const {
  if (ae_ == 0.0 || dd_ == 0.0 || !(s_.a.z() > 0.0) || !(rim_m_ > 0.0)) return false;
  const double qx = x - s_.c0.x(), qy = y - s_.c0.y();
  const double gamma = qx * e1_.y() - qy * e1_.x();
  const double c = gamma / (s_.rho * rim_m_);
  if (!(std::abs(c) <= 1.0)) return false;
  const double sh = std::sqrt((1.0 - c) * (1.0 + c));
  bool found = false;
  for (double sign_root : {-1.0, 1.0}) {
    const Eigen::Vector3d w = c * rim_u_ + sign_root * sh * rim_v_;
    const double sigma = ((qx - s_.rho * w.x()) * e1_.x() + (qy - s_.rho * w.y()) * e1_.y()) / dd_;
    if (!(sigma > 0.0 && sigma < 1.0)) continue;
    // The normal (a.e1) w - (w.e1) a, turned into the rim's normal cone, must point down.
    const double we = w.dot(e1_), sign = ae_ > 0.0 ? 1.0 : -1.0;
    if (sign * we < 0.0) continue;
    const double nz = sign * (ae_ * w.z() - we * s_.a.z());
    if (!(nz < 0.0)) continue;
    const double zc = s_.c0.z() + s_.rho * w.z() + sigma * e1_.z();
    if (!found || zc < z) {
      z = zc;
      if (n) *n = sign * (ae_ * w - we * s_.a);
    }
    found = true;
  }
  return found;
}

bool VerticalEntry::capsule_low(double x, double y, const Eigen::Vector3d& w, double& z, double& sigma) const {
  // Lowest point on the line of Segment(A, A + e1) (+) Ball(r), A = c0 + rho w: the minimum over
  // sigma of A_z + sigma e1_z - sqrt(r^2 - |d0 - sigma D|^2) (convex), unconstrained in closed
  // form, then clamped to [0, 1].
  const double r = s_.r;
  const double d0x = x - s_.c0.x() - s_.rho * w.x(), d0y = y - s_.c0.y() - s_.rho * w.y();
  const double cross = d0x * e1_.y() - d0y * e1_.x();
  const double perp2 = cross * cross * inv_dd_;
  if (perp2 > r * r) return false;
  const double ez = e1_.z();
  const double along = slope_ == 0.0 ? 0.0 : slope_ * std::sqrt(r * r - perp2);  // (0 for a level move: no root)
  sigma = std::clamp((d0x * e1_.x() + d0y * e1_.y()) * inv_dd_ - along, 0.0, 1.0);
  const double ex = d0x - sigma * e1_.x(), ey = d0y - sigma * e1_.y();
  const double q = r * r - ex * ex - ey * ey;
  if (q < 0.0) return false;
  z = s_.c0.z() + s_.rho * w.z() + sigma * ez - std::sqrt(q);
  return true;
}

bool VerticalEntry::bull_rim(double x, double y, double z_guess, Eigen::Vector2d& dir, double& z,
                             Eigen::Vector3d* n_out, double* support_out) const {
  if (dd_ == 0.0 || !(s_.a.z() > 0.0) || !(s_.r > 0.0)) return false;
  if (!dir.allFinite()) {
    const Eigen::Vector3d v = Eigen::Vector3d(x, y, z_guess) - 0.5 * (s_.c0 + s_.c1);
    dir = Eigen::Vector2d(v.dot(eu_), v.dot(ev_));
    const double len = dir.norm();
    dir = len > 0.0 ? Eigen::Vector2d(dir / len) : Eigen::Vector2d(1.0, 0.0);
  }
  // Rim directions w = cs eu + sn ev, as turns of the start direction by the angle 2 atan(tau)
  // (rational: no trigonometry, unit up to rounding). f(tau) = tan(half the angle from w to the
  // contact's direction about the axis): 0 at the optimum, where the contact normal has no
  // tangential part. The first step turns w onto that direction, then secant steps on tau.
  auto rotate = [](const Eigen::Vector2d& d, double tau) {
    const double q = 1.0 / (1.0 + tau * tau), c = (1.0 - tau * tau) * q, sn = 2.0 * tau * q;
    return Eigen::Vector2d(c * d.x() - sn * d.y(), sn * d.x() + c * d.y());
  };
  const Eigen::Vector2d start = dir;
  auto turn = [&](double tau) { return rotate(start, tau); };
  // Once certified, `dir` returns turned onto the contact's direction (one more fixed-point
  // step, free): a better warm start for the neighbours than the accepted direction.
  auto eval = [&](const Eigen::Vector2d& d, double& f, bool& certified) {
    const Eigen::Vector3d w = d.x() * eu_ + d.y() * ev_, t = d.x() * ev_ - d.y() * eu_;
    double sigma = 0.0;
    if (!capsule_low(x, y, w, z, sigma)) return false;
    const Eigen::Vector3d v = Eigen::Vector3d(x, y, z) - s_.c0 - sigma * e1_;
    const double vw = v.dot(w), vt = v.dot(t);
    // tan(alpha / 2) of the angle alpha = atan2(vt, vw); near the optimum (|vt| <= 1e-3 vw) its
    // first order vt / (2 vw), within 3e-7 of it relatively (it only steers the search).
    if (vw > 0.0 && std::abs(vt) <= 1e-3 * vw) {
      f = 0.5 * vt / vw;
    } else {
      const double len = std::sqrt(vw * vw + vt * vt);
      f = len + vw > 0.0 ? vt / (len + vw) : 1e300;
    }
    const Eigen::Vector3d n = (v - s_.rho * w) * inv_r_;
    const double na = n.dot(s_.a), ne = n.dot(e1_);
    const double n_perp = std::sqrt(std::max(0.0, n.squaredNorm() - na * na));
    const double gap = s_.rho * (n_perp - n.dot(w)) + s_.ell * std::max(0.0, na) + std::max(0.0, ne) - sigma * ne;
    certified = n.z() < -1e-3 && gap <= -1e-11 * n.z();
    if (certified && n_out) *n_out = n;
    if (certified && support_out) *support_out = gap + n.dot(Eigen::Vector3d(x, y, z));  // h(n) = gap + n . p
    return true;
  };
  double f0 = 0.0, f1 = 0.0;
  bool ok = false;
  if (!eval(dir, f0, ok)) return false;
  if (ok) {
    dir = rotate(dir, f0);
    return true;
  }
  if (!(std::abs(f0) < 1e3)) return false;
  double tau0 = 0.0, tau = f0;
  for (int k = 0; k < 10; ++k) {
    dir = turn(tau);
    if (!eval(dir, f1, ok)) return false;
    if (ok) {
      dir = rotate(dir, f1);
      return true;
    }
    if (!(std::abs(f1) < 1e3)) return false;
    const double next = f1 != f0 ? tau - f1 * (tau - tau0) / (f1 - f0) : tau + f1;
    tau0 = tau, f0 = f1, tau = next;
  }
  return false;
}

bool flat_interval(const Sweep& s, const Eigen::Vector3d& o, const Eigen::Vector3d& u, double& t0, double& t1) {
  // Points o + t u - sigma e1 - c0 of the static cylinder, in (t, sigma): the radial condition
  // |A + t B + sigma C| <= rho is an ellipse E, 0 <= sigma <= 1 and 0 <= lambda <= ell (lambda
  // the axial coordinate, linear in t and sigma) a parallelogram Q. E and Q are convex, so the
  // extremes of t over E and Q are on an edge of Q (a chord of E) or at an extreme of E.
  const Eigen::Vector3d e1 = s.c1 - s.c0, w = o - s.c0;
  const double l0 = w.dot(s.a), lu = u.dot(s.a), le = e1.dot(s.a);
  const Eigen::Vector3d A = w - l0 * s.a, B = u - lu * s.a, C = le * s.a - e1;
  const double rho = s.rho, ell = s.ell;
  bool any = false;
  // In Q: 0 <= sigma <= 1, 0 <= lambda = l0 + t lu - sigma le <= ell.
  auto in_q = [&](double t, double sigma) {
    const double lambda = l0 + t * lu - sigma * le;
    return sigma >= 0.0 && sigma <= 1.0 && lambda >= 0.0 && lambda <= ell;
  };
  // The line (t, sigma) = (pt + tau vt, ps + tau vs): its part in E and Q merged into [t0, t1].
  auto chord = [&](double pt, double ps, double vt, double vs, bool on_lambda_edge) {
    const Eigen::Vector3d M = A + pt * B + ps * C, N = vt * B + vs * C;
    const double nn = N.squaredNorm();
    double ta = -kInf, tb = kInf;
    if (nn > 0.0) {
      const double disc = rho * rho * nn - M.cross(N).squaredNorm();
      if (disc < 0.0) return;
      const double mid = -M.dot(N), root = std::sqrt(disc);
      ta = (mid - root) / nn;
      tb = (mid + root) / nn;
    } else if (M.squaredNorm() > rho * rho) {
      return;
    }
    if (!clip(ps, vs, 0.0, 1.0, ta, tb)) return;
    // (On a lambda edge lambda is constant by construction: clipping it would only see rounding.)
    if (!on_lambda_edge && !clip(l0 + pt * lu - ps * le, vt * lu - vs * le, 0.0, ell, ta, tb)) return;
    if (!std::isfinite(ta) || !std::isfinite(tb)) return;
    const double xa = pt + ta * vt, xb = pt + tb * vt;
    merge(true, std::min(xa, xb), std::max(xa, xb), any, t0, t1);
  };
  chord(0.0, 0.0, 1.0, 0.0, false);  // sigma = 0
  chord(0.0, 1.0, 1.0, 0.0, false);  // sigma = 1
  for (double lk : {0.0, ell}) {  // lambda = lk
    if (lu != 0.0) {
      chord((lk - l0) / lu, 0.0, le / lu, 1.0, true);
    } else if (le != 0.0) {
      chord(0.0, (l0 - lk) / le, 1.0, 0.0, true);
    } else if (l0 < 0.0 || l0 > ell) {
      return false;  // the line stays beyond an end of the cylinder
    }
  }
  // The extremes of E itself.
  const double bb = B.squaredNorm(), cc = C.squaredNorm(), bc = B.dot(C);
  const double det = bb * cc - bc * bc;
  if (det > 1e-24 * bb * cc && cc > 0.0) {
    const double ab = A.dot(B), ac = A.dot(C);
    const double tc = (-ab * cc + ac * bc) / det, sc = (-ac * bb + ab * bc) / det;  // centre
    const double off = std::abs(A.dot(B.cross(C))) / std::sqrt(det);  // distance of A to span(B, C)
    if (off <= rho) {
      const double k = std::sqrt((rho - off) * (rho + off) / (det * cc));
      for (double sign : {-1.0, 1.0}) {
        const double t = tc + sign * k * cc, sigma = sc - sign * k * bc;
        if (in_q(t, sigma)) merge(true, t, t, any, t0, t1);
      }
    }
  }
  return any;
}

bool line_interval(const Sweep& s, const Eigen::Vector3d& o, const Eigen::Vector3d& u, double& t0,
                   double& t1) {
  if (s.profile.active) {
    // (The cylinder that holds the tool first: closed form, it rejects most lines.)
    return flat_interval(s, o, u, t0, t1) && profile_sweep_interval(s.profile, s.c0, s.c1, s.a, o, u, t0, t1);
  }
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
  if (s.r == 0.0) return flat_interval(s, o, u, t0, t1);
  return bull_interval(s, o, u, kInf, t0, t1);
}

bool bull_interval(const Sweep& s, const Eigen::Vector3d& o, const Eigen::Vector3d& u, double h, double& t0,
                   double& t1) {
  // The sweep lies between flat-end sweeps (closed form): outside it the cylinder
  // Disc(rho + r) (+) Seg(-r, ell + r), inside it Disc(rho + r) (+) Seg(0, ell) and
  // Disc(rho) (+) Seg(-r, ell + r). The signed distance S(t) of o + t u to the sweep is convex
  // in t, >= 0 at the outer entry and <= 0 at the inner one: regula falsi (Illinois) between
  // them finds the entry, likewise the exit.
  auto flat = [&](double rho, double ext, double ell, double& a0, double& a1) {
    Sweep f = s;
    f.rho = rho, f.r = 0.0, f.ell = ell;
    f.c0 = s.c0 - ext * s.a, f.c1 = s.c1 - ext * s.a;
    return flat_interval(f, o, u, a0, a1);
  };
  double o0 = 0.0, o1 = 0.0;
  if (!flat(s.rho + s.r, s.r, s.ell + 2.0 * s.r, o0, o1)) return false;
  if (o0 >= h || o1 <= 0.0) return false;  // the entry cannot be below h, or the exit above 0
  auto S = [&](double t) { return signed_distance_fast(s, o + t * u); };
  double i0 = 0.0, i1 = 0.0, j0 = 0.0, j1 = 0.0;
  bool inner = false;
  if (flat(s.rho + s.r, 0.0, s.ell, i0, i1)) inner = true;
  if (flat(s.rho, s.r, s.ell + 2.0 * s.r, j0, j1)) {
    if (inner) i0 = std::min(i0, j0), i1 = std::max(i1, j1);
    else i0 = j0, i1 = j1, inner = true;
  }
  if (!inner) {  // only the rounded rims can hold the line: look for S < 0 between the outer ends
    double tm = 0.0;
    if (brent_min(S, o0, o1, 1e-13, tm) > 0.0) return false;
    i0 = i1 = tm;
  }
  auto root = [&](double out, double in) {  // S(out) >= 0 >= S(in)
    double fo = S(out), fi = S(in);
    if (fo <= 0.0) return out;
    int side = 0;
    for (int k = 0; k < 100 && std::abs(out - in) > 1e-13; ++k) {
      double m = (fi * out - fo * in) / (fi - fo);
      if (!(std::min(out, in) < m && m < std::max(out, in)) || k % 8 == 7) m = 0.5 * (out + in);
      const double fm = S(m);
      if (fm <= 0.0) {
        in = m, fi = fm;
        if (side == -1) fo *= 0.5;
        side = -1;
      } else {
        out = m, fo = fm;
        if (side == 1) fi *= 0.5;
        side = 1;
      }
    }
    return 0.5 * (out + in);
  };
  t0 = root(o0, i0);
  // With a finite h only the entry is needed exactly: the inner exit, when positive, shows the
  // exit is.
  t1 = std::isfinite(h) && i1 > 0.0 ? i1 : root(o1, i1);
  return true;
}

}  // namespace vmsim::removal::detail
