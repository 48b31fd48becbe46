#include "vmsim/kinematics/dynamics.hpp"

#include <Eigen/Geometry>
#include <cmath>
#include <sstream>

#include "vmsim/common/errors.hpp"
#include "vmsim/kinematics/path_kinematics.hpp"

// Spatial algebra in the angular-first convention of Featherstone (RBDA, 2008), with the
// transform X from a parent's coordinates to a link's written as (E, r): E rotates parent
// coordinates into link coordinates and r is the link origin in parent coordinates, so
//   X (w, v)      = (E w, E (v - r x w))
//   X^T (n, f)    = (E^T n + r x E^T f, E^T f)
// The time derivative of X along the joint rate wq is  dX/dt = -(S wq) x X, and of X^T on a force
// d/dt (X^T f) = X^T (f_dot + (S wq) x* f). Those two identities are all the time-derivative
// recursion needs beyond the product rule.

namespace vmsim::kinematics {
namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;
using Eigen::VectorXd;
using RefV = Eigen::Ref<const VectorXd>;

double sign(double x) { return x > 0.0 ? 1.0 : (x < 0.0 ? -1.0 : 0.0); }

std::string model_message(const MachineModel& machine, const std::string& what) {
  std::ostringstream out;
  out << "machine '" << machine.name << "': " << what;
  if (machine.source_file.empty()) return out.str();
  return located_message(machine.source_file, 0, 0, out.str());
}

void lump_body(detail::DynLink& link, const RigidBody& body, const Eigen::Isometry3d& X_link_body) {
  if (body.mass_kg == 0.0 && body.inertia_kg_m2.isZero()) return;
  const Matrix3d R = X_link_body.linear();
  const Vector3d c = X_link_body * body.com_m;
  link.mass += body.mass_kg;
  link.first_moment += body.mass_kg * c;
  link.inertia_origin += R * body.inertia_kg_m2 * R.transpose() +
                         body.mass_kg * (c.squaredNorm() * Matrix3d::Identity() - c * c.transpose());
}

void update_transforms(const DynamicsModel& model, DynamicsData& data, const RefV& q) {
  for (std::size_t i = 0; i < model.links.size(); ++i) {
    const detail::DynLink& L = model.links[i];
    detail::DynLinkState& s = data.link_state[i];
    const double qi = q[L.axis];
    if (L.revolute) {
      const Matrix3d R = L.R_parent_joint * Eigen::AngleAxisd(qi, L.direction).toRotationMatrix();
      s.E = R.transpose();
      s.r = L.p_parent_joint;
    } else {
      s.E = L.R_parent_joint.transpose();
      s.r = L.p_parent_joint + L.R_parent_joint * (L.direction * qi);
    }
  }
}

/// The generalised recursion on transforms already set for q:
///   Q    = ID(q, v, a)     (the RNEA with velocity argument v and acceleration argument a)
///   Q_t  = d/dt ID(q(t), v(t), a(t)) with dq/dt = wq, dv/dt = vt, da/dt = at.
/// With wq = v = qd, vt = a = qdd, at = qddd this is tau and tau-dot; other arguments give mass
/// matrix columns, single-joint velocity products and the path coefficients. kVelocity = false
/// skips the velocity products (v = vt = 0); kRate = false skips the derivative.
template <bool kVelocity, bool kRate>
void recursion(const DynamicsModel& model, DynamicsData& data, const RefV& wq, const RefV& v,
               const RefV& vt, const RefV& a, const RefV& at, bool gravity, VectorXd& Q,
               VectorXd& Q_t) {
  const std::size_t n_links = model.links.size();
  const Vector3d a0 = gravity ? Vector3d(-model.gravity_B) : Vector3d::Zero();
  for (std::size_t i = 0; i < n_links; ++i) {
    const detail::DynLink& L = model.links[i];
    detail::DynLinkState& s = data.link_state[i];
    const Vector3d& d = L.direction;
    const int k = L.axis;
    // Parent quantities carried into link coordinates (X applied).
    Vector3d w_x, v_x, wd_x, vd_x, w_tx, v_tx, wd_tx, vd_tx;
    if (L.parent < 0) {
      w_x.setZero();
      v_x.setZero();
      wd_x.setZero();
      vd_x = s.E * a0;
      w_tx.setZero();
      v_tx.setZero();
      wd_tx.setZero();
      vd_tx.setZero();
    } else {
      const detail::DynLinkState& p = data.link_state[static_cast<std::size_t>(L.parent)];
      if constexpr (kVelocity) {
        w_x = s.E * p.w;
        v_x = s.E * (p.v - s.r.cross(p.w));
      }
      wd_x = s.E * p.wd;
      vd_x = s.E * (p.vd - s.r.cross(p.wd));
      if constexpr (kRate) {
        if constexpr (kVelocity) {
          w_tx = s.E * p.w_t;
          v_tx = s.E * (p.v_t - s.r.cross(p.w_t));
        }
        wd_tx = s.E * p.wd_t;
        vd_tx = s.E * (p.vd_t - s.r.cross(p.wd_t));
      }
    }
    if constexpr (!kVelocity) {
      w_x.setZero();
      v_x.setZero();
      w_tx.setZero();
      v_tx.setZero();
    }
    const double vj = kVelocity ? v[k] : 0.0;
    const double vtj = kVelocity ? vt[k] : 0.0;
    const double aj = a[k];
    const double wj = kRate ? wq[k] : 0.0;
    const double atj = kRate ? at[k] : 0.0;
    if (L.revolute) {
      // S = (d, 0)
      s.w = w_x + d * vj;
      s.v = v_x;
      s.wd = wd_x + d * aj;
      s.vd = vd_x;
      if constexpr (kVelocity) {
        s.wd += s.w.cross(d * vj);
        s.vd += s.v.cross(d * vj);
      }
      if constexpr (kRate) {
        const Vector3d Sw = d * wj;
        if constexpr (kVelocity) {
          s.w_t = w_tx - Sw.cross(w_x) + d * vtj;
          s.v_t = v_tx - Sw.cross(v_x);
        } else {
          s.w_t.setZero();
          s.v_t.setZero();
        }
        s.wd_t = wd_tx - Sw.cross(wd_x) + d * atj;
        s.vd_t = vd_tx - Sw.cross(vd_x);
        if constexpr (kVelocity) {
          s.wd_t += s.w_t.cross(d * vj) + s.w.cross(d * vtj);
          s.vd_t += s.v_t.cross(d * vj) + s.v.cross(d * vtj);
        }
      }
    } else {
      // S = (0, d)
      s.w = w_x;
      s.v = v_x + d * vj;
      s.wd = wd_x;
      s.vd = vd_x + d * aj;
      if constexpr (kVelocity) s.vd += s.w.cross(d * vj);
      if constexpr (kRate) {
        const Vector3d Sw = d * wj;
        if constexpr (kVelocity) {
          s.w_t = w_tx;
          s.v_t = v_tx - Sw.cross(w_x) + d * vtj;
        } else {
          s.w_t.setZero();
          s.v_t.setZero();
        }
        s.wd_t = wd_tx;
        s.vd_t = vd_tx - Sw.cross(wd_x) + d * atj;
        if constexpr (kVelocity) s.vd_t += s.w_t.cross(d * vj) + s.w.cross(d * vtj);
      }
    }
    // Forces: f = I a + v x* I v, and its derivative (I is constant in link coordinates).
    const Vector3d& h = L.first_moment;
    const Matrix3d& Io = L.inertia_origin;
    const double m = L.mass;
    s.n = Io * s.wd + h.cross(s.vd);
    s.f = m * s.vd - h.cross(s.wd);
    if constexpr (kVelocity) {
      const Vector3d In = Io * s.w + h.cross(s.v);
      const Vector3d If = m * s.v - h.cross(s.w);
      s.n += s.w.cross(In) + s.v.cross(If);
      s.f += s.w.cross(If);
      if constexpr (kRate) {
        const Vector3d In_t = Io * s.w_t + h.cross(s.v_t);
        const Vector3d If_t = m * s.v_t - h.cross(s.w_t);
        s.n_t = Io * s.wd_t + h.cross(s.vd_t) + s.w_t.cross(In) + s.v_t.cross(If) +
                s.w.cross(In_t) + s.v.cross(If_t);
        s.f_t = m * s.vd_t - h.cross(s.wd_t) + s.w_t.cross(If) + s.w.cross(If_t);
      }
    } else if constexpr (kRate) {
      s.n_t = Io * s.wd_t + h.cross(s.vd_t);
      s.f_t = m * s.vd_t - h.cross(s.wd_t);
    }
  }
  Q.setZero();
  if constexpr (kRate) Q_t.setZero();
  for (std::size_t i = n_links; i-- > 0;) {
    const detail::DynLink& L = model.links[i];
    detail::DynLinkState& s = data.link_state[i];
    const Vector3d& d = L.direction;
    const int k = L.axis;
    Q[k] = L.revolute ? d.dot(s.n) : d.dot(s.f);
    if constexpr (kRate) Q_t[k] = L.revolute ? d.dot(s.n_t) : d.dot(s.f_t);
    if (L.parent < 0) continue;
    detail::DynLinkState& p = data.link_state[static_cast<std::size_t>(L.parent)];
    const Vector3d fp = s.E.transpose() * s.f;
    p.f += fp;
    p.n += s.E.transpose() * s.n + s.r.cross(fp);
    if constexpr (kRate) {
      // X^T (f_t + (S wq) x* f)
      const Vector3d Sw = d * wq[k];
      Vector3d n_c = s.n_t;
      Vector3d f_c = s.f_t;
      if (L.revolute) {
        n_c += Sw.cross(s.n);
        f_c += Sw.cross(s.f);
      } else {
        n_c += Sw.cross(s.f);
      }
      const Vector3d fp_t = s.E.transpose() * f_c;
      p.f_t += fp_t;
      p.n_t += s.E.transpose() * n_c + s.r.cross(fp_t);
    }
  }
}

/// Joint-level (rigid-body) effects, columns inertia .. gravity, and their derivatives along
/// wq, for the generalised arguments of recursion(). Transforms must be set. Columns of effects
/// not in `effects` are left zero. The friction column is left zero here.
void rigid_split(const DynamicsModel& model, DynamicsData& data, const RefV& wq, const RefV& v,
                 const RefV& vt, const RefV& a, const RefV& at, EffectSet effects,
                 Eigen::Matrix<double, Eigen::Dynamic, kEffectCount>& value,
                 Eigen::Matrix<double, Eigen::Dynamic, kEffectCount>& rate) {
  const Eigen::Index n = model.axis_count();
  value.setZero();
  rate.setZero();
  const auto col = [](Effect e) { return static_cast<Eigen::Index>(e); };
  if (effects.contains(Effect::inertia) || effects.contains(Effect::inertia_coupling)) {
    // Columns of H and of dH/dt, one recursion each.
    for (Eigen::Index j = 0; j < n; ++j) {
      data.unit.setZero();
      data.unit[j] = 1.0;
      recursion<false, true>(model, data, wq, data.zero, data.zero, data.unit, data.zero, false,
                             data.tmp_Q, data.tmp_Qd);
      data.mass_matrix.col(j) = data.tmp_Q;
      data.mass_matrix_rate.col(j) = data.tmp_Qd;
    }
    const VectorXd Hd = data.mass_matrix.diagonal();
    const VectorXd Hd_t = data.mass_matrix_rate.diagonal();
    const VectorXd unc = Hd.cwiseProduct(a);
    const VectorXd unc_t = Hd_t.cwiseProduct(a) + Hd.cwiseProduct(at);
    if (effects.contains(Effect::inertia)) {
      value.col(col(Effect::inertia)) = unc;
      rate.col(col(Effect::inertia)) = unc_t;
    }
    if (effects.contains(Effect::inertia_coupling)) {
      value.col(col(Effect::inertia_coupling)) = data.mass_matrix * a - unc;
      rate.col(col(Effect::inertia_coupling)) =
          data.mass_matrix_rate * a + data.mass_matrix * at - unc_t;
    }
  }
  if (effects.contains(Effect::centrifugal) || effects.contains(Effect::coriolis)) {
    // Centrifugal: the velocity products of each joint alone, summed.
    VectorXd& cf = data.tmp_Q2;
    VectorXd& cf_t = data.tmp_Qd2;
    cf.setZero();
    cf_t.setZero();
    for (Eigen::Index j = 0; j < n; ++j) {
      if (v[j] == 0.0 && vt[j] == 0.0) continue;
      data.unit.setZero();
      data.unit[j] = v[j];
      data.unit2.setZero();
      data.unit2[j] = vt[j];
      recursion<true, true>(model, data, wq, data.unit, data.unit2, data.zero, data.zero, false,
                            data.tmp_Q, data.tmp_Qd);
      cf += data.tmp_Q;
      cf_t += data.tmp_Qd;
    }
    if (effects.contains(Effect::centrifugal)) {
      value.col(col(Effect::centrifugal)) = cf;
      rate.col(col(Effect::centrifugal)) = cf_t;
    }
    if (effects.contains(Effect::coriolis)) {
      recursion<true, true>(model, data, wq, v, vt, data.zero, data.zero, false, data.tmp_Q,
                            data.tmp_Qd);
      value.col(col(Effect::coriolis)) = data.tmp_Q - cf;
      rate.col(col(Effect::coriolis)) = data.tmp_Qd - cf_t;
    }
  }
  if (effects.contains(Effect::gravity)) {
    recursion<false, true>(model, data, wq, data.zero, data.zero, data.zero, data.zero, true,
                           data.tmp_Q, data.tmp_Qd);
    value.col(col(Effect::gravity)) = data.tmp_Q;
    rate.col(col(Effect::gravity)) = data.tmp_Qd;
  }
}

}  // namespace

