// One axis drive: cascade control at its loop rates, exact discretisation of the linear
// mechanics between ticks, dry friction with a stick state. See servo.hpp and README.md.
#include <Eigen/Core>
#include <array>
#include <deque>
#include <memory>
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
/// so that position, velocity and acceleration line up in time), received window by window: the
/// knots are pushed as they come and those no lookup reaches any more are forgotten. A value
/// read at u = (t - t0) / period is the same whatever the windows were, as long as the knots up
/// to floor(u) + 2 have been pushed, or the signal is finished (the caller makes sure of it).
class SetpointSignal {
 public:
  struct Sample {
    double x = 0.0, v = 0.0, a = 0.0;
  };

  SetpointSignal(double start_time_s, double period_s, FineInterpolation interpolation, bool held)
      : t0_(start_time_s),
        period_(period_s),
        inverse_period_(1.0 / period_s),
        cubic_(interpolation == FineInterpolation::cubic),
        held_(held) {}

  void push(double value) {
    if (count_ == 0) front_ = value;
    x_.push_back(value);
    v_.push_back(0.0);
    a_.push_back(0.0);
    ++count_;
    // The central differences of the knot before, now that its neighbour is known.
    if (count_ >= 2) derive(count_ - 2);
  }
  /// No more knots: the last one's differences hold it (as at the end of the run).
  void finish() {
    if (finished_ || count_ == 0) return;
    finished_ = true;
    derive(count_ - 1);
  }
  std::size_t count() const { return count_; }
  double front() const { return front_; }
  bool finished() const { return finished_; }
  /// Forgets the knots before `index` (no lookup reaches them any more).
  void forget_before(std::size_t index) {
    if (index <= first_ + x_.size() / 2 || index > first_ + x_.size()) return;
    const auto drop = static_cast<std::ptrdiff_t>(index - first_);
    x_.erase(x_.begin(), x_.begin() + drop);
    v_.erase(v_.begin(), v_.begin() + drop);
    a_.erase(a_.begin(), a_.begin() + drop);
    first_ = index;
  }
  /// The knot index at time t (floor of u, may be negative or past the end).
  double knot_position(double t) const { return (t - t0_) * inverse_period_; }

  Sample at(double t) const {
    const double u = (t - t0_) * inverse_period_;
    const std::size_t last = count_ - 1;
    if (u <= 0.0) return {front_, 0.0, 0.0};
    if (u >= static_cast<double>(last)) return {x(last), 0.0, 0.0};
    const std::size_t k = static_cast<std::size_t>(u);
    const double f = u - static_cast<double>(k);
    if (held_) return {x(k), 0.0, 0.0};
    const std::size_t i = k - first_;
    Sample s;
    s.a = a_[i] + f * (a_[i + 1] - a_[i]);
    if (!cubic_) {
      s.x = x_[i] + f * (x_[i + 1] - x_[i]);
      s.v = v_[i] + f * (v_[i + 1] - v_[i]);
      return s;
    }
    // Cubic Hermite with the central-difference slopes (Catmull-Rom): C1 in x.
    const double f2 = f * f, f3 = f2 * f;
    const double dx = x_[i + 1] - x_[i];
    const double m0 = v_[i] * period_, m1 = v_[i + 1] * period_;
    s.x = x_[i] + (3.0 * f2 - 2.0 * f3) * dx + (f3 - 2.0 * f2 + f) * m0 + (f3 - f2) * m1;
    s.v = ((6.0 * f - 6.0 * f2) * dx + (3.0 * f2 - 4.0 * f + 1.0) * m0 + (3.0 * f2 - 2.0 * f) * m1) *
          inverse_period_;
    return s;
  }

  /// The knot held at t (for the external force): 0 without knots.
  double held(double t) const {
    if (count_ == 0) return 0.0;
    const double u = (t - t0_) * inverse_period_;
    if (u <= 0.0) return front_;
    const std::size_t k = static_cast<std::size_t>(u);
    return k < count_ ? x(k) : x(count_ - 1);
  }

