#pragma once
// One robot: a process that loaded a model file checks it against the model the physics runs
// (ROBOT_MODEL, published by sirupp-sim). Same name, same file contents (FNV-1a hash) and same
// servo tick, or the process refuses to drive, naming both files.

#include <sirupp/robot_model_t.hpp>
#include <string>

#include "core/robot_model.hpp"

namespace sirupp::core {

// Empty when `sim` is the robot `ours` describes; otherwise one line naming both models and files,
// as `who` (e.g. "sirupp-control") sees it, and what to do about it.
std::string ModelMismatch(const RobotModel& ours, const sirupp::robot_model_t& sim,
                          const std::string& who);

}  // namespace sirupp::core
