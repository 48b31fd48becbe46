// One axis drive: cascade control at its loop rates, exact discretisation of the linear
// mechanics between ticks, dry friction with a stick state. See servo.hpp and README.md.
#include <Eigen/Core>
#include <array>
#include <deque>
#include <cmath>
#include <numbers>

#include "vmsim/common/errors.hpp"
#include "vmsim/servo/servo.hpp"

namespace vmsim::servo {
namespace {

using kinematics::BalancingType;
using kinematics::CurrentLoopModel;
using kinematics::FineInterpolation;
using kinematics::PositionFeedback;
using kinematics::VelocityControllerType;

constexpr double kTwoPi = 2.0 * std::numbers::pi;
constexpr int kInputs = 4;  // electrical input, motor torque, load torque, spring offset torque

// exp(M) by scaling and squaring of a Taylor series: M is small (at most 9 x 9) and well scaled
// after the scaling; used once per model.
Eigen::MatrixXd matrix_exponential(const Eigen::MatrixXd& m) {
  double norm = m.cwiseAbs().rowwise().sum().maxCoeff();
  int squarings = 0;
  while (norm > 0.25) {
    norm *= 0.5;
    ++squarings;
  }
  const Eigen::MatrixXd a = m / std::ldexp(1.0, squarings);
  Eigen::MatrixXd result = Eigen::MatrixXd::Identity(m.rows(), m.cols());
  Eigen::MatrixXd term = result;
  for (int k = 1; k <= 20; ++k) {
    term = (term * a) / static_cast<double>(k);
    result += term;
  }
  for (int i = 0; i < squarings; ++i) result = result * result;
  return result;
}

/// Set points with their fine interpolation and derivatives (central differences at the knots,
/// so that position, velocity and acceleration line up in time).
class SetpointSignal {
 public:
  struct Sample {
    double x = 0.0, v = 0.0, a = 0.0;
  };

  SetpointSignal(const AxisInput& input, FineInterpolation interpolation)
      : t0_(input.start_time_s),
        period_(input.period_s),
        inverse_period_(1.0 / input.period_s),
        cubic_(interpolation == FineInterpolation::cubic),
        held_(input.kind == AxisInput::Kind::velocity),
        x_(input.values) {
    const std::size_t n = x_.size();
    v_.resize(n);
    a_.resize(n);
    for (std::size_t k = 0; k < n; ++k) {
      const double before = x_[k == 0 ? 0 : k - 1];
      const double after = x_[k + 1 < n ? k + 1 : n - 1];
      v_[k] = (after - before) * 0.5 * inverse_period_;
      a_[k] = (after - 2.0 * x_[k] + before) * inverse_period_ * inverse_period_;
    }
  }

  Sample at(double t) const {
    const double u = (t - t0_) * inverse_period_;
    const std::size_t last = x_.size() - 1;
    if (u <= 0.0) return {x_.front(), 0.0, 0.0};
    if (u >= static_cast<double>(last)) return {x_.back(), 0.0, 0.0};
    const std::size_t k = static_cast<std::size_t>(u);
    const double f = u - static_cast<double>(k);
    if (held_) return {x_[k], 0.0, 0.0};
    Sample s;
    s.a = a_[k] + f * (a_[k + 1] - a_[k]);
    if (!cubic_) {
      s.x = x_[k] + f * (x_[k + 1] - x_[k]);
      s.v = v_[k] + f * (v_[k + 1] - v_[k]);
      return s;
    }
    // Cubic Hermite with the central-difference slopes (Catmull-Rom): C1 in x.
    const double f2 = f * f, f3 = f2 * f;
    const double dx = x_[k + 1] - x_[k];
    const double m0 = v_[k] * period_, m1 = v_[k + 1] * period_;
    s.x = x_[k] + (3.0 * f2 - 2.0 * f3) * dx + (f3 - 2.0 * f2 + f) * m0 + (f3 - f2) * m1;
    s.v = ((6.0 * f - 6.0 * f2) * dx + (3.0 * f2 - 4.0 * f + 1.0) * m0 + (3.0 * f2 - 2.0 * f) * m1) *
          inverse_period_;
    return s;
  }

  /// The sample held at t (for the external force).
  static double held(const std::vector<double>& values, double t0, double inverse_period,
                     double t) {
    if (values.empty()) return 0.0;
    const double u = (t - t0) * inverse_period;
    if (u <= 0.0) return values.front();
    const std::size_t k = static_cast<std::size_t>(u);
    return k < values.size() ? values[k] : values.back();
  }

 private:
  double t0_, period_, inverse_period_;
  bool cubic_, held_;
  std::vector<double> x_, v_, a_;
};

/// A pure delay of n samples (n = 0: pass-through).
class DelayLine {
 public:
  void reset(int samples, double value) {
    n_ = samples;
    head_ = 0;
    buffer_.fill(value);
  }
  double push(double value) {
    if (n_ == 0) return value;
    const double out = buffer_[static_cast<std::size_t>(head_)];
    buffer_[static_cast<std::size_t>(head_)] = value;
    head_ = head_ + 1 == n_ ? 0 : head_ + 1;
    return out;
  }

