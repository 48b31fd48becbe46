// make_walked_histogram (values walked twice, for a view's lines too many to hold) against
// make_histogram of the same values held: the same edges, counts and out-of-range counts, and
// the same errors.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "vmsim/common/errors.hpp"
#include "vmsim/viz/plot.hpp"

namespace vmsim::viz {
namespace {

ValueWalk walk_of(const std::vector<double>& values) {
  return [&values](const std::function<void(double)>& visit) {
    for (double v : values) visit(v);
  };
}

TEST(WalkedHistogram, SameAsTheHeldValues) {
  std::mt19937 random(11);
  for (int seed = 0; seed < 20; ++seed) {
    std::vector<double> values(static_cast<std::size_t>(1 + seed * 37));
    for (double& v : values) v = std::normal_distribution<double>(0.0, 3.0)(random);
    if (seed % 3 == 0) values.push_back(-0.0), values.push_back(0.0);
    for (const std::optional<Range>& range : {std::optional<Range>(), std::optional<Range>(Range{-1.0, 2.0})}) {
      const Histogram held = make_histogram(values, 1 + seed, range);
      const Histogram walked = make_walked_histogram(walk_of(values), 1 + seed, range);
      EXPECT_EQ(walked.edges, held.edges);
      EXPECT_EQ(walked.counts, held.counts);
      EXPECT_EQ(walked.below, held.below);
      EXPECT_EQ(walked.above, held.above);
    }
  }
  const std::vector<double> same{2.0, 2.0};
  EXPECT_EQ(make_walked_histogram(walk_of(same), 2).edges, (std::vector<double>{1.5, 2.0, 2.5}));
}

TEST(WalkedHistogram, SameErrors) {
  const std::vector<double> none, one{1.0}, with_nan{1.0, NAN};
  EXPECT_THROW(make_walked_histogram(walk_of(none), 3), InputError);
  EXPECT_THROW(make_walked_histogram(walk_of(one), 0), InputError);
  EXPECT_THROW(make_walked_histogram(walk_of(with_nan), 3), InputError);
  EXPECT_THROW(make_walked_histogram(walk_of(one), 3, Range{1.0, 1.0}), InputError);
}

}  // namespace
}  // namespace vmsim::viz
