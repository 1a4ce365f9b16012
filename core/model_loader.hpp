#pragma once
// Loads config/robots/*.yaml into a RobotModel: units converted to SI, inertia derived from shapes
// where not given, every value checked. The file format is documented in docs/model-format.md.
// Any problem throws ConfigError "file:line:col: key.path: problem".

#include <string>

#include "core/robot_model.hpp"

namespace sirupp::core {

// The format tag a model file must declare (`format: sirupp-robot-1`).
inline constexpr const char* kRobotFormat = "sirupp-robot-1";

RobotModel LoadRobotModel(const std::string& file);
// Same, from text; `name` stands for the file in messages.
RobotModel ParseRobotModel(const std::string& text, const std::string& name);

}  // namespace sirupp::core
