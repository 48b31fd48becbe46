// The `effects` section of an axis in the machine file (servo/README.md documents every field).
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "machine_loader_internal.hpp"

namespace vmsim::kinematics {
namespace {

constexpr double kPi = std::numbers::pi;
using UnitTable = FieldReader::UnitTable;

const UnitTable kSmallLength = {{"um", 1e-6}, {"mm", 1e-3}, {"m", 1.0}};
const UnitTable kSmallAngle = {{"arcsec", kPi / 648000.0}, {"deg", kPi / 180.0}, {"rad", 1.0}};
const UnitTable kPeriodLength = {{"mm", 1e-3}, {"m", 1.0}};
const UnitTable kPeriodAngle = {{"deg", kPi / 180.0}, {"rad", 1.0}};
const UnitTable kLinearVelocity = {{"mm_per_s", 1e-3}, {"m_per_min", 1.0 / 60.0}, {"m_per_s", 1.0}};
const UnitTable kRotaryVelocity = {
    {"deg_per_s", kPi / 180.0}, {"rev_per_min", 2.0 * kPi / 60.0}, {"rad_per_s", 1.0}};
const UnitTable kLinearStiffness = {{"N_per_um", 1e6}, {"N_per_m", 1.0}};
const UnitTable kRotaryStiffness = {{"N_m_per_arcmin", 180.0 * 60.0 / kPi},
                                    {"N_m_per_rad", 1.0}};
const UnitTable kLinearDamping = {{"N_s_per_m", 1.0}, {"N_s_per_um", 1e6}};
const UnitTable kRotaryDamping = {{"N_m_s_per_rad", 1.0}};
const UnitTable kPhase = {{"deg", kPi / 180.0}, {"rad", 1.0}};

bool linear(const Axis& axis) { return axis.type == AxisType::linear; }

StribeckFriction read_stribeck(const FieldReader& reader, const Axis& axis) {
  StribeckFriction result;
  result.enabled = true;
  result.static_friction_A = reader.number("static_friction_A");
  result.velocity = reader.quantity("velocity", linear(axis) ? kLinearVelocity : kRotaryVelocity);
  result.exponent = reader.number_or("exponent", 2.0);
  reader.require_non_negative("static_friction_A", result.static_friction_A);
  reader.require_positive("velocity", result.velocity);
  reader.require_positive("exponent", result.exponent);
  reader.reject_unknown_fields();
  return result;
}

AsymmetricFriction read_asymmetric(const FieldReader& reader, const Axis& axis) {
  AsymmetricFriction result;
  result.enabled = true;
  const std::string viscous_unit = linear(axis) ? "_A_s_per_m" : "_A_s_per_rad";
  result.dry_positive_A = reader.number_or("dry_positive_A", axis.drive.friction_dry_A);
  result.dry_negative_A = reader.number_or("dry_negative_A", axis.drive.friction_dry_A);
  result.viscous_positive_A_per_joint_unit_per_s = reader.number_or(
      "viscous_positive" + viscous_unit, axis.drive.friction_viscous_A_per_joint_unit_per_s);
  result.viscous_negative_A_per_joint_unit_per_s = reader.number_or(
      "viscous_negative" + viscous_unit, axis.drive.friction_viscous_A_per_joint_unit_per_s);
  reader.require_non_negative("dry_positive_A", result.dry_positive_A);
  reader.require_non_negative("dry_negative_A", result.dry_negative_A);
  reader.require_non_negative("viscous_positive" + viscous_unit,
                              result.viscous_positive_A_per_joint_unit_per_s);
  reader.require_non_negative("viscous_negative" + viscous_unit,
                              result.viscous_negative_A_per_joint_unit_per_s);
  reader.reject_unknown_fields();
  return result;
}

Backlash read_backlash(const FieldReader& reader, const Axis& axis) {
  Backlash result;
  result.enabled = true;
  result.gap = reader.quantity("gap", linear(axis) ? kSmallLength : kSmallAngle);
  reader.require_positive("gap", result.gap);
  reader.reject_unknown_fields();
  return result;
}

Cogging read_cogging(const FieldReader& reader) {
  Cogging result;
  result.enabled = true;
  result.amplitude_N_m = reader.number("amplitude_N_m");
  result.periods_per_rev = reader.number("periods_per_rev");
  result.phase_rad = reader.quantity_or("phase", kPhase, 0.0);
  reader.require_non_negative("amplitude_N_m", result.amplitude_N_m);
  reader.require_positive("periods_per_rev", result.periods_per_rev);
  reader.reject_unknown_fields();
  return result;
}

PitchError read_pitch_error(const FieldReader& reader, const Axis& axis) {
  PitchError result;
  result.enabled = true;
  result.amplitude = reader.quantity("amplitude", linear(axis) ? kSmallLength : kSmallAngle);
  // Default period: the travel of one motor revolution (the screw lead of a direct drive).
  result.period = reader.quantity_or("period", linear(axis) ? kPeriodLength : kPeriodAngle,
                                     2.0 * kPi * axis.drive.ratio);
  result.phase_rad = reader.quantity_or("phase", kPhase, 0.0);
  reader.require_non_negative("amplitude", result.amplitude);
  reader.require_positive("period", result.period);
  reader.reject_unknown_fields();
  return result;
}

Compliance read_compliance(const FieldReader& reader, const Axis& axis, MachineKind kind) {
  Compliance result;
  result.enabled = true;
  // A robot joint's friction is mostly before its gear's output (motor bearings, the reducer's
  // fast stages): motor side by default; a machine tool's at the guideways: load side.
  result.friction_side = kind == MachineKind::robot ? FrictionSide::motor : FrictionSide::load;
  if (reader.has("friction_side")) {
    const std::string side = reader.child("friction_side").as_string();
    if (side == "motor") {
      result.friction_side = FrictionSide::motor;
    } else if (side == "load") {
      result.friction_side = FrictionSide::load;
    } else {
      reader.child("friction_side").fail("'" + side + "' is not one of: motor, load");
    }
  }
  result.stiffness = reader.quantity("stiffness", linear(axis) ? kLinearStiffness : kRotaryStiffness);
  result.motor_side_inertia_kg_m2 =
      reader.number_or("motor_side_inertia_kg_m2", axis.drive.rotor_inertia_kg_m2);
  reader.require_positive("stiffness", result.stiffness);
  // Damping as a ratio of the mode's critical damping, or as the damper d at the joint [N m s/rad
  // or N s/m]: d = 2 zeta sqrt(k J_red) with the two-mass reduced inertia at the joint,
  // J_red = J_m J_L / (J_m + J_L) / r^2 (J_m, J_L at the motor).
  const double damping = reader.quantity_or("damping", linear(axis) ? kLinearDamping : kRotaryDamping,
                                            std::numeric_limits<double>::quiet_NaN());
  const bool damper_given = !std::isnan(damping);
  if (damper_given) reader.require_non_negative("damping", damping);
  if (damper_given && reader.has("damping_ratio")) {
    reader.fail("give the damping once: damping_ratio or damping_<unit>");
  }
  result.damping_ratio = reader.number_or("damping_ratio", 0.0);
  reader.require_non_negative("damping_ratio", result.damping_ratio);
  result.compensate_gravity_deflection = reader.boolean_or("compensate_gravity_deflection", false);
  if (damper_given) {
    const double j_eq = axis.drive.equivalent_inertia_kg_m2;
    const double jm = result.motor_side_inertia_kg_m2;
    const double r = axis.drive.ratio;
    if (jm > 0.0 && jm < j_eq && r > 0.0) {
      const double j_reduced_joint = jm * (j_eq - jm) / j_eq / (r * r);
      result.damping_ratio = damping / (2.0 * std::sqrt(result.stiffness * j_reduced_joint));
    }
  }
  if (result.damping_ratio >= 1.0) {
    reader.fail("field 'damping_ratio' must be < 1, got " + format_number(result.damping_ratio));
  }
  const double j_eq = axis.drive.equivalent_inertia_kg_m2;
  if (!(result.motor_side_inertia_kg_m2 > 0.0 && result.motor_side_inertia_kg_m2 < j_eq)) {
    reader.fail("the motor-side inertia (motor_side_inertia_kg_m2, default "
                "drive.rotor_inertia_kg_m2) must lie in (0, equivalent_inertia_kg_m2 = " +
                format_number(j_eq) + "), got " + format_number(result.motor_side_inertia_kg_m2));
  }
  reader.reject_unknown_fields();
  return result;
}

}  // namespace

DriveEffects read_drive_effects(const FieldReader& effects, const Axis& axis, MachineKind kind) {
  DriveEffects result;
  if (effects.has("stribeck")) result.stribeck = read_stribeck(effects.child("stribeck"), axis);
  if (effects.has("smooth_friction")) {
    const FieldReader smooth = effects.child("smooth_friction");
    result.smooth_friction.enabled = true;
    result.smooth_friction.speed =
        smooth.quantity("speed", linear(axis) ? kLinearVelocity : kRotaryVelocity);
    smooth.require_positive("speed", result.smooth_friction.speed);
    smooth.reject_unknown_fields();
  }
  if (effects.has("asymmetric_friction")) {
    result.asymmetric_friction = read_asymmetric(effects.child("asymmetric_friction"), axis);
  }
  if (effects.has("backlash")) result.backlash = read_backlash(effects.child("backlash"), axis);
  if (effects.has("cogging")) result.cogging = read_cogging(effects.child("cogging"));
  if (effects.has("pitch_error")) {
    result.pitch_error = read_pitch_error(effects.child("pitch_error"), axis);
  }
  if (effects.has("compliance")) {
    result.compliance = read_compliance(effects.child("compliance"), axis, kind);
  }
  result.gravity_compensated = effects.boolean_or("gravity_compensated", false);
  effects.reject_unknown_fields();
  if (result.stribeck.enabled) {
    const double dry = result.asymmetric_friction.enabled
                           ? std::max(result.asymmetric_friction.dry_positive_A,
                                      result.asymmetric_friction.dry_negative_A)
                           : axis.drive.friction_dry_A;
    if (result.stribeck.static_friction_A < dry) {
      effects.child("stribeck").fail(
          "static_friction_A (" + format_number(result.stribeck.static_friction_A) +
          ") is below the dry friction (" + format_number(dry) + " A)");
    }
  }
  return result;
}

}  // namespace vmsim::kinematics
