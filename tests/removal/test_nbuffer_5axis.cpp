// 5-axis cuts (the axis turning within segments) on a Z-map against an independent reference:
// the same trajectory's exact swept volume with the whole tool (no shortening to the part that
// can reach the material, split_segment without the material box) in sub-steps 20 times finer
// than the production's, every line through line_interval. The production heights (a tool
// shortened to what can reach the material, sub-steps at the orientation tolerance) must lie
// within that tolerance, measured normal to the surface, of the reference.
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

using test::make_tool;

// Two passes along x, 0.2 mm segments, 0.1 mm below the stock top (5 mm), the axis tilted by 10 to
// 30 deg and its azimuth turning by 0.5 to 4 mrad a segment (reversing at random).
std::vector<Pose> random_turning_passes(std::mt19937& rng, double min_tilt_deg = 10.0, double max_tilt_deg = 30.0) {
  std::uniform_real_distribution<double> tilt(min_tilt_deg * M_PI / 180.0, max_tilt_deg * M_PI / 180.0),
      turn(0.5e-3, 4e-3), unit(0.0, 1.0);
  const double beta = tilt(rng);
  double phi = 2.0 * M_PI * unit(rng);
  std::vector<Pose> path;
  for (int pass = 0; pass < 2; ++pass) {
    const double y = (-0.35 + 0.6 * pass + 0.05 * unit(rng)) * mm;
    for (int k = 0; k <= 10; ++k) {
      const double x = (pass % 2 == 0 ? -1.0 + 0.2 * k : 1.0 - 0.2 * k) * mm;
      if (unit(rng) < 0.15) phi -= 2.0 * turn(rng);
      phi += turn(rng);
      const Eigen::Vector3d axis(std::sin(beta) * std::cos(phi), std::sin(beta) * std::sin(phi), std::cos(beta));
      path.push_back(Pose{Eigen::Vector3d(x, y, 4.9 * mm), axis});
    }
  }
  return path;
}

// Returns the Z-map's statistics.
CutStatistics expect_within_orientation_tolerance(const Tool& tool, std::uint32_t seed, double min_tilt_deg = 10.0,
                                                  double max_tilt_deg = 30.0) {
  std::mt19937 rng(seed);
  const Box stock{Eigen::Vector3d(-2, -2, 0) * mm, Eigen::Vector3d(2, 2, 5) * mm};  // holds the walls
  NBuffer zmap = NBuffer::zmap(stock, 0.075 * mm);
  const std::vector<Pose> path = random_turning_passes(rng, min_tilt_deg, max_tilt_deg);
  CutOptions options;
  options.orientation_tolerance_m = 0.5e-6;  // coarse: the errors are large enough to see
  const CutStatistics stats = zmap.cut(tool, path, options);

  // The reference: the whole tool, sub-steps at 1/20 of the tolerance.
  const double reference_tolerance_m = options.orientation_tolerance_m / 20.0;
  std::vector<detail::Sweep> sweeps;
  for (std::size_t i = 0; i + 1 < path.size(); ++i) {
    detail::split_segment(tool, path[i], path[i + 1], reference_tolerance_m, sweeps);
  }
  EXPECT_GT(sweeps.size(), 10 * stats.sub_segments);  // (far finer than the production)
  const double z0 = stock.min_W_m.z(), top = stock.max_W_m.z() - z0;
  std::vector<double> reference(static_cast<std::size_t>(zmap.nu()) * zmap.nv(), top);
  for (int j = 0; j < zmap.nv(); ++j) {
    for (int i = 0; i < zmap.nu(); ++i) {
      double& h = reference[static_cast<std::size_t>(i) + static_cast<std::size_t>(zmap.nu()) * j];
      const Eigen::Vector3d o = zmap.origin(i, j);
      for (const detail::Sweep& s : sweeps) {
        if (o.x() < s.lo.x() || o.x() > s.hi.x() || o.y() < s.lo.y() || o.y() > s.hi.y()) continue;
        double t0 = 0.0, t1 = 0.0;
        // (bull_interval with the line's length returns early where the entry is above it)
        const bool hit = s.r > 0.0 ? detail::bull_interval(s, o, Eigen::Vector3d::UnitZ(), h, t0, t1)
                                   : detail::line_interval(s, o, Eigen::Vector3d::UnitZ(), t0, t1);
        if (hit && t1 > 0.0 && t0 < h) h = std::max(0.0, t0);
      }
    }
  }
  auto ref = [&](int i, int j) { return reference[static_cast<std::size_t>(i) + static_cast<std::size_t>(zmap.nu()) * j]; };

  // Normal to the surface the distance is at most the two tolerances; along the line it is
  // that over the cosine of the surface's slope, taken from the reference's steeper one-sided
  // differences (lines on steep walls, where that estimate is poor, are left out).
  const double sp = zmap.spacing_m();
  const double bound_normal_m = options.orientation_tolerance_m + reference_tolerance_m;
  double worst_ratio = 0.0;
  int compared = 0, cut = 0;
  for (int j = 1; j + 1 < zmap.nv(); ++j) {
    for (int i = 1; i + 1 < zmap.nu(); ++i) {
      const double h = ref(i, j);
      const double gx = std::max(std::abs(ref(i + 1, j) - h), std::abs(h - ref(i - 1, j))) / sp;
      const double gy = std::max(std::abs(ref(i, j + 1) - h), std::abs(h - ref(i, j - 1))) / sp;
      cut += h < top;
      if (std::hypot(gx, gy) > 20.0) continue;
      const double bound = bound_normal_m * std::sqrt(1.0 + gx * gx + gy * gy) + 1e-11;
      worst_ratio = std::max(worst_ratio, std::abs(zmap.length(i, j) - h) / bound);
      ++compared;
    }
  }
  EXPECT_LE(worst_ratio, 1.0) << "seed " << seed;
  EXPECT_GT(cut, 300) << "seed " << seed;
  EXPECT_GT(compared, (zmap.nu() - 2) * (zmap.nv() - 2) * 3 / 4) << "seed " << seed;
  return stats;
}

TEST(NBufferFiveAxis, FlatEndWithinOrientationToleranceOfTheWholeTool) {
  // A long tool: most of it is above the material, where the Z-map's sweeps end.
  const Tool flat = make_tool(ToolType::flat, 1.6, 0, 10);
  for (std::uint32_t seed : {1u, 2u, 3u}) expect_within_orientation_tolerance(flat, seed);
}

TEST(NBufferFiveAxis, BullNoseWithinOrientationToleranceOfTheWholeTool) {
  const Tool bull = make_tool(ToolType::bull, 1.6, 0.3, 10);
  for (std::uint32_t seed : {4u, 5u}) expect_within_orientation_tolerance(bull, seed);
  // Small tilts: the sub-steps (along the tip's line) are chained across the turns.
  for (std::uint32_t seed : {6u, 7u}) {
    const CutStatistics stats = expect_within_orientation_tolerance(bull, seed, 6.0, 12.0);
    EXPECT_GT(stats.chained_turning, stats.sub_segments / 2) << "seed " << seed;
  }
}

}  // namespace
}  // namespace vmsim::removal