std::string_view effect_name(Effect effect) {
  switch (effect) {
    case Effect::inertia: return "inertia";
    case Effect::inertia_coupling: return "inertia_coupling";
    case Effect::centrifugal: return "centrifugal";
    case Effect::coriolis: return "coriolis";
    case Effect::gravity: return "gravity";
    case Effect::friction: return "friction";
  }
  return "unknown";
}

DynamicsModel::DynamicsModel(const MachineModel& machine) {
  const int n = static_cast<int>(machine.axis_count());
  gravity_B = machine.gravity_B_m_per_s2;
  ratio.resize(n);
  rotor_inertia.resize(n);
  friction_viscous_N_m_s.resize(n);
  friction_dry_N_m.resize(n);
  for (int i = 0; i < n; ++i) {
    const Axis& axis = machine.axes[static_cast<std::size_t>(i)];
    const Drive& drive = axis.drive;
    if (!(drive.ratio != 0.0) || !std::isfinite(drive.ratio)) {
      throw InputError(model_message(machine, "axis '" + axis.name +
                                                  "': drive ratio must be finite and non-zero, got " +
                                                  std::to_string(drive.ratio)));
    }
    ratio[i] = drive.ratio;
    rotor_inertia[i] = drive.rotor_inertia_kg_m2;
    friction_viscous_N_m_s[i] =
        drive.torque_constant_N_m_per_A * drive.friction_viscous_A_per_joint_unit_per_s;
    friction_dry_N_m[i] = drive.torque_constant_N_m_per_A * drive.friction_dry_A;
    axis_names.push_back(axis.name);
  }
  std::vector<bool> used(static_cast<std::size_t>(n), false);
  for (const Chain* chain : {&machine.workpiece_chain, &machine.tool_chain}) {
    int parent = -1;
    Eigen::Isometry3d X_parent_here = Eigen::Isometry3d::Identity();
    for (const Joint& joint : *chain) {
      if (joint.body.mass_kg < 0.0) {
        throw InputError(model_message(machine, "joint '" + joint.name +
                                                    "': negative mass " +
                                                    std::to_string(joint.body.mass_kg)));
      }
      X_parent_here = X_parent_here * joint.origin;
      if (joint.type == JointType::fixed) {
        // Rigidly attached to the link before it (or to the base, where it does nothing).
        if (parent >= 0) lump_body(links[static_cast<std::size_t>(parent)], joint.body, X_parent_here);
        continue;
      }
      if (joint.axis_index < 0 || joint.axis_index >= n) {
        throw InputError(model_message(machine, "joint '" + joint.name + "': axis index " +
                                                    std::to_string(joint.axis_index) +
                                                    " out of range"));
      }
      if (used[static_cast<std::size_t>(joint.axis_index)]) {
        throw InputError(model_message(
            machine, "joint '" + joint.name + "': axis '" +
                         machine.axes[static_cast<std::size_t>(joint.axis_index)].name +
                         "' is moved by two joints"));
      }
      used[static_cast<std::size_t>(joint.axis_index)] = true;
      detail::DynLink link;
      link.axis = joint.axis_index;
      link.parent = parent;
      link.revolute = joint.type == JointType::revolute;
      link.direction = joint.direction.normalized();
      link.R_parent_joint = X_parent_here.linear();
      link.p_parent_joint = X_parent_here.translation();
      lump_body(link, joint.body, Eigen::Isometry3d::Identity());
      links.push_back(link);
      parent = static_cast<int>(links.size()) - 1;
      X_parent_here = Eigen::Isometry3d::Identity();
    }
  }
}

