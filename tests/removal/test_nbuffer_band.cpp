// Bands of an N-buffer (nbuffer.hpp, "Bands"): a buffer split into ranges of tile rows, each
// band cut on its own with the whole trajectory and the bands put back together, against the
// whole buffer cut at once. The removal is a min over the sweeps per line and each tile's cut
// depends on its own lines only, so the two must agree bit for bit: 3-axis ball and flat ends,
// a tilted bull-nose moving along x (the chains, whose tables span the band edges), turning
// 5-axis passes, two tools one after the other (the tile bounds exchanged between the cuts),
// compact storage and general lines.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <random>
#include <utility>
#include <vector>

#include "removal_test_tools.hpp"
#include "vmsim/removal/nbuffer.hpp"

namespace vmsim::removal {
namespace {

constexpr double mm = 1e-3;
using test::make_tool;

// Zigzag passes over a 12 x 8 mm stock 10 mm high, along x (the chains' case when level), up
// to 3 mm deep; the axis tilted by `tilt` [rad], turning by `turn` [rad] along each pass.
std::vector<Pose> passes(std::mt19937& rng, double tilt, double turn, bool level, int count = 9) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::vector<Pose> path;
  for (int pass = 0; pass < count; ++pass) {
    const double y = -3.7 + 0.83 * 9 / count * pass + 0.05 * unit(rng);
    for (int k = 0; k <= 24; ++k) {
      const double x = (pass % 2 == 0 ? -5.5 + 0.45 * k : 5.3 - 0.45 * k);
      const double z = level ? 7.6 - 0.1 * pass : 7.0 + 1.5 * std::sin(0.7 * x + unit(rng) * 0.05);
      const double angle = tilt + turn * k / 24.0;
      const Eigen::Vector3d axis(std::sin(angle), 0.3 * std::sin(angle), std::cos(angle));
      path.push_back({Eigen::Vector3d(x, y, z) * mm, axis.normalized()});
    }
  }
  return path;
}

// Tile rows [0, n) split into `parts` contiguous bands of unequal sizes.
std::vector<std::pair<int, int>> bands_of(int n, int parts) {
  std::vector<std::pair<int, int>> bands;
  int begin = 0;
  for (int p = 0; p < parts; ++p) {
    const int end = p + 1 == parts ? n : begin + std::max(1, (n - begin) / (parts - p) + (p % 2 == 0 ? 1 : -1));
    bands.emplace_back(begin, std::min(end, n - (parts - p - 1)));
    begin = bands.back().second;
  }
  return bands;
}

// Cuts `stretches` (tool, trajectory) one after the other into `uncut` whole, and into each band
// of it, the bands' tile bounds exchanged between stretches as the processes do; returns both.
std::pair<NBuffer, NBuffer> whole_and_banded(const NBuffer& uncut, const std::vector<std::pair<Tool, std::vector<Pose>>>& stretches,
                                             int parts) {
  NBuffer whole = uncut;
  for (const auto& [tool, path] : stretches) whole.cut(tool, path);
  std::vector<NBuffer> bands;
  for (const auto& [begin, end] : bands_of(uncut.tile_rows(), parts)) bands.push_back(uncut.band(begin, end));
  NBuffer gathered = uncut;
  for (std::size_t k = 0; k < stretches.size(); ++k) {
    for (NBuffer& band : bands) band.cut(stretches[k].first, stretches[k].second);
    for (const NBuffer& band : bands) {
      const auto [begin, end] = band.band_tile_rows();
      gathered.unpack_band(begin, end, band.pack_band());
    }
    const std::vector<double> bounds = gathered.pack_tile_bounds();
    for (NBuffer& band : bands) band.set_foreign_tile_bounds(bounds);
  }
  return {std::move(whole), std::move(gathered)};
}

void expect_bit_identical(const NBuffer& whole, const NBuffer& gathered) {
  const std::vector<double> a = whole.lengths(), b = gathered.lengths();
  ASSERT_EQ(a.size(), b.size());
  std::size_t differing = 0, cut = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    differing += std::memcmp(&a[i], &b[i], sizeof(double)) != 0 ? 1 : 0;
  }
  for (double h : a) cut += h < 10 * mm ? 1 : 0;
  EXPECT_EQ(differing, 0u);
  EXPECT_GT(cut, a.size() / 20) << "the test must cut a good part of the lines";
  EXPECT_EQ(whole.pack_tile_bounds(), gathered.pack_tile_bounds());
}

