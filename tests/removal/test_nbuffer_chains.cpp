// Chains of level moves along x with a tilted flat-end or bull-nose tool (nbuffer.cpp): each
// sweep tests only the lines between the lowest points of the tool's sections at its two ends.
// Checked here: the section's lowest point (section_lowest_x) against a brute-force minimum of
// the static tool's entry along the row, and whole random chains (both directions, reversals,
// stops, interruptions in the middle of a chain) on the Z-map against the same lines cut as a
// general buffer (every line through line_interval, no chains).
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

// A random tilted axis with |a_x| in [0.01, 0.35] (the chains' condition) and a small a_y.
Eigen::Vector3d random_axis(std::mt19937& rng) {
  std::uniform_real_distribution<double> ax(0.01, 0.35), ay(-0.2, 0.2), sign(-1.0, 1.0);
  return Eigen::Vector3d((sign(rng) < 0.0 ? -1.0 : 1.0) * ax(rng), sign(rng) < -0.5 ? 0.0 : ay(rng), 1.0).normalized();
}

// A bull-nose standing at the origin (no motion): random radii and length, a random tilt.
detail::Sweep random_static_bull(std::mt19937& rng) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const double rho = (1.0 + 2.0 * unit(rng)) * mm, r = (0.3 + unit(rng)) * mm, ell = (2.0 + 6.0 * unit(rng)) * mm;
  const Eigen::Vector3d a = random_axis(rng);
  return detail::make_sweep(Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), a, rho, r, ell);
}

// The static tool's entry on the vertical line (x, y) [m], +inf where it misses.
double static_entry(const detail::Sweep& s, double x, double y) {
  double t0 = 0.0, t1 = 0.0;
  if (!detail::line_interval(s, Eigen::Vector3d(x, y, -1.0), Eigen::Vector3d::UnitZ(), t0, t1)) return detail::kInf;
  return t0 - 1.0;
}

TEST(NBufferChains, SectionLowestPointMatchesBruteForce) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  int checked = 0, exact_heights = 0;
  for (int trial = 0; trial < 40; ++trial) {
    const bool bull = trial % 2 == 1;
    const double rho = (1.0 + 2.0 * unit(rng)) * mm, r = bull ? (0.3 + unit(rng)) * mm : 0.0;
    const double ell = (2.0 + 6.0 * unit(rng)) * mm;
    const Eigen::Vector3d a = random_axis(rng);
    const detail::Sweep s = detail::make_sweep(Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), a, rho, r, ell);
    double x_lo = 0.0, x_hi = 0.0;
    // Planes beyond the tool's y extent miss it.
    EXPECT_FALSE(detail::section_lowest_x(s, s.hi.y() + 1e-6, x_lo, x_hi));
    EXPECT_FALSE(detail::section_lowest_x(s, s.lo.y() - 1e-6, x_lo, x_hi));
    for (int row = 0; row < 8; ++row) {
      const double y = s.lo.y() + (0.03 + 0.94 * unit(rng)) * (s.hi.y() - s.lo.y());
      double z_low = 0.0, z_point = 0.0;
      ASSERT_TRUE(detail::section_lowest_x(s, y, x_lo, x_hi, &z_low, &z_point)) << trial;
      // The brute force: the entry along the row on a dense grid, then golden section between
      // the best sample's neighbours (the entry is convex along the row).
      const int n = 1500;
      const double step = (s.hi.x() - s.lo.x()) / n;
      int best = -1;
      double best_z = detail::kInf;
      for (int i = 0; i <= n; ++i) {
        const double z = static_entry(s, s.lo.x() + i * step, y);
        if (z < best_z) best_z = z, best = i;
      }
      if (best < 0) continue;  // the row only grazes the tool
      double lo = s.lo.x() + std::max(best - 1, 0) * step, hi = s.lo.x() + std::min(best + 1, n) * step;
      for (int k = 0; k < 100; ++k) {
        const double m1 = lo + (hi - lo) / 3.0, m2 = hi - (hi - lo) / 3.0;
        if (static_entry(s, m1, y) <= static_entry(s, m2, y)) {
          hi = m2;
        } else {
          lo = m1;
        }
      }
      double x_min = 0.5 * (lo + hi), precision = 1e-8;
      if (!(static_entry(s, x_min, y) <= best_z)) {  // the refinement left the tool (a row grazing it)
        x_min = s.lo.x() + best * step;
        precision = step;
      }
      // The lowest point lies in the interval (to the brute force's precision), and the
      // interval is tight.
      EXPECT_GE(x_min, x_lo - precision) << trial << " row " << row;
      EXPECT_LE(x_min, x_hi + precision) << trial << " row " << row;
      EXPECT_LT(x_hi - x_lo, 1e-6) << trial << " row " << row;
      // Its height: bounded from below, and where given, the brute force's minimum (which
      // the golden section finds to ~1e-13 m).
      const double z_brute = std::min(best_z, static_entry(s, x_min, y));
      EXPECT_LE(z_low, z_brute + 1e-13) << trial << " row " << row;
      if (std::isfinite(z_point) && precision < step) {  // (not where the row only grazes the tool)
        EXPECT_NEAR(z_point, z_brute, 2e-13) << trial << " row " << row;
        ++exact_heights;
      }
      // Lines beyond the interval enter higher, the farther the higher.
      for (double d : {1e-6, 1e-5, 1e-4}) {
        EXPECT_GE(static_entry(s, x_hi + 2 * d, y), static_entry(s, x_hi + d, y) - 1e-13);
        EXPECT_GE(static_entry(s, x_lo - 2 * d, y), static_entry(s, x_lo - d, y) - 1e-13);
      }
      ++checked;
    }
  }
  EXPECT_GT(checked, 250);
  EXPECT_GT(exact_heights, 200);
}

