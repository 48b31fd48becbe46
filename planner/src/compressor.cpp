// NC block compressor: runs of short G1 blocks smoothed by a penalised least-squares cubic
// B-spline (compressor.hpp has the model).
#include "vmsim/planner/compressor.hpp"

#include <Eigen/Geometry>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <optional>
#include <string>

#include "vmsim/common/errors.hpp"
#include "vmsim/common/files.hpp"

namespace vmsim::planner {
namespace {

using toolpath::MotionKind;
using toolpath::PathPoint;

constexpr int kDegree = 3;

bool same_or_both_nan(double a, double b) { return a == b || (std::isnan(a) && std::isnan(b)); }

bool same_orientation(const PathPoint& a, const PathPoint& b) {
  if ((a.axis_W - b.axis_W).norm() > 1e-12) return false;
  for (std::size_t k = 0; k < 3; ++k) {
    if (!same_or_both_nan(a.rotary_words_deg[k], b.rotary_words_deg[k])) return false;
  }
  return true;
}

double angle_between(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b));
}

/// Distance from p to the segment [a, b].
double segment_distance(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  const Eigen::Vector3d ab = b - a;
  const double length_squared = ab.squaredNorm();
  const double t = length_squared > 0.0 ? std::clamp((p - a).dot(ab) / length_squared, 0.0, 1.0) : 0.0;
  return (a + t * ab - p).norm();
}

/// One run before fitting: points first .. last of the path, its tolerance, its end tangents.
struct Run {
  std::size_t first = 0, last = 0;
  double tolerance_m = 0.0;
  std::optional<Eigen::Vector3d> start_tangent, end_tangent;
};

class RunFitter {
 public:
  /// dense: a control point per programmed point (interior knots at the programmed points'
  /// parameters: the curve can pass through every point), else about one per two blocks.
  RunFitter(const std::vector<Eigen::Vector3d>& points, const Run& run, bool dense) : points_(points), run_(run) {
    const std::size_t m = points_.size() - 1;
    u_.assign(points_.size(), 0.0);
    for (std::size_t k = 1; k <= m; ++k) u_[k] = u_[k - 1] + (points_[k] - points_[k - 1]).norm();
    length_m_ = u_[m];
    for (double& u : u_) u /= length_m_;
    u_[m] = 1.0;
    // Control points: about one per two blocks (the penalty, not their count, sets the
    // smoothness), at least a cubic's four.
    const std::size_t n = dense ? m + 3 : std::max<std::size_t>(4, std::min(m + 3, m / 2 + 4));
    knots_.resize(static_cast<Eigen::Index>(n + kDegree + 1));
    for (std::size_t j = 0; j <= static_cast<std::size_t>(kDegree); ++j) {
      knots_[static_cast<Eigen::Index>(j)] = 0.0;
      knots_[static_cast<Eigen::Index>(n + j)] = 1.0;
    }
    for (std::size_t j = 0; j + 4 < n; ++j) {
      knots_[static_cast<Eigen::Index>(4 + j)] =
          dense ? u_[j + 1] : static_cast<double>(j + 1) / static_cast<double>(n - 3);
    }
    control_count_ = n;
  }

  double length_m() const { return length_m_; }
  /// The programmed points' parameters u (chord length / length_m), 0 .. 1.
  const std::vector<double>& parameters() const { return u_; }

