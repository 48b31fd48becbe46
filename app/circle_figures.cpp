// Figures of a circular test: least-squares circle, G, H, harmonics and the reversal features.
#include "circle_figures.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <numeric>

namespace vmsim::app::circle {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kTwoPi = 2.0 * std::numbers::pi;

// Angle to (-pi, pi].
double wrapped(double angle_rad) {
  double a = std::remainder(angle_rad, kTwoPi);
  if (a <= -kPi) a += kTwoPi;
  return a;
}

// Angle to [0, 2 pi).
double positive_angle(double angle_rad) {
  double a = std::fmod(angle_rad, kTwoPi);
  if (a < 0.0) a += kTwoPi;
  if (a >= kTwoPi) a -= kTwoPi;
  return a;
}

// Samples of an arc sorted by angle, with the deviation and the angular weight of each.
struct SortedArc {
  std::vector<double> angle_rad;
  std::vector<double> deviation_m;
  std::vector<double> weight_rad;
};

SortedArc sorted_arc(const DataArc& arc, double radius_m) {
  std::vector<std::size_t> order(arc.angle_rad.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::sort(order.begin(), order.end(),
            [&](std::size_t a, std::size_t b) { return arc.angle_rad[a] < arc.angle_rad[b]; });
  SortedArc out;
  for (std::size_t i : order) {
    out.angle_rad.push_back(arc.angle_rad[i]);
    out.deviation_m.push_back(arc.radius_m[i] - radius_m);
  }
  const std::size_t n = out.angle_rad.size();
  out.weight_rad.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const double previous = i > 0 ? out.angle_rad[i - 1] : out.angle_rad[n - 1] - kTwoPi;
    const double next = i + 1 < n ? out.angle_rad[i + 1] : out.angle_rad[0] + kTwoPi;
    out.weight_rad[i] = 0.5 * (next - previous);
  }
  return out;
}

// Weighted least squares of the deviation on 1, cos t, sin t (and cos 2t, sin 2t), and with
// `direction_sign` != 0 the lost-motion patterns of both axes (CircleFigures::lost_motion_m).
Eigen::VectorXd harmonic_fit(const SortedArc& arc, int harmonics, double direction_sign = 0.0) {
  const int columns = 1 + 2 * harmonics + (direction_sign != 0.0 ? 2 : 0);
  Eigen::MatrixXd normal = Eigen::MatrixXd::Zero(columns, columns);
  Eigen::VectorXd right = Eigen::VectorXd::Zero(columns);
  Eigen::VectorXd basis(columns);
  for (std::size_t i = 0; i < arc.angle_rad.size(); ++i) {
    basis(0) = 1.0;
    const double t = arc.angle_rad[i];
    for (int k = 1; k <= harmonics; ++k) {
      basis(2 * k - 1) = std::cos(k * t);
      basis(2 * k) = std::sin(k * t);
    }
    if (direction_sign != 0.0) {
      // A table lagging its motion by g / 2 on each axis: u moves towards -u where s sin t > 0
      // (u = R cos t), v towards -v where s cos t < 0; radially g/2 cos t and g/2 sin t.
      const auto sign = [](double x) { return x > 0.0 ? 1.0 : (x < 0.0 ? -1.0 : 0.0); };
      basis(1 + 2 * harmonics) = 0.5 * direction_sign * sign(std::sin(t)) * std::cos(t);
      basis(2 + 2 * harmonics) = -0.5 * direction_sign * sign(std::cos(t)) * std::sin(t);
    }
    normal += arc.weight_rad[i] * basis * basis.transpose();
    right += arc.weight_rad[i] * arc.deviation_m[i] * basis;
  }
  return normal.ldlt().solve(right);
}

struct Line {
  double offset = 0.0;
  double slope = 0.0;
  bool valid = false;
  double at(double x) const { return offset + slope * x; }
};

Line fit_line(const std::vector<double>& x, const std::vector<double>& y) {
  Line line;
  const std::size_t n = x.size();
  if (n < 2) return line;
  const double mx = std::accumulate(x.begin(), x.end(), 0.0) / static_cast<double>(n);
  const double my = std::accumulate(y.begin(), y.end(), 0.0) / static_cast<double>(n);
  double sxx = 0.0, sxy = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    sxx += (x[i] - mx) * (x[i] - mx);
    sxy += (x[i] - mx) * (y[i] - my);
  }
  line.slope = sxx > 0.0 ? sxy / sxx : 0.0;
  line.offset = my - line.slope * mx;
  line.valid = sxx > 0.0;
  return line;
}

}  // namespace

std::string direction_name(Direction direction) { return direction == Direction::ccw ? "CCW" : "CW"; }

