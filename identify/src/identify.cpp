// Identification: the inverse model by least squares on the zero-phase-filtered measured motion,
// then the set-point delay by a scan of the closed-loop simulation (identify/README.md).
#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

#include "internal.hpp"
#include "vmsim/common/errors.hpp"
#include "vmsim/identify/identify.hpp"

namespace vmsim::identify {
namespace detail {

std::vector<double> derivative(const std::vector<double>& x, double h) {
  const std::size_t n = x.size();
  std::vector<double> d(n, 0.0);
  if (n < 2) return d;
  d.front() = (x[1] - x[0]) / h;
  d.back() = (x[n - 1] - x[n - 2]) / h;
  for (std::size_t i = 1; i + 1 < n; ++i) d[i] = (x[i + 1] - x[i - 1]) / (2.0 * h);
  return d;
}

double scan_minimum(const std::function<double(double)>& f, double lo, double hi, int grid,
                    bool log, double tolerance, double& best) {
  auto at = [&](int i) {
    const double u = grid > 1 ? static_cast<double>(i) / (grid - 1) : 0.0;
    return log ? lo * std::pow(hi / lo, u) : lo + (hi - lo) * u;
  };
  std::vector<double> values(static_cast<std::size_t>(grid));
  int k = 0;
  for (int i = 0; i < grid; ++i) {
    values[static_cast<std::size_t>(i)] = f(at(i));
    if (values[static_cast<std::size_t>(i)] < values[static_cast<std::size_t>(k)]) k = i;
  }
  double a = at(std::max(0, k - 1)), b = at(std::min(grid - 1, k + 1));
  double x_best = at(k);
  best = values[static_cast<std::size_t>(k)];
  if (log) {
    a = std::log(a);
    b = std::log(b);
  }
  auto g = [&](double u) { return f(log ? std::exp(u) : u); };
  const double ratio = 0.6180339887498949;
  double c = b - ratio * (b - a), d = a + ratio * (b - a);
  double fc = g(c), fd = g(d);
  const double tol = log ? std::log1p(tolerance) : tolerance;
  while (std::abs(b - a) > tol) {
    if (fc < fd) {
      b = d;
      d = c;
      fd = fc;
      c = b - ratio * (b - a);
      fc = g(c);
    } else {
      a = c;
      c = d;
      fc = fd;
      d = a + ratio * (b - a);
      fd = g(d);
    }
  }
  const double u = fc < fd ? c : d;
  const double fu = std::min(fc, fd);
  if (fu < best) {
    best = fu;
    x_best = log ? std::exp(u) : u;
  }
  return x_best;
}

}  // namespace detail

namespace {

double rms_difference(const std::vector<double>& a, const std::vector<double>& b) {
  double sum = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) sum += (a[i] - b[i]) * (a[i] - b[i]);
  return std::sqrt(sum / static_cast<double>(std::max<std::size_t>(1, a.size())));
}

}  // namespace

