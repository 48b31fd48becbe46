#include "vmsim/kinematics/kinematics.hpp"

#include <Eigen/LU>
#include <Eigen/SVD>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>

namespace vmsim::kinematics {
namespace {

constexpr double kTwoPi = 2.0 * std::numbers::pi;

Eigen::Index idx(int i) { return static_cast<Eigen::Index>(i); }

void check_size(const MachineModel& model, const Eigen::VectorXd& q, const char* what) {
  if (q.size() != static_cast<Eigen::Index>(model.axis_count())) {
    throw std::invalid_argument(std::string(what) + ": joint vector has " +
                                std::to_string(q.size()) + " entries, model '" + model.name +
                                "' has " + std::to_string(model.axis_count()) + " axes");
  }
}

double joint_value(const MachineModel& model, const Joint& joint, const Eigen::VectorXd& q) {
  if (joint.type == JointType::fixed) return 0.0;
  if (joint.axis_index < 0 || joint.axis_index >= static_cast<int>(model.axis_count())) {
    throw std::invalid_argument("joint '" + joint.name + "' of model '" + model.name +
                                "' has no valid axis index");
  }
  return q[idx(joint.axis_index)];
}

/// A moving joint's axis line in B at the current configuration.
struct JointLineB {
  int axis = -1;
  JointType type = JointType::fixed;
  Eigen::Vector3d point_B = Eigen::Vector3d::Zero();
  Eigen::Vector3d direction_B = Eigen::Vector3d::UnitZ();
};

/// X_B_end(q) of a chain; optionally the lines of its moving joints.
Eigen::Isometry3d chain_end_B(const MachineModel& model, const Chain& chain,
                              const Eigen::VectorXd& q, std::vector<JointLineB>* lines) {
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  for (const Joint& joint : chain) {
    X = X * joint.origin;
    if (joint.type == JointType::fixed) continue;
    const double value = joint_value(model, joint, q);
    if (lines != nullptr) {
      lines->push_back({joint.axis_index, joint.type, X.translation(), X.linear() * joint.direction});
    }
    if (joint.type == JointType::prismatic) {
      X.translation() += X.linear() * (joint.direction * value);
    } else {
      X.linear() = X.linear() * Eigen::AngleAxisd(value, joint.direction).toRotationMatrix();
    }
  }
  return X;
}

/// Angle that rotates p about the unit axis w closest to q (Paden-Kahan subproblem 1).
double subproblem1(const Eigen::Vector3d& w, const Eigen::Vector3d& p, const Eigen::Vector3d& q) {
  const Eigen::Vector3d pp = p - w * w.dot(p);
  const Eigen::Vector3d qp = q - w * w.dot(q);
  return std::atan2(w.dot(pp.cross(qp)), pp.dot(qp));
}

Eigen::Matrix3d rotation(const Eigen::Vector3d& w, double angle) {
  return Eigen::AngleAxisd(angle, w).toRotationMatrix();
}

/// The multiple of 2 pi added to `angle` that brings it nearest to `previous`; for a limited
/// axis, nearest among the values within its travel (if any).
double unwrap(double angle, double previous, const Axis& axis) {
  const double k_nearest = std::round((previous - angle) / kTwoPi);
  const double nearest = angle + kTwoPi * k_nearest;
  if (axis.continuous) return nearest;
  const double k_min = std::ceil((axis.travel_min - 1e-12 - angle) / kTwoPi);
  const double k_max = std::floor((axis.travel_max + 1e-12 - angle) / kTwoPi);
  if (!(k_min <= k_max)) return nearest;  // no turn of the angle lies within the travel
  // The distance to `previous` is convex in k: the nearest turn within [k_min, k_max] is the
  // unconstrained nearest one clamped. Closed form: a loop over the turns would never end for
  // a travel of 1e300 deg.
  return angle + kTwoPi * std::clamp(k_nearest, k_min, k_max);
}

/// The orientation structure of a 3P + 2R model, in the product order of
/// a_W = R_WB(q) R_BS(q) z = Rot(w1, phi1) Rot(w2, phi2) v,  phi_k = sign_k * q[axis_k],
/// with w1, w2, v evaluated at zero rotary angles (constant rotations are conjugated through).
struct ClosedFormStructure {
  bool valid = false;
  std::array<int, 2> rotary_axis{-1, -1};
  std::array<double, 2> sign{1.0, 1.0};
  std::array<Eigen::Vector3d, 2> w{Eigen::Vector3d::UnitZ(), Eigen::Vector3d::UnitX()};
  Eigen::Vector3d v = Eigen::Vector3d::UnitZ();
  std::array<int, 3> linear_axis{-1, -1, -1};
};

ClosedFormStructure analyse_structure(const MachineModel& model) {
  ClosedFormStructure st;
  if (model.axis_count() != 5) return st;
  std::vector<int> seen(5, 0);
  int n_rotary = 0;
  int n_linear = 0;
  Eigen::Matrix3d M = Eigen::Matrix3d::Identity();
  auto visit_moving = [&](const Joint& joint, double sign) {
    if (joint.axis_index < 0 || joint.axis_index >= 5 || seen[joint.axis_index]++ > 0) {
      n_rotary = 99;  // an axis used twice or not at all: not the closed-form structure
      return;
    }
    if (joint.type == JointType::revolute) {
      if (n_rotary < 2) {
        st.rotary_axis[n_rotary] = joint.axis_index;
        st.sign[n_rotary] = sign;
        st.w[n_rotary] = (M * joint.direction).normalized();
      }
      ++n_rotary;
    } else {
      if (n_linear < 3) st.linear_axis[n_linear] = joint.axis_index;
      ++n_linear;
    }
  };
  // R_WB = R_BW^T: the workpiece chain backwards, every factor transposed.
  for (auto it = model.workpiece_chain.rbegin(); it != model.workpiece_chain.rend(); ++it) {
    if (it->type != JointType::fixed) visit_moving(*it, -1.0);
    M = M * it->origin.linear().transpose();
  }
  for (const Joint& joint : model.tool_chain) {
    M = M * joint.origin.linear();
    if (joint.type != JointType::fixed) visit_moving(joint, 1.0);
  }
  st.v = M.col(2);
  st.valid = n_rotary == 2 && n_linear == 3 && st.w[0].cross(st.w[1]).norm() > 1e-6;
  return st;
}

struct Candidate {
  Eigen::VectorXd q;
  bool singular = false;
};

double rotary_distance2(const MachineModel& model, const Eigen::VectorXd& a,
                        const Eigen::VectorXd& b) {
  double d2 = 0.0;
  for (std::size_t i = 0; i < model.axis_count(); ++i) {
    if (model.axes[i].type != AxisType::rotary) continue;
    const double d = a[static_cast<Eigen::Index>(i)] - b[static_cast<Eigen::Index>(i)];
    d2 += d * d;
  }
  return d2;
}

double axis_angle_error(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b));
}