DynamicsData::DynamicsData(const DynamicsModel& model) {
  const Eigen::Index n = model.axis_count();
  Q = VectorXd::Zero(n);
  Q_dot = VectorXd::Zero(n);
  tau = VectorXd::Zero(n);
  tau_dot = VectorXd::Zero(n);
  mass_matrix = Eigen::MatrixXd::Zero(n, n);
  mass_matrix_rate = Eigen::MatrixXd::Zero(n, n);
  terms.torque_N_m.setZero(n, kEffectCount);
  terms.torque_rate_N_m_per_s.setZero(n, kEffectCount);
  terms.total_torque_N_m = VectorXd::Zero(n);
  terms.total_torque_rate_N_m_per_s = VectorXd::Zero(n);
  for (VectorXd* c : {&coefficients.a, &coefficients.b, &coefficients.c, &coefficients.d,
                      &coefficients.e, &coefficients.a_s, &coefficients.b_s, &coefficients.c_s,
                      &coefficients.d_s, &qd, &qdd, &qddd, &zero, &unit, &unit2, &tmp_Q,
                      &tmp_Qd, &tmp_Q2, &tmp_Qd2}) {
    *c = VectorXd::Zero(n);
  }
  split_value.setZero(n, kEffectCount);
  split_rate.setZero(n, kEffectCount);
  link_state.resize(model.links.size());
}

