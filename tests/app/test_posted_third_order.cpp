// `vmsim plan` in third order (jerk limits, as SOFT on an 840D) on the posted programs whose
// third-order plan used to fail: Fusion 360 in mm and inch (an internal error: the programme's
// scan judged x clamped at 0 where the rows saw it 6e-7 below), Haas and FreeCAD/LinuxCNC with
// their blended corners (no profile: a denormal q_sss of an axis that does not move made a
// speed cap of 0 inside a stretch). Checked from outside: exit 0, the set points' finite
// differences within the machine file's velocity, acceleration and jerk limits, and a duration
// no shorter than the second-order plan's (a jerk limit can only slow the motion down).
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <algorithm>
#include <nlohmann/json.hpp>
#include <numbers>
#include <string>
#include <vector>

#include "cli_runner.hpp"
#include "vmsim/common/files.hpp"
#include "vmsim/common/trace.hpp"
#include "vmsim/kinematics/machine_loader.hpp"

namespace vmsim {
namespace {

const std::string kRoot = VMSIM_SOURCE_DIR;
const std::string kMikron = kRoot + "/samples/machines/mikron_ucp710.yaml";  // the four part files' machine

struct LimitRatios {
  double velocity = 0, acceleration = 0, jerk = 0;  ///< largest |finite difference| / limit over the axes
};

// Backward velocity, centred acceleration, backward-centred jerk at the period, the motion
// held at rest outside the samples: each a weighted mean of the continuous derivative.
LimitRatios limit_ratios(const std::filesystem::path& setpoints, const kinematics::MachineModel& machine) {
  const Trace trace = read_trace(setpoints.string());
  const double T = std::stod(trace.metadata_value("period_s").value());
  const std::size_t axes = machine.axis_count();
  std::vector<std::vector<double>> q(axes);
  for (std::size_t j = 0; j < axes; ++j) {
    const auto& axis = machine.axes[j];
    const double scale = axis.type == kinematics::AxisType::linear ? 1e-3 : std::numbers::pi / 180.0;
    for (double value : trace.column(axis.name + ".cmd")) q[j].push_back(value * scale);
  }
  const long n = static_cast<long>(q[0].size());
  LimitRatios out;
  for (std::size_t j = 0; j < axes; ++j) {
    auto at = [&](long k) { return q[j][static_cast<std::size_t>(std::clamp(k, 0L, n - 1))]; };
    const auto& limits = machine.axes[j].limits;
    for (long k = -1; k <= n; ++k) {
      const double v = (at(k) - at(k - 1)) / T;
      const double a = (at(k + 1) - 2 * at(k) + at(k - 1)) / (T * T);
      const double jerk = (at(k + 1) - 3 * at(k) + 3 * at(k - 1) - at(k - 2)) / (T * T * T);
      if (limits.velocity_max > 0) out.velocity = std::max(out.velocity, std::abs(v) / limits.velocity_max);
      if (limits.acceleration_max > 0) out.acceleration = std::max(out.acceleration, std::abs(a) / limits.acceleration_max);
      if (limits.jerk_max > 0) out.jerk = std::max(out.jerk, std::abs(jerk) / limits.jerk_max);
    }
  }
  return out;
}

class PostedThirdOrder : public ::testing::TestWithParam<std::string> {};

TEST_P(PostedThirdOrder, PlansWithinTheJerkLimits) {
  const std::string name = GetParam();
  const std::string part = kRoot + "/tests/data/posted/" + name + "/part.yaml";
  const auto folder = test::fresh_folder("posted_third_order_" + name);
  const test::RunResult third = test::run_vmsim("-q plan --part " + part + " --third-order --no-plot --out " +
                                                (folder / "third").string());
  ASSERT_EQ(third.exit_code, 0) << third.output;
  const test::RunResult second = test::run_vmsim("-q plan --part " + part + " --no-third-order --no-plot --out " +
                                                 (folder / "second").string());
  ASSERT_EQ(second.exit_code, 0) << second.output;
  const auto summary = [&](const char* run) {
    return nlohmann::json::parse(read_file((folder / run / "summary.json").string()));
  };
  const double t_third = summary("third")["duration_s"], t_second = summary("second")["duration_s"];
  EXPECT_GE(t_third, t_second * (1.0 - 1e-9)) << "third " << t_third << " s, second " << t_second << " s";
  EXPECT_LT(t_third, 3.0 * t_second);  // not a crawl

  const kinematics::MachineModel machine = kinematics::load_machine(kMikron);
  const LimitRatios ratios = limit_ratios(folder / "third" / "setpoints.csv", machine);
  EXPECT_LE(ratios.velocity, 1.0 + 1e-4);
  EXPECT_LE(ratios.acceleration, 1.0 + 1e-4);
  EXPECT_LE(ratios.jerk, 1.0 + 1e-3);
  EXPECT_GT(ratios.jerk, 0.3);  // the jerk limits are reached, not merely held
  std::printf("%s: T %.3f s third order, %.3f s second order; largest velocity %.4f, acceleration %.4f, jerk %.4f "
              "of the limits\n",
              name.c_str(), t_third, t_second, ratios.velocity, ratios.acceleration, ratios.jerk);
}

INSTANTIATE_TEST_SUITE_P(Corpus, PostedThirdOrder,
                         ::testing::Values("fusion360_mm", "fusion360_inch", "haas", "freecad_linuxcnc"));

}  // namespace
}  // namespace vmsim
