// write_heights_binary (row by row, for views too large to hold the file whole) against
// heights_binary (the whole file as one string): the same bytes, on a cut compact Z-map and on
// general lines; and the header read back by hand.
#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <sstream>

#include "vmsim/removal/nbuffer.hpp"
#include "vmsim/removal/output.hpp"

namespace vmsim::removal {
namespace {

std::string streamed(const NBuffer& buffer) {
  std::ostringstream out;
  write_heights_binary(buffer, out);
  return out.str();
}

TEST(HeightsBinaryStream, SameBytesAsTheWholeFileOnACutCompactZmap) {
  NBuffer zmap = NBuffer::zmap(Box{{0.0, 0.0, 0.0}, {0.0041, 0.0023, 0.005}}, 1e-4);  // tiles cut at the edge
  zmap.make_compact();
  Tool tool;
  tool.type = ToolType::ball;
  tool.diameter_m = 0.002;
  tool.corner_radius_m = 0.001;
  tool.length_m = 0.02;
  const std::vector<Pose> poses{{{0.0, 0.001, 0.0045}, {0.0, 0.0, 1.0}}, {{0.004, 0.0015, 0.0042}, {0.0, 0.0, 1.0}}};
  zmap.cut(tool, poses);
  ASSERT_GT(zmap.allocated_tiles(), 0u);  // offsets stored: lengths off their tile's base
  const std::string bytes = streamed(zmap);
  EXPECT_EQ(bytes, heights_binary(zmap));
  // By hand: the header, then nu * nv doubles.
  std::int32_t nu = 0, nv = 0, is_zmap = 0;
  std::memcpy(&nu, bytes.data() + 8, 4);
  std::memcpy(&nv, bytes.data() + 12, 4);
  std::memcpy(&is_zmap, bytes.data() + 16, 4);
  EXPECT_EQ(nu, zmap.nu());
  EXPECT_EQ(nv, zmap.nv());
  EXPECT_EQ(is_zmap, 1);
  EXPECT_EQ(bytes.size(), 8u + 12u + 32u + 8u * static_cast<std::size_t>(nu) * static_cast<std::size_t>(nv));
  double last = 0.0;
  std::memcpy(&last, bytes.data() + bytes.size() - 8, 8);
  EXPECT_EQ(last, zmap.length(nu - 1, nv - 1));
}

TEST(HeightsBinaryStream, SameBytesAsTheWholeFileOnGeneralLines) {
  std::vector<Eigen::Vector3d> origins, directions;
  std::vector<double> lengths;
  for (int iv = 0; iv < 5; ++iv) {
    for (int iu = 0; iu < 7; ++iu) {
      origins.emplace_back(1e-3 * iu, 2e-3 * iv, 0.1 * iu * iv);
      directions.emplace_back(0.0, 0.3 * iu, 1.0);
      lengths.push_back(1e-3 * (iu + 2 * iv));
    }
  }
  const NBuffer lines = NBuffer::lines(7, 5, origins, directions, lengths);
  EXPECT_EQ(streamed(lines), heights_binary(lines));
  EXPECT_EQ(streamed(lines).size(), 8u + 12u + 32u + 7u * 8u * 35u);
}

}  // namespace
}  // namespace vmsim::removal
