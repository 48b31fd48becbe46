// Compact offsets spilled to memory-mapped files past the memory budget (tile_store.hpp): a
// buffer cut with everything spilled, or half of it, holds bit for bit the lengths of the same
// buffer cut in memory (the store only moves where the floats live); copies and bands of a
// spilled buffer are independent of it; nothing is left in the spill directory, even while the
// files are in use; a directory that cannot take the files is a clear error naming it.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <random>
#include <vector>

#include "removal_test_tools.hpp"
#include "vmsim/removal/nbuffer.hpp"
#include "vmsim/removal/tile_store.hpp"

namespace vmsim::removal {
namespace {

namespace fs = std::filesystem;
constexpr double mm = 1e-3;
using test::make_tool;

// Restores the process's spill settings when a test ends (they are process-wide).
class SpillSettingsGuard {
 public:
  SpillSettingsGuard() : saved_(spill_settings()) {}
  ~SpillSettingsGuard() { set_spill_settings(saved_); }

 private:
  SpillSettings saved_;
};

fs::path fresh_directory(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("vmsim-test-spill-" + name + "-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  return dir;
}

bool empty_directory(const fs::path& dir) { return fs::directory_iterator(dir) == fs::directory_iterator(); }

// Zig-zag passes of a ball-end mill over a 12 x 8 mm stock at random depths.
std::vector<Pose> random_passes(unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::vector<Pose> path;
  for (int pass = 0; pass < 12; ++pass) {
    const double y = -3.8 + 0.65 * pass;
    for (int k = 0; k <= 40; ++k) {
      const double x = (pass % 2 == 0 ? -5.5 + 0.275 * k : 5.5 - 0.275 * k);
      path.push_back({Eigen::Vector3d(x, y, 6.0 + 2.0 * unit(rng)) * mm, Eigen::Vector3d::UnitZ()});
    }
  }
  return path;
}

NBuffer cut_compact(unsigned seed) {
  const Box stock{Eigen::Vector3d(-6, -4, 0) * mm, Eigen::Vector3d(6, 4, 10) * mm};
  NBuffer buffer = NBuffer::zmap(stock, 0.025 * mm);
  buffer.make_compact();
  buffer.cut(make_tool(ToolType::ball, 3, 1.5), random_passes(seed));
  return buffer;
}

TEST(TileSpill, SpilledBuffersHoldTheLengthsOfTheBuffersInMemoryBitForBit) {
  const SpillSettingsGuard guard;
  const NBuffer in_memory = cut_compact(7);
  const std::size_t blocks_bytes = in_memory.allocated_tiles() * NBuffer::kTile * NBuffer::kTile * sizeof(float);
  ASSERT_GT(in_memory.allocated_tiles(), 100u);

  const fs::path dir = fresh_directory("all");
  const std::size_t memory_before = spill_figures().memory_bytes;
  for (const std::size_t budget : {std::size_t{0}, memory_before + blocks_bytes / 2}) {
    set_spill_settings({budget, dir});
    const std::size_t spilled_before = spill_figures().spilled_bytes;
    {
      const NBuffer spilled = cut_compact(7);
      EXPECT_GT(spill_figures().spilled_bytes, spilled_before) << "budget " << budget;
      if (budget == 0) {
        EXPECT_GE(spill_figures().spilled_bytes - spilled_before, blocks_bytes);
      }
      // The files are unlinked as soon as they are mapped: nothing shows in the directory.
      EXPECT_TRUE(empty_directory(dir));
      ASSERT_TRUE(spilled.same_lines(in_memory));
      EXPECT_EQ(spilled.allocated_tiles(), in_memory.allocated_tiles());
      EXPECT_EQ(spilled.lengths(), in_memory.lengths()) << "budget " << budget;
      const std::vector<double> d = difference(spilled, in_memory);
      for (double v : d) ASSERT_EQ(v, 0.0);
    }
    EXPECT_EQ(spill_figures().spilled_bytes, spilled_before);  // the mappings went with the buffer
  }
  EXPECT_TRUE(empty_directory(dir));
  fs::remove(dir);
}

TEST(TileSpill, CopiesAndBandsOfASpilledBufferAreIndependent) {
  const SpillSettingsGuard guard;
  const fs::path dir = fresh_directory("copies");
  set_spill_settings({0, dir});
  const NBuffer original = cut_compact(11);
  const std::vector<double> before = original.lengths();
  NBuffer copy = original;
  copy.cut(make_tool(ToolType::flat, 4), std::vector<Pose>{{Eigen::Vector3d(0, 0, 2) * mm, Eigen::Vector3d::UnitZ()},
                                                          {Eigen::Vector3d(3, 1, 2) * mm, Eigen::Vector3d::UnitZ()}});
  EXPECT_EQ(original.lengths(), before);
  EXPECT_NE(copy.lengths(), before);
  // A band cut apart and gathered back equals the whole buffer's cut (as in memory).
  const int rows = original.tile_rows();
  NBuffer whole = original, band = original.band(rows / 3, rows);
  const std::vector<Pose> pass = {{Eigen::Vector3d(-5, -3, 3) * mm, Eigen::Vector3d::UnitZ()},
                                  {Eigen::Vector3d(5, 3, 3) * mm, Eigen::Vector3d::UnitZ()}};
  const Tool tool = make_tool(ToolType::ball, 2, 1);
  whole.cut(tool, pass);
  band.cut(tool, pass);
  NBuffer gathered = whole;
  gathered.unpack_band(rows / 3, rows, band.pack_band());
  EXPECT_EQ(gathered.lengths(), whole.lengths());
  EXPECT_NE(whole.lengths(), original.lengths());
  fs::remove(dir);
}

TEST(TileSpill, ADirectoryThatCannotTakeTheFilesIsAnErrorNamingIt) {
  const SpillSettingsGuard guard;
  const fs::path missing = fs::temp_directory_path() / "vmsim-no-such-spill-directory" / "deeper";
  set_spill_settings({0, missing});
  try {
    cut_compact(3);
    FAIL() << "a spill into a missing directory must fail";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(missing.string()), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("--spill-dir"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(missing));
}

TEST(TileOffsetStore, BlocksAreAllocatedOnceAndAssignChecksTheirSize) {
  TileOffsetStore store(4);
  store.reset(3);
  EXPECT_EQ(store.allocated_blocks(), 0u);
  EXPECT_TRUE(store.block(1).empty());
  std::span<float> b = store.block_or_allocate(1, -1.0f);
  ASSERT_EQ(b.size(), 4u);
  b[2] = 5.0f;
  EXPECT_EQ(store.block_or_allocate(1, 0.0f)[2], 5.0f);  // not filled again
  EXPECT_EQ(store.allocated_blocks(), 1u);
  const std::vector<float> values = {1, 2, 3, 4};
  store.assign(0, values);
  TileOffsetStore copy = store;
  store.assign(0, std::vector<float>{});
  EXPECT_FALSE(store.has(0));
  ASSERT_TRUE(copy.has(0));
  EXPECT_EQ(copy.block(0)[3], 4.0f);
  EXPECT_EQ(copy.block(1)[0], -1.0f);
  EXPECT_THROW(store.assign(2, std::vector<float>{1, 2}), std::invalid_argument);
}

}  // namespace
}  // namespace vmsim::removal
