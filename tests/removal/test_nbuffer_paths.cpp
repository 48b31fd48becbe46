// The Z-map's fast paths (culling by bounds, row ranges, the continuing-sweep skip, the ball and
// flat-bottom closed forms) against the same lines cut as a general buffer (every line of every
// visited tile through line_interval), and the closed-form line intervals against the signed
// distance (a second algorithm: nested convex minimisation).
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
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


// The vertical ball-end fast path (VerticalBallEntry: ramps, plunges, z-steps of a 3-axis ball)
// against the general functions it stands for, bit for bit: vertical_entry (the line's entry)
// and lowest_z_beyond at distance_2d (the culling bound), and the culling's decision on lines
// whose top lies at, an ulp from, near and far from that bound. Random sweeps of every shape the
// path serves: ramps of any slope, plunges, near-plunges, z-steps, moves shorter than a line
// spacing; lines anywhere around them (inside, on the rim, outside, on c0's and c1's verticals).
TEST(NBufferPaths, VerticalBallEntryEqualsTheGeneralPathBitForBit) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> c(-1.0, 1.0), unit(0.0, 1.0);
  auto same_bits = [](double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; };
  int hits = 0, misses = 0, bounded = 0, decided = 0;
  for (int k = 0; k < 3000; ++k) {
    const double r = (k % 3 == 0 ? 5.0 : 1.5) * mm;
    const Eigen::Vector3d c0 = Eigen::Vector3d(20 * c(rng), 20 * c(rng), 10 + 10 * c(rng)) * mm;
    Eigen::Vector3d move = Eigen::Vector3d(c(rng), c(rng), c(rng)) * 0.3 * mm;
    switch (k % 6) {
      case 1: move = Eigen::Vector3d(0.0, 0.0, -0.5 * unit(rng) * mm); break;              // plunge
      case 2: move.x() *= 1e-9, move.y() *= 1e-9; break;                                  // near-plunge
      case 3: move *= 0.01; break;                                                        // shorter than a line spacing
      case 4: move = Eigen::Vector3d(0.04 * c(rng), 0.0, 1e-9 * c(rng)) * mm; break;      // servo noise on a level pass
      case 5: move.z() = 0.05 * mm * (c(rng) > 0 ? 1 : -1), move.x() *= 0.01; break;      // z-step
      default: break;
    }
    const detail::Sweep s = detail::make_sweep(c0, c0 + move, Eigen::Vector3d::UnitZ(), 0.0, r, 3 * r);
    if (!detail::VerticalBallEntry::serves(s)) continue;
    const detail::VerticalBallEntry fast(s);
    for (int j = 0; j < 60; ++j) {
      double x = c0.x() + 1.2 * r * c(rng), y = c0.y() + 1.2 * r * c(rng);
      if (j == 0) x = c0.x(), y = c0.y();
      if (j == 1) x = s.c1.x(), y = s.c1.y();
      if (j == 2) x = c0.x() + r, y = c0.y();  // on the rim at c0
      if (j % 5 == 3) {                        // near the middle of the move
        const double t = unit(rng);
        x = c0.x() + t * move.x() + 1e-7 * c(rng), y = c0.y() + t * move.y() + 1e-7 * c(rng);
      }
      double z0 = 0.0, z1 = 0.0, z = 0.0;
      const bool hit = detail::vertical_entry(s, x, y, z0, z1);
      ASSERT_EQ(fast.entry(x, y, z), hit) << k << " " << j;
      if (hit) {
        ASSERT_TRUE(same_bits(z, z0)) << k << " " << j << ": " << z << " vs " << z0;
        ++hits;
      } else {
        ++misses;
      }
      const double bound = detail::lowest_z_beyond(s, detail::distance_2d(x, y, s.c0.x(), s.c0.y(), s.c1.x(), s.c1.y()));
      ASSERT_TRUE(same_bits(fast.lowest_below(x, y), bound)) << k << " " << j;
      bounded += std::isfinite(bound);
      // The culling's decision for lines of many lengths, at and around that bound.
      const double z_origin = (k % 4 == 0 ? -0.01 : 0.0) + 0.01 * c(rng);
      const double at = std::isfinite(bound) ? bound - z_origin : (c0.z() - z_origin);
      for (const double h : {at, std::nextafter(at, 0.0), std::nextafter(at, 1.0), at + 1e-12, at - 1e-12, at + 1e-9 * c(rng),
                             at + 1e-4 * c(rng), at + r * c(rng), 0.0, 1.0}) {
        const bool general = bound - z_origin >= h;
        ASSERT_EQ(fast.cannot_lower(x, y, z_origin, h), general) << k << " " << j << " h " << h;
        decided += general;
      }
    }
  }
  EXPECT_GT(hits, 50000);
  EXPECT_GT(misses, 10000);
  EXPECT_GT(bounded, 50000);
  EXPECT_GT(decided, 300000);
}

