// Identification against known values: data from the independent truth simulator with known
// friction, inertia, offset and delay (plus noise and quantisation); the identified values must
// be within stated tolerances. Also the signal helpers, the bench's force-only log, and the
// machine-file round trip.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <numbers>
#include <random>

#include "truth_sim.hpp"
#include "vmsim/common/errors.hpp"
#include "vmsim/common/files.hpp"
#include "vmsim/identify/diagnose.hpp"
#include "vmsim/kinematics/machine_loader.hpp"

namespace vmsim::identify::test {
namespace {

const std::string kBench = std::string(VMSIM_SOURCE_DIR) + "/samples/machines/ballscrew_bench.yaml";

TEST(Signals, ZeroPhaseLowpassKeepsThePhaseOfASlowSine) {
  const double h = 1e-3;
  std::vector<double> x(4000);
  for (std::size_t i = 0; i < x.size(); ++i) x[i] = std::sin(2.0 * std::numbers::pi * 5.0 * static_cast<double>(i) * h);
  const std::vector<double> y = zero_phase_lowpass(x, h, 50.0);
  // 5 Hz through a 50 Hz Butterworth twice: gain 1 within 1e-3, no delay.
  for (std::size_t i = 500; i < 3500; ++i) EXPECT_NEAR(y[i], x[i], 2e-3) << i;
}

TEST(Signals, NoiseLevelOfWhiteNoiseOnASmoothSignal) {
  std::mt19937 rng(3);
  std::normal_distribution<double> gauss(0.0, 0.02);
  std::vector<double> x(20000);
  for (std::size_t i = 0; i < x.size(); ++i) x[i] = std::sin(1e-3 * static_cast<double>(i)) + gauss(rng);
  EXPECT_NEAR(noise_level(x), 0.02, 0.001);
}

// Known values drawn from seeded ranges; the baseline machine file starts from the nominal ones.
// Tolerances: J_eq 3 %, viscous 5 %, dry 0.02 A, offset 0.02 A, delay 0.2 ms.
TEST(Identify, RecoversFrictionInertiaOffsetAndDelay) {
  const kinematics::MachineModel machine = kinematics::load_machine(kBench);
  for (std::uint32_t seed : {11u, 12u}) {
    std::mt19937 rng(seed);
    auto uniform = [&](double lo, double hi) {
      return std::uniform_real_distribution<double>(lo, hi)(rng);
    };
    TruthDrive truth;
    truth.dry_A = uniform(0.25, 0.45);
    truth.viscous_A_s_per_m = uniform(2.5, 4.0);
    truth.inertia *= uniform(1.1, 1.4);
    truth.offset_A = uniform(-0.3, 0.3);
    truth.delay_s = uniform(1.0e-3, 3.0e-3);
    const std::vector<double> sp = generic_excitation(1e-3);
    const Trace trace = simulate_truth(truth, sp, seed);
    const auto data = extract_measurements(machine, trace, "truth");
    const auto results = identify_axes(machine, data);
    ASSERT_EQ(results.size(), 1u);
    const AxisIdentification& r = results[0];
    // Stated tolerances.
    EXPECT_NEAR(r.equivalent_inertia_kg_m2, truth.inertia, 0.03 * truth.inertia) << seed;
    EXPECT_NEAR(r.friction_viscous_A_per_joint_unit_per_s, truth.viscous_A_s_per_m,
                0.05 * truth.viscous_A_s_per_m) << seed;
    EXPECT_NEAR(r.friction_dry_A, truth.dry_A, 0.02) << seed;
    EXPECT_NEAR(r.offset_A, truth.offset_A, 0.02) << seed;
    EXPECT_NEAR(r.delay_s, truth.delay_s, 0.2e-3) << seed;
    EXPECT_GT(r.r2, 0.9);
    EXPECT_LT(r.simulation_effort_rms_A, 0.5 * r.simulation_effort_rms_before_A);
    std::printf("seed %u: J %.4g (truth %.4g) kg m^2, a %.3g (%.3g) A s/m, b %.3g (%.3g) A, "
                "offset %.3g (%.3g) A, delay %.3g (%.3g) ms, R^2 %.4f, RMS %.3g A, closed-loop "
                "effort RMS %.3g -> %.3g A\n",
                seed, r.equivalent_inertia_kg_m2, truth.inertia,
                r.friction_viscous_A_per_joint_unit_per_s, truth.viscous_A_s_per_m,
                r.friction_dry_A, truth.dry_A, r.offset_A, truth.offset_A, r.delay_s * 1e3,
                truth.delay_s * 1e3, r.r2, r.residual_rms_A, r.simulation_effort_rms_before_A,
                r.simulation_effort_rms_A);

    // The updated machine file loads and carries the values.
    kinematics::MachineModel updated = machine;
    apply_identification(updated, r);
    const std::string text = updated_machine_yaml(read_file(kBench), updated, {{"X", "test"}},
                                                  kBench, std::string(VMSIM_SOURCE_DIR) + "/samples/machines");
    const kinematics::MachineModel loaded = kinematics::parse_machine(text, "updated.yaml");
    EXPECT_DOUBLE_EQ(loaded.axes[0].drive.equivalent_inertia_kg_m2, r.equivalent_inertia_kg_m2);
    EXPECT_DOUBLE_EQ(loaded.axes[0].controller.delay_s, r.delay_s);
    EXPECT_DOUBLE_EQ(loaded.axes[0].drive.friction_dry_A, r.friction_dry_A);
  }
}

// The laboratory bench's log: reference, measured position and force command only (no current,
// no load scale). The effort is converted from N; effects that need a load scale are reported
// as not observable; a hidden viscous-friction error is still found.
TEST(Diagnose, BenchLogWithForceOnly) {
  const kinematics::MachineModel machine = kinematics::load_machine(kBench);
  TruthDrive truth;
  truth.viscous_A_s_per_m *= 3.0;
  const std::vector<double> sp = generic_excitation(1e-3);
  const Trace full = simulate_truth(truth, sp, 7);
  Trace log;
  log.columns = {"t", "X.cmd", "X.pos", "X.force"};
  const double newton_per_A = machine.axes[0].drive.torque_constant_N_m_per_A / machine.axes[0].drive.ratio;
  std::vector<double> force = full.column("X.cur");
  for (double& f : force) f *= newton_per_A;
  log.values = {full.column("t"), full.column("X.cmd"), full.column("X.pos"), force};
  const auto data = extract_measurements(machine, log, "bench.csv");
  ASSERT_EQ(data.size(), 1u);
  EXPECT_EQ(data[0].effort_signal, "force");
  EXPECT_TRUE(data[0].pos2.empty());
  EXPECT_NEAR(data[0].effort_A[100], full.column("X.cur")[100], 1e-12);
  const Diagnosis d = diagnose(machine, data, {});
  ASSERT_EQ(d.axes.size(), 1u);
  ASSERT_FALSE(d.axes[0].found.empty());
  EXPECT_EQ(d.axes[0].found[0].effect, "viscous_friction");
  for (const auto& c : d.axes[0].first_round) {
    if (c.effect == "backlash" || c.effect == "pitch_error") {
      EXPECT_FALSE(c.found);
      EXPECT_NE(c.evidence.find("not observable"), std::string::npos);
    }
  }
  // The outputs: JSON names the effect, the extended machine loads, the CSV reads back.
  const std::string json = diagnosis_json(d, machine, "bench.csv");
  EXPECT_NE(json.find("\"viscous_friction\""), std::string::npos);
  std::vector<AxisNote> notes;
  const kinematics::MachineModel extended = extended_machine(machine, d, notes);
  const std::string yaml = updated_machine_yaml(read_file(kBench), extended, notes, kBench);
  EXPECT_NEAR(kinematics::parse_machine(yaml, "x.yaml").axes[0].drive.friction_viscous_A_per_joint_unit_per_s,
              truth.viscous_A_s_per_m, 0.15 * truth.viscous_A_s_per_m);
  const Trace residuals = parse_trace(residuals_csv(d, machine), "residuals.csv");
  EXPECT_EQ(residuals.sample_count(), data[0].t.size());
  EXPECT_TRUE(residuals.column_index("X_effort_residual_after_A").has_value());
  EXPECT_FALSE(diagnosis_report(d, machine, "bench.csv").empty());
}

TEST(Diagnose, RejectsATraceWithoutEffort) {
  const kinematics::MachineModel machine = kinematics::load_machine(kBench);
  Trace log;
  log.columns = {"t", "X.cmd", "X.pos"};
  log.values = {std::vector<double>(20), std::vector<double>(20), std::vector<double>(20)};
  for (std::size_t i = 0; i < 20; ++i) log.values[0][i] = 1e-3 * static_cast<double>(i);
  EXPECT_THROW(extract_measurements(machine, log, "x.csv"), InputError);
}

// An axis that stands still the whole trace (the A and C axes of a 3-axis part program) gave the
// periodic fits (cogging, pitch error) no period at all, and diagnose crashed on it.
TEST(Diagnose, AnAxisAtStandstillFindsNothingAndDoesNotCrash) {
  const kinematics::MachineModel machine = kinematics::load_machine(kBench);
  Trace log;
  log.columns = {"t", "X.cmd", "X.pos", "X.cur"};
  const std::size_t n = 2000;
  log.values.assign(4, std::vector<double>(n, 0.0));
  for (std::size_t i = 0; i < n; ++i) {
    log.values[0][i] = 1e-3 * static_cast<double>(i);
    log.values[1][i] = log.values[2][i] = 5.0;
  }
  const auto data = extract_measurements(machine, log, "standstill.csv");
  const Diagnosis d = diagnose(machine, data, {});
  // An axis the trace holds still is listed, not diagnosed (nothing of its drive shows).
  EXPECT_TRUE(d.axes.empty());
  ASSERT_EQ(d.held_axes.size(), 1u);
  EXPECT_EQ(d.held_axes[0].axis_name, "X");
  EXPECT_NE(d.held_axes[0].reason.find("held still"), std::string::npos) << d.held_axes[0].reason;
}

}  // namespace
}  // namespace vmsim::identify::test

