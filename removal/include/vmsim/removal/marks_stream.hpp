#pragma once
// Marks of a view too large for one value a line (issue 21: a 500 x 500 mm die at 10 um has
// 2.5e9 lines): the same marks as find_marks (marks.hpp), from a deviation read row by row and
// line by line on demand, holding per line nothing but the labels of the lines that belong to
// a mark.
//  1. MarkRegionFinder: the 4-connected regions of one sign, fed row by row; it keeps the
//     previous row's labels and a union-find over the labels of two rows (the regions still
//     open), and returns each region of at least min_lines lines by its first line (row-major).
//  2. find_marks_streamed: from each such first line, the flood fill of find_marks again (same
//     order of the lines, hence the same sums of area and centroid bit for bit, the same deepest
//     line), writing the labels into SparseMarkLabels (per tile of 16 x 16 lines holding a
//     marked line).
#include <cstddef>
#include <functional>
#include <memory>
#include <span>
#include <unordered_map>
#include <vector>

#include "vmsim/removal/marks.hpp"
#include "vmsim/removal/nbuffer.hpp"

namespace vmsim::removal {

/// Labels of the lines of a grid (index into a mark list, or -1), held per tile of
/// kTile x kTile lines that holds a labelled line.
class SparseMarkLabels {
 public:
  static constexpr int kTile = 16;
  SparseMarkLabels() = default;
  SparseMarkLabels(int nu, int nv) : nu_(nu), nv_(nv) {}
  int nu() const { return nu_; }
  int nv() const { return nv_; }
  /// The label of line (iu, iv); -1 where none.
  int at(int iu, int iv) const;
  void set(int iu, int iv, int label);
  /// Replaces every label l >= 0 by new_label[l].
  void relabel(const std::vector<int>& new_label);
  std::size_t tiles_held() const { return tiles_.size(); }

 private:
  std::size_t tile_of(int iu, int iv) const;
  int nu_ = 0, nv_ = 0;
  std::unordered_map<std::size_t, std::vector<int>> tiles_;
};

/// A region of one sign found by MarkRegionFinder.
struct MarkRegion {
  std::size_t first_line = 0;  ///< its first line, row-major (iu + nu iv)
  int sign = 0;                ///< -1: deviation < -threshold (gouge), +1: > threshold (excess)
  std::size_t line_count = 0;
};

/// The 4-connected regions of lines with |deviation| > threshold of one sign, fed row by row.
class MarkRegionFinder {
 public:
  MarkRegionFinder(int nu, int nv, const MarkOptions& options);
  /// The deviations [m] of the next row (iv = 0, 1, ...), nu of them. Throws
  /// std::invalid_argument on a wrong size or past the last row.
  void add_row(std::span<const double> deviation_m);
  /// After the last row: the regions of at least min_lines lines, by first line. Throws
  /// std::logic_error when rows are missing.
  std::vector<MarkRegion> regions() const;
  /// -1, 0 or +1: the side of the threshold a deviation lies on.
  int sign_of(double deviation_m) const;

 private:
  struct Open {  // a region still open (seen on the last row), or merged into one
    int parent = 0;
    int sign = 0;
    std::size_t first_line = 0;
    std::size_t line_count = 0;
  };
  int root_of(int id);
  int join(int a, int b);
  void close_regions_left_behind(const std::vector<int>& row_label);
  void keep(const Open& region);

  int nu_ = 0, nv_ = 0, rows_seen_ = 0;
  MarkOptions options_;
  std::vector<int> previous_row_label_;  ///< per line of the last row: index into open_, or -1
  std::vector<Open> open_;
  std::vector<MarkRegion> kept_;
};

/// A deviation [m] read on demand: whole rows in order, and single lines.
struct DeviationReader {
  /// Fills `row_m` (nu values) with row iv's deviations. Called with iv = 0, 1, ... in order.
  std::function<void(int iv, std::span<double> row_m)> row;
  /// The deviation of line (iu, iv); must equal what `row` gives.
  std::function<double(int iu, int iv)> at;
};

struct StreamedMarkMap {
  std::vector<Mark> marks;  ///< sorted by depth, deepest first (as find_marks)
  SparseMarkLabels labels;  ///< index into `marks`, or -1
};

/// The marks find_marks finds for the same deviation, with the same values bit for bit, in the
/// same order; the labels held sparsely. Holds O(nu) values plus the marked lines' labels and
/// the flood fill's stack of one mark.
StreamedMarkMap find_marks_streamed(const NBuffer& production, const DeviationReader& deviation,
                                    const MarkOptions& options = {});

}  // namespace vmsim::removal
