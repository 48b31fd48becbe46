#pragma once
// Shared by the tool path reader tests.
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <string>

#include "vmsim/common/errors.hpp"
#include "vmsim/toolpath/toolpath.hpp"

namespace vmsim::toolpath::test {

/// The message of the InputError that `parse()` throws ("" when it does not throw).
template <typename Parse>
std::string input_error_of(Parse parse) {
  try {
    parse();
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

inline void expect_vector(const Eigen::Vector3d& actual, const Eigen::Vector3d& expected,
                          double tolerance = 1e-15) {
  EXPECT_NEAR(actual.x(), expected.x(), tolerance);
  EXPECT_NEAR(actual.y(), expected.y(), tolerance);
  EXPECT_NEAR(actual.z(), expected.z(), tolerance);
}

/// A G-code program read as the file "part.nc".
inline Toolpath gcode(const std::string& text, const ReaderOptions& options = {}) {
  return parse_gcode(text, "part.nc", options);
}

/// The message of the error reading a G-code program gives ("" when it reads).
inline std::string gcode_error(const std::string& text, const ReaderOptions& options = {}) {
  return input_error_of([&] { gcode(text, options); });
}

/// The same points (tip within 1e-12 m, tool axis, kind, feed) in the same order.
inline void expect_same_points(const Toolpath& actual, const Toolpath& expected) {
  ASSERT_EQ(actual.points.size(), expected.points.size());
  for (std::size_t i = 0; i < actual.points.size(); ++i) {
    const PathPoint& a = actual.points[i];
    const PathPoint& e = expected.points[i];
    EXPECT_LE((a.tip_W_m - e.tip_W_m).norm(), 1e-12)
        << "point " << i << ": " << a.tip_W_m.transpose() << " vs " << e.tip_W_m.transpose();
    EXPECT_LE((a.axis_W - e.axis_W).norm(), 1e-15) << "point " << i;
    EXPECT_EQ(a.kind, e.kind) << "point " << i;
    EXPECT_DOUBLE_EQ(a.feed_m_per_s, e.feed_m_per_s) << "point " << i;
  }
}

}  // namespace vmsim::toolpath::test