void rigid_body_dynamics(const DynamicsModel& model, DynamicsData& data, const RefV& q,
                         const RefV& qd, const RefV& qdd, const RefV& qddd, bool include_gravity) {
  update_transforms(model, data, q);
  recursion<true, true>(model, data, qd, qd, qdd, qdd, qddd, include_gravity, data.Q, data.Q_dot);
}

void mass_matrix(const DynamicsModel& model, DynamicsData& data, const RefV& q) {
  update_transforms(model, data, q);
  const Eigen::Index n = model.axis_count();
  for (Eigen::Index j = 0; j < n; ++j) {
    data.unit.setZero();
    data.unit[j] = 1.0;
    recursion<false, false>(model, data, data.zero, data.zero, data.zero, data.unit, data.zero,
                            false, data.tmp_Q, data.tmp_Qd);
    data.mass_matrix.col(j) = data.tmp_Q;
  }
}

void actuator_torque(const DynamicsModel& model, DynamicsData& data, const RefV& q,
                     const RefV& qd, const RefV& qdd, const RefV& qddd) {
  rigid_body_dynamics(model, data, q, qd, qdd, qddd, true);
  const Eigen::Index n = model.axis_count();
  for (Eigen::Index i = 0; i < n; ++i) {
    const double r = model.ratio[i];
    const double J_r = model.rotor_inertia[i] / r;
    data.tau[i] = r * data.Q[i] + J_r * qdd[i] + model.friction_viscous_N_m_s[i] * qd[i] +
                  model.friction_dry_N_m[i] * sign(qd[i]);
    data.tau_dot[i] =
        r * data.Q_dot[i] + J_r * qddd[i] + model.friction_viscous_N_m_s[i] * qdd[i];
  }
}

