#pragma once
// Joint values on the command line, one convention for every process and command
// (docs/command-line.md): --deg gives revolute joints in degrees and prismatic joints in metres,
// --rad gives revolute joints in radians and prismatic joints in metres, one value per joint in
// the model's order; --pose NAME names one of the model's poses. The values returned are SI (rad
// or m).

#include <optional>
#include <string>
#include <vector>

#include "core/robot_model.hpp"
#include "runtime/args.hpp"

namespace sirupp::runtime {

// --pose NAME, --deg Q.., --rad Q.. with the convention in their help text.
std::vector<Flag> JointFlags();
// One flag of joint values in the --deg convention (e.g. the viewer's --ghost-deg).
Flag DegreesFlag(const std::string& name, const std::string& what);

// Revolute values in degrees (prismatic in m) to SI.
std::vector<double> FromDegrees(std::vector<double> values, const core::RobotModel& model);

// A --deg-convention flag's values in SI, or nothing when the flag is absent; throws
// core::UsageError naming `command`, the flag and the count.
std::optional<std::vector<double>> DegreesArg(const Args& args, const std::string& flag,
                                              const core::RobotModel& model);

// Joint positions in SI from exactly one of --pose, --deg, --rad (nothing when none is given and
// `required` is false), each within the joint's limits; throws core::UsageError naming `command`,
// the joint and the allowed range.
std::optional<std::vector<double>> PositionsArg(const Args& args, const core::RobotModel& model,
                                                const std::string& command, bool required);

}  // namespace sirupp::runtime
