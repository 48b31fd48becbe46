#pragma once
// Small machine models built in code, so that tests and benchmarks need no files. They follow
// the samples in samples/machines/ in structure, not in every value: tests that need the
// documented values load the YAML files.
#include "vmsim/kinematics/machine_model.hpp"

namespace vmsim::kinematics {

/// A table-table 5-axis machine of the Mikron UCP710 kind: workpiece chain A (tilting, about x)
/// then C (rotary, about z); tool chain X, Y, Z. Offsets are non-zero (A and C axes do not
/// intersect exactly) so that the kinematics is exercised in general position.
MachineModel make_table_table_sample();

/// A 6R robot of the KUKA KR180 class (approximate geometry and mass properties), with a
/// spindle on the flange and a fixed workpiece frame in front of it.
MachineModel make_robot_sample();

}  // namespace vmsim::kinematics
