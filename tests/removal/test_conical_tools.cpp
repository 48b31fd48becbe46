// Conical tools (V, tapered flat-end, tapered ball-end) in the removal: closed-form grooves and
// craters on the Z-map, a tilted tapered ball-end against a separately written Minkowski
// (ball (+) cone) reference, the Z-map against general lines (a second algorithm: the static
// line intervals minimised over the motion), and the OpenVDB level set against the Z-map.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <random>
#include <vector>

#include "../../removal/src/profile.hpp"
#include "removal_test_tools.hpp"
#include "vmsim/common/errors.hpp"
#include "vmsim/removal/level_set.hpp"
#include "vmsim/removal/nbuffer.hpp"

namespace vmsim::removal {
namespace {

constexpr double mm = 1e-3;
constexpr double um = 1e-6;
constexpr double deg = M_PI / 180.0;

Box box_mm(double x0, double y0, double z0, double x1, double y1, double z1) {
  return Box{Eigen::Vector3d(x0, y0, z0) * mm, Eigen::Vector3d(x1, y1, z1) * mm};
}
Pose pose_mm(double x, double y, double z, Eigen::Vector3d axis = Eigen::Vector3d::UnitZ()) {
  return Pose{Eigen::Vector3d(x, y, z) * mm, axis.normalized()};
}
Tool v_tool(double d_mm, double angle_deg, double tip_mm = 0.0, double length_mm = 20.0) {
  Tool t = test::make_tool(ToolType::v, d_mm, 0.0, length_mm);
  t.tip_angle_rad = angle_deg * deg;
  t.tip_diameter_m = tip_mm * mm;
  return t;
}
Tool tapered(ToolType type, double d_mm, double tip_mm, double taper_deg, double length_mm = 20.0) {
  Tool t = test::make_tool(type, d_mm, 0.0, length_mm);
  t.tip_diameter_m = tip_mm * mm;
  t.taper_angle_rad = taper_deg * deg;
  return t;
}
double height(const NBuffer& b, int i, int j) { return b.origin(i, j).z() + b.length(i, j); }

// The lower envelope of each tool written out (height above the tip at a distance rho from the
// axis; +inf beyond the tool), for the crater and groove checks.
double v_envelope(double rho, double half_angle, double tip_radius, double radius) {
  if (rho > radius) return INFINITY;
  return std::max(0.0, rho - tip_radius) / std::tan(half_angle);
}
double tapered_ball_envelope(double rho, double r, double beta, double radius) {
  if (rho > radius) return INFINITY;
  if (rho <= r * std::cos(beta)) return r - std::sqrt(r * r - rho * rho);
  return r * (1.0 - std::sin(beta)) + (rho - r * std::cos(beta)) / std::tan(beta);
}

// A straight V pass at depth h cuts a V groove of width 2 h tan(alpha): the heights across it.
TEST(ConicalTools, VPassCutsTheClosedFormGroove) {
  for (const double angle : {60.0, 90.0, 120.0}) {
    for (const double tip_mm : {0.0, 0.2}) {
      NBuffer b = NBuffer::zmap(box_mm(-4, -3, 0, 4, 3, 5), 0.01 * mm);
      const double h = 0.8 * mm, top = 5 * mm, y0 = 0.0123 * mm;
      const Tool tool = v_tool(6, angle, tip_mm);
      b.cut(tool, std::vector<Pose>{pose_mm(-3, y0 / mm, (top - h) / mm), pose_mm(3, y0 / mm, (top - h) / mm)});
      const double alpha = 0.5 * angle * deg, rt = 0.5 * tip_mm * mm;
      const double half_width = rt + h * std::tan(alpha);
      double worst = 0.0;
      int cut = 0;
      const int i = b.nu() / 2;  // x = 0
      for (int j = 0; j < b.nv(); ++j) {
        const double y = b.origin(i, j).y();
        const double expected = std::min(top, top - h + v_envelope(std::abs(y - y0), alpha, rt, 3 * mm));
        worst = std::max(worst, std::abs(height(b, i, j) - expected));
        cut += height(b, i, j) < top;
      }
      EXPECT_LT(worst, 1e-12) << angle << " deg, tip " << tip_mm;
      // The groove's width at the top: the lines strictly inside it are cut, none outside.
      const int expected_cut = static_cast<int>(std::floor((y0 + half_width) / (0.01 * mm) - 1e-9)) -
                               static_cast<int>(std::ceil((y0 - half_width) / (0.01 * mm) + 1e-9)) + 1;
      EXPECT_EQ(cut, expected_cut) << angle << " deg: width " << 2 * half_width / mm << " mm";
    }
  }
}

// A plunge to depth h leaves the tool's lower envelope as a crater (each shape, closed form).
TEST(ConicalTools, PlungeLeavesTheToolsEnvelope) {
  struct Case {
    Tool tool;
    std::function<double(double)> envelope;
  };
  const std::vector<Case> cases = {
      {v_tool(4, 90), [](double rho) { return v_envelope(rho, 45 * deg, 0.0, 2 * mm); }},
      {v_tool(4, 60, 0.3), [](double rho) { return v_envelope(rho, 30 * deg, 0.15 * mm, 2 * mm); }},
      {tapered(ToolType::tapered_flat, 4, 1.0, 10),
       [](double rho) { return v_envelope(rho, 10 * deg, 0.5 * mm, 2 * mm); }},
      {tapered(ToolType::tapered_ball, 4, 1.0, 10),
       [](double rho) { return tapered_ball_envelope(rho, 0.5 * mm, 10 * deg, 2 * mm); }},
      {tapered(ToolType::tapered_ball, 4, 1.0, 0),  // taper 0: a ball-end of the tip's diameter
       [](double rho) { return rho > 0.5 * mm ? INFINITY : 0.5 * mm - std::sqrt(0.25 * mm * mm - rho * rho); }},
  };
  for (std::size_t k = 0; k < cases.size(); ++k) {
    NBuffer b = NBuffer::zmap(box_mm(-3, -3, 0, 3, 3, 5), 0.02 * mm);
    const double top = 5 * mm, h = 1.2 * mm;
    const Eigen::Vector3d c(0.0071 * mm, -0.013 * mm, 0);
    b.cut(cases[k].tool, std::vector<Pose>{pose_mm(c.x() / mm, c.y() / mm, 6), pose_mm(c.x() / mm, c.y() / mm, (top - h) / mm)});
    double worst = 0.0;
    for (int j = 0; j < b.nv(); ++j) {
      for (int i = 0; i < b.nu(); ++i) {
        const Eigen::Vector3d o = b.origin(i, j);
        const double expected = std::min(top, top - h + cases[k].envelope(std::hypot(o.x() - c.x(), o.y() - c.y())));
        worst = std::max(worst, std::abs(height(b, i, j) - expected));
      }
    }
    EXPECT_LT(worst, 1e-12) << "case " << k;
  }
}

// The tapered ball-end is Ball(r) (+) a cone of half angle beta with its apex at the ball's
// centre: its distance to a point is the distance to that cone less r (below the flank's end).
double cone_distance(const Eigen::Vector3d& p, const Eigen::Vector3d& apex, const Eigen::Vector3d& a, double beta) {
  const Eigen::Vector3d w = p - apex;
  const double zeta = w.dot(a), rho = (w - zeta * a).norm();
  if (rho <= zeta * std::tan(beta)) return 0.0;                       // inside
  if (rho * std::sin(beta) + zeta * std::cos(beta) <= 0.0) return w.norm();  // nearest: the apex
  return rho * std::cos(beta) - zeta * std::sin(beta);                // nearest: a generator
}
// Entry of the vertical line (x, y) into Ball(r) (+) cone: the least z with distance <= r
// (the distance is convex along the line: its minimum, then bisection below it).
double minkowski_entry(double x, double y, const Eigen::Vector3d& apex, const Eigen::Vector3d& a, double beta, double r,
                       double z_lo, double z_hi) {
  auto f = [&](double z) { return cone_distance(Eigen::Vector3d(x, y, z), apex, a, beta) - r; };
  double lo = z_lo, hi = z_hi;
  for (int i = 0; i < 200; ++i) {  // ternary search for the minimum
    const double m1 = lo + (hi - lo) / 3, m2 = hi - (hi - lo) / 3;
    (f(m1) <= f(m2) ? hi : lo) = f(m1) <= f(m2) ? m2 : m1;
  }
  double inside = 0.5 * (lo + hi);
  if (f(inside) > 0.0) return INFINITY;
  double outside = z_lo;
  for (int i = 0; i < 200; ++i) {
    const double mid = 0.5 * (inside + outside);
    (f(mid) <= 0.0 ? inside : outside) = mid;
  }
  return inside;
}

TEST(ConicalTools, TiltedTaperedBallMatchesTheMinkowskiSum) {
  const double r = 0.5 * mm, beta = 8 * deg;
  const Tool tool = tapered(ToolType::tapered_ball, 6, 1.0, 8);
  const Eigen::Vector3d a = Eigen::Vector3d(std::sin(25 * deg), 0.3 * std::sin(25 * deg), std::cos(25 * deg)).normalized();
  const Eigen::Vector3d tip(0.0031 * mm, -0.0027 * mm, 4.3 * mm);
  NBuffer b = NBuffer::zmap(box_mm(-1.5, -1.5, 0, 1.5, 1.5, 5), 0.025 * mm);
  b.cut(tool, std::vector<Pose>{Pose{tip, a}});
  const Eigen::Vector3d apex = tip + r * a;
  double worst = 0.0;
  int checked = 0;
  for (int j = 0; j < b.nv(); ++j) {
    for (int i = 0; i < b.nu(); ++i) {
      const Eigen::Vector3d o = b.origin(i, j);
      // Near the tip: the flank's end (1.9 mm up the axis here) and the cylinder are above.
      if (std::hypot(o.x() - tip.x(), o.y() - tip.y()) > 1.2 * mm) continue;
      const double expected = std::min(5 * mm, minkowski_entry(o.x(), o.y(), apex, a, beta, r, 3 * mm, 5.5 * mm));
      worst = std::max(worst, std::abs(height(b, i, j) - expected));
      ++checked;
    }
  }
  EXPECT_GT(checked, 5000);
  EXPECT_LT(worst, 1e-10) << worst / um << " um";
  // The signed distance outside, against the same reference.
  const detail::Profile profile = detail::make_profile(tool);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> uni(-1.5 * mm, 1.5 * mm);
  double worst_distance = 0.0;
  for (int k = 0; k < 2000; ++k) {
    const Eigen::Vector3d p = tip + Eigen::Vector3d(uni(rng), uni(rng), uni(rng));
    const Eigen::Vector3d w = p - tip;
    const double axial = w.dot(a);
    if (axial > 1.5 * mm) continue;  // (below the flank's end)
    const double reference = cone_distance(p, apex, a, beta) - r;
    if (reference <= 0.0) continue;
    worst_distance = std::max(worst_distance, std::abs(profile.signed_distance((w - axial * a).norm(), axial) - reference));
  }
  EXPECT_LT(worst_distance, 1e-15);
}

// Z-map (closed forms and the vertical golden section) against general lines (static line
// intervals minimised over the motion) on level, ramp, plunge and tilted moves.
TEST(ConicalTools, ZmapAgreesWithGeneralLines) {
  const std::vector<Tool> tools = {v_tool(3, 90), v_tool(3, 60, 0.2), tapered(ToolType::tapered_flat, 3, 0.6, 12),
                                   tapered(ToolType::tapered_ball, 3, 0.8, 6)};
  const Eigen::Vector3d tilt = Eigen::Vector3d(0.2, -0.1, 1.0).normalized();
  // (Two trajectories: the tilted one with a constant axis; a turning axis only adds sub-steps.)
  const std::vector<Pose> path = {pose_mm(-2, -0.5, 6), pose_mm(-2, -0.5, 4.4), pose_mm(1.5, -0.3, 4.4),
                                  pose_mm(1.5, 0.4, 4.0), pose_mm(-1.0, 0.9, 4.7)};
  const std::vector<Pose> tilted = {pose_mm(-1.0, 0.9, 4.7, tilt), pose_mm(1.2, 1.1, 4.3, tilt),
                                    pose_mm(1.6, 1.3, 4.5, tilt)};
  for (std::size_t k = 0; k < tools.size(); ++k) {
    NBuffer zmap = NBuffer::zmap(box_mm(-3, -2, 0, 3, 2.5, 5), 0.04 * mm);
    NBuffer general = test::general_lines_like(zmap);
    for (const auto* p : {&path, &tilted}) {
      zmap.cut(tools[k], *p);
      general.cut(tools[k], *p);
    }
    const test::BufferDifference d = test::compare_lines(zmap, general, 5 * mm);
    EXPECT_LT(d.worst_m, 1e-11) << "tool " << k;
    EXPECT_GT(d.lowered, 1000u) << "tool " << k;
  }
}

// The OpenVDB level set and the Z-map on the same path, for each shape: the level set's surface
// within a fraction of a voxel of the Z-map's exact heights (away from the creases).
TEST(ConicalTools, LevelSetAgreesWithZmap) {
  const double voxel = 20 * um;
  const std::vector<Tool> tools = {v_tool(3, 90), v_tool(3, 120, 0.3), tapered(ToolType::tapered_flat, 3, 0.8, 15),
                                   tapered(ToolType::tapered_ball, 3, 1.0, 10)};
  const Eigen::Vector3d tilt = Eigen::Vector3d(0.15, 0.0, 1.0).normalized();
  const std::vector<Pose> path = {pose_mm(-1.5, -0.4, 1.5), pose_mm(1.5, -0.4, 1.5), pose_mm(1.5, 0.3, 1.7)};
  const std::vector<Pose> tilted = {pose_mm(1.5, 0.6, 1.65, tilt), pose_mm(-1.5, 0.6, 1.6, tilt)};
  for (std::size_t k = 0; k < tools.size(); ++k) {
    LevelSetOptions options;
    options.voxel_m = voxel;
    LevelSetStock stock = LevelSetStock::box(box_mm(-2, -1.5, 0, 2, 1.5, 2), options);
    NBuffer zmap = NBuffer::zmap(box_mm(-2, -1.5, 0, 2, 1.5, 2), 0.05 * mm);
    for (const auto* p : {&path, &tilted}) {
      stock.cut(tools[k], *p);
      zmap.cut(tools[k], *p);
    }
    double worst = 0.0;
    int checked = 0;
    for (int j = 2; j < zmap.nv() - 2; ++j) {
      for (int i = 2; i < zmap.nu() - 2; ++i) {
        const double z = height(zmap, i, j);
        // Off the creases (a V groove bottom bends the heights by ~100 um, a 0.5 mm ball by 5 um).
        const double bend = std::abs(height(zmap, i, j - 1) + height(zmap, i, j + 1) - 2 * z) +
                            std::abs(height(zmap, i - 1, j) + height(zmap, i + 1, j) - 2 * z);
        if (bend > 15 * um || z > 2 * mm - 4 * voxel) continue;
        const Eigen::Vector3d o = zmap.origin(i, j);
        const double phi = stock.signed_distance(Eigen::Vector3d(o.x(), o.y(), z));
        worst = std::max(worst, std::abs(phi));
        ++checked;
      }
    }
    EXPECT_GT(checked, 200) << "tool " << k;
    EXPECT_LT(worst, 0.15 * voxel) << "tool " << k << ": " << worst / um << " um";
  }
}

TEST(ConicalTools, BadShapesAreRefused) {
  EXPECT_THROW(v_tool(6, 180).validate(), InputError);
  EXPECT_THROW(v_tool(6, 0).validate(), InputError);
  EXPECT_THROW(v_tool(6, 90, 6).validate(), InputError);
  EXPECT_NO_THROW(v_tool(6, 90, 0.5).validate());
  EXPECT_THROW(tapered(ToolType::tapered_flat, 6, 1, 45).validate(), InputError);
  EXPECT_THROW(tapered(ToolType::tapered_flat, 6, 0, 5).validate(), InputError);
  EXPECT_THROW(tapered(ToolType::tapered_ball, 6, 7, 5).validate(), InputError);
  EXPECT_NO_THROW(tapered(ToolType::tapered_ball, 6, 6, 0).validate());
  EXPECT_NO_THROW(tapered(ToolType::tapered_flat, 6, 1, 0).validate());
}

}  // namespace
}  // namespace vmsim::removal
