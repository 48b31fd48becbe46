// The chain streamed along the program (issue 21): the servo, the direct kinematics, the thinning,
// the actual positions' and drives' checks and the following errors run in windows of
// --servo-window-s of machine time. The window must not change a result: the same small job
// (three passes of sample part 1 on the Mikron) with windows of 13 ms (about three set points)
// and of 10^6 s (the whole run in one) gives the same report.json, key by key except the clocks,
// and the same heights (`.bin`) and marks, byte for byte. A second, separately written summary
// of the following errors (the whole run at once, as the chain computed it before it was
// streamed) gives the same figures as FollowingErrorSummary fed sample by sample.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <random>
#include <sstream>

#include "cli_runner.hpp"
#include "following_errors.hpp"
#include "simulate_part.hpp"
#include "small_part.hpp"
#include "validity_checks.hpp"
#include "vmsim/common/files.hpp"
#include "vmsim/kinematics/kinematics.hpp"
#include "vmsim/kinematics/machine_loader.hpp"

namespace vmsim {
namespace {

const std::string kRoot = VMSIM_SOURCE_DIR;


// The report without what depends on the clock or the folder.
nlohmann::json without_clocks(nlohmann::json report) {
  for (const char* key : {"stage_seconds", "stage_cpu_seconds", "stage_peak_rss_mib", "date_utc"}) report.erase(key);
  if (report.contains("context")) report["context"].erase("date_utc");
  if (report.contains("view_3d")) report["view_3d"].erase("seconds");
  for (auto& [name, run] : report["runs"].items()) {
    if (run.is_object()) run.erase("stage_seconds");
  }
  return report;
}

void expect_same_json(const nlohmann::json& a, const nlohmann::json& b, const std::string& path) {
  if (a.is_object() && b.is_object()) {
    for (auto it = a.begin(); it != a.end(); ++it) {
      ASSERT_TRUE(b.contains(it.key())) << path << "/" << it.key();
      expect_same_json(it.value(), b[it.key()], path + "/" + it.key());
    }
    EXPECT_EQ(a.size(), b.size()) << path;
  } else if (a.is_array() && b.is_array()) {
    ASSERT_EQ(a.size(), b.size()) << path;
    for (std::size_t i = 0; i < a.size(); ++i) expect_same_json(a[i], b[i], path + "/" + std::to_string(i));
  } else {
    EXPECT_EQ(a, b) << path;
  }
}

TEST(StreamChain, TheWindowChangesNoResult) {
  const auto folder = test::fresh_folder("stream_chain_windows");
  const std::string part = test::small_part(folder, 3);
  const auto progress = [](const std::string&) {};
  std::vector<nlohmann::json> reports;
  for (double window_s : {0.013, 1e6}) {
    app::SimulatePartOptions options;
    options.part_path = part;
    options.grid_m = 25e-6;
    options.renders = false;
    options.servo_window_s = window_s;
    options.out_dir = (folder / ("out_" + std::to_string(reports.size()))).string();
    reports.push_back(without_clocks(app::simulate_part(options, progress)));
  }
  ASSERT_TRUE(reports[0].contains("runs"));
  expect_same_json(reports[0], reports[1], "");
  // The outputs written, byte for byte.
  std::size_t compared = 0;
  for (const auto& entry : std::filesystem::recursive_directory_iterator(folder / "out_0")) {
    const std::string extension = entry.path().extension().string();
    if (extension != ".bin" && entry.path().filename() != "marks.csv") continue;
    const auto other = folder / "out_1" / std::filesystem::relative(entry.path(), folder / "out_0");
    EXPECT_EQ(read_file(entry.path().string()), read_file(other.string())) << entry.path();
    ++compared;
  }
  EXPECT_GT(compared, 1u);
}

// The compact Z-map's offsets spilled to memory-mapped files (--memory-budget-gb 0: all of them)
// change no result, leave nothing in the spill directory, and the report says how much went
// there; a budget that is no number of GiB is refused with exit 3 and nothing written.
TEST(StreamChain, ZmapSpilledToDiskChangesNoResult) {
  const auto folder = test::fresh_folder("stream_chain_spill");
  const std::string part = test::small_part(folder, 3);
  const auto spill_dir = folder / "spill";
  std::filesystem::create_directories(spill_dir);
  const std::string common = "-q simulate-part --part " + part + " --grid-um 25 --no-renders --compact-zmap-above-lines 0";
  const test::RunResult in_memory = test::run_vmsim(common + " --out " + (folder / "memory").string());
  ASSERT_EQ(in_memory.exit_code, 0) << in_memory.output;
  const test::RunResult spilled = test::run_vmsim(common + " --memory-budget-gb 0 --spill-dir " + spill_dir.string() +
                                                  " --out " + (folder / "spilled").string());
  ASSERT_EQ(spilled.exit_code, 0) << spilled.output;
  EXPECT_TRUE(std::filesystem::is_empty(spill_dir));
  const auto report = nlohmann::json::parse(read_file((folder / "spilled" / "report.json").string()));
  EXPECT_GT(report["surface"]["zmap_heights"]["spilled_to_disk_peak_mib"].get<double>(), 0.0);
  const auto in_memory_report = nlohmann::json::parse(read_file((folder / "memory" / "report.json").string()));
  EXPECT_EQ(in_memory_report["surface"]["zmap_heights"]["spilled_to_disk_peak_mib"].get<double>(), 0.0);
  std::size_t compared = 0;
  for (const auto& entry : std::filesystem::recursive_directory_iterator(folder / "memory")) {
    if (entry.path().extension() != ".bin" && entry.path().filename() != "marks.csv") continue;
    const auto other = folder / "spilled" / std::filesystem::relative(entry.path(), folder / "memory");
    EXPECT_EQ(read_file(entry.path().string()), read_file(other.string())) << entry.path();
    ++compared;
  }
  EXPECT_GT(compared, 1u);

  const test::RunResult refused = test::run_vmsim(common + " --memory-budget-gb -2 --out " + (folder / "refused").string());
  EXPECT_EQ(refused.exit_code, 3) << refused.output;
  EXPECT_NE(refused.output.find("--memory-budget-gb"), std::string::npos) << refused.output;
  EXPECT_FALSE(std::filesystem::exists(folder / "refused"));
}

// ---------------------------------------------------------------------------------------------
// The whole-run summary of the following errors, written apart (all samples at once).

struct WholeRun {
  std::vector<double> t_s;
  Eigen::MatrixXd q_cmd, q_actual, q_motor;
  std::vector<bool> cutting;
};

nlohmann::json whole_run_tip(const kinematics::MachineModel& machine, const WholeRun& run, double tool_length) {
  const std::size_t n = run.t_s.size();
  std::vector<Eigen::Vector3d> commanded(n);
  for (std::size_t k = 0; k < n; ++k) {
    commanded[k] = kinematics::forward_kinematics(machine, run.q_cmd.col(static_cast<Eigen::Index>(k)), tool_length).tip_W_m;
  }
  const auto window = static_cast<std::size_t>(std::ceil(0.1 / (run.t_s[1] - run.t_s[0])));
  double peak = 0.0, sum = 0.0, lag = 0.0, deflection_peak = 0.0;
  std::size_t at = 0, deflection_at = 0, count = 0;
  for (std::size_t k = 0; k < n; ++k) {
    if (!run.cutting[k]) continue;
    const Eigen::Vector3d tip =
        kinematics::forward_kinematics(machine, run.q_actual.col(static_cast<Eigen::Index>(k)), tool_length).tip_W_m;
    lag = std::max(lag, (tip - commanded[k]).norm());
    double best = (tip - commanded[k]).norm();
    const std::size_t from = k > window ? k - window : 0;
    const std::size_t to = std::min(n - 1, k + window);  // the last commanded tip read
    for (std::size_t i = from; i < to; ++i) {
      const Eigen::Vector3d a = commanded[i], b = commanded[i + 1];
      const double f = (b - a).squaredNorm() > 0 ? std::clamp((tip - a).dot(b - a) / (b - a).squaredNorm(), 0.0, 1.0) : 0.0;
      best = std::min(best, (a + f * (b - a) - tip).norm());
    }
    if (best > peak) peak = best, at = k;
    sum += best * best;
    ++count;
    Eigen::VectorXd q_motor = run.q_actual.col(static_cast<Eigen::Index>(k));
    q_motor[0] = run.q_motor(0, static_cast<Eigen::Index>(k));  // axis 0 is the elastic one here
    const double d = (tip - kinematics::forward_kinematics(machine, q_motor, tool_length).tip_W_m).norm();
    if (d > deflection_peak) deflection_peak = d, deflection_at = k;
  }
  return {{"peak", peak}, {"rms", std::sqrt(sum / static_cast<double>(count))}, {"at_t", run.t_s[at]},
          {"lag", lag}, {"deflection", deflection_peak}, {"deflection_t", run.t_s[deflection_at]}};
}

TEST(StreamChain, FollowingErrorsSampleBySampleEqualTheWholeRunsSummary) {
  kinematics::MachineModel machine = kinematics::load_machine(kRoot + "/samples/machines/mikron_ucp710.yaml");
  machine.axes[0].effects.compliance.enabled = true;  // X elastic: the motor side is read
  machine.axes[0].effects.compliance.stiffness = 1e8;
  const std::size_t axes = machine.axes.size();
  // A seeded random walk of commanded positions, actual ones a little behind and off.
  std::mt19937 random(21);
  std::normal_distribution<double> noise(0.0, 1.0);
  WholeRun run;
  const std::size_t n = 3000;
  run.q_cmd.resize(static_cast<Eigen::Index>(axes), static_cast<Eigen::Index>(n));
  run.q_actual = run.q_cmd;
  run.q_motor = run.q_cmd;
  Eigen::VectorXd q = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(axes));
  for (std::size_t k = 0; k < n; ++k) {
    run.t_s.push_back(0.5 + 0.004 * static_cast<double>(k));
    for (Eigen::Index j = 0; j < q.size(); ++j) q[j] += 1e-5 * noise(random) + (j < 3 ? 2e-5 : 1e-4);
    run.q_cmd.col(static_cast<Eigen::Index>(k)) = q;
    for (Eigen::Index j = 0; j < q.size(); ++j) {
      run.q_actual(j, static_cast<Eigen::Index>(k)) = q[j] - 3e-6 + 2e-6 * noise(random);
      run.q_motor(j, static_cast<Eigen::Index>(k)) = run.q_actual(j, static_cast<Eigen::Index>(k)) + 1e-6 * noise(random);
    }
    run.cutting.push_back(k % 700 > 50);
  }
  const double tool_length = 0.06;
  app::FollowingErrorSummary summary(machine, tool_length, true, true);
  for (std::size_t k = 0; k < n; ++k) {
    const auto i = static_cast<Eigen::Index>(k);
    summary.add(run.t_s[k], run.q_cmd.col(i), run.q_actual.col(i), run.q_motor.col(i), run.cutting[k]);
  }
  const nlohmann::json streamed = summary.finish([](double t) { return 2.0 * t; });  // s = 2 t
  const nlohmann::json whole = whole_run_tip(machine, run, tool_length);
  const auto& tip = streamed["tool_tip_while_cutting"];
  // Written apart (other rounding of the distance to a segment): equal within 1e-9 relative.
  EXPECT_NEAR(tip["contour_error_peak_um"].get<double>(), whole["peak"].get<double>() * 1e6, 1e-9 * tip["contour_error_peak_um"].get<double>());
  EXPECT_NEAR(tip["contour_error_rms_um"].get<double>(), whole["rms"].get<double>() * 1e6, 1e-9);
  EXPECT_DOUBLE_EQ(tip["at_s_mm"].get<double>(), 2.0 * whole["at_t"].get<double>() * 1e3);
  EXPECT_DOUBLE_EQ(tip["behind_the_command_peak_um"].get<double>(), whole["lag"].get<double>() * 1e6);
  EXPECT_NEAR(tip["joint_deflection_peak_um"].get<double>(), whole["deflection"].get<double>() * 1e6, 1e-9 * tip["joint_deflection_peak_um"].get<double>());
  EXPECT_DOUBLE_EQ(tip["joint_deflection_at_s_mm"].get<double>(), 2.0 * whole["deflection_t"].get<double>() * 1e3);
  // Per axis: the peaks over all samples and while cutting, and the RMS while cutting.
  for (std::size_t j = 0; j < axes; ++j) {
    const auto row = static_cast<Eigen::Index>(j);
    const double peak_all = (run.q_cmd.row(row) - run.q_actual.row(row)).cwiseAbs().maxCoeff();
    double peak = 0.0, sum = 0.0;
    std::size_t count = 0, at = 0;
    for (std::size_t k = 0; k < n; ++k) {
      if (!run.cutting[k]) continue;
      const double e = std::abs(run.q_cmd(row, static_cast<Eigen::Index>(k)) - run.q_actual(row, static_cast<Eigen::Index>(k)));
      if (e > peak) peak = e, at = k;
      sum += e * e;
      ++count;
    }
    const bool linear = machine.axes[j].type == kinematics::AxisType::linear;
    const double unit = linear ? 1e6 : 180.0 / std::numbers::pi;
    const auto& all = streamed["axes"][j];
    EXPECT_DOUBLE_EQ(linear ? all["following_error_peak_um"].get<double>() : all["following_error_peak_mdeg"].get<double>(),
                     linear ? peak_all * 1e6 : peak_all * 180.0 / std::numbers::pi * 1e3);
    const auto& cut = streamed["axes_while_cutting"][j];
    EXPECT_DOUBLE_EQ(cut[linear ? "following_error_peak_um" : "following_error_peak_deg"].get<double>(), peak * unit);
    EXPECT_NEAR(cut[linear ? "following_error_rms_um" : "following_error_rms_deg"].get<double>(),
                std::sqrt(sum / static_cast<double>(count)) * unit, 1e-12 * unit);
    EXPECT_DOUBLE_EQ(cut["at_time_s"].get<double>(), run.t_s[at]);
  }
}

// The contour error searches the commanded segments block by block, skipping blocks whose
// bounding sphere lies beyond the best distance so far, and takes the least square root once.
// Against the plain search over every segment (as FollowingErrorSummary had it, the same
// arithmetic per segment): the same figures bit for bit, on random paths that come back near
// themselves (a circle of a few mm: far samples' blocks lie near), at 0.5 ms (200 samples in
// 0.1 s), 4 ms and 40 ms (3 samples, fewer than a block).
TEST(StreamChain, ContourErrorSkippingFarBlocksEqualsThePlainSearch) {
  const kinematics::MachineModel machine = kinematics::load_machine(kRoot + "/samples/machines/mikron_ucp710.yaml");
  const std::size_t axes = machine.axes.size();
  const double tool_length = 0.06;
  for (const double period_s : {0.0005, 0.004, 0.04}) {
    std::mt19937 random(static_cast<unsigned>(period_s * 1e5));
    std::normal_distribution<double> noise(0.0, 1.0);
    const std::size_t n = 4000;
    std::vector<double> t_s;
    std::vector<bool> cutting;
    Eigen::MatrixXd q_cmd(static_cast<Eigen::Index>(axes), static_cast<Eigen::Index>(n)), q_actual = q_cmd;
    for (std::size_t k = 0; k < n; ++k) {
      const auto i = static_cast<Eigen::Index>(k);
      t_s.push_back(1.0 + period_s * static_cast<double>(k));
      const double angle = 2.0 * std::numbers::pi * static_cast<double>(k) / 350.0;
      for (Eigen::Index j = 0; j < q_cmd.rows(); ++j) q_cmd(j, i) = j < 3 ? 0.003 * std::cos(angle + static_cast<double>(j)) : 0.01 * std::sin(angle);
      q_cmd(2, i) = 0.0005 * std::sin(3 * angle);
      // Behind the command by 5 samples (the lag), and a little off.
      const Eigen::Index behind = i - std::min<Eigen::Index>(i, 5);
      for (Eigen::Index j = 0; j < q_cmd.rows(); ++j) q_actual(j, i) = q_cmd(j, behind) + 2e-6 * noise(random) - 1e-6;
      cutting.push_back(k % 900 > 30);
    }
    app::FollowingErrorSummary summary(machine, tool_length, true, false);
    for (std::size_t k = 0; k < n; ++k) {
      const auto i = static_cast<Eigen::Index>(k);
      summary.add(t_s[k], q_cmd.col(i), q_actual.col(i), q_actual.col(i), cutting[k]);
    }
    const nlohmann::json tip = summary.finish([](double t) { return t; })["tool_tip_while_cutting"];
    // The plain search.
    std::vector<Eigen::Vector3d> commanded(n);
    for (std::size_t k = 0; k < n; ++k) commanded[k] = kinematics::forward_kinematics(machine, q_cmd.col(static_cast<Eigen::Index>(k)), tool_length).tip_W_m;
    const auto window = static_cast<std::size_t>(std::ceil(0.1 / (t_s[1] - t_s[0])));
    double peak = 0.0, sum = 0.0, at = t_s[0];
    for (std::size_t k = 0; k < n; ++k) {
      if (!cutting[k]) continue;
      const Eigen::Vector3d tip_now = kinematics::forward_kinematics(machine, q_actual.col(static_cast<Eigen::Index>(k)), tool_length).tip_W_m;
      double deviation = (tip_now - commanded[k]).norm();
      for (std::size_t i = k > window ? k - window : 0; i + 1 < n && i < k + window; ++i) {
        const Eigen::Vector3d segment = commanded[i + 1] - commanded[i];
        const double length2 = segment.squaredNorm();
        const double f = length2 > 0.0 ? std::clamp((tip_now - commanded[i]).dot(segment) / length2, 0.0, 1.0) : 0.0;
        deviation = std::min(deviation, (tip_now - commanded[i] - f * segment).norm());
      }
      if (deviation > peak) peak = deviation, at = t_s[k];
      sum += deviation * deviation;
    }
    EXPECT_EQ(tip["contour_error_peak_um"].get<double>(), peak * 1e6) << period_s;
    EXPECT_EQ(tip["at_s_mm"].get<double>(), at * 1e3) << period_s;
    // The RMS: the same sum of squares in the same order.
    std::size_t count = 0;
    for (bool c : cutting) count += c ? 1 : 0;
    EXPECT_EQ(tip["contour_error_rms_um"].get<double>(), std::sqrt(sum / static_cast<double>(count)) * 1e6) << period_s;
    EXPECT_GT(peak, 1e-7) << period_s;  // a contour error to find, well apart from the lag
    EXPECT_LT(peak, 0.5 * tip["behind_the_command_peak_um"].get<double>() * 1e-6) << period_s;
  }
}

// The actual positions' and the drives' checks fed sample by sample against hand-made cases.
TEST(StreamChain, TravelAndSaturationChecksNameTheWorstAxisAndTheFirstTime) {
  kinematics::MachineModel machine = kinematics::load_machine(kRoot + "/samples/machines/mikron_ucp710.yaml");
  app::ActualTravelCheck travel(machine, "reference");
  Eigen::VectorXd q = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(machine.axes.size()));
  for (std::size_t j = 0; j < machine.axes.size(); ++j) q[static_cast<Eigen::Index>(j)] = machine.axes[j].home;
  travel.add(0.0, q);
  EXPECT_EQ(travel.result().status, app::CheckStatus::passed);
  Eigen::VectorXd beyond = q;
  beyond[1] = machine.axes[1].travel_max + 2e-3;  // Y 2 mm beyond
  travel.add(1.0, beyond);
  beyond[1] = machine.axes[1].travel_max + 2e-3;  // the same again later: the first is named
  travel.add(2.0, beyond);
  beyond[1] = q[1];
  beyond[0] = machine.axes[0].travel_min - 1e-3;  // X 1 mm: less
  travel.add(3.0, beyond);
  const app::ValidityCheck check = travel.result();
  EXPECT_EQ(check.status, app::CheckStatus::warning);
  EXPECT_NEAR(check.value, 2.0, 1e-9);
  EXPECT_NE(check.detail.find("axis Y"), std::string::npos) << check.detail;
  EXPECT_NE(check.detail.find("t = 1.0000 s"), std::string::npos) << check.detail;

  machine.axes[2].controller.current_max_A = 10.0;
  app::DriveSaturationCheck saturation(machine, "reference");
  Eigen::VectorXd current = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(machine.axes.size()));
  for (int k = 0; k < 10; ++k) {
    current[2] = k >= 6 ? -9.99 : 5.0;  // at the limit in 3 of the 8 cutting samples (k = 6, 7, 8)
    saturation.add(0.1 * k, current, k != 0 && k != 9);
  }
  const app::ValidityCheck drives = saturation.result();
  EXPECT_EQ(drives.status, app::CheckStatus::warning);
  EXPECT_NEAR(drives.value, 100.0 * 3.0 / 8.0, 1e-9);
  EXPECT_NE(drives.detail.find("first at t = 0.6000 s"), std::string::npos) << drives.detail;
}

}  // namespace
}  // namespace vmsim
