// Level-set (OpenVDB) material removal: closed-form troughs, scallops, tilted flat-end and
// bull-nose profiles; laws (nothing above the stock, never adds material, thread count);
// agreement with the N-buffer on the same path; the sweep distance against the exact
// minimisation of sweep.hpp; regions, surface, .vdb round trip.
#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "../../removal/src/level_set_sweep.hpp"
#include "../../removal/src/sweep.hpp"
#include "vmsim/common/errors.hpp"
#include "vmsim/removal/level_set.hpp"
#include "vmsim/removal/nbuffer.hpp"

namespace vmsim::removal {
namespace {

constexpr double mm = 1e-3;
constexpr double um = 1e-6;
constexpr double kVoxel = 20 * um;

Box box_mm(double x0, double y0, double z0, double x1, double y1, double z1) {
  return Box{Eigen::Vector3d(x0, y0, z0) * mm, Eigen::Vector3d(x1, y1, z1) * mm};
}
Pose pose_mm(double x, double y, double z, Eigen::Vector3d axis = Eigen::Vector3d::UnitZ()) {
  return Pose{Eigen::Vector3d(x, y, z) * mm, axis.normalized()};
}
Tool make_tool(ToolType type, double d_mm, double r_mm = 0.0, double length_mm = 20.0) {
  Tool t;
  t.type = type;
  t.diameter_m = d_mm * mm;
  t.corner_radius_m = r_mm * mm;
  t.length_m = length_mm * mm;
  return t;
}
LevelSetOptions uniform(double voxel_m) {
  LevelSetOptions o;
  o.voxel_m = voxel_m;
  return o;
}

// Height of the machined surface above (x, y): the zero of the interpolated phi on the vertical
// line, bisected between z_lo (in the material) and z_hi (above it) [m].
double surface_z(const LevelSetStock& s, double x, double y, double z_lo, double z_hi) {
  EXPECT_LT(s.signed_distance(Eigen::Vector3d(x, y, z_lo)), 0.0) << "x " << x << " y " << y;
  EXPECT_GT(s.signed_distance(Eigen::Vector3d(x, y, z_hi)), 0.0) << "x " << x << " y " << y;
  for (int i = 0; i < 60; ++i) {
    const double z = 0.5 * (z_lo + z_hi);
    (s.signed_distance(Eigen::Vector3d(x, y, z)) < 0.0 ? z_lo : z_hi) = z;
  }
  return 0.5 * (z_lo + z_hi);
}

TEST(LevelSet, BallStraightPassCutsTheClosedFormTrough) {
  LevelSetStock s = LevelSetStock::box(box_mm(-3, -3, 0, 3, 3, 2), uniform(kVoxel));
  const std::vector<Pose> path = {pose_mm(-2, 0.013, 1.7), pose_mm(2, 0.013, 1.7)};
  const LevelSetCutStatistics stats = s.cut(make_tool(ToolType::ball, 4), path);
  EXPECT_GT(stats.voxels_changed, 0u);
  const double R = 2 * mm, cz = 1.7 * mm + R, yc = 0.013 * mm;
  // Profile across the trough, below the edges (creases, see level_set.hpp).
  double worst = 0.0;
  for (double y = -0.9 * mm; y <= 0.9 * mm; y += 0.0137 * mm) {
    const double expected = cz - std::sqrt(R * R - (y - yc) * (y - yc));
    worst = std::max(worst, std::abs(surface_z(s, 0.1 * mm, y, 1.0 * mm, 2.1 * mm) - expected));
  }
  EXPECT_LT(worst, 0.1 * kVoxel) << "worst profile error " << worst / um << " um";
  EXPECT_NEAR(surface_z(s, 0.0, yc, 1.0 * mm, 2.1 * mm), 1.7 * mm, 0.1 * kVoxel);  // depth
  // Width: the walls 3 voxels below the top.
  const double z = 2 * mm - 3 * kVoxel;
  const double half = std::sqrt(R * R - (cz - z) * (cz - z));
  for (double side : {-1.0, 1.0}) {
    double inside = yc + side * 2.5 * mm, outside = yc;
    for (int i = 0; i < 60; ++i) {
      const double y = 0.5 * (inside + outside);
      (s.signed_distance(Eigen::Vector3d(0, y, z)) < 0.0 ? inside : outside) = y;
    }
    EXPECT_NEAR(0.5 * (inside + outside), yc + side * half, 0.1 * kVoxel);
  }
  // Outside the pass the stock is untouched.
  EXPECT_NEAR(surface_z(s, 0.0, 2.5 * mm, 1.5 * mm, 2.1 * mm), 2 * mm, 0.01 * kVoxel);
  EXPECT_NEAR(surface_z(s, 2.8 * mm, 2.7 * mm, 1.5 * mm, 2.1 * mm), 2 * mm, 0.01 * kVoxel);
}

TEST(LevelSet, ParallelPassesLeaveTheScallopHeight) {
  // Stepover 0.8 mm with R = 2 mm: h = R - sqrt(R^2 - (p/2)^2) = 40.4 um (2 voxels). The cusp
  // lies on a voxel column (y = 0), so the interpolation there is along z only.
  LevelSetStock s = LevelSetStock::box(box_mm(-3, -3, 0, 3, 3, 2), uniform(kVoxel));
  const Tool tool = make_tool(ToolType::ball, 4);
  for (double y : {-0.4, 0.4}) {
    const std::vector<Pose> pass = {pose_mm(-2, y, 1.7), pose_mm(2, y, 1.7)};
    s.cut(tool, pass);
  }
  const double R = 2 * mm, p = 0.8 * mm;
  const double h = R - std::sqrt(R * R - 0.25 * p * p);
  const double cusp = surface_z(s, 0.0, 0.0, 1.0 * mm, 2.1 * mm);
  const double bottom = surface_z(s, 0.0, 0.4 * mm, 1.0 * mm, 2.1 * mm);
  EXPECT_NEAR(bottom, 1.7 * mm, 0.1 * kVoxel);
  EXPECT_NEAR(cusp - bottom, h, 0.1 * kVoxel) << "scallop " << (cusp - bottom) / um << " um, closed form " << h / um;
}

TEST(LevelSet, TiltedFlatEndPassesMatchTheirClosedForms) {
  const double beta = 10.0 * M_PI / 180.0, R = 2 * mm, tip_z = 1.6 * mm;
  const Eigen::Vector3d axis(std::sin(beta), 0.0, std::cos(beta));
  const Tool tool = make_tool(ToolType::flat, 4);
  {  // Moving along y, normal to the tilt plane: the bottom is the plane z = tip_z - x tan(beta).
    LevelSetStock s = LevelSetStock::box(box_mm(-3, -3, 0, 3, 3, 2), uniform(kVoxel));
    const std::vector<Pose> path = {pose_mm(0, -2, 1.6, axis), pose_mm(0, 2, 1.6, axis)};
    s.cut(tool, path);
    double worst = 0.0;
    for (double x = -0.9 * R * std::cos(beta); x <= 0.9 * R * std::cos(beta); x += 0.0731 * mm) {
      worst = std::max(worst, std::abs(surface_z(s, x, 0.05 * mm, 0.8 * mm, 2.1 * mm) - (tip_z - x * std::tan(beta))));
    }
    EXPECT_LT(worst, 0.1 * kVoxel) << worst / um << " um";
  }
  {  // Moving along x, in the tilt plane (the sweep distance by 1-D minimisation): the rim of
     // the tilted disc, z = tip_z - sin(beta) sqrt(R^2 - y^2).
    LevelSetStock s = LevelSetStock::box(box_mm(-3, -3, 0, 3, 3, 2), uniform(kVoxel));
    // At x = 1.3 mm the lowest rim point passes for every |y| < 0.95 R.
    const std::vector<Pose> path = {pose_mm(-1.5, 0, 1.6, axis), pose_mm(1.5, 0, 1.6, axis)};
    s.cut(tool, path);
    double worst = 0.0;
    for (double y = -0.95 * R; y <= 0.95 * R; y += 0.0731 * mm) {
      const double expected = tip_z - std::sin(beta) * std::sqrt(R * R - y * y);
      worst = std::max(worst, std::abs(surface_z(s, 1.3 * mm, y, 0.8 * mm, 2.1 * mm) - expected));
    }
    EXPECT_LT(worst, 0.1 * kVoxel) << worst / um << " um";
  }
}

TEST(LevelSet, BullNosePassMatchesItsClosedForm) {
  LevelSetStock s = LevelSetStock::box(box_mm(-3, -4, 0, 3, 4, 2), uniform(kVoxel));
  const double rho = 2 * mm, r = 1 * mm, tip_z = 1.7 * mm;
  const std::vector<Pose> path = {pose_mm(-2, 0, 1.7), pose_mm(2, 0, 1.7)};
  s.cut(make_tool(ToolType::bull, 6, 1), path);
  double worst = 0.0;
  for (double y = -2.6 * mm; y <= 2.6 * mm; y += 0.0517 * mm) {
    const double e = std::max(0.0, std::abs(y) - rho);
    const double expected = tip_z + r - std::sqrt(r * r - e * e);
    worst = std::max(worst, std::abs(surface_z(s, 0.1 * mm, y, 1.0 * mm, 2.1 * mm) - expected));
  }
  EXPECT_LT(worst, 0.1 * kVoxel) << worst / um << " um";
}

std::vector<Eigen::Vector3d> random_points(const Box& b, int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < n; ++i) {
    Eigen::Vector3d p;
    for (int k = 0; k < 3; ++k) {
      p[k] = std::uniform_real_distribution<double>(b.min_W_m[k], b.max_W_m[k])(rng);
    }
    points.push_back(p);
  }
  return points;
}

TEST(LevelSet, PassAboveTheStockRemovesNothing) {
  LevelSetStock s = LevelSetStock::box(box_mm(-3, -3, 0, 3, 3, 2), uniform(kVoxel));
  const auto points = random_points(box_mm(-3.2, -3.2, 1.8, 3.2, 3.2, 2.2), 20000, 1);
  const std::vector<double> before = s.signed_distances(points);
  const std::size_t active = s.active_voxel_count();
  const std::vector<Pose> path = {pose_mm(-2, 0, 2.001), pose_mm(2, 0.5, 2.001), pose_mm(2, 1, 2.3)};
  const LevelSetCutStatistics stats = s.cut(make_tool(ToolType::ball, 4), path);
  EXPECT_EQ(stats.voxels_changed, 0u);
  EXPECT_EQ(s.signed_distances(points), before);
  EXPECT_EQ(s.active_voxel_count(), active);
}

TEST(LevelSet, RemovalNeverAddsMaterialAndDoesNotDependOnThreads) {
  // A 5-axis path (turning axis) with a bull-nose and a ball mill, on a coarser grid.
  const double voxel = 50 * um;
  LevelSetStock s = LevelSetStock::box(box_mm(-4, -4, 0, 4, 4, 3), uniform(voxel));
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<Pose> path;
  for (int i = 0; i < 21; ++i) {
    const Eigen::Vector3d axis(0.2 * std::sin(0.1 * i), 0.15 * std::cos(0.1 * i), 1.0);
    path.push_back(pose_mm(3 * std::sin(0.3 * i), 2.5 * std::cos(0.21 * i), 2.4 + 0.3 * u(rng), axis));
  }
  const auto points = random_points(box_mm(-4.2, -4.2, 0.5, 4.2, 4.2, 3.2), 40000, 2);
  LevelSetStock two = s.copy();
  std::vector<double> previous = s.signed_distances(points);
  for (std::size_t k = 0; k + 1 < path.size(); k += 10) {
    const std::span<const Pose> piece(path.data() + k, std::min<std::size_t>(11, path.size() - k));
    LevelSetCutOptions one_thread;
    one_thread.threads = 1;
    one_thread.orientation_tolerance_m = 5 * um;  // 0.1 voxel
    const LevelSetCutStatistics stats =
        s.cut(k < 10 ? make_tool(ToolType::bull, 3, 0.5) : make_tool(ToolType::ball, 3), piece, one_thread);
    std::printf("k %zu: %zu sub-segments, %zu evaluated, %zu changed\n", k, stats.sub_segments, stats.voxels_evaluated,
                stats.voxels_changed);
    LevelSetCutOptions two_threads;
    two_threads.threads = 2;
    two_threads.batch_segments = 3;
    two_threads.orientation_tolerance_m = 5 * um;
    two.cut(k < 10 ? make_tool(ToolType::bull, 3, 0.5) : make_tool(ToolType::ball, 3), piece, two_threads);
    const std::vector<double> now = s.signed_distances(points);
    std::size_t raised = 0;
    for (std::size_t i = 0; i < points.size(); ++i) {
      ASSERT_GE(now[i], previous[i]) << "material added at point " << i;
      raised += now[i] > previous[i];
    }
    EXPECT_GT(raised, 100u) << "the path cuts, k " << k;
    previous = now;
  }
  EXPECT_EQ(two.signed_distances(points), previous) << "1 and 2 threads, other batches: same grid";
}

TEST(LevelSet, AgreesWithTheNBufferOnTheSamePath) {
  // A zig-zag of a ball D4 with 0.5 mm stepover: the N-buffer's exact surface points lie on the
  // level set's zero surface within the interpolation error (largest at the scallop cusps and
  // trough edges, creases, see level_set.hpp).
  const Box stock = box_mm(-3, -3, 0, 3, 3, 2);
  std::vector<Pose> path;
  for (int k = 0; k < 5; ++k) {
    const double y = -1.0 + 0.5 * k, z = 1.75 + 0.02 * k;
    const double xa = k % 2 ? 2.0 : -2.0, xb = -xa;
    for (int i = 0; i <= 40; ++i) path.push_back(pose_mm(xa + (xb - xa) * i / 40.0, y + 0.01 * std::sin(i), z));
  }
  const Tool tool = make_tool(ToolType::ball, 4);
  NBuffer nb = NBuffer::zmap(stock, 0.05 * mm);
  nb.cut(tool, path);
  LevelSetStock s = LevelSetStock::box(stock, uniform(kVoxel));
  s.cut(tool, path);
  std::vector<Eigen::Vector3d> points;
  for (int j = 1; j + 1 < nb.nv(); ++j) {
    for (int i = 1; i + 1 < nb.nu(); ++i) points.push_back(nb.surface_point(i, j));
  }
  const std::vector<double> phi = s.signed_distances(points);
  double worst = 0.0, sum = 0.0;
  for (double v : phi) worst = std::max(worst, std::abs(v)), sum += std::abs(v);
  const double mean = sum / static_cast<double>(phi.size());
  std::printf("N-buffer vs level set at %zu points: mean |phi| %.3f um, max %.3f um (voxel 20 um)\n", phi.size(),
              mean / um, worst / um);
  EXPECT_LT(mean, 0.02 * kVoxel);
  EXPECT_LT(worst, 0.25 * kVoxel);
}

TEST(LevelSet, SweepDistanceMatchesTheExactMinimisation) {
  // level_set_sweep.hpp's closed forms against sweep.cpp's signed_distance (nested golden
  // sections for flat/bull tools, parallelogram distance for balls): equal outside the sweep;
  // inside, the closed forms are exact and sweep.cpp's minimum over the segment is >= them.
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  int outside = 0;
  for (int trial = 0; trial < 400; ++trial) {
    const ToolType type = trial % 3 == 0 ? ToolType::ball : trial % 3 == 1 ? ToolType::flat : ToolType::bull;
    const Tool tool = make_tool(type, 6, 1, 12);
    Eigen::Vector3d a0(0.4 * u(rng), 0.4 * u(rng), 1.0);
    Eigen::Vector3d d(2 * u(rng), 2 * u(rng), trial % 2 ? 0.0 : u(rng));
    if (trial % 4 == 0) d -= d.dot(a0.normalized()) * a0.normalized();  // normal to the axis
    const Pose p0 = pose_mm(0, 0, 0, a0), p1{p0.tip_W_m + d * mm, a0.normalized()};
    std::vector<detail::Sweep> sweeps;
    detail::split_segment(tool, p0, p1, 1e-6, sweeps);
    ASSERT_EQ(sweeps.size(), 1u);
    const detail::SweepDistance fast(sweeps[0], 1e-12);
    for (int k = 0; k < 20; ++k) {
      const Eigen::Vector3d p = Eigen::Vector3d(6 * u(rng), 6 * u(rng), 8 * u(rng)) * mm;
      const double exact = detail::signed_distance(sweeps[0], p), mine = fast(p);
      if (exact > 0.0) {
        ++outside;
        ASSERT_NEAR(mine, exact, 1e-10) << "trial " << trial;
      } else {
        ASSERT_LE(mine, exact + 1e-10) << "trial " << trial;
      }
    }
    // The culling law: where behind_start holds, the sweep's distance is the start tool's.
    for (int k = 0; k < 20; ++k) {
      const Eigen::Vector3d lo = Eigen::Vector3d(6 * u(rng), 6 * u(rng), 8 * u(rng)) * mm;
      const Eigen::Vector3d hi = lo.array() + 0.3 * mm;
      if (!fast.behind_start(lo, hi) || fast.start_core(0.5 * (lo + hi)) <= 0.3 * mm) continue;
      for (int m = 0; m < 8; ++m) {
        const Eigen::Vector3d p(m & 1 ? hi.x() : lo.x(), m & 2 ? hi.y() : lo.y(), m & 4 ? hi.z() : lo.z());
        ASSERT_NEAR(fast(p), fast.start_tool(p), 1e-10) << "trial " << trial;
      }
    }
  }
  EXPECT_GT(outside, 4000);
}

TEST(LevelSet, MeshStockMatchesTheBoxDistance) {
  // The stock box as 12 triangles through meshToLevelSet: phi at points near the faces (away
  // from edges) equals the analytic distance to the box.
  const Box b = box_mm(-2, -1.5, 0, 2, 1.5, 1);
  TriangleMesh m;
  for (int i = 0; i < 8; ++i) {
    m.vertices_m.emplace_back(i & 1 ? b.max_W_m.x() : b.min_W_m.x(), i & 2 ? b.max_W_m.y() : b.min_W_m.y(),
                                i & 4 ? b.max_W_m.z() : b.min_W_m.z());
  }
  m.triangles = {{0, 2, 3}, {0, 3, 1}, {4, 5, 7}, {4, 7, 6}, {0, 1, 5}, {0, 5, 4},
                 {2, 6, 7}, {2, 7, 3}, {0, 4, 6}, {0, 6, 2}, {1, 3, 7}, {1, 7, 5}};
  LevelSetStock s = LevelSetStock::mesh(m, uniform(50 * um));
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int k = 0; k < 2000; ++k) {
    // A point within 2 voxels of the top face, at least 0.3 mm from its edges.
    const Eigen::Vector3d p(1.7 * mm * u(rng), 1.2 * mm * u(rng), 1 * mm + 100 * um * u(rng));
    ASSERT_NEAR(s.signed_distance(p), p.z() - 1 * mm, 0.01 * 50 * um);
  }
  TriangleMesh bad = m;
  bad.triangles[3][1] = 8;
  EXPECT_THROW(LevelSetStock::mesh(bad, uniform(50 * um)), InputError);
}