// The points of a section where the entry's x-slope is `slope` (section_point_x, the chains'
// junction boundaries where the tool turns), cold and warm-started along the rows, against
// the brute force: the static tool's entry on a dense grid along the row, its slope by finite
// differences. Beyond x_hi the slope is at least `slope`, before x_lo at most it, and the
// interval is tight.
TEST(NBufferChains, SectionSlopePointsMatchBruteForce) {
  std::mt19937 rng(8);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  int checked = 0, warm_checked = 0;
  for (int trial = 0; trial < 16; ++trial) {
    const detail::Sweep s = random_static_bull(rng);
    const double slope = (trial % 2 == 0 ? 1.0 : -1.0) * std::pow(10.0, -3.0 + 1.5 * unit(rng));
    detail::SectionWarm warm;
    const double y_start = s.lo.y() + (0.2 + 0.3 * unit(rng)) * (s.hi.y() - s.lo.y());
    for (int row = 0; row < 30; ++row) {
      const double y = y_start + row * 10e-6;  // rows 10 um apart: the warm start's case
      double cold_lo = 0.0, cold_hi = 0.0, x_lo = 0.0, x_hi = 0.0;
      ASSERT_TRUE(detail::section_point_x(s, y, slope, cold_lo, cold_hi)) << trial;
      ASSERT_TRUE(detail::section_point_x(s, y, slope, x_lo, x_hi, &warm)) << trial;
      for (const auto& [lo, hi] : {std::pair{cold_lo, cold_hi}, std::pair{x_lo, x_hi}}) {
        EXPECT_LT(hi - lo, 1e-7) << trial << " row " << row;
        const double h = 2e-6;  // finite-difference step [m]
        for (double d : {3e-6, 3e-5, 3e-4}) {
          const double beyond = (static_entry(s, hi + d + h, y) - static_entry(s, hi + d - h, y)) / (2 * h);
          const double before = (static_entry(s, lo - d + h, y) - static_entry(s, lo - d - h, y)) / (2 * h);
          if (std::isfinite(beyond)) {
            EXPECT_GE(beyond, slope - 1e-6) << trial << " row " << row << " d " << d;
          }
          if (std::isfinite(before)) {
            EXPECT_LE(before, slope + 1e-6) << trial << " row " << row << " d " << d;
          }
        }
        // Tight: just inside the interval's ends the slope is already near `slope`.
        const double mid = 0.5 * (lo + hi);
        const double at = (static_entry(s, mid + h, y) - static_entry(s, mid - h, y)) / (2 * h);
        EXPECT_NEAR(at, slope, 1e-3) << trial << " row " << row;
      }
      ++checked;
      warm_checked += std::isfinite(warm.u);
    }
  }
  EXPECT_EQ(checked, 16 * 30);
  EXPECT_GT(warm_checked, 16 * 28);
}