void actuator_torque_terms(const DynamicsModel& model, DynamicsData& data, const RefV& q,
                           const RefV& qd, const RefV& qdd, const RefV& qddd, EffectSet effects) {
  update_transforms(model, data, q);
  TorqueTerms& t = data.terms;
  rigid_split(model, data, qd, qd, qdd, qdd, qddd, effects, t.torque_N_m,
              t.torque_rate_N_m_per_s);
  const auto col = [](Effect e) { return static_cast<Eigen::Index>(e); };
  const Eigen::Index n = model.axis_count();
  for (Eigen::Index i = 0; i < n; ++i) {
    t.torque_N_m.row(i) *= model.ratio[i];
    t.torque_rate_N_m_per_s.row(i) *= model.ratio[i];
    if (effects.contains(Effect::inertia)) {
      const double J_r = model.rotor_inertia[i] / model.ratio[i];
      t.torque_N_m(i, col(Effect::inertia)) += J_r * qdd[i];
      t.torque_rate_N_m_per_s(i, col(Effect::inertia)) += J_r * qddd[i];
    }
    if (effects.contains(Effect::friction)) {
      t.torque_N_m(i, col(Effect::friction)) =
          model.friction_viscous_N_m_s[i] * qd[i] + model.friction_dry_N_m[i] * sign(qd[i]);
      t.torque_rate_N_m_per_s(i, col(Effect::friction)) = model.friction_viscous_N_m_s[i] * qdd[i];
    }
  }
  t.total_torque_N_m = t.torque_N_m.rowwise().sum();
  t.total_torque_rate_N_m_per_s = t.torque_rate_N_m_per_s.rowwise().sum();
}