/// Linear axes of a closed-form candidate whose rotary axes are set in q: the tip is affine in
/// them, tip = tip0 + J_lin q_lin. One refinement step removes the rounding of the first solve.
bool solve_linear_axes(const MachineModel& model, const ClosedFormStructure& st,
                       const Eigen::Vector3d& tip_W, double tool_length_m, Eigen::VectorXd& q) {
  for (int k : st.linear_axis) q[idx(k)] = 0.0;
  Eigen::Matrix3Xd Jp;
  Eigen::Matrix3Xd Jw;
  tool_jacobian_W(model, q, tool_length_m, Jp, Jw);
  Eigen::Matrix3d A;
  for (int c = 0; c < 3; ++c) A.col(c) = Jp.col(idx(st.linear_axis[static_cast<std::size_t>(c)]));
  const Eigen::FullPivLU<Eigen::Matrix3d> lu(A);
  if (!lu.isInvertible()) return false;
  for (int pass = 0; pass < 2; ++pass) {
    const Eigen::Vector3d residual = tip_W - forward_kinematics(model, q, tool_length_m).tip_W_m;
    const Eigen::Vector3d dx = lu.solve(residual);
    for (int c = 0; c < 3; ++c) q[idx(st.linear_axis[static_cast<std::size_t>(c)])] += dx[c];
  }
  return true;
}