std::vector<AxisIdentification> identify_axes(const kinematics::MachineModel& machine,
                                              const std::vector<AxisMeasurement>& measurements,
                                              const IdentifyOptions& options,
                                              std::vector<std::string>* held_axes) {
  std::vector<AxisIdentification> results;
  // On a whole machine's trace the other axes stand where the trace has them: gravity there.
  const std::vector<double> reference = reference_configuration(machine, measurements);
  for (int a = 0; a < static_cast<int>(machine.axes.size()); ++a) {
    std::vector<const AxisMeasurement*> runs;
    for (const auto& m : measurements) {
      if (m.axis_index == a) runs.push_back(&m);
    }
    if (runs.empty()) continue;
    const kinematics::Axis& axis = machine.axes[static_cast<std::size_t>(a)];
    // An axis the trace holds still (a rotary axis of a 3-axis part program) says nothing of
    // its drive: left as it is, and named in `held_axes`.
    double travel = 0.0;
    for (const AxisMeasurement* m : runs) {
      if (m->cmd.empty()) continue;
      const auto [lo, hi] = std::minmax_element(m->cmd.begin(), m->cmd.end());
      travel = std::max(travel, *hi - *lo);
    }
    if (travel < options.least_travel) {
      if (held_axes) held_axes->push_back(axis.name);
      continue;
    }
    const double kt = axis.drive.torque_constant_N_m_per_A;
    const double r = axis.drive.ratio;
    DriveModel model = make_drive_model(machine, a, reference);
    // The model's gravity at each sample's own position: a tilting rotary axis moves through a
    // sinusoid of its angle (servo::AxisServoModel), which a constant would leave to the fit.
    const bool rotary = axis.type == kinematics::AxisType::rotary;
    auto gravity_A_at = [&](double q) {
      double torque = model.servo.gravity_constant_N_m;
      if (rotary) torque += model.servo.gravity_cos_N_m * std::cos(q) + model.servo.gravity_sin_N_m * std::sin(q);
      return torque / kt;
    };
    const double gravity_A = gravity_A_at(reference[static_cast<std::size_t>(a)]);

    // Rows of the inverse model: [q''/(Kt r), q', sign(q'), 1] theta = effort.
    std::vector<Eigen::Vector4d> rows;
    std::vector<double> targets;
    for (const AxisMeasurement* m : runs) {
      const double fs = 1.0 / m->period_s;
      const double cutoff = options.filter_cutoff_hz > 0.0 ? options.filter_cutoff_hz
                                                           : std::min(50.0, 0.08 * fs);
      const std::vector<double> q = zero_phase_lowpass(m->pos, m->period_s, cutoff);
      const std::vector<double> effort = zero_phase_lowpass(m->effort_A, m->period_s, cutoff);
      const std::vector<double> v = detail::derivative(q, m->period_s);
      const std::vector<double> acc = detail::derivative(v, m->period_s);
      const std::vector<double> vc = detail::derivative(m->cmd, m->period_s);
      double vmax = 0.0;
      for (double x : vc) vmax = std::max(vmax, std::abs(x));
      const double band = options.standstill_fraction * vmax;
      // Leave out the filter's edge transients.
      const std::size_t edge = std::min(m->t.size() / 4, static_cast<std::size_t>(fs / cutoff));
      for (std::size_t i = edge; i + edge < m->t.size(); ++i) {
        if (std::abs(v[i]) <= band || std::abs(vc[i]) <= band) continue;
        if ((v[i] > 0.0) != (vc[i] > 0.0)) continue;
        rows.emplace_back(acc[i] / (kt * r), v[i], v[i] > 0.0 ? 1.0 : -1.0, 1.0);
        targets.push_back(effort[i] - gravity_A_at(q[i]));
      }
    }
    if (rows.size() < 20) {
      throw InputError(runs.front()->source + ": axis " + axis.name +
                       ": too few moving samples to identify (" + std::to_string(rows.size()) +
                       "); record moves at several speeds in both directions");
    }
    Eigen::MatrixXd phi(static_cast<Eigen::Index>(rows.size()), 4);
    Eigen::VectorXd y(static_cast<Eigen::Index>(rows.size()));
    for (std::size_t i = 0; i < rows.size(); ++i) {
      phi.row(static_cast<Eigen::Index>(i)) = rows[i].transpose();
      y(static_cast<Eigen::Index>(i)) = targets[i];
    }
    // Column scaling for a well-conditioned solve.
    Eigen::Vector4d scale;
    for (int j = 0; j < 4; ++j) {
      scale(j) = phi.col(j).norm();
      if (scale(j) == 0.0) scale(j) = 1.0;
      phi.col(j) /= scale(j);
    }
    Eigen::Vector4d theta = phi.colPivHouseholderQr().solve(y);
    const Eigen::VectorXd fit_residual = y - phi * theta;
    theta = theta.cwiseQuotient(scale);
    const double mean = y.mean();
    const double sst = (y.array() - mean).square().sum();
    AxisIdentification id;
    id.axis_name = axis.name;
    id.axis_index = a;
    id.samples_used = rows.size();
    id.equivalent_inertia_kg_m2 = theta(0);
    id.friction_viscous_A_per_joint_unit_per_s = std::max(0.0, theta(1));
    id.friction_dry_A = std::max(0.0, theta(2));
    id.gravity_A = gravity_A;
    id.offset_A = theta(3);
    id.r2 = sst > 0.0 ? 1.0 - fit_residual.squaredNorm() / sst : 0.0;
    id.residual_rms_A = std::sqrt(fit_residual.squaredNorm() / static_cast<double>(rows.size()));
    if (!(id.equivalent_inertia_kg_m2 > 0.0)) {
      throw InputError(runs.front()->source + ": axis " + axis.name +
                       ": the identified inertia is not positive (" +
                       std::to_string(id.equivalent_inertia_kg_m2) +
                       " kg m^2); record accelerating moves");
    }

    // Closed-loop check and delay scan: effort and position residuals in noise units.
    DriveModel identified = model;
    kinematics::Axis& ax = identified.servo.axis;
    ax.drive.equivalent_inertia_kg_m2 = id.equivalent_inertia_kg_m2;
    ax.drive.rotor_inertia_kg_m2 =
        std::min(ax.drive.rotor_inertia_kg_m2, 0.999 * id.equivalent_inertia_kg_m2);
    ax.drive.friction_viscous_A_per_joint_unit_per_s = id.friction_viscous_A_per_joint_unit_per_s;
    ax.drive.friction_dry_A = id.friction_dry_A;
    identified.offset_A = id.offset_A;
    double before_e = 0.0, before_p = 0.0, noise_e = 0.0, noise_p = 0.0;
    for (const AxisMeasurement* m : runs) {
      const servo::AxisSignals s = simulate(model, *m);
      before_e += std::pow(rms_difference(m->effort_A, s.current), 2);
      before_p += std::pow(rms_difference(m->pos, s.pos), 2);
      std::vector<double> re(m->t.size()), rp(m->t.size());
      for (std::size_t i = 0; i < re.size(); ++i) {
        re[i] = m->effort_A[i] - s.current[i];
        rp[i] = m->pos[i] - s.pos[i];
      }
      noise_e = std::max(noise_e, noise_level(re));
      noise_p = std::max(noise_p, noise_level(rp));
    }
    const double runs_n = static_cast<double>(runs.size());
    id.simulation_effort_rms_before_A = std::sqrt(before_e / runs_n);
    id.simulation_position_rms_before = std::sqrt(before_p / runs_n);
    noise_e = std::max(noise_e, 1e-6);
    noise_p = std::max(noise_p, 1e-9);
    auto cost = [&](double delay) {
      DriveModel trial = identified;
      trial.servo.axis.controller.delay_s = delay;
      double total = 0.0;
      for (const AxisMeasurement* m : runs) {
        const servo::AxisSignals s = simulate(trial, *m);
        total += std::pow(rms_difference(m->effort_A, s.current) / noise_e, 2) +
                 std::pow(rms_difference(m->pos, s.pos) / noise_p, 2);
      }
      return total;
    };
    double best = 0.0;
    const double period = runs.front()->period_s;
    const int grid = std::clamp(static_cast<int>(options.delay_max_s / (0.5 * period)) + 1, 5, 41);
    id.delay_s = detail::scan_minimum(cost, 0.0, options.delay_max_s, grid, false, 0.01 * period,
                                      best);
    identified.servo.axis.controller.delay_s = id.delay_s;

    // Output-error refinement: J, a, b and the offset by Gauss-Newton on the closed-loop
    // effort residual (low-passed like the inverse model's signals), started from the inverse
    // model. It removes what the inverse model cannot see (loop dynamics between the samples,
    // aliasing of a fast current loop); it is kept only where it lowers the residual.
    if (options.output_error_iterations > 0) {
      const double cutoff0 = options.filter_cutoff_hz > 0.0
                                 ? options.filter_cutoff_hz
                                 : std::min(50.0, 0.08 / runs.front()->period_s);
      auto apply = [&](const Eigen::Vector4d& p) {
        DriveModel m = identified;
        auto& d = m.servo.axis.drive;
        d.equivalent_inertia_kg_m2 = std::max(p(0), 1e-6 * id.equivalent_inertia_kg_m2);
        d.rotor_inertia_kg_m2 = std::min(d.rotor_inertia_kg_m2, 0.999 * d.equivalent_inertia_kg_m2);
        d.friction_viscous_A_per_joint_unit_per_s = std::max(0.0, p(1));
        d.friction_dry_A = std::max(0.0, p(2));
        m.offset_A = p(3);
        return m;
      };
      auto residual = [&](const DriveModel& m) {
        std::vector<double> all;
        for (const AxisMeasurement* run : runs) {
          const servo::AxisSignals s = simulate(m, *run);
          std::vector<double> e(run->t.size());
          for (std::size_t i = 0; i < e.size(); ++i) e[i] = run->effort_A[i] - s.current[i];
          e = zero_phase_lowpass(e, run->period_s, cutoff0);
          all.insert(all.end(), e.begin(), e.end());
        }
        return Eigen::VectorXd(Eigen::Map<Eigen::VectorXd>(all.data(), static_cast<Eigen::Index>(all.size())));
      };
      Eigen::Vector4d p(id.equivalent_inertia_kg_m2, id.friction_viscous_A_per_joint_unit_per_s,
                        id.friction_dry_A, id.offset_A);
      double vmax = 0.0;
      for (const AxisMeasurement* run : runs) {
        for (double x : detail::derivative(run->cmd, run->period_s)) vmax = std::max(vmax, std::abs(x));
      }
      const Eigen::Vector4d step(0.05 * p(0), 0.2 * std::max(p(1), 0.05 / std::max(vmax, 1e-9)),
                                 0.05 + 0.1 * p(2), 0.05 + 0.1 * std::abs(p(3)));
      Eigen::VectorXd r0 = residual(apply(p));
      for (int it = 0; it < options.output_error_iterations; ++it) {
        Eigen::MatrixXd jac(r0.size(), 4);
        for (int j = 0; j < 4; ++j) {
          Eigen::Vector4d q = p;
          q(j) += step(j);
          jac.col(j) = (residual(apply(q)) - r0) / step(j);
        }
        Eigen::Matrix4d hess = jac.transpose() * jac;
        hess.diagonal() *= 1.0 + 1e-6;
        const Eigen::Vector4d delta = hess.ldlt().solve(-jac.transpose() * r0);
        bool accepted = false;
        for (double f : {1.0, 0.5, 0.25}) {
          const Eigen::Vector4d q = p + f * delta;
          const Eigen::VectorXd trial = residual(apply(q));
          if (trial.squaredNorm() < r0.squaredNorm()) {
            p = q;
            r0 = trial;
            accepted = true;
            break;
          }
        }
        if (!accepted) break;
      }
      identified = apply(p);
      id.equivalent_inertia_kg_m2 = identified.servo.axis.drive.equivalent_inertia_kg_m2;
      id.friction_viscous_A_per_joint_unit_per_s =
          identified.servo.axis.drive.friction_viscous_A_per_joint_unit_per_s;
      id.friction_dry_A = identified.servo.axis.drive.friction_dry_A;
      id.offset_A = identified.offset_A;
      // The delay again, near the first estimate, with the refined parameters.
      id.delay_s = detail::scan_minimum(cost, std::max(0.0, id.delay_s - period),
                                        id.delay_s + period, 5, false, 0.01 * period, best);
      identified.servo.axis.controller.delay_s = id.delay_s;
    }
    double after_e = 0.0, after_p = 0.0;
    for (const AxisMeasurement* m : runs) {
      const servo::AxisSignals s = simulate(identified, *m);
      after_e += std::pow(rms_difference(m->effort_A, s.current), 2);
      after_p += std::pow(rms_difference(m->pos, s.pos), 2);
    }
    id.simulation_effort_rms_A = std::sqrt(after_e / runs_n);
    id.simulation_position_rms = std::sqrt(after_p / runs_n);
    results.push_back(id);
  }
  return results;
}

void apply_identification(kinematics::MachineModel& machine, const AxisIdentification& result) {
  kinematics::Axis& axis = machine.axes.at(static_cast<std::size_t>(result.axis_index));
  axis.drive.equivalent_inertia_kg_m2 = result.equivalent_inertia_kg_m2;
  axis.drive.rotor_inertia_kg_m2 =
      std::min(axis.drive.rotor_inertia_kg_m2, 0.999 * result.equivalent_inertia_kg_m2);
  axis.drive.friction_viscous_A_per_joint_unit_per_s =
      result.friction_viscous_A_per_joint_unit_per_s;
  axis.drive.friction_dry_A = result.friction_dry_A;
  axis.controller.delay_s = result.delay_s;
}

}  // namespace vmsim::identify
