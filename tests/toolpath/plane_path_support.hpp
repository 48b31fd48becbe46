#pragma once
// Shared by the cutter-compensation tests (G-code, 840D, TNC): points of a read tool path in the
// compensation plane (mm), by source line, and brute-force distances to a programmed contour.
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <algorithm>
#include <cstddef>
#include <limits>
#include <vector>

#include "vmsim/toolpath/toolpath.hpp"

namespace vmsim::toolpath::test {

inline constexpr double kTight = 1e-9;  // mm: hand-computed points, to rounding

inline Eigen::Vector2d xy_mm(const PathPoint& point) { return point.tip_W_m.head<2>() * 1e3; }
inline double z_mm(const PathPoint& point) { return point.tip_W_m.z() * 1e3; }

inline int line_of(const Toolpath& path, const PathPoint& point) {
  return path.blocks[static_cast<std::size_t>(point.block)].line;
}

/// The points of the blocks on source lines [first, last].
inline std::vector<PathPoint> points_of_lines(const Toolpath& path, int first, int last) {
  std::vector<PathPoint> points;
  for (const PathPoint& point : path.points) {
    const int line = line_of(path, point);
    if (line >= first && line <= last) points.push_back(point);
  }
  return points;
}

/// The last point of the block on `line` (NaN where it has none).
inline Eigen::Vector2d end_of_line(const Toolpath& path, int line) {
  Eigen::Vector2d end = Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN());
  for (const PathPoint& point : path.points) {
    if (line_of(path, point) == line) end = xy_mm(point);
  }
  return end;
}

inline void expect_xy(const Eigen::Vector2d& actual, double x, double y, double tolerance = kTight) {
  EXPECT_NEAR(actual.x(), x, tolerance) << actual.transpose();
  EXPECT_NEAR(actual.y(), y, tolerance) << actual.transpose();
}

inline double distance_to_segment(const Eigen::Vector2d& p, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  const Eigen::Vector2d ab = b - a;
  const double t = std::clamp((p - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
  return (p - (a + t * ab)).norm();
}

/// Brute force: the distance from p to a closed polygon's edges.
inline double distance_to_polygon(const Eigen::Vector2d& p, const std::vector<Eigen::Vector2d>& polygon) {
  double d = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < polygon.size(); ++i) {
    d = std::min(d, distance_to_segment(p, polygon[i], polygon[(i + 1) % polygon.size()]));
  }
  return d;
}

}  // namespace vmsim::toolpath::test
