#include "tools/rig_args.hpp"

#include <algorithm>
#include <chrono>
#include <ostream>

#include "core/errors.hpp"
#include "core/model_loader.hpp"
#include "runtime/data_path.hpp"
#include "tools/cli.hpp"

namespace sirupp::tools {

core::RobotModel ModelFromArgs(const runtime::Args& parsed) {
  return core::LoadRobotModel(runtime::ResolveDataPath(
      parsed.Has("model") ? parsed.String("model") : "config/robots/puma260.yaml"));
}

// Joint positions (rad or m) from exactly one of --pose NAME, --deg Q.., --rad Q.., each within the
// joint's limits; throws core::UsageError naming `command`, the joint and the allowed range.
std::vector<double> PositionsFromArgs(const runtime::Args& parsed, const core::RobotModel& model,
                                      const std::string& command) {
  const int given =
      (parsed.Has("pose") ? 1 : 0) + (parsed.Has("deg") ? 1 : 0) + (parsed.Has("rad") ? 1 : 0);
  if (given != 1) throw core::UsageError(command + ": give exactly one of --pose, --deg, --rad");
  std::vector<double> position;
  if (parsed.Has("pose")) {
    const core::NamedPose* pose = model.FindNamedPose(parsed.String("pose"));
    if (pose == nullptr) {
      std::string names;
      for (const auto& named : model.named_poses) names += (names.empty() ? "" : ", ") + named.name;
      throw core::UsageError(command + ": --pose '" + parsed.String("pose") + "': " + model.name +
                             " has " + names);
    }
    position = pose->position;
  } else {
    const bool degrees = parsed.Has("deg");
    position = parsed.Numbers(degrees ? "deg" : "rad", model.num_joints());
    for (int j = 0; j < model.num_joints(); ++j) {
      if (degrees && model.joints[static_cast<size_t>(j)].type == core::JointType::kRevolute) {
        position[static_cast<size_t>(j)] *= 3.14159265358979323846 / 180;
      }
    }
  }
  for (int j = 0; j < model.num_joints(); ++j) {
    const core::Joint& joint = model.joints[static_cast<size_t>(j)];
    const double q = position[static_cast<size_t>(j)];
    if (q < joint.position_min || q > joint.position_max) {
      throw core::UsageError(command + ": joint " + std::to_string(j + 1) + " (" + joint.name +
                             "): " + core::FormatApprox(q) + " is outside the limits [" +
                             core::FormatApprox(joint.position_min) + ", " +
                             core::FormatApprox(joint.position_max) + "] (rad or m)");
    }
  }
  return position;
}

core::Bus BusFromArgs(const runtime::Args& parsed) {
  return core::Bus(parsed.Has("lcm-url") ? parsed.String("lcm-url") : "",
                   parsed.Has("prefix") ? parsed.String("prefix") : "");
}

void PrintSent(std::ostream& out, const core::Bus& bus, const std::string& channel,
               const core::RobotModel& model, const std::vector<double>& position) {
  out << "sent " << bus.FullName(channel) << ": " << model.name << " to";
  for (double q : position) out << " " << core::FormatApprox(q);
  out << " (rad or m)";
}

namespace {
const std::map<std::string, std::string> kRigFlags = {{"lcm-url", "LCM URL"},
                                                      {"prefix", "channel prefix of the rig"}};

}  // namespace

std::map<std::string, std::string> WithRigFlags(std::map<std::string, std::string> flags) {
  flags.insert(kRigFlags.begin(), kRigFlags.end());
  return flags;
}

double TimeoutFrom(const runtime::Args& parsed, double fallback) {
  if (!parsed.Has("timeout")) return fallback;
  const double timeout = parsed.Numbers("timeout", 1)[0];
  if (!(timeout > 0)) {
    throw core::UsageError("--timeout " + core::FormatNumber(timeout) + ": allowed seconds > 0");
  }
  return timeout;
}

}  // namespace sirupp::tools