// The lowest points warm-started along rows 10 um apart (Newton from the rows before, a
// bracket tried before evaluating its centre) against the cold bisection: the same point and
// height.
TEST(NBufferChains, SectionLowestPointWarmEqualsCold) {
  std::mt19937 rng(12);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  int heights = 0, warm_rows = 0;
  for (int trial = 0; trial < 16; ++trial) {
    const detail::Sweep s = random_static_bull(rng);
    detail::SectionWarm warm;
    const double y_start = s.lo.y() + (0.1 + 0.3 * unit(rng)) * (s.hi.y() - s.lo.y());
    for (int row = 0; row < 200; ++row) {
      const double y = y_start + row * 10e-6;
      double cold_lo = 0.0, cold_hi = 0.0, cold_low = 0.0, cold_z = 0.0, lo = 0.0, hi = 0.0, low = 0.0, z = 0.0;
      ASSERT_TRUE(detail::section_point_x(s, y, 0.0, cold_lo, cold_hi, nullptr, &cold_low, &cold_z)) << trial;
      ASSERT_TRUE(detail::section_point_x(s, y, 0.0, lo, hi, &warm, &low, &z)) << trial;
      EXPECT_LE(lo, cold_hi) << trial << " row " << row;
      EXPECT_GE(hi, cold_lo) << trial << " row " << row;
      EXPECT_LT(hi - lo, 1e-6) << trial << " row " << row;
      EXPECT_NEAR(low, cold_low, 1e-12) << trial << " row " << row;
      if (std::isfinite(z) && std::isfinite(cold_z)) {
        EXPECT_NEAR(z, cold_z, 2e-13) << trial << " row " << row;
        ++heights;
      }
      warm_rows += std::isfinite(warm.u);
    }
  }
  EXPECT_GT(heights, 16 * 150);
  EXPECT_GT(warm_rows, 16 * 195);
}

// Random passes along x with one tilted axis each: segments of random length, sometimes a
// reversal or a stop (both end a chain), a step in y between passes.
std::vector<Pose> random_chains(std::mt19937& rng, double z_mm) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::vector<Pose> path;
  for (int pass = 0; pass < 4; ++pass) {
    const Eigen::Vector3d a = random_axis(rng);
    double x = -1.5 + 3.0 * unit(rng), dir = unit(rng) < 0.5 ? 1.0 : -1.0;
    const double y = -1.2 + 0.8 * pass + 0.2 * unit(rng);
    for (int k = 0; k < 12; ++k) {
      path.push_back(Pose{Eigen::Vector3d(x, y, z_mm) * mm, a});
      const double u = unit(rng);
      if (u < 0.1) dir = -dir;             // reversal
      if (u > 0.93) continue;              // stop: the same pose twice
      x += dir * (0.05 + 0.25 * unit(rng));
      if (std::abs(x) > 2.0) dir = -dir;
    }
  }
  return path;
}

void expect_chains_exact(const Tool& tool, std::uint32_t seed, double tolerance_m, double spacing_mm, int stop_after_batches) {
  std::mt19937 rng(seed);
  const Box stock{Eigen::Vector3d(-3, -3, 0) * mm, Eigen::Vector3d(3, 3, 5) * mm};
  NBuffer zmap = NBuffer::zmap(stock, spacing_mm * mm);
  NBuffer general = general_lines_like(zmap);
  const std::vector<Pose> path = random_chains(rng, 4.85);
  CutOptions options;
  options.batch_segments = 9;  // batches end in the middle of chains
  // The axis turns between passes: coarse sub-steps there (both buffers cut the same sweeps).
  options.orientation_tolerance_m = 20e-6;
  int batches = 0;
  if (stop_after_batches > 0) options.interrupted = [&](double) { return ++batches >= stop_after_batches; };
  const CutStatistics stats = zmap.cut(tool, path, options);
  batches = 0;
  general.cut(tool, path, options);
  EXPECT_EQ(stats.interrupted, stop_after_batches > 0);
  const auto difference = compare_lines(zmap, general, 5 * mm);
  EXPECT_LT(difference.worst_m, tolerance_m) << "seed " << seed;
  EXPECT_GT(difference.lowered, 300u) << "seed " << seed;
}

// Passes along x with the axis precessing about z at a small tilt (bull-nose orientation
// sub-steps in chains), segments of random length, reversals, stops, steps in y between passes.
std::vector<Pose> random_turning_chains(std::mt19937& rng, double z_mm) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::vector<Pose> path;
  const double tilt = (7.0 + 5.0 * unit(rng)) * M_PI / 180.0;
  double phase = 2.0 * M_PI * unit(rng);
  for (int pass = 0; pass < 3; ++pass) {
    double x = -1.5 + 3.0 * unit(rng), dir = unit(rng) < 0.5 ? 1.0 : -1.0;
    const double y = -1.0 + 0.9 * pass + 0.2 * unit(rng);
    for (int k = 0; k < 14; ++k) {
      const Eigen::Vector3d a(std::sin(tilt) * std::cos(phase), std::sin(tilt) * std::sin(phase), std::cos(tilt));
      path.push_back(Pose{Eigen::Vector3d(x, y, z_mm) * mm, a});
      const double u = unit(rng);
      if (u < 0.1) dir = -dir;  // reversal
      if (u > 0.93) continue;   // stop: the same pose twice
      phase += (unit(rng) < 0.2 ? -1.0 : 1.0) * (0.5e-3 + 3e-3 * unit(rng));
      x += dir * (0.05 + 0.25 * unit(rng));
      if (std::abs(x) > 2.0) dir = -dir;
    }
  }
  return path;
}

