#pragma once
// Private: the exact line-versus-swept-tool computations shared by the N-buffer and the
// OpenVDB model. SI units, frame W.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "profile.hpp"
#include "vmsim/removal/tool.hpp"

namespace vmsim::removal::detail {

inline constexpr double kInf = std::numeric_limits<double>::infinity();

/// One segment with a constant tool axis: the core point c goes from c0 to c1; the body is
/// Disc(rho) (+) Segment(c, c + ell a) (+) Ball(r).
struct Sweep {
  Eigen::Vector3d c0, c1, a;
  double rho = 0.0, r = 0.0, ell = 0.0;
  Eigen::Vector3d lo, hi;  // bounding box of the swept volume
  bool vertical = false;   // a is exactly +z
  double cz_min = 0.0;     // lowest z of the core point c over the segment
  double tilt_sin = 0.0;   // |a_xy|
  double amin = 0.0;       // min over the segment of a . c, minus r: every point p has a . p >= amin
  /// The sweep before it in the same run (vertical, same tool) ended at c0: every line is
  /// already at or below the tool at c0, so lines behind c0 need no test (nbuffer.cpp).
  bool continues = false;
  /// The sweep before it in the same run ended at c0 with the same axis and tool section (rho,
  /// r): every line is already at or below the tool's bottom at c0.
  bool continues_axis = false;
  /// A conical tool (V, tapered): the tool itself, its tip at c0 -> c1 (r = 0, c = tip), and
  /// Disc(rho) (+) Segment(0, ell a) the cylinder that holds it, which every bound and culling
  /// above uses (valid: it holds the tool). line_interval, vertical_entry and signed_distance
  /// take the tool itself; nbuffer.cpp's fast paths and chains are for the others only.
  Profile profile;
};

Sweep make_sweep(const Eigen::Vector3d& c0, const Eigen::Vector3d& c1, const Eigen::Vector3d& a,
                 double rho, double r, double ell);

/// Splits the motion pose0 -> pose1 into constant-axis sweeps whose error is below tolerance_m
/// (see nbuffer.hpp). Appends to `out`.
/// With `material` (a box holding every line's material), the tool is cut short where no pose
/// of the segment can bring it into the box (the core length ell becomes the largest axial
/// position that can reach the box): the sweep inside the box is unchanged, the sub-step count
/// (which grows with the length) and the work drop. Not done for a constant vertical axis.
/// Where the sub-steps of a turning segment move: the core point c along the line c0 -> c1 (the
/// motion as defined), or the tip along its line with c = tip + r a of the sub-step's axis
/// (bull-nose only; otherwise as `core`): for a tip moving exactly along x each sub-step then
/// does too (nbuffer.cpp's chains), at the price of r added to the rotation's lever and r (1 -
/// cos(theta / 2)) (each core point within that of the motion's) in the bound; consecutive
/// sub-steps then meet with their core points r times the axis step apart.
enum class SubStepPath { core, tip };
void split_segment(const Tool& tool, const Pose& pose0, const Pose& pose1, double tolerance_m,
                   std::vector<Sweep>& out, const Box* material = nullptr, SubStepPath path = SubStepPath::core);

/// Lower bound on z of the points of the sweep whose distance in the plane from the segment
/// (c0, c1) projected on xy is at least d [m] (+inf where the sweep does not reach; -inf for a
/// tool pointing downwards). Exact for vertical sweeps.
double lowest_z_beyond(const Sweep& s, double d);

/// The largest planar distance d at which lowest_z_beyond(s, d) < z (negative when none).
double reach_below(const Sweep& s, double z);

/// The tool of sweep `s` held still with its core point c at the origin; needs a_z > 0 and
/// |a_x| >= kSectionMinAx (else false). For the plane y = eta [m, from c], an interval
/// [x_lo, x_hi] [m, from c] holding the x of every lowest point of the tool's section by that
/// plane (the surface points whose outer normal has n_x = 0, n_z < 0); false when the plane
/// misses the tool. Why: for a level move along x, the entry of a vertical line at (x, eta) as a
/// function of the tool's position is convex and smallest where the line passes that lowest
/// point, so the lines ahead of it at the end of a move are cut lower by the next move along
/// the same line (nbuffer.cpp, the chains). Bisection on the contact normal's angle with a
/// margin over rounding and the bracket's width (a Lipschitz bound): a rigorous interval,
/// within about 1e-10 m of the point except near the plane's extreme y. With `z_low`, also a
/// lower bound of that lowest point's z [m, from c] (no line in the plane enters the tool, at
/// any position along x, below it). With `z_point`, that lowest z itself [m, from c] where it
/// is known within kSectionZError (a narrow bracket, the point off the top end and the flank),
/// else NaN.
bool section_lowest_x(const Sweep& s, double eta, double& x_lo, double& x_hi, double* z_low = nullptr,
                      double* z_point = nullptr);
/// The neighbouring row's solution (u = tan(b / 2) of the point's normal angle b at eta, and its
/// rate du / deta): a warm start for section_point_x (NaN: none; any value gives rigorous
/// results).
struct SectionWarm {
  double u = std::numeric_limits<double>::quiet_NaN(), du_deta = std::numeric_limits<double>::quiet_NaN(), eta = 0.0;
  double u_before = std::numeric_limits<double>::quiet_NaN(), eta_before = 0.0;  // the row before (second order)
  double back = 0.0, inv_back2 = 0.0;  // eta_before - eta and 1 / its square (kept: the rows are equally apart)
  double step = 0.0, inv_step = 0.0;   // the last step in eta and its inverse
  /// Constants of the last tool section and slope solved for (recomputed when any differs).
  struct Constants {
    double slope = std::numeric_limits<double>::quiet_NaN(), ax = 0.0, rho = 0.0, r = 0.0;  // (the key)
    double lip = 0.0, width = 0.0;  // |dx / du| bound; bracket width in u
    double slope_norm = 1.0;        // sqrt(1 + slope^2)
  } constants;
  /// tan b: for the lowest point (slope 0) the y-slope of the section's lowest z over the rows.
  double tan_b() const { return 2.0 * u / ((1.0 - u) * (1.0 + u)); }
};
/// As section_lowest_x, for the points of the section where the lower envelope's x-slope
/// (dz/dx) is `slope` instead of 0 (slope 0: the lowest points; z_low, z_point only for those):
/// [x_lo, x_hi] holds them. Along a row the slope of the static tool's lower envelope grows with
/// x (convex), so it is at least `slope` beyond x_hi and at most it before x_lo. The interval
/// is within about 1e-8 m for slope != 0. With `warm`, a few Newton steps from the neighbouring
/// row's solution and a checked bracket replace the bisections (`warm` is updated).
bool section_point_x(const Sweep& s, double eta, double slope, double& x_lo, double& x_hi, SectionWarm* warm = nullptr,
                     double* z_low = nullptr, double* z_point = nullptr);
inline constexpr double kSectionZError = 1e-13;
/// The lowest points' brackets are sized for normals with cos^3 b above this (b up to ~48 deg);
/// steeper ones get no height (NaN) unless their bracket happens to be narrow enough.
inline constexpr double kSectionCos3 = 0.3;
inline constexpr double kSectionMinAx = 0.01;

/// Bull-nose sweep (r > 0, rho > 0) and a line: the entry t0 to ~1e-13 m (regula falsi on the
/// signed distance between closed-form flat-end brackets). With a finite h it returns false
/// early when the entry cannot be below h or the exit above 0, and then t1 is only a value in
/// (0, exit] (enough for the cut rule); with h = +inf, t1 is the exact exit.
bool bull_interval(const Sweep& s, const Eigen::Vector3d& o, const Eigen::Vector3d& u, double h, double& t0,
                   double& t1);

/// Vertical lines against one constant-axis flat-end or bull-nose sweep (rho > 0) whose axis
/// points up (a_z > 0): fast entries that certify themselves, built once per sweep (and tile).
/// The sweep is Core (+) Ball(r) with Core = c0 + Disc(rho) (+) Segment(0, ell a) (+)
/// Segment(0, c1 - c0), a convex set with the support function
///   h(n) = n . c0 + rho |n - (n . a) a| + ell max(0, n . a) + max(0, n . (c1 - c0)) + r |n|.
/// Two facts decide every line cheaply:
///  - Lower bound: every point p of the sweep has n . p <= h(n), so on the line (x, y), for any
///    n with n_z < 0, the entry is at least (n_x x + n_y y - h(n)) / (-n_z) (a supporting
///    plane; exact at the line whose lowest point has the normal n).
///  - Certificate: a point p of the sweep on the line at distance r from a Core point K (for
///    r = 0, a point of the Core on its boundary), with n = (p - K) / r (or an outer normal of
///    the Core at p), is at most delta / |n_z| above the line's entry, delta = h(n) - n . p;
///    an entry is accepted only when that is under 1e-11 m (or delta = 0 in closed form).
/// A result `undecided` means "not decided here": the caller takes the general computation.
class VerticalEntry {
 public:
  explicit VerticalEntry(const Sweep& s);

