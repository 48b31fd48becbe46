#pragma once
// Physical effects of a feed drive beyond the rigid, linear model: each off by default, each
// with its parameters in the machine file (`axes[i].effects`, README "Machine description").
// The servo simulation uses them; the diagnosis looks for them in measured data.
namespace vmsim::kinematics {

struct DriveEffects {
  // Filled in by the servo work (issue 5).
};

}  // namespace vmsim::kinematics
