// The independent truth simulator of the identification tests (see truth_sim.hpp).
#include "truth_sim.hpp"

#include <algorithm>
#include <cmath>

namespace vmsim::identify::test {
namespace {

constexpr double kTwoPi = 6.283185307179586;

// One jerk-limited move: a trapezoidal velocity profile smoothed by a moving average of the
// jerk time (which keeps the distance), appended to `x`.
void move(std::vector<double>& x, double period, double distance, double speed, double accel,
          double jerk) {
  const double sign = distance < 0.0 ? -1.0 : 1.0;
  const double d = std::abs(distance);
  double v = std::min(speed, std::sqrt(d * accel));
  const double t_acc = v / accel;
  const double t_cruise = d / v - t_acc;
  const std::size_t n = static_cast<std::size_t>(std::ceil((2.0 * t_acc + t_cruise) / period));
  std::vector<double> vel(n);
  for (std::size_t k = 0; k < n; ++k) {
    const double t = (static_cast<double>(k) + 0.5) * period;
    const double total = 2.0 * t_acc + t_cruise;
    vel[k] = v * std::min({1.0, t / t_acc, std::max(0.0, (total - t) / t_acc)});
  }
  // Scale to the exact distance, then smooth.
  double sum = 0.0;
  for (double u : vel) sum += u * period;
  for (double& u : vel) u *= d / sum;
  const std::size_t m = std::max<std::size_t>(1, static_cast<std::size_t>(accel / jerk / period));
  std::vector<double> smooth(n + m - 1, 0.0);
  for (std::size_t k = 0; k < n; ++k) {
    for (std::size_t j = 0; j < m; ++j) smooth[k + j] += vel[k] / static_cast<double>(m);
  }
  double pos = x.back();
  for (double u : smooth) {
    pos += sign * u * period;
    x.push_back(pos);
  }
}

void dwell(std::vector<double>& x, double period, double duration) {
  const std::size_t n = static_cast<std::size_t>(duration / period);
  for (std::size_t k = 0; k < n; ++k) x.push_back(x.back());
}

}  // namespace

std::vector<double> generic_excitation(double period, double scale) {
  std::vector<double> x{0.0};
  const double jerk = 200.0;
  dwell(x, period, 0.2);
  // Constant-velocity moves at several speeds, both ways.
  for (double v : {0.002, 0.01, 0.04, 0.1, 0.18}) {
    const double speed = v * scale;
    const double d = speed * 0.4 + speed * speed / 2.5;
    move(x, period, d, speed, 2.5, jerk);
    dwell(x, period, 0.15);
    move(x, period, -d, speed, 2.5, jerk);
    dwell(x, period, 0.15);
  }
  // Reversals without a dwell.
  for (int k = 0; k < 4; ++k) {
    move(x, period, 0.02 * scale, 0.08 * scale, 2.5, jerk);
    move(x, period, -0.02 * scale, 0.08 * scale, 2.5, jerk);
  }
  dwell(x, period, 0.1);
  // Hard accelerations.
  for (int k = 0; k < 3; ++k) {
    move(x, period, 0.04 * scale, 0.16 * scale, 5.0, jerk);
    dwell(x, period, 0.1);
    move(x, period, -0.04 * scale, 0.16 * scale, 5.0, jerk);
    dwell(x, period, 0.1);
  }
  dwell(x, period, 0.2);
  return x;
}

Trace simulate_truth(const TruthDrive& p, const std::vector<double>& sp, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  const double r = p.ratio, T = p.period, h = T / p.substeps;
  const double count = kTwoPi / p.counts_per_rev;
  auto quant = [](double v, double q) { return q > 0.0 ? std::round(v / q) * q : v; };
  const bool two_mass = p.stiffness > 0.0;
  const double jm = two_mass ? p.rotor_inertia : p.inertia;
  const double jl = p.inertia - p.rotor_inertia;
  const double spring = p.stiffness * r * r;
  const double mu = jm * jl / (jm + jl);
  const double damper = two_mass ? 2.0 * p.damping_ratio * std::sqrt(spring * mu) : 0.0;
  // Viscous friction at the motor [N m s/rad], per direction of motion.
  auto viscous_at = [&](double omega) {
    double a = p.viscous_A_s_per_m;
    if (p.asymmetric) a = omega > 0.0 ? p.viscous_positive_A_s_per_m : p.viscous_negative_A_s_per_m;
    return p.kt * a * r * omega;
  };
  auto dry = [&](double dir, double omega) {
    double b = p.dry_A;
    if (p.asymmetric) b = dir > 0.0 ? p.dry_positive_A : p.dry_negative_A;
    if (p.stribeck_static_A > 0.0) {
      b += (p.stribeck_static_A - b) * std::exp(-std::pow(r * omega / p.stribeck_velocity, 2));
    }
    return p.kt * b;
  };

  // State: motor angle/speed; load angle/speed (two-mass) or play position (backlash).
  double th = sp.front() / r, om = 0.0, thl = th, oml = 0.0;
  bool stuck = true;
  // One step of a body of `inertia` under `force` with viscous and dry friction, sticking when
  // its velocity would change sign and breaking away when the force exceeds the dry friction.
  auto friction_step = [&](double force, double inertia, double& velocity) {
    if (stuck) {
      const double limit = dry(force, 0.0);
      if (std::abs(force) > limit) {
        stuck = false;
        velocity = h * (force - std::copysign(limit, force)) / inertia;
      }
    } else {
      const double next =
          velocity + h * (force - viscous_at(velocity) - std::copysign(dry(velocity, velocity), velocity)) / inertia;
      if (next * velocity <= 0.0) {
        velocity = 0.0;
        stuck = true;
      } else {
        velocity = next;
      }
    }
  };
  int side = 0;  // rigid backlash: +1 / -1 motor pushing the load forwards / backwards, 0 apart
  const double i0 = p.offset_A;
  double omega_set = 0.0, i_applied = i0, i_next = i0;
  double enc_prev = quant(th, count);
  Trace out;
  out.columns = {"t", "X.cmd", "X.pos", "X.pos2", "X.cur"};
  out.values.assign(5, {});
  const std::size_t n = sp.size();
  auto setpoint = [&](double t) {
    const double u = t / T;
    if (u <= 0.0) return sp.front();
    if (u >= static_cast<double>(n - 1)) return sp.back();
    const std::size_t k = static_cast<std::size_t>(u);
    const double f = u - static_cast<double>(k);
    return sp[k] + f * (sp[k + 1] - sp[k]);
  };
  for (std::size_t k = 0; k < n; ++k) {
    const double t = static_cast<double>(k) * T;
    // Position loop (output one sample late).
    const double enc = quant(th, count);
    const double pos = r * enc;
    const double speed = p.kv * (setpoint(t - p.delay_s) - pos);
    const double omega_set_applied = omega_set;
    omega_set = speed / r;
    // Velocity loop (output one sample late).
    const double omega_meas = (enc - enc_prev) / T;
    enc_prev = enc;
    double cmd = p.kp * (omega_set_applied - omega_meas) / p.kt;
    cmd = std::clamp(cmd, -p.current_max_A, p.current_max_A);
    i_applied = i_next;
    i_next = cmd;
    // Record.
    double nut = r * (two_mass || p.backlash_gap > 0.0 ? thl : th);
    double load = nut;
    if (p.pitch_amplitude > 0.0) {
      load += p.pitch_amplitude * std::sin(kTwoPi * nut / p.pitch_period + p.pitch_phase);
    }
    out.values[0].push_back(t);
    out.values[1].push_back(sp[k] * 1e3);
    out.values[2].push_back(pos * 1e3);
    out.values[3].push_back(quant(load, p.scale_quantum) * 1e3);
    out.values[4].push_back(quant(i_applied + p.current_noise_A * gauss(rng), p.current_quantum_A));
    // Mechanics over the period.
    for (int s = 0; s < p.substeps; ++s) {
      const double cog =
          p.cogging_N_m > 0.0 ? p.cogging_N_m * std::sin(p.cogging_periods * th + p.cogging_phase)
                              : 0.0;
      const double motor = p.kt * i_applied + cog;
      const double resist = p.kt * p.offset_A;
      if (!two_mass && p.backlash_gap > 0.0 && side == 0) {
        // Rigid drive with backlash, apart: the motor side (rotor) alone, the load coasting
        // with its friction; at a flank an inelastic impact (momentum kept).
        const double half = 0.5 * p.backlash_gap / r;
        const double jr = p.rotor_inertia;
        om += h * motor / jr;
        th += h * om;
        const double on_load = -resist;
        friction_step(on_load, jl, oml);
        thl += h * oml;
        if (std::abs(th - thl) >= half) {
          side = th > thl ? 1 : -1;
          om = oml = (jr * om + jl * oml) / (jr + jl);
          thl = th - side * half;
          if (om != 0.0) stuck = false;
        }
      } else if (!two_mass) {
        const double drive = motor - resist;
        friction_step(drive, jm, om);
        th += h * om;
        if (p.backlash_gap > 0.0) {
          // In contact: one body; the motor leaves the load when it would have to pull it
          // (the force J_L tau_m - J_r tau_L against the side; at rest: the motor pulling away).
          thl = th - side * 0.5 * p.backlash_gap / r;
          oml = om;
          const double jr = p.rotor_inertia;
          const double on_load =
              stuck ? 0.0 : -resist - viscous_at(om) - std::copysign(dry(om, om), om);
          const double press = stuck ? motor : jl * motor - jr * on_load;
          if (side * press < 0.0) side = 0;
        }
      } else {
        const double ts = spring * (th - thl) + damper * (om - oml);
        om += h * (motor - ts) / jm;
        const double on_load = ts - resist;
        friction_step(on_load, jl, oml);
        th += h * om;
        thl += h * oml;
      }
    }
  }
  return out;
}

double peak_current(const Trace& trace) {
  double peak = 0.0;
  for (double v : trace.column("X.cur")) peak = std::max(peak, std::abs(v));
  return peak;
}

}  // namespace vmsim::identify::test