std::vector<DataArc> find_data_arcs(const PlanePath& path, double radius_m, double band_m) {
  // The samples near the circle, with their angle unwrapped along the motion.
  std::vector<std::size_t> index;
  std::vector<double> unwrapped;
  for (std::size_t k = 0; k < path.t_s.size(); ++k) {
    const double r = std::hypot(path.u_m[k], path.v_m[k]);
    if (!(std::abs(r - radius_m) <= band_m)) continue;
    const double angle = std::atan2(path.v_m[k], path.u_m[k]);
    unwrapped.push_back(unwrapped.empty() ? angle : unwrapped.back() + wrapped(angle - unwrapped.back()));
    index.push_back(k);
  }
  // Runs of one direction: a run ends at its extreme angle once the angle has turned back
  // from it by more than the turn-back threshold.
  const double turn_back = 10.0 * kPi / 180.0;
  std::vector<std::pair<std::size_t, std::size_t>> runs;  // first, last (positions in `index`)
  std::size_t first = 0;
  while (first < unwrapped.size()) {
    int sign = 0;
    std::size_t extreme = first;
    std::size_t k = first + 1;
    for (; k < unwrapped.size(); ++k) {
      if (sign == 0) {
        if (std::abs(unwrapped[k] - unwrapped[first]) > turn_back) sign = unwrapped[k] > unwrapped[first] ? 1 : -1;
        if (sign == 0) continue;
      }
      if ((unwrapped[k] - unwrapped[extreme]) * sign > 0.0) extreme = k;
      if ((unwrapped[extreme] - unwrapped[k]) * sign > turn_back) break;
    }
    if (sign != 0) runs.emplace_back(first, extreme);
    if (k >= unwrapped.size()) break;
    first = std::max(extreme, first + 1);
  }
  std::vector<DataArc> arcs;
  for (const auto& [begin, end] : runs) {
    const double span = std::abs(unwrapped[end] - unwrapped[begin]);
    if (span < kTwoPi) continue;
    const int sign = unwrapped[end] > unwrapped[begin] ? 1 : -1;
    const double middle = 0.5 * (unwrapped[begin] + unwrapped[end]);
    DataArc arc;
    arc.direction = sign > 0 ? Direction::ccw : Direction::cw;
    double first_angle = 0.0, last_angle = 0.0;
    for (std::size_t j = begin; j <= end; ++j) {
      // The 360 degrees around the middle, half-open so that no angle is taken twice.
      const double from_middle = (unwrapped[j] - middle) * sign;
      if (from_middle < -kPi || from_middle >= kPi) continue;
      const std::size_t k = index[j];
      if (arc.t_s.empty()) first_angle = unwrapped[j];
      last_angle = unwrapped[j];
      arc.t_s.push_back(path.t_s[k]);
      arc.angle_rad.push_back(positive_angle(unwrapped[j]));
      arc.radius_m.push_back(std::hypot(path.u_m[k], path.v_m[k]));
    }
    if (arc.t_s.size() < 16) continue;
    const double duration = arc.t_s.back() - arc.t_s.front();
    arc.angular_speed_rad_per_s = duration > 0.0 ? std::abs(last_angle - first_angle) / duration : 0.0;
    arcs.push_back(std::move(arc));
  }
  return arcs;
}