 private:
  std::array<double, 9> buffer_{};
  int n_ = 0;
  int head_ = 0;
};

/// Exactly discretised linear part: x+ = phi x + gamma u over one plant step.
template <int N>
struct Discrete {
  Eigen::Matrix<double, N, N> phi;
  Eigen::Matrix<double, N, kInputs> gamma;
};

template <int N>
Discrete<N> discretise(const Eigen::Matrix<double, N, N>& a, const Eigen::Matrix<double, N, kInputs>& b,
                       double step_s) {
  Eigen::MatrixXd m = Eigen::MatrixXd::Zero(N + kInputs, N + kInputs);
  m.topLeftCorner(N, N) = a * step_s;
  m.topRightCorner(N, kInputs) = b * step_s;
  const Eigen::MatrixXd e = matrix_exponential(m);
  Discrete<N> d;
  d.phi = e.topLeftCorner(N, N);
  d.gamma = e.topRightCorner(N, kInputs);
  return d;
}

/// Derived parameters at the motor shaft (SI).
struct Parameters {
  double r = 1.0, kt = 1.0, j_total = 1.0, j_motor = 0.0, j_load = 0.0;
  double viscous = 0.0;                      // mean c [N m s/rad]
  double viscous_positive = 0.0, viscous_negative = 0.0;
  double dry_positive = 0.0, dry_negative = 0.0;  // [N m]
  bool stribeck = false;
  double static_friction = 0.0, stribeck_speed = 1.0, stribeck_exponent = 2.0;
  bool coulomb = false, asymmetric = false;
  bool smooth = false;        // dry friction b tanh(omega / smooth_speed), no stick state
  double smooth_speed = 1.0;  // [rad/s at the motor]
  double spring = 0.0, damping = 0.0, gap = 0.0;  // [N m/rad], [N m s/rad], motor rad
  bool two_mass = false, backlash = false;
  bool motor_friction = false;  // two-mass: the friction acts on the motor body, not the load
  bool rigid_backlash = false;  // backlash without compliance: two bodies, rigid in contact
  bool cogging = false;
  double cogging_amplitude = 0.0, cogging_periods = 0.0, cogging_phase = 0.0;
  bool pitch = false;
  double pitch_amplitude = 0.0, pitch_wavenumber = 0.0, pitch_phase = 0.0;
  double motor_count = 0.0;  // motor encoder count [rad]; 0 = ideal
  double load_count = 0.0;   // load encoder resolution [joint unit]
  double inverse_motor_count = 0.0, inverse_load_count = 0.0;
  double gravity_constant = 0.0, gravity_cos = 0.0, gravity_sin = 0.0;
  bool gravity_trig = false, rotary = false;
};

Parameters derive(const AxisServoModel& model) {
  const kinematics::Axis& axis = model.axis;
  const kinematics::DriveEffects& fx = axis.effects;
  Parameters p;
  p.r = axis.drive.ratio;
  p.kt = axis.drive.torque_constant_N_m_per_A;
  p.j_total = axis.drive.equivalent_inertia_kg_m2;
  p.rotary = axis.type == kinematics::AxisType::rotary;
  // Eq. 6: Kt a q' = Kt a r omega.
  const double a = axis.drive.friction_viscous_A_per_joint_unit_per_s;
  p.viscous_positive = p.viscous_negative = p.kt * a * p.r;
  p.dry_positive = p.dry_negative = p.kt * axis.drive.friction_dry_A;
  if (fx.asymmetric_friction.enabled) {
    p.asymmetric = true;
    p.dry_positive = p.kt * fx.asymmetric_friction.dry_positive_A;
    p.dry_negative = p.kt * fx.asymmetric_friction.dry_negative_A;
    p.viscous_positive = p.kt * fx.asymmetric_friction.viscous_positive_A_per_joint_unit_per_s * p.r;
    p.viscous_negative = p.kt * fx.asymmetric_friction.viscous_negative_A_per_joint_unit_per_s * p.r;
  }
  p.viscous = 0.5 * (p.viscous_positive + p.viscous_negative);
  if (fx.stribeck.enabled) {
    p.stribeck = true;
    p.static_friction = p.kt * fx.stribeck.static_friction_A;
    p.stribeck_speed = fx.stribeck.velocity / p.r;
    p.stribeck_exponent = fx.stribeck.exponent;
  }
  p.coulomb = p.dry_positive > 0.0 || p.dry_negative > 0.0 || (p.stribeck && p.static_friction > 0.0);
  if (fx.smooth_friction.enabled) {
    p.smooth = true;
    p.smooth_speed = fx.smooth_friction.speed / p.r;
  }
  if (fx.compliance.enabled) {
    p.two_mass = true;
    p.j_motor = fx.compliance.motor_side_inertia_kg_m2 > 0.0 ? fx.compliance.motor_side_inertia_kg_m2
                                                            : axis.drive.rotor_inertia_kg_m2;
    p.j_load = p.j_total - p.j_motor;
    if (!(p.j_motor > 0.0 && p.j_load > 0.0)) {
      throw InputError("axis " + axis.name +
                       ": effects.compliance needs a motor-side inertia in (0, J_eq)");
    }
    p.spring = fx.compliance.stiffness * p.r * p.r;
    const double j_reduced = p.j_motor * p.j_load / p.j_total;
    p.damping = 2.0 * fx.compliance.damping_ratio * std::sqrt(p.spring * j_reduced);
    p.motor_friction = fx.compliance.friction_side == kinematics::FrictionSide::motor;
  }
  if (fx.backlash.enabled) {
    p.backlash = true;
    p.gap = fx.backlash.gap / p.r;
    if (!p.two_mass) {
      // Rigid drive with play: inside the gap the motor side (rotor, coupling, screw) moves
      // alone and the load (nut, table) coasts.
      p.rigid_backlash = true;
      p.j_motor = axis.drive.rotor_inertia_kg_m2;
      p.j_load = p.j_total - p.j_motor;
      if (!(p.j_motor > 0.0 && p.j_load > 0.0)) {
        throw InputError("axis " + axis.name +
                         ": effects.backlash needs drive.rotor_inertia_kg_m2 in (0, J_eq): the "
                         "motor side that moves alone inside the gap");
      }
    }
  }
  if (fx.cogging.enabled) {
    p.cogging = fx.cogging.amplitude_N_m > 0.0;
    p.cogging_amplitude = fx.cogging.amplitude_N_m;
    p.cogging_periods = fx.cogging.periods_per_rev;
    p.cogging_phase = fx.cogging.phase_rad;
  }
  if (fx.pitch_error.enabled) {
    p.pitch = true;
    p.pitch_amplitude = fx.pitch_error.amplitude;
    p.pitch_wavenumber = kTwoPi / fx.pitch_error.period;
    p.pitch_phase = fx.pitch_error.phase_rad;
  }
  if (axis.controller.encoder_counts_per_rev > 0.0) {
    p.motor_count = kTwoPi / axis.controller.encoder_counts_per_rev;
  }
  p.load_count = axis.controller.load_encoder_resolution;
  if (p.motor_count > 0.0) p.inverse_motor_count = 1.0 / p.motor_count;
  if (p.load_count > 0.0) p.inverse_load_count = 1.0 / p.load_count;
  p.gravity_constant = model.gravity_constant_N_m;
  p.gravity_cos = model.gravity_cos_N_m;
  p.gravity_sin = model.gravity_sin_N_m;
  p.gravity_trig = std::abs(p.gravity_cos) > 1e-12 || std::abs(p.gravity_sin) > 1e-12;
  return p;
}

// Round to the nearest count. Adding and subtracting 1.5 * 2^52 rounds to an integer in the
// FPU's round-to-nearest mode: two additions on the velocity loop's critical path instead of a
// conversion to an integer and back (std::nearbyint is a library call on baseline x86-64).
// Exact for |value / count| < 2^51, far beyond any travel.
inline double round_to_integer(double value) {
  constexpr double kRound = 6755399441055744.0;
  return (value + kRound) - kRound;
}
inline double quantise(double value, double count, double inverse_count) {
  if (count <= 0.0) return value;
  return round_to_integer(value * inverse_count) * count;
}

// The simulation of one axis with N plant states: [theta, omega, i] (rigid) or
// [theta_m, omega_m, i, theta_L, omega_L] (two bodies: compliance, or backlash in a rigid drive).
template <int N>
class AxisRun {
 public:
  static constexpr bool kTwoBody = N == 5;

