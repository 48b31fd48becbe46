#pragma once
// Shared by the tool path reader tests.
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <string>

#include "vmsim/common/errors.hpp"

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

}  // namespace vmsim::toolpath::test