std::vector<Candidate> closed_form_candidates(const MachineModel& model,
                                              const ClosedFormStructure& st, const ToolPose& pose,
                                              const Eigen::Vector3d& a,
                                              const Eigen::VectorXd& q_previous,
                                              double tool_length_m, const InverseOptions& options) {
  const Eigen::Vector3d& w1 = st.w[0];
  const Eigen::Vector3d& w2 = st.w[1];
  const Eigen::Vector3d& v = st.v;
  const std::array<double, 2> phi_previous{st.sign[0] * q_previous[idx(st.rotary_axis[0])],
                                           st.sign[1] * q_previous[idx(st.rotary_axis[1])]};
  const double sin_singular = std::sin(std::max(options.singular_angle_rad, 0.0));
  const bool free1 = a.cross(w1).norm() <= sin_singular;
  const bool free2 = v.cross(w2).norm() <= sin_singular;

  std::vector<std::array<double, 2>> phis;
  const bool singular = free1 || free2;
  if (free2) {
    // The rotation about w2 does not move v: that axis keeps its previous value.
    const double phi2 = phi_previous[1];
    const Eigen::Vector3d c = rotation(w2, phi2) * v;
    const double phi1 = free1 ? phi_previous[0] : subproblem1(w1, c, a);
    phis.push_back({phi1, phi2});
  } else if (free1) {
    // Tool axis along w1 (table-table: along C): phi1 keeps its previous value, phi2 best fit.
    const double phi1 = phi_previous[0];
    const Eigen::Vector3d c = rotation(w1, -phi1) * a;
    phis.push_back({phi1, subproblem1(w2, v, c)});
  } else {
    // Subproblem 2: c = Rot(w2, phi2) v = Rot(w1, -phi1) a, so w2.c = w2.v and w1.c = w1.a.
    const double k = w1.dot(w2);
    const double den = 1.0 - k * k;
    const double alpha = (w1.dot(a) - k * w2.dot(v)) / den;
    const double beta = (w2.dot(v) - k * w1.dot(a)) / den;
    const double gamma2 = (1.0 - alpha * alpha - beta * beta - 2.0 * alpha * beta * k) / den;
    if (gamma2 < -1e-12) return {};  // the tool axis is out of reach of the two rotary axes
    const double gamma = std::sqrt(std::max(gamma2, 0.0));
    const Eigen::Vector3d w12 = w1.cross(w2);
    for (double sgn : {1.0, -1.0}) {
      const Eigen::Vector3d c = alpha * w1 + beta * w2 + sgn * gamma * w12;
      phis.push_back({subproblem1(w1, c, a), subproblem1(w2, v, c)});
      if (gamma == 0.0) break;
    }
  }

  std::vector<Candidate> out;
  for (const auto& phi : phis) {
    Eigen::VectorXd q = q_previous;
    for (std::size_t r = 0; r < 2; ++r) {
      const int axis = st.rotary_axis[r];
      const bool kept = (r == 0 && free1) || (r == 1 && free2);
      q[idx(axis)] = kept ? q_previous[idx(axis)]
                          : unwrap(st.sign[r] * phi[r], q_previous[idx(axis)],
                                   model.axes[static_cast<std::size_t>(axis)]);
    }
    if (!solve_linear_axes(model, st, pose.tip_W_m, tool_length_m, q)) continue;
    const ToolPose check = forward_kinematics(model, q, tool_length_m);
    const double tip_error = (check.tip_W_m - pose.tip_W_m).norm();
    const double axis_error = axis_angle_error(check.axis_W, a);
    const double axis_allowed = singular ? options.singular_angle_rad + 1e-9 : 1e-9;
    if (!(tip_error <= 1e-9 + 1e-12 * pose.tip_W_m.norm()) || !(axis_error <= axis_allowed)) {
      continue;
    }
    bool duplicate = false;
    for (const Candidate& c : out) duplicate = duplicate || (c.q - q).norm() < 1e-12;
    if (!duplicate) out.push_back({q, singular});
  }
  return out;
}

struct TaskState {
  Eigen::Vector3d position_error = Eigen::Vector3d::Zero();
  double angle_error = 0.0;
  Eigen::Vector3d rotation_error = Eigen::Vector3d::Zero();  ///< rotation vector a -> a_target
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();
  double merit() const {
    return position_error.squaredNorm() + angle_error * angle_error;  // m^2 + (1 m * rad)^2
  }
};

TaskState task_state(const MachineModel& model, const Eigen::VectorXd& q, const ToolPose& target,
                     const Eigen::Vector3d& a_target, double tool_length_m) {
  const ToolPose now = forward_kinematics(model, q, tool_length_m);
  TaskState t;
  t.axis = now.axis_W;
  t.position_error = target.tip_W_m - now.tip_W_m;
  const Eigen::Vector3d cross = now.axis_W.cross(a_target);
  const double sn = cross.norm();
  const double cs = now.axis_W.dot(a_target);
  t.angle_error = std::atan2(sn, cs);
  if (sn > 1e-300) {
    t.rotation_error = cross / sn * t.angle_error;
  } else if (cs < 0.0) {
    t.rotation_error = now.axis_W.unitOrthogonal() * std::numbers::pi;
  }
  return t;
}

