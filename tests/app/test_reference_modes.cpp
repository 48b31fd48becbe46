// The cheaper reference (issue 21): the planned tool path's surface as the reference, valid
// within the bound the reference run's path stages measure.
//  - CommandedPathDeviation on paths whose distance is known by construction (a delayed copy
//    shifted sideways, its axis turned, a bump, a lag beyond the search window, rapids above the
//    stock);
//  - on a small part, the simulated reference and the planned path's surface line by line, and
//    the marks of both modes, within the bound the report states.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <iostream>
#include <sstream>

#include "cli_runner.hpp"
#include "simulate_part.hpp"
#include "small_part.hpp"
#include "surface_views.hpp"
#include "validity_checks.hpp"
#include "vmsim/common/files.hpp"

namespace vmsim {
namespace {


removal::Box stock_box() { return {Eigen::Vector3d(-0.1, -0.1, -0.1), Eigen::Vector3d(0.1, 0.1, 0.1)}; }

// Along x at 1 mm/s from rest at t = 0.1 s for 0.5 s, then at rest (at height z).
Eigen::Vector3d straight_tip(double t_s, double z_m) {
  return Eigen::Vector3d(1e-3 * std::clamp(t_s - 0.1, 0.0, 0.5), 0.0, z_m);
}

constexpr double kPeriod_s = 1e-3;
constexpr double kReach_m = 0.0301;  // the tool's reach from its tip

// Commanded: straight_tip(t), axis +z; actual: straight_tip(t - lag) + offset(t), axis `axis`.
app::CommandedPathDeviation measure(double lag_s, const std::function<Eigen::Vector3d(double)>& offset,
                                    const Eigen::Vector3d& axis, double z_m = 0.0, std::size_t window = 200) {
  app::CommandedPathDeviation deviation(kReach_m, 5e-3, 30e-3, stock_box(), window);
  for (int k = 0; k <= 1000; ++k) {
    const double t = k * kPeriod_s;
    deviation.add(t, {straight_tip(t, z_m), Eigen::Vector3d::UnitZ()},
                  {straight_tip(t - lag_s, z_m) + offset(t), axis});
  }
  deviation.finish();
  return deviation;
}

TEST(CommandedPathDeviation, ADelayedCopyShiftedSidewaysIsItsShiftAway) {
  // The delay along the path leaves no trace; the 3 um sideways shift is the Hausdorff distance.
  const auto deviation = measure(0.03, [](double) { return Eigen::Vector3d(0.0, 3e-6, 0.0); }, Eigen::Vector3d::UnitZ());
  EXPECT_NEAR(deviation.deviation_m(), 3e-6, 1e-12);
  EXPECT_EQ(deviation.poses_matched(), 2u * 1001u);  // every pose of both paths
}

TEST(CommandedPathDeviation, ATurnedAxisCountsTimesTheToolsReach) {
  const double turn_rad = 1e-4;
  const Eigen::Vector3d axis(std::sin(turn_rad), 0.0, std::cos(turn_rad));
  const auto deviation = measure(0.03, [](double) { return Eigen::Vector3d::Zero(); }, axis);
  EXPECT_NEAR(deviation.deviation_m(), turn_rad * kReach_m, 1e-12);
}

TEST(CommandedPathDeviation, ABumpOffTheLineIsItsHeight) {
  // A 5 um triangular bump sideways around t = 0.35 s (width 20 ms): its top is 5 um from the
  // commanded line; the commanded points under it are nearer the bump's flanks.
  const auto bump = [](double t) {
    return Eigen::Vector3d(0.0, 5e-6 * std::max(0.0, 1.0 - std::abs(t - 0.35) / 0.01), 0.0);
  };
  const auto deviation = measure(0.03, bump, Eigen::Vector3d::UnitZ());
  EXPECT_NEAR(deviation.deviation_m(), 5e-6, 1e-12);
  EXPECT_TRUE(deviation.worst_actual());
  EXPECT_NEAR(deviation.worst_t_s(), 0.35, kPeriod_s / 2);
}

TEST(CommandedPathDeviation, ALagBeyondTheSearchWindowOnlyEnlargesTheBound) {
  // 0.3 s of lag against a window of 10 samples (10 ms): the nearest points are not searched;
  // the figure is larger than the true 3 um, never smaller.
  const auto deviation =
      measure(0.3, [](double) { return Eigen::Vector3d(0.0, 3e-6, 0.0); }, Eigen::Vector3d::UnitZ(), 0.0, 10);
  EXPECT_GT(deviation.deviation_m(), 3e-6 + 1e-9);
}

TEST(CommandedPathDeviation, PosesClearOfTheStockAreNotMatched) {
  // 1 mm off, but the whole tool 0.4 m above the stock's top: neither path removes anything.
  const auto deviation = measure(0.03, [](double) { return Eigen::Vector3d(0.0, 1e-3, 0.0); },
                                 Eigen::Vector3d::UnitZ(), 0.5);
  EXPECT_EQ(deviation.deviation_m(), 0.0);
  EXPECT_EQ(deviation.poses_matched(), 0u);
}

TEST(CommandedPathDeviation, SteepLineFactorIsTheSecantOfTheSteepestSlope) {
  // Lines are steep beyond 3 spacings of step per spacing: slope atan(3), 1 / cos = sqrt(10).
  EXPECT_NEAR(app::steep_line_factor(app::kSteepStepPerSpacing), 1.0 / std::cos(std::atan(3.0)), 1e-12);
}


struct Heights {
  int nu = 0, nv = 0;
  double spacing_m = 0.0;
  std::vector<double> length_m;
};

// A `*_heights.bin` (removal/src/output.cpp: "VMSIMNB1", nu, nv, z-map flag, origin, spacing,
// then the nu nv lengths, u fastest).
Heights read_heights(const std::filesystem::path& path) {
  const std::string bytes = read_file(path.string());
  constexpr std::size_t header = 8 + 3 * 4 + 4 * 8;
  Heights heights;
  EXPECT_EQ(bytes.substr(0, 8), "VMSIMNB1");
  std::memcpy(&heights.nu, bytes.data() + 8, 4);
  std::memcpy(&heights.nv, bytes.data() + 12, 4);
  std::memcpy(&heights.spacing_m, bytes.data() + 8 + 12 + 24, 8);
  heights.length_m.resize((bytes.size() - header) / 8);
  std::memcpy(heights.length_m.data(), bytes.data() + header, heights.length_m.size() * 8);
  EXPECT_EQ(heights.length_m.size(), static_cast<std::size_t>(heights.nu) * static_cast<std::size_t>(heights.nv));
  return heights;
}

// Lines with a neighbour more than 3 spacings higher or lower (the comparison's steep rule).
std::vector<bool> steep_lines(const Heights& h) {
  std::vector<bool> steep(h.length_m.size(), false);
  const auto at = [&](int i, int j) { return static_cast<std::size_t>(i) + static_cast<std::size_t>(h.nu) * static_cast<std::size_t>(j); };
  for (int j = 0; j < h.nv; ++j) {
    for (int i = 0; i < h.nu; ++i) {
      if (i + 1 < h.nu && std::abs(h.length_m[at(i + 1, j)] - h.length_m[at(i, j)]) > 3 * h.spacing_m) {
        steep[at(i, j)] = steep[at(i + 1, j)] = true;
      }
      if (j + 1 < h.nv && std::abs(h.length_m[at(i, j + 1)] - h.length_m[at(i, j)]) > 3 * h.spacing_m) {
        steep[at(i, j)] = steep[at(i, j + 1)] = true;
      }
    }
  }
  return steep;
}

const app::ProgressSink kSilent = [](const std::string&) {};

TEST(ReferenceModes, ThePlannedPathsSurfaceIsTheSimulatedReferenceWithinTheStatedBound) {
  const auto folder = test::fresh_folder("reference_modes");
  nlohmann::json reports[2];
  const char* names[2] = {"simulated", "commanded"};
  for (int k = 0; k < 2; ++k) {
    app::SimulatePartOptions options;
    options.part_path = test::small_part(folder, 3);
    options.out_dir = (folder / names[k]).string();
    options.grid_m = 25e-6;
    options.renders = false;
    options.reference_mode = k == 0 ? app::ReferenceMode::simulated : app::ReferenceMode::commanded;
    // A 20 um mark planted on the middle pass (as test_simulate_part): marks to compare.
    options.production_disturbance = [](double, Eigen::VectorXd& q) {
      if (q[0] >= -6e-3 && q[0] <= -4e-3 && std::abs(q[1] + 4.75e-3) < 1e-6) q[2] -= 20e-6;
    };
    reports[k] = app::simulate_part(options, kSilent);
  }
  const nlohmann::json& simulated = reports[0];
  const nlohmann::json& commanded = reports[1];
  EXPECT_EQ(simulated["reference"]["used"], "simulated");
  EXPECT_EQ(commanded["reference"]["used"], "commanded");
  // The same path stages: the same bound in both.
  const double bound_um = commanded["reference"]["surface_bound_um"].get<double>();
  EXPECT_EQ(simulated["reference"]["surface_bound_um"].get<double>(), bound_um);
  EXPECT_GT(commanded["reference"]["poses_matched"].get<double>(), 1000.0);
  // The one removal of the reference was the planned path's; the bound is the check.
  for (const auto& check : commanded["validity_checks"]) {
    if (check["id"] != "reference_vs_commanded") continue;
    EXPECT_NE(check["status"], "FAILED") << check.dump();
    EXPECT_NEAR(check["value"].get<double>(), bound_um, 1e-9);
  }
  // Each cut surface is within the trajectory's thinning tolerance of its sweep (0.05 um, tip and
  // axis x length) and each line within the steep factor of that: the two references' lines
  // may differ by the bound plus twice that.
  const double factor = commanded["reference"]["steep_factor"].get<double>();
  const double allowed_m = bound_um * 1e-6 + factor * 2 * 0.05e-6 + 1e-9;
  const Heights a = read_heights(folder / "simulated" / "reference_heights.bin");
  const Heights b = read_heights(folder / "commanded" / "reference_heights.bin");
  ASSERT_EQ(a.length_m.size(), b.length_m.size());
  const std::vector<bool> steep_a = steep_lines(a), steep_b = steep_lines(b);
  double largest_m = 0.0;
  std::size_t assessed = 0, differing = 0;
  for (std::size_t line = 0; line < a.length_m.size(); ++line) {
    if (steep_a[line] || steep_b[line]) continue;
    const double difference = std::abs(a.length_m[line] - b.length_m[line]);
    largest_m = std::max(largest_m, difference);
    ++assessed;
    differing += difference > 1e-12 ? 1 : 0;
  }
  EXPECT_GT(assessed, a.length_m.size() / 2);
  EXPECT_GT(differing, 0u);  // two different surfaces, not one file twice
  EXPECT_LE(largest_m, allowed_m) << "bound " << bound_um << " um";
  std::cout << "surface bound " << bound_um << " um; largest difference of the two references' lines "
            << largest_m * 1e6 << " um over " << assessed << " lines (" << differing << " differing)\n";
  // The marks: each one of either report deeper than the threshold by more than the allowance
  // is in the other at the same deepest line, its depth within the allowance (shallower ones
  // may fall either side of the threshold).
  ASSERT_FALSE(simulated["marks"].empty());
  EXPECT_NEAR(simulated["marks"][0]["depth_um"].get<double>(), 20.0, 0.5);
  const double threshold_um = simulated["surface"]["mark_threshold_um"].get<double>();
  for (int k = 0; k < 2; ++k) {
    const nlohmann::json& one = reports[k];
    const nlohmann::json& other = reports[1 - k];
    for (const auto& mark : one["marks"]) {
      if (mark["depth_um"].get<double>() <= threshold_um + allowed_m * 1e6) continue;
      // The other's mark of the same kind nearest to it (its deepest line may move a little).
      const nlohmann::json* nearest = nullptr;
      double nearest_mm = 1.0;
      for (const auto& candidate : other["marks"]) {
        if (candidate["kind"] != mark["kind"]) continue;
        double squared = 0.0;
        for (int i = 0; i < 3; ++i) {
          const double d = candidate["deepest_point_mm"][i].get<double>() - mark["deepest_point_mm"][i].get<double>();
          squared += d * d;
        }
        if (std::sqrt(squared) < nearest_mm) nearest_mm = std::sqrt(squared), nearest = &candidate;
      }
      ASSERT_NE(nearest, nullptr) << names[k] << " mark not in the other: " << mark.dump();
      EXPECT_NEAR((*nearest)["depth_um"].get<double>(), mark["depth_um"].get<double>(), allowed_m * 1e6)
          << mark.dump();
    }
  }
  for (const char* key : {"deviation_min_um", "deviation_max_um"}) {
    EXPECT_NEAR(simulated["surface"][key].get<double>(), commanded["surface"][key].get<double>(), allowed_m * 1e6)
        << key;
  }
  // The report says which reference and the bound.
  const std::string html = read_file((folder / "commanded" / "report.html").string());
  EXPECT_NE(html.find("Reference surface:</b> the planned tool path"), std::string::npos);
}

TEST(ReferenceModes, AutoFallsBackToTheSimulatedReferenceWhenTheBoundIsTooLarge) {
  // A fraction so small that no servo meets it: the reference run is cut, and the report says why.
  const auto folder = test::fresh_folder("reference_auto");
  app::SimulatePartOptions options;
  options.part_path = test::small_part(folder, 3);
  options.out_dir = (folder / "out").string();
  options.grid_m = 50e-6;
  options.renders = false;
  options.commanded_reference_fraction = 1e-9;
  const nlohmann::json report = app::simulate_part(options, kSilent);
  EXPECT_EQ(report["reference"]["option"], "auto");
  EXPECT_GT(report["reference"]["surface_bound_um"].get<double>(), 2.0 * 1e-9);
  EXPECT_EQ(report["reference"]["used"], "simulated");
  EXPECT_NE(report["reference"]["why"].get<std::string>().find("the reference run is cut"), std::string::npos);
  EXPECT_GT(report["runs"]["reference"]["trajectory_poses_cut"].get<double>(), 0.0);
}

TEST(ReferenceModes, TheCommandLineTakesTheModeAndRejectsOthers) {
  const test::RunResult bad = test::run_vmsim("simulate-part --no-renders --reference sometimes --out " +
                                              (test::fresh_folder("reference_bad") / "out").string());
  EXPECT_NE(bad.exit_code, 0) << bad.output;
  EXPECT_NE(bad.output.find("--reference"), std::string::npos) << bad.output;
  const test::RunResult fraction = test::run_vmsim("simulate-part --no-renders --commanded-reference-fraction 0 --out " +
                                                   (test::fresh_folder("reference_fraction") / "out").string());
  EXPECT_EQ(fraction.exit_code, 3) << fraction.output;
  EXPECT_NE(fraction.output.find("--commanded-reference-fraction"), std::string::npos) << fraction.output;
}

}  // namespace
}  // namespace vmsim
