#pragma once
// Storage of a compact N-buffer's per-tile offsets (nbuffer.hpp, make_compact), in memory up to
// a budget and beyond it in memory-mapped files (issue 21: a Z-map larger than the machine's
// memory spills to disk rather than failing).
//
// Offsets are kept in chunks of many tiles. While the process's offsets in memory stay within
// the budget, a chunk is ordinary memory; past it, a chunk is a file in the spill directory,
// mapped shared: the kernel writes its pages back and drops them under memory pressure, and
// reads them again on access. Each spill file is unlinked as soon as it is mapped, so nothing is
// left on disk when the process ends, however it ends (a crash, a signal), and nothing of the
// user's is touched: the files are new ones (mkstemp) in the directory given.
//
// The cut visits tiles along the tool path, so the pages it touches at a time are few: a spilled
// Z-map is cut at nearly the speed of one in memory as long as the page cache holds the strip
// being cut.
#include <cstddef>
#include <filesystem>
#include <memory>
#include <mutex>
#include <span>
#include <vector>

namespace vmsim::removal {

/// Where compact offsets go past the budget. Process-wide (every buffer shares the budget).
struct SpillSettings {
  /// Offsets held in memory by all buffers together before chunks go to files [bytes]. The
  /// default, the largest value, never spills.
  std::size_t memory_budget_bytes = static_cast<std::size_t>(-1);
  /// Directory of the spill files (must exist and be writable when a spill happens).
  std::filesystem::path directory = std::filesystem::temp_directory_path();
};
void set_spill_settings(const SpillSettings& settings);
SpillSettings spill_settings();

/// What the process holds now [bytes]: offsets in memory chunks, and in spill files.
struct SpillFigures {
  std::size_t memory_bytes = 0;
  std::size_t spilled_bytes = 0;
  std::size_t spilled_peak_bytes = 0;  ///< largest spilled_bytes so far
};
SpillFigures spill_figures();

/// One float block of `block_floats` per tile, allocated on first use, never freed alone (a
/// tile once cut keeps its offsets). Allocation is thread-safe; reading and writing the blocks of
/// different tiles from different threads is too. Copies are deep.
class TileOffsetStore {
 public:
  explicit TileOffsetStore(std::size_t block_floats = 256);
  TileOffsetStore(const TileOffsetStore& other);
  TileOffsetStore& operator=(const TileOffsetStore& other);
  TileOffsetStore(TileOffsetStore&&) noexcept;
  TileOffsetStore& operator=(TileOffsetStore&&) noexcept;
  ~TileOffsetStore();

  /// `tiles` tiles, none holding offsets (frees every chunk).
  void reset(std::size_t tiles);
  std::size_t size() const { return blocks_.size(); }
  std::size_t block_floats() const { return block_floats_; }

  bool has(std::size_t tile) const { return blocks_[tile] != nullptr; }
  /// The tile's block, empty when it holds none.
  std::span<const float> block(std::size_t tile) const {
    return blocks_[tile] ? std::span<const float>(blocks_[tile], block_floats_) : std::span<const float>();
  }
  /// The tile's block, allocated and filled with `fill` when it held none.
  std::span<float> block_or_allocate(std::size_t tile, float fill);
  /// Sets the tile's block to `values` (block_floats of them), or to none when it is empty.
  void assign(std::size_t tile, std::span<const float> values);

  std::size_t allocated_blocks() const;
  /// Bytes of the blocks in use plus the table of tiles.
  std::size_t bytes() const { return allocated_blocks() * block_floats_ * sizeof(float) + blocks_.size() * sizeof(float*); }

 private:
  struct Chunk;
  float* allocate_block();

  std::size_t block_floats_;
  std::vector<float*> blocks_;
  std::vector<std::unique_ptr<Chunk>> chunks_;
  std::size_t used_in_last_chunk_ = 0;
  std::unique_ptr<std::mutex> mutex_ = std::make_unique<std::mutex>();
};

}  // namespace vmsim::removal