/// Damped least-squares step dq = J^T (J J^T + mu I)^-1 e, from the SVD of J. With mu -> 0 it
/// is the minimum-norm (pseudo-inverse) Newton step.
Eigen::VectorXd dls_step(const Eigen::JacobiSVD<Eigen::MatrixXd>& svd, const Eigen::VectorXd& e,
                         double mu) {
  const Eigen::VectorXd& sigma = svd.singularValues();
  const Eigen::VectorXd ue = svd.matrixU().transpose() * e;
  Eigen::VectorXd coeff(sigma.size());
  for (Eigen::Index i = 0; i < sigma.size(); ++i) {
    const double s = sigma[i];
    coeff[i] = (s * s + mu) > 0.0 ? s / (s * s + mu) * ue[i] : 0.0;
  }
  return svd.matrixV() * coeff;
}

/// How far each joint must move to be within its travel [joint unit] (0 for one within it or
/// on a continuous axis); aims a hair inside the bound.
Eigen::VectorXd travel_correction(const MachineModel& model, const Eigen::VectorXd& q) {
  constexpr double kMargin = 1e-9;
  Eigen::VectorXd c = Eigen::VectorXd::Zero(q.size());
  for (std::size_t i = 0; i < model.axis_count(); ++i) {
    const Axis& axis = model.axes[i];
    if (axis.type == AxisType::rotary && axis.continuous) continue;
    const auto k = static_cast<Eigen::Index>(i);
    if (q[k] > axis.travel_max) c[k] = axis.travel_max - kMargin - q[k];
    if (q[k] < axis.travel_min) c[k] = axis.travel_min + kMargin - q[k];
  }
  return c;
}

