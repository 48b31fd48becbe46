// The noise model of issue 20: the white-noise level is taken from a measured signal itself,
// so a model error (any smooth content, and the corners of a motion profile) cannot raise it.
// Compared with the standard deviation the samples were drawn with.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "vmsim/identify/identify.hpp"

namespace vmsim::identify {
namespace {

TEST(NoiseModel, RobustLevelOfAMeasuredSignalIgnoresSmoothContentAndCorners) {
  std::mt19937 rng(3);
  std::normal_distribution<double> gauss(0.0, 1.0);
  const double sigma = 0.02, quantum = 0.005;
  std::vector<double> signal;
  for (int k = 0; k < 20000; ++k) {
    const double t = k * 1e-3;
    // A current-like signal: a large slow part, friction steps at reversals every 0.5 s and
    // acceleration pulses (corners) of 1.5 A.
    const double smooth = 2.0 * std::sin(2.0 * 3.14159 * 0.7 * t) + 0.3 * std::sin(2.0 * 3.14159 * 13.0 * t);
    const double steps = (static_cast<int>(t / 0.5) % 2 == 0 ? 0.4 : -0.4) +
                         (std::fmod(t, 0.25) < 0.05 ? 1.5 : 0.0);
    signal.push_back(std::round((smooth + steps + sigma * gauss(rng)) / quantum) * quantum);
  }
  const double level = robust_noise_level(signal);
  // The quantisation adds q^2/12 to the variance.
  const double expected = std::sqrt(sigma * sigma + quantum * quantum / 12.0);
  EXPECT_NEAR(level, expected, 0.06 * expected);
  // A model error of the same kind (a 13 Hz part of 0.3 A the model lacks) is not noise: the
  // fourth difference of a smooth signal is tiny. (The old estimate, from the residual's
  // second difference, counted such errors at higher frequency as noise.)
  std::vector<double> model_error(signal.size());
  for (std::size_t k = 0; k < signal.size(); ++k) {
    model_error[k] = 0.3 * std::sin(2.0 * 3.14159 * 13.0 * static_cast<double>(k) * 1e-3);
  }
  EXPECT_LT(robust_noise_level(model_error), 1e-4);
}

}  // namespace
}  // namespace vmsim::identify