  /// What the last lines along one caller's walk left for the next (one per thread; a walk is
  /// the rows of a tile for one sweep): a supporting plane (the last contact normal) and the
  /// last bull-nose rim directions. Any state gives certified results; it only saves work.
  struct Warm {
    bool plane = false;
    double nx = 0.0, ny = 0.0, inv_nz = 0.0, hn = 0.0;  // z >= (nx x + ny y - hn) * inv_nz
    // Bull-nose rim directions found (cos, sin of the rim angle) in the last three rows, by
    // row modulo 3 and column modulo 16 (a walk spans at most 16 columns), with their row and
    // column (both >= 0).
    struct Found {
      Eigen::Vector2d dir = Eigen::Vector2d::Zero();
      int row = -10, col = -10;
    };
    Found found[3 * 16];
    Eigen::Vector2d last = Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN());
  };
  enum class Result { above, exact, undecided };

  /// The entry of the vertical line (x, y) whose material reaches from `floor` up to `top`
  /// (z, m): `above` when the entry is certainly at or above `top` (nothing to cut), `exact`
  /// with z the entry when it is certified and above `floor`, else `undecided`. `row`, `col`
  /// number the lines of the walk (neighbours differ by 1; used for warm starts only).
  Result entry(double x, double y, double floor, double top, int row, int col, Warm& warm, double& z) const {
    if (!usable_) return Result::undecided;
    // The lowest bottom's plane over the line: the entry where the line crosses that bottom,
    // else a lower bound (no point of the sweep lies below it). The cheap decisions are inline:
    // most lines end here.
    const double zp = k0_ - kx_ * x - ky_ * y;
    if (in_bottom(x, y, zp)) {
      z = zp;
      return z > floor ? Result::exact : Result::undecided;
    }
    if (warm.plane && (warm.nx * x + warm.ny * y - warm.hn) * warm.inv_nz >= top + kPlaneMargin) return Result::above;
    if (zp >= top) return Result::above;
    return entry_off_bottom(x, y, zp, floor, top, row, col, warm, z);
  }