/// Iterative IKT on the 5-dof task from q_previous (see the header). Phase 1: minimum-norm
/// (damped) Newton steps to the task, limited in size, with backtracking. Phase 2, only when
/// the solution found lies beyond the travel: self-motion (null-space steps) towards the
/// travel while Newton steps keep the task, so that the redundancy is spent on the end stops
/// only when it has to be.
std::optional<Candidate> iterative_candidate(const MachineModel& model, const ToolPose& pose,
                                             const Eigen::Vector3d& a,
                                             const Eigen::VectorXd& q_previous,
                                             double tool_length_m, const InverseOptions& options) {
  const Eigen::Index n = q_previous.size();
  Eigen::VectorXd q = q_previous;
  Eigen::Matrix3Xd Jp;
  Eigen::Matrix3Xd Jw;
  Eigen::MatrixXd J(5, n);
  Eigen::VectorXd e(5);
  TaskState state = task_state(model, q, pose, a, tool_length_m);
  bool converged = false;
  bool limits_phase = false;
  double sigma_ratio = 1.0;
  // Damping mu of the DLS steps [(m per joint unit)^2], adapted as in Levenberg-Marquardt.
  constexpr double kMuMin = 1e-14;
  constexpr double kMuMax = 1e2;
  constexpr double kMaxJointStep = 0.5;  // [joint unit]
  double mu = 1e-6;
  auto unwrap_all = [&] {
    for (std::size_t i = 0; i < model.axis_count(); ++i) {
      if (model.axes[i].type != AxisType::rotary) continue;
      const auto k = static_cast<Eigen::Index>(i);
      q[k] = unwrap(q[k], q_previous[k], model.axes[i]);
    }
  };
  for (int iteration = 0; iteration <= options.max_iterations; ++iteration) {
    tool_jacobian_W(model, q, tool_length_m, Jp, Jw);
    const Eigen::Vector3d b1 = state.axis.unitOrthogonal();
    const Eigen::Vector3d b2 = state.axis.cross(b1);
    J.topRows(3) = Jp;
    J.row(3) = b1.transpose() * Jw;
    J.row(4) = b2.transpose() * Jw;
    e.head(3) = state.position_error;
    e[3] = b1.dot(state.rotation_error);
    e[4] = b2.dot(state.rotation_error);
    const Eigen::JacobiSVD<Eigen::MatrixXd> svd(J, Eigen::ComputeThinU | Eigen::ComputeThinV);
    const Eigen::VectorXd& sigma = svd.singularValues();
    const double sigma_max = sigma.size() > 0 ? sigma[0] : 0.0;
    const double sigma_min = sigma.size() >= 5 ? sigma[4] : 0.0;
    sigma_ratio = sigma_max > 0.0 ? sigma_min / sigma_max : 0.0;
    Eigen::VectorXd correction = Eigen::VectorXd::Zero(n);
    if (state.position_error.norm() <= options.position_tolerance_m &&
        state.angle_error <= options.axis_tolerance_rad) {
      unwrap_all();
      correction = travel_correction(model, q);
      if (correction.isZero(0.0)) {
        converged = true;
        break;
      }
      limits_phase = true;
    } else if (limits_phase) {
      correction = travel_correction(model, q);
    }
    if (iteration == options.max_iterations) break;
    Eigen::VectorXd dq;
    if (!limits_phase) {
      // Step limiting: aim at most max_step_m / max_step_rad closer to the target per step.
      double scale = 1.0;
      const double ep = state.position_error.norm();
      if (ep > options.max_step_m) scale = std::min(scale, options.max_step_m / ep);
      if (state.angle_error > options.max_step_rad) {
        scale = std::min(scale, options.max_step_rad / state.angle_error);
      }
      dq = dls_step(svd, scale * e, mu);
    } else {
      const Eigen::MatrixXd& V = svd.matrixV();
      const Eigen::MatrixXd null_projector =
          Eigen::MatrixXd::Identity(n, n) - V * V.transpose();
      Eigen::VectorXd self_motion = null_projector * correction;
      const double norm = self_motion.norm();
      if (norm > options.max_step_rad) self_motion *= options.max_step_rad / norm;
      dq = dls_step(svd, e, mu) + self_motion;
    }
    // Joint-space step limit: near a singularity the Newton step can be huge.
    const double dq_max = dq.cwiseAbs().maxCoeff();
    if (dq_max > kMaxJointStep) dq *= kMaxJointStep / dq_max;
    auto merit = [&](const TaskState& t, const Eigen::VectorXd& q_at) {
      return t.merit() + (limits_phase ? travel_correction(model, q_at).squaredNorm() : 0.0);
    };
    const double merit_now = merit(state, q);
    // Backtracking: accept the first step length that lowers the merit.
    bool accepted = false;
    bool full_step = false;
    double t = 1.0;
    for (int halving = 0; halving < 30 && !accepted; ++halving) {
      const Eigen::VectorXd q_try = q + t * dq;
      const TaskState trial = task_state(model, q_try, pose, a, tool_length_m);
      if (merit(trial, q_try) < merit_now) {
        q = q_try;
        state = trial;
        accepted = true;
        full_step = halving == 0;
      }
      t *= 0.5;
    }
    // Levenberg-Marquardt: less damping after a full step, more after a shortened one, so that
    // regular poses converge quadratically and near-singular ones still make progress.
    if (full_step) {
      mu = std::max(mu * 0.1, kMuMin);
    } else {
      mu = std::min(mu * 10.0, kMuMax);
    }
    if (!accepted && mu >= kMuMax) break;  // stuck: a local minimum of the error, out of reach
  }
  if (!converged) return std::nullopt;
  return Candidate{q, sigma_ratio < 1e-6};
}

/// Every solution found, rotary axes unwrapped next to q_previous, travel not yet checked;
/// sorted closest to q_previous first.
std::vector<Candidate> all_candidates(const MachineModel& model, const ToolPose& pose,
                                      const Eigen::VectorXd& q_previous, double tool_length_m,
                                      const InverseOptions& options) {
  check_size(model, q_previous, "inverse_kinematics");
  const double axis_norm = pose.axis_W.norm();
  if (!(axis_norm > 0.0) || !pose.tip_W_m.allFinite() || !std::isfinite(axis_norm)) return {};
  const Eigen::Vector3d a = pose.axis_W / axis_norm;
  std::vector<Candidate> out;
  const ClosedFormStructure st = analyse_structure(model);
  if (st.valid) {
    out = closed_form_candidates(model, st, pose, a, q_previous, tool_length_m, options);
  } else if (auto c = iterative_candidate(model, pose, a, q_previous, tool_length_m, options)) {
    out.push_back(*c);
  }
  std::stable_sort(out.begin(), out.end(), [&](const Candidate& x, const Candidate& y) {
    const double dx = rotary_distance2(model, x.q, q_previous);
    const double dy = rotary_distance2(model, y.q, q_previous);
    if (std::abs(dx - dy) > 1e-18) return dx < dy;
    return (x.q - q_previous).squaredNorm() < (y.q - q_previous).squaredNorm();
  });
  return out;
}

}  // namespace