TEST(LevelSet, FineRegionsResolveTheirBoxesAndSurfaceIsOriented) {
  LevelSetOptions o;
  o.voxel_m = 0.2 * mm;
  o.regions.push_back(LevelSetRegion{box_mm(-1, -1, 1, 1, 1, 2.5), kVoxel});
  LevelSetStock s = LevelSetStock::box(box_mm(-4, -4, 0, 4, 4, 2), o);
  ASSERT_EQ(s.grid_count(), 2u);
  const std::vector<Pose> path = {pose_mm(-3.5, 0.013, 1.7), pose_mm(3.5, 0.013, 1.7)};
  s.cut(make_tool(ToolType::ball, 4), path);
  const double R = 2 * mm, cz = 1.7 * mm + R;
  for (double x : {-2.5, 0.3}) {  // coarse grid, then the region
    const double voxel = x < -1 ? 0.2 * mm : kVoxel;
    for (double y = -0.8 * mm; y <= 0.8 * mm; y += 0.1 * mm) {
      const double expected = cz - std::sqrt(R * R - (y - 0.013 * mm) * (y - 0.013 * mm));
      EXPECT_NEAR(surface_z(s, x * mm, y, 1.0 * mm, 2.1 * mm), expected, 0.1 * voxel) << "x " << x << " y " << y;
    }
  }
  const TriangleMesh mesh = s.surface();
  ASSERT_GT(mesh.triangles.size(), 1000u);
  // Every vertex on the analytic surface (box minus the capsule), within a voxel of its grid;
  // triangles on the top face face up.
  int up = 0, fine = 0;
  for (const auto& t : mesh.triangles) {
    const Eigen::Vector3d& a = mesh.vertices_m[t[0]];
    const Eigen::Vector3d n = (mesh.vertices_m[t[1]] - a).cross(mesh.vertices_m[t[2]] - a);
    if (std::abs(a.z() - 2 * mm) < 1 * um && std::abs(a.y()) > 2.5 * mm) {
      EXPECT_GT(n.z(), 0.0);
      ++up;
    }
  }
  for (const auto& v : mesh.vertices_m) {
    const double in_box = std::max((v - Eigen::Vector3d(0, 0, 1 * mm)).cwiseAbs().maxCoeff() - 1 * mm, -1.0);
    const bool in_region = std::abs(v.x()) < 1 * mm && std::abs(v.y()) < 1 * mm && in_box < 0.5 * mm;
    fine += in_region;
    const double px = std::clamp(v.x(), -3.5 * mm, 3.5 * mm);
    const double capsule = std::hypot(v.x() - px, v.y() - 0.013 * mm, v.z() - cz) - R;
    const Eigen::Vector3d q = (v - Eigen::Vector3d(0, 0, 1 * mm)).cwiseAbs() - Eigen::Vector3d(4, 4, 1) * mm;
    const double box = q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
    EXPECT_LT(std::abs(std::max(box, -capsule)), (in_region ? 1.0 : 1.0) * (in_region ? kVoxel : 0.2 * mm));
  }
  EXPECT_GT(up, 10);
  EXPECT_GT(fine, 100);
  EXPECT_GT(s.memory_bytes(), 0u);
}