  /// The bottom disc (radius rho about c - r a, normal a) at the end of the motion where a . c
  /// is least: no point of the sweep lies below its plane, so where the line crosses it (or,
  /// for a motion in the bottom's plane, the swept bottom) the crossing is the entry: true with
  /// its z.
  bool bottom(double x, double y, double& z) const;
  /// True when that lowest bottom disc is the one at the start c0 (a . c0 <= a . c1).
  bool lowest_at_start() const { return start_lowest_; }
  /// The x-interval of the row y whose lines cross the bottom disc at the start c0 shrunk by
  /// `margin` [m] at each end; false when empty.
  bool start_disc_row(double y, double margin, double& x0, double& x1) const;

  /// Flat-end (r = 0): the line's crossing with the swept bottom rim c0 + rho w(phi) + sigma
  /// (c1 - c0), 0 < sigma < 1 (the roots of a quadratic in closed form), where the normal
  /// n = (a.e1) w - (w.e1) a (normal to the motion, in the rim's normal cone) has n_z < 0:
  /// delta = 0, exact. `n` gets that normal.
  bool flat_rim(double x, double y, double& z, Eigen::Vector3d* n = nullptr) const;
  /// Bull-nose (r > 0): the lowest point on the line of the rim tube, min over the rim angle
  /// phi of the capsule (rim point swept) (+) Ball(r), closed form per phi; phi by secant
  /// steps (without trigonometry) from `dir` = (cos phi, sin phi) in the frame (eu, ev) normal
  /// to the axis (a warm start; NaN: from the line's azimuth about the axis at z_guess), on
  /// return the direction found. Accepted with the bound above; `n` gets the contact normal and
  /// `support_n` its support value h(n).
  bool bull_rim(double x, double y, double z_guess, Eigen::Vector2d& dir, double& z, Eigen::Vector3d* n = nullptr,
                double* support_n = nullptr) const;
  /// The support function h(n) above.
  double support(const Eigen::Vector3d& n) const;