Eigen::Isometry3d workpiece_frame_B(const MachineModel& model, const Eigen::VectorXd& q) {
  check_size(model, q, "workpiece_frame_B");
  return chain_end_B(model, model.workpiece_chain, q, nullptr);
}

Eigen::Isometry3d spindle_frame_B(const MachineModel& model, const Eigen::VectorXd& q) {
  check_size(model, q, "spindle_frame_B");
  return chain_end_B(model, model.tool_chain, q, nullptr);
}

ToolPose forward_kinematics(const MachineModel& model, const Eigen::VectorXd& q,
                            double tool_length_m) {
  const Eigen::Isometry3d X_BW = workpiece_frame_B(model, q);
  const Eigen::Isometry3d X_BS = spindle_frame_B(model, q);
  const Eigen::Isometry3d X_WS = X_BW.inverse(Eigen::Isometry) * X_BS;
  ToolPose pose;
  pose.tip_W_m = X_WS * Eigen::Vector3d(0.0, 0.0, -tool_length_m);
  pose.axis_W = X_WS.linear().col(2);
  return pose;
}

void tool_jacobian_W(const MachineModel& model, const Eigen::VectorXd& q, double tool_length_m,
                     Eigen::Matrix3Xd& tip_jacobian, Eigen::Matrix3Xd& rotation_jacobian) {
  check_size(model, q, "tool_jacobian_W");
  std::vector<JointLineB> workpiece_lines;
  std::vector<JointLineB> tool_lines;
  const Eigen::Isometry3d X_BW = chain_end_B(model, model.workpiece_chain, q, &workpiece_lines);
  const Eigen::Isometry3d X_BS = chain_end_B(model, model.tool_chain, q, &tool_lines);
  const Eigen::Vector3d p_BT_B = X_BS * Eigen::Vector3d(0.0, 0.0, -tool_length_m);
  const Eigen::Matrix3d R_WB = X_BW.linear().transpose();
  const Eigen::Index n = q.size();
  tip_jacobian.setZero(3, n);
  rotation_jacobian.setZero(3, n);
  // Tool-chain joints move T; workpiece-chain joints move W, i.e. T relative to W the other way.
  auto add = [&](const std::vector<JointLineB>& lines, double sign) {
    for (const JointLineB& line : lines) {
      const Eigen::Index k = idx(line.axis);
      if (line.type == JointType::prismatic) {
        tip_jacobian.col(k) += sign * (R_WB * line.direction_B);
      } else {
        tip_jacobian.col(k) += sign * (R_WB * line.direction_B.cross(p_BT_B - line.point_B));
        rotation_jacobian.col(k) += sign * (R_WB * line.direction_B);
      }
    }
  };
  add(tool_lines, 1.0);
  add(workpiece_lines, -1.0);
}

std::vector<InverseResult> inverse_kinematics_all(const MachineModel& model, const ToolPose& pose,
                                                  const Eigen::VectorXd& q_previous,
                                                  double tool_length_m,
                                                  const InverseOptions& options) {
  std::vector<InverseResult> out;
  for (Candidate& c : all_candidates(model, pose, q_previous, tool_length_m, options)) {
    if (within_travel(model, c.q)) out.push_back({std::move(c.q), c.singular});
  }
  return out;
}

std::optional<InverseResult> inverse_kinematics(const MachineModel& model, const ToolPose& pose,
                                                const Eigen::VectorXd& q_previous,
                                                double tool_length_m,
                                                const InverseOptions& options) {
  std::vector<InverseResult> all =
      inverse_kinematics_all(model, pose, q_previous, tool_length_m, options);
  if (all.empty()) return std::nullopt;
  return std::move(all.front());
}

