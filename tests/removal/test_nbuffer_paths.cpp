// The Z-map's fast paths (culling by bounds, row ranges, the continuing-sweep skip, the ball and
// flat-bottom closed forms) against the same lines cut as a general buffer (every line of every
// visited tile through line_interval), and the closed-form line intervals against the signed
// distance (a second algorithm: nested convex minimisation).
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "../../removal/src/sweep.hpp"
#include "removal_test_tools.hpp"
#include "vmsim/removal/nbuffer.hpp"

namespace vmsim::removal {
namespace {

constexpr double mm = 1e-3;

using test::compare_lines;
using test::general_lines_like;
using test::make_tool;

// Zig-zag finishing passes (0.3 mm stepover, 0.2 mm segments) 0.2 mm into the top of the stock;
// the axis tilted by `tilt` and precessing by `turn` per segment; z waves when `wave`.
std::vector<Pose> passes(double tilt, double turn, bool wave) {
  std::vector<Pose> path;
  double phase = 0.3;
  for (int k = 0; k < 8; ++k) {
    for (int s = 0; s <= 15; ++s) {
      const double x = -1.5 + 0.2 * (k % 2 == 0 ? s : 15 - s), y = -1.2 + 0.3 * k;
      phase += turn;
      const Eigen::Vector3d axis(std::sin(tilt) * std::cos(phase), std::sin(tilt) * std::sin(phase), std::cos(tilt));
      const double z = 4.8 + (wave ? 0.1 * std::sin(3 * x) : 0.0);
      path.push_back(Pose{Eigen::Vector3d(x, y, z) * mm, axis});
    }
  }
  return path;
}

void expect_same_as_general_lines(const Tool& tool, const std::vector<Pose>& path, double tolerance_m,
                                  double spacing_mm = 0.04) {
  const Box stock{Eigen::Vector3d(-3, -3, 0) * mm, Eigen::Vector3d(3, 3, 5) * mm};
  NBuffer zmap = NBuffer::zmap(stock, spacing_mm * mm);
  NBuffer general = general_lines_like(zmap);
  CutOptions options;
  options.orientation_tolerance_m = 0.5e-6;
  const CutStatistics stats = zmap.cut(tool, path, options);
  general.cut(tool, path, options);
  const auto difference = compare_lines(zmap, general, 5 * mm);
  EXPECT_LT(difference.worst_m, tolerance_m);
  EXPECT_GT(difference.lowered, 400u);
  EXPECT_GT(stats.lines_lowered, 400u);
}

TEST(NBufferPaths, BallZmapEqualsGeneralLines) {
  const Tool ball = make_tool(ToolType::ball, 3, 0, 9);
  expect_same_as_general_lines(ball, passes(0.0, 0.0, false), 1e-12);
  expect_same_as_general_lines(ball, passes(0.0, 0.0, true), 1e-12);
  expect_same_as_general_lines(ball, passes(0.3, 0.0, false), 1e-12);
  expect_same_as_general_lines(ball, passes(0.3, 0.02, true), 1e-12);
}

TEST(NBufferPaths, FlatZmapEqualsGeneralLines) {
  const Tool flat = make_tool(ToolType::flat, 3, 0, 9);
  expect_same_as_general_lines(flat, passes(0.0, 0.0, true), 1e-12);
  expect_same_as_general_lines(flat, passes(0.2, 0.0, false), 1e-12);
  expect_same_as_general_lines(flat, passes(0.2, 0.01, true), 1e-12);
}

TEST(NBufferPaths, BullZmapEqualsGeneralLines) {
  const Tool bull = make_tool(ToolType::bull, 3, 0.5, 9);
  // A coarser grid: the general buffer computes every line of every tile the long way.
  expect_same_as_general_lines(bull, passes(0.0, 0.0, true), 1e-12, 0.15);
  expect_same_as_general_lines(bull, passes(0.2, 0.0, false), 1e-11, 0.15);
  expect_same_as_general_lines(bull, passes(0.2, 0.01, true), 1e-11, 0.15);
}

// VerticalEntry (the Z-map's fast path for tilted flat-end and bull-nose sweeps) against the
// general line_interval on random tilted sweeps: level moves, ramps, moves in the bottom's plane
// and pure plunges; rows of lines 10 um apart (warm starts) with random material tops, and lines
// grazing the bottom disc's edge. `above` must mean the entry is at or above the top, `exact` the
// entry within 1e-11 m; the start-disc rows the Z-map skips must be decided by the tool at c0.
TEST(NBufferPaths, VerticalEntryAgreesWithLineInterval) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> c(-1.0, 1.0), tilt(-0.35, 0.35), unit(0.0, 1.0);
  int exact = 0, above = 0, skipped = 0, grazing = 0, edge = 0;
  for (int k = 0; k < 240; ++k) {
    const bool bull = k % 2 == 1;
    const double rho = bull ? 1.5 * mm : 2 * mm, r = bull ? 0.5 * mm : 0.0;
    const Eigen::Vector3d a = Eigen::Vector3d(tilt(rng), tilt(rng), 1.0).normalized();
    const Eigen::Vector3d c0 = Eigen::Vector3d(c(rng), c(rng), c(rng)) * mm;
    Eigen::Vector3d move = Eigen::Vector3d(c(rng), c(rng), 0.2 * c(rng)) * 0.3 * mm;
    if (k % 8 == 2) move -= move.dot(a) * a;  // in the bottom's plane
    if (k % 8 == 4) move.z() = 0.0;           // level
    if (k % 8 == 6) move = Eigen::Vector3d(0.0, 0.0, -0.2 * mm);  // plunge
    const detail::Sweep s = detail::make_sweep(c0, c0 + move, a, rho, r, 4 * mm);
    const detail::Sweep start = detail::make_sweep(c0, c0, a, rho, r, 4 * mm);
    const detail::VerticalEntry fast(s);
    detail::VerticalEntry::Warm row_warm;
    const double row_y = (k % 3 == 0 ? c0.y() + (rho + r) * c(rng) : 3 * c(rng) * mm);
    const double floor = c0.z() - 3 * mm;  // the lines start below the sweep: line_interval's t0 is from there
    // One line against line_interval; returns its entry (or +inf on a miss).
    auto check = [&](double x, double y, double top, int walk, detail::VerticalEntry::Warm& warm) {
      double t0 = 0.0, t1 = 0.0;
      const bool hit = detail::line_interval(s, Eigen::Vector3d(x, y, floor), Eigen::Vector3d::UnitZ(), t0, t1);
      t0 += floor;
      double z = 0.0;
      const auto result = fast.entry(x, y, floor, top, 0, walk, warm, z);
      if (result == detail::VerticalEntry::Result::above) {
        ++above;
        if (hit) {
          EXPECT_GE(t0, top - 1e-11) << k << " x " << x << " y " << y;
        }
      } else if (result == detail::VerticalEntry::Result::exact) {
        ++exact;
        // Both must be points of the sweep's boundary; apart by more than 1e-11 m only where the
        // line runs along the boundary (grazing: rounding decides which end is found), i.e. with
        // no interior point between them.
        EXPECT_LT(std::abs(detail::signed_distance(s, Eigen::Vector3d(x, y, z))), 1e-11) << k << " x " << x;
        if (!hit || std::abs(z - t0) > 1e-11) {
          if (hit) {
            EXPECT_GT(detail::signed_distance(s, Eigen::Vector3d(x, y, 0.5 * (z + t0))), -1e-11) << k << " x " << x;
          }
          ++grazing;
        }
        EXPECT_GT(z, floor);
      }
      return hit ? t0 : detail::kInf;
    };
    int walk = 0;
    for (double x = -3.5 * mm; x < 3.5 * mm; x += 0.01 * mm, ++walk) {
      // Tops near the entry (the culling's hard case), above it and below it.
      double t0 = 0.0, t1 = 0.0;
      const bool hit = detail::line_interval(s, Eigen::Vector3d(x, row_y, floor), Eigen::Vector3d::UnitZ(), t0, t1);
      const double top = hit && k % 4 != 0 ? floor + t0 + (unit(rng) - 0.5) * (walk % 7 == 0 ? 1e-3 : 0.05) * mm
                                           : c0.z() + c(rng) * mm;
      check(x, row_y, top, walk, row_warm);
    }
    // Lines on the edge of the bottom disc at c0 and just inside and outside it (grazing the rim).
    for (double yy = c0.y() - 2.5 * mm; yy < c0.y() + 2.5 * mm; yy += 0.1 * mm) {
      double x0 = 0.0, x1 = 0.0;
      if (!fast.start_disc_row(yy, 0.0, x0, x1)) continue;
      for (double x : {x0, x1, std::nextafter(x0, -1.0), std::nextafter(x1, 1.0), x0 + 1e-9, x1 - 1e-9, x0 - 1e-9, x1 + 1e-9}) {
        detail::VerticalEntry::Warm cold;
        ++edge;
        const double entry = check(x, yy, c0.z() + mm, 0, cold);
        if (std::isfinite(entry)) check(x, yy, entry + 1e-9 * unit(rng), 0, cold);
      }
    }
    // Lines the Z-map skips for a sweep continuing with the same axis: the entry is the tool's
    // at c0 (which the sweep before held).
    if (fast.lowest_at_start()) {
      for (double yy = c0.y() - 2.5 * mm; yy < c0.y() + 2.5 * mm; yy += 0.05 * mm) {
        double x0 = 0.0, x1 = 0.0;
        if (!fast.start_disc_row(yy, 1e-9, x0, x1)) continue;
        for (double x = x0; x <= x1; x += std::max(1e-6, 0.1 * (x1 - x0))) {
          double t0 = 0.0, t1 = 0.0, s0 = 0.0, s1 = 0.0;
          const Eigen::Vector3d o(x, yy, c0.z() - 3 * mm);
          ASSERT_TRUE(detail::line_interval(s, o, Eigen::Vector3d::UnitZ(), t0, t1));
          ASSERT_TRUE(detail::line_interval(start, o, Eigen::Vector3d::UnitZ(), s0, s1));
          ASSERT_NEAR(t0, s0, 1e-11) << k;
          ++skipped;
        }
      }
    }
  }
  EXPECT_GT(exact, 20000);
  EXPECT_GT(above, 20000);
  EXPECT_GT(skipped, 1000);
  EXPECT_LT(grazing, edge / 10) << edge;  // the edge lines (and only a few of them) graze
}

TEST(NBufferPaths, ClosedFormIntervalsLieOnTheSignedDistanceZero) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> c(-1.0, 1.0), tilt(-0.6, 0.6);
  int hits = 0;
  for (int k = 0; k < 400; ++k) {
    const bool bull = k % 2 == 1;
    const Eigen::Vector3d a = Eigen::Vector3d(tilt(rng), tilt(rng), 1.0).normalized();
    const Eigen::Vector3d c0 = Eigen::Vector3d(c(rng), c(rng), c(rng)) * mm;
    const Eigen::Vector3d c1 = c0 + Eigen::Vector3d(c(rng), c(rng), 0.3 * c(rng)) * mm;
    const detail::Sweep s = detail::make_sweep(c0, c1, a, bull ? 1.5 * mm : 2 * mm, bull ? 0.5 * mm : 0.0, 4 * mm);
    const Eigen::Vector3d o = Eigen::Vector3d(2 * c(rng), 2 * c(rng), -6.0) * mm;
    const Eigen::Vector3d u = Eigen::Vector3d(0.5 * c(rng), 0.5 * c(rng), 1.0).normalized();
    double t0 = 0.0, t1 = 0.0;
    if (!detail::line_interval(s, o, u, t0, t1)) {
      // A miss: the signed distance stays positive along the line (sampled).
      for (double t = 0.0; t < 14 * mm; t += 0.01 * mm) ASSERT_GT(detail::signed_distance(s, o + t * u), -1e-12);
      continue;
    }
    ++hits;
    EXPECT_NEAR(detail::signed_distance(s, o + t0 * u), 0.0, 1e-11) << k;
    EXPECT_NEAR(detail::signed_distance(s, o + t1 * u), 0.0, 1e-11) << k;
    EXPECT_LT(detail::signed_distance(s, o + 0.5 * (t0 + t1) * u), 1e-12) << k;
    EXPECT_GT(detail::signed_distance(s, o + (t0 - 1e-7) * u), 0.0) << k;
  }
  EXPECT_GT(hits, 100);
}

}  // namespace
}  // namespace vmsim::removal
