#pragma once
// simulate-part: the whole chain for one part, at the production feed and at a low reference
// feed (second paper, Section 4):
//   tool path -> IKT and path derivatives -> feedrate plan (set points at the interpolation
//   period) -> servo simulation of every axis -> direct kinematics of the simulated (load)
//   positions: the actual tool trajectory -> N-buffer removal on one Z-map grid per run ->
//   production minus reference, line by line -> marks -> each mark related to the tool path.
// Both runs use identical grids, so grid, scallop and tool-shape effects cancel exactly and what
// remains is the trajectory follow-up.
#include <nlohmann/json.hpp>

#include <Eigen/Core>
#include <functional>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "vmsim/kinematics/dynamics.hpp"
#include "vmsim/planner/feedrate.hpp"

namespace vmsim::app {

/// Which surface the production run is compared with (issue 21): the planned tool path's own
/// surface (no reference removal: valid within the bound the reference run's path stages
/// measure, README "A cheaper reference"), the simulated reference run's, or the first where the
/// bound is small enough.
enum class ReferenceMode { automatic, commanded, simulated };

struct SimulatePartOptions {
  std::string part_path;
  std::string out_dir;
  planner::FeedrateMethod method = planner::FeedrateMethod::kinematic;
  planner::DynamicLimitSource limits = planner::DynamicLimitSource::tuned;
  kinematics::EffectSet effects = kinematics::EffectSet::all();
  double production_feed_m_per_s = 0.0;  ///< 0 = the part file's
  double reference_feed_m_per_s = 0.0;   ///< 0 = the part file's
  /// Jerk (kinematic) / torque-rate (dynamic) limits in the plan: true / false as given on the
  /// command line; nullopt: what the program asks (Siemens SOFT: on, BRISK: off; app/nc_modes.hpp),
  /// off where it says nothing (an NC's acceleration-only mode). The report says which.
  std::optional<bool> third_order;
  /// The drives' feedforward: true / false as given on the command line (off: no velocity or
  /// torque feedforward); nullopt: what the program asks (FFWON / FFWOF), the machine file's
  /// where it says nothing.
  std::optional<bool> feedforward;
  /// Corner blending tolerance [m] (planner/corner_blend.hpp); 0 = exact stop at corners.
  double corner_tolerance_m = 0.0;
  /// True: corner_tolerance_m at every corner (given on the command line); false: the
  /// program's tolerances (ChainInputOptions::corner_tolerance_override).
  bool corner_tolerance_override = false;
  /// The compressor: NaN = as the program asks (COMPCAD ...), 0 = off, > 0 = on everywhere
  /// within it [m] (ChainInputOptions::compressor_tolerance_override_m).
  double compressor_tolerance_override_m = std::numeric_limits<double>::quiet_NaN();
  double grid_m = 20e-6;                 ///< line spacing of every surface view
  double mark_threshold_m = 2e-6;        ///< |deviation| above which a line belongs to a mark
  /// The actual trajectory is thinned to the samples needed to keep every dropped sample within
  /// this distance of the straight segment that replaces it (tip, and tool axis times the tool
  /// length): the removal then differs from cutting every sample by at most this much.
  double trajectory_tolerance_m = 0.05e-6;
  /// Largest distance the tool moves between two recorded servo samples [m] (chords of a curved
  /// motion stay far below the mark threshold: sagitta = chord^2 / (8 radius)).
  double max_sample_chord_m = 20e-6;
  /// Perfect drives: the axes follow the planned motion exactly (q(s(t)) on the path spline),
  /// no servo simulation. Separates what the planner does from what the drives do; with it a
  /// tool path must leave no mark.
  bool perfect_drives = false;
  /// Optional: changes the actual axis positions of the production run (SI joint units) at
  /// time t, after the servo; for tests that plant a known deviation.
  std::function<void(double t_s, Eigen::VectorXd& q)> production_disturbance;
  /// Largest distance allowed between a set point's tool tip and the programmed path [m]:
  /// beyond it the run stops with an error (the set points are not what the program asks for).
  /// The planner holds its path to the same tolerance (FeedrateOptions::path_tolerance_m).
  double setpoint_path_tolerance_m = planner::FeedrateOptions{}.path_tolerance_m;
  /// The same [m] on segments where the programmed tool axis turns (simultaneous 5-axis motion;
  /// FeedrateOptions::turning_path_tolerance_m).
  double setpoint_turning_path_tolerance_m = planner::FeedrateOptions{}.turning_path_tolerance_m;
  bool commanded_check = true;  ///< also cut the commanded tool path and compare the reference
  ReferenceMode reference_mode = ReferenceMode::automatic;
  /// automatic: the planned path's surface is the reference when the bound on its line heights'
  /// difference from the simulated reference's is at most this fraction of mark_threshold_m.
  double commanded_reference_fraction = 0.1;
  /// Also run the production feed with the other planning method (kinematic <-> dynamic) against
  /// the same reference: the report's "method_comparison" gives each method's cycle time and
  /// marks side by side (first paper's dynamic limits against the NC's kinematic ones).
  bool compare_methods = false;
  bool renders = true;
  int threads = 0;
  /// Z-maps with more lines than this store their heights compactly (NBuffer::make_compact:
  /// tiles allocated where a tool reaches, a double base and float offsets a tile, within
  /// 2^-24 of the depth below the tile's top); 0 = every Z-map. The default keeps plain doubles
  /// (exact) up to 32 M lines (sample part 1: 2 M at 20 um, 8 M at 10 um).
  std::size_t compact_zmap_above_lines = std::size_t{32} << 20;
  /// Several ranks: each sends rank 0 its band of a view in pieces of whole tile rows of about
  /// this many lines (at least one tile row), so that no rank packs a whole band at once (8 B a
  /// line). Any value gives the same results.
  std::size_t gather_piece_lines = std::size_t{1} << 22;
  /// The servo, the direct kinematics and the thinning run along the program in windows of
  /// this much machine time [s] (set points of a window in, its samples out and consumed), so
  /// that the reference run's memory is bounded by the window, not by its machine time. Any
  /// value gives the same results (bit for bit); > 0.
  double servo_window_s = 2.0;
  /// The deepest mark the part can take [m], for the report's verdict; 0 = the part file's
  /// `tolerance_um` (none there: the report gives no verdict).
  double tolerance_m = 0.0;
  /// The command line as typed, for the report's context (empty: not shown).
  std::string command_line;
};

/// Progress lines for the long stages (the command prints them).
using ProgressSink = std::function<void(const std::string& line)>;

/// Under mpirun with several ranks (mpi_ranks.hpp) every rank calls this: each cuts its band of
/// the surface views, rank 0 alone compares and writes and returns the report; the other ranks
/// write nothing and return an empty object.
/// Runs the chain and writes everything into options.out_dir (complete or not at all: the
/// folder is assembled in a staging folder beside it and swapped in whole; an existing folder
/// is replaced only when empty or a previous vmsim result, see vmsim/common/output_folder.hpp,
/// which is checked once the inputs are read, before any computation). Returns the report (also written
/// as report.json). Renders are skipped, with the reason in the report, when no display is
/// there; every numerical result is written all the same.
nlohmann::json simulate_part(const SimulatePartOptions& options, const ProgressSink& progress);

}  // namespace vmsim::app