 private:
  bool capsule_low(double x, double y, const Eigen::Vector3d& w, double& z, double& sigma) const;
  // (x, y, z) on the lowest plane: in the lowest bottom disc (or the swept bottom, a stadium,
  // for a motion in the bottom's plane)?
  bool in_bottom(double x, double y, double z) const {
    if (plane_motion_) return in_stadium(x, y, z);
    const double dx = x - b_low_.x(), dy = y - b_low_.y(), dz = z - b_low_.z();
    return dx * dx + dy * dy + dz * dz <= s_.rho * s_.rho;
  }
  bool in_stadium(double x, double y, double z) const;
  Result entry_off_bottom(double x, double y, double zp, double floor, double top, int row, int col, Warm& warm,
                          double& z) const;
  // The plane bounds are computed in doubles (values ~ |c0|, divided by at most 1e3): a margin
  // far above their rounding and far below any accuracy that matters [m].
  static constexpr double kPlaneMargin = 1e-12;
  /// Flat-end: the line's entry into the flank (cylinder wall) of the tool at core point c, where
  /// the flank faces down, with its outer normal n.
  bool flank(double x, double y, const Eigen::Vector3d& c, double& z, Eigen::Vector3d& n) const;
  void set_plane(const Eigen::Vector3d& n, Warm& warm) const;
  void set_plane(const Eigen::Vector3d& n, double support_n, Warm& warm) const;  // h(n) known
  const Sweep& s_;
  Eigen::Vector3d e1_, eu_, ev_;
  double ae_ = 0.0;   // a . e1
  double dd_ = 0.0;   // |e1_xy|^2
  // capsule_low: 1 / |e1_xy|^2, e1_z / (|e1_xy| sqrt(|e1_xy|^2 + e1_z^2)); bull_rim: 1 / r
  double inv_dd_ = 0.0, slope_ = 0.0, inv_r_ = 0.0;
  // flat_rim: the rim angle's cosine and sine axes (the roots are w = c U +- sqrt(1 - c^2) V)
  Eigen::Vector3d rim_u_, rim_v_;
  double rim_m_ = 0.0;
  // bottom: the plane a . p = amin as z = k0 - kx x - ky y, and the lowest disc's centre
  double k0_ = 0.0, kx_ = 0.0, ky_ = 0.0;
  Eigen::Vector3d b_low_, b0_, b1_;
  // start_disc_row: the quadratic form of the start disc's projection
  double qa_ = 0.0, qb_ = 0.0, qc_ = 0.0;
  bool plane_motion_ = false, start_lowest_ = true, usable_ = false;
};

/// Line through a flat-end sweep (r = 0, rho > 0), any line direction: closed form (the
/// section of the swept cylinder by the plane of the line and the motion is an ellipse cut by
/// a parallelogram; the extremes of t are on its edges or at the ellipse's own extremes).
bool flat_interval(const Sweep& s, const Eigen::Vector3d& o, const Eigen::Vector3d& u, double& t0, double& t1);