// The Z-map with the chains across turning sub-steps against the same sub-steps cut as general
// lines (no chains, every line through line_interval): the junction boundaries lose nothing
// against the sub-steps, so they agree to the bull-nose's 1e-11 m; and cutting never adds
// material. Batches of 9 end inside chains; `stop_after_batches` interrupts one.
void expect_turning_chains_exact(std::uint32_t seed, int stop_after_batches, std::size_t turning_cap = 1000) {
  std::mt19937 rng(seed);
  const Tool bull = make_tool(ToolType::bull, 3, 0.6, 3);
  const Box stock{Eigen::Vector3d(-3, -3, 0) * mm, Eigen::Vector3d(3, 3, 5) * mm};
  NBuffer zmap = NBuffer::zmap(stock, 0.08 * mm);
  NBuffer general = general_lines_like(zmap);
  const std::vector<Pose> path = random_turning_chains(rng, 4.9);
  CutOptions options;
  options.batch_segments = 9;
  options.batch_turning_sweeps = turning_cap;  // (1000: batches of 9 segments, whatever the sub-steps)
  options.orientation_tolerance_m = 0.05e-6;   // several sub-steps a segment
  int batches = 0;
  options.interrupted = [&](double) { return ++batches == stop_after_batches; };
  const std::vector<double> before = zmap.lengths();
  const CutStatistics stats = zmap.cut(bull, path, options);
  if (stop_after_batches == 0) {
    // Each batch ends after 9 segments or `turning_cap` sub-steps that turn, whichever is first.
    const std::size_t by_segments = (stats.segments + 8) / 9;
    if (turning_cap >= 1000) EXPECT_EQ(batches, static_cast<int>(by_segments));
    else EXPECT_GT(batches, static_cast<int>(by_segments));
  }
  batches = 0;
  general.cut(bull, path, options);
  EXPECT_EQ(stats.interrupted, stop_after_batches > 0);
  EXPECT_GT(stats.chained_turning, stats.sub_segments / 2) << "seed " << seed;  // (the chains are used)
  EXPECT_GT(stats.junction_rows_covered, 20u) << "seed " << seed;               // (and the coverage)
  EXPECT_GT(stats.sub_segments, 2 * stats.segments) << "seed " << seed;
  const auto difference = compare_lines(zmap, general, 5 * mm);
  EXPECT_LT(difference.worst_m, 1e-11) << "seed " << seed;
  EXPECT_GT(difference.lowered, 300u) << "seed " << seed;
  const std::vector<double> after = zmap.lengths();
  for (std::size_t k = 0; k < after.size(); ++k) ASSERT_LE(after[k], before[k]) << "seed " << seed;
}

TEST(NBufferChains, TurningBullChainsEqualGeneralLines) {
  for (std::uint32_t seed : {11u, 12u}) expect_turning_chains_exact(seed, 0);
  expect_turning_chains_exact(14, 0, 5);  // batches ended by the turning sub-steps
  expect_turning_chains_exact(13, 4);  // stopped in the middle of a chain
}

TEST(NBufferChains, FlatChainsEqualGeneralLines) {
  const Tool flat = make_tool(ToolType::flat, 3, 0, 3);
  for (std::uint32_t seed : {1u, 2u, 3u}) expect_chains_exact(flat, seed, 1e-12, 0.05, 0);
  expect_chains_exact(flat, 4, 1e-12, 0.05, 2);  // stopped in the middle of a chain
}

TEST(NBufferChains, BullChainsEqualGeneralLines) {
  const Tool bull = make_tool(ToolType::bull, 3, 0.6, 3);
  // A coarser grid: the general buffer computes every line of every tile the long way.
  for (std::uint32_t seed : {5u, 6u}) expect_chains_exact(bull, seed, 1e-11, 0.12, 0);
  expect_chains_exact(bull, 7, 1e-11, 0.12, 3);
}

}  // namespace
}  // namespace vmsim::removal