  /// The curve for penalty weight lambda.
  CompressorSpline fit(double lambda) const {
    const std::size_t n = control_count_;
    const std::size_t m = points_.size() - 1;
    Eigen::Matrix<double, 3, Eigen::Dynamic> control(3, static_cast<Eigen::Index>(n));
    std::vector<bool> fixed(n, false);
    control.col(0) = points_.front();
    control.col(static_cast<Eigen::Index>(n - 1)) = points_.back();
    fixed[0] = fixed[n - 1] = true;
    // End tangents: S'(0) = 3 (C1 - C0) / knot[4], S'(1) = 3 (C[n-1] - C[n-2]) / (1 - knot[n-1]);
    // |dS/du| is about the run's length L (u: chord length / L).
    if (run_.start_tangent) {
      control.col(1) = points_.front() + *run_.start_tangent * length_m_ * knots_[4] / 3.0;
      fixed[1] = true;
    }
    if (run_.end_tangent) {
      control.col(static_cast<Eigen::Index>(n - 2)) =
          points_.back() - *run_.end_tangent * length_m_ * (1.0 - knots_[static_cast<Eigen::Index>(n - 1)]) / 3.0;
      fixed[n - 2] = true;
    }
    std::vector<int> unknown(n, -1);
    int unknowns = 0;
    for (std::size_t j = 0; j < n; ++j) {
      if (!fixed[j]) unknown[j] = unknowns++;
    }
    if (unknowns > 0) {
      // Normal equations of  sum |S(u_k) - P_k|^2 + lambda sum |C[j-1] - 2 C[j] + C[j+1]|^2.
      std::vector<Eigen::Triplet<double>> entries;
      Eigen::MatrixXd rhs = Eigen::MatrixXd::Zero(unknowns, 3);
      const auto add_row = [&](const std::vector<std::pair<std::size_t, double>>& row, const Eigen::Vector3d& target,
                               double weight) {
        Eigen::Vector3d known = target;
        for (const auto& [j, value] : row) {
          if (fixed[j]) known -= value * control.col(static_cast<Eigen::Index>(j));
        }
        for (const auto& [j, value] : row) {
          if (fixed[j]) continue;
          rhs.row(unknown[j]) += weight * value * known.transpose();
          for (const auto& [i, other] : row) {
            if (!fixed[i]) entries.emplace_back(unknown[j], unknown[i], weight * value * other);
          }
        }
      };
      for (std::size_t k = 0; k <= m; ++k) {
        const Eigen::Index span = CompressorSpline::Span(u_[k], kDegree, knots_);
        const auto basis = CompressorSpline::BasisFunctions(u_[k], kDegree, knots_);
        std::vector<std::pair<std::size_t, double>> row;
        for (Eigen::Index b = 0; b <= kDegree; ++b) row.emplace_back(static_cast<std::size_t>(span - kDegree + b), basis(b));
        add_row(row, points_[k], 1.0);
      }
      for (std::size_t j = 1; j + 1 < n; ++j) {
        add_row({{j - 1, 1.0}, {j, -2.0}, {j + 1, 1.0}}, Eigen::Vector3d::Zero(), lambda);
      }
      Eigen::SparseMatrix<double> normal(unknowns, unknowns);
      normal.setFromTriplets(entries.begin(), entries.end());
      const Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> solver(normal);
      const Eigen::MatrixXd solution = solver.solve(rhs);
      for (std::size_t j = 0; j < n; ++j) {
        if (!fixed[j]) control.col(static_cast<Eigen::Index>(j)) = solution.row(unknown[j]).transpose();
      }
    }
    return CompressorSpline(knots_, control.array());
  }

  /// Largest distance between the curve and the programmed points and polyline (both ways).
  double deviation_m(const CompressorSpline& curve) const {
    double worst = 0.0;
    const std::size_t m = points_.size() - 1;
    for (std::size_t k = 0; k <= m; ++k) {
      // Nearest curve point by Newton on (S - P) . S' = 0 from the point's own parameter.
      double u = u_[k];
      for (int iteration = 0; iteration < 8; ++iteration) {
        const auto d = curve.derivatives(u, 2);
        const Eigen::Vector3d r = d.col(0).matrix() - points_[k];
        const Eigen::Vector3d s1 = d.col(1).matrix(), s2 = d.col(2).matrix();
        const double slope = s2.dot(r) + s1.squaredNorm();
        if (!(slope > 0.0)) break;
        u = std::clamp(u - r.dot(s1) / slope, 0.0, 1.0);
      }
      const double distance = (curve(u).matrix() - points_[k]).norm();
      if (!(distance <= worst)) worst = std::isnan(distance) ? std::numeric_limits<double>::infinity() : distance;
    }
    constexpr int kChecksPerBlock = 8;
    for (std::size_t k = 1; k <= m; ++k) {
      for (int c = 1; c < kChecksPerBlock; ++c) {
        const double u = u_[k - 1] + (u_[k] - u_[k - 1]) * c / kChecksPerBlock;
        const Eigen::Vector3d at = curve(u).matrix();
        double nearest = std::numeric_limits<double>::infinity();
        for (std::size_t s = k > 2 ? k - 2 : 1; s <= std::min(m, k + 2); ++s) {
          nearest = std::min(nearest, segment_distance(at, points_[s - 1], points_[s]));
        }
        if (!(nearest <= worst)) worst = std::isnan(nearest) ? std::numeric_limits<double>::infinity() : nearest;
      }
    }
    return worst;
  }

