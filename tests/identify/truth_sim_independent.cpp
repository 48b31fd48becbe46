// The second, independent truth simulator (see truth_sim_independent.hpp). Written from the
// physics of a cascade-controlled ball-screw axis; it shares no code with servo/ or truth_sim.cpp.
#include "truth_sim_independent.hpp"

#include <algorithm>
#include <cmath>
#include <random>

namespace vmsim::identify::test {
namespace {

constexpr double kPi = 3.141592653589793;

double quantise(double v, double q) { return q > 0.0 ? std::round(v / q) * q : v; }

// Appends a velocity ramp to `target` at `accel` then `hold` seconds at it, on period T.
void ramp_hold(std::vector<double>& vel, double period, double target, double accel, double hold) {
  double v = vel.empty() ? 0.0 : vel.back();
  while (std::abs(target - v) > 1e-12) {
    const double step = std::min(std::abs(target - v), accel * period);
    v += std::copysign(step, target - v);
    vel.push_back(v);
  }
  for (double t = 0.0; t < hold; t += period) vel.push_back(v);
}

}  // namespace

double IndependentDrive::ratio_m_per_rad() const {
  return ratio_joint_per_rad > 0.0 ? ratio_joint_per_rad : lead_m / (2.0 * kPi);
}

double IndependentDrive::equivalent_inertia_kg_m2() const {
  const double r = ratio_m_per_rad();
  return motor_inertia_kg_m2 + load_mass_kg * r * r;
}

std::vector<double> independent_excitation(double period, std::size_t& record_from,
                                           std::size_t& record_to, int repeats) {
  // Velocity plan [m/s]: (target, acceleration, hold). The log starts inside the first cruise
  // and ends inside the last one.
  struct Segment {
    double v, a, hold;
  };
  const Segment plan[] = {
      {0.0, 1.0, 0.1},     {0.06, 1.5, 0.5},    {0.0, 2.0, 0.15},  {-0.02, 1.0, 0.5},
      {0.0, 1.0, 0.1},     {0.005, 0.5, 0.6},   {-0.005, 0.5, 0.6}, {0.0, 0.5, 0.15},
      {0.12, 3.0, 0.3},    {-0.12, 3.0, 0.3},   {0.0, 3.0, 0.15},  {0.2, 4.0, 0.25},
      {0.0, 4.0, 0.2},     {-0.06, 2.0, 0.5},   {0.0, 2.0, 0.1},   {0.002, 0.2, 1.0},
      {-0.002, 0.2, 1.0},  {0.0, 0.2, 0.1},     {0.1, 5.0, 0.2},   {-0.1, 5.0, 0.2},
      {0.0, 5.0, 0.15},    {-0.2, 4.0, 0.25},   {0.0, 4.0, 0.2},   {0.03, 1.0, 0.6},
      {-0.03, 2.0, 0.5},   {0.04, 2.0, 0.8},    {0.0, 1.0, 0.2}};
  std::vector<double> vel;
  std::size_t first_cruise_end = 0, last_cruise_start = 0;
  // The middle of the plan (from its first reversal on) is repeated for longer runs.
  const std::size_t last = std::size(plan) - 1;
  for (int rep = 0; rep < repeats; ++rep) {
    for (std::size_t s = rep == 0 ? 0 : 2; s <= last; ++s) {
      if (s == last && rep + 1 < repeats) break;
      if (s == last) last_cruise_start = vel.size() - static_cast<std::size_t>(0.5 / period);
      ramp_hold(vel, period, plan[s].v, plan[s].a, plan[s].hold);
      if (s == 1) first_cruise_end = vel.size();
    }
  }
  // Jerk limit: moving average over 20 ms (an acceleration of 4 m/s^2 then needs 200 m/s^3).
  const std::size_t m = static_cast<std::size_t>(0.02 / period);
  std::vector<double> smooth(vel.size() + m, 0.0);
  for (std::size_t k = 0; k < vel.size(); ++k) {
    for (std::size_t j = 0; j < m; ++j) smooth[k + j] += vel[k] / static_cast<double>(m);
  }
  std::vector<double> x{0.0};
  for (double v : smooth) x.push_back(x.back() + v * period);
  for (int k = 0; k < 200; ++k) x.push_back(x.back());  // settle
  record_from = first_cruise_end - static_cast<std::size_t>(0.2 / period);
  record_to = last_cruise_start + m;
  return x;
}

Trace simulate_independent(const IndependentDrive& p, const std::vector<double>& sp,
                           std::size_t record_from, std::size_t record_to, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  const double r = p.ratio_m_per_rad();
  const double Tp = p.position_period_s, Tv = p.velocity_period_s;
  const int per_position = static_cast<int>(std::lround(Tp / Tv));
  const int per_trace = static_cast<int>(std::lround(p.trace_period_s / Tv));
  const double h = Tv / p.substeps;
  const double j_nominal = p.equivalent_inertia_kg_m2();
  const double j_true = p.inertia_factor * j_nominal;
  const double jm = p.motor_inertia_kg_m2;
  const double m_load = (j_true - jm) / (r * r);
  const double count_rad = 2.0 * kPi / p.motor_counts_per_rev;
  const double current_decay = std::exp(-2.0 * kPi * p.current_bandwidth_hz * h);
  const bool two_mass = p.stiffness_N_per_m > 0.0;
  const bool play = p.backlash_m > 0.0;
  // Two-mass damping from the ratio of the mode between rotor (as a mass r^-2 jm) and load.
  const double m_motor = jm / (r * r);
  const double m_reduced = m_motor * m_load / (m_motor + m_load);
  const double spring_k = two_mass ? p.stiffness_N_per_m : p.contact_stiffness_N_per_m;
  const double spring_c = 2.0 * (two_mass ? p.damping_ratio : 0.3) * std::sqrt(spring_k * m_reduced);

  // Friction force on the load [N] at load speed v: viscous + smooth Coulomb, no stiction.
  auto friction_N = [&](double v) {
    double a = p.viscous_A_s_per_m, b = p.coulomb_A;
    if (p.asymmetric) {
      a = v >= 0.0 ? p.viscous_positive_A_s_per_m : p.viscous_negative_A_s_per_m;
      b = v >= 0.0 ? p.coulomb_positive_A : p.coulomb_negative_A;
    }
    const double s = std::tanh(v / p.smooth_speed_m_per_s);
    double amps = a * v + b * s;
    if (p.hump_A > 0.0) amps += p.hump_A * s * std::exp(-std::pow(v / p.hump_speed_m_per_s, 2));
    return amps * p.kt_N_m_per_A / r;  // current -> motor torque -> force at the nut
  };
  auto pitch = [&](double x) {
    return p.pitch_amplitude_m > 0.0
               ? p.pitch_amplitude_m * std::sin(2.0 * kPi * x / p.pitch_period_m + p.pitch_phase_rad)
               : 0.0;
  };
  auto external_N = [&](double t, double x) {
    double f = p.offset_force_N + p.gravity_cos_N * std::cos(x) + p.gravity_sin_N * std::sin(x);
    if (p.bump_force_N != 0.0) {
      const double edge = 0.02;  // smooth on and off over 20 ms
      const double on = 0.5 * (std::tanh((t - p.bump_start_s) / edge) - std::tanh((t - p.bump_end_s) / edge));
      f += p.bump_force_N * on;
    }
    return f;
  };
  auto setpoint_at = [&](double t) {  // linear interpolation of the set points (delay line)
    const double u = t / Tp;
    if (u <= 0.0) return sp.front();
    const std::size_t k = static_cast<std::size_t>(u);
    if (k + 1 >= sp.size()) return sp.back();
    return sp[k] + (u - static_cast<double>(k)) * (sp[k + 1] - sp[k]);
  };

  // State. Motor angle theta, load position xl; at rest at the first set point.
  double theta = sp.front() / r, omega = 0.0;
  double xl = sp.front() + pitch(sp.front()), vl = 0.0;
  double current = 0.0;
  // Controller state.
  double x_prev = sp.front(), x_prev2 = sp.front();
  double v_ff = 0.0, tau_ff = 0.0;            // held over the position period
  double speed_cmd = 0.0, speed_cmd_next = 0.0;  // position output, one velocity cycle late
  double tau_ff_applied = 0.0, tau_ff_next = 0.0;
  double integral = 0.0;
  double enc_prev = quantise(theta, count_rad);
  double i_cmd = 0.0, i_cmd_next = 0.0;  // velocity output, one velocity cycle late

  Trace out;
  const std::string& a = p.axis_name;
  out.columns = {"t", a + ".cmd", a + ".pos", a + (p.loop_on_motor_encoder ? ".pos2" : ".pos_motor"),
                 a + ".cur"};
  out.values.assign(5, {});
  const double unit = p.rotary ? 180.0 / kPi : 1e3;  // joint unit -> deg or mm
  const std::size_t ticks = (sp.size() - 1) * static_cast<std::size_t>(per_position);
  for (std::size_t j = 0; j < ticks; ++j) {
    const double t = static_cast<double>(j) * Tv;
    const double scale = quantise(xl, p.scale_quantum_m);
    const double enc = quantise(theta, count_rad);
    // Commands computed in the previous cycle take effect now (computation delay).
    if (p.position_output_delay_cycles > 0) {
      speed_cmd = speed_cmd_next;
      tau_ff_applied = tau_ff_next;
    }
    i_cmd = i_cmd_next;
    if (j % static_cast<std::size_t>(per_trace) == 0) {
      const std::size_t k = j / static_cast<std::size_t>(per_trace);
      if (k >= record_from && k <= record_to) {
        out.values[0].push_back(static_cast<double>(k - record_from) * p.trace_period_s);
        out.values[1].push_back(sp[k * static_cast<std::size_t>(per_trace) /
                                   static_cast<std::size_t>(per_position)] * unit);
        out.values[2].push_back((p.loop_on_motor_encoder ? r * enc : scale) * unit);
        out.values[3].push_back((p.loop_on_motor_encoder ? scale : r * enc) * unit);
        out.values[4].push_back(quantise(current + p.current_noise_A * gauss(rng), p.current_quantum_A));
      }
    }
    if (j % static_cast<std::size_t>(per_position) == 0) {
      const double x = setpoint_at(t - p.setpoint_delay_s);
      if (p.velocity_feedforward) v_ff = (x - x_prev) / Tp;
      if (p.torque_feedforward) {
        tau_ff = j_nominal / r * (x - 2.0 * x_prev + x_prev2) / (Tp * Tp);
      }
      x_prev2 = x_prev;
      x_prev = x;
      const double feedback = p.loop_on_motor_encoder ? r * enc : scale;
      speed_cmd_next = p.kv_per_s * (x - feedback) + v_ff;
      tau_ff_next = tau_ff;
      if (p.position_output_delay_cycles == 0) {
        speed_cmd = speed_cmd_next;
        tau_ff_applied = tau_ff_next;
      }
    }
    // Velocity PI on the differenced motor encoder.
    const double omega_meas = (enc - enc_prev) / Tv;
    enc_prev = enc;
    const double error = speed_cmd / r - omega_meas;
    const double kp = p.velocity_gain_N_m_s_per_rad;
    double tau = kp * (error + integral / p.velocity_integral_time_s) + tau_ff_applied;
    double cmd = tau / p.kt_N_m_per_A;
    if (std::abs(cmd) < p.current_max_A) {
      integral += error * Tv;  // anti-windup: no integration while clamped
    }
    i_cmd_next = std::clamp(cmd, -p.current_max_A, p.current_max_A);

    for (int s = 0; s < p.substeps; ++s) {
      const double ts = t + s * h;
      current = i_cmd + (current - i_cmd) * current_decay;
      const double cog = p.cogging_N_m > 0.0
                             ? p.cogging_N_m * std::sin(p.cogging_per_rev * theta + p.cogging_phase_rad)
                             : 0.0;
      const double motor_torque = p.kt_N_m_per_A * current + cog;
      const double nut = r * theta + pitch(r * theta);
      if (!two_mass && !play) {
        // Rigid: one body; the load follows the nut.
        const double force = friction_N(r * omega) + external_N(ts, xl);
        omega += h * (motor_torque - r * force) / j_true;
        theta += h * omega;
        xl = r * theta + pitch(r * theta);
        vl = r * omega;
      } else {
        // Motor and load joined by a spring (two-mass) or by a stiff contact with a play.
        double delta = nut - xl;
        const double rate = r * omega - vl;
        double f = 0.0;
        if (two_mass) {
          f = spring_k * delta + spring_c * rate;
        } else {
          const double half = 0.5 * p.backlash_m;
          if (delta > half) {
            f = std::max(0.0, spring_k * (delta - half) + spring_c * rate);
          } else if (delta < -half) {
            f = std::min(0.0, spring_k * (delta + half) + spring_c * rate);
          }
        }
        omega += h * (motor_torque - r * f) / jm;
        vl += h * (f - friction_N(vl) - external_N(ts, xl)) / m_load;
        theta += h * omega;
        xl += h * vl;
        delta = 0.0;
      }
      (void)nut;
    }
  }
  return out;
}

Trace simulate_independent_machine(const std::vector<IndependentDrive>& drives,
                                   const std::vector<std::vector<double>>& setpoints,
                                   std::size_t record_from, std::size_t record_to, std::uint32_t seed) {
  Trace merged;
  for (std::size_t k = 0; k < drives.size(); ++k) {
    const Trace one = simulate_independent(drives[k], setpoints[k], record_from, record_to,
                                           seed + static_cast<std::uint32_t>(k));
    for (std::size_t c = 0; c < one.columns.size(); ++c) {
      if (one.columns[c] == "t" && k > 0) continue;
      merged.columns.push_back(one.columns[c]);
      merged.values.push_back(one.values[c]);
    }
  }
  return merged;
}

std::string independent_machine_yaml(const IndependentDrive& p) {
  auto num = [](double v) {
    char text[40];
    std::snprintf(text, sizeof text, "%.10g", v);
    return std::string(text);
  };
  std::string y;
  y += "# The nominal drive of the independent truth simulator (tests/identify/"
       "truth_sim_independent.cpp):\n# loop closed on a direct scale, held feedforward.\n";
  y += "name: independent truth drive\nkind: machine_tool\n";
  y += "interpolation_period_s: " + num(p.position_period_s) + "\n";
  y += "axes:\n  - name: X\n    type: linear\n    travel_mm: [-1000, 1000]\n";
  y += "    limits: {velocity_m_per_min: 20, acceleration_m_per_s2: 6, jerk_m_per_s3: 300}\n";
  y += "    drive:\n";
  y += "      screw_lead_mm: " + num(p.lead_m * 1e3) + "\n";
  y += "      equivalent_inertia_kg_m2: " + num(p.equivalent_inertia_kg_m2()) + "\n";
  y += "      rotor_inertia_kg_m2: " + num(p.motor_inertia_kg_m2) + "\n";
  y += "      torque_constant_N_m_per_A: " + num(p.kt_N_m_per_A) + "\n";
  y += "      friction_viscous_A_s_per_m: " + num(p.viscous_A_s_per_m) + "\n";
  y += "      friction_dry_A: " + num(p.coulomb_A) + "\n";
  y += "      torque_max_N_m: " + num(p.current_max_A * p.kt_N_m_per_A) + "\n";
  y += "      torque_rate_max_N_m_per_s: 100000\n";
  y += "    controller:\n";
  // The position controller's output reaches the velocity loop one velocity cycle later.
  y += "      position: {kv_per_s: " + num(p.kv_per_s) + ", period_s: " + num(p.position_period_s) +
       ", output_dead_time_s: " +
       num(p.position_output_delay_cycles * p.velocity_period_s) + ", feedback: load, load_encoder_resolution_nm: " +
       num(p.scale_quantum_m * 1e9) + "}\n";
  y += "      velocity: {type: PI, gain_N_m_s_per_rad: " + num(p.velocity_gain_N_m_s_per_rad) +
       ", integral_time_s: " + num(p.velocity_integral_time_s) + ", period_s: " +
       num(p.velocity_period_s) + ", output_delay_samples: 1}\n";
  y += "      current: {model: first_order, bandwidth_hz: " + num(p.current_bandwidth_hz) + "}\n";
  y += std::string("      feedforward: {velocity: ") + (p.velocity_feedforward ? "true" : "false") +
       ", torque: " + (p.torque_feedforward ? "true" : "false") + ", timing: held_backward}\n";
  y += "      saturation: {current_A: " + num(p.current_max_A) + "}\n";
  y += "      encoder_counts_per_rev: " + num(p.motor_counts_per_rev) + "\n";
  y += "    effects:\n      smooth_friction: {speed_m_per_s: " + num(p.smooth_speed_m_per_s) + "}\n";
  y += "structure:\n  workpiece_chain:\n    - fixed: workpiece\n  tool_chain:\n"
       "    - joint: X\n      direction: [1, 0, 0]\n"
       "      body: {mass_kg: " + num(p.load_mass_kg) +
       ", com_mm: [0, 0, 0], inertia_kg_m2: {ixx: 0.1, iyy: 0.1, izz: 0.1}}\n"
       "    - fixed: spindle\n";
  return y;
}

double independent_peak_current(const Trace& trace) {
  double peak = 0.0;
  for (double v : trace.column("X.cur")) peak = std::max(peak, std::abs(v));
  return peak;
}

}  // namespace vmsim::identify::test
