// sirupp-sim: the arm in ODE as an LCM process. Thin main: arguments in, SimNode loop, summary out.
// Usage and options: sim/README.md, or `sirupp-sim --help`.

#include <functional>
#include <iostream>
#include <optional>
#include <sstream>

#include "core/bus.hpp"
#include "core/environment.hpp"
#include "core/errors.hpp"
#include "core/model_loader.hpp"
#include "runtime/args.hpp"
#include "runtime/data_path.hpp"
#include "runtime/process_main.hpp"
#include "sim/arm_world.hpp"
#include "sim/model_change.hpp"
#include "sim/sim_node.hpp"

namespace {

constexpr const char* kUsage =
    "usage: sirupp-sim [--model FILE] [--environment FILE] [--mode "
    "lockstep|realtime|fast|freerun]\n"
    "                  [--participants NAME...] [--step SECONDS] [--state-every N]\n"
    "                  [--lockstep-timeout SECONDS] [--watchdog SECONDS] [--duration SECONDS]\n"
    "                  [--idle hold|limp] [--pose NAME | --position VALUES...] [--no-friction]\n"
    "                  [--payload-kg KG] [--friction-scale S] [--gravity-off] [--lcm-url URL] "
    "[--prefix PREFIX] [--rt-priority N]\n"
    "The ODE physics of a robot model: takes SIM_ARM_COMMAND, publishes SIM_ARM_STATE every tick,\n"
    "ROBOT_MODEL and ENVIRONMENT at 1 Hz and HEARTBEAT. Positions for --position are in the model\n"
    "file's angle unit. Defaults: config/robots/puma260.yaml, lockstep with participant\n"
    "sirupp-control, the model's servo tick (0.512 ms for the PUMA 260). See sim/README.md.\n"
    "realtime = lockstep paced by the wall clock (every participant answers every tick; the sim\n"
    "time slips rather than the physics when the PC cannot keep up); freerun = paced, the newest\n"
    "command of any sender held (opt-in; stale efforts under load). docs/timing.md.\n"
    "--rt-priority N: run under SCHED_FIFO at priority N (1..99; needs root or CAP_SYS_NICE), so\n"
    "realtime ticks start on time on a busy machine (docs/timing.md).\n"
    "--payload-kg, --friction-scale, --gravity-off change the simulated arm only (a point mass at\n"
    "the tool point, every friction effort scaled, no gravity); controllers keep their model.\n";

int Run(const std::vector<std::string>& argv) {
  using sirupp::runtime::Args;
  const Args args(argv, "sirupp-sim",
                  {{"model", "robot model file"},
                   {"environment", "environment XML file"},
                   {"mode", "lockstep, realtime, fast or freerun"},
                   {"participants", "participant names (lockstep and realtime)"},
                   {"step", "physics step in seconds"},
                   {"state-every", "publish the state every N ticks"},
                   {"lockstep-timeout", "seconds before a silent participant is reported"},
                   {"watchdog",
                    "realtime: seconds a participant may be silent before the arm brakes (0.5); "
                    "freerun: age of a held command (0.05)"},
                   {"duration", "simulated seconds to run (0 = until stopped)"},
                   {"idle", "hold or limp before the first command"},
                   {"pose", "named pose to start in"},
                   {"position", "start positions, in the model file's angle unit"},
                   {"no-friction", "switch joint friction off"},
                   {"payload-kg", "point mass at the tool point, kg"},
                   {"friction-scale", "scale every friction effort"},
                   {"gravity-off", "no gravity"},
                   {"lcm-url", "LCM URL"},
                   {"prefix", "channel prefix of the rig"},
                   {"rt-priority", "SCHED_FIFO priority 1..99 (0: off)"}});
  const int rt_priority = sirupp::runtime::RtPriorityArg(args, "sirupp-sim");
  const std::string model_file = sirupp::runtime::ResolveDataPath(
      args.Has("model") ? args.String("model") : "config/robots/puma260.yaml");
  sirupp::core::RobotModel model = sirupp::core::LoadRobotModel(model_file);
  sirupp::sim::ModelChange change;
  if (args.Has("payload-kg")) change.payload_kg = args.Numbers("payload-kg", 1)[0];
  if (args.Has("friction-scale")) change.friction_scale = args.Numbers("friction-scale", 1)[0];
  change.gravity_off = args.Switch("gravity-off");
  try {
    sirupp::sim::ApplyModelChange(model, change);
  } catch (const std::invalid_argument& error) {
    throw sirupp::core::UsageError(std::string("sirupp-sim: ") + error.what());
  }
  if (!change.empty())
    std::cerr << "sirupp-sim: simulated arm changed: " << change.Describe() << "\n";
  sirupp::core::Environment environment;
  if (args.Has("environment")) {
    environment =
        sirupp::core::LoadEnvironment(sirupp::runtime::ResolveDataPath(args.String("environment")));
  }

  sirupp::sim::WorldOptions world_options;
  if (args.Has("step")) world_options.step_s = args.Numbers("step", 1)[0];
  world_options.friction = !args.Switch("no-friction");

  sirupp::sim::NodeOptions options;
  try {
    if (args.Has("mode")) options.mode = sirupp::sim::ParseTimingMode(args.String("mode"));
    if (args.Has("idle")) {
      const std::string idle = args.String("idle");
      if (idle != "hold" && idle != "limp") {
        throw std::invalid_argument("--idle '" + idle + "': allowed hold, limp");
      }
      options.idle =
          idle == "hold" ? sirupp::core::CommandMode::kHold : sirupp::core::CommandMode::kLimp;
    }
  } catch (const std::invalid_argument& error) {
    throw sirupp::core::UsageError(std::string("sirupp-sim: ") + error.what());
  }
  if (args.Has("participants")) options.participants = args.Values("participants", -1);
  if (args.Has("state-every")) {
    const double every = args.Numbers("state-every", 1)[0];
    if (every < 1 || every != static_cast<int>(every)) {
      throw sirupp::core::UsageError("sirupp-sim: --state-every " +
                                     sirupp::core::FormatNumber(every) +
                                     ": allowed a whole number >= 1");
    }
    options.state_every = static_cast<int>(every);
  }
  if (args.Has("lockstep-timeout")) {
    options.lockstep_timeout_s = args.Numbers("lockstep-timeout", 1)[0];
  }
  if (args.Has("watchdog")) {
    options.watchdog_s = args.Numbers("watchdog", 1)[0];
  } else if (options.mode == sirupp::sim::TimingMode::kFreeRun) {
    options.watchdog_s = 0.05;  // a held command goes stale fast
  }
  if (args.Has("duration")) options.duration_s = args.Numbers("duration", 1)[0];

  std::vector<double> start;
  if (args.Has("pose") && args.Has("position")) {
    throw sirupp::core::UsageError("sirupp-sim: give --pose or --position, not both");
  }
  if (args.Has("pose")) {
    const sirupp::core::NamedPose* pose = model.FindNamedPose(args.String("pose"));
    if (pose == nullptr) {
      std::string names;
      for (const auto& named : model.named_poses) names += (names.empty() ? "" : ", ") + named.name;
      throw sirupp::core::UsageError("sirupp-sim: --pose '" + args.String("pose") +
                                     "': the model has " + names);
    }
    start = pose->position;
  } else if (args.Has("position")) {
    start = args.Numbers("position", model.num_joints());
    const double scale = model.file_angle_unit == "deg" ? 3.14159265358979323846 / 180 : 1.0;
    for (int j = 0; j < model.num_joints(); ++j) {
      if (model.joints[static_cast<size_t>(j)].type == sirupp::core::JointType::kRevolute) {
        start[static_cast<size_t>(j)] *= scale;
      } else {
        start[static_cast<size_t>(j)] *= model.file_length_unit_m;
      }
    }
  }

  std::optional<sirupp::sim::ArmWorld> world_storage;
  try {
    world_storage.emplace(model, environment, world_options);
  } catch (const std::invalid_argument& error) {
    throw sirupp::core::UsageError(std::string("sirupp-sim: --step: ") + error.what());
  }
  sirupp::sim::ArmWorld& world = *world_storage;
  for (const std::string& omission : world.Omissions()) {
    std::cerr << "sirupp-sim: note: " << omission << "\n";
  }
  if (!start.empty()) {
    try {
      world.SetJointState(start);
    } catch (const std::invalid_argument& error) {
      throw sirupp::core::UsageError(std::string("sirupp-sim: start pose: ") + error.what());
    }
  }
  sirupp::core::Bus bus(args.Has("lcm-url") ? args.String("lcm-url") : "",
                        args.Has("prefix") ? args.String("prefix") : "");
  // Each flag on its own against the node's rules, so the message names the flag and its value.
  const auto check_flag = [&](const std::string& flag,
                              const std::function<void(sirupp::sim::NodeOptions&)>& apply) {
    if (!args.Has(flag)) return;
    sirupp::sim::NodeOptions probe;  // the defaults pass
    probe.mode = options.mode;
    if (flag != "participants" && !options.participants.empty()) {
      probe.participants = {options.participants.front()};
    }
    apply(probe);
    try {
      sirupp::sim::CheckNodeOptions(probe);
    } catch (const std::invalid_argument& error) {
      std::string given;
      for (const std::string& value : args.Values(flag, -1)) given += " " + value;
      throw sirupp::core::UsageError("sirupp-sim: --" + flag + given + ": " + error.what());
    }
  };
  check_flag("participants", [&](auto& p) { p.participants = options.participants; });
  check_flag("lockstep-timeout",
             [&](auto& p) { p.lockstep_timeout_s = options.lockstep_timeout_s; });
  check_flag("watchdog", [&](auto& p) { p.watchdog_s = options.watchdog_s; });
  check_flag("duration", [&](auto& p) { p.duration_s = options.duration_s; });
  std::optional<sirupp::sim::SimNode> node_storage;
  try {
    node_storage.emplace(bus, world, environment, options);
  } catch (const std::invalid_argument& error) {
    throw sirupp::core::UsageError(std::string("sirupp-sim: ") + error.what());
  }
  sirupp::sim::SimNode& node = *node_storage;
  std::cerr << "sirupp-sim: " << model.name << " (" << model.num_joints() << " joints), "
            << environment.objects.size() << " environment objects, "
            << sirupp::sim::TimingModeName(options.mode) << " mode, step "
            << sirupp::core::FormatNumber(world.step_s() * 1e3) << " ms, on " << bus.url() << "\n";
  sirupp::runtime::RequestRealtimePriority(rt_priority, "sirupp-sim");
  sirupp::runtime::ServiceUntilSignal([&node] { return node.Service(50); });
  std::cerr << "sirupp-sim: " << node.Summary() << "\n";
  std::cerr << "sirupp-sim: final joint positions (rad or m):";
  for (double q : world.State().position) std::cerr << " " << sirupp::core::FormatApprox(q);
  std::cerr << "\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return sirupp::runtime::ProcessMain(argc, argv, "sirupp-sim", kUsage, Run);
}
