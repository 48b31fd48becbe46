// Measured axis signals, the drive model wrapper, the closed-loop simulation on the measurement's
// grid, and the signal helpers (zero-phase filter, noise level).
#include <algorithm>
#include <cmath>
#include <numbers>

#include "vmsim/common/errors.hpp"
#include "vmsim/identify/identify.hpp"

namespace vmsim::identify {

std::vector<AxisMeasurement> extract_measurements(const kinematics::MachineModel& machine,
                                                  const Trace& trace, const std::string& file) {
  std::vector<AxisMeasurement> result;
  if (trace.sample_count() < 10) {
    throw InputError(file + ": a measured trace needs at least 10 samples, got " +
                     std::to_string(trace.sample_count()));
  }
  const auto t_index = trace.column_index("t");
  if (!t_index) throw InputError(file + ": no column 't'");
  const std::vector<double>& t = trace.values[*t_index];
  double period = 0.0;
  for (int a = 0; a < static_cast<int>(machine.axes.size()); ++a) {
    const kinematics::Axis& axis = machine.axes[static_cast<std::size_t>(a)];
    const auto cmd = trace.column_index(axis.name + ".cmd");
    const auto pos = trace.column_index(axis.name + ".pos");
    if (!cmd || !pos) continue;
    const bool linear = axis.type == kinematics::AxisType::linear;
    const double unit = linear ? 1e-3 : std::numbers::pi / 180.0;
    AxisMeasurement m;
    const double kt = axis.drive.torque_constant_N_m_per_A;
    const double r = axis.drive.ratio;
    std::vector<double> effort;
    if (const auto cur = trace.column_index(axis.name + ".cur")) {
      m.effort_signal = "cur";
      effort = trace.values[*cur];
    } else if (const auto torque = trace.column_index(axis.name + ".torque")) {
      m.effort_signal = "torque";
      effort = trace.values[*torque];
      for (double& e : effort) e /= kt;
    } else if (const auto force = trace.column_index(axis.name + ".force")) {
      if (!linear) {
        throw InputError(file + ": column '" + axis.name + ".force' on the rotary axis " +
                         axis.name + " (use .torque)");
      }
      m.effort_signal = "force";
      effort = trace.values[*force];
      for (double& e : effort) e *= r / kt;
    } else {
      continue;  // no effort: nothing to identify on this axis
    }
    if (period == 0.0 && !uniform_period(t, 1e-6, period)) {
      throw InputError(file + ": the samples are not uniformly spaced in t (relative tolerance "
                       "1e-6); identification needs a uniform period");
    }
    m.axis_name = axis.name;
    m.axis_index = a;
    m.source = file;
    m.period_s = period;
    m.t = t;
    m.effort_A = std::move(effort);
    m.cmd = trace.values[*cmd];
    m.pos = trace.values[*pos];
    for (double& v : m.cmd) v *= unit;
    for (double& v : m.pos) v *= unit;
    if (const auto pos2 = trace.column_index(axis.name + ".pos2")) {
      m.pos2 = trace.values[*pos2];
      for (double& v : m.pos2) v *= unit;
    }
    if (const auto motor = trace.column_index(axis.name + ".pos_motor")) {
      if (!m.pos2.empty()) {
        throw InputError(file + ": axis " + axis.name + " has both .pos2 and .pos_motor: log the "
                         "other measuring system once (.pos2 when the loop is closed on the "
                         "motor encoder, .pos_motor when it is closed on a direct scale)");
      }
      m.pos_motor = trace.values[*motor];
      for (double& v : m.pos_motor) v *= unit;
    }
    result.push_back(std::move(m));
  }
  if (result.empty()) {
    throw InputError(file + ": no axis of the machine has the columns <AXIS>.cmd, <AXIS>.pos and "
                     "an effort (<AXIS>.cur, .torque or .force)");
  }
  return result;
}

DriveModel make_drive_model(const kinematics::MachineModel& machine, int axis_index) {
  std::vector<double> reference;
  for (const auto& axis : machine.axes) reference.push_back(axis.home);
  return make_drive_model(machine, axis_index, reference);
}

std::vector<double> reference_configuration(const kinematics::MachineModel& machine,
                                            const std::vector<AxisMeasurement>& data) {
  std::vector<double> reference;
  for (const auto& axis : machine.axes) reference.push_back(axis.home);
  for (std::size_t a = 0; a < machine.axes.size(); ++a) {
    double sum = 0.0;
    std::size_t count = 0;
    for (const auto& m : data) {
      if (m.axis_index != static_cast<int>(a)) continue;
      for (double q : m.pos) sum += q;
      count += m.pos.size();
    }
    if (count > 0) reference[a] = sum / static_cast<double>(count);
  }
  return reference;
}

DriveModel make_drive_model(const kinematics::MachineModel& machine, int axis_index,
                            const std::vector<double>& reference) {
  DriveModel model;
  model.servo = servo::make_axis_servo_model(machine, axis_index, reference, true);
  return model;
}

servo::AxisSignals simulate(const DriveModel& model, const AxisMeasurement& data) {
  servo::AxisInput input;
  input.kind = servo::AxisInput::Kind::position;
  const double h = data.period_s;
  const std::size_t n = data.t.size();
  // Lead-in and run-out at the end speeds: a trace cut out of a longer run starts in motion, and
  // the model must not pay for starting from rest (nor for a one-sided last difference).
  const std::size_t lead_in = static_cast<std::size_t>(std::ceil(0.3 / h));
  const std::size_t run_out = 20;
  const std::size_t span = std::min<std::size_t>(5, n - 1);
  const double v_first = (data.cmd[span] - data.cmd[0]) / (static_cast<double>(span) * h);
  const double v_last = (data.cmd[n - 1] - data.cmd[n - 1 - span]) / (static_cast<double>(span) * h);
  input.values.reserve(n + lead_in + run_out);
  for (std::size_t k = lead_in; k >= 1; --k) {
    input.values.push_back(data.cmd.front() - v_first * h * static_cast<double>(k));
  }
  input.values.insert(input.values.end(), data.cmd.begin(), data.cmd.end());
  for (std::size_t k = 1; k <= run_out; ++k) {
    input.values.push_back(data.cmd.back() + v_last * h * static_cast<double>(k));
  }
  input.start_time_s = data.t.front() - h * static_cast<double>(lead_in);
  input.period_s = h;
  if (model.offset_A != 0.0) {
    const double force = -model.offset_A * model.servo.axis.drive.torque_constant_N_m_per_A /
                         model.servo.axis.drive.ratio;
    input.external_force.assign(input.values.size(), force);
  }
  servo::SimulationOptions options;
  options.record_period_s = data.period_s;
  // Cogging is held over a plant step: sub-step so that its phase holds at speed.
  if (model.servo.axis.effects.cogging.enabled) options.plant_substeps = 8;
  servo::AxisSignals out = servo::simulate_axis(model.servo, input, options);
  // The records of the trace's own samples (guard against rounding at the end).
  for (auto* v : {&out.t, &out.cmd, &out.pos, &out.load_pos, &out.motor_pos, &out.vel, &out.current}) {
    if (v->empty()) continue;
    const double last = v->back();
    v->resize(n + lead_in, last);
    v->erase(v->begin(), v->begin() + static_cast<std::ptrdiff_t>(lead_in));
  }
  return out;
}

namespace {

std::vector<double> butterworth_pass(const std::vector<double>& x, double b0, double b1,
                                     double b2, double a1, double a2) {
  std::vector<double> y(x.size());
  double x1 = x.front(), x2 = x.front(), y1 = x.front(), y2 = x.front();
  for (std::size_t i = 0; i < x.size(); ++i) {
    const double v = b0 * x[i] + b1 * x1 + b2 * x2 - a1 * y1 - a2 * y2;
    x2 = x1;
    x1 = x[i];
    y2 = y1;
    y1 = v;
    y[i] = v;
  }
  return y;
}

}  // namespace

std::vector<double> zero_phase_lowpass(const std::vector<double>& x, double period_s,
                                       double cutoff_hz) {
  const std::size_t n = x.size();
  if (n < 4 || cutoff_hz <= 0.0 || cutoff_hz >= 0.5 / period_s) return x;
  const double k = std::tan(std::numbers::pi * cutoff_hz * period_s);
  const double norm = 1.0 / (1.0 + std::numbers::sqrt2 * k + k * k);
  const double b0 = k * k * norm, b1 = 2.0 * b0, b2 = b0;
  const double a1 = 2.0 * (k * k - 1.0) * norm;
  const double a2 = (1.0 - std::numbers::sqrt2 * k + k * k) * norm;
  // Odd reflection at both ends (as filtfilt) over about three time constants.
  const std::size_t pad = std::min(n - 1, static_cast<std::size_t>(3.0 / (cutoff_hz * period_s)) + 1);
  std::vector<double> ext;
  ext.reserve(n + 2 * pad);
  for (std::size_t i = pad; i >= 1; --i) ext.push_back(2.0 * x.front() - x[i]);
  ext.insert(ext.end(), x.begin(), x.end());
  for (std::size_t i = 1; i <= pad; ++i) ext.push_back(2.0 * x.back() - x[n - 1 - i]);
  std::vector<double> y = butterworth_pass(ext, b0, b1, b2, a1, a2);
  std::reverse(y.begin(), y.end());
  y = butterworth_pass(y, b0, b1, b2, a1, a2);
  std::reverse(y.begin(), y.end());
  return std::vector<double>(y.begin() + static_cast<std::ptrdiff_t>(pad),
                             y.begin() + static_cast<std::ptrdiff_t>(pad + n));
}

double robust_noise_level(const std::vector<double>& signal) {
  // Fourth difference (binomial 1 -4 6 -4 1, gain sqrt(70) on white noise): a smooth signal
  // (motion, friction, inertia, and any model error of the same kind) hardly enters it; the
  // median absolute value ignores the few samples where the signal itself has a corner
  // (a reversal, the start of an acceleration).
  if (signal.size() < 9) return 0.0;
  std::vector<double> d;
  d.reserve(signal.size() - 4);
  for (std::size_t i = 2; i + 2 < signal.size(); ++i) {
    d.push_back(std::abs(signal[i - 2] - 4.0 * signal[i - 1] + 6.0 * signal[i] -
                         4.0 * signal[i + 1] + signal[i + 2]));
  }
  auto mid = d.begin() + static_cast<std::ptrdiff_t>(d.size() / 2);
  std::nth_element(d.begin(), mid, d.end());
  return 1.4826 * *mid / std::sqrt(70.0);
}

double noise_level(const std::vector<double>& residual) {
  // RMS, not a robust scale: the one-sample spikes an encoder count gives a differenced
  // velocity (and so the current) are part of the noise the model cannot follow.
  if (residual.size() < 5) return 0.0;
  double sum = 0.0;
  for (std::size_t i = 1; i + 1 < residual.size(); ++i) {
    const double d = residual[i + 1] - 2.0 * residual[i] + residual[i - 1];
    sum += d * d;
  }
  return std::sqrt(sum / static_cast<double>(residual.size() - 2) / 6.0);
}

}  // namespace vmsim::identify
