// N-buffer material removal: closed-form known answers, laws (never adds material, order and
// thread independence, splitting a segment changes nothing), run-versus-run difference.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "../../removal/src/sweep.hpp"
#include "removal_test_tools.hpp"
#include "vmsim/removal/nbuffer.hpp"

namespace vmsim::removal {
namespace {

constexpr double mm = 1e-3;
constexpr double um = 1e-6;

Box box_mm(double x0, double y0, double z0, double x1, double y1, double z1) {
  return Box{Eigen::Vector3d(x0, y0, z0) * mm, Eigen::Vector3d(x1, y1, z1) * mm};
}
Pose pose_mm(double x, double y, double z, Eigen::Vector3d axis = Eigen::Vector3d::UnitZ()) {
  return Pose{Eigen::Vector3d(x, y, z) * mm, axis.normalized()};
}
using test::make_tool;
double height(const NBuffer& b, int i, int j) { return b.zmap_origin_m().z() + b.length(i, j); }
double xline(const NBuffer& b, int i) { return b.zmap_origin_m().x() + i * b.spacing_m(); }
double yline(const NBuffer& b, int j) { return b.zmap_origin_m().y() + j * b.spacing_m(); }

// Lowest point of a capsule (ball centres a -> b, radius R) above (x, y), closed form by the
// distance to the centre segment in the plane, for a horizontal segment.
double ball_trough(double x, double y, double ax, double bx, double yc, double zc, double R) {
  const double px = std::clamp(x, std::min(ax, bx), std::max(ax, bx));
  const double d2 = (x - px) * (x - px) + (y - yc) * (y - yc);
  return d2 <= R * R ? zc - std::sqrt(R * R - d2) : 1e9;
}

TEST(NBuffer, BallStraightPassCutsTheClosedFormTrough) {
  NBuffer b = NBuffer::zmap(box_mm(-5, -5, 0, 5, 5, 10), 0.05 * mm);
  const Tool tool = make_tool(ToolType::ball, 10);
  const std::vector<Pose> path = {pose_mm(-3, 0.013, 9.9), pose_mm(3, 0.013, 9.9)};
  b.cut(tool, path);
  const double R = 5 * mm, zc = 9.9 * mm + R, top = 10 * mm;
  double worst = 0.0;
  int cut_lines_mid = 0;
  for (int j = 0; j < b.nv(); ++j) {
    for (int i = 0; i < b.nu(); ++i) {
      const double expected = std::min(top, ball_trough(xline(b, i), yline(b, j), -3 * mm, 3 * mm, 0.013 * mm, zc, R));
      worst = std::max(worst, std::abs(height(b, i, j) - expected));
      if (i == b.nu() / 2 && height(b, i, j) < top) ++cut_lines_mid;
    }
  }
  EXPECT_LT(worst, 1e-12);
  // Width of the trough: 2 sqrt(R^2 - (R - depth)^2) = 2 sqrt(5^2 - 4.9^2) mm = 1.98997 mm.
  const double width = 2.0 * std::sqrt(R * R - (R - 0.1 * mm) * (R - 0.1 * mm));
  EXPECT_NEAR(cut_lines_mid * 0.05 * mm, width, 0.05 * mm + 1e-9);
  // Depth at the centre line: exactly 0.1 mm below the top (within rounding).
  double deepest = top;
  for (int j = 0; j < b.nv(); ++j) deepest = std::min(deepest, height(b, b.nu() / 2, j));
  EXPECT_NEAR(top - deepest, 0.1 * mm, 0.1 * um);  // nearest line within 0.025 mm of the centre
}

TEST(NBuffer, ParallelPassesLeaveTheScallopHeight) {
  const double p = 0.5 * mm, R = 3 * mm;
  NBuffer b = NBuffer::zmap(box_mm(-4, -2, 0, 4, 2, 10), 0.025 * mm);
  const Tool tool = make_tool(ToolType::ball, 6);
  std::vector<Pose> path;
  for (int k = -3; k <= 3; ++k) {  // zig-zag, 7 passes
    const double y = k * p / mm;
    if (k % 2 == 0) {
      path.push_back(pose_mm(-3, y, 9.0));
      path.push_back(pose_mm(3, y, 9.0));
    } else {
      path.push_back(pose_mm(3, y, 9.0));
      path.push_back(pose_mm(-3, y, 9.0));
    }
  }
  b.cut(tool, path);
  const double zc = 9 * mm + R;
  const double scallop = R - std::sqrt(R * R - p * p / 4);
  double worst = 0.0, highest = -1.0;
  const int i = b.nu() / 2;  // x = 0
  for (int j = 0; j < b.nv(); ++j) {
    const double y = yline(b, j);
    if (std::abs(y) > 3 * p) continue;
    double expected = 10 * mm;
    for (int k = -3; k <= 3; ++k) expected = std::min(expected, ball_trough(0.0, y, -3 * mm, 3 * mm, k * p, zc, R));
    worst = std::max(worst, std::abs(height(b, i, j) - expected));
    highest = std::max(highest, height(b, i, j));
  }
  EXPECT_LT(worst, 1e-12);
  EXPECT_NEAR(highest - 9 * mm, scallop, 0.1 * um);  // lines at the scallop crests exist (p/2 on the grid)
}

TEST(NBuffer, PassAboveTheStockRemovesNothing) {
  NBuffer b = NBuffer::zmap(box_mm(0, 0, 0, 4, 4, 5), 0.05 * mm);
  const std::vector<double> before = b.lengths();
  for (ToolType type : {ToolType::ball, ToolType::flat, ToolType::bull}) {
    const Tool tool = make_tool(type, 6, 1);
    const std::vector<Pose> path = {pose_mm(-2, 2, 5.0), pose_mm(6, 2, 5.0), pose_mm(6, 3, 8.0, {0.2, 0, 1})};
    b.cut(tool, path);
  }
  EXPECT_EQ(b.lengths(), before);
}

TEST(NBuffer, BullNosePassMatchesTheTorusProfile) {
  const double D = 8 * mm, r = 1.5 * mm, rho = D / 2 - r;
  NBuffer b = NBuffer::zmap(box_mm(-6, -6, 0, 6, 6, 10), 0.04 * mm);
  b.cut(make_tool(ToolType::bull, 8, 1.5), std::vector<Pose>{pose_mm(-5, 0.3, 9.2), pose_mm(5, 0.3, 9.2)});
  const double cz = 9.2 * mm + r;
  double worst = 0.0;
  for (int j = 0; j < b.nv(); ++j) {
    const double e = std::abs(yline(b, j) - 0.3 * mm) - rho;
    double expected = 10 * mm;
    if (e <= r) expected = std::min(expected, cz - std::sqrt(r * r - std::max(0.0, e) * std::max(0.0, e)));
    for (int i = b.nu() / 2 - 5; i <= b.nu() / 2 + 5; ++i) worst = std::max(worst, std::abs(height(b, i, j) - expected));
  }
  EXPECT_LT(worst, 1e-12);
}

TEST(NBuffer, BullNoseRampLiesOnTheSweptBoundary) {
  // A ramp (z changes along the move) takes the golden-section path; its surface points must lie
  // on the swept volume's boundary by the signed distance (a second algorithm).
  const Tool tool = make_tool(ToolType::bull, 8, 1.5);
  NBuffer b = NBuffer::zmap(box_mm(-6, -6, 0, 6, 6, 10), 0.1 * mm);
  const Pose p0 = pose_mm(-4, 0.0, 9.5), p1 = pose_mm(4, 1.0, 8.5);
  b.cut(tool, std::vector<Pose>{p0, p1});
  std::vector<detail::Sweep> sweeps;
  detail::split_segment(tool, p0, p1, 1e-8, sweeps);
  ASSERT_EQ(sweeps.size(), 1u);
  int checked = 0;
  for (int j = 0; j < b.nv(); ++j) {
    for (int i = 0; i < b.nu(); ++i) {
      if (b.length(i, j) >= 10 * mm) continue;
      const Eigen::Vector3d p = b.surface_point(i, j);
      EXPECT_NEAR(detail::signed_distance(sweeps[0], p), 0.0, 1e-9);
      EXPECT_GT(detail::signed_distance(sweeps[0], p - Eigen::Vector3d(0, 0, 1e-7)), 0.0);
      ++checked;
    }
  }
  EXPECT_GT(checked, 1000);
}

TEST(NBuffer, TiltedFlatEndPassMatchesTheClosedForm) {
  // Flat end D10 tilted by beta about y, moving along y: beyond the ends the lower envelope at
  // X = x - x_c is -X tan(beta) under the bottom disc (X <= rho cos beta), X cot(beta) - rho /
  // sin(beta) under the flank.
  const double beta = 10.0 * M_PI / 180.0, rho = 5 * mm;
  const Eigen::Vector3d axis(std::sin(beta), 0.0, std::cos(beta));
  NBuffer b = NBuffer::zmap(box_mm(-6, -3, 0, 8, 3, 10), 0.1 * mm);
  const Tool tool = make_tool(ToolType::flat, 10, 0, 40);
  b.cut(tool, std::vector<Pose>{pose_mm(0, -10, 9.0, axis), pose_mm(0, 10, 9.0, axis)});
  double worst = 0.0;
  int cut = 0;
  for (int j = 0; j < b.nv(); ++j) {
    for (int i = 0; i < b.nu(); ++i) {
      const double X = xline(b, i);
      double expected = 10 * mm;
      if (X >= -rho * std::cos(beta)) {
        const double z = X <= rho * std::cos(beta) ? -X * std::tan(beta) : X / std::tan(beta) - rho / std::sin(beta);
        expected = std::min(expected, 9 * mm + z);
      }
      if (expected < 10 * mm) ++cut;
      worst = std::max(worst, std::abs(height(b, i, j) - expected));
    }
  }
  EXPECT_GT(cut, 1000);
  EXPECT_LT(worst, 1e-10);
}

TEST(NBuffer, GeneralLinesAlongATiltedDirection) {
  // Lines along (0, sin 30, cos 30) cut by a straight ball pass: each lowered line ends on the
  // swept tool (ball and shank), at distance R from the swept centre rectangle (closed form).
  const Eigen::Vector3d u(0.0, 0.5, std::sqrt(0.75));
  std::vector<Eigen::Vector3d> o, d;
  std::vector<double> len;
  const int n = 60;
  for (int iv = 0; iv < n; ++iv) {
    for (int iu = 0; iu < n; ++iu) {
      o.emplace_back((iu - 30) * 0.1 * mm, (iv - 30) * 0.1 * mm - 5 * mm, 0.0);
      d.push_back(u);
      len.push_back(10 * mm);
    }
  }
  NBuffer b = NBuffer::lines(n, n, o, d, len);
  const Eigen::Vector3d c0(-2 * mm, 0.0, 8.5 * mm + 3 * mm), c1(2 * mm, 0.0, 8.5 * mm + 3 * mm);
  b.cut(make_tool(ToolType::ball, 6), std::vector<Pose>{Pose{c0 - Eigen::Vector3d(0, 0, 3 * mm), Eigen::Vector3d::UnitZ()},
                                                          Pose{c1 - Eigen::Vector3d(0, 0, 3 * mm), Eigen::Vector3d::UnitZ()}});
  int lowered = 0;
  for (int iv = 0; iv < n; ++iv) {
    for (int iu = 0; iu < n; ++iu) {
      if (b.length(iu, iv) >= 10 * mm) continue;
      ++lowered;
      const Eigen::Vector3d p = b.surface_point(iu, iv);
      // Distance to the rectangle swept by the ball centre and the axis (x in [-2, 2] mm,
      // y = 0, z from the centre up 24 mm): R on the surface of the swept tool.
      const double dx = std::max({-2 * mm - p.x(), 0.0, p.x() - 2 * mm});
      const double dz = std::max({c0.z() - p.z(), 0.0, p.z() - c0.z() - 24 * mm});
      EXPECT_NEAR(std::sqrt(dx * dx + p.y() * p.y() + dz * dz), 3 * mm, 1e-12);
    }
  }
  EXPECT_GT(lowered, 100);
}

TEST(NBuffer, LongSegmentEqualsTheSameSegmentIn100Pieces) {
  for (ToolType type : {ToolType::ball, ToolType::flat, ToolType::bull}) {
    const Tool tool = make_tool(type, 6, 1);
    NBuffer whole = NBuffer::zmap(box_mm(-5, -5, 0, 5, 5, 10), 0.02 * mm);
    NBuffer pieces = whole;
    const Pose a = pose_mm(-4, -1.3, 9.7), b = pose_mm(4, 1.9, 9.7);
    whole.cut(tool, std::vector<Pose>{a, b});
    std::vector<Pose> split;
    for (int k = 0; k <= 100; ++k) {
      const double s = k / 100.0;
      split.push_back(Pose{(1 - s) * a.tip_W_m + s * b.tip_W_m, Eigen::Vector3d::UnitZ()});
    }
    pieces.cut(tool, split);
    const std::vector<double> diff = difference(pieces, whole);
    double worst = 0.0;
    for (int j = 0; j < whole.nv(); ++j) {
      for (int i = 0; i < whole.nu(); ++i) {
        // A flat end's rim is a vertical wall: a line within rounding of it may fall either side.
        const double d = detail::distance_2d(xline(whole, i), yline(whole, j), a.tip_W_m.x(), a.tip_W_m.y(),
                                             b.tip_W_m.x(), b.tip_W_m.y());
        if (type == ToolType::flat && std::abs(d - 3 * mm) < 1e-9) continue;
        worst = std::max(worst, std::abs(diff[static_cast<std::size_t>(i) + static_cast<std::size_t>(whole.nu()) * j]));
      }
    }
    EXPECT_LT(worst, 1e-12) << static_cast<int>(type);
  }
}

TEST(NBuffer, SteppedPositionsLeaveArtefactsTheSweepDoesNot) {
  // The same segment cut as 11 stepped tool positions leaves cusps between them (what the
  // swept cut must not do): the swept result is lower, by up to the cusp height.
  const Tool tool = make_tool(ToolType::ball, 6);
  NBuffer swept = NBuffer::zmap(box_mm(-5, -5, 0, 5, 5, 10), 0.01 * mm);
  NBuffer stepped = swept;
  swept.cut(tool, std::vector<Pose>{pose_mm(-2, 0, 9.7), pose_mm(2, 0, 9.7)});
  for (int k = 0; k <= 10; ++k) stepped.cut(tool, std::vector<Pose>{pose_mm(-2 + 0.4 * k, 0, 9.7)});
  const std::vector<double> diff = difference(stepped, swept);
  const double cusp = 3 * mm - std::sqrt(9 * mm * mm - 0.2 * mm * 0.2 * mm);  // 6.7 um on y = 0
  const int j0 = swept.nv() / 2;  // y = 0
  double on_centre = 0.0;
  for (int i = 0; i < swept.nu(); ++i) on_centre = std::max(on_centre, diff[static_cast<std::size_t>(i + swept.nu() * j0)]);
  EXPECT_NEAR(on_centre, cusp, 0.1 * um);
  EXPECT_GE(*std::min_element(diff.begin(), diff.end()), -1e-15);  // the sweep contains every position
}

std::vector<Pose> random_path(std::mt19937& rng, int n, bool tilt) {
  std::uniform_real_distribution<double> x(-4, 4), z(8.5, 10.5), t(-0.3, 0.3);
  std::vector<Pose> path;
  for (int k = 0; k < n; ++k) {
    Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();
    if (tilt) axis = Eigen::Vector3d(t(rng), t(rng), 1.0);
    path.push_back(pose_mm(x(rng), x(rng), z(rng), axis));
  }
  return path;
}

TEST(NBuffer, RemovalNeverAddsMaterialRandomised) {
  std::mt19937 rng(7);
  NBuffer b = NBuffer::zmap(box_mm(-5, -5, 0, 5, 5, 10), 0.1 * mm);
  const ToolType types[] = {ToolType::ball, ToolType::bull, ToolType::flat};
  for (int round = 0; round < 9; ++round) {
    const std::vector<double> before = b.lengths();
    CutOptions options;
    options.orientation_tolerance_m = 2 * um;  // few sub-steps: the law holds for any tolerance
    b.cut(make_tool(types[round % 3], 4, 1, 8), random_path(rng, round % 3 == 0 ? 6 : 3, round >= 6 && round % 3 == 0), options);
    const std::vector<double> after = b.lengths();
    int lowered = 0;
    for (std::size_t k = 0; k < after.size(); ++k) {
      ASSERT_LE(after[k], before[k]);
      ASSERT_GE(after[k], 0.0);
      lowered += after[k] < before[k];
    }
    EXPECT_GT(lowered, 0) << round;
  }
}

// Cuts `path` into `one` on one thread in batches of 7 segments and into `two` (a copy of `one`
// before the cut) on two threads with the default batch; returns the one-thread statistics.
CutStatistics cut_on_one_and_two_threads(const Tool& tool, const std::vector<Pose>& path,
                                         double orientation_tolerance_m, NBuffer& one, NBuffer& two) {
  two = one;
  CutOptions o1;
  o1.threads = 1;
  o1.batch_segments = 7;
  CutOptions o2;
  o2.threads = 2;
  o1.orientation_tolerance_m = o2.orientation_tolerance_m = orientation_tolerance_m;
  const CutStatistics stats = one.cut(tool, path, o1);
  two.cut(tool, path, o2);
  return stats;
}

TEST(NBuffer, SameResultForOneAndTwoThreadsAndAnyBatch) {
  std::mt19937 rng(11);
  const std::vector<Pose> path = random_path(rng, 200, true);
  const Tool tool = make_tool(ToolType::ball, 3, 0, 6);
  NBuffer one = NBuffer::zmap(box_mm(-5, -5, 0, 5, 5, 10), 0.05 * mm);
  NBuffer two = one;
  cut_on_one_and_two_threads(tool, path, 5 * um, one, two);  // 5 um: keep the sub-steps few
  EXPECT_EQ(one.lengths(), two.lengths());
}

TEST(NBuffer, TiltedFlatAndBullSameResultForOneAndTwoThreadsAndAnyBatch) {
  // Tilted zig-zags (the fast path's warm starts and the skip of the start disc for sweeps
  // continuing with the same axis), constant and turning axis.
  for (const double turn : {0.0, 0.01}) {
    std::vector<Pose> path;
    double phase = 0.0;
    for (int k = 0; k < 6; ++k) {
      for (int s = 0; s <= 12; ++s) {
        phase += turn;
        const Eigen::Vector3d axis(0.17 * std::cos(phase), 0.17 * std::sin(phase), 1.0);
        path.push_back(pose_mm(-1.5 + 0.25 * (k % 2 == 0 ? s : 12 - s), -1.0 + 0.4 * k, 9.8, axis));
      }
    }
    for (ToolType type : {ToolType::flat, ToolType::bull}) {
      const Tool tool = make_tool(type, 4, 1, 8);
      NBuffer one = NBuffer::zmap(box_mm(-4, -4, 0, 4, 4, 10), 0.02 * mm);
      NBuffer two = one;
      const CutStatistics stats = cut_on_one_and_two_threads(tool, path, 1 * um, one, two);
      EXPECT_GT(stats.lines_lowered, 10000u);
      // (The bull-nose's turning sub-steps are chained, their tables built in parallel.)
      if (type == ToolType::bull && turn > 0.0) {
        EXPECT_GT(stats.chained_turning, stats.sub_segments / 2);
      }
      // The thread count never matters. The batch size does not either, except where turning
      // bull-nose chains meet: there the lines a sweep leaves to the over zones of the sweeps
      // after it depend on which of them are in its batch, and the rim searches of the lines
      // tested start from other neighbours, so their entries, certified within 1e-11 m, may
      // differ by that much.
      NBuffer three = NBuffer::zmap(box_mm(-4, -4, 0, 4, 4, 10), 0.02 * mm);
      CutOptions o3;
      o3.threads = 2;
      o3.batch_segments = 7;
      o3.orientation_tolerance_m = 1 * um;
      three.cut(tool, path, o3);
      EXPECT_EQ(one.lengths(), three.lengths()) << static_cast<int>(type) << " turn " << turn;
      if (type == ToolType::bull && turn > 0.0) {
        const std::vector<double> a = one.lengths(), b = two.lengths();
        double worst = 0.0;
        for (std::size_t i = 0; i < a.size(); ++i) worst = std::max(worst, std::abs(a[i] - b[i]));
        EXPECT_LE(worst, 1e-11);
      } else {
        EXPECT_EQ(one.lengths(), two.lengths()) << static_cast<int>(type) << " turn " << turn;
      }
    }
  }
}

TEST(NBuffer, PlantedDeviationLeavesItsMarkInTheDifference) {
  // Zig-zag finishing with a ball D10 at 0.2 mm stepover; the production run's tip dips 20 um
  // over 2 mm of one pass (x = 1 .. 3 mm on y = 0), with 0.1 mm ramps in and out.
  const Tool tool = make_tool(ToolType::ball, 10);
  auto program = [&](bool planted) {
    std::vector<Pose> path;
    for (int k = -10; k <= 10; ++k) {
      const double y = k * 0.2;
      std::vector<double> xs;
      for (int s = 0; s <= 100; ++s) xs.push_back(-5 + 0.1 * s);
      if (k % 2 != 0) std::reverse(xs.begin(), xs.end());
      for (double x : xs) {
        double z = 9.5;
        if (planted && k == 0 && x >= 0.95 && x <= 3.05) z -= 0.02;
        path.push_back(pose_mm(x, y, z));
      }
    }
    return path;
  };
  NBuffer reference = NBuffer::zmap(box_mm(-6, -3, 0, 6, 3, 10), 0.02 * mm);
  NBuffer production = reference;
  reference.cut(tool, program(false));
  production.cut(tool, program(true));
  const std::vector<double> diff = difference(production, reference);
  const auto it = std::min_element(diff.begin(), diff.end());
  EXPECT_NEAR(*it, -20 * um, 0.5 * um);
  const std::size_t k = static_cast<std::size_t>(it - diff.begin());
  const double x = xline(production, static_cast<int>(k % static_cast<std::size_t>(production.nu())));
  const double y = yline(production, static_cast<int>(k / static_cast<std::size_t>(production.nu())));
  EXPECT_GE(x, 0.95 * mm);
  EXPECT_LE(x, 3.05 * mm);
  EXPECT_NEAR(y, 0.0, 0.1 * mm);
  // Away from the planted stretch the two runs are identical, bit for bit.
  for (std::size_t m = 0; m < diff.size(); ++m) {
    const double xm = xline(production, static_cast<int>(m % static_cast<std::size_t>(production.nu())));
    if (xm < 0.0 || xm > 4.0 * mm) {
      ASSERT_EQ(diff[m], 0.0);
    }
  }
}

TEST(NBuffer, TurningBallKeepsTheExactCapsuleAtTheBottom) {
  // The ball of a ball-end mill turns about its centre: with the axis turning 20 deg over the
  // segment the bottom of the trough is still the capsule of the ball centres.
  const Tool tool = make_tool(ToolType::ball, 6, 0, 12);
  NBuffer b = NBuffer::zmap(box_mm(-5, -3, 0, 5, 3, 10), 0.05 * mm);
  const double a = 20.0 * M_PI / 180.0;
  const Pose p0{Eigen::Vector3d(-3 * mm, 0, 9.6 * mm), Eigen::Vector3d::UnitZ()};
  const Eigen::Vector3d axis1(std::sin(a), 0, std::cos(a));
  const Pose p1{Eigen::Vector3d(3 * mm, 0, 12.6 * mm) - 3 * mm * axis1, axis1};  // centre at z 12.6 mm
  CutOptions options;
  options.orientation_tolerance_m = 0.5 * um;
  const CutStatistics stats = b.cut(tool, std::vector<Pose>{p0, p1}, options);
  EXPECT_GT(stats.sub_segments, 100u);
  double worst = 0.0;
  for (int j = 0; j < b.nv(); ++j) {
    const double y = yline(b, j);
    if (std::abs(y) > 0.5 * mm) continue;
    for (int i = 0; i < b.nu(); ++i) {
      const double expected = std::min(10 * mm, ball_trough(xline(b, i), y, -3 * mm, 3 * mm, 0.0, 12.6 * mm, 3 * mm));
      worst = std::max(worst, std::abs(height(b, i, j) - expected));
    }
  }
  EXPECT_LT(worst, 1e-12);
}

TEST(NBuffer, DifferenceNeedsIdenticalGrids) {
  const NBuffer a = NBuffer::zmap(box_mm(0, 0, 0, 1, 1, 1), 0.1 * mm);
  const NBuffer b = NBuffer::zmap(box_mm(0, 0, 0, 1, 1, 1), 0.05 * mm);
  EXPECT_THROW(difference(a, b), std::invalid_argument);
  const std::vector<double> zero = difference(a, a);
  EXPECT_TRUE(std::all_of(zero.begin(), zero.end(), [](double v) { return v == 0.0; }));
}

}  // namespace
}  // namespace vmsim::removal
