// The diagnosis against an independent truth: "measured" data from a truth simulator that holds
// one effect the baseline model lacks (each effect of the catalogue in turn, parameters drawn
// from seeded ranges, noise and quantisation, one generic excitation). The diagnosis must name
// that effect first and the extended model must at least halve the validation residual; with no
// hidden effect it must find nothing. The table effects x (found, rank, gain) is printed.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <map>
#include <random>

#include "truth_sim.hpp"
#include "vmsim/identify/diagnose.hpp"
#include "vmsim/kinematics/machine_loader.hpp"

namespace vmsim::identify::test {
namespace {

std::string num(double v) {
  char text[32];
  std::snprintf(text, sizeof text, "%.3g", v);
  return text;
}

const std::string kBench = std::string(VMSIM_SOURCE_DIR) + "/samples/machines/ballscrew_bench.yaml";

// The truth for one hidden effect ("none": the baseline itself), parameters from `seed`.
TruthDrive truth_with(const std::string& effect, std::uint32_t seed,
                      const std::vector<double>& setpoints) {
  std::mt19937 rng(seed);
  auto uniform = [&](double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(rng); };
  auto coin = [&] { return uniform(0.0, 1.0) < 0.5; };
  TruthDrive p;
  const double lead = 0.01;
  if (effect == "coulomb_friction") {
    p.dry_A = coin() ? p.dry_A * uniform(2.0, 2.8) : p.dry_A * uniform(0.0, 0.3);
    p.description = "dry " + num(p.dry_A) + " A";
  } else if (effect == "viscous_friction") {
    p.viscous_A_s_per_m *= uniform(2.5, 3.5);
    p.description = "viscous " + num(p.viscous_A_s_per_m) + " A s/m";
  } else if (effect == "asymmetric_friction") {
    // One direction rubs harder (dry and viscous), the other less.
    const bool up = coin();
    const double hi = uniform(1.6, 2.4), lo = uniform(0.3, 0.6);
    p.asymmetric = true;
    p.dry_positive_A = p.dry_A * (up ? hi : lo);
    p.dry_negative_A = p.dry_A * (up ? lo : hi);
    p.viscous_positive_A_s_per_m = p.viscous_A_s_per_m * (up ? hi : lo);
    p.viscous_negative_A_s_per_m = p.viscous_A_s_per_m * (up ? lo : hi);
    p.description = "dry +" + num(p.dry_positive_A) + " / -" + num(p.dry_negative_A) +
                    " A, viscous +" + num(p.viscous_positive_A_s_per_m) + " / -" +
                    num(p.viscous_negative_A_s_per_m) + " A s/m";
  } else if (effect == "stribeck_friction") {
    p.stribeck_static_A = p.dry_A + uniform(0.3, 0.5);
    p.stribeck_velocity = uniform(1e-3, 4e-3);
    p.description = "static " + num(p.stribeck_static_A) + " A, v_s " +
                    num(p.stribeck_velocity * 1e3) + " mm/s";
  } else if (effect == "backlash") {
    p.backlash_gap = uniform(10e-6, 30e-6);
    p.description = "gap " + num(p.backlash_gap * 1e6) + " um";
  } else if (effect == "cogging") {
    const int choices[] = {6, 8, 10, 12};
    p.cogging_periods = choices[std::uniform_int_distribution<int>(0, 3)(rng)];
    p.cogging_N_m = uniform(0.05, 0.09);
    p.cogging_phase = uniform(-3.1, 3.1);
    p.description = num(p.cogging_periods) + "/rev, " + num(p.cogging_N_m) + " N m";
  } else if (effect == "pitch_error") {
    p.pitch_amplitude = uniform(4e-6, 10e-6);
    p.pitch_period = lead;
    p.pitch_phase = uniform(-3.1, 3.1);
    p.description = "period 10 mm, " + num(p.pitch_amplitude * 1e6) + " um";
  } else if (effect == "compliance") {
    // Two-mass mode between 80 and 160 Hz.
    const double f = uniform(80.0, 160.0), w = 2.0 * 3.141592653589793 * f;
    const double jm = p.rotor_inertia, jl = p.inertia - p.rotor_inertia;
    p.stiffness = w * w * jm * jl / (jm + jl) / (p.ratio * p.ratio);
    p.damping_ratio = uniform(0.03, 0.1);
    p.description = "mode " + num(f) + " Hz, damping " + num(p.damping_ratio);
  } else if (effect == "delay") {
    p.delay_s = uniform(1.5e-3, 4e-3);
    p.description = "delay " + num(p.delay_s * 1e3) + " ms";
  } else if (effect == "gravity") {
    p.offset_A = uniform(0.2, 0.4) * (coin() ? 1.0 : -1.0);
    p.description = "offset " + num(p.offset_A) + " A";
  } else if (effect == "current_saturation") {
    const double peak = peak_current(simulate_truth(p, setpoints, seed));
    p.current_max_A = peak * uniform(0.55, 0.7);
    p.description = "limit " + num(p.current_max_A) + " A";
  } else if (effect == "inertia") {
    p.inertia *= coin() ? uniform(1.3, 1.6) : uniform(0.65, 0.8);
    p.rotor_inertia = std::min(p.rotor_inertia, 0.9 * p.inertia);
    p.description = "J_eq " + num(p.inertia) + " kg m^2";
  }
  return p;
}

struct Outcome {
  bool found = false;
  int rank = 0;  // in the forward selection (1 = first); 0 = not found
  int first_round_rank = 0;
  double gain = 0.0;  // 1 - weighted RMS after / before on the validation data
  std::string first;
  std::string channel;
  double other_ratio = 1.0;
  std::string truth, fitted;
  double before = 0.0, after = 0.0;
};

std::map<std::string, Outcome>& outcomes() {
  static std::map<std::string, Outcome> table;
  return table;
}

Outcome run_case(const std::string& effect, std::uint32_t seed) {
  const kinematics::MachineModel machine = kinematics::load_machine(kBench);
  const std::vector<double> sp = generic_excitation(1e-3);
  const TruthDrive truth = truth_with(effect, seed, sp);
  const Trace trace = simulate_truth(truth, sp, seed + 1000);
  const auto data = extract_measurements(machine, trace, "truth:" + effect);
  const Diagnosis d = diagnose(machine, data, {});
  const AxisDiagnosis& axis = d.axes.at(0);
  Outcome o;
  for (std::size_t i = 0; i < axis.found.size(); ++i) {
    if (axis.found[i].effect == effect) {
      o.found = true;
      o.rank = static_cast<int>(i) + 1;
    }
  }
  for (std::size_t i = 0; i < axis.first_round.size(); ++i) {
    if (axis.first_round[i].effect == effect) o.first_round_rank = static_cast<int>(i) + 1;
  }
  o.first = axis.found.empty() ? "(none)" : axis.found.front().effect;
  o.truth = truth.description;
  o.fitted = axis.found.empty() ? "" : axis.found.front().evidence;
  // The residual that carries the evidence: the effort, or the load-minus-motor position
  // (the channel that falls most); the other one must not grow by more than 10 %.
  const double effort_ratio = axis.after.effort_rms_A / axis.before.effort_rms_A;
  const double diff_ratio = axis.before.load_diff_rms > 0.0
                                ? axis.after.load_diff_rms / axis.before.load_diff_rms
                                : 1.0;
  const bool diff = diff_ratio < effort_ratio;
  o.channel = diff ? "load-motor" : "effort";
  o.before = diff ? axis.before.load_diff_rms : axis.before.effort_rms_A;
  o.after = diff ? axis.after.load_diff_rms : axis.after.effort_rms_A;
  o.other_ratio = diff ? effort_ratio : diff_ratio;
  o.gain = 1.0 - o.after / o.before;
  std::cout << "[" << effect << "] first round:";
  for (const auto& c : axis.first_round) {
    std::cout << " " << c.effect << "(" << c.relative_gain << (c.found ? ",found" : "") << ")";
  }
  std::cout << "\n  found:";
  for (const auto& c : axis.found) std::cout << " " << c.effect << " [" << c.evidence << "]";
  std::cout << "\n  " << o.channel << " RMS " << o.before << " -> " << o.after << ", effort RMS "
            << axis.before.effort_rms_A << " -> " << axis.after.effort_rms_A
            << " A, noise " << axis.effort_noise_A << " A\n";
  outcomes()[effect] = o;
  return o;
}

class HiddenEffect : public ::testing::TestWithParam<std::string> {};

TEST_P(HiddenEffect, IsNamedFirstAndHalvesTheValidationResidual) {
  const std::string effect = GetParam();
  // VMSIM_IDENTIFY_SEED (optional) draws another set of truths, for robustness runs by hand.
  const char* extra = std::getenv("VMSIM_IDENTIFY_SEED");
  const std::uint32_t seed = 17u + static_cast<std::uint32_t>(extra ? std::atoi(extra) : 0) +
                             static_cast<std::uint32_t>(std::hash<std::string>{}(effect) % 1000u);
  const Outcome o = run_case(effect, seed);
  EXPECT_EQ(o.first, effect);
  EXPECT_LE(o.after, 0.5 * o.before) << effect;
  EXPECT_LE(o.other_ratio, 1.1) << effect;
}

INSTANTIATE_TEST_SUITE_P(Catalogue, HiddenEffect,
                         ::testing::Values("coulomb_friction", "viscous_friction",
                                           "asymmetric_friction", "stribeck_friction", "backlash",
                                           "cogging", "pitch_error", "compliance", "delay",
                                           "gravity", "current_saturation", "inertia"),
                         [](const ::testing::TestParamInfo<std::string>& param_info) { return param_info.param; });

TEST(Control, NoHiddenEffectFindsNothing) {
  const char* extra = std::getenv("VMSIM_IDENTIFY_SEED");
  const Outcome o = run_case("none", 5u + static_cast<std::uint32_t>(extra ? std::atoi(extra) : 0));
  EXPECT_EQ(o.first, "(none)");
}

// Prints the closing table after every test has run.
class TableEnvironment : public ::testing::Environment {
 public:
  void TearDown() override {
    if (outcomes().empty()) return;
    std::printf("\n| hidden effect | named first | found | rank | first-round rank of the hidden "
                "effect | validation residual (RMS) | truth | fitted |\n");
    std::printf("|---|---|---|---|---|---|---|---|\n");
    for (const auto& [effect, o] : outcomes()) {
      const bool effort = o.channel == "effort";
      std::printf("| %s | %s | %s | %d | %d | %s: -%.0f %% (%.3g -> %.3g %s) | %s | %s |\n",
                  effect.c_str(), o.first.c_str(), o.found ? "yes" : "no", o.rank,
                  o.first_round_rank, o.channel.c_str(), 100.0 * o.gain,
                  effort ? o.before : o.before * 1e6, effort ? o.after : o.after * 1e6,
                  effort ? "A" : "um", o.truth.c_str(), o.fitted.c_str());
    }
  }
};
[[maybe_unused]] ::testing::Environment* const table_environment =
    ::testing::AddGlobalTestEnvironment(new TableEnvironment);

}  // namespace
}  // namespace vmsim::identify::test
