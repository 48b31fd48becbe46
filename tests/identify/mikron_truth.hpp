#pragma once
// The Mikron UCP710 sample (samples/machines/mikron_ucp710.yaml) as the independent truth
// simulator (truth_sim_independent.cpp) has its drives, for the whole-machine tests of issue 20
// (test_calibrate_machine.cpp, test_diagnose_five_axis_program.cpp).
//
// The drives: the 2 ms position loop taking the set points directly, held backward-difference
// feedforward, the loop's output one velocity cycle late, friction without stiction, the loop
// closed on the motor encoder with the load scale logged as .pos2. Gravity from the file's
// bodies: the mass the Z drive lifts, and the cradle and table hanging below the A axis.
#include <string>
#include <vector>

#include "truth_sim_independent.hpp"
#include "vmsim/kinematics/machine_loader.hpp"

namespace vmsim::identify::test {

/// The Mikron sample with its drives as the truth simulator implements them (vmsim's machine
/// file); `y_delay_s` > 0 gives a machine with a set-point delay on Y.
std::string mikron_truth_machine_yaml(double y_delay_s);

/// The mass the Z drive lifts [kg]: the bodies of the tool chain from joint Z on.
double mikron_z_lifted_mass_kg();

/// The first moment of the bodies the A axis tilts (cradle and table, each centre of mass on the
/// table's axis) about the A axis, in A's frame: sum of m c_y and of m c_z [kg m].
void mikron_a_first_moment_kg_m(double& y_kg_m, double& z_kg_m);

/// The truth drive of each machine axis from the nominal machine file's values; `y_delay_s` on Y.
std::vector<IndependentDrive> mikron_truth_drives(const kinematics::MachineModel& machine, double y_delay_s);

}  // namespace vmsim::identify::test