void path_joint_motion(DynamicsData& data, const RefV& q_s, const RefV& q_ss, const RefV& q_sss,
                       const PathMotion& m) {
  data.qd = q_s * m.sd;
  data.qdd = q_ss * (m.sd * m.sd) + q_s * m.sdd;
  data.qddd = q_sss * (m.sd * m.sd * m.sd) + q_ss * (3.0 * m.sd * m.sdd) + q_s * m.sddd;
}

void actuator_torque_on_path(const DynamicsModel& model, DynamicsData& data, const RefV& q,
                             const RefV& q_s, const RefV& q_ss, const RefV& q_sss,
                             const PathMotion& motion, EffectSet effects) {
  path_joint_motion(data, q_s, q_ss, q_sss, motion);
  if (effects == EffectSet::all()) {
    actuator_torque(model, data, q, data.qd, data.qdd, data.qddd);
  } else {
    actuator_torque_terms(model, data, q, data.qd, data.qdd, data.qddd, effects);
    data.tau = data.terms.total_torque_N_m;
    data.tau_dot = data.terms.total_torque_rate_N_m_per_s;
  }
}

void path_torque_coefficients(const DynamicsModel& model, DynamicsData& data, const RefV& q,
                              const RefV& q_s, const RefV& q_ss, const RefV& q_sss,
                              EffectSet effects, bool with_s_derivatives) {
  // "Time" here is s: the configuration moves at dq/ds = q_s.
  update_transforms(model, data, q);
  PathTorqueCoefficients& k = data.coefficients;
  const VectorXd& z = data.zero;
  const Eigen::Index n = model.axis_count();
  if (effects == EffectSet::all() && !with_s_derivatives) {
    // The same three recursions without their derivative parts.
    recursion<false, false>(model, data, q_s, z, z, q_s, q_ss, false, k.a, data.tmp_Qd);
    recursion<true, false>(model, data, q_s, q_s, q_ss, q_ss, q_sss, false, k.b, data.tmp_Qd);
    recursion<false, false>(model, data, q_s, z, z, z, z, true, k.c, data.tmp_Qd);
    k.a_s.setZero(n);
    k.b_s.setZero(n);
    k.c_s.setZero(n);
  } else if (effects == EffectSet::all()) {
    // a = ID(q, 0, q_s) without gravity; b = ID(q, q_s, q_ss) without gravity; c = G(q).
    recursion<false, true>(model, data, q_s, z, z, q_s, q_ss, false, k.a, k.a_s);
    recursion<true, true>(model, data, q_s, q_s, q_ss, q_ss, q_sss, false, k.b, k.b_s);
    recursion<false, true>(model, data, q_s, z, z, z, z, true, k.c, k.c_s);
  } else {
    // a: the inertia effects with acceleration argument q_s; b: the inertia and velocity-product
    // effects with velocity q_s and acceleration q_ss.
    EffectSet sel;
    for (Effect e : {Effect::inertia, Effect::inertia_coupling})
      if (effects.contains(e)) sel = sel.with(e);
    rigid_split(model, data, q_s, z, z, q_s, q_ss, sel, data.split_value, data.split_rate);
    k.a = data.split_value.rowwise().sum();
    k.a_s = data.split_rate.rowwise().sum();
    for (Effect e : {Effect::centrifugal, Effect::coriolis})
      if (effects.contains(e)) sel = sel.with(e);
    rigid_split(model, data, q_s, q_s, q_ss, q_ss, q_sss, sel, data.split_value, data.split_rate);
    k.b = data.split_value.rowwise().sum();
    k.b_s = data.split_rate.rowwise().sum();
    if (effects.contains(Effect::gravity)) {
      recursion<false, true>(model, data, q_s, z, z, z, z, true, k.c, k.c_s);
    } else {
      k.c.setZero();
      k.c_s.setZero();
    }
  }
  const bool inertia = effects.contains(Effect::inertia);
  const bool friction = effects.contains(Effect::friction);
  for (Eigen::Index i = 0; i < n; ++i) {
    const double r = model.ratio[i];
    const double J_r = inertia ? model.rotor_inertia[i] / r : 0.0;
    k.a[i] = r * k.a[i] + J_r * q_s[i];
    k.a_s[i] = r * k.a_s[i] + J_r * q_ss[i];
    k.b[i] = r * k.b[i] + J_r * q_ss[i];
    k.b_s[i] = r * k.b_s[i] + J_r * q_sss[i];
    k.c[i] *= r;
    k.c_s[i] *= r;
    const double fv = friction ? model.friction_viscous_N_m_s[i] : 0.0;
    k.d[i] = fv * q_s[i];
    k.d_s[i] = fv * q_ss[i];
    k.e[i] = friction ? model.friction_dry_N_m[i] * sign(q_s[i]) : 0.0;
    if (!with_s_derivatives) k.a_s[i] = k.b_s[i] = k.c_s[i] = k.d_s[i] = 0.0;
  }
}