std::optional<InverseResult> inverse_kinematics_given_rotary(
    const MachineModel& model, const ToolPose& pose, const Eigen::VectorXd& q_given,
    const Eigen::VectorXd& q_previous, double tool_length_m, double axis_tolerance_rad,
    std::string* why) {
  check_size(model, q_given, "inverse_kinematics_given_rotary");
  check_size(model, q_previous, "inverse_kinematics_given_rotary");
  const auto fail = [why](const std::string& reason) -> std::optional<InverseResult> {
    if (why != nullptr) *why = reason;
    return std::nullopt;
  };
  const ClosedFormStructure st = analyse_structure(model);
  if (!st.valid) {
    return fail("rotary axis words need a machine of three linear and two rotary axes");
  }
  Eigen::VectorXd q = q_previous;
  for (int axis : st.rotary_axis) {
    if (!std::isnan(q_given[idx(axis)])) q[idx(axis)] = q_given[idx(axis)];
  }
  const double axis_norm = pose.axis_W.norm();
  if (!(axis_norm > 0.0) || !pose.tip_W_m.allFinite()) return fail("no tool pose");
  const Eigen::Vector3d axis_W = forward_kinematics(model, q, tool_length_m).axis_W;
  const double angle = axis_angle_error(axis_W, pose.axis_W / axis_norm);
  if (!(angle <= axis_tolerance_rad)) {
    return fail("the rotary axes give a tool axis " + std::to_string(angle * 180.0 / std::numbers::pi) +
                " deg away from the programmed one");
  }
  if (!solve_linear_axes(model, st, pose.tip_W_m, tool_length_m, q)) {
    return fail("the linear axes cannot reach the tip");
  }
  if (!within_travel(model, q)) {
    for (std::size_t i = 0; i < model.axis_count(); ++i) {
      const Axis& axis = model.axes[i];
      const double value = q[static_cast<Eigen::Index>(i)];
      if ((axis.type == AxisType::rotary && axis.continuous) ||
          (value >= axis.travel_min - 1e-12 && value <= axis.travel_max + 1e-12)) {
        continue;
      }
      const bool rotary = axis.type == AxisType::rotary;
      const double f = rotary ? 180.0 / std::numbers::pi : 1000.0;
      const char* unit = rotary ? " deg" : " mm";
      return fail("axis " + axis.name + " would be at " + std::to_string(value * f) + unit +
                  ", outside its travel [" + std::to_string(axis.travel_min * f) + ", " +
                  std::to_string(axis.travel_max * f) + "]" + unit);
    }
  }
  const double sin_singular = std::sin(1e-3);
  return InverseResult{q, axis_W.cross(st.w[0]).norm() <= sin_singular ||
                              st.v.cross(st.w[1]).norm() <= sin_singular};
}

std::string explain_unreachable(const MachineModel& model, const ToolPose& pose,
                                const Eigen::VectorXd& q_previous, double tool_length_m,
                                const InverseOptions& options) {
  const std::vector<Candidate> candidates =
      all_candidates(model, pose, q_previous, tool_length_m, options);
  if (candidates.empty()) {
    return analyse_structure(model).valid
               ? "the tool pose is out of reach of the machine's axes"
               : "the iterative inverse kinematics did not converge from the previous "
                 "configuration (pose out of reach)";
  }
  for (const Candidate& c : candidates) {
    for (std::size_t i = 0; i < model.axis_count(); ++i) {
      const Axis& axis = model.axes[i];
      if (axis.type == AxisType::rotary && axis.continuous) continue;
      const double value = c.q[static_cast<Eigen::Index>(i)];
      if (value < axis.travel_min - 1e-12 || value > axis.travel_max + 1e-12) {
        const bool rotary = axis.type == AxisType::rotary;
        const double f = rotary ? 180.0 / std::numbers::pi : 1000.0;
        const char* unit = rotary ? " deg" : " mm";
        return "axis " + axis.name + " would be at " + std::to_string(value * f) + unit +
               ", outside its travel [" + std::to_string(axis.travel_min * f) + ", " +
               std::to_string(axis.travel_max * f) + "]" + unit;
      }
    }
  }
  return "the tool pose is out of reach";
}

bool within_travel(const MachineModel& model, const Eigen::VectorXd& q, double tolerance) {
  if (q.size() != static_cast<Eigen::Index>(model.axis_count())) return false;
  for (std::size_t i = 0; i < model.axis_count(); ++i) {
    const Axis& axis = model.axes[i];
    if (axis.type == AxisType::rotary && axis.continuous) continue;
    const double value = q[static_cast<Eigen::Index>(i)];
    if (!(value >= axis.travel_min - tolerance && value <= axis.travel_max + tolerance)) {
      return false;
    }
  }
  return true;
}

}  // namespace vmsim::kinematics