/// Interval [t0, t1] where the line o + t u (|u| = 1) meets the swept volume; false if it
/// misses. Closed form for ball-ends (rho = 0), flat-ends (r = 0, flat_interval) and vertical
/// sweeps on vertical lines; bull-nose otherwise: bull_interval (~1e-13 m).
bool line_interval(const Sweep& s, const Eigen::Vector3d& o, const Eigen::Vector3d& u, double& t0,
                   double& t1);

/// Vertical sweep, vertical line through (x, y): lowest point of the swept volume (entry z)
/// and an upper bound of its highest point; false if the line misses.
bool vertical_entry(const Sweep& s, double x, double y, double& z0, double& z1);

/// vertical_entry and the culling bound for a vertical ball-end sweep (rho = 0, a = +z, not a
/// conical tool) that changes height (c0.z != c1.z, the 3-axis ramps and plunges of a finishing
/// path, where the level closed form does not apply): the same doubles, cheaper. `entry` is
/// capsule_interval(c0, c1, r, (x, y, 0), +z) written out for a vertical line: what it drops
/// are products by exact ones and sums with exact zeros (u = +z has zero x and y; u x d has a
/// zero z), every other operation is capsule_interval's in its order (the three-term dot
/// products through Eigen as there), so each candidate entry, and their minimum, is the same
/// double; x86-64 without FMA contraction evaluates each expression as written. Per sweep
/// constants are computed once. `lowest_below` is lowest_z_beyond(s, distance_2d(...)) for the
/// vertical sweep (distance_2d's and lowest_z_beyond's operations). Both are checked bit for bit
/// against the general functions (tests/removal/test_nbuffer_paths.cpp).
class VerticalBallEntry {
 public:
  explicit VerticalBallEntry(const Sweep& s)
      : ax_(s.c0.x()), ay_(s.c0.y()), az_(s.c0.z()), bx_(s.c1.x()), by_(s.c1.y()), bz_(s.c1.z()), r_(s.r),
        cz_min_(s.cz_min), d_(s.c1 - s.c0) {
    rr_ = r_ * r_;
    dd_ = d_.squaredNorm();
    const Eigen::Vector3d u_cross_d = Eigen::Vector3d::UnitZ().cross(d_);
    ux_ = u_cross_d.x(), uy_ = u_cross_d.y();
    uu_ = u_cross_d.squaredNorm();
    cylinder_ = dd_ > 0.0 && uu_ > 1e-30 * dd_;
    uu_rr_ = uu_ * r_ * r_;
    dd_rr_ = dd_ * r_ * r_;
    ud_ = Eigen::Vector3d::UnitZ().dot(d_);
    root_max_ = std::sqrt(dd_ * uu_rr_);
    inv_uu_ = cylinder_ ? 1.0 / uu_ : 0.0;
    inv_ud_ = ud_ != 0.0 ? 1.0 / ud_ : 0.0;
    // distance_2d's
    pdx_ = bx_ - ax_, pdy_ = by_ - ay_;
    pdd_ = pdx_ * pdx_ + pdy_ * pdy_;
  }

  /// True for the sweeps this class serves.
  static bool serves(const Sweep& s) {
    return s.vertical && s.rho == 0.0 && !s.profile.active && s.c0.z() != s.c1.z();
  }

  /// lowest_z_beyond(s, distance_2d(x, y, c0, c1)): the lowest z of the sweep over (x, y) and
  /// beyond (+inf when it does not reach there).
  double lowest_below(double x, double y) const {
    const double wx = x - ax_, wy = y - ay_;
    // (distance_2d's t = clamp(num / pdd, 0, 1): a quotient of a num outside (0, pdd) rounds to
    // a value the clamp takes to 0 or 1 (division by pdd > 0 is monotonic), so it is not done.)
    double t = 0.0;
    if (pdd_ > 0.0) {
      const double num = wx * pdx_ + wy * pdy_;
      t = num <= 0.0 ? 0.0 : num >= pdd_ ? 1.0 : std::clamp(num / pdd_, 0.0, 1.0);
    }
    const double ex = wx - t * pdx_, ey = wy - t * pdy_;
    const double e = std::max(0.0, std::sqrt(ex * ex + ey * ey) - 0.0);  // (lowest_z_beyond: d - rho)
    return e > r_ ? kInf : cz_min_ - std::sqrt((r_ - e) * (r_ + e));
  }