  AxisRun(const AxisServoModel& model, const AxisInput& input, const SimulationOptions& options)
      : model_(model), c_(model.axis.controller), p_(derive(model)), input_(input),
        options_(options), setpoints_(input, c_.fine_interpolation) {
    base_ = base_period_s(c_);
    n_pos_ = std::max(1L, std::lround(c_.position_period_s / base_));
    n_vel_ = std::max(1L, std::lround(c_.velocity_period_s / base_));
    n_cur_ = std::max(1L, std::lround(c_.current_period_s / base_));
    substeps_ = options.plant_substeps > 0 ? options.plant_substeps
                                           : (p_.two_mass || p_.backlash ? 8 : 1);
    substep_ = base_ / substeps_;
    // The body the friction acts on: the load of two bodies, unless the two-mass model puts it
    // on the motor (Compliance::friction_side); its torque input is u1 (motor) or u2 (load).
    const bool load_friction = kTwoBody && !p_.motor_friction;
    friction_vel_ = load_friction ? 4 : 1;
    friction_pos_ = load_friction ? 3 : 0;
    friction_input_ = p_.motor_friction ? 1 : 2;  // a rigid body takes both alike
    build_matrices();
  }

  AxisSignals run();

 private:
  using State = Eigen::Matrix<double, N, 1>;
  using Input = Eigen::Matrix<double, kInputs, 1>;

  void build_matrices();
  double gravity(double q) const {
    double g = p_.gravity_constant;
    if (p_.gravity_trig) g += p_.gravity_cos * std::cos(q) + p_.gravity_sin * std::sin(q);
    return g;
  }
  double load_angle() const {
    if constexpr (kTwoBody) return x_(3);
    return x_(0);
  }
  double load_position() const {
    const double nut = p_.r * load_angle();
    return p_.pitch ? nut + p_.pitch_amplitude * std::sin(p_.pitch_wavenumber * nut + p_.pitch_phase)
                    : nut;
  }
  double measured_position() const {
    if (c_.position_feedback == PositionFeedback::load) return quantise(load_position(), p_.load_count, p_.inverse_load_count);
    return p_.r * quantise(x_(0), p_.motor_count, p_.inverse_motor_count);
  }
  double dry_level(double direction, double speed) const {
    const double base = direction > 0.0 ? p_.dry_positive : p_.dry_negative;
    if (!p_.stribeck) return base;
    const double ratio = speed / p_.stribeck_speed;
    const double shape =
        p_.stribeck_exponent == 2.0 ? ratio * ratio : std::pow(ratio, p_.stribeck_exponent);
    return base + (p_.static_friction - base) * std::exp(-shape);
  }
  // Spring torque from motor to load at the current state (two-mass), and the offset input.
  bool in_contact(double& offset) const {
    const double delta = x_(0) - x_(3);
    if (!p_.backlash) {
      offset = 0.0;
      return true;
    }
    const double half = 0.5 * p_.gap;
    if (delta > half) {
      offset = -p_.spring * half;
      return true;
    }
    if (delta < -half) {
      offset = p_.spring * half;
      return true;
    }
    offset = 0.0;
    return false;
  }
  bool backlash_keeps_contact(const Input& u);
  void backlash_after_free_step(const State& before);
  void advance(const Discrete<N>& d, const Input& u) {
    if constexpr (N == 3) {
      // Rigid: the first column of phi is e0 exactly (no force depends on theta), the motor and
      // the load torque enter alike and there is no spring input.
      const double x1 = x_(1), x2 = x_(2), tau = u(1) + u(2);
      x_(0) += d.phi(0, 1) * x1 + d.phi(0, 2) * x2 + d.gamma(0, 0) * u(0) + d.gamma(0, 1) * tau;
      x_(1) = d.phi(1, 1) * x1 + d.phi(1, 2) * x2 + d.gamma(1, 0) * u(0) + d.gamma(1, 1) * tau;
      x_(2) = d.phi(2, 1) * x1 + d.phi(2, 2) * x2 + d.gamma(2, 0) * u(0) + d.gamma(2, 1) * tau;
    } else {
      x_ = d.phi * x_ + d.gamma * u;
    }
  }
  void plant_step(const Input& held);

