// Closed STL stock: ASCII and binary reading, located errors for malformed files, and the
// Z-map built from a mesh against the closed-form heights of a box with a pyramid roof.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "vmsim/common/errors.hpp"
#include "vmsim/removal/nbuffer.hpp"
#include "vmsim/removal/stl.hpp"

namespace vmsim::removal {
namespace {

constexpr double mm = 1e-3;

// Box [0, 10] x [0, 8] x [0, 5] mm with a pyramid roof, apex (5, 4, 8) mm; outward normals.
std::vector<std::array<Eigen::Vector3d, 3>> house() {
  const Eigen::Vector3d b0(0, 0, 0), b1(10, 0, 0), b2(10, 8, 0), b3(0, 8, 0);
  const Eigen::Vector3d t0(0, 0, 5), t1(10, 0, 5), t2(10, 8, 5), t3(0, 8, 5), apex(5, 4, 8);
  return {
      {b0, b2, b1}, {b0, b3, b2},                          // bottom (normal -z)
      {b0, b1, t1}, {b0, t1, t0}, {b1, b2, t2}, {b1, t2, t1},  // walls
      {b2, b3, t3}, {b2, t3, t2}, {b3, b0, t0}, {b3, t0, t3},
      {t0, t1, apex}, {t1, t2, apex}, {t2, t3, apex}, {t3, t0, apex},  // roof
  };
}

std::string ascii(const std::vector<std::array<Eigen::Vector3d, 3>>& tris, const std::string& bad_coordinate = "") {
  std::string s = "solid house\n";
  for (std::size_t k = 0; k < tris.size(); ++k) {
    s += "  facet normal 0 0 0\n    outer loop\n";
    for (int v = 0; v < 3; ++v) {
      const Eigen::Vector3d& p = tris[k][v];
      const std::string x = (k == 5 && v == 1 && !bad_coordinate.empty()) ? bad_coordinate : std::to_string(p.x());
      s += "      vertex " + x + " " + std::to_string(p.y()) + " " + std::to_string(p.z()) + "\n";
    }
    s += "    endloop\n  endfacet\n";
  }
  return s + "endsolid house\n";
}

double roof_mm(double x, double y) { return 8.0 - 3.0 * std::max(std::abs(x - 5.0) / 5.0, std::abs(y - 4.0) / 4.0); }

std::string message_of(const std::string& bytes, const std::string& name) {
  try {
    parse_stl(bytes, name);
  } catch (const InputError& e) {
    return e.what();
  }
  return "no error";
}

TEST(Stl, AsciiHouseReadsClosedWithItsVolume) {
  const TriangleMesh mesh = parse_stl(ascii(house()), "house.stl");
  EXPECT_EQ(mesh.vertices_m.size(), 9u);
  EXPECT_EQ(mesh.triangles.size(), 14u);
  // Box 10 x 8 x 5 plus pyramid 10 x 8 x 3 / 3 (mm^3).
  EXPECT_NEAR(mesh.volume_m3(), (400.0 + 80.0) * mm * mm * mm, 1e-18);
  const Box b = mesh.bounds();
  EXPECT_NEAR(b.max_W_m.z(), 8 * mm, 1e-15);
}

TEST(Stl, BinaryRoundTripAndInwardNormalsTurned) {
  const TriangleMesh a = parse_stl(ascii(house()), "house.stl");
  const TriangleMesh b = parse_stl(mesh_stl(a), "house-binary.stl");
  EXPECT_EQ(b.triangles.size(), a.triangles.size());
  EXPECT_NEAR(b.volume_m3(), a.volume_m3(), 1e-15);
  auto flipped = house();
  for (auto& t : flipped) std::swap(t[1], t[2]);
  EXPECT_NEAR(parse_stl(ascii(flipped), "inward.stl").volume_m3(), a.volume_m3(), 1e-18);
}

TEST(Stl, ZmapHeightsMatchTheClosedForm) {
  const TriangleMesh mesh = parse_stl(ascii(house()), "house.stl");
  MeshZmapReport report;
  // 0.1 mm: lines on the roof's ridges and on the walls (x = 0, 10; y = 0, 8) test the
  // tie-breaking on shared edges and vertices.
  const NBuffer b = NBuffer::zmap(mesh, 0.1 * mm, &report);
  ASSERT_EQ(b.nu(), 101);
  ASSERT_EQ(b.nv(), 81);
  double worst = 0.0;
  int on_boundary = 0;
  for (int j = 0; j < b.nv(); ++j) {
    for (int i = 0; i < b.nu(); ++i) {
      const double x = i * 0.1, y = j * 0.1;
      const double h = b.zmap_origin_m().z() + b.length(i, j);
      const bool edge = i == 0 || j == 0 || i == b.nu() - 1 || j == b.nv() - 1;
      if (edge) {
        // On the outline a line grazes a wall: it is either outside (0) or on the roof.
        EXPECT_TRUE(h == 0.0 || std::abs(h - roof_mm(x, y) * mm) < 1e-12) << i << " " << j;
        ++on_boundary;
        continue;
      }
      worst = std::max(worst, std::abs(h - roof_mm(x, y) * mm));
    }
  }
  EXPECT_LT(worst, 1e-12);
  EXPECT_EQ(report.lines_filled, 0u);
  EXPECT_GT(on_boundary, 300);
}

TEST(Stl, ZmapFillsBelowAnOverhang) {
  // Two separate houses, the second 20 mm along x and 2 mm lower: the grid's bottom is the
  // second one's, so the lines through the first enter 2 mm above it and are filled beneath.
  auto tris = house();
  auto lower = house();
  for (auto& t : lower) {
    for (auto& p : t) p = Eigen::Vector3d(p.x() + 20.0, p.y(), p.z() - 2.0);
  }
  tris.insert(tris.end(), lower.begin(), lower.end());
  MeshZmapReport report;
  const NBuffer b = NBuffer::zmap(parse_stl(ascii(tris), "two.stl"), 0.5 * mm, &report);
  // Lines through the first house enter at z = 0, 2 mm above the grid bottom (z = -2 mm).
  EXPECT_GT(report.lines_filled, 200u);
  EXPECT_GT(report.lines_missing, 0u);
  EXPECT_NEAR(b.zmap_origin_m().z() + b.length(10, 8), 8 * mm, 1e-12);  // apex (5, 4)
}

TEST(Stl, MalformedFilesNameFileAndTriangle) {
  // Truncated binary.
  const TriangleMesh mesh = parse_stl(ascii(house()), "house.stl");
  std::string binary = mesh_stl(mesh);
  binary.resize(binary.size() - 30);
  std::string m = message_of(binary, "cut.stl");
  EXPECT_NE(m.find("cut.stl"), std::string::npos) << m;
  EXPECT_NE(m.find("truncated"), std::string::npos) << m;
  EXPECT_NE(m.find("triangle 14"), std::string::npos) << m;
  // NaN in ASCII: the line of the vertex.
  m = message_of(ascii(house(), "nan"), "nan.stl");
  EXPECT_NE(m.find("nan.stl:"), std::string::npos) << m;
  EXPECT_NE(m.find("not finite"), std::string::npos) << m;
  // NaN in binary.
  std::string bad = mesh_stl(mesh);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  std::memcpy(bad.data() + 84 + 50 * 3 + 12 + 4, &nan, 4);
  m = message_of(bad, "nanb.stl");
  EXPECT_NE(m.find("nanb.stl: triangle 4"), std::string::npos) << m;
  // Open mesh: one roof triangle missing.
  auto open = house();
  open.pop_back();
  m = message_of(ascii(open), "open.stl");
  EXPECT_NE(m.find("open.stl:"), std::string::npos) << m;
  EXPECT_NE(m.find("not closed"), std::string::npos) << m;
  // Inconsistent orientation: one wall triangle flipped.
  auto flipped = house();
  std::swap(flipped[4][1], flipped[4][2]);
  m = message_of(ascii(flipped), "flip.stl");
  EXPECT_NE(m.find("flip.stl:"), std::string::npos) << m;
  EXPECT_NE(m.find("triangle"), std::string::npos) << m;
  // A non-number and a truncated ASCII file.
  m = message_of(ascii(house(), "1.0x"), "word.stl");
  EXPECT_NE(m.find("is not a number"), std::string::npos) << m;
  std::string cut_ascii = ascii(house());
  cut_ascii.resize(cut_ascii.size() / 2);
  m = message_of(cut_ascii, "half.stl");
  EXPECT_NE(m.find("half.stl:"), std::string::npos) << m;
}

}  // namespace
}  // namespace vmsim::removal