  /// lowest_below(x, y) - z0 >= h (the culling's test: the sweep cannot lower a line of length
  /// h from z0), the same decision, without lowest_below's two roots where it is clear: with
  /// X = r^2 - e^2 and g = cz_min - z0 - h the test is sqrt(X) <= g (X < 0: the bound is +inf),
  /// i.e. X <= g^2 for g >= 0, decided here when X is farther than a margin from 0 and g^2
  /// (and g from 0); the margin, 1e-13 of the sizes involved, is far above the rounding of
  /// both ways of computing it (a few units of 1e-16 relative). Elsewhere lowest_below decides.
  bool cannot_lower(double x, double y, double z0, double h) const {
    const double wx = x - ax_, wy = y - ay_;
    double t = 0.0;
    if (pdd_ > 0.0) {
      const double num = wx * pdx_ + wy * pdy_;
      t = num <= 0.0 ? 0.0 : num >= pdd_ ? 1.0 : num / pdd_;
    }
    const double ex = wx - t * pdx_, ey = wy - t * pdy_;
    const double X = rr_ - (ex * ex + ey * ey);
    const double size = std::abs(cz_min_) + std::abs(z0) + std::abs(h) + r_;
    const double g = cz_min_ - z0 - h;
    constexpr double relative = 1e-13;
    const double margin_x = relative * (rr_ + (std::abs(g) + r_) * size) + 1e-300;
    if (X < -margin_x) return true;  // e > r: no point of the sweep over the line
    if (X > margin_x) {
      if (g < -relative * size) return false;  // the bound lies below the line's top
      if (g > relative * size) {
        const double gg = g * g;
        if (X < gg - margin_x) return true;
        if (X > gg + margin_x) return false;
      }
    }
    return lowest_below(x, y) - z0 >= h;
  }

  /// vertical_entry's z0 (the line's entry, absolute z); false when the line misses the sweep.
  bool entry(double x, double y, double& z) const {
    bool any = false;
    // m = o - A with o = (x, y, 0)
    const double mx = x - ax_, my = y - ay_, mz = 0.0 - az_;
    // The end spheres: mu = m . u = m_z; the part of m normal to u is (m_x, m_y, 0).
    auto sphere = [&](double q, double pz) {
      const double disc = rr_ - q;
      if (disc < 0.0) return;
      const double candidate = -pz - std::sqrt(disc);
      z = any ? std::min(z, candidate) : candidate;
      any = true;
    };
    const double qa = mx * mx + my * my;
    if (!(dd_ > 0.0)) {
      sphere(qa, mz);
      return any;
    }
    const double px = x - bx_, py = y - by_, pz = 0.0 - bz_;
    const double qb = px * px + py * py;
    // An end sphere whose centre is not lower and whose distance is not smaller than the
    // other's gives a candidate no lower than the other's, which hits wherever it does (the
    // roundings are monotonic): it cannot change the minimum, and is left out.
    const bool a_no_lower = -mz >= -pz && qa >= qb, b_no_lower = -pz >= -mz && qb >= qa;
    if (!a_no_lower || b_no_lower) sphere(qa, mz);  // (both: the same candidate, one taken)
    if (!b_no_lower) sphere(qb, pz);
    const Eigen::Vector3d m(mx, my, mz);
    double c0 = -kInf, c1 = kInf;
    bool hit = true;
    // M = m x d (as Eigen's cross: each component one difference of two products)
    const double Mx = my * d_.z() - mz * d_.y(), My = mz * d_.x() - mx * d_.z();
    if (cylinder_) {
      const double triple = mx * ux_ + my * uy_;  // m . (u x d), whose z is zero
      const double disc = dd_ * (uu_rr_ - triple * triple);
      if (disc < 0.0) {
        hit = false;
      } else {
        const double b = Mx * ux_ + My * uy_;
        if (ud_ != 0.0 && outside_end_planes(b, m.dot(d_))) {
          hit = false;
        } else {
          const double root = std::sqrt(disc);
          c0 = (-b - root) / uu_;
          c1 = (-b + root) / uu_;
        }
      }
    } else {
      const double Mz = mx * d_.y() - my * d_.x();
      hit = Eigen::Vector3d(Mx, My, Mz).squaredNorm() <= dd_rr_;
    }
    if (hit) {
      // Between the end planes: 0 <= (m + t u) . d <= dd (clip).
      const double v0 = m.dot(d_);  // (as outside_end_planes')
      if (ud_ == 0.0) {
        hit = v0 >= 0.0 && v0 <= dd_;
      } else {
        double ta = (0.0 - v0) / ud_, tb = (dd_ - v0) / ud_;
        if (ta > tb) std::swap(ta, tb);
        c0 = std::max(c0, ta);
        c1 = std::min(c1, tb);
        hit = c0 <= c1;
      }
    }
    if (hit && std::isfinite(c0) && std::isfinite(c1)) {
      z = any ? std::min(z, c0) : c0;
      any = true;
    }
    return any;
  }