const Box kStock{Eigen::Vector3d(-6, -4, 0) * mm, Eigen::Vector3d(6, 4, 10) * mm};

TEST(NBufferBand, ThreeAxisBallAndFlatOnOddBands) {
  std::mt19937 rng(11);
  // 8 mm / 0.05 mm: 161 rows, 11 tile rows (the last one short), split in 3 and in 4.
  const NBuffer uncut = NBuffer::zmap(kStock, 0.05 * mm);
  ASSERT_EQ(uncut.tile_rows(), 11);
  for (int parts : {2, 3, 4}) {
    const auto [whole, gathered] =
        whole_and_banded(uncut,
                         {{make_tool(ToolType::ball, 3.0), passes(rng, 0.0, 0.0, false)},
                          {make_tool(ToolType::flat, 2.0), passes(rng, 0.0, 0.0, true)}},
                         parts);
    expect_bit_identical(whole, gathered);
  }
}

TEST(NBufferBand, TiltedBullChainsAndTurningPasses) {
  std::mt19937 rng(12);
  const NBuffer uncut = NBuffer::zmap(kStock, 0.04 * mm);
  const NBuffer coarse = NBuffer::zmap(kStock, 0.1 * mm);  // (the turning bull-nose is slow)
  for (int parts : {2, 3}) {
    // Level moves along x with a tilted bull-nose: the chains (section tables across rows).
    const auto [whole, gathered] = whole_and_banded(
        uncut, {{make_tool(ToolType::bull, 4.0, 1.0), passes(rng, 0.15, 0.0, true)}}, parts);
    expect_bit_identical(whole, gathered);
    // The axis turning along each pass: orientation sub-steps, sized by the material box.
    const auto [whole5, gathered5] =
        whole_and_banded(coarse,
                         {{make_tool(ToolType::flat, 3.0), passes(rng, 0.05, 0.2, false, 4)},
                          {make_tool(ToolType::bull, 4.0, 1.0), passes(rng, 0.1, -0.25, false, 3)}},
                         parts);
    expect_bit_identical(whole5, gathered5);
  }
}

// The first tool faces the whole top 1 mm down, so the material box's top drops by 1 mm in every
// band; the second turns its axis along its passes, and the box sizes its orientation sub-steps.
// Without the exchange of the tile bounds between the two cuts, a band would still see the other
// bands' tiles at the old top and cut the turning passes in other sub-steps.
TEST(NBufferBand, TileBoundsExchangedAfterAFacingGiveTheWholeMaterialBox) {
  std::mt19937 rng(15);
  const NBuffer uncut = NBuffer::zmap(kStock, 0.2 * mm);
  std::vector<Pose> facing;
  for (int pass = 0; pass <= 6; ++pass) {
    const double y = -4.5 + 1.5 * pass;
    for (double x : {-8.0, 8.0}) facing.push_back({Eigen::Vector3d(pass % 2 == 0 ? x : -x, y, 9.0) * mm, Eigen::Vector3d::UnitZ()});
  }
  for (int parts : {2, 3}) {
    const auto [whole, gathered] =
        whole_and_banded(uncut,
                         {{make_tool(ToolType::flat, 4.0), facing},
                          {make_tool(ToolType::flat, 3.0, 0.0, 8.0), passes(rng, 0.1, 0.3, false, 3)}},
                         parts);
    expect_bit_identical(whole, gathered);
  }
}