  /// The block (1 .. m) whose parameter interval holds u.
  std::size_t block_of(double u) const {
    const auto it = std::lower_bound(u_.begin() + 1, u_.end(), u);
    return it == u_.end() ? u_.size() - 1 : static_cast<std::size_t>(it - u_.begin());
  }

 private:
  const std::vector<Eigen::Vector3d>& points_;
  const Run& run_;
  std::vector<double> u_;
  double length_m_ = 0.0;
  CompressorSpline::KnotVectorType knots_;
  std::size_t control_count_ = 0;
};

/// Sample parameters in (ua, ub] (ub included) so that each chord's sagitta is below
/// sagitta_m and the tangent turns by at most max_turn_rad over it.
void sample_curve(const CompressorSpline& curve, double ua, double ub, double sagitta_m, double max_turn_rad,
                  int depth, std::vector<double>& out) {
  const Eigen::Vector3d a = curve(ua).matrix(), b = curve(ub).matrix();
  double sagitta = 0.0;
  for (double f : {0.25, 0.5, 0.75}) {
    sagitta = std::max(sagitta, segment_distance(curve(ua + f * (ub - ua)).matrix(), a, b));
  }
  const double turn = angle_between(curve.derivatives(ua, 1).col(1).matrix(), curve.derivatives(ub, 1).col(1).matrix());
  if (depth < 40 && (sagitta > sagitta_m || turn > max_turn_rad)) {
    const double um = 0.5 * (ua + ub);
    sample_curve(curve, ua, um, sagitta_m, max_turn_rad, depth + 1, out);
    sample_curve(curve, um, ub, sagitta_m, max_turn_rad, depth + 1, out);
    return;
  }
  out.push_back(ub);
}

}  // namespace

void CompressorOptions::validate() const {
  auto fail = [](const std::string& field, double value, const std::string& rule) {
    throw InputError("compressor: " + field + " = " + format_double(value) + ": " + rule);
  };
  if (!std::isnan(override_tolerance_m) && !(override_tolerance_m >= 0.0 && std::isfinite(override_tolerance_m))) {
    fail("override_tolerance_m", override_tolerance_m, "must be NaN (the program decides) or >= 0");
  }
  if (!(max_block_length_m > 0.0) || !std::isfinite(max_block_length_m)) fail("max_block_length_m", max_block_length_m, "must be > 0");
  if (!(corner_angle_rad > 0.0 && corner_angle_rad < std::numbers::pi)) fail("corner_angle_rad", corner_angle_rad, "must be in (0, pi)");
  if (min_run_blocks < 2) fail("min_run_blocks", static_cast<double>(min_run_blocks), "must be >= 2");
  if (!(sampling_fraction > 0.0 && sampling_fraction <= 0.5)) fail("sampling_fraction", sampling_fraction, "must be in (0, 0.5]");
  if (!(max_sagitta_m > 0.0) || !std::isfinite(max_sagitta_m)) fail("max_sagitta_m", max_sagitta_m, "must be > 0");
  if (!(max_chord_turn_rad > 0.0 && max_chord_turn_rad < corner_angle_rad)) {
    fail("max_chord_turn_rad", max_chord_turn_rad, "must be in (0, corner_angle_rad)");
  }
}

