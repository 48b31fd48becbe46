// The `effects` section of an axis in the machine file.
#include "machine_loader_internal.hpp"

namespace vmsim::kinematics {

DriveEffects read_drive_effects(const FieldReader& effects, const Axis& axis) {
  (void)axis;
  DriveEffects result;
  effects.reject_unknown_fields();
  return result;
}

}  // namespace vmsim::kinematics