// Random 3-axis ball-end trajectories (servo-like passes along x with nm noise in z over a
// wave, plunges, z-steps, moves shorter than a line spacing) cut on a Z-map, plain and compact,
// 1 and 2 threads, against every line cut by hand the general way in the cut's order (the level
// closed form for level sweeps, else the bound lowest_z_beyond and vertical_entry): the same
// doubles. The compact buffer, cut in one batch, holds the plain result's offsets from its base.
TEST(NBufferPaths, BallRampsOnAZmapEqualTheGeneralPathLineByLine) {
  const Tool ball = make_tool(ToolType::ball, 3, 0, 9);
  const Box stock{Eigen::Vector3d(-3, -3, 0) * mm, Eigen::Vector3d(3, 3, 5) * mm};
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> c(-1.0, 1.0);
  std::vector<Pose> path;
  auto add = [&](double x, double y, double z) { path.push_back(Pose{Eigen::Vector3d(x, y, z) * mm, Eigen::Vector3d::UnitZ()}); };
  add(-2.0, -2.0, 6.0);
  add(-2.0, -2.0, 4.7);  // plunge into the stock
  for (int pass = 0; pass < 6; ++pass) {
    const double y = -2.0 + 0.35 * pass;
    for (int i = 0; i <= 100; ++i) {
      const double x = -2.0 + 0.04 * (pass % 2 == 0 ? i : 100 - i);
      double z = 4.7 + 0.15 * std::sin(2.0 * x) + 1e-6 * c(rng);  // nm noise (mm units)
      if (i % 37 == 5) z += 0.03;                                 // a z-step up, then down
      add(x + 1e-5 * c(rng), y, z);
      if (i % 23 == 7) add(x + 0.004, y, z - 0.002);              // shorter than a line spacing
      if (i % 41 == 11) add(path.back().tip_W_m.x() / mm, y, z);  // a level move of length 0... and level
    }
    add(path.back().tip_W_m.x() / mm, y + 0.35, path.back().tip_W_m.z() / mm - 0.01);  // stepover going down
  }
  add(0.5, 0.5, 4.2);  // a deep plunge-ramp
  add(0.5, 0.5, 4.0);  // and a plunge

  // By hand, in the cut's order: each line from the stock, every sweep.
  NBuffer zmap = NBuffer::zmap(stock, 0.04 * mm);
  const double z0 = zmap.zmap_origin_m().z();
  std::vector<double> expected = zmap.lengths();
  for (std::size_t k = 0; k + 1 < path.size(); ++k) {
    std::vector<detail::Sweep> sweeps;
    detail::split_segment(ball, path[k], path[k + 1], 0.05e-6, sweeps);
    ASSERT_EQ(sweeps.size(), 1u);
    const detail::Sweep& s = sweeps[0];
    for (int iv = 0; iv < zmap.nv(); ++iv) {
      for (int iu = 0; iu < zmap.nu(); ++iu) {
        double& h = expected[static_cast<std::size_t>(iu) + static_cast<std::size_t>(zmap.nu()) * iv];
        const double x = zmap.origin(iu, iv).x(), y = zmap.origin(iu, iv).y();
        const double d = detail::distance_2d(x, y, s.c0.x(), s.c0.y(), s.c1.x(), s.c1.y());
        double t0 = 0.0, t1 = 0.0;
        if (s.c0.z() == s.c1.z()) {
          if (d > s.r) continue;
          t0 = s.c0.z() - std::sqrt((s.r - d) * (s.r + d)) - z0;
          t1 = s.c0.z() + s.ell + s.r - z0;
        } else {
          if (detail::lowest_z_beyond(s, d) - z0 >= h) continue;
          if (!detail::vertical_entry(s, x, y, t0, t1)) continue;
          t0 -= z0;
          t1 -= z0;
        }
        if (t1 > 0.0 && t0 < h) h = std::max(0.0, t0);
      }
    }
  }
  std::size_t lowered = 0;
  for (double h : expected) lowered += h < 5 * mm;
  EXPECT_GT(lowered, 5000u);

  for (int threads : {1, 2}) {
    CutOptions options;
    options.threads = threads;
    NBuffer plain = NBuffer::zmap(stock, 0.04 * mm);
    plain.cut(ball, path, options);
    const std::vector<double> lengths = plain.lengths();
    std::size_t differ = 0;
    for (std::size_t i = 0; i < lengths.size(); ++i) differ += std::memcmp(&lengths[i], &expected[i], sizeof(double)) != 0;
    EXPECT_EQ(differ, 0u) << threads << " threads";

    NBuffer compact = NBuffer::zmap(stock, 0.04 * mm);
    compact.make_compact();
    options.batch_segments = path.size();  // one batch: each tile decoded, cut and encoded once
    compact.cut(ball, path, options);
    const double base = 5 * mm;
    std::size_t compact_differ = 0;
    for (int iv = 0; iv < compact.nv(); ++iv) {
      for (int iu = 0; iu < compact.nu(); ++iu) {
        const double h = expected[static_cast<std::size_t>(iu) + static_cast<std::size_t>(compact.nu()) * iv];
        const double stored = h == base ? base : std::max(0.0, base + static_cast<double>(static_cast<float>(h - base)));
        const double got = compact.length(iu, iv);
        compact_differ += std::memcmp(&got, &stored, sizeof(double)) != 0;
      }
    }
    EXPECT_EQ(compact_differ, 0u) << threads << " threads";
  }
}

}  // namespace
}  // namespace vmsim::removal
