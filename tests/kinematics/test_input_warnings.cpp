// Values plausible but unusual (a slip of unit?) load with a located warning in
// MachineModel::warnings.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <string>

#include "vmsim/kinematics/machine_loader.hpp"

namespace vmsim::kinematics {
namespace {

const std::string kSamples = std::string(VMSIM_SOURCE_DIR) + "/samples/machines/";

std::string mikron_with(const std::string& from, const std::string& to) {
  std::ifstream in(kSamples + "mikron_ucp710.yaml");
  std::stringstream buffer;
  buffer << in.rdbuf();
  std::string text = buffer.str();
  const std::size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << "test setup: '" << from << "' not in the sample";
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

std::string all_warnings(const MachineModel& model) {
  std::string text;
  for (const std::string& warning : model.warnings) text += warning + "\n";
  return text;
}

TEST(MachineWarnings, TheSampleHasNone) {
  EXPECT_TRUE(load_machine(kSamples + "mikron_ucp710.yaml").warnings.empty());
  EXPECT_TRUE(load_machine(kSamples + "kr180_class_urdf.yaml").warnings.empty());
}

TEST(MachineWarnings, InterpolationPeriodOfSecondsIsWarnedAbout) {
  const MachineModel model = parse_machine(
      mikron_with("interpolation_period_ms: 4", "interpolation_period_s: 4"), "odd.yaml", kSamples);
  const std::string warnings = all_warnings(model);
  EXPECT_NE(warnings.find("odd.yaml:24:"), std::string::npos) << warnings;
  EXPECT_NE(warnings.find("an interpolation period of 4 s is unusual"), std::string::npos)
      << warnings;
}

TEST(MachineWarnings, RotaryTravelOfManyTurnsIsWarnedAbout) {
  const MachineModel model = parse_machine(
      mikron_with("travel_deg: [-120, 30]", "travel_deg: [-72000, 72000]"),
      "odd.yaml", kSamples);
  const std::string warnings = all_warnings(model);
  EXPECT_NE(warnings.find("odd.yaml:104:"), std::string::npos) << warnings;
  EXPECT_NE(warnings.find("more than 100 turns"), std::string::npos) << warnings;
}

}  // namespace
}  // namespace vmsim::kinematics
