#pragma once
// The planning options shared by several commands: --method, --limits, and --effects, the
// dynamic effects of the first paper's Eq. 4 switched on, written H,Hcpl,B,C,G,F (uncoupled
// inertia, coupled inertia, centrifugal, Coriolis, gravity, friction) or "all".
#include <string>

#include "exit_codes.hpp"
#include "vmsim/common/errors.hpp"
#include "vmsim/kinematics/dynamics.hpp"
#include "vmsim/planner/feedrate.hpp"

namespace vmsim::app {

inline kinematics::EffectSet parse_effects(const std::string& text) {
  using kinematics::Effect;
  if (text == "all") return kinematics::EffectSet::all();
  kinematics::EffectSet effects;
  std::size_t start = 0;
  while (start <= text.size()) {
    const std::size_t comma = text.find(',', start);
    const std::string word = text.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
    if (word == "H") {
      effects = effects.with(Effect::inertia);
    } else if (word == "Hcpl") {
      effects = effects.with(Effect::inertia_coupling);
    } else if (word == "B") {
      effects = effects.with(Effect::centrifugal);
    } else if (word == "C") {
      effects = effects.with(Effect::coriolis);
    } else if (word == "G") {
      effects = effects.with(Effect::gravity);
    } else if (word == "F") {
      effects = effects.with(Effect::friction);
    } else {
      throw CommandLineError("--effects: '" + word +
                       "' is not an effect (use H, Hcpl, B, C, G, F, comma-separated, or all)");
    }
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return effects;
}

/// --method kinematic|dynamic
inline planner::FeedrateMethod parse_method(const std::string& text) {
  if (text == "kinematic") return planner::FeedrateMethod::kinematic;
  if (text == "dynamic") return planner::FeedrateMethod::dynamic;
  throw CommandLineError("--method must be kinematic or dynamic, got '" + text + "'");
}

/// --limits tuned|actuator
inline planner::DynamicLimitSource parse_limit_source(const std::string& text) {
  if (text == "tuned") return planner::DynamicLimitSource::tuned;
  if (text == "actuator") return planner::DynamicLimitSource::actuator;
  throw CommandLineError("--limits must be tuned or actuator, got '" + text + "'");
}

}  // namespace vmsim::app
