#include "mpi_ranks.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <stdexcept>

#include "vmsim/common/errors.hpp"

#ifdef VMSIM_WITH_MPI
#include <mpi.h>
#endif

namespace vmsim::app {
namespace {

Ranks& mutable_world() {
  static Ranks ranks;
  return ranks;
}

#ifdef VMSIM_WITH_MPI
bool started_by_mpi_launcher() {
  for (const char* name : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_RANK"}) {
    if (std::getenv(name) != nullptr) return true;
  }
  return false;
}
bool g_mpi_started = false;
// MPI counts are ints: larger messages go in pieces of this many doubles (1 GiB).
constexpr std::size_t kPiece = std::size_t{1} << 27;
#endif

}  // namespace

const Ranks& Ranks::world() { return mutable_world(); }

MpiSession::MpiSession([[maybe_unused]] int& argc, [[maybe_unused]] char**& argv) {
#ifdef VMSIM_WITH_MPI
  if (!started_by_mpi_launcher()) return;
  // Only the main thread calls MPI (TBB's workers never do).
  int provided = 0;
  MPI_Init_thread(&argc, &argv, MPI_THREAD_FUNNELED, &provided);
  g_mpi_started = true;
  Ranks& world = mutable_world();
  MPI_Comm_rank(MPI_COMM_WORLD, &world.rank_);
  MPI_Comm_size(MPI_COMM_WORLD, &world.size_);
#endif
}

MpiSession::~MpiSession() {
#ifdef VMSIM_WITH_MPI
  if (g_mpi_started) MPI_Finalize();
#endif
}

void Ranks::gather_to_root(const std::vector<double>& values,
                           const std::function<void(int, std::vector<double>&&)>& on_root) const {
  if (root()) on_root(0, std::vector<double>(values));
  if (!distributed()) return;
#ifdef VMSIM_WITH_MPI
  constexpr int kTag = 21;
  if (!root()) {
    const std::uint64_t count = values.size();
    MPI_Send(&count, 1, MPI_UINT64_T, 0, kTag, MPI_COMM_WORLD);
    for (std::size_t at = 0; at < values.size(); at += kPiece) {
      MPI_Send(values.data() + at, static_cast<int>(std::min(kPiece, values.size() - at)), MPI_DOUBLE, 0, kTag,
               MPI_COMM_WORLD);
    }
    return;
  }
  for (int from = 1; from < size_; ++from) {
    std::uint64_t count = 0;
    MPI_Recv(&count, 1, MPI_UINT64_T, from, kTag, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
    std::vector<double> received(count);
    for (std::size_t at = 0; at < received.size(); at += kPiece) {
      MPI_Recv(received.data() + at, static_cast<int>(std::min(kPiece, received.size() - at)), MPI_DOUBLE, from,
               kTag, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
    }
    on_root(from, std::move(received));
  }
#endif
}

void Ranks::broadcast([[maybe_unused]] std::vector<double>& values) const {
  if (!distributed()) return;
#ifdef VMSIM_WITH_MPI
  std::uint64_t count = values.size();
  MPI_Bcast(&count, 1, MPI_UINT64_T, 0, MPI_COMM_WORLD);
  values.resize(count);
  for (std::size_t at = 0; at < values.size(); at += kPiece) {
    MPI_Bcast(values.data() + at, static_cast<int>(std::min(kPiece, values.size() - at)), MPI_DOUBLE, 0,
              MPI_COMM_WORLD);
  }
#endif
}

std::size_t Ranks::sum(std::size_t value) const {
  if (!distributed()) return value;
#ifdef VMSIM_WITH_MPI
  std::uint64_t mine = value, total = 0;
  MPI_Allreduce(&mine, &total, 1, MPI_UINT64_T, MPI_SUM, MPI_COMM_WORLD);
  return static_cast<std::size_t>(total);
#else
  return value;
#endif
}

void Ranks::abort(int exit_code) const {
#ifdef VMSIM_WITH_MPI
  if (g_mpi_started) MPI_Abort(MPI_COMM_WORLD, exit_code);
#endif
  std::exit(exit_code);
}

std::vector<std::pair<int, int>> split_rows(const std::vector<double>& weights, int parts) {
  const int rows = static_cast<int>(weights.size());
  if (parts < 1 || rows < parts) {
    throw InputError(std::to_string(parts) + " processes for " + std::to_string(rows) +
                     " tile rows of 16 lines: each process needs a row at least (fewer processes, or a finer grid)");
  }
  double total = 0.0;
  for (double w : weights) {
    if (!(w >= 0.0) || !std::isfinite(w)) throw std::invalid_argument("split_rows: weights must be finite and >= 0");
    total += w;
  }
  std::vector<std::pair<int, int>> bands;
  double running = 0.0;
  int begin = 0;
  for (int row = 0; row < rows && static_cast<int>(bands.size()) + 1 < parts; ++row) {
    running += weights[static_cast<std::size_t>(row)];
    const int part = static_cast<int>(bands.size());
    const int rows_left_after = rows - (row + 1);
    const int parts_left_after = parts - (part + 1);
    // End the band here when its share is reached (or the rows left are just enough), never
    // before it holds a row and never leaving a later band without one.
    const bool share_reached = total > 0.0 ? running >= total * (part + 1) / parts
                                           : row + 1 >= static_cast<int>(static_cast<long>(rows) * (part + 1) / parts);
    if ((share_reached && rows_left_after >= parts_left_after) || rows_left_after == parts_left_after) {
      bands.emplace_back(begin, row + 1);
      begin = row + 1;
    }
  }
  bands.emplace_back(begin, rows);
  return bands;
}

}  // namespace vmsim::app