 private:
  // Whether the cylinder's chord [c0, c1] on the line surely lies outside the end planes' range
  // [ta, tb] as capsule_interval computes them (its clip then fails), decided without the root
  // and the four quotients: the computed root is at most root_max_ = fl(sqrt(fl(dd uu R^2)))
  // (every step monotonic, triple^2 >= 0), so the computed c0 >= fl(fl(-b - root_max_) / uu) and
  // c1 <= fl(fl(-b + root_max_) / uu); those quotients and ta, tb are taken as products by the
  // reciprocals, widened by 1e-14 of their size (a quotient and its reciprocal product differ by
  // a few units in the last place, 1e-16 relative). Most lines the sweep of a short move tests
  // lie ahead of or behind it (the ball's front and back), where this holds.
  bool outside_end_planes(double b, double v0) const {
    constexpr double widen = 1e-14;
    const double c_lo = (-b - root_max_) * inv_uu_, c_hi = (-b + root_max_) * inv_uu_;
    double ta = (0.0 - v0) * inv_ud_, tb = (dd_ - v0) * inv_ud_;
    if (ta > tb) std::swap(ta, tb);
    constexpr double tiny = 1e-300;  // (below the normal range the relative bound does not hold)
    const double low = std::max(c_lo - widen * std::abs(c_lo), ta - widen * std::abs(ta)) - tiny;
    const double high = std::min(c_hi + widen * std::abs(c_hi), tb + widen * std::abs(tb)) + tiny;
    return low > high;
  }

  double ax_, ay_, az_, bx_, by_, bz_, r_, cz_min_;
  Eigen::Vector3d d_;
  double rr_ = 0.0, dd_ = 0.0, ux_ = 0.0, uy_ = 0.0, uu_ = 0.0, uu_rr_ = 0.0, dd_rr_ = 0.0, ud_ = 0.0;
  double pdx_ = 0.0, pdy_ = 0.0, pdd_ = 0.0;
  double root_max_ = 0.0, inv_uu_ = 0.0, inv_ud_ = 0.0;
  bool cylinder_ = false;
};

/// Signed distance from p to the swept volume (exact outside for rho = 0; for rho > 0 the
/// minimum over the segment of the tool's signed distance, exact outside to ~1e-12 m).
double signed_distance(const Sweep& s, const Eigen::Vector3d& p);

/// Distance in the plane from (px, py) to the 2-D segment (ax, ay)-(bx, by).
double distance_2d(double px, double py, double ax, double ay, double bx, double by);
/// Its square (the same arithmetic without the root: a minimum of distances needs one root).
double distance_2d_squared(double px, double py, double ax, double ay, double bx, double by);

/// Capsule (segment A-B, radius R) against a line: the interval of t; false if it misses.
bool capsule_interval(const Eigen::Vector3d& A, const Eigen::Vector3d& B, double R,
                      const Eigen::Vector3d& o, const Eigen::Vector3d& u, double& t0, double& t1);

}  // namespace vmsim::removal::detail