VectorXd PathTorqueCoefficients::torque(double sd, double sdd) const {
  return a * sdd + b * (sd * sd) + c + d * sd + e * sign(sd);
}

VectorXd PathTorqueCoefficients::torque_rate(double sd, double sdd, double sddd) const {
  return a * sddd + (a_s + 2.0 * b) * (sd * sdd) + b_s * (sd * sd * sd) + c_s * sd +
         d_s * (sd * sd) + d * sdd;
}

TorqueProfile torque_profile_at_constant_feed(const DynamicsModel& model,
                                              const Eigen::Ref<const Eigen::MatrixXd>& q,
                                              const Eigen::Ref<const Eigen::MatrixXd>& q_s,
                                              const Eigen::Ref<const Eigen::MatrixXd>& q_ss,
                                              const Eigen::Ref<const Eigen::MatrixXd>& q_sss,
                                              double feed_m_per_s, EffectSet effects) {
  const Eigen::Index n = model.axis_count();
  const Eigen::Index points = q.cols();
  for (const Eigen::Ref<const Eigen::MatrixXd>* m : {&q, &q_s, &q_ss, &q_sss}) {
    if (m->rows() != n || m->cols() != points) {
      std::ostringstream out;
      out << "torque profile: path derivatives of shape " << m->rows() << " x " << m->cols()
          << ", expected " << n << " axes x " << points << " points";
      throw InputError(out.str());
    }
  }
  TorqueProfile profile;
  profile.axis_names = model.axis_names;
  for (int e = 0; e < kEffectCount; ++e) {
    profile.torque_N_m[static_cast<std::size_t>(e)].setZero(n, points);
    profile.torque_rate_N_m_per_s[static_cast<std::size_t>(e)].setZero(n, points);
  }
  profile.total_torque_N_m.setZero(n, points);
  profile.total_torque_rate_N_m_per_s.setZero(n, points);
  DynamicsData data(model);
  const PathMotion motion{feed_m_per_s, 0.0, 0.0};
  for (Eigen::Index p = 0; p < points; ++p) {
    path_joint_motion(data, q_s.col(p), q_ss.col(p), q_sss.col(p), motion);
    actuator_torque_terms(model, data, q.col(p), data.qd, data.qdd, data.qddd, effects);
    for (int e = 0; e < kEffectCount; ++e) {
      profile.torque_N_m[static_cast<std::size_t>(e)].col(p) = data.terms.torque_N_m.col(e);
      profile.torque_rate_N_m_per_s[static_cast<std::size_t>(e)].col(p) =
          data.terms.torque_rate_N_m_per_s.col(e);
    }
    profile.total_torque_N_m.col(p) = data.terms.total_torque_N_m;
    profile.total_torque_rate_N_m_per_s.col(p) = data.terms.total_torque_rate_N_m_per_s;
  }
  return profile;
}

TorqueProfile torque_profile_at_constant_feed(const DynamicsModel& model,
                                              const PathKinematics& path, double feed_m_per_s,
                                              EffectSet effects) {
  return torque_profile_at_constant_feed(model, path.q, path.q_s, path.q_ss, path.q_sss,
                                         feed_m_per_s, effects);
}

ActuatorLimits equivalent_actuator_limits(const Axis& axis) {
  const double k = axis.drive.equivalent_inertia_kg_m2 / axis.drive.ratio;
  return {k * axis.limits.acceleration_max, k * axis.limits.jerk_max};
}

double scaled_torque_rate_limit(double torque_max_N_m, const ActuatorLimits& equivalent) {
  if (!(equivalent.torque_N_m > 0.0)) {
    throw InputError("Eq. 11: the equivalent torque limit must be positive, got " +
                     std::to_string(equivalent.torque_N_m));
  }
  return torque_max_N_m * equivalent.torque_rate_N_m_per_s / equivalent.torque_N_m;
}

}  // namespace vmsim::kinematics
