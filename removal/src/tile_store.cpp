#include "vmsim/removal/tile_store.hpp"

#include <fcntl.h>
#include <sys/mman.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <string>

namespace vmsim::removal {
namespace {

std::mutex g_settings_mutex;
SpillSettings g_settings;
std::atomic<std::size_t> g_memory_bytes{0};
std::atomic<std::size_t> g_spilled_bytes{0};
std::atomic<std::size_t> g_spilled_peak_bytes{0};

// Chunks grow from a few blocks (small buffers stay small) to this many.
constexpr std::size_t kFirstChunkBlocks = 64;
constexpr std::size_t kLargestChunkBlocks = 16384;  // 16 MiB of 1 KiB blocks

// A new file in `directory`, unlinked at once, `bytes` long and mapped shared.
float* map_spill_file(const std::filesystem::path& directory, std::size_t bytes) {
  std::string name = (directory / "vmsim-spill-XXXXXX").string();
  const int fd = mkstemp(name.data());
  if (fd < 0) {
    throw std::runtime_error("cannot create a spill file in " + directory.string() + " (" + std::strerror(errno) +
                     "): the Z-maps exceed the memory budget; give a writable --spill-dir or a larger "
                     "--memory-budget-gb");
  }
  unlink(name.c_str());  // nothing is left behind, however the process ends
  // posix_fallocate reserves the blocks now: a full disk is an error here, not a SIGBUS later.
  const int reserved = posix_fallocate(fd, 0, static_cast<off_t>(bytes));
  void* data = reserved == 0 ? mmap(nullptr, bytes, PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0) : MAP_FAILED;
  const int map_errno = reserved != 0 ? reserved : errno;
  close(fd);
  if (data == MAP_FAILED) {
    throw std::runtime_error("cannot spill " + std::to_string(bytes >> 20) + " MiB of Z-map to " + directory.string() +
                     " (" + std::strerror(map_errno) + "): free disk space there or give another --spill-dir");
  }
  return static_cast<float*>(data);
}

}  // namespace

void set_spill_settings(const SpillSettings& settings) {
  const std::lock_guard lock(g_settings_mutex);
  g_settings = settings;
}

SpillSettings spill_settings() {
  const std::lock_guard lock(g_settings_mutex);
  return g_settings;
}

SpillFigures spill_figures() { return {g_memory_bytes.load(), g_spilled_bytes.load(), g_spilled_peak_bytes.load()}; }

struct TileOffsetStore::Chunk {
  float* data = nullptr;
  std::size_t blocks = 0;
  std::size_t bytes = 0;
  bool spilled = false;

  Chunk(std::size_t block_count, std::size_t block_floats) : blocks(block_count) {
    bytes = block_count * block_floats * sizeof(float);
    const SpillSettings settings = spill_settings();
    // The budget counts what is in memory; a chunk that would pass it goes to a file.
    const std::size_t in_memory = g_memory_bytes.fetch_add(bytes) + bytes;
    if (in_memory <= settings.memory_budget_bytes) {
      data = new float[block_count * block_floats];
      return;
    }
    g_memory_bytes.fetch_sub(bytes);
    data = map_spill_file(settings.directory, bytes);
    spilled = true;
    const std::size_t now = g_spilled_bytes.fetch_add(bytes) + bytes;
    std::size_t peak = g_spilled_peak_bytes.load();
    while (now > peak && !g_spilled_peak_bytes.compare_exchange_weak(peak, now)) {
    }
  }
  ~Chunk() {
    if (spilled) {
      munmap(data, bytes);
      g_spilled_bytes.fetch_sub(bytes);
    } else {
      delete[] data;
      g_memory_bytes.fetch_sub(bytes);
    }
  }
  Chunk(const Chunk&) = delete;
  Chunk& operator=(const Chunk&) = delete;
};

TileOffsetStore::TileOffsetStore(const TileOffsetStore& other) : block_floats_(other.block_floats_) {
  blocks_.assign(other.blocks_.size(), nullptr);
  for (std::size_t t = 0; t < other.blocks_.size(); ++t) {
    if (other.blocks_[t]) assign(t, other.block(t));
  }
}

TileOffsetStore::TileOffsetStore(std::size_t block_floats) : block_floats_(block_floats) {}
TileOffsetStore::TileOffsetStore(TileOffsetStore&&) noexcept = default;
TileOffsetStore& TileOffsetStore::operator=(TileOffsetStore&&) noexcept = default;
TileOffsetStore::~TileOffsetStore() = default;

TileOffsetStore& TileOffsetStore::operator=(const TileOffsetStore& other) {
  if (this != &other) *this = TileOffsetStore(other);
  return *this;
}

void TileOffsetStore::reset(std::size_t tiles) {
  blocks_.assign(tiles, nullptr);
  chunks_.clear();
  used_in_last_chunk_ = 0;
}

float* TileOffsetStore::allocate_block() {
  if (!mutex_) mutex_ = std::make_unique<std::mutex>();  // a moved-from store used again
  const std::lock_guard lock(*mutex_);
  if (chunks_.empty() || used_in_last_chunk_ == chunks_.back()->blocks) {
    const std::size_t blocks =
        chunks_.empty() ? kFirstChunkBlocks : std::min(2 * chunks_.back()->blocks, kLargestChunkBlocks);
    chunks_.push_back(std::make_unique<Chunk>(blocks, block_floats_));
    used_in_last_chunk_ = 0;
  }
  return chunks_.back()->data + (used_in_last_chunk_++) * block_floats_;
}

std::span<float> TileOffsetStore::block_or_allocate(std::size_t tile, float fill) {
  if (!blocks_[tile]) {
    float* block = allocate_block();
    std::fill_n(block, block_floats_, fill);
    blocks_[tile] = block;
  }
  return {blocks_[tile], block_floats_};
}

void TileOffsetStore::assign(std::size_t tile, std::span<const float> values) {
  if (values.empty()) {
    blocks_[tile] = nullptr;  // its block stays in its chunk, unused
    return;
  }
  if (values.size() != block_floats_) {
    throw std::invalid_argument("TileOffsetStore::assign: " + std::to_string(values.size()) + " values for a block of " +
                                std::to_string(block_floats_));
  }
  if (!blocks_[tile]) blocks_[tile] = allocate_block();
  std::copy(values.begin(), values.end(), blocks_[tile]);
}

std::size_t TileOffsetStore::allocated_blocks() const {
  return static_cast<std::size_t>(std::count_if(blocks_.begin(), blocks_.end(), [](const float* b) { return b; }));
}

}  // namespace vmsim::removal
