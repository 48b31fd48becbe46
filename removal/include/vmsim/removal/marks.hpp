#pragma once
// Marks: connected regions where the production-feed surface departs from the low-feed
// reference by more than a threshold (second paper, Section 4: the reference is the same tool
// path machined at low feed, so grid, scallop and tool-shape effects cancel and what is left
// is the trajectory follow-up).
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstddef>
#include <vector>

#include "vmsim/removal/nbuffer.hpp"

namespace vmsim::removal {

enum class MarkKind {
  gouge,   ///< the production run cut deeper than the reference (deviation < 0)
  excess,  ///< the production run left material the reference removed (deviation > 0)
};

struct Mark {
  MarkKind kind = MarkKind::gouge;
  /// Largest |deviation| in the region [m] (the mark's depth or height).
  double depth_m = 0.0;
  /// Surface area of the region [m^2] (lines x the area each line stands for).
  double area_m2 = 0.0;
  std::size_t line_count = 0;
  /// Surface point of the production run at the deepest line, and the area-weighted centroid
  /// of the region's surface points [m, W].
  Eigen::Vector3d deepest_point_W_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d centroid_W_m = Eigen::Vector3d::Zero();
  /// Line index range of the region (inclusive).
  int iu_min = 0, iu_max = 0, iv_min = 0, iv_max = 0;
};

struct MarkOptions {
  /// A line belongs to a mark when |deviation| exceeds this [m].
  double threshold_m = 2e-6;
  /// Regions of fewer lines are noise, not marks.
  std::size_t min_lines = 4;
};

struct MarkMap {
  std::vector<Mark> marks;  ///< sorted by depth, deepest first
  /// Per line (row-major, index = iu + nu * iv): index into `marks`, or -1.
  std::vector<int> label;
};

/// Finds the marks of a run-versus-run deviation (from removal::difference) on the lines of
/// `production` (4-connected regions of one sign). Throws std::invalid_argument when the sizes
/// disagree.
MarkMap find_marks(const NBuffer& production, const std::vector<double>& deviation_m,
                   const MarkOptions& options = {});

}  // namespace vmsim::removal
