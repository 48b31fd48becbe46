// The diagnosis on a machine it was not written for (issue 20): "measured" data from the second,
// independent truth simulator (truth_sim_independent.cpp: PI velocity loop at 4 kHz, 1 ms
// position loop on a direct scale, held backward-difference feedforward, smooth friction without
// stiction, a first-order current loop, computation delays, quantised encoders and current,
// noise, a trace cut out of a longer run so that it starts and ends in motion, `.pos_motor`).
// One hidden effect per case, plus a control with none and a case with an unmodelled external
// force (which must be reported as unexplained, not as a catalogue effect).
//
// Each case asserts the effect named first. Cases the diagnosis does not yet get right are
// listed in kKnownMisses with the reason; they are reported (skipped with the outcome), not
// asserted, and the closing table prints every outcome. VMSIM_IDENTIFY_SEED=n draws other truths.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <map>
#include <random>
#include <set>

#include "truth_sim_independent.hpp"
#include "vmsim/identify/diagnose.hpp"
#include "vmsim/kinematics/machine_loader.hpp"

namespace vmsim::identify::test {
namespace {

std::string num(double v) {
  char text[32];
  std::snprintf(text, sizeof text, "%.3g", v);
  return text;
}

// Cases the diagnosis does not yet name first on this simulator (default seeds); see the table
// in identify/README.md. Not asserted, so that the suite stays green, but reported.
const std::set<std::string> kKnownMisses = {};

IndependentDrive truth_with(const std::string& effect, std::uint32_t seed,
                            const std::vector<double>& sp, std::size_t from, std::size_t to) {
  std::mt19937 rng(seed);
  auto uniform = [&](double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(rng); };
  auto coin = [&] { return uniform(0.0, 1.0) < 0.5; };
  IndependentDrive p;
  const double r = p.ratio_m_per_rad();
  if (effect == "coulomb_friction") {
    p.coulomb_A *= coin() ? uniform(2.2, 2.8) : uniform(0.1, 0.35);
    p.description = "Coulomb " + num(p.coulomb_A) + " A";
  } else if (effect == "viscous_friction") {
    p.viscous_A_s_per_m *= uniform(2.5, 3.5);
    p.description = "viscous " + num(p.viscous_A_s_per_m) + " A s/m";
  } else if (effect == "asymmetric_friction") {
    const bool up = coin();
    const double hi = uniform(1.6, 2.4), lo = uniform(0.3, 0.6);
    p.asymmetric = true;
    p.coulomb_positive_A = p.coulomb_A * (up ? hi : lo);
    p.coulomb_negative_A = p.coulomb_A * (up ? lo : hi);
    p.viscous_positive_A_s_per_m = p.viscous_A_s_per_m * (up ? hi : lo);
    p.viscous_negative_A_s_per_m = p.viscous_A_s_per_m * (up ? lo : hi);
    p.description = "Coulomb +" + num(p.coulomb_positive_A) + "/-" + num(p.coulomb_negative_A) +
                    " A, viscous +" + num(p.viscous_positive_A_s_per_m) + "/-" +
                    num(p.viscous_negative_A_s_per_m) + " A s/m";
  } else if (effect == "stribeck_friction") {
    p.hump_A = uniform(0.3, 0.5);
    p.hump_speed_m_per_s = uniform(1e-3, 4e-3);
    p.description = "low-speed hump +" + num(p.hump_A) + " A below " +
                    num(p.hump_speed_m_per_s * 1e3) + " mm/s";
  } else if (effect == "backlash") {
    p.backlash_m = uniform(10e-6, 30e-6);
    p.description = "play " + num(p.backlash_m * 1e6) + " um";
  } else if (effect == "cogging") {
    const int choices[] = {6, 8, 10, 12};
    p.cogging_per_rev = choices[std::uniform_int_distribution<int>(0, 3)(rng)];
    p.cogging_N_m = uniform(0.08, 0.15);
    p.cogging_phase_rad = uniform(-3.1, 3.1);
    p.description = std::to_string(p.cogging_per_rev) + "/rev, " + num(p.cogging_N_m) + " N m";
  } else if (effect == "pitch_error") {
    p.pitch_amplitude_m = uniform(4e-6, 10e-6);
    p.pitch_period_m = p.lead_m;
    p.pitch_phase_rad = uniform(-3.1, 3.1);
    p.description = "period 16 mm, " + num(p.pitch_amplitude_m * 1e6) + " um";
  } else if (effect == "compliance") {
    const double f = uniform(80.0, 160.0), w = 2.0 * 3.141592653589793 * f;
    const double m_motor = p.motor_inertia_kg_m2 / (r * r);
    const double reduced = m_motor * p.load_mass_kg / (m_motor + p.load_mass_kg);
    p.stiffness_N_per_m = w * w * reduced;
    p.damping_ratio = uniform(0.03, 0.1);
    p.description = "mode " + num(f) + " Hz, damping " + num(p.damping_ratio);
  } else if (effect == "delay") {
    p.setpoint_delay_s = uniform(1.5e-3, 4e-3);
    p.description = "delay " + num(p.setpoint_delay_s * 1e3) + " ms";
  } else if (effect == "gravity") {
    const double amps = uniform(0.3, 0.5) * (coin() ? 1.0 : -1.0);
    p.offset_force_N = amps * p.kt_N_m_per_A / r;
    p.description = "offset " + num(amps) + " A (" + num(p.offset_force_N) + " N)";
  } else if (effect == "current_saturation") {
    const double peak = independent_peak_current(simulate_independent(p, sp, from, to, seed));
    p.current_max_A = peak * uniform(0.55, 0.7);
    p.description = "limit " + num(p.current_max_A) + " A (peak without " + num(peak) + " A)";
  } else if (effect == "inertia") {
    p.inertia_factor = coin() ? uniform(1.3, 1.6) : uniform(0.65, 0.8);
    p.description = "J_eq x " + num(p.inertia_factor);
  } else if (effect == "external_force") {
    // Not in the catalogue: a force on the table during half a second (a clamp, a cut).
    p.bump_force_N = uniform(150.0, 250.0) * (coin() ? 1.0 : -1.0);
    const double duration = static_cast<double>(to - from) * p.trace_period_s;
    p.bump_start_s = static_cast<double>(from) * p.trace_period_s + uniform(0.3, 0.6) * duration;
    p.bump_end_s = p.bump_start_s + 0.5;
    p.description = num(p.bump_force_N) + " N from t = " +
                    num(p.bump_start_s - static_cast<double>(from) * p.trace_period_s) + " s for 0.5 s";
  }
  return p;
}

struct Outcome {
  std::string first = "(none)";
  int rank = 0;              // place in the forward selection; 0 = not found
  double gain = 0.0;         // 1 - after / before of the evidence channel (validation)
  std::string channel;
  int false_effects = 0;     // found effects other than the hidden one
  bool unexplained = false;
  std::string unexplained_text, truth, fitted;
};

std::map<std::string, Outcome>& outcomes() {
  static std::map<std::string, Outcome> table;
  return table;
}

std::uint32_t seed_offset() {
  const char* extra = std::getenv("VMSIM_IDENTIFY_SEED");
  return extra ? static_cast<std::uint32_t>(std::atoi(extra)) : 0u;
}

Outcome run_case(const std::string& effect) {
  const std::uint32_t seed = 101u + seed_offset() * 7919u +
                             static_cast<std::uint32_t>(std::hash<std::string>{}(effect) % 1000u);
  std::size_t from = 0, to = 0;
  const IndependentDrive nominal;
  const std::vector<double> sp = independent_excitation(nominal.position_period_s, from, to);
  const IndependentDrive truth = truth_with(effect, seed, sp, from, to);
  const Trace trace = simulate_independent(truth, sp, from, to, seed + 1000u);
  const kinematics::MachineModel machine =
      kinematics::parse_machine(independent_machine_yaml(nominal), "independent.yaml");
  const auto data = extract_measurements(machine, trace, "independent:" + effect);
  const Diagnosis d = diagnose(machine, data, {});
  const AxisDiagnosis& axis = d.axes.at(0);
  Outcome o;
  o.truth = truth.description;
  for (std::size_t i = 0; i < axis.found.size(); ++i) {
    if (axis.found[i].effect == effect) {
      o.rank = static_cast<int>(i) + 1;
    } else {
      ++o.false_effects;
    }
  }
  if (!axis.found.empty()) {
    o.first = axis.found.front().effect;
    o.fitted = axis.found.front().evidence;
    o.channel = axis.found.front().channel;
  }
  const double e = axis.before.effort_rms_A > 0.0 ? axis.after.effort_rms_A / axis.before.effort_rms_A : 1.0;
  const double l = axis.before.load_diff_rms > 0.0 ? axis.after.load_diff_rms / axis.before.load_diff_rms : 1.0;
  const double p = axis.before.position_rms > 0.0 ? axis.after.position_rms / axis.before.position_rms : 1.0;
  o.gain = 1.0 - std::min({e, l, p});
  o.unexplained = axis.unexplained.present;
  o.unexplained_text = axis.unexplained.sentence;
  std::cout << "[" << effect << "] truth: " << o.truth << "\n  noise " << axis.effort_noise_A
            << " A (" << axis.noise_source << "), first round:";
  for (const auto& c : axis.first_round) {
    std::cout << " " << c.effect << "(" << c.channel << " " << num(c.relative_gain) << ", score "
              << num(c.score) << (c.found ? ", found" : "") << (c.bound_note.empty() ? "" : ", at bound")
              << ")";
  }
  std::cout << "\n  found:";
  for (const auto& c : axis.found) std::cout << " " << c.effect << " [" << c.evidence << "]";
  std::cout << "\n  verdict: " << axis.unexplained.sentence << "\n";
  outcomes()[effect] = o;
  return o;
}

class IndependentHiddenEffect : public ::testing::TestWithParam<std::string> {};

TEST_P(IndependentHiddenEffect, IsNamedFirst) {
  const std::string effect = GetParam();
  const Outcome o = run_case(effect);
  if (kKnownMisses.count(effect) != 0 && seed_offset() == 0) {
    GTEST_SKIP() << "known miss (identify/README.md): named first " << o.first;
  }
  EXPECT_EQ(o.first, effect);
  EXPECT_EQ(o.rank, 1);
  // Nothing after the right one (issue 20: forward selection used to add what the first
  // effect's imperfect fit left; seeds 0, 1, 2 now find none).
  EXPECT_EQ(o.false_effects, 0) << "found after " << effect << ": " << o.fitted;
}

INSTANTIATE_TEST_SUITE_P(Catalogue, IndependentHiddenEffect,
                         ::testing::Values("coulomb_friction", "viscous_friction",
                                           "asymmetric_friction", "stribeck_friction", "backlash",
                                           "cogging", "pitch_error", "compliance", "delay",
                                           "gravity", "current_saturation", "inertia"),
                         [](const ::testing::TestParamInfo<std::string>& param_info) { return param_info.param; });

TEST(IndependentControl, NoHiddenEffectFindsNothingAndNothingUnexplained) {
  const Outcome o = run_case("none");
  EXPECT_EQ(o.first, "(none)");
  EXPECT_FALSE(o.unexplained) << o.unexplained_text;
}

TEST(IndependentExternalForce, IsReportedAsUnexplained) {
  const Outcome o = run_case("external_force");
  EXPECT_EQ(o.false_effects, 0);
  EXPECT_TRUE(o.unexplained) << o.unexplained_text;
  EXPECT_NE(o.unexplained_text.find("does not explain"), std::string::npos) << o.unexplained_text;
}

class IndependentTable : public ::testing::Environment {
 public:
  void TearDown() override {
    if (outcomes().empty()) return;
    std::printf("\n| hidden effect (independent truth, seed offset %u) | named first | rank | gain "
                "| false effects | unexplained | truth |\n|---|---|---|---|---|---|---|\n",
                seed_offset());
    for (const auto& [effect, o] : outcomes()) {
      std::printf("| %s | %s | %d | %.0f %% | %d | %s | %s |\n", effect.c_str(), o.first.c_str(),
                  o.rank, 100.0 * o.gain, o.false_effects, o.unexplained ? "yes" : "no",
                  o.truth.c_str());
    }
  }
};
[[maybe_unused]] ::testing::Environment* const independent_table =
    ::testing::AddGlobalTestEnvironment(new IndependentTable);

}  // namespace
}  // namespace vmsim::identify::test