  const AxisServoModel& model_;
  const kinematics::Controller& c_;
  Parameters p_;
  const AxisInput& input_;
  SimulationOptions options_;
  SetpointSignal setpoints_;
  double base_ = 0.0;
  long n_pos_ = 1, n_vel_ = 1, n_cur_ = 1;
  int substeps_ = 1;
  double substep_ = 0.0;  // plant sub-step [s]
  Discrete<N> contact_, free_;
  State x_ = State::Zero();
  bool stuck_ = false;
  int friction_vel_ = 1, friction_pos_ = 0, friction_input_ = 2;
  int side_ = 0;  // rigid backlash: +1 / -1 motor pushing the load forwards / backwards, 0 apart
};

template <int N>
void AxisRun<N>::build_matrices() {
  using A = Eigen::Matrix<double, N, N>;
  using B = Eigen::Matrix<double, N, kInputs>;
  // The motor body (inertia jm) with the current dynamics, the electrical input u0 and the
  // motor torque u1.
  auto motor = [&](double jm, A& a, B& b) {
    a(0, 1) = 1.0;
    a(1, 2) = p_.kt / jm;
    b(1, 1) = 1.0 / jm;
    switch (c_.current_model) {
      case CurrentLoopModel::ideal:
        break;  // i is set at each velocity-loop output
      case CurrentLoopModel::first_order: {
        const double wc = kTwoPi * c_.current_bandwidth_hz;
        a(2, 2) = -wc;
        b(2, 0) = wc;
        break;
      }
      case CurrentLoopModel::PI: {
        const double ke = c_.back_emf_V_s_per_rad > 0.0 ? c_.back_emf_V_s_per_rad : p_.kt;
        a(2, 1) = -ke / c_.inductance_H;
        a(2, 2) = -c_.resistance_ohm / c_.inductance_H;
        b(2, 0) = 1.0 / c_.inductance_H;
        break;
      }
    }
  };
  const double h = base_ / substeps_;
  A a = A::Zero();
  B b = B::Zero();
  if constexpr (kTwoBody) {
    // Apart: the motor alone; the load (inertia jl) with its viscous friction and the load
    // torque u2.
    const double jm = p_.j_motor, jl = p_.j_load;
    motor(jm, a, b);
    a(3, 4) = 1.0;
    // The viscous friction on the body the friction acts on.
    const double viscous_motor = p_.motor_friction ? p_.viscous : 0.0;
    const double viscous_load = p_.motor_friction ? 0.0 : p_.viscous;
    a(1, 1) = -viscous_motor / jm;
    a(4, 4) = -viscous_load / jl;
    b(4, 2) = 1.0 / jl;
    free_ = discretise<N>(a, b, h);
    if (p_.two_mass) {
      // The spring (and its damping) between motor and load; the offset input u3 moves the
      // spring's zero by the half gap when the backlash is on.
      a(1, 0) = -p_.spring / jm;
      a(1, 3) = p_.spring / jm;
      a(1, 1) = -(p_.damping + viscous_motor) / jm;
      a(1, 4) = p_.damping / jm;
      a(4, 0) = p_.spring / jl;
      a(4, 3) = -p_.spring / jl;
      a(4, 1) = p_.damping / jl;
      a(4, 4) = -(p_.damping + viscous_load) / jl;
      b(1, 3) = -1.0 / jm;
      b(4, 3) = 1.0 / jl;
      contact_ = discretise<N>(a, b, h);
      return;
    }
    // Rigid backlash in contact: one body of inertia J_eq in the motor states; the load states
    // follow it at the flank (set after each step).
    a = A::Zero();
    b = B::Zero();
    motor(p_.j_total, a, b);
    a(1, 1) = -p_.viscous / p_.j_total;
    b(1, 2) = 1.0 / p_.j_total;
    contact_ = discretise<N>(a, b, h);
  } else {
    motor(p_.j_total, a, b);
    a(1, 1) = -p_.viscous / p_.j_total;
    b(1, 2) = 1.0 / p_.j_total;
    contact_ = discretise<N>(a, b, h);
    free_ = contact_;
  }
}

// Rigid backlash: does the motor keep pushing the load on its flank over the next step? It
// does while the force that makes both accelerate together presses motor and load together:
//   tau_c = (J_L tau_m - J_m tau_L) / J_eq   (motor torque tau_m, load torque tau_L)
// has the sign of the side. At rest the friction holds the load; the motor leaves it when its
// torque pulls away.
template <int N>
bool AxisRun<N>::backlash_keeps_contact(const Input& u) {
  if (side_ == 0) return false;
  const double tau_motor = p_.kt * x_(2) + u(1);
  bool keep;
  if (stuck_) {
    keep = side_ * tau_motor >= 0.0;
  } else {
    const double v = x_(1);
    const double viscous = p_.asymmetric ? (v > 0.0 ? p_.viscous_positive : p_.viscous_negative)
                                         : p_.viscous;
    double tau_load = u(2) - viscous * v;
    if (p_.coulomb) tau_load -= std::copysign(dry_level(v, std::abs(v)), v);
    keep = side_ * (p_.j_load * tau_motor - p_.j_motor * tau_load) >= 0.0;
  }
  if (!keep) side_ = 0;
  return keep;
}

// Rigid backlash, after a step apart: when the motor has crossed the gap it hits the load. The
// impact is inelastic (momentum kept, no rebound); the contact time is interpolated within the
// step and both move on together with the common speed from there.
template <int N>
void AxisRun<N>::backlash_after_free_step(const State& before) {
  const double half = 0.5 * p_.gap;
  const double delta = x_(0) - x_(3);
  if (delta < half && delta > -half) return;
  side_ = delta >= half ? 1 : -1;
  const double delta_before = before(0) - before(3);
  const double target = side_ * half;
  const double f = delta != delta_before
                       ? std::clamp((target - delta_before) / (delta - delta_before), 0.0, 1.0)
                       : 1.0;
  const double motor_at_contact = before(0) + f * (x_(0) - before(0));
  const double w = (p_.j_motor * x_(1) + p_.j_load * x_(4)) / p_.j_total;
  x_(0) = motor_at_contact + w * (1.0 - f) * (base_ / substeps_);
  x_(1) = w;
  x_(3) = x_(0) - target;
  x_(4) = w;
  if (w != 0.0) stuck_ = false;
}

// One plant sub-step with the inputs held: the dry friction (with the stick state) and the
// mode of the two bodies are decided at its start.
template <int N>
void AxisRun<N>::plant_step(const Input& held) {
  Input u = held;
  bool contact = true;
  if constexpr (kTwoBody) {
    contact = p_.two_mass ? in_contact(u(3)) : backlash_keeps_contact(u);
  }
  const double v = x_(friction_vel_);
  const int f_in = friction_input_;
  bool hold = false;
  if (p_.asymmetric) u(f_in) -= ((v > 0.0 ? p_.viscous_positive : p_.viscous_negative) - p_.viscous) * v;
  if (p_.coulomb && p_.smooth) {
    // Smooth dry friction, linearly implicit over the sub-step: the tanh is stiff near zero
    // speed (slope b / w), an explicit held value would chatter there.
    const double level = dry_level(v, std::abs(v));
    const double th = std::tanh(v / p_.smooth_speed);
    const double f = level * th;
    const double slope = level * (1.0 - th * th) / p_.smooth_speed;
    double net = u(f_in) - p_.viscous * v;
    double j = p_.j_total;
    if constexpr (kTwoBody) {
      if (p_.two_mass) {
        j = p_.motor_friction ? p_.j_motor : p_.j_load;
        double spring = 0.0;  // from the motor to the load
        if (contact) spring = p_.spring * (x_(0) - x_(3)) + p_.damping * (x_(1) - x_(4)) + u(3);
        net += p_.motor_friction ? p_.kt * x_(2) - spring : spring;
      } else if (contact) {
        net += p_.kt * x_(2) + u(1);
      } else {
        j = p_.j_load;
      }
    } else {
      net += p_.kt * x_(2) + u(1);
    }
    const double k = substep_ * slope / j;
    u(f_in) -= f + slope * (substep_ / j) * (net - f) / (1.0 + k);
  } else if (p_.coulomb) {
    if (stuck_) {
      // Torque on the friction body without the dry friction, at rest.
      double net = u(f_in);
      if constexpr (kTwoBody) {
        if (p_.motor_friction) {
          // The motor at rest: its torque against the spring (and the damper, with the load's
          // speed).
          net += p_.kt * x_(2);
          if (contact) net -= p_.spring * (x_(0) - x_(3)) - p_.damping * x_(4) + u(3);
        } else if (contact) {
          net += p_.two_mass ? p_.spring * (x_(0) - x_(3)) + p_.damping * x_(1) + u(3)
                             : p_.kt * x_(2) + u(1);
        }
      } else {
        net += p_.kt * x_(2) + u(1);
      }
      const double limit = p_.stribeck ? p_.static_friction : dry_level(net, 0.0);
      if (std::abs(net) <= limit) {
        u(f_in) -= net;
        hold = true;
      } else {
        u(f_in) -= std::copysign(limit, net);
        stuck_ = false;
      }
    } else {
      u(f_in) -= std::copysign(dry_level(v, std::abs(v)), v);
    }
  }
  const State before = x_;
  advance(contact ? contact_ : free_, u);
  // Rigid backlash in contact: the load sits at the flank and moves with the motor.
  const bool rigid_contact = kTwoBody && p_.rigid_backlash && contact;
  if constexpr (kTwoBody) {
    if (rigid_contact) {
      x_(3) = x_(0) - side_ * 0.5 * p_.gap;
      x_(4) = x_(1);
    }
  }
  if (hold) {
    x_(friction_pos_) = before(friction_pos_);
    x_(friction_vel_) = 0.0;
    if (rigid_contact) {
      x_(0) = before(0);
      x_(1) = 0.0;
    }
  } else if (p_.coulomb && !p_.smooth && v != 0.0 && x_(friction_vel_) * v <= 0.0) {
    // The velocity reached zero within the step: the body stops and sticks until the torque on
    // it exceeds the static friction (no chatter around zero).
    x_(friction_vel_) = 0.0;
    if (rigid_contact) x_(1) = 0.0;
    stuck_ = true;
  }
  if constexpr (kTwoBody) {
    if (p_.rigid_backlash && !contact) backlash_after_free_step(before);
  }
}

template <int N>
AxisSignals AxisRun<N>::run() {
  const bool position_input = input_.kind == AxisInput::Kind::position;
  const double inverse_input_period = 1.0 / input_.period_s;
  const double duration =
      static_cast<double>(input_.values.size() - 1) * input_.period_s + input_.extra_time_s;
  const long ticks = static_cast<long>(std::floor(duration / base_ + 1e-9));
  const double record_period = options_.record_period_s > 0.0 ? options_.record_period_s : input_.period_s;
  const double record_ratio = record_period / base_;
  const long n_record = std::lround(record_ratio);
  if (n_record < 1 || std::abs(record_ratio - static_cast<double>(n_record)) > 1e-6 * record_ratio) {
    throw InputError("axis " + model_.axis.name + ": the record period " +
                     std::to_string(record_period) +
                     " s is not a whole multiple of the fastest loop period " +
                     std::to_string(base_) + " s");
  }

  // Initial state: at rest at the first set point, the static torque (gravity minus the
  // external force) carried by the motor and the PI integrators, as after a long standstill.
  const double q0 = position_input ? input_.values.front() : model_.axis.home;
  const double static_torque =
      gravity(q0) - p_.r * SetpointSignal::held(input_.external_force, input_.start_time_s,
                                                inverse_input_period, input_.start_time_s);
  double i0 = static_torque / p_.kt;
  if (c_.current_max_A > 0.0) i0 = std::clamp(i0, -c_.current_max_A, c_.current_max_A);
  x_(0) = q0 / p_.r;
  x_(2) = i0;
  if constexpr (kTwoBody) {
    // Motor minus load angle: the spring deflection and, with backlash, the motor on the flank
    // it pushes (centred in the gap when nothing pushes).
    const int side = (static_torque > 0.0) - (static_torque < 0.0);
    double delta = p_.backlash ? side * 0.5 * p_.gap : 0.0;
    if (p_.two_mass) delta += static_torque / p_.spring;
    if (p_.rigid_backlash) side_ = side;
    if (c_.position_feedback == PositionFeedback::load) {
      x_(3) = q0 / p_.r;
      x_(0) = x_(3) + delta;
    } else {
      x_(3) = x_(0) - delta;
    }
  }
  stuck_ = p_.coulomb && !p_.smooth;

  const double kv = c_.position_gain_kv_per_s;
  const double velocity_period = static_cast<double>(n_vel_) * base_;
  const double inverse_r = 1.0 / p_.r;
  const double inverse_kt = 1.0 / p_.kt;
  const double current_period = static_cast<double>(n_cur_) * base_;
  const double position_period = static_cast<double>(n_pos_) * base_;
  // The velocity loop is a chain of dependent operations run at every tick, on the critical
  // path of the simulation: its constants are folded so that it is a few multiply-adds
  // (Kp / Kt, the integrator kept in amperes, the filter gain times 1 / T).
  const double kp_per_kt = c_.velocity_gain_N_m_s_per_rad * inverse_kt;
  const double ki_per_kt = c_.velocity_type == VelocityControllerType::PI
                               ? kp_per_kt * velocity_period / c_.velocity_integral_time_s
                               : 0.0;
  const double velocity_filter =
      c_.velocity_filter_time_s > 0.0 ? std::exp(-velocity_period / c_.velocity_filter_time_s) : 0.0;
  // The velocity loop differences the encoder in counts (the angle itself when ideal), the
  // count's size folded into the gain: one multiplication less on the critical path.
  const bool counted = p_.motor_count > 0.0;
  const double difference_gain =
      (1.0 - velocity_filter) / velocity_period * (counted ? p_.motor_count : 1.0);
  auto encoder_reading = [&](double angle) {
    return counted ? round_to_integer(angle * p_.inverse_motor_count) : angle;
  };
  const double imax = c_.current_max_A > 0.0 ? c_.current_max_A : 0.0;
  const double wmax = c_.velocity_max_rad_per_s > 0.0 ? c_.velocity_max_rad_per_s : 0.0;
  const bool current_pi = c_.current_model == CurrentLoopModel::PI;
  const bool current_ideal = c_.current_model == CurrentLoopModel::ideal;
  const double kpi = c_.current_gain_V_per_A;
  const double kii = current_pi ? kpi * current_period / c_.current_integral_time_s : 0.0;
  const double vmax = c_.voltage_max_V;
  // Balancing lag, discretised exactly for a set point linear between position ticks (so that
  // on a ramp it lags by exactly its time constant).
  double lag_alpha = 0.0, lag_b0 = 1.0, lag_b1 = 0.0;
  if (c_.balancing_type == BalancingType::first_order_lag) {
    const double tau = c_.balancing_time_s;
    lag_alpha = std::exp(-position_period / tau);
    const double ramp = 1.0 - tau / position_period * (1.0 - lag_alpha);
    lag_b0 = ramp;
    lag_b1 = 1.0 - lag_alpha - ramp;
  }
  const double tff_gain =
      c_.torque_feedforward ? c_.torque_feedforward_weight * p_.j_total / p_.r : 0.0;
  const double vff_gain = c_.velocity_feedforward ? c_.velocity_feedforward_weight : 0.0;
  const bool feedforward = vff_gain != 0.0 || tff_gain != 0.0;
  const bool interpolate_feedforward =
      feedforward && options_.interpolate_feedforward &&
      c_.feedforward_timing == kinematics::FeedforwardTiming::interpolated;
  const bool backward_feedforward =
      c_.feedforward_timing == kinematics::FeedforwardTiming::held_backward;
  const double inverse_position_ticks = 1.0 / static_cast<double>(n_pos_);

  double velocity_integral_A =
      c_.velocity_type == VelocityControllerType::PI ? static_torque * inverse_kt : 0.0;
  double current_integral = current_pi ? c_.resistance_ohm * i0 : 0.0;
  double encoder_previous = encoder_reading(x_(0));
  double omega_filtered = 0.0;
  double lag_state = q0, lag_input_previous = q0;
  // Position controller outputs, each after the output delay: the P term [rad/s], the velocity
  // feedforward [rad/s] and the torque feedforward / Kt [A] at the position tick, and their
  // change per base tick until the next position tick (0 when held).
  DelayLine out_p, out_vff, out_vff_step, out_tff, out_tff_step;
  for (DelayLine* line : {&out_p, &out_vff, &out_vff_step, &out_tff, &out_tff_step}) {
    line->reset(c_.position_output_delay_samples, 0.0);
  }
  // Output dead time given as a time (position.output_dead_time_*): the outputs computed at a
  // position tick take effect this many base ticks later, at any tick (e.g. the next velocity
  // cycle), not only at a later position tick.
  const long dead_ticks = c_.position_output_dead_time_s > 0.0
                              ? std::lround(c_.position_output_dead_time_s / base_)
                              : 0;
  struct PendingOutput {
    long due = 0;
    double p = 0.0, vff = 0.0, vff_step = 0.0, tff = 0.0, tff_step = 0.0;
  };
  std::deque<PendingOutput> pending;
  long applied_tick = 0;
  DelayLine velocity_out, current_out;
  velocity_out.reset(c_.velocity_output_delay_samples, i0);
  current_out.reset(c_.current_output_delay_samples, c_.resistance_ohm * i0);
  double p_term = 0.0, vff = 0.0, vff_step = 0.0, tff = 0.0, tff_step = 0.0;
  double omega_input = 0.0, current_command = i0, voltage = c_.resistance_ohm * i0;
  // The same, undelayed, for the inner signals [joint units, N m].
  double deviation = 0.0, p_term_joint = 0.0, vff_joint = 0.0, vff_step_joint = 0.0;
  double tff_now = 0.0, tff_step_now = 0.0;
  double current_set_now = i0;

  AxisSignals out;
  const std::size_t records = static_cast<std::size_t>(ticks / n_record) + 1;
  for (auto* v : {&out.t, &out.cmd, &out.pos, &out.load_pos, &out.motor_pos, &out.vel, &out.current}) {
    v->reserve(records);
  }
  Input u = Input::Zero();
  // Countdown counters rather than k % n (an integer division per loop and tick).
  long position_count = 0, velocity_count = 0, current_count = 0, record_count = 0;
  long record_index = 0;
  double gravity_q = 0.0, gravity_value = 0.0, gravity_slope = 0.0;

  for (long k = 0; k <= ticks; ++k) {
    const long position_phase = position_count;  // base ticks since the last position tick
    const bool position_tick = position_count == 0;
    const bool velocity_tick = velocity_count == 0;
    const bool current_tick = current_count == 0;
    const bool record_tick = record_count == 0;
    position_count = position_count + 1 == n_pos_ ? 0 : position_count + 1;
    velocity_count = velocity_count + 1 == n_vel_ ? 0 : velocity_count + 1;
    current_count = current_count + 1 == n_cur_ ? 0 : current_count + 1;
    record_count = record_count + 1 == n_record ? 0 : record_count + 1;
    const double t = input_.start_time_s + static_cast<double>(k) * base_;
    // Position loop (NC): fine interpolation, delay, balancing, P controller, feedforward.
    if (!position_input && velocity_tick) {
      // Velocity input: the set point goes straight to the velocity controller.
      p_term_joint = setpoints_.at(t).x;
      omega_input = p_term_joint * inverse_r;
    }
    if (position_input && position_tick) {
      const double t_delayed = t - c_.delay_s;
      const SetpointSignal::Sample s = setpoints_.at(t_delayed);
      double balanced = s.x;
      if (c_.balancing_type == BalancingType::dead_time) {
        balanced = setpoints_.at(t_delayed - c_.balancing_time_s).x;
      } else if (c_.balancing_type == BalancingType::first_order_lag) {
        lag_state = lag_alpha * lag_state + lag_b0 * s.x + lag_b1 * lag_input_previous;
        lag_input_previous = s.x;
        balanced = lag_state;
      }
      deviation = balanced - measured_position();
      p_term_joint = kv * deviation;
      vff_joint = vff_gain * s.v;
      tff_now = tff_gain * s.a;
      if (backward_feedforward && feedforward) {
        // The NC's own differences of the set points it has sent (causal): the velocity lags
        // half a position period, the acceleration a whole one.
        const double x1 = setpoints_.at(t_delayed - position_period).x;
        const double x2 = setpoints_.at(t_delayed - 2.0 * position_period).x;
        const double inv = 1.0 / position_period;
        vff_joint = vff_gain * (s.x - x1) * inv;
        tff_now = tff_gain * (s.x - 2.0 * x1 + x2) * inv * inv;
      }
      if (interpolate_feedforward) {
        // The drive's fine interpolation of the feedforward: linear from this position tick's
        // value to the next one's (the set point one position period later), so the velocity
        // set point has no steps at the position period.
        const SetpointSignal::Sample next = setpoints_.at(t_delayed + position_period);
        vff_step_joint = (vff_gain * next.v - vff_joint) * inverse_position_ticks;
        tff_step_now = (tff_gain * next.a - tff_now) * inverse_position_ticks;
      }
      if (dead_ticks > 0) {
        pending.push_back({k + dead_ticks, p_term_joint * inverse_r, vff_joint * inverse_r,
                           vff_step_joint * inverse_r, tff_now * inverse_kt,
                           tff_step_now * inverse_kt});
      } else {
        p_term = out_p.push(p_term_joint * inverse_r);
        vff = out_vff.push(vff_joint * inverse_r);
        vff_step = out_vff_step.push(vff_step_joint * inverse_r);
        tff = out_tff.push(tff_now * inverse_kt);
        tff_step = out_tff_step.push(tff_step_now * inverse_kt);
        applied_tick = k;
      }
    }
    while (!pending.empty() && pending.front().due <= k) {
      const PendingOutput& o = pending.front();
      p_term = o.p;
      vff = o.vff;
      vff_step = o.vff_step;
      tff = o.tff;
      tff_step = o.tff_step;
      applied_tick = o.due;
      pending.pop_front();
    }
    // Velocity loop: differenced, filtered motor encoder; PI or P; current saturation.
    if (velocity_tick) {
      const double phase = static_cast<double>(dead_ticks > 0 ? k - applied_tick : position_phase);
      const double omega_set =
          position_input ? p_term + vff + vff_step * phase : omega_input;
      const double bias = velocity_integral_A + tff + tff_step * phase;  // [A]
      const double target = wmax > 0.0 ? std::clamp(omega_set, -wmax, wmax) : omega_set;
      const double encoder = encoder_reading(x_(0));
      omega_filtered =
          velocity_filter * omega_filtered + difference_gain * (encoder - encoder_previous);
      encoder_previous = encoder;
      const double error = target - omega_filtered;
      const double unsaturated = kp_per_kt * error + bias;
      // Saturation as a (well predicted) branch rather than min / max: the command then does not
      // wait for the comparison.
      double command = unsaturated;
      const bool saturated = imax > 0.0 && std::abs(unsaturated) > imax;
      if (saturated) command = std::copysign(imax, unsaturated);
      // Anti-windup: integrate only while the output is not pushed further into saturation.
      if (!saturated || (unsaturated > command) != (error > 0.0)) {
        velocity_integral_A += ki_per_kt * error;
      }
      current_set_now = command;
      current_command = velocity_out.push(command);
      if (current_ideal) x_(2) = current_command;
      if (!current_pi) u(0) = current_command;
    }
    // Current loop (PI on the electrical model).
    if (current_pi && current_tick) {
      const double error = current_command - x_(2);
      const double unsaturated = kpi * error + current_integral;
      double command = unsaturated;
      if (vmax > 0.0) command = std::clamp(command, -vmax, vmax);
      if (command == unsaturated || (unsaturated > command) != (error > 0.0)) {
        current_integral += kii * error;
      }
      voltage = current_out.push(command);
      u(0) = voltage;
    }

    if (record_tick) {
      const double cmd = setpoints_.at(t).x;
      const double pos = measured_position();
      out.t.push_back(input_.start_time_s + static_cast<double>(record_index++) * record_period);
      out.cmd.push_back(cmd);
      out.pos.push_back(pos);
      out.load_pos.push_back(load_position());
      out.motor_pos.push_back(p_.r * quantise(x_(0), p_.motor_count, p_.inverse_motor_count));
      out.vel.push_back(p_.r * x_(1));
      out.current.push_back(x_(2));
      if (options_.inner_signals) {
        const double phase = static_cast<double>(position_phase);
        const double vff_at = position_input ? vff_joint + vff_step_joint * phase : 0.0;
        out.following_error.push_back(cmd - pos);
        out.control_deviation.push_back(deviation);
        out.velocity_setpoint.push_back(p_term_joint + vff_at);
        out.velocity_feedforward.push_back(vff_at);
        out.torque_feedforward.push_back(tff_now + tff_step_now * phase);
        out.current_setpoint.push_back(current_set_now);
      }
    }
    if (k == ticks) break;

    // Disturbances held over the tick: gravity, external force, cogging (on the motor).
    const double q_nut = p_.r * load_angle();
    double external = 0.0;
    if (!input_.external_force.empty()) {
      external = p_.r * SetpointSignal::held(input_.external_force, input_.start_time_s,
                                             inverse_input_period, t);
    }
    // Gravity of a tilting axis: sinusoid evaluated at each position tick, linearised in between
    // (relative error below 1e-5 at the Mikron A axis's top speed).
    if (p_.gravity_trig && position_tick) {
      gravity_q = q_nut;
      gravity_value = gravity(q_nut);
      gravity_slope = -p_.gravity_cos * std::sin(q_nut) + p_.gravity_sin * std::cos(q_nut);
    }
    const double tau_gravity =
        p_.gravity_trig ? gravity_value + gravity_slope * (q_nut - gravity_q) : p_.gravity_constant;
    u(2) = external - tau_gravity;
    if (!p_.cogging) {
      u(1) = 0.0;
      for (int s = 0; s < substeps_; ++s) plant_step(u);
    } else {
      for (int s = 0; s < substeps_; ++s) {
        u(1) = p_.cogging_amplitude * std::sin(p_.cogging_periods * x_(0) + p_.cogging_phase);
        plant_step(u);
      }
    }
  }
  return out;
}

}  // namespace

AxisSignals simulate_axis(const AxisServoModel& model, const AxisInput& input,
                          const SimulationOptions& options) {
  if (input.values.size() < 2) {
    throw InputError("axis " + model.axis.name + ": at least two set points are needed");
  }
  if (!(input.period_s > 0.0)) {
    throw InputError("axis " + model.axis.name + ": the set-point period must be > 0");
  }
  if (!input.external_force.empty() && input.external_force.size() != input.values.size()) {
    throw InputError("axis " + model.axis.name +
                     ": the external force needs one value per set point");
  }
  const auto& compliance = model.axis.effects.compliance;
  if (compliance.enabled && compliance.compensate_gravity_deflection &&
      input.kind == AxisInput::Kind::position &&
      model.axis.controller.position_feedback == PositionFeedback::motor) {
    // Deflection compensation: the motor is commanded further by the spring's static deflection
    // under gravity at the set point, tau_g(q) / (k r) at the joint (tau_g at the motor), so that
    // at rest the load stands at the set point.
    AxisInput shifted = input;
    const double r = model.axis.drive.ratio;
    for (double& q : shifted.values) {
      double tau = model.gravity_constant_N_m;
      if (model.axis.type == kinematics::AxisType::rotary) {
        tau += model.gravity_cos_N_m * std::cos(q) + model.gravity_sin_N_m * std::sin(q);
      }
      q += tau / (compliance.stiffness * r);
    }
    AxisRun<5> run(model, shifted, options);
    AxisSignals out = run.run();
    // The set point as given (the compensation is inside the controller).
    const SetpointSignal given(input, model.axis.controller.fine_interpolation);
    for (std::size_t k = 0; k < out.t.size(); ++k) {
      out.cmd[k] = given.at(out.t[k]).x;
      if (options.inner_signals) out.following_error[k] = out.cmd[k] - out.pos[k];
    }
    return out;
  }
  if (compliance.enabled || model.axis.effects.backlash.enabled) {
    AxisRun<5> run(model, input, options);
    return run.run();
  }
  AxisRun<3> run(model, input, options);
  return run.run();
}

}  // namespace vmsim::servo
