// Marks from a run-versus-run comparison: planted trajectory deviations found with their depth,
// area and place; a run compared with itself has no mark.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>

#include "vmsim/removal/marks.hpp"
#include "vmsim/removal/nbuffer.hpp"

namespace vmsim::removal {
namespace {

Tool ball(double diameter_m) {
  Tool tool;
  tool.type = ToolType::ball;
  tool.diameter_m = diameter_m;
  tool.corner_radius_m = diameter_m / 2;
  tool.length_m = 0.03;
  return tool;
}

// Parallel passes along x over a 10 x 6 mm stock; `dip(x, y)` lowers the trajectory [m].
NBuffer machine(double grid_m, const std::function<double(double, double)>& dip) {
  Box stock{{0.0, 0.0, 0.0}, {0.010, 0.006, 0.005}};
  NBuffer buffer = NBuffer::zmap(stock, grid_m);
  std::vector<Pose> poses;
  for (double y = 0.0; y <= 0.006 + 1e-12; y += 0.0005) {
    for (double x = -0.004; x <= 0.014 + 1e-12; x += 0.0001) {
      poses.push_back({{x, y, 0.004 - dip(x, y)}, {0.0, 0.0, 1.0}});
    }
    poses.push_back({{0.014, y, 0.02}, {0.0, 0.0, 1.0}});   // retract
    poses.push_back({{-0.004, y + 0.0005, 0.02}, {0.0, 0.0, 1.0}});
  }
  buffer.cut(ball(0.006), poses);
  return buffer;
}

TEST(Marks, ARunComparedWithItselfHasNoMark) {
  const NBuffer run = machine(50e-6, [](double, double) { return 0.0; });
  const MarkMap map = find_marks(run, difference(run, run));
  EXPECT_TRUE(map.marks.empty());
  for (int label : map.label) EXPECT_EQ(label, -1);
}

TEST(Marks, APlantedDipIsFoundWithItsDepthAndPlace) {
  const NBuffer reference = machine(50e-6, [](double, double) { return 0.0; });
  // 20 um deeper over x in [4, 6] mm on the pass at y = 3 mm.
  const NBuffer production = machine(50e-6, [](double x, double y) {
    return (std::abs(y - 0.003) < 1e-9 && x >= 0.004 && x <= 0.006) ? 20e-6 : 0.0;
  });
  const MarkMap map = find_marks(production, difference(production, reference));
  ASSERT_GE(map.marks.size(), 1u);
  const Mark& mark = map.marks.front();
  EXPECT_EQ(mark.kind, MarkKind::gouge);
  EXPECT_NEAR(mark.depth_m, 20e-6, 0.5e-6);
  EXPECT_NEAR(mark.deepest_point_W_m.y(), 0.003, 0.5e-3);
  EXPECT_GT(mark.deepest_point_W_m.x(), 0.0035);
  EXPECT_LT(mark.deepest_point_W_m.x(), 0.0065);
  EXPECT_NEAR(mark.centroid_W_m.x(), 0.005, 0.5e-3);
  // The region is at least as long as the dip along x, and a closed-form bound on its width:
  // a ball of radius R lowered by d cuts a trough of half-width sqrt(2 R d) at most.
  const double length_m = (mark.iu_max - mark.iu_min) * 50e-6;
  EXPECT_GE(length_m, 0.002 - 1e-9);
  const double width_m = (mark.iv_max - mark.iv_min) * 50e-6;
  EXPECT_LE(width_m, 2 * std::sqrt(2 * 0.003 * 20e-6) + 2 * 50e-6 + 0.0005);
  // Labels mark exactly the region's lines.
  std::size_t labelled = 0;
  for (int label : map.label) labelled += label == 0 ? 1 : 0;
  EXPECT_EQ(labelled, mark.line_count);
  EXPECT_NEAR(mark.area_m2, static_cast<double>(mark.line_count) * 50e-6 * 50e-6, 1e-18);
}

TEST(Marks, ExcessAndGougeAreSeparateAndSortedByDepth) {
  const NBuffer reference = machine(100e-6, [](double, double) { return 0.0; });
  const NBuffer production = machine(100e-6, [](double x, double y) {
    if (std::abs(y - 0.001) < 1e-9 && x >= 0.002 && x <= 0.004) return 10e-6;   // deeper
    if (std::abs(y - 0.005) < 1e-9 && x >= 0.006 && x <= 0.008) return -30e-6;  // left higher
    return 0.0;
  });
  const MarkMap map = find_marks(production, difference(production, reference));
  ASSERT_EQ(map.marks.size(), 2u);
  EXPECT_EQ(map.marks[0].kind, MarkKind::excess);
  EXPECT_EQ(map.marks[1].kind, MarkKind::gouge);
  EXPECT_GT(map.marks[0].depth_m, map.marks[1].depth_m);
  EXPECT_NEAR(map.marks[1].depth_m, 10e-6, 0.5e-6);
  // A threshold above the gouge keeps only the excess.
  MarkOptions strict;
  strict.threshold_m = 15e-6;
  EXPECT_EQ(find_marks(production, difference(production, reference), strict).marks.size(), 1u);
}

TEST(Marks, SizeMismatchIsAnError) {
  const NBuffer run = machine(200e-6, [](double, double) { return 0.0; });
  EXPECT_THROW(find_marks(run, std::vector<double>(3, 0.0)), std::invalid_argument);
}

}  // namespace
}  // namespace vmsim::removal
