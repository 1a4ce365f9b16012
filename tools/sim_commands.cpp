#include "tools/sim_commands.hpp"

#include <chrono>
#include <ostream>
#include <sirupp/joint_target_t.hpp>
#include <sirupp/sim_reset_t.hpp>

#include "core/bus.hpp"
#include "core/channels.hpp"
#include "core/errors.hpp"
#include "core/model_loader.hpp"
#include "tools/args.hpp"
#include "tools/cli.hpp"

namespace sirupp::tools {
namespace {

core::RobotModel ModelFromArgs(const Args& parsed) {
  return core::LoadRobotModel(
      ResolveDataPath(parsed.Has("model") ? parsed.String("model") : "config/robots/puma260.yaml"));
}

// Joint positions (rad or m) from exactly one of --pose NAME, --deg Q.., --rad Q.., each within the
// joint's limits; throws core::UsageError naming `command`, the joint and the allowed range.
std::vector<double> PositionsFromArgs(const Args& parsed, const core::RobotModel& model,
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

core::Bus BusFromArgs(const Args& parsed) {
  return core::Bus(parsed.Has("lcm-url") ? parsed.String("lcm-url") : "",
                   parsed.Has("prefix") ? parsed.String("prefix") : "");
}

int64_t WallMicros() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

void PrintSent(std::ostream& out, const core::Bus& bus, const std::string& channel,
               const core::RobotModel& model, const std::vector<double>& position) {
  out << "sent " << bus.FullName(channel) << ": " << model.name << " to";
  for (double q : position) out << " " << core::FormatApprox(q);
  out << " (rad or m)";
}

}  // namespace

const char* const kResetUsage =
    "usage: sirupp reset [--model FILE] (--pose NAME | --deg Q1 .. QN | --rad Q1 .. QN)\n"
    "                    [--objects] [--lcm-url URL] [--prefix PREFIX]\n"
    "  Teleports the arm in a running sirupp-sim: every joint to the given position, at rest.\n"
    "  --pose: a named pose of the model (default model config/robots/puma260.yaml); --deg:\n"
    "  revolute joints in degrees, --rad: in radians, prismatic joints in metres either way.\n"
    "  --objects: also put the environment's free objects back where their file placed them.\n"
    "  The sim refuses positions outside the joint limits (see its heartbeat or stderr).\n";

const char* const kMoveUsage =
    "usage: sirupp move joints (--pose NAME | --deg Q1 .. QN | --rad Q1 .. QN) [--model FILE]\n"
    "                          [--lcm-url URL] [--prefix PREFIX]\n"
    "  Sends a joint target to sirupp-control (ARM_TARGET): every joint moves to the given\n"
    "  position with its default speed and acceleration from the model, one trapezoidal move\n"
    "  per joint. Positions outside the joint limits are refused here, and nothing is sent.\n";

int RunReset(const std::vector<std::string>& args, std::ostream& out) {
  const Args parsed(args, "reset",
                    {{"model", "robot model file"},
                     {"pose", "named pose"},
                     {"deg", "joint positions in degrees"},
                     {"rad", "joint positions in radians"},
                     {"objects", "reset the free objects too"},
                     {"lcm-url", "LCM URL"},
                     {"prefix", "channel prefix of the rig"}});
  const core::RobotModel model = ModelFromArgs(parsed);
  sirupp::sim_reset_t reset{};
  reset.utime = WallMicros();
  reset.sender = "sirupp reset";
  reset.num_joints = model.num_joints();
  reset.position = PositionsFromArgs(parsed, model, "reset");
  reset.reset_objects = parsed.Switch("objects") ? 1 : 0;
  core::Bus bus = BusFromArgs(parsed);
  bus.Publish(core::Channels{}.sim_reset, reset);
  PrintSent(out, bus, core::Channels{}.sim_reset, model, reset.position);
  out << (reset.reset_objects ? ", objects reset" : "") << "\n";
  return 0;
}

int RunMove(const std::vector<std::string>& args, std::ostream& out) {
  if (args.empty() || args[0] != "joints") {
    throw core::UsageError("move: expected 'joints' (pose targets arrive with the sequencer)");
  }
  const Args parsed(std::vector<std::string>(args.begin() + 1, args.end()), "move joints",
                    {{"model", "robot model file"},
                     {"pose", "named pose"},
                     {"deg", "joint positions in degrees"},
                     {"rad", "joint positions in radians"},
                     {"lcm-url", "LCM URL"},
                     {"prefix", "channel prefix of the rig"}});
  const core::RobotModel model = ModelFromArgs(parsed);
  sirupp::joint_target_t target{};
  target.utime = WallMicros();
  target.num_joints = model.num_joints();
  target.position = PositionsFromArgs(parsed, model, "move joints");
  target.max_velocity.assign(target.position.size(), 0.0);  // 0 = the model's defaults
  target.acceleration.assign(target.position.size(), 0.0);
  target.active.assign(target.position.size(), 1);
  core::Bus bus = BusFromArgs(parsed);
  bus.Publish(core::Channels{}.arm_target, target);
  PrintSent(out, bus, core::Channels{}.arm_target, model, target.position);
  out << "\n";
  return 0;
}

}  // namespace sirupp::tools
