#pragma once
// The processes a simulate-part job runs on: MPI ranks when vmsim is built with MPI
// (VMSIM_WITH_MPI) and started by mpirun, else one process, for which every call below is a
// no-op (or returns its argument). No MPI header here: only mpi_ranks.cpp sees MPI.
//
// What is split (README, "Running on several processes"): every rank runs the whole path
// (plan, servo, direct kinematics: deterministic, so every rank has the same trajectory bit for
// bit without communication) and cuts only its band of each surface view's lines (a range of
// tile rows, NBuffer::band); the bands are gathered on rank 0, which alone compares, finds the
// marks and writes the output folder.
#include <cstddef>
#include <functional>
#include <span>
#include <string>
#include <utility>
#include <vector>

namespace vmsim::app {

/// Starts MPI for the process's lifetime when vmsim was built with MPI and the process was
/// started by an MPI launcher (mpirun sets OMPI_COMM_WORLD_SIZE, PMI_SIZE or PMIX_RANK); else
/// nothing (one rank). Make one, first thing in main.
class MpiSession {
 public:
  MpiSession(int& argc, char**& argv);
  ~MpiSession();
  MpiSession(const MpiSession&) = delete;
  MpiSession& operator=(const MpiSession&) = delete;
};

/// The ranks of the job (MPI_COMM_WORLD), or one rank.
class Ranks {
 public:
  static const Ranks& world();
  int rank() const { return rank_; }
  int size() const { return size_; }
  bool root() const { return rank_ == 0; }
  bool distributed() const { return size_ > 1; }

  /// Sends each rank's `values` to rank 0, which gets them rank by rank (its own first) through
  /// `on_root(rank, values)`; any size (sent in pieces below MPI's int counts).
  void gather_to_root(const std::vector<double>& values,
                      const std::function<void(int rank, std::vector<double>&& values)>& on_root) const;
  /// Rank 0's `values` on every rank.
  void broadcast(std::vector<double>& values) const;
  /// The sum over the ranks, on every rank.
  std::size_t sum(std::size_t value) const;
  /// Ends every rank of the job with `exit_code` (MPI_Abort); one rank: std::exit.
  [[noreturn]] void abort(int exit_code) const;

 private:
  friend class MpiSession;
  int rank_ = 0, size_ = 1;
};

/// Splits `weights.size()` tile rows into `parts` contiguous bands [begin, end), in order, each
/// at least one row, with sums of weights as even as the rows allow (each band ends at the row
/// where the running sum first reaches its share). Throws vmsim::InputError when there are
/// fewer rows than parts, std::invalid_argument on a negative or non-finite weight.
std::vector<std::pair<int, int>> split_rows(const std::vector<double>& weights, int parts);

}  // namespace vmsim::app
