#include "banded_removal.hpp"

#include <algorithm>
#include <cmath>

namespace vmsim::app {

std::vector<double> zmap_row_weights(const removal::NBuffer& zmap, const std::vector<Eigen::Vector3d>& cutting_tips_W_m,
                                     double reach_m) {
  const int rows = zmap.tile_rows();
  std::vector<double> weights(static_cast<std::size_t>(rows), 0.0);
  const double row_height = removal::NBuffer::kTile * zmap.spacing_m();
  const double y0 = zmap.zmap_origin_m().y() - 0.5 * zmap.spacing_m();  // a tile row's lines lie within its height
  for (std::size_t k = 1; k < cutting_tips_W_m.size(); ++k) {
    const Eigen::Vector3d& a = cutting_tips_W_m[k - 1];
    const Eigen::Vector3d& b = cutting_tips_W_m[k];
    const double length = (b - a).head<2>().norm();
    if (!(length > 0.0)) continue;
    const double lo = std::min(a.y(), b.y()) - reach_m, hi = std::max(a.y(), b.y()) + reach_m;
    const int first = std::clamp(static_cast<int>(std::floor((lo - y0) / row_height)), 0, rows - 1);
    const int last = std::clamp(static_cast<int>(std::floor((hi - y0) / row_height)), 0, rows - 1);
    for (int row = first; row <= last; ++row) weights[static_cast<std::size_t>(row)] += length / (last - first + 1);
  }
  double total = 0.0;
  for (double w : weights) total += w;
  const double floor = total > 0.0 ? total / rows / 20.0 : 1.0;
  for (double& w : weights) w += floor;
  return weights;
}

ViewBands view_bands(const removal::NBuffer& buffer, const Ranks& ranks, const std::vector<double>& weights) {
  ViewBands bands;
  bands.per_rank = split_rows(weights.empty() ? std::vector<double>(static_cast<std::size_t>(buffer.tile_rows()), 1.0)
                                              : weights,
                              ranks.size());
  return bands;
}

removal::NBuffer rank_share(const removal::NBuffer& uncut, const ViewBands& bands, const Ranks& ranks) {
  if (!ranks.distributed()) return uncut;
  const auto [begin, end] = bands.per_rank[static_cast<std::size_t>(ranks.rank())];
  return uncut.band(begin, end);
}

removal::NBuffer gather_bands(removal::NBuffer&& mine, const removal::NBuffer& uncut_whole, const ViewBands& bands,
                              const Ranks& ranks, std::size_t piece_lines) {
  if (!ranks.distributed()) return std::move(mine);
  // In rounds of a few tile rows from every rank: a band packed whole is 8 B a line (3.2 GB for
  // a quarter of the 80 x 500 mm die at 5 um, on the sender and again on rank 0), a round's
  // piece about piece_lines x 8 B.
  const std::size_t row_lines = static_cast<std::size_t>(mine.tile_count() / static_cast<std::size_t>(mine.tile_rows())) *
                                removal::NBuffer::kTile * removal::NBuffer::kTile;
  const int rows_per_round = static_cast<int>(std::max<std::size_t>(1, piece_lines / row_lines));
  int rounds = 0;
  for (const auto& [begin, end] : bands.per_rank) rounds = std::max(rounds, (end - begin + rows_per_round - 1) / rows_per_round);
  removal::NBuffer whole;
  if (ranks.root()) whole = uncut_whole;
  const auto [my_begin, my_end] = bands.per_rank[static_cast<std::size_t>(ranks.rank())];
  for (int round = 0; round < rounds; ++round) {
    const int from = std::min(my_end, my_begin + round * rows_per_round);
    const int to = std::min(my_end, from + rows_per_round);
    ranks.gather_to_root(mine.pack_rows(from, to), [&](int rank, std::vector<double>&& packed) {
      const auto [begin, end] = bands.per_rank[static_cast<std::size_t>(rank)];
      const int rank_from = std::min(end, begin + round * rows_per_round);
      const int rank_to = std::min(end, rank_from + rows_per_round);
      if (rank_from < rank_to) whole.unpack_band(rank_from, rank_to, packed);
    });
  }
  return ranks.root() ? whole : std::move(mine);
}

void exchange_tile_bounds(removal::NBuffer& mine, const ViewBands& bands, const Ranks& ranks) {
  if (!ranks.distributed()) return;
  constexpr std::size_t kPerTile = 7;  // NBuffer::pack_tile_bounds
  const std::size_t tiles_per_row = mine.tile_count() / static_cast<std::size_t>(mine.tile_rows());
  std::vector<double> merged;
  ranks.gather_to_root(mine.pack_tile_bounds(), [&](int rank, std::vector<double>&& packed) {
    if (merged.empty()) merged.resize(packed.size());
    const auto [begin, end] = bands.per_rank[static_cast<std::size_t>(rank)];
    const std::size_t from = static_cast<std::size_t>(begin) * tiles_per_row * kPerTile;
    const std::size_t to = static_cast<std::size_t>(end) * tiles_per_row * kPerTile;
    std::copy(packed.begin() + static_cast<std::ptrdiff_t>(from), packed.begin() + static_cast<std::ptrdiff_t>(to),
              merged.begin() + static_cast<std::ptrdiff_t>(from));
  });
  ranks.broadcast(merged);
  mine.set_foreign_tile_bounds(merged);
}

}  // namespace vmsim::app
