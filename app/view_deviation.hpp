#pragma once
// A run-versus-run deviation computed on demand from the two N-buffers (issue 21: a view of
// 2.5e9 lines cannot hold one double a line): line (iu, iv)'s deviation is a - b, 0 where the
// line is steep in either run (exclude_steep_lines' test in surface_views.hpp: a neighbour's
// length differs by more than kSteepStepPerSpacing spacings), which needs the line's own and its
// four neighbours' lengths only. Whole views are walked row by row (DeviationRows): each
// length is read once per walk, three rows of each run held.
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "vmsim/removal/marks_stream.hpp"
#include "vmsim/removal/nbuffer.hpp"

namespace vmsim::app {

class ViewDeviation {
 public:
  /// a - b on the lines of `a` and `b` (identical lines), views of line spacing `spacing_m`;
  /// with `nan_as_infinity`, a NaN difference reads as +infinity (the specks check).
  ViewDeviation(const removal::NBuffer& a, const removal::NBuffer& b, double spacing_m,
                bool nan_as_infinity = false);
  int nu() const { return a_->nu(); }
  int nv() const { return a_->nv(); }
  std::size_t line_count() const { return a_->line_count(); }
  /// The deviation [m] of line (iu, iv): a - b, 0 where steep in either run.
  double at(int iu, int iv) const;
  /// True where the line is steep in a or in b (not assessed).
  bool steep(int iu, int iv) const;
  /// For removal::find_marks_streamed: rows through a DeviationRows, lines through at().
  removal::DeviationReader reader() const;

  friend class DeviationRows;

 private:
  bool steep_in(const removal::NBuffer& buffer, int iu, int iv) const;
  double value(double a_m, double b_m, bool steep) const;

  const removal::NBuffer* a_;
  const removal::NBuffer* b_;
  double step_limit_m_;
  bool nan_as_infinity_;
};

/// A walk over a ViewDeviation's rows, fastest in order (iv = 0, 1, ...): holds rows iv - 1,
/// iv, iv + 1 of both runs' lengths.
class DeviationRows {
 public:
  explicit DeviationRows(const ViewDeviation& deviation);
  /// Row iv's deviations [m] (nu of them), valid until the next call.
  std::span<const double> row(int iv);
  /// Row iv's steep flags (1: steep in either run), as of the last row().
  std::span<const std::uint8_t> steep_row() const { return steep_; }

 private:
  struct Lengths {  // three rows of one run: above, at and below the current row
    std::vector<double> above, at, below;
  };
  void load(const removal::NBuffer& buffer, int iv, std::vector<double>& row) const;
  void move_to(int iv);
  void mark_steep(const Lengths& lengths);

  const ViewDeviation& deviation_;
  int current_row_ = -2;
  Lengths a_, b_;
  std::vector<double> deviation_m_;
  std::vector<std::uint8_t> steep_;
};

}  // namespace vmsim::app
