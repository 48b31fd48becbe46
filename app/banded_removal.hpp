#pragma once
// simulate-part's removal split over the job's ranks (mpi_ranks.hpp): each rank cuts its band of
// tile rows of every surface view (NBuffer::band) and rank 0 gathers the bands into the whole
// buffer. With one rank every function here passes the whole buffer through.
#include <Eigen/Core>

#include <functional>
#include <utility>
#include <vector>

#include "mpi_ranks.hpp"
#include "vmsim/removal/nbuffer.hpp"

namespace vmsim::app {

/// The bands of one view's tile rows, one per rank ([begin, end), in rank order).
struct ViewBands {
  std::vector<std::pair<int, int>> per_rank;
};

/// Work per tile row of a Z-map, to balance the bands: the planar length of the cutting moves
/// (consecutive `cutting_tips_W_m`) spread over the tile rows within `reach_m` of them, plus a
/// twentieth of the mean for every row (the rows' own cost: copies, gathering).
std::vector<double> zmap_row_weights(const removal::NBuffer& zmap, const std::vector<Eigen::Vector3d>& cutting_tips_W_m,
                                     double reach_m);

/// The bands of `buffer` over `ranks` (by `weights` per tile row; empty: by rows).
ViewBands view_bands(const removal::NBuffer& buffer, const Ranks& ranks, const std::vector<double>& weights = {});

/// What this rank cuts of `uncut` (the whole buffer, or this rank's band of it): its band, or
/// `uncut` itself with one rank.
removal::NBuffer rank_share(const removal::NBuffer& uncut, const ViewBands& bands, const Ranks& ranks);

/// Gathers every rank's cut band into the whole buffer on rank 0 (`uncut_whole`, which rank 0
/// holds, gives the grid), returned there; other ranks get their band back. One rank: `mine`.
/// Sent in rounds, a piece of whole tile rows of about `piece_lines` lines (at least one tile
/// row) from every rank each round, so that no side ever packs a whole band.
removal::NBuffer gather_bands(removal::NBuffer&& mine, const removal::NBuffer& uncut_whole, const ViewBands& bands,
                              const Ranks& ranks, std::size_t piece_lines);

/// Gives every rank's band the other bands' current tile bounds (called between the cuts of
/// consecutive tool stretches: the next cut's material box, and so its 5-axis sub-steps, is
/// then the whole buffer's). Collective; nothing with one rank.
void exchange_tile_bounds(removal::NBuffer& mine, const ViewBands& bands, const Ranks& ranks);

}  // namespace vmsim::app
