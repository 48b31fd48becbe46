#pragma once
// circle-test: the ISO 230-4 circular test as a built-in program (README, "Circular test").
//
// For each plane (XY, YZ, ZX), feed and direction (CCW, CW) it generates the program a ballbar
// test runs (a radial lead-in, an overrun arc so that the data arc starts in steady motion, the
// 360-degree data arc, an overrun arc, a radial lead-out), plans it (planner::plan_feedrate on
// the exact circle), simulates the drives of the plane's two axes (servo::simulate_machine),
// takes the tool tip (direct kinematics of the simulated load positions, tool length 0: the
// spindle gauge point) in the plane, and computes the figures of circle_figures.hpp. Each
// feature is then explained by the drive model: the drive effects are switched off one at a
// time (friction, backlash, cogging, pitch error, compliance of each axis, the servo mismatch
// of the second axis against the first, the feedforward) and the test simulated again; an
// effect's share of a feature is the feature with every effect minus the feature without it.
// With a measured trace of a circle test the same figures are computed from its positions.
//
// Writes, into a result folder replaced as a whole (vmsim/common/output_folder.hpp):
// circle_test.json (figures, attribution, program), circle_deviation.csv (radial deviation on a
// 0.5-degree grid per plane, feed, direction, simulated or measured) and polar_<plane>_F<feed>.png
// (skipped without a display, with the reason in the JSON).
#include <nlohmann/json.hpp>

#include <optional>
#include <string>
#include <vector>

#include "simulate_part.hpp"  // ProgressSink

namespace vmsim::app {

struct CircleTestOptions {
  std::string machine_path;
  std::string out_dir;
  /// "XY", "YZ", "ZX", "all"; empty: XY, or the plane of the measured trace.
  std::string plane;
  double radius_m = 0.1;
  /// Feeds of the tests [m/s]; empty: 500, 2000, 5000 mm/min.
  std::vector<double> feeds_m_per_s;
  /// A measured trace of a circle test (trace format); empty: none.
  std::string trace_path;
  /// Positions of the linear axes X, Y, Z at the circle's centre [m]; unset: the middle of each
  /// axis's travel (home for an axis without end stops).
  std::optional<std::vector<double>> centre_m;
  /// Explain the features by switching the drive effects off one at a time.
  bool attribute = true;
  bool renders = true;
  std::string command_line;
};

/// Runs the circle test and writes the result folder (complete or not at all). Returns the
/// summary written as circle_test.json. Throws vmsim::InputError for bad options (naming the
/// option and value: an unknown plane, a radius or centre outside an axis's travel, naming the
/// machine file and the travel), a machine without linear X, Y, Z axes for the plane, or a
/// trace without a circle of the given radius around the centre; nothing is written then.
nlohmann::json run_circle_test(const CircleTestOptions& options, const ProgressSink& progress);

}  // namespace vmsim::app