TEST(LevelSet, VdbRoundTripKeepsEveryGrid) {
  LevelSetOptions o;
  o.voxel_m = 0.1 * mm;
  o.regions.push_back(LevelSetRegion{box_mm(-1, -1, 1, 1, 1, 2.5), 25 * um});
  LevelSetStock s = LevelSetStock::box(box_mm(-3, -3, 0, 3, 3, 2), o);
  const std::vector<Pose> path = {pose_mm(-2, 0, 1.7), pose_mm(2, 0.3, 1.75)};
  s.cut(make_tool(ToolType::ball, 4), path);
  const std::string bytes = s.vdb_bytes();
  ASSERT_GT(bytes.size(), 8u);
  EXPECT_EQ(bytes.substr(0, 4), std::string("\x20\x42\x44\x56", 4));  // OpenVDB magic
  LevelSetStock back = LevelSetStock::from_vdb(bytes);
  ASSERT_EQ(back.grid_count(), 2u);
  EXPECT_EQ(back.voxel_m(1), 25 * um);
  EXPECT_EQ(back.region_box(1).max_W_m, s.region_box(1).max_W_m);
  const auto points = random_points(box_mm(-3, -3, 1.5, 3, 3, 2.1), 5000, 9);
  EXPECT_EQ(back.signed_distances(points), s.signed_distances(points));
  // It can still be cut, the same way.
  const std::vector<Pose> more = {pose_mm(-2, -1, 1.8), pose_mm(2, -1, 1.8)};
  s.cut(make_tool(ToolType::ball, 4), more);
  back.cut(make_tool(ToolType::ball, 4), more);
  EXPECT_EQ(back.signed_distances(points), s.signed_distances(points));
  EXPECT_THROW(LevelSetStock::from_vdb("not a vdb file", "x.vdb"), InputError);
}

TEST(LevelSet, BadInputIsReported) {
  EXPECT_THROW(LevelSetStock::box(box_mm(0, 0, 0, 1, 1, 0), uniform(kVoxel)), InputError);
  EXPECT_THROW(LevelSetStock::box(box_mm(0, 0, 0, 1, 1, 1), uniform(0.0)), InputError);
  LevelSetOptions o = uniform(0.1 * mm);
  o.regions.push_back(LevelSetRegion{box_mm(5, 5, 5, 6, 6, 6), kVoxel});
  EXPECT_THROW(LevelSetStock::box(box_mm(0, 0, 0, 1, 1, 1), o), InputError);
  LevelSetStock s = LevelSetStock::box(box_mm(0, 0, 0, 1, 1, 1), uniform(0.1 * mm));
  const std::vector<Pose> zero_axis = {Pose{Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()}};
  EXPECT_THROW(s.cut(make_tool(ToolType::ball, 4), zero_axis), InputError);
}

}  // namespace
}  // namespace vmsim::removal