 private:
  double x(std::size_t k) const { return x_[k - first_]; }
  void derive(std::size_t k) {
    const std::size_t i = k - first_;
    const double before = x_[k == 0 ? i : i - 1];
    const double after = x_[k + 1 < count_ ? i + 1 : i];
    v_[i] = (after - before) * 0.5 * inverse_period_;
    a_[i] = (after - 2.0 * x_[i] + before) * inverse_period_ * inverse_period_;
  }

  double t0_, period_, inverse_period_;
  bool cubic_, held_;
  bool finished_ = false;
  std::size_t count_ = 0;  ///< knots pushed so far
  std::size_t first_ = 0;  ///< index of x_[0]
  double front_ = 0.0;     ///< the first knot (held before the start)
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

  // `compensate_deflection`: the set points pushed are shifted by the spring's static
  // deflection under gravity (the motor is commanded further, see simulate_axis); the recorded
  // command stays the one given.
  AxisRun(const AxisServoModel& model, double start_time_s, double period_s, AxisInput::Kind kind,
          const SimulationOptions& options, bool compensate_deflection)
      : model_(model), c_(model.axis.controller), p_(derive(model)), options_(options),
        start_time_s_(start_time_s), period_s_(period_s), position_input_(kind == AxisInput::Kind::position),
        compensate_(compensate_deflection),
        setpoints_(start_time_s, period_s, c_.fine_interpolation, kind == AxisInput::Kind::velocity),
        given_(start_time_s, period_s, c_.fine_interpolation, kind == AxisInput::Kind::velocity),
        force_(start_time_s, period_s, c_.fine_interpolation, true) {
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

  /// Appends set points (and, optionally, the external force on each; either with every
  /// window or never).
  void push(const double* values, const double* external_force, std::size_t count);
  /// Simulates every tick the set points pushed so far determine, appending the records.
  void advance(AxisSignals& out);
  /// No more set points: simulates to the last one plus extra_time_s.
  void finish(double extra_time_s, AxisSignals& out);
  std::size_t pushed() const { return setpoints_.count(); }

 private:
  struct LoopState;
  void start();
  // Simulates the ticks up to `last_tick` (inclusive); `final_tick`: the run's last tick (no
  // plant step after it), or -1 while the end is not known.
  void simulate_ticks(long last_tick, long final_tick, AxisSignals& out);
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
  SimulationOptions options_;
  double start_time_s_, period_s_;
  bool position_input_, compensate_;
  SetpointSignal setpoints_;  ///< what the controller follows
  SetpointSignal given_;      ///< the set points as given (recorded command), when compensated
  SetpointSignal force_;      ///< external force [N or N m], held per sample
  bool has_force_ = false;
  bool started_ = false;
  long next_tick_ = 0;        ///< the first tick not simulated yet
  std::unique_ptr<LoopState> loop_;
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


// The controllers' constants and the loop state carried from one window to the next (what were
// the locals of one whole run). simulate_ticks copies them into locals for its loop (the hot
// path keeps them in registers) and stores them back at the end of the window.
template <int N>
struct AxisRun<N>::LoopState {
  // Constants.
  double inverse_input_period = 0.0, record_period = 0.0;
  long n_record = 1;
  double kv = 0.0, velocity_period = 0.0, inverse_r = 1.0, inverse_kt = 1.0, current_period = 0.0,
         position_period = 0.0, kp_per_kt = 0.0, ki_per_kt = 0.0, velocity_filter = 0.0;
  bool counted = false;
  double difference_gain = 0.0, imax = 0.0, wmax = 0.0;
  bool current_pi = false, current_ideal = false;
  double kpi = 0.0, kii = 0.0, vmax = 0.0;
  double lag_alpha = 0.0, lag_b0 = 1.0, lag_b1 = 0.0;
  double tff_gain = 0.0, vff_gain = 0.0;
  bool feedforward = false, interpolate_feedforward = false, backward_feedforward = false;
  double inverse_position_ticks = 1.0;
  long dead_ticks = 0;
  /// How far ahead of and behind a tick's time the set points are read [s] (with a margin).
  double ahead_s = 0.0, behind_s = 0.0;
  // State.
  struct PendingOutput {
    long due = 0;
    double p = 0.0, vff = 0.0, vff_step = 0.0, tff = 0.0, tff_step = 0.0;
  };
  double velocity_integral_A = 0.0, current_integral = 0.0, encoder_previous = 0.0,
         omega_filtered = 0.0, lag_state = 0.0, lag_input_previous = 0.0;
  // Position controller outputs, each after the output delay: the P term [rad/s], the velocity
  // feedforward [rad/s] and the torque feedforward / Kt [A] at the position tick, and their
  // change per base tick until the next position tick (0 when held).
  DelayLine out_p, out_vff, out_vff_step, out_tff, out_tff_step;
  std::deque<PendingOutput> pending;
  long applied_tick = 0;
  DelayLine velocity_out, current_out;
  double p_term = 0.0, vff = 0.0, vff_step = 0.0, tff = 0.0, tff_step = 0.0;
  double omega_input = 0.0, current_command = 0.0, voltage = 0.0;
  // The same, undelayed, for the inner signals [joint units, N m].
  double deviation = 0.0, p_term_joint = 0.0, vff_joint = 0.0, vff_step_joint = 0.0;
  double tff_now = 0.0, tff_step_now = 0.0, current_set_now = 0.0;
  Eigen::Matrix<double, kInputs, 1> u = Eigen::Matrix<double, kInputs, 1>::Zero();
  // Countdown counters rather than k % n (an integer division per loop and tick).
  long position_count = 0, velocity_count = 0, current_count = 0, record_count = 0;
  long record_index = 0;
  double gravity_q = 0.0, gravity_value = 0.0, gravity_slope = 0.0;
};

template <int N>
void AxisRun<N>::push(const double* values, const double* external_force, std::size_t count) {
  if (count == 0) return;
  if (setpoints_.count() == 0) has_force_ = external_force != nullptr;
  if ((external_force != nullptr) != has_force_) {
    throw InputError("axis " + model_.axis.name +
                     ": the external force is given with every window of set points or with none");
  }
  for (std::size_t k = 0; k < count; ++k) {
    double q = values[k];
    if (compensate_) {
      // Deflection compensation: the motor is commanded further by the spring's static
      // deflection under gravity at the set point, tau_g(q) / (k r) at the joint (tau_g at the
      // motor), so that at rest the load stands at the set point.
      given_.push(q);
      double tau = model_.gravity_constant_N_m;
      if (model_.axis.type == kinematics::AxisType::rotary) {
        tau += model_.gravity_cos_N_m * std::cos(q) + model_.gravity_sin_N_m * std::sin(q);
      }
      q += tau / (model_.axis.effects.compliance.stiffness * model_.axis.drive.ratio);
    }
    setpoints_.push(q);
    if (has_force_) force_.push(external_force[k]);
  }
}

template <int N>
void AxisRun<N>::start() {
  started_ = true;
  loop_ = std::make_unique<LoopState>();
  LoopState& L = *loop_;
  L.inverse_input_period = 1.0 / period_s_;
  L.record_period = options_.record_period_s > 0.0 ? options_.record_period_s : period_s_;
  const double record_ratio = L.record_period / base_;
  L.n_record = std::lround(record_ratio);
  if (L.n_record < 1 || std::abs(record_ratio - static_cast<double>(L.n_record)) > 1e-6 * record_ratio) {
    throw InputError("axis " + model_.axis.name + ": the record period " +
                     std::to_string(L.record_period) +
                     " s is not a whole multiple of the fastest loop period " +
                     std::to_string(base_) + " s");
  }

  // Initial state: at rest at the first set point, the static torque (gravity minus the
  // external force) carried by the motor and the PI integrators, as after a long standstill.
  const double q0 = position_input_ ? setpoints_.front() : model_.axis.home;
  const double static_torque = gravity(q0) - p_.r * force_.held(start_time_s_);
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

  L.kv = c_.position_gain_kv_per_s;
  L.velocity_period = static_cast<double>(n_vel_) * base_;
  L.inverse_r = 1.0 / p_.r;
  L.inverse_kt = 1.0 / p_.kt;
  L.current_period = static_cast<double>(n_cur_) * base_;
  L.position_period = static_cast<double>(n_pos_) * base_;
  // The velocity loop is a chain of dependent operations run at every tick, on the critical
  // path of the simulation: its constants are folded so that it is a few multiply-adds
  // (Kp / Kt, the integrator kept in amperes, the filter gain times 1 / T).
  L.kp_per_kt = c_.velocity_gain_N_m_s_per_rad * L.inverse_kt;
  L.ki_per_kt = c_.velocity_type == VelocityControllerType::PI
                    ? L.kp_per_kt * L.velocity_period / c_.velocity_integral_time_s
                    : 0.0;
  L.velocity_filter =
      c_.velocity_filter_time_s > 0.0 ? std::exp(-L.velocity_period / c_.velocity_filter_time_s) : 0.0;
  // The velocity loop differences the encoder in counts (the angle itself when ideal), the
  // count's size folded into the gain: one multiplication less on the critical path.
  L.counted = p_.motor_count > 0.0;
  L.difference_gain =
      (1.0 - L.velocity_filter) / L.velocity_period * (L.counted ? p_.motor_count : 1.0);
  L.imax = c_.current_max_A > 0.0 ? c_.current_max_A : 0.0;
  L.wmax = c_.velocity_max_rad_per_s > 0.0 ? c_.velocity_max_rad_per_s : 0.0;
  L.current_pi = c_.current_model == CurrentLoopModel::PI;
  L.current_ideal = c_.current_model == CurrentLoopModel::ideal;
  L.kpi = c_.current_gain_V_per_A;
  L.kii = L.current_pi ? L.kpi * L.current_period / c_.current_integral_time_s : 0.0;
  L.vmax = c_.voltage_max_V;
  // Balancing lag, discretised exactly for a set point linear between position ticks (so that
  // on a ramp it lags by exactly its time constant).
  if (c_.balancing_type == BalancingType::first_order_lag) {
    const double tau = c_.balancing_time_s;
    L.lag_alpha = std::exp(-L.position_period / tau);
    const double ramp = 1.0 - tau / L.position_period * (1.0 - L.lag_alpha);
    L.lag_b0 = ramp;
    L.lag_b1 = 1.0 - L.lag_alpha - ramp;
  }
  L.tff_gain = c_.torque_feedforward ? c_.torque_feedforward_weight * p_.j_total / p_.r : 0.0;
  L.vff_gain = c_.velocity_feedforward ? c_.velocity_feedforward_weight : 0.0;
  L.feedforward = L.vff_gain != 0.0 || L.tff_gain != 0.0;
  L.interpolate_feedforward = L.feedforward && options_.interpolate_feedforward &&
                              c_.feedforward_timing == kinematics::FeedforwardTiming::interpolated;
  L.backward_feedforward = c_.feedforward_timing == kinematics::FeedforwardTiming::held_backward;
  L.inverse_position_ticks = 1.0 / static_cast<double>(n_pos_);
  // Output dead time given as a time (position.output_dead_time_*): the outputs computed at a
  // position tick take effect this many base ticks later, at any tick (e.g. the next velocity
  // cycle), not only at a later position tick.
  L.dead_ticks = c_.position_output_dead_time_s > 0.0 ? std::lround(c_.position_output_dead_time_s / base_) : 0;
  const double balancing = c_.balancing_type == BalancingType::dead_time ? std::abs(c_.balancing_time_s) : 0.0;
  L.ahead_s = std::abs(c_.delay_s) + L.position_period + 2.0 * base_;
  L.behind_s = std::abs(c_.delay_s) + balancing + 2.0 * L.position_period + 2.0 * base_;

  L.velocity_integral_A = c_.velocity_type == VelocityControllerType::PI ? static_torque * L.inverse_kt : 0.0;
  L.current_integral = L.current_pi ? c_.resistance_ohm * i0 : 0.0;
  L.encoder_previous = L.counted ? round_to_integer(x_(0) * p_.inverse_motor_count) : x_(0);
  L.lag_state = q0;
  L.lag_input_previous = q0;
  for (DelayLine* line : {&L.out_p, &L.out_vff, &L.out_vff_step, &L.out_tff, &L.out_tff_step}) {
    line->reset(c_.position_output_delay_samples, 0.0);
  }
  L.velocity_out.reset(c_.velocity_output_delay_samples, i0);
  L.current_out.reset(c_.current_output_delay_samples, c_.resistance_ohm * i0);
  L.current_command = i0;
  L.voltage = c_.resistance_ohm * i0;
  L.current_set_now = i0;
}

template <int N>
void AxisRun<N>::advance(AxisSignals& out) {
  // Two knots beyond the last one read are needed (the central difference of the next knot).
  if (setpoints_.count() < 4) return;
  if (!started_) start();
  const LoopState& L = *loop_;
  const double known_s = static_cast<double>(setpoints_.count() - 3) * period_s_ - L.ahead_s;
  const long last_tick = static_cast<long>(std::floor(known_s / base_)) - 1;
  if (last_tick < next_tick_) return;
  simulate_ticks(last_tick, -1, out);
  // Knots no later tick reads again.
  const double t_next = start_time_s_ + static_cast<double>(next_tick_) * base_;
  const double oldest = std::floor(setpoints_.knot_position(t_next - L.behind_s)) - 2.0;
  if (oldest > 0.0) {
    const auto index = static_cast<std::size_t>(oldest);
    setpoints_.forget_before(index);
    given_.forget_before(index);
    force_.forget_before(index);
  }
}

template <int N>
void AxisRun<N>::finish(double extra_time_s, AxisSignals& out) {
  if (setpoints_.count() < 2) {
    throw InputError("axis " + model_.axis.name + ": at least two set points are needed");
  }
  setpoints_.finish();
  given_.finish();
  force_.finish();
  if (!started_) start();
  const double duration = static_cast<double>(setpoints_.count() - 1) * period_s_ + extra_time_s;
  const long ticks = static_cast<long>(std::floor(duration / base_ + 1e-9));
  if (next_tick_ > ticks) return;
  const auto records = static_cast<std::size_t>((ticks - next_tick_) / loop_->n_record) + 2;
  for (auto* v : {&out.t, &out.cmd, &out.pos, &out.load_pos, &out.motor_pos, &out.vel, &out.current}) {
    v->reserve(v->size() + records);
  }
  simulate_ticks(ticks, ticks, out);
}

template <int N>
void AxisRun<N>::simulate_ticks(long last_tick, long final_tick, AxisSignals& out) {
  LoopState& L = *loop_;
  const bool position_input = position_input_;
  const double inverse_r = L.inverse_r, inverse_kt = L.inverse_kt;
  const double kv = L.kv, position_period = L.position_period;
  const double kp_per_kt = L.kp_per_kt, ki_per_kt = L.ki_per_kt;
  const double velocity_filter = L.velocity_filter, difference_gain = L.difference_gain;
  const bool counted = L.counted;
  auto encoder_reading = [&](double angle) {
    return counted ? round_to_integer(angle * p_.inverse_motor_count) : angle;
  };
  const double imax = L.imax, wmax = L.wmax;
  const bool current_pi = L.current_pi, current_ideal = L.current_ideal;
  const double kpi = L.kpi, kii = L.kii, vmax = L.vmax;
  const double lag_alpha = L.lag_alpha, lag_b0 = L.lag_b0, lag_b1 = L.lag_b1;
  const double tff_gain = L.tff_gain, vff_gain = L.vff_gain;
  const bool feedforward = L.feedforward, interpolate_feedforward = L.interpolate_feedforward;
  const bool backward_feedforward = L.backward_feedforward;
  const double inverse_position_ticks = L.inverse_position_ticks;
  const long dead_ticks = L.dead_ticks;
  const long n_record = L.n_record;
  const double record_period = L.record_period;

  double velocity_integral_A = L.velocity_integral_A, current_integral = L.current_integral;
  double encoder_previous = L.encoder_previous, omega_filtered = L.omega_filtered;
  double lag_state = L.lag_state, lag_input_previous = L.lag_input_previous;
  DelayLine out_p = L.out_p, out_vff = L.out_vff, out_vff_step = L.out_vff_step, out_tff = L.out_tff,
            out_tff_step = L.out_tff_step;
  auto& pending = L.pending;
  long applied_tick = L.applied_tick;
  DelayLine velocity_out = L.velocity_out, current_out = L.current_out;
  double p_term = L.p_term, vff = L.vff, vff_step = L.vff_step, tff = L.tff, tff_step = L.tff_step;
  double omega_input = L.omega_input, current_command = L.current_command, voltage = L.voltage;
  double deviation = L.deviation, p_term_joint = L.p_term_joint, vff_joint = L.vff_joint,
         vff_step_joint = L.vff_step_joint;
  double tff_now = L.tff_now, tff_step_now = L.tff_step_now, current_set_now = L.current_set_now;
  Input u = L.u;
  long position_count = L.position_count, velocity_count = L.velocity_count,
       current_count = L.current_count, record_count = L.record_count;
  long record_index = L.record_index;
  double gravity_q = L.gravity_q, gravity_value = L.gravity_value, gravity_slope = L.gravity_slope;

  long k = next_tick_;
  for (; k <= last_tick; ++k) {
    const long position_phase = position_count;  // base ticks since the last position tick
    const bool position_tick = position_count == 0;
    const bool velocity_tick = velocity_count == 0;
    const bool current_tick = current_count == 0;
    const bool record_tick = record_count == 0;
    position_count = position_count + 1 == n_pos_ ? 0 : position_count + 1;
    velocity_count = velocity_count + 1 == n_vel_ ? 0 : velocity_count + 1;
    current_count = current_count + 1 == n_cur_ ? 0 : current_count + 1;
    record_count = record_count + 1 == n_record ? 0 : record_count + 1;
    const double t = start_time_s_ + static_cast<double>(k) * base_;
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
      const auto& o = pending.front();
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
      const double pos = measured_position();
      const double record_t = start_time_s_ + static_cast<double>(record_index++) * record_period;
      // The set point as given (a deflection compensation is inside the controller).
      const double cmd = compensate_ ? given_.at(record_t).x : setpoints_.at(t).x;
      out.t.push_back(record_t);
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
    if (k == final_tick) {
      ++k;  // the run is over
      break;
    }

    // Disturbances held over the tick: gravity, external force, cogging (on the motor).
    const double q_nut = p_.r * load_angle();
    double external = 0.0;
    if (has_force_) external = p_.r * force_.held(t);
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
  next_tick_ = k;

  L.velocity_integral_A = velocity_integral_A;
  L.current_integral = current_integral;
  L.encoder_previous = encoder_previous;
  L.omega_filtered = omega_filtered;
  L.lag_state = lag_state;
  L.lag_input_previous = lag_input_previous;
  L.out_p = out_p;
  L.out_vff = out_vff;
  L.out_vff_step = out_vff_step;
  L.out_tff = out_tff;
  L.out_tff_step = out_tff_step;
  L.applied_tick = applied_tick;
  L.velocity_out = velocity_out;
  L.current_out = current_out;
  L.p_term = p_term;
  L.vff = vff;
  L.vff_step = vff_step;
  L.tff = tff;
  L.tff_step = tff_step;
  L.omega_input = omega_input;
  L.current_command = current_command;
  L.voltage = voltage;
  L.deviation = deviation;
  L.p_term_joint = p_term_joint;
  L.vff_joint = vff_joint;
  L.vff_step_joint = vff_step_joint;
  L.tff_now = tff_now;
  L.tff_step_now = tff_step_now;
  L.current_set_now = current_set_now;
  L.u = u;
  L.position_count = position_count;
  L.velocity_count = velocity_count;
  L.current_count = current_count;
  L.record_count = record_count;
  L.record_index = record_index;
  L.gravity_q = gravity_q;
  L.gravity_value = gravity_value;
  L.gravity_slope = gravity_slope;
}

}  // namespace

struct AxisSimulator::Impl {
  AxisServoModel model;
  std::unique_ptr<AxisRun<3>> rigid;
  std::unique_ptr<AxisRun<5>> two_body;
  bool finished = false;
};

AxisSimulator::AxisSimulator(const AxisServoModel& model, double start_time_s, double period_s,
                             AxisInput::Kind kind, const SimulationOptions& options)
    : impl_(std::make_unique<Impl>()) {
  if (!(period_s > 0.0)) {
    throw InputError("axis " + model.axis.name + ": the set-point period must be > 0");
  }
  impl_->model = model;
  const AxisServoModel& m = impl_->model;
  const auto& compliance = m.axis.effects.compliance;
  const bool compensate = compliance.enabled && compliance.compensate_gravity_deflection &&
                          kind == AxisInput::Kind::position &&
                          m.axis.controller.position_feedback == PositionFeedback::motor;
  if (compliance.enabled || m.axis.effects.backlash.enabled) {
    impl_->two_body = std::make_unique<AxisRun<5>>(m, start_time_s, period_s, kind, options, compensate);
  } else {
    impl_->rigid = std::make_unique<AxisRun<3>>(m, start_time_s, period_s, kind, options, false);
  }
}

AxisSimulator::~AxisSimulator() = default;
AxisSimulator::AxisSimulator(AxisSimulator&&) noexcept = default;
AxisSimulator& AxisSimulator::operator=(AxisSimulator&&) noexcept = default;

void AxisSimulator::advance(std::span<const double> values, AxisSignals& out,
                            std::span<const double> external_force) {
  if (impl_->finished) throw InputError("axis " + impl_->model.axis.name + ": set points after the end");
  if (!external_force.empty() && external_force.size() != values.size()) {
    throw InputError("axis " + impl_->model.axis.name +
                     ": the external force needs one value per set point");
  }
  const double* force = external_force.empty() ? nullptr : external_force.data();
  if (impl_->rigid) {
    impl_->rigid->push(values.data(), force, values.size());
    impl_->rigid->advance(out);
  } else {
    impl_->two_body->push(values.data(), force, values.size());
    impl_->two_body->advance(out);
  }
}

void AxisSimulator::finish(AxisSignals& out, double extra_time_s) {
  if (impl_->finished) return;
  impl_->finished = true;
  if (impl_->rigid) {
    impl_->rigid->finish(extra_time_s, out);
  } else {
    impl_->two_body->finish(extra_time_s, out);
  }
}

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
  // The whole input in windows (the same records as in one, bit for bit; a window's set points
  // stay in the cache while its ticks read them).
  AxisSimulator simulator(model, input.start_time_s, input.period_s, input.kind, options);
  AxisSignals out;
  // The records, allocated once (growing them would hand memory back and forth with the system).
  const double record_period = options.record_period_s > 0.0 ? options.record_period_s : input.period_s;
  const double duration = static_cast<double>(input.values.size() - 1) * input.period_s + input.extra_time_s;
  const auto records = static_cast<std::size_t>(std::max(0.0, duration / record_period)) + 2;
  for (auto* v : {&out.t, &out.cmd, &out.pos, &out.load_pos, &out.motor_pos, &out.vel, &out.current}) v->reserve(records);
  if (options.inner_signals) {
    for (auto* v : {&out.following_error, &out.control_deviation, &out.velocity_setpoint, &out.velocity_feedforward,
                    &out.torque_feedforward, &out.current_setpoint}) {
      v->reserve(records);
    }
  }
  constexpr std::size_t kWindow = 512;
  const std::span<const double> values(input.values), force(input.external_force);
  for (std::size_t first = 0; first < values.size(); first += kWindow) {
    const std::size_t count = std::min(kWindow, values.size() - first);
    simulator.advance(values.subspan(first, count), out, force.empty() ? force : force.subspan(first, count));
  }
  simulator.finish(out, input.extra_time_s);
  return out;
}

}  // namespace vmsim::servo