TEST(NBufferBand, CompactStorage) {
  std::mt19937 rng(13);
  NBuffer uncut = NBuffer::zmap(kStock, 0.05 * mm);
  uncut.make_compact();
  const auto [whole, gathered] = whole_and_banded(
      uncut,
      {{make_tool(ToolType::ball, 3.0), passes(rng, 0.0, 0.0, false)},
       {make_tool(ToolType::bull, 4.0, 1.0), passes(rng, 0.1, 0.0, true)}},
      3);
  ASSERT_TRUE(gathered.is_compact());
  expect_bit_identical(whole, gathered);
  EXPECT_EQ(whole.allocated_tiles(), gathered.allocated_tiles());
}

TEST(NBufferBand, GeneralLines) {
  std::mt19937 rng(14);
  const NBuffer uncut = test::general_lines_like(NBuffer::zmap(kStock, 0.1 * mm));
  const auto [whole, gathered] =
      whole_and_banded(uncut, {{make_tool(ToolType::ball, 3.0), passes(rng, 0.0, 0.0, false)}}, 3);
  expect_bit_identical(whole, gathered);
}

// A band sent in pieces of a few tile rows (pack_rows, as simulate-part gathers it) gives the
// band sent whole, plain and compact: the same lengths and bounds bit for bit.
TEST(NBufferBand, ABandPackedPieceByPieceIsTheBandPackedWhole) {
  for (bool compact : {false, true}) {
    std::mt19937 rng(15);
    NBuffer uncut = NBuffer::zmap(kStock, 0.05 * mm);
    if (compact) uncut.make_compact();
    NBuffer band = uncut.band(2, 9);
    band.cut(make_tool(ToolType::ball, 3.0), passes(rng, 0.0, 0.0, false));
    NBuffer at_once = uncut, in_pieces = uncut;
    at_once.unpack_band(2, 9, band.pack_band());
    for (const auto& [from, to] : {std::pair{2, 3}, std::pair{3, 5}, std::pair{5, 5}, std::pair{5, 9}}) {
      const std::vector<double> piece = band.pack_rows(from, to);
      if (from < to) in_pieces.unpack_band(from, to, piece);
      else EXPECT_TRUE(piece.empty());
    }
    const std::vector<double> a = at_once.lengths(), b = in_pieces.lengths();
    ASSERT_EQ(a.size(), b.size());
    EXPECT_EQ(std::memcmp(a.data(), b.data(), a.size() * sizeof(double)), 0) << "compact " << compact;
    EXPECT_EQ(at_once.pack_tile_bounds(), in_pieces.pack_tile_bounds());
    EXPECT_NE(a, uncut.lengths()) << "the band must have been cut";
    EXPECT_THROW(static_cast<void>(band.pack_rows(1, 4)), std::invalid_argument);
    EXPECT_THROW(static_cast<void>(band.pack_rows(8, 10)), std::invalid_argument);
  }
}

TEST(NBufferBand, ABandHoldsOnlyItsTiles) {
  const NBuffer uncut = NBuffer::zmap(kStock, 0.05 * mm);
  const NBuffer band = uncut.band(4, 7);
  EXPECT_FALSE(band.holds_all_tiles());
  EXPECT_EQ(band.band_tile_rows(), std::make_pair(4, 7));
  // 3 of 11 tile rows: 3/11 of the whole's bytes.
  EXPECT_EQ(band.length_bytes() * 11, uncut.length_bytes() * 3);
  EXPECT_THROW(static_cast<void>(uncut.band(5, 5)), std::invalid_argument);
  EXPECT_THROW(static_cast<void>(band.band(3, 6)), std::invalid_argument);
  EXPECT_THROW(static_cast<void>(difference(band, band)), std::invalid_argument);
  NBuffer whole = uncut;
  EXPECT_THROW(whole.unpack_band(4, 7, std::vector<double>(10, 0.0)), std::invalid_argument);
}

}  // namespace
}  // namespace vmsim::removal
