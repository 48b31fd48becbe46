#pragma once
// An independent "truth" simulator for the identification tests: a simple fixed-step closed
// loop of a bench-like drive (P position loop, P velocity loop on the differenced, quantised
// motor encoder, ideal current with saturation, one-sample computation delays), rigid or
// two-mass mechanics integrated by semi-implicit Euler with fine sub-steps, and each effect of
// the catalogue coded here, separately from the servo library. It writes a "measured" trace:
// t, X.cmd, X.pos, X.pos2 (load scale), X.cur with noise and quantisation.
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "vmsim/common/trace.hpp"

namespace vmsim::identify::test {

struct TruthDrive {
  // Nominal drive (the values of the baseline model).
  double ratio = 0.01 / (2.0 * 3.141592653589793);  ///< m/rad
  double inertia = 2.207e-4;                        ///< J_eq [kg m^2]
  double rotor_inertia = 1.7e-4;                    ///< motor side, for the two-mass case
  double kt = 0.5;                                  ///< N m/A
  double viscous_A_s_per_m = 2.0;
  double dry_A = 0.2;
  double kv = 25.0;           ///< 1/s
  double kp = 0.0347;         ///< N m s/rad
  double period = 1e-3;       ///< all loops [s]
  double counts_per_rev = 4000.0;
  double current_max_A = 6.0;
  double delay_s = 0.0;
  // Effects (off when zero / false).
  bool asymmetric = false;
  double dry_positive_A = 0.0, dry_negative_A = 0.0;
  double viscous_positive_A_s_per_m = 0.0, viscous_negative_A_s_per_m = 0.0;
  double stribeck_static_A = 0.0, stribeck_velocity = 0.0;  ///< m/s; Gaussian shape
  double backlash_gap = 0.0;                                 ///< m
  double cogging_N_m = 0.0, cogging_periods = 0.0, cogging_phase = 0.0;
  double pitch_amplitude = 0.0, pitch_period = 0.0, pitch_phase = 0.0;  ///< m, m, rad
  double stiffness = 0.0, damping_ratio = 0.0;  ///< N/m at the joint; 0 = rigid
  double offset_A = 0.0;                        ///< constant resistant effort
  // Measurement.
  double current_noise_A = 0.01;
  double current_quantum_A = 0.005;
  double scale_quantum = 1e-7;  ///< load scale resolution [m]
  int substeps = 40;
  std::string description;  ///< the hidden effect, for the tables
};

/// Generic excitation at 1 kHz: moves at several speeds both ways, reversals, accelerations.
/// Positions in m.
std::vector<double> generic_excitation(double period_s, double scale = 1.0);

/// Simulates the drive on the set points and returns the trace (mm, A).
Trace simulate_truth(const TruthDrive& drive, const std::vector<double>& setpoints_m,
                     std::uint32_t noise_seed);

/// Peak |current| of a run (for choosing a saturation level).
double peak_current(const Trace& trace);

}  // namespace vmsim::identify::test
