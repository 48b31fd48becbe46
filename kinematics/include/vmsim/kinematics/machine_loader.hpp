#pragma once
// Loading a machine description (YAML, documented field by field in the README, section
// "Machine description"). Every value is converted to SI here and nowhere else.
//
// Errors: vmsim::InputError whose message names the file, the line and column, the field path
// (e.g. `axes[2].drive.torque_max_N_m`), the axis and the value. Unknown fields are errors too,
// so that a misspelt key is never silently ignored.
#include <string>

#include "vmsim/kinematics/machine_model.hpp"

namespace vmsim::kinematics {

/// Loads and validates a machine file. A `structure: {urdf: ...}` section loads the chain from
/// a URDF file (path relative to the machine file).
MachineModel load_machine(const std::string& path);

/// The same from text already in memory; `file_name_for_messages` names it in errors, and
/// relative paths (URDF) are resolved against `base_directory`.
MachineModel parse_machine(const std::string& yaml_text, const std::string& file_name_for_messages,
                           const std::string& base_directory = ".");

/// Checks the invariants every module relies on (names unique, each axis moved by exactly one
/// joint, positive limits and periods, physically valid inertia tensors, ...). load_machine
/// calls it; code that builds a model by hand can too. Throws vmsim::InputError.
void validate_machine(const MachineModel& model);

}  // namespace vmsim::kinematics
