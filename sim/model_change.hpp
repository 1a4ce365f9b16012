#pragma once
// Changes to a robot model that the grading suites (and `sirupp-sim --payload-kg ...`) apply to
// the simulated arm only: the controller keeps the model it loaded, as a real controller does not
// know the load it carries. A payload is a point mass at the tool point (the flange for the PUMA
// 260), merged into the last link's mass, centre of mass and inertia; friction scales every
// friction effort of every joint; gravity off sets the gravity vector to zero.

#include <string>

#include "core/robot_model.hpp"

namespace sirupp::sim {

class ArmWorld;

struct ModelChange {
  double payload_kg = 0;      // >= 0
  double friction_scale = 1;  // >= 0; 0 = no friction
  bool gravity_off = false;
  bool empty() const { return payload_kg == 0 && friction_scale == 1 && !gravity_off; }
  // "payload 0.5 kg at the tool point, friction x2, gravity off" (empty: "none").
  std::string Describe() const;
};

// Applies `change` to `model` (its name and source hash stay, so sirupp-control still accepts the
// sim's ROBOT_MODEL; the description says what changed). Throws std::invalid_argument for a
// negative or non-finite payload or scale.
void ApplyModelChange(core::RobotModel& model, const ModelChange& change);

// True when ApplyModelChange changed `model` (its description says so).
bool HasModelChange(const core::RobotModel& model);

// SIM_COMMAND LOAD_MODEL: the model in `text` (file `name`) replaces the running arm of `world` in
// place (ArmWorld::ReplaceModel). Throws core::ConfigError (name:line, the field) for a bad file,
// and std::invalid_argument for a model the running arm cannot take: another joint count or servo
// tick, a joint outside its new limits, an overlap, or a running arm changed by ApplyModelChange
// (the change would be lost). The world is unchanged then. Returns the model now running.
const core::RobotModel& LoadModelText(ArmWorld& world, const std::string& text,
                                      const std::string& name);

}  // namespace sirupp::sim