CompressorResult compress_polylines(const toolpath::Toolpath& path, const CompressorOptions& options) {
  options.validate();
  const std::vector<PathPoint>& p = path.points;
  const std::size_t count = p.size();
  CompressorResult result;
  result.summary.points_in = count;

  const auto tolerance_at = [&](std::size_t i) {
    const double tolerance = std::isnan(options.override_tolerance_m) ? p[i].compressor_tolerance_m : options.override_tolerance_m;
    return tolerance > 0.0 ? tolerance : 0.0;
  };
  const auto chord = [&](std::size_t i) -> Eigen::Vector3d { return p[i].tip_W_m - p[i - 1].tip_W_m; };
  // The motion ending at i is a short G1 block under the compressor (orientation aside).
  const auto short_g1 = [&](std::size_t i) {
    const PathPoint& a = p[i - 1];
    const PathPoint& b = p[i];
    const double length = chord(i).norm();
    return b.kind == MotionKind::linear && b.feed_m_per_s > 0.0 && b.inverse_time_feed_per_s == 0.0 &&
           length > 1e-12 && length <= options.max_block_length_m && a.tool_number == b.tool_number &&
           same_or_both_nan(a.tool_length_m, b.tool_length_m) && tolerance_at(i) > 0.0;
  };
  std::vector<char> eligible(count, 0);  // per motion (index of its end point)
  for (std::size_t i = 1; i < count; ++i) {
    if (!short_g1(i)) continue;
    if (same_orientation(p[i - 1], p[i])) {
      eligible[i] = 1;
    } else {
      ++result.summary.orientation_blocks_left;
    }
  }
  // Motions i and i + 1 in one run: point i is an inner point of it.
  const auto joined = [&](std::size_t i) {
    return eligible[i] && eligible[i + 1] && tolerance_at(i) == tolerance_at(i + 1) && p[i].corner_tolerance_m != 0.0 &&
           p[i].dwell_s == 0.0 &&
           p[i].jerk_mode == p[i + 1].jerk_mode && p[i].feedforward == p[i + 1].feedforward &&
           angle_between(chord(i), chord(i + 1)) <= options.corner_angle_rad;
  };
  std::vector<Run> runs;
  for (std::size_t i = 1; i < count;) {
    if (!eligible[i]) {
      ++i;
      continue;
    }
    std::size_t end = i;
    while (end + 1 < count && joined(end)) ++end;
    if (end - i + 1 >= options.min_run_blocks) runs.push_back({i - 1, end, tolerance_at(i), std::nullopt, std::nullopt});
    i = end + 1;
  }
  // End tangents where a run meets cutting motion without a corner or an exact stop.
  for (std::size_t r = 0; r < runs.size(); ++r) {
    Run& run = runs[r];
    const std::size_t a = run.first, b = run.last;
    if (a >= 1 && p[a].kind != MotionKind::rapid && chord(a).norm() > 1e-12 && p[a].corner_tolerance_m != 0.0 &&
        p[a].dwell_s == 0.0 &&
        angle_between(chord(a), chord(a + 1)) <= options.corner_angle_rad) {
      const bool after_run = r > 0 && runs[r - 1].last == a;
      run.start_tangent = after_run ? (chord(a).normalized() + chord(a + 1).normalized()).normalized()
                                    : Eigen::Vector3d(chord(a).normalized());
    }
    if (b + 1 < count && p[b + 1].kind != MotionKind::rapid && chord(b + 1).norm() > 1e-12 &&
        p[b].corner_tolerance_m != 0.0 && p[b].dwell_s == 0.0 &&
        angle_between(chord(b), chord(b + 1)) <= options.corner_angle_rad) {
      const bool before_run = r + 1 < runs.size() && runs[r + 1].first == b;
      run.end_tangent = before_run ? (chord(b).normalized() + chord(b + 1).normalized()).normalized()
                                   : Eigen::Vector3d(chord(b + 1).normalized());
    }
  }

  result.toolpath.blocks = path.blocks;
  result.toolpath.warnings = path.warnings;
  result.toolpath.cutter_diameter_m = path.cutter_diameter_m;
  result.toolpath.cutter_corner_radius_m = path.cutter_corner_radius_m;
  result.toolpath.stock_box = path.stock_box;
  std::vector<PathPoint>& out = result.toolpath.points;
  out.reserve(count);
  std::size_t next = 0;  // the next input point to copy
  for (const Run& run : runs) {
    while (next <= run.first) out.push_back(p[next++]);
    std::vector<Eigen::Vector3d> points;
    for (std::size_t i = run.first; i <= run.last; ++i) points.push_back(p[i].tip_W_m);
    const double allowed_m = (1.0 - options.sampling_fraction) * run.tolerance_m;
    // lambda from 1e-10 (nearly least squares) to 1e8 (nearly the tangent-constrained
    // cubic): the largest that passes, to a half decade, by bisection of its exponent. About
    // one control point per two blocks first; where even the least-squares fit misses, one per
    // block (knots at the points: the curve can pass through them).
    double low = -10.0, high = 8.0;
    std::optional<CompressorSpline> best;
    double best_deviation = 0.0;
    std::optional<RunFitter> chosen;
    for (const bool dense : {false, true}) {
      RunFitter fitter(points, run, dense);
      CompressorSpline curve = fitter.fit(std::pow(10.0, low));
      const double deviation = fitter.deviation_m(curve);
      if (deviation <= allowed_m) {
        best = curve;
        best_deviation = deviation;
        chosen.emplace(std::move(fitter));
        break;
      }
    }
    if (!best) {
      ++result.summary.runs_left;
      continue;  // the run's points are copied as they are
    }
    const RunFitter& fitter = *chosen;
    double best_exponent = low;
    while (high - low > 0.5) {
      const double middle = 0.5 * (low + high);
      CompressorSpline curve = fitter.fit(std::pow(10.0, middle));
      const double deviation = fitter.deviation_m(curve);
      if (deviation <= allowed_m) {
        low = middle;
        best = curve;
        best_deviation = deviation;
        best_exponent = middle;
      } else {
        high = middle;
      }
    }
    // Evenly in u, as many intervals as blocks (no coarser: a chord over a whole period of a
    // wave would see no sagitta at its quarter points; even: a cubic spline through unevenly
    // spaced points has a third derivative that jumps with the spacing), bisected further.
    std::vector<double> samples;
    const std::size_t intervals = points.size() - 1;
    for (std::size_t k = 1; k <= intervals; ++k) {
      sample_curve(*best, static_cast<double>(k - 1) / static_cast<double>(intervals),
                   k == intervals ? 1.0 : static_cast<double>(k) / static_cast<double>(intervals),
                   std::min(options.sampling_fraction * run.tolerance_m, options.max_sagitta_m),
                   options.max_chord_turn_rad, 0, samples);
    }
    for (double u : samples) {
      if (u >= 1.0) break;
      PathPoint sample = p[run.first + fitter.block_of(u)];
      sample.tip_W_m = (*best)(u).matrix();
      sample.dwell_s = 0.0;  // only the run's last point may dwell (inner dwells break runs)
      out.push_back(sample);
    }
    out.push_back(p[run.last]);
    next = run.last + 1;
    CompressedRun done;
    done.first_point = run.first;
    done.last_point = run.last;
    done.tolerance_m = run.tolerance_m;
    done.length_m = fitter.length_m();
    done.lambda = std::pow(10.0, best_exponent);
    done.deviation_m = best_deviation;
    done.start_tangent_fixed = run.start_tangent.has_value();
    done.end_tangent_fixed = run.end_tangent.has_value();
    done.samples = samples.size();
    done.curve = *best;
    result.summary.deviation_max_m = std::max(result.summary.deviation_max_m, best_deviation);
    result.summary.blocks_compressed += run.last - run.first;
    result.runs.push_back(std::move(done));
    ++result.summary.runs;
  }
  while (next < count) out.push_back(p[next++]);
  result.summary.points_out = out.size();
  return result;
}

}  // namespace vmsim::planner