namespace vmsim::identify {
namespace {

// A robot's joints default to friction on the motor side; a machine file that says `load` for
// one of them must say so again after identify writes it back (the writer used to leave the key
// out, and the loader's robot default turned it into `motor`).
// identify and calibrate write the machine file into a result folder: a URDF the original names
// relative to its own folder must still load from there.
TEST(MachineYaml, ARelativeUrdfPathStillLoadsFromAnotherFolder) {
  const std::string folder = std::string(VMSIM_SOURCE_DIR) + "/samples/machines";
  const std::string path = folder + "/kr180_class_urdf.yaml";
  const kinematics::MachineModel robot = kinematics::load_machine(path);
  const std::string yaml = updated_machine_yaml(read_file(path), robot, {}, path, folder);
  const std::filesystem::path elsewhere = std::filesystem::temp_directory_path();
  const kinematics::MachineModel back = kinematics::parse_machine(yaml, "written", elsewhere.string());
  ASSERT_EQ(back.axes.size(), robot.axes.size());
  EXPECT_NE(yaml.find((std::filesystem::path(folder) / "kr180_class.urdf").lexically_normal().string()),
            std::string::npos);
}

TEST(MachineYaml, TheFrictionSideOfAnElasticJointSurvivesTheRoundTrip) {
  const std::string path = std::string(VMSIM_SOURCE_DIR) + "/samples/machines/kr180_class.yaml";
  kinematics::MachineModel robot = kinematics::load_machine(path);
  std::size_t elastic = 0;
  for (auto& axis : robot.axes) {
    if (!axis.effects.compliance.enabled) continue;
    ASSERT_EQ(axis.effects.compliance.friction_side, kinematics::FrictionSide::motor) << axis.name;
    if (elastic++ == 0) axis.effects.compliance.friction_side = kinematics::FrictionSide::load;
  }
  ASSERT_GT(elastic, 0u);
  const std::string yaml = updated_machine_yaml(read_file(path), robot, {}, path, std::string(VMSIM_SOURCE_DIR) + "/samples/machines");
  const kinematics::MachineModel back = kinematics::parse_machine(yaml, path, std::string(VMSIM_SOURCE_DIR) + "/samples/machines");
  ASSERT_EQ(back.axes.size(), robot.axes.size());
  for (std::size_t j = 0; j < robot.axes.size(); ++j) {
    if (!robot.axes[j].effects.compliance.enabled) continue;
    EXPECT_EQ(back.axes[j].effects.compliance.friction_side, robot.axes[j].effects.compliance.friction_side)
        << robot.axes[j].name;
  }
}

}  // namespace
}  // namespace vmsim::identify
