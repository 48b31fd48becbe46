// The drive keys of issue 20: smooth friction without a stick state, the position controller's
// output dead time as a time, the feedforward timing, and a negative set-point delay; each
// against a closed form or an equivalent formulation, and the loader's located errors.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <sstream>

#include "servo_test_support.hpp"
#include "vmsim/common/errors.hpp"

namespace vmsim::servo::test {
namespace {

// Constant velocity v after `start` s of rest, `total` s long, sampled at `period`.
AxisInput constant_speed(double v, double period, double start, double total) {
  AxisInput input;
  input.period_s = period;
  const auto n = static_cast<std::size_t>(total / period);
  for (std::size_t k = 0; k <= n; ++k) {
    input.values.push_back(v * std::max(0.0, static_cast<double>(k) * period - start));
  }
  return input;
}

std::string bench_text() {
  std::ifstream in(std::string(VMSIM_SOURCE_DIR) + "/samples/machines/ballscrew_bench.yaml");
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

std::string replaced(std::string text, const std::string& from, const std::string& to) {
  const auto at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  return text.replace(at, from.size(), to);
}

// At a constant speed comparable to the tanh width, the mean current is a v + b tanh(v / w)
// (written out here), where the stick model would give a v + b.
TEST(ServoDriveKeys, SmoothFrictionAtSpeedIsViscousPlusTanh) {
  for (double v : {0.002, -0.0015}) {
    AxisServoModel model = bench_model();
    model.axis.effects.smooth_friction.enabled = true;
    model.axis.effects.smooth_friction.speed = 0.003;
    SimulationOptions options;
    options.record_period_s = 1e-3;
    const AxisSignals s = simulate_axis(model, constant_speed(v, 1e-3, 0.1, 2.0), options);
    double mean = 0.0;
    int count = 0;
    for (std::size_t k = 0; k < s.t.size(); ++k) {
      if (s.t[k] < 1.0 || s.t[k] > 1.9) continue;
      mean += s.current[k];
      ++count;
    }
    mean /= count;
    const auto& d = model.axis.drive;
    const double expected = d.friction_viscous_A_per_joint_unit_per_s * v +
                            d.friction_dry_A * std::tanh(v / 0.003);
    EXPECT_NEAR(mean, expected, 0.01) << "v = " << v;
    // The stick model would give a v + b sign(v): the test tells the two apart.
    EXPECT_GT(std::abs(d.friction_dry_A - std::abs(expected - d.friction_viscous_A_per_joint_unit_per_s * v)), 0.05);
  }
}

// An output dead time of one position period is the output delay of one sample: the same run.
TEST(ServoDriveKeys, DeadTimeOfOnePositionPeriodEqualsOneOutputSample) {
  AxisServoModel samples = bench_model();
  samples.axis.controller.position_output_delay_samples = 1;
  AxisServoModel time = samples;
  time.axis.controller.position_output_delay_samples = 0;
  time.axis.controller.position_output_dead_time_s = samples.axis.controller.position_period_s;
  const AxisInput input = jerk_limited_move(0.05, 0.1, 2.0, 100.0, 1e-3, 0.05);
  const AxisSignals a = simulate_axis(samples, input);
  const AxisSignals b = simulate_axis(time, input);
  ASSERT_EQ(a.current.size(), b.current.size());
  for (std::size_t k = 0; k < a.current.size(); ++k) {
    ASSERT_EQ(a.current[k], b.current[k]) << k;
    ASSERT_EQ(a.pos[k], b.pos[k]) << k;
  }
}

// On a constant-speed ramp (after its start) backward and central differences agree, so held
// and held_backward feedforward give the same following error; during an acceleration the
// backward one lags, and the following error differs.
TEST(ServoDriveKeys, HeldBackwardFeedforwardLagsOnlyWhereTheSpeedChanges) {
  AxisServoModel held = frictionless_bench_model();
  held.axis.controller.velocity_feedforward = true;
  held.axis.controller.feedforward_timing = kinematics::FeedforwardTiming::held;
  AxisServoModel backward = held;
  backward.axis.controller.feedforward_timing = kinematics::FeedforwardTiming::held_backward;
  const AxisInput input = constant_speed(0.05, 1e-3, 0.1, 1.0);
  const AxisSignals a = simulate_axis(held, input);
  const AxisSignals b = simulate_axis(backward, input);
  double late = 0.0, early = 0.0;
  for (std::size_t k = 0; k < a.pos.size(); ++k) {
    const double d = std::abs(a.pos[k] - b.pos[k]);
    if (a.t[k] > 0.8 && a.t[k] < 0.95) late = std::max(late, d);
    if (a.t[k] > 0.1 && a.t[k] < 0.2) early = std::max(early, d);
  }
  EXPECT_LT(late, 1e-9);
  EXPECT_GT(early, 1e-7);
}

TEST(ServoDriveKeys, LoaderReadsTheKeysAndLocatesTheirErrors) {
  const std::string text = bench_text();
  const std::string position = "position: {kv_per_s: 25, period_ms: 1, output_delay_samples: 1}";
  const kinematics::MachineModel m = kinematics::parse_machine(
      replaced(replaced(text, position, "position: {kv_per_s: 25, period_ms: 1, output_dead_time_us: 1000}"),
               "      encoder_counts_per_rev: 4000\n",
               "      encoder_counts_per_rev: 4000\n      delay_ms: -1.5\n      feedforward: {velocity: true, timing: held_backward}\n    effects:\n      smooth_friction: {speed_mm_per_s: 0.2}\n"),
      "bench.yaml");
  const auto& axis = m.axes.at(0);
  EXPECT_DOUBLE_EQ(axis.controller.position_output_dead_time_s, 1e-3);
  EXPECT_EQ(axis.controller.position_output_delay_samples, 0);
  EXPECT_DOUBLE_EQ(axis.controller.delay_s, -1.5e-3);
  EXPECT_EQ(axis.controller.feedforward_timing, kinematics::FeedforwardTiming::held_backward);
  EXPECT_TRUE(axis.effects.smooth_friction.enabled);
  EXPECT_DOUBLE_EQ(axis.effects.smooth_friction.speed, 2e-4);
  // Both forms of the output delay; a delay removing more than the loops' dead times.
  for (const auto& [from, to, words] :
       {std::tuple<std::string, std::string, std::string>{
            position, "position: {kv_per_s: 25, period_ms: 1, output_delay_samples: 1, output_dead_time_ms: 1}",
            "give the position output delay once"},
        {"      encoder_counts_per_rev: 4000\n", "      encoder_counts_per_rev: 4000\n      delay_ms: -2.5\n",
         "a negative delay removes at most"}}) {
    try {
      kinematics::parse_machine(replaced(text, from, to), "bench.yaml");
      ADD_FAILURE() << "no error for " << to;
    } catch (const InputError& e) {
      const std::string message = e.what();
      EXPECT_NE(message.find("bench.yaml:"), std::string::npos) << message;
      EXPECT_NE(message.find(words), std::string::npos) << message;
    }
  }
}

}  // namespace
}  // namespace vmsim::servo::test
