// The split of a view's tile rows into the ranks' bands (mpi_ranks.hpp, split_rows): hand-worked
// cases, and on random weights the laws of a greedy split (contiguous, every row in one band,
// no band empty, none heavier than its share plus one row), and the single-process Ranks.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <utility>
#include <vector>

#include "mpi_ranks.hpp"
#include "vmsim/common/errors.hpp"

namespace vmsim::app {
namespace {

using Bands = std::vector<std::pair<int, int>>;

TEST(SplitRows, HandWorkedCases) {
  // 10 equal rows in 3: the first band ends where the running sum reaches 10/3 (4 rows), the
  // second where it reaches 20/3 (7 rows).
  EXPECT_EQ(split_rows(std::vector<double>(10, 1.0), 3), (Bands{{0, 4}, {4, 7}, {7, 10}}));
  // A heavy row: 15 in all, half is 7.5, reached at row 3 (1 + 1 + 1 + 10).
  EXPECT_EQ(split_rows({1, 1, 1, 10, 1, 1}, 2), (Bands{{0, 4}, {4, 6}}));
  // All the work in row 0: every band still gets a row.
  EXPECT_EQ(split_rows({100, 0, 0, 0}, 3), (Bands{{0, 1}, {1, 2}, {2, 4}}));
  // No weight at all: by rows (the row count reaches 5 / 2, in integers 2, after row 1).
  EXPECT_EQ(split_rows({0, 0, 0, 0, 0}, 2), (Bands{{0, 2}, {2, 5}}));
  EXPECT_EQ(split_rows({3, 4}, 1), (Bands{{0, 2}}));
  EXPECT_EQ(split_rows({3, 4}, 2), (Bands{{0, 1}, {1, 2}}));
  EXPECT_THROW(split_rows({1, 1}, 3), InputError);
  EXPECT_THROW(split_rows({1, -1, 1}, 2), std::invalid_argument);
}

TEST(SplitRows, RandomWeightsObeyTheGreedyLaws) {
  std::mt19937 rng(21);
  for (int trial = 0; trial < 500; ++trial) {
    const int rows = 1 + static_cast<int>(rng() % 40);
    const int parts = 1 + static_cast<int>(rng() % static_cast<unsigned>(rows));
    std::vector<double> weights(static_cast<std::size_t>(rows));
    for (double& w : weights) w = (rng() % 4 == 0) ? 0.0 : std::uniform_real_distribution<double>(0.0, 5.0)(rng);
    const Bands bands = split_rows(weights, parts);
    ASSERT_EQ(static_cast<int>(bands.size()), parts) << trial;
    double total = 0.0, heaviest_row = 0.0;
    for (double w : weights) total += w, heaviest_row = std::max(heaviest_row, w);
    int expected_begin = 0;
    for (const auto& [begin, end] : bands) {
      EXPECT_EQ(begin, expected_begin) << trial;
      EXPECT_LT(begin, end) << trial;
      double sum = 0.0;
      for (int row = begin; row < end; ++row) sum += weights[static_cast<std::size_t>(row)];
      // A band starts where the bands before reached their shares (k T / parts) and ends at the
      // first row where the running sum reaches its own, or earlier where the rows left are just
      // enough (then every later band is one row): never heavier than T / parts plus one row.
      EXPECT_LE(sum, total / parts + heaviest_row + 1e-9) << trial;
      expected_begin = end;
    }
    EXPECT_EQ(expected_begin, rows) << trial;
  }
}

TEST(Ranks, OneProcessWithoutLauncher) {
  const Ranks& ranks = Ranks::world();
  EXPECT_EQ(ranks.size(), 1);
  EXPECT_TRUE(ranks.root());
  EXPECT_FALSE(ranks.distributed());
  EXPECT_EQ(ranks.sum(7), 7u);
  std::vector<double> values{1.5, 2.5};
  ranks.broadcast(values);
  EXPECT_EQ(values, (std::vector<double>{1.5, 2.5}));
  int calls = 0;
  ranks.gather_to_root(values, [&](int rank, std::vector<double>&& got) {
    EXPECT_EQ(rank, 0);
    EXPECT_EQ(got, values);
    ++calls;
  });
  EXPECT_EQ(calls, 1);
}

}  // namespace
}  // namespace vmsim::app
