// ViewDeviation (the deviation of a line computed on demand from its own and its neighbours'
// lengths) against the whole-view computation simulate-part made before issue 21:
// removal::difference, then exclude_steep_lines with each run. Same values bit for bit, by
// line (at) and by rows (DeviationRows, in order and not), same steep lines.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "surface_views.hpp"
#include "view_deviation.hpp"
#include "vmsim/removal/nbuffer.hpp"

namespace vmsim::app {
namespace {

// General lines with lengths on a few levels (steps of up to 2 mm between neighbours: steep at
// a 0.1 mm spacing) and small noise.
removal::NBuffer stepped_lines(int nu, int nv, std::mt19937& random) {
  std::uniform_real_distribution<double> noise_m(0.0, 2e-5);
  std::uniform_int_distribution<int> level(0, 3);
  std::vector<Eigen::Vector3d> origins, directions;
  std::vector<double> lengths;
  for (int iv = 0; iv < nv; ++iv) {
    for (int iu = 0; iu < nu; ++iu) {
      origins.emplace_back(1e-4 * iu, 1e-4 * iv, 0.0);
      directions.emplace_back(0.0, 0.0, 1.0);
      lengths.push_back(0.003 + (level(random) == 0 ? 2e-3 : 0.0) + noise_m(random));
    }
  }
  return removal::NBuffer::lines(nu, nv, origins, directions, lengths);
}

std::vector<double> dense_deviation(const removal::NBuffer& a, const removal::NBuffer& b, double spacing_m,
                                    std::size_t& steep_lines) {
  std::vector<double> deviation = removal::difference(a, b);
  std::vector<double> assessed(deviation.size(), 1.0);
  exclude_steep_lines(b, spacing_m, assessed);
  exclude_steep_lines(a, spacing_m, assessed);
  steep_lines = 0;
  for (std::size_t line = 0; line < assessed.size(); ++line) {
    if (assessed[line] != 0.0) continue;
    deviation[line] = 0.0;
    ++steep_lines;
  }
  return deviation;
}

TEST(ViewDeviation, SameAsTheWholeViewComputation) {
  std::mt19937 random(7);
  std::uniform_int_distribution<int> size(1, 40);
  for (int seed = 0; seed < 30; ++seed) {
    const int nu = size(random), nv = size(random);
    const removal::NBuffer a = stepped_lines(nu, nv, random), b = stepped_lines(nu, nv, random);
    const double spacing_m = 1e-4;
    std::size_t expected_steep = 0;
    const std::vector<double> expected = dense_deviation(a, b, spacing_m, expected_steep);
    const ViewDeviation deviation(a, b, spacing_m);
    DeviationRows rows(deviation);
    std::size_t steep = 0;
    for (int iv = 0; iv < nv; ++iv) {
      const std::span<const double> row = rows.row(iv);
      for (int iu = 0; iu < nu; ++iu) {
        const double want = expected[static_cast<std::size_t>(iu + nu * iv)];
        ASSERT_EQ(row[static_cast<std::size_t>(iu)], want) << "seed " << seed << " line " << iu << ", " << iv;
        ASSERT_EQ(deviation.at(iu, iv), want) << "seed " << seed << " line " << iu << ", " << iv;
        steep += rows.steep_row()[static_cast<std::size_t>(iu)];
        EXPECT_EQ(deviation.steep(iu, iv), rows.steep_row()[static_cast<std::size_t>(iu)] != 0);
      }
    }
    EXPECT_EQ(steep, expected_steep) << "seed " << seed;
    // Rows out of order give the same.
    DeviationRows jumping(deviation);
    for (int k = 0; k < 10; ++k) {
      const int iv = std::uniform_int_distribution<int>(0, nv - 1)(random);
      const std::span<const double> row = jumping.row(iv);
      for (int iu = 0; iu < nu; ++iu) ASSERT_EQ(row[static_cast<std::size_t>(iu)], expected[static_cast<std::size_t>(iu + nu * iv)]);
    }
  }
}

TEST(ViewDeviation, StepsAreSteepInEitherRun) {
  // 4 x 3 lines 0.1 mm apart: a 1 mm step between columns 1 and 2 in run a only.
  std::vector<Eigen::Vector3d> origins, directions(12, Eigen::Vector3d::UnitZ());
  std::vector<double> a_lengths, b_lengths;
  for (int iv = 0; iv < 3; ++iv) {
    for (int iu = 0; iu < 4; ++iu) {
      origins.emplace_back(1e-4 * iu, 1e-4 * iv, 0.0);
      a_lengths.push_back(iu >= 2 ? 0.004 : 0.003);
      b_lengths.push_back(0.003 - 1e-5);
    }
  }
  const removal::NBuffer a = removal::NBuffer::lines(4, 3, origins, directions, a_lengths);
  const removal::NBuffer b = removal::NBuffer::lines(4, 3, origins, directions, b_lengths);
  const ViewDeviation ab(a, b, 1e-4), ba(b, a, 1e-4);
  for (int iv = 0; iv < 3; ++iv) {
    EXPECT_NEAR(ab.at(0, iv), 1e-5, 1e-15);
    EXPECT_EQ(ab.at(1, iv), 0.0);  // steep: beside the step
    EXPECT_EQ(ab.at(2, iv), 0.0);
    EXPECT_NEAR(ab.at(3, iv), 1e-3 + 1e-5, 1e-15);
    EXPECT_EQ(ba.at(1, iv), 0.0);  // steep in a, the second run here
  }
}

TEST(ViewDeviation, ANanDifferenceReadsAsInfinityWhenAsked) {
  std::vector<Eigen::Vector3d> origins{{0, 0, 0}, {1e-4, 0, 0}}, directions(2, Eigen::Vector3d::UnitZ());
  const removal::NBuffer a = removal::NBuffer::lines(2, 1, origins, directions, {0.003, 0.003});
  const removal::NBuffer b = removal::NBuffer::lines(2, 1, origins, directions, {0.003, 0.003});
  EXPECT_EQ(ViewDeviation(a, b, 1e-4, true).at(0, 0), 0.0);
  // inf - inf is NaN: infinite lengths on both runs.
  const double inf = std::numeric_limits<double>::infinity();
  const removal::NBuffer c = removal::NBuffer::lines(2, 1, origins, directions, {inf, inf});
  EXPECT_TRUE(std::isnan(ViewDeviation(c, c, 1e-4).at(0, 0)));
  EXPECT_EQ(ViewDeviation(c, c, 1e-4, true).at(0, 0), inf);
}

TEST(ViewDeviation, AWindowOfTheHeightFieldIsTheWholeFieldCropped) {
  std::mt19937 random(3);
  const removal::NBuffer a = stepped_lines(23, 19, random), b = stepped_lines(23, 19, random);
  SurfaceView view;
  view.zmap = false;
  view.spacing_m = 1e-4;
  const ViewDeviation deviation(a, b, view.spacing_m);
  const viz::HeightField whole = view_height_field(view, a, &deviation, 1);
  const LineWindow window{3, 17, 5, 11};
  const viz::HeightField crop = view_height_field_window(view, a, deviation, window);
  ASSERT_EQ(crop.nx, 15);
  ASSERT_EQ(crop.ny, 7);
  EXPECT_DOUBLE_EQ(crop.origin_x_m, whole.origin_x_m + 3 * view.spacing_m);
  EXPECT_DOUBLE_EQ(crop.origin_y_m, whole.origin_y_m + 5 * view.spacing_m);
  for (int j = 0; j < crop.ny; ++j) {
    for (int i = 0; i < crop.nx; ++i) {
      EXPECT_EQ(crop.height_m[crop.index(i, j)], whole.height_m[whole.index(i + 3, j + 5)]);
      EXPECT_EQ(crop.deviation_m[crop.index(i, j)], whole.deviation_m[whole.index(i + 3, j + 5)]);
    }
  }
}

// A close-up of a window too large for a render (a mark along a whole die) is drawn from every
// stride-th line: the strided window holds the whole field's nodes at those lines, and the
// stride keeps it within the node budget.
TEST(ViewDeviation, AStridedWindowHoldsEveryStrideThLineOfTheWholeField) {
  std::mt19937 random(11);
  const removal::NBuffer a = stepped_lines(40, 30, random);
  const removal::NBuffer b = stepped_lines(40, 30, random);
  SurfaceView view;
  view.zmap = false;
  view.spacing_m = 1e-3;
  const ViewDeviation deviation(a, b, view.spacing_m);
  const viz::HeightField whole = view_height_field(view, a, &deviation, 1);
  const LineWindow window{3, 38, 2, 27};  // 36 x 26 lines
  EXPECT_EQ(close_up_stride(window, 36.0 * 26.0), 1);
  EXPECT_EQ(close_up_stride(window, 36.0 * 26.0 - 1), 2);
  const int stride = close_up_stride(window, 100.0);  // sqrt(936 / 100) -> 4
  ASSERT_EQ(stride, 4);
  const viz::HeightField crop = view_height_field_window(view, a, deviation, window, stride);
  ASSERT_EQ(crop.nx, 9);  // lines 3, 7, ..., 35
  ASSERT_EQ(crop.ny, 7);  // lines 2, 6, ..., 26
  EXPECT_LE(crop.nx * crop.ny, 100);
  EXPECT_DOUBLE_EQ(crop.spacing_x_m, 4 * view.spacing_m);
  EXPECT_DOUBLE_EQ(crop.origin_x_m, whole.origin_x_m + 3 * view.spacing_m);
  for (int j = 0; j < crop.ny; ++j) {
    for (int i = 0; i < crop.nx; ++i) {
      EXPECT_EQ(crop.height_m[crop.index(i, j)], whole.height_m[whole.index(3 + 4 * i, 2 + 4 * j)]);
      EXPECT_EQ(crop.deviation_m[crop.index(i, j)], whole.deviation_m[whole.index(3 + 4 * i, 2 + 4 * j)]);
    }
  }
}

}  // namespace
}  // namespace vmsim::app
