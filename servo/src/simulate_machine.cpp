// The whole machine from a set-point trace: every axis with a `.cmd` column, independently.
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "vmsim/common/errors.hpp"
#include "vmsim/common/files.hpp"
#include "vmsim/servo/servo.hpp"

namespace vmsim::servo {
namespace {

// File units of a position (mm or deg) per joint unit.
double trace_scale(const kinematics::Axis& axis) {
  return axis.type == kinematics::AxisType::linear ? 1e3 : 180.0 / std::numbers::pi;
}

std::vector<double> scaled(const std::vector<double>& values, double factor) {
  std::vector<double> result(values.size());
  for (std::size_t i = 0; i < values.size(); ++i) result[i] = values[i] * factor;
  return result;
}

std::vector<double>* signal(AxisSignals& s, int i) {
  std::vector<double>* all[] = {&s.t, &s.cmd, &s.pos, &s.load_pos, &s.motor_pos, &s.vel, &s.current,
                                &s.following_error, &s.control_deviation, &s.velocity_setpoint,
                                &s.velocity_feedforward, &s.torque_feedforward, &s.current_setpoint};
  return all[i];
}
constexpr int kSignals = 13;

}  // namespace

void move_records(AxisSignals& from, std::size_t count, AxisSignals& to) {
  for (int i = 0; i < kSignals; ++i) {
    std::vector<double>& source = *signal(from, i);
    std::vector<double>& target = *signal(to, i);
    const std::size_t n = std::min(count, source.size());
    if (n == 0) continue;
    if (target.empty() && n == source.size()) {
      target.swap(source);
      continue;
    }
    target.insert(target.end(), source.begin(), source.begin() + static_cast<std::ptrdiff_t>(n));
    source.erase(source.begin(), source.begin() + static_cast<std::ptrdiff_t>(n));
  }
}

MachineSimulator::MachineSimulator(const kinematics::MachineModel& machine, const std::vector<int>& axes,
                                   const std::vector<double>& reference, double start_time_s,
                                   double period_s, const SimulationOptions& options) {
  for (int j : axes) {
    axes_.emplace_back(make_axis_servo_model(machine, j, reference, options.gravity), start_time_s,
                       period_s, AxisInput::Kind::position, options);
  }
  ready_.resize(axes_.size());
}

MachineSimulator::~MachineSimulator() = default;
MachineSimulator::MachineSimulator(MachineSimulator&&) noexcept = default;

std::vector<AxisSignals> MachineSimulator::advance(const Eigen::Ref<const Eigen::MatrixXd>& setpoints) {
  if (static_cast<std::size_t>(setpoints.rows()) != axes_.size()) {
    throw InputError("servo: " + std::to_string(setpoints.rows()) + " rows of set points for " +
                     std::to_string(axes_.size()) + " simulated axes");
  }
  for (std::size_t a = 0; a < axes_.size(); ++a) {
    row_.resize(static_cast<std::size_t>(setpoints.cols()));
    for (Eigen::Index k = 0; k < setpoints.cols(); ++k) {
      row_[static_cast<std::size_t>(k)] = setpoints(static_cast<Eigen::Index>(a), k);
    }
    axes_[a].advance(row_, ready_[a]);
  }
  return release(false);
}

std::vector<AxisSignals> MachineSimulator::finish(double extra_time_s) {
  for (std::size_t a = 0; a < axes_.size(); ++a) axes_[a].finish(ready_[a], extra_time_s);
  return release(true);
}

std::vector<AxisSignals> MachineSimulator::release(bool all) {
  std::size_t count = std::numeric_limits<std::size_t>::max();
  for (const AxisSignals& s : ready_) count = std::min(count, s.t.size());
  std::vector<AxisSignals> out(axes_.size());
  if (ready_.empty()) return out;
  for (std::size_t a = 0; a < ready_.size(); ++a) move_records(ready_[a], all ? ready_[a].t.size() : count, out[a]);
  return out;
}

Trace simulate_machine(const kinematics::MachineModel& machine, const Trace& setpoints,
                       const std::string& setpoints_file, const SimulationOptions& options,
                       const std::vector<int>& row_lines) {
  auto line_of = [&](std::size_t row) {
    return row < row_lines.size() ? row_lines[row] : 0;
  };
  const auto t_index = setpoints.column_index("t");
  if (!t_index) throw InputError(located_message(setpoints_file, 0, 0, "no column 't'"));
  const std::vector<double>& t = setpoints.values[*t_index];
  if (t.size() < 2) {
    throw InputError(located_message(setpoints_file, 0, 0,
                                     "at least two set points are needed, got " +
                                         std::to_string(t.size())));
  }
  const double period = (t.back() - t.front()) / static_cast<double>(t.size() - 1);
  for (std::size_t i = 1; i < t.size(); ++i) {
    const double dt = t[i] - t[i - 1];
    if (std::abs(dt - period) > 1e-6 * period) {
      throw InputError(located_message(
          setpoints_file, line_of(i), 0,
          "the servo simulation needs set points at a uniform period: t steps by " +
              format_double(dt) + " s here (row " + std::to_string(i + 1) +
              "), the mean period is " + format_double(period) + " s"));
    }
  }

  // Which axes are simulated; the others stay at home (for the gravity reference).
  std::vector<int> simulated;
  std::vector<double> reference = std::vector<double>(machine.axes.size());
  for (std::size_t j = 0; j < machine.axes.size(); ++j) {
    const auto column = setpoints.column_index(machine.axes[j].name + ".cmd");
    reference[j] = column ? setpoints.values[*column].front() / trace_scale(machine.axes[j])
                          : machine.axes[j].home;
    if (column) simulated.push_back(static_cast<int>(j));
  }
  if (simulated.empty()) {
    throw InputError(located_message(setpoints_file, 0, 0,
                                     "no '<AXIS>.cmd' column for an axis of the machine " +
                                         machine.name));
  }

  // A set point beyond an end stop is not a motion the machine can make: refused before anything
  // is simulated (the drive model has no end stops and would follow it without a word).
  for (int j : simulated) {
    const kinematics::Axis& axis = machine.axes[static_cast<std::size_t>(j)];
    if (axis.type == kinematics::AxisType::rotary && axis.continuous) continue;
    const double scale = trace_scale(axis);
    const std::vector<double>& column = setpoints.column(axis.name + ".cmd");
    const double low = axis.travel_min * scale, high = axis.travel_max * scale;
    const double slack = 1e-9 * std::max(1.0, high - low);  // the file's decimal rounding
    for (std::size_t i = 0; i < column.size(); ++i) {
      if (!(column[i] >= low - slack && column[i] <= high + slack)) {
        const char* unit = axis.type == kinematics::AxisType::linear ? "mm" : "deg";
        throw InfeasibleError(located_message(
            setpoints_file, line_of(i), 0,
            axis.name + ".cmd = " + format_double(column[i]) + " " + unit + " (row " + std::to_string(i + 1) +
                ") is outside the travel of axis " + axis.name + " [" + format_double(low) + ", " +
                format_double(high) + "] " + unit + " in " + machine.source_file));
      }
    }
  }

  Trace out;
  out.metadata = {{"source", "vmsim servo (feed drive simulation)"},
                  {"machine", machine.source_file},
                  {"setpoints", setpoints_file}};
  // Axis by axis (the axes are independent), each in one window: simulate_axis runs on
  // AxisSimulator, the one code path of windowed and whole runs. One axis's signals at a time.
  bool first = true;
  for (int j : simulated) {
    const kinematics::Axis& axis = machine.axes[static_cast<std::size_t>(j)];
    const double scale = trace_scale(axis);
    AxisInput input;
    input.start_time_s = t.front();
    input.period_s = period;
    input.values = scaled(setpoints.column(axis.name + ".cmd"), 1.0 / scale);
    const AxisServoModel model = make_axis_servo_model(machine, j, reference, options.gravity);
    const AxisSignals s = simulate_axis(model, input, options);
    if (first) {
      out.add_column("t", s.t);
      first = false;
    }
    out.add_column(axis.name + ".cmd", scaled(s.cmd, scale));
    out.add_column(axis.name + ".pos", scaled(s.pos, scale));
    const kinematics::DriveEffects& fx = axis.effects;
    if (fx.backlash.enabled || fx.compliance.enabled || fx.pitch_error.enabled) {
      out.add_column(axis.name + ".pos2", scaled(s.load_pos, scale));
    }
    out.add_column(axis.name + ".vel", scaled(s.vel, scale));
    out.add_column(axis.name + ".cur", s.current);
    if (options.inner_signals) {
      out.add_column(axis.name + "_following_error", scaled(s.following_error, scale));
      out.add_column(axis.name + "_control_deviation", scaled(s.control_deviation, scale));
      out.add_column(axis.name + "_velocity_setpoint", scaled(s.velocity_setpoint, scale));
      out.add_column(axis.name + "_velocity_feedforward", scaled(s.velocity_feedforward, scale));
      out.add_column(axis.name + "_torque_feedforward", s.torque_feedforward);
      out.add_column(axis.name + "_current_setpoint", s.current_setpoint);
    }
  }
  return out;
}

}  // namespace vmsim::servo
