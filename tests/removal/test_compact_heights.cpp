// Compact heights (NBuffer::make_compact: a double base a tile, float offsets, tiles allocated
// only where a cut lowers a line) against the plain buffer (a double a line) cut with the same
// tools and trajectories: every line within the stated bound of the plain one, uncut lines
// exact, untouched tiles not allocated, the tile-by-tile difference equal to the plain one
// within twice the bound, and a cut never raising a stored length.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "removal_test_tools.hpp"
#include "vmsim/common/errors.hpp"
#include "vmsim/removal/nbuffer.hpp"

namespace vmsim::removal {
namespace {

constexpr double mm = 1e-3;
using test::make_tool;

// Random passes over part of a 12 x 8 mm stock 10 mm high, up to 3 mm deep, with the axis
// tilted up to `max_tilt` (0: 3-axis).
std::vector<Pose> random_passes(std::mt19937& rng, double max_tilt) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::vector<Pose> path;
  const double tilt = max_tilt * unit(rng), phase = 6.283 * unit(rng);
  const Eigen::Vector3d axis(std::sin(tilt) * std::cos(phase), std::sin(tilt) * std::sin(phase), std::cos(tilt));
  for (int pass = 0; pass < 6; ++pass) {
    const double y = -3.0 + 0.4 * pass + 0.1 * unit(rng);
    for (int k = 0; k <= 30; ++k) {
      const double x = -5.0 + 0.2 * k;  // left half of the stock only (x up to 1 mm)
      const double z = 7.0 + 1.5 * std::sin(0.7 * x + unit(rng) * 0.05) + 0.2 * unit(rng);
      path.push_back({Eigen::Vector3d(x, y, z) * mm, axis});
    }
  }
  return path;
}

void expect_within_bound(const NBuffer& compact, const NBuffer& plain, const NBuffer& uncut) {
  ASSERT_TRUE(compact.same_lines(plain));
  std::size_t exact = 0, lowered = 0;
  for (int j = 0; j < plain.nv(); ++j) {
    for (int i = 0; i < plain.nu(); ++i) {
      const double h = plain.length(i, j), c = compact.length(i, j), top = uncut.length(i, j);
      if (h == top) {
        EXPECT_EQ(c, top) << "uncut line " << i << ", " << j;  // exact where not cut
        ++exact;
        continue;
      }
      ++lowered;
      // The depth below the tile's base is at most the depth below the stock's top.
      ASSERT_LE(std::abs(c - h), NBuffer::compact_bound_m(top - h)) << "line " << i << ", " << j;
    }
  }
  EXPECT_GT(lowered, 1000u);
  EXPECT_GT(exact, 1000u);
}

class CompactHeights : public ::testing::TestWithParam<int> {};

TEST_P(CompactHeights, EqualPlainWithinTheBound) {
  std::mt19937 rng(1234u + static_cast<unsigned>(GetParam()));
  const Box stock{Eigen::Vector3d(-6, -4, 0) * mm, Eigen::Vector3d(6, 4, 10) * mm};
  const NBuffer uncut = NBuffer::zmap(stock, 0.03 * mm);
  const std::vector<Tool> tools = {make_tool(ToolType::ball, 2, 1), make_tool(ToolType::flat, 2),
                                   make_tool(ToolType::bull, 3, 0.5)};
  const Tool& tool = tools[static_cast<std::size_t>(GetParam()) % tools.size()];
  const double max_tilt = GetParam() >= 3 ? 0.2 : 0.0;
  NBuffer plain = uncut, compact = uncut;
  compact.make_compact();
  EXPECT_TRUE(compact.is_compact());
  EXPECT_EQ(compact.allocated_tiles(), 0u);  // the stock box: every line at its tile's base
  // Two trajectories one after the other (the second cuts lines the first already lowered).
  for (int run = 0; run < 2; ++run) {
    const std::vector<Pose> path = random_passes(rng, max_tilt);
    plain.cut(tool, path);
    compact.cut(tool, path);
  }
  expect_within_bound(compact, plain, uncut);
  // Tiles only where a cut lowered a line: the right part of the stock (x > 1 mm plus the
  // tool's radius) is never reached.
  std::size_t touched = 0;
  const int k = NBuffer::kTile;
  for (int tv = 0; tv * k < plain.nv(); ++tv) {
    for (int tu = 0; tu * k < plain.nu(); ++tu) {
      bool lowered = false;
      for (int j = tv * k; j < std::min(plain.nv(), (tv + 1) * k); ++j) {
        for (int i = tu * k; i < std::min(plain.nu(), (tu + 1) * k); ++i) lowered |= plain.length(i, j) < uncut.length(i, j);
      }
      touched += lowered ? 1 : 0;
    }
  }
  EXPECT_EQ(compact.allocated_tiles(), touched);
  EXPECT_LT(compact.allocated_tiles(), compact.tile_count() * 3 / 4);
  EXPECT_LT(compact.length_bytes(), plain.length_bytes() * 3 / 8);
  // The difference of two compact buffers against that of the plain ones.
  NBuffer plain2 = uncut, compact2 = uncut;
  compact2.make_compact();
  const std::vector<Pose> other = random_passes(rng, max_tilt);
  plain2.cut(tool, other);
  compact2.cut(tool, other);
  const std::vector<double> d_plain = difference(plain, plain2), d_compact = difference(compact, compact2);
  const std::vector<double> d_mixed = difference(compact, plain2);
  ASSERT_EQ(d_plain.size(), d_compact.size());
  for (std::size_t line = 0; line < d_plain.size(); ++line) {
    const int i = static_cast<int>(line % static_cast<std::size_t>(plain.nu()));
    const int j = static_cast<int>(line / static_cast<std::size_t>(plain.nu()));
    const double bound = NBuffer::compact_bound_m(uncut.length(i, j) - std::min(plain.length(i, j), plain2.length(i, j)));
    ASSERT_LE(std::abs(d_compact[line] - d_plain[line]), 2 * bound) << line;
    ASSERT_LE(std::abs(d_mixed[line] - d_plain[line]), bound) << line;
    // Row-major, as plain lengths are.
    ASSERT_EQ(d_plain[line], plain.length(i, j) - plain2.length(i, j));
  }
}

INSTANTIATE_TEST_SUITE_P(Tools, CompactHeights, ::testing::Range(0, 6));

TEST(CompactHeights, CutNeverRaisesAStoredLength) {
  // A cut that passes again just above what is stored (within the rounding) must leave every
  // line as it was or lower: the offsets only go down.
  const Box stock{Eigen::Vector3d(-3, -3, 0) * mm, Eigen::Vector3d(3, 3, 30) * mm};
  NBuffer compact = NBuffer::zmap(stock, 0.05 * mm);
  compact.make_compact();
  const Tool ball = make_tool(ToolType::ball, 2, 1);
  std::vector<Pose> path;
  for (int k = 0; k <= 20; ++k) path.push_back({Eigen::Vector3d(-2.0 + 0.2 * k, 0.1, 1.2345678) * mm, Eigen::Vector3d::UnitZ()});
  compact.cut(ball, path);
  std::vector<double> before = compact.lengths();
  for (int again = 0; again < 3; ++again) {
    for (Pose& pose : path) pose.tip_W_m.z() += 1e-12;  // a hair above: cuts nothing exactly
    compact.cut(ball, path);
    const std::vector<double> after = compact.lengths();
    for (std::size_t line = 0; line < after.size(); ++line) ASSERT_LE(after[line], before[line]) << line;
    before = after;
  }
}

TEST(CompactHeights, MeshLikeStockKeepsItsLinesWithinTheBound) {
  // A plain buffer with lines of many lengths (cut once) made compact afterwards: each line
  // within the bound of its depth below its tile's largest line, the largest exact.
  const Box stock{Eigen::Vector3d(-2, -2, 0) * mm, Eigen::Vector3d(2, 2, 20) * mm};
  NBuffer plain = NBuffer::zmap(stock, 0.02 * mm);
  std::vector<Pose> ramp;
  for (int k = 0; k <= 40; ++k) ramp.push_back({Eigen::Vector3d(-2.5 + 0.125 * k, 0.0, 5.0 + 0.3 * k) * mm, Eigen::Vector3d::UnitZ()});
  plain.cut(make_tool(ToolType::ball, 6, 3), ramp);
  NBuffer compact = plain;
  compact.make_compact();
  double largest = 0.0;
  for (int j = 0; j < plain.nv(); ++j) {
    for (int i = 0; i < plain.nu(); ++i) {
      largest = std::max(largest, std::abs(compact.length(i, j) - plain.length(i, j)));
      ASSERT_LE(std::abs(compact.length(i, j) - plain.length(i, j)), NBuffer::compact_bound_m(20 * mm));
    }
  }
  EXPECT_GT(largest, 0.0);  // floats do round: the bound is not vacuous
}

// A box's Z-map made compact at once (no plain buffer on the way) is make_compact()'s buffer:
// the same lengths, tiles, bounds and bytes, and the same lengths bit for bit after the same cuts.
TEST(CompactHeights, CompactZmapIsTheMadeCompactZmap) {
  std::mt19937 rng(77u);
  // 12.01 x 8.03 mm at 0.03 mm: partial tiles on both far edges.
  const Box stock{Eigen::Vector3d(-6, -4, 0.5) * mm, Eigen::Vector3d(6.01, 4.03, 10) * mm};
  NBuffer made = NBuffer::zmap(stock, 0.03 * mm);
  made.make_compact();
  NBuffer direct = NBuffer::compact_zmap(stock, 0.03 * mm);
  ASSERT_TRUE(direct.is_compact());
  ASSERT_TRUE(direct.same_lines(made));
  EXPECT_NE(direct.nu() % NBuffer::kTile, 0);
  EXPECT_NE(direct.nv() % NBuffer::kTile, 0);
  EXPECT_EQ(direct.allocated_tiles(), 0u);
  EXPECT_EQ(direct.length_bytes(), made.length_bytes());
  EXPECT_EQ(direct.pack_tile_bounds(), made.pack_tile_bounds());
  EXPECT_EQ(direct.lengths(), made.lengths());
  const Tool tool = make_tool(ToolType::bull, 3, 0.5);
  for (int run = 0; run < 2; ++run) {
    const std::vector<Pose> path = random_passes(rng, 0.2);
    made.cut(tool, path);
    direct.cut(tool, path);
  }
  EXPECT_GT(direct.allocated_tiles(), 0u);
  EXPECT_EQ(direct.allocated_tiles(), made.allocated_tiles());
  EXPECT_EQ(direct.lengths(), made.lengths());
  EXPECT_EQ(direct.pack_tile_bounds(), made.pack_tile_bounds());
  // The grid's checks are zmap()'s.
  EXPECT_THROW(NBuffer::compact_zmap(stock, 0.0), InputError);
  EXPECT_THROW(NBuffer::compact_zmap(Box{stock.max_W_m, stock.min_W_m}, 0.03 * mm), InputError);
}

// A grid beyond 2^31 - 1 lines (int line indices) is refused with the finest spacing that fits,
// which does fit (and 0.1 um less does not): a 500 x 500 mm die at 10 um.
TEST(CompactHeights, TooManyLinesNamesTheFinestSpacingThatFits) {
  const Box die{Eigen::Vector3d(-250, -250, 0) * mm, Eigen::Vector3d(250, 250, 40) * mm};
  std::string message;
  try {
    NBuffer::compact_zmap(die, 0.01 * mm);
  } catch (const InputError& error) {
    message = error.what();
  }
  ASSERT_NE(message.find("2500100001 lines over the 500 x 500 mm stock"), std::string::npos) << message;
  const std::size_t at = message.find("a spacing of ");
  ASSERT_NE(at, std::string::npos) << message;
  const double finest_um = std::stod(message.substr(at + 13));
  const auto lines = [](double spacing_um) {
    const double n = std::floor(500.0 / (spacing_um * 1e-3) * (1.0 + 1e-12)) + 1.0;
    return n * n;
  };
  EXPECT_LE(lines(finest_um), 2147483647.0) << message;
  EXPECT_GT(lines(finest_um - 0.1), 2147483647.0) << message;
}

}  // namespace
}  // namespace vmsim::removal