CircleFigures circle_figures(const DataArc& arc, double radius_m, const FigureOptions& options) {
  CircleFigures figures;
  figures.direction = arc.direction;
  figures.angular_speed_rad_per_s = arc.angular_speed_rad_per_s;
  const SortedArc sorted = sorted_arc(arc, radius_m);
  if (sorted.angle_rad.size() < 8) return figures;
  // The least-squares circle, linearised for deviations small against the radius: r - R =
  // dR + a cos t + b sin t (a, b: the centre's offset).
  const Eigen::VectorXd lsc = harmonic_fit(sorted, 1);
  figures.mean_radius_deviation_m = lsc(0);
  figures.lsc_centre_u_m = lsc(1);
  figures.lsc_centre_v_m = lsc(2);
  std::vector<double> residual(sorted.angle_rad.size());
  double low = 1e300, high = -1e300;
  for (std::size_t i = 0; i < residual.size(); ++i) {
    const double t = sorted.angle_rad[i];
    residual[i] = sorted.deviation_m[i] - lsc(1) * std::cos(t) - lsc(2) * std::sin(t);
    low = std::min(low, residual[i] - lsc(0));
    high = std::max(high, residual[i] - lsc(0));
  }
  figures.circular_deviation_G_m = high - low;
  // The ellipse with the axes' lost motion fitted beside it: the steps of a backlash have a
  // second harmonic of 0.85 g at 45 / 135 degrees, which would read as a servo mismatch.
  const double direction_sign = arc.direction == Direction::ccw ? 1.0 : -1.0;
  const Eigen::VectorXd second = harmonic_fit(sorted, 2, direction_sign);
  figures.lost_motion_m = {second(5), second(6)};
  figures.ellipse_size_m = 2.0 * std::hypot(second(3), second(4));
  double major_deg = 0.5 * std::atan2(second(4), second(3)) * 180.0 / kPi;
  if (major_deg < 0.0) major_deg += 180.0;
  if (major_deg >= 180.0) major_deg -= 180.0;
  figures.ellipse_major_axis_deg = major_deg;

  const double sign = direction_sign;
  for (int quadrant = 0; quadrant < 4; ++quadrant) {
    Reversal reversal;
    reversal.axis = quadrant % 2;
    reversal.angle_rad = quadrant * kPi / 2.0;
    std::vector<double> before_x, before_y, after_x, after_y, spike_x, spike_y;
    for (std::size_t i = 0; i < residual.size(); ++i) {
      const double travelled = wrapped(sorted.angle_rad[i] - reversal.angle_rad) * sign;
      if (travelled >= -options.gap_rad - options.line_window_rad && travelled <= -options.gap_rad) {
        before_x.push_back(travelled), before_y.push_back(residual[i]);
      } else if (travelled >= options.settle_rad &&
                 travelled <= options.settle_rad + options.line_window_rad) {
        after_x.push_back(travelled), after_y.push_back(residual[i]);
      }
      if (travelled >= 0.0 && travelled <= options.settle_rad) {
        spike_x.push_back(travelled), spike_y.push_back(residual[i]);
      }
    }
    const Line before = fit_line(before_x, before_y);
    const Line after = fit_line(after_x, after_y);
    reversal.valid = before.valid && after.valid && !spike_x.empty();
    if (reversal.valid) {
      reversal.step_m = after.at(0.0) - before.at(0.0);
      // Beyond both steady lines: a step that takes a few samples to complete (the motor
      // crossing a backlash gap) lies between them and is no spike.
      double peak = 0.0;
      for (std::size_t i = 0; i < spike_x.size(); ++i) {
        const double upper = std::max(before.at(spike_x[i]), after.at(spike_x[i]));
        const double lower = std::min(before.at(spike_x[i]), after.at(spike_x[i]));
        const double off = spike_y[i] > upper ? spike_y[i] - upper : (spike_y[i] < lower ? spike_y[i] - lower : 0.0);
        if (std::abs(off) > std::abs(peak)) peak = off;
      }
      reversal.spike_m = peak;
    }
    figures.reversals.push_back(reversal);
  }
  return figures;
}

std::vector<double> deviation_on_grid(const DataArc& arc, double radius_m,
                                      const std::vector<double>& grid_rad) {
  const SortedArc sorted = sorted_arc(arc, radius_m);
  std::vector<double> out;
  out.reserve(grid_rad.size());
  const std::size_t n = sorted.angle_rad.size();
  if (n == 0) return std::vector<double>(grid_rad.size(), 0.0);
  for (double angle : grid_rad) {
    const double a = positive_angle(angle);
    const auto upper = std::upper_bound(sorted.angle_rad.begin(), sorted.angle_rad.end(), a);
    const std::size_t hi = static_cast<std::size_t>(upper - sorted.angle_rad.begin());
    // Neighbours across 0 / 2 pi where a lies before the first or after the last sample.
    const std::size_t i1 = hi % n;
    const std::size_t i0 = (hi + n - 1) % n;
    double a0 = sorted.angle_rad[i0], a1 = sorted.angle_rad[i1];
    if (hi == 0) a0 -= kTwoPi;
    if (hi == n) a1 += kTwoPi;
    const double w = a1 > a0 ? (a - a0) / (a1 - a0) : 0.0;
    out.push_back(sorted.deviation_m[i0] + w * (sorted.deviation_m[i1] - sorted.deviation_m[i0]));
  }
  return out;
}

double circular_hysteresis_m(const DataArc& ccw, const DataArc& cw, double radius_m) {
  std::vector<double> grid(1440);
  for (std::size_t i = 0; i < grid.size(); ++i) grid[i] = kTwoPi * static_cast<double>(i) / static_cast<double>(grid.size());
  const std::vector<double> a = deviation_on_grid(ccw, radius_m, grid);
  const std::vector<double> b = deviation_on_grid(cw, radius_m, grid);
  double largest = 0.0;
  for (std::size_t i = 0; i < grid.size(); ++i) largest = std::max(largest, std::abs(a[i] - b[i]));
  return largest;
}

}  // namespace vmsim::app::circle
