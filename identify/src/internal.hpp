#pragma once
// Helpers shared by the identification and the diagnosis (not part of the interface).
#include <functional>
#include <vector>

namespace vmsim::identify::detail {

/// Central differences of x sampled at period h (one-sided at the ends).
std::vector<double> derivative(const std::vector<double>& x, double h);

/// Minimum of f over [lo, hi]: the best of `grid` evenly spaced points (log-spaced when `log`),
/// then a golden-section search in the neighbouring interval down to `tolerance` (absolute, or
/// relative when `log`). Returns the argument; `best` receives f there.
double scan_minimum(const std::function<double(double)>& f, double lo, double hi, int grid,
                    bool log, double tolerance, double& best);

/// sign with a dead band: 0 where |v| <= band.
inline double sign_band(double v, double band) { return v > band ? 1.0 : (v < -band ? -1.0 : 0.0); }

}  // namespace vmsim::identify::detail
