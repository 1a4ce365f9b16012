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
#include "runtime/joint_args.hpp"
#include "runtime/process_main.hpp"
#include "sim/arm_world.hpp"
#include "sim/model_change.hpp"
#include "sim/sim_node.hpp"

namespace {

using sirupp::runtime::Flag;

constexpr const char* kAbout =
    "The ODE physics of a robot model: takes SIM_ARM_COMMAND, publishes SIM_ARM_STATE every tick, "
    "ROBOT_MODEL and ENVIRONMENT at 1 Hz and HEARTBEAT. Defaults: the PUMA 260 model, lockstep "
    "with participant sirupp-control, the model's servo tick (0.512 ms for the PUMA 260). See "
    "sim/README.md.\n"
    "realtime = lockstep paced by the wall clock (every participant answers every tick; the sim "
    "time slips rather than the physics when the PC cannot keep up); freerun = paced, the newest "
    "command of any sender held (opt-in; stale efforts under load). docs/timing.md.\n"
    "The virtual PIC-SERVO boards run here, beside the physics: a participant answering "
    "MODE_BOARDS (sirupp-control without a student's controller) answers SIM_BOARD_STATUS every "
    "--exchange-ticks ticks, and the boards run profile and PID every tick and publish "
    "ARM_SETPOINT (while every participant answers MODE_BOARDS, --tick-batch ticks at a time on "
    "SIM_ARM_TICKS).\n"
    "Joint values: docs/command-line.md (--deg: revolute in degrees, prismatic in metres).";

std::vector<Flag> SimFlags() {
  std::vector<Flag> flags = {
      sirupp::runtime::ModelFlag(),
      Flag("environment", "environment XML file").Takes("FILE"),
      Flag("mode", "timing mode").Takes("MODE").OneOf({"lockstep", "realtime", "fast", "freerun"}),
      Flag("participants", "participant names (lockstep and realtime)").Takes("NAME", -1),
      Flag("step", "physics step in seconds").Takes("SECONDS"),
      Flag("state-every", "publish the state every N ticks")
          .Takes("N")
          .Integer(1, sirupp::runtime::Flag::kMany),
      Flag("lockstep-timeout", "seconds before a silent participant is reported").Takes("SECONDS"),
      Flag("watchdog",
           "realtime: seconds a participant may be silent before the arm brakes (0.5); freerun: "
           "age of a held command (0.05)")
          .Takes("SECONDS"),
      Flag("pace-ticks",
           "realtime: sleep once per N ticks, then run them back to back (each still waits for "
           "every answer); the sim time lags the wall clock by up to N ticks (1)")
          .Takes("N")
          .Integer(1, 64),
      Flag("exchange-ticks",
           "the virtual boards' exchange with sirupp-control: SIM_BOARD_STATUS every N ticks "
           "(16; a multiple of --state-every)")
          .Takes("N")
          .Integer(1, 4096),
      Flag("tick-batch",
           "while every participant lets the boards drive the arm: SIM_ARM_STATE and "
           "ARM_SETPOINT N ticks at a time on SIM_ARM_TICKS (16; 1 = each tick on its own)")
          .Takes("N")
          .Integer(1, 64),
      Flag("duration", "simulated seconds to run (0 = until stopped)").Takes("SECONDS"),
      Flag("idle", "before the first command").Takes("MODE").OneOf({"hold", "limp"}),
      Flag("no-friction", "switch joint friction off").Switch(),
      Flag("payload-kg",
           "point mass at the tool point, kg (the simulated arm only; controllers keep their "
           "model)")
          .Takes("KG"),
      Flag("friction-scale", "scale every friction effort (the simulated arm only)").Takes("S"),
      Flag("gravity-off", "no gravity (the simulated arm only)").Switch(),
      Flag("lcm-url", "LCM URL").Takes("URL"),
      Flag("prefix", "channel prefix of the rig").Takes("PREFIX"),
      sirupp::runtime::RtPriorityFlag()};
  const std::vector<Flag> joint_flags = sirupp::runtime::JointFlags();  // the start position
  flags.insert(flags.end(), joint_flags.begin(), joint_flags.end());
  return flags;
}

// --payload-kg, --friction-scale, --gravity-off: the simulated arm differs from the model the
// controllers have.
void ApplyArmChanges(const sirupp::runtime::Args& args, sirupp::core::RobotModel& model) {
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
}

sirupp::sim::NodeOptions NodeOptionsFromArgs(const sirupp::runtime::Args& args) {
  sirupp::sim::NodeOptions options;
  try {
    if (args.Has("mode")) options.mode = sirupp::sim::ParseTimingMode(args.String("mode"));
    if (args.Has("idle")) {
      options.idle = args.String("idle") == "hold" ? sirupp::core::CommandMode::kHold
                                                   : sirupp::core::CommandMode::kLimp;
    }
  } catch (const std::invalid_argument& error) {
    throw sirupp::core::UsageError(std::string("sirupp-sim: ") + error.what());
  }
  if (args.Has("participants")) options.participants = args.Values("participants", -1);
  options.state_every = static_cast<int>(args.Integer("state-every", options.state_every));
  if (args.Has("lockstep-timeout")) {
    options.lockstep_timeout_s = args.Numbers("lockstep-timeout", 1)[0];
  }
  if (args.Has("watchdog")) {
    options.watchdog_s = args.Numbers("watchdog", 1)[0];
  } else if (options.mode == sirupp::sim::TimingMode::kFreeRun) {
    options.watchdog_s = 0.05;  // a held command goes stale fast
  }
  if (args.Has("duration")) options.duration_s = args.Numbers("duration", 1)[0];
  options.pace_ticks = static_cast<int>(args.Integer("pace-ticks", options.pace_ticks));
  options.tick_batch = static_cast<int>(args.Integer("tick-batch", options.tick_batch));
  if (args.Has("exchange-ticks")) {
    options.exchange_ticks = static_cast<int>(args.Integer("exchange-ticks", 16));
  } else {
    // The default, rounded up to a multiple of --state-every.
    options.exchange_ticks = (options.exchange_ticks + options.state_every - 1) /
                             options.state_every * options.state_every;
  }
  return options;
}

// Each flag on its own against the node's rules, so the message names the flag and its value.
void CheckNodeFlags(const sirupp::runtime::Args& args, const sirupp::sim::NodeOptions& options) {
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
  check_flag("exchange-ticks", [&](auto& p) {
    p.state_every = options.state_every;
    p.exchange_ticks = options.exchange_ticks;
  });
}

int Run(const std::vector<std::string>& argv) {
  const sirupp::runtime::Args args(argv, "sirupp-sim", SimFlags(), kAbout);
  const int rt_priority = static_cast<int>(args.Integer("rt-priority", 0));
  const std::string model_file = sirupp::runtime::ModelFileArg(args);
  sirupp::core::RobotModel model = sirupp::core::LoadRobotModel(model_file);
  ApplyArmChanges(args, model);
  sirupp::core::Environment environment;
  if (args.Has("environment")) {
    environment =
        sirupp::core::LoadEnvironment(sirupp::runtime::ResolveDataPath(args.String("environment")));
  }

  sirupp::sim::WorldOptions world_options;
  if (args.Has("step")) world_options.step_s = args.Numbers("step", 1)[0];
  world_options.friction = !args.Switch("no-friction");
  const sirupp::sim::NodeOptions options = NodeOptionsFromArgs(args);
  const std::vector<double> start = sirupp::runtime::PositionsArg(args, model, "sirupp-sim", false)
                                        .value_or(std::vector<double>{});

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
  CheckNodeFlags(args, options);
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
  node.Flush();  // the last ticks of a batch reach the logger too
  std::cerr << "sirupp-sim: " << node.Summary() << "\n";
  std::cerr << "sirupp-sim: final joint positions (rad or m):";
  for (double q : world.State().position) std::cerr << " " << sirupp::core::FormatApprox(q);
  std::cerr << "\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return sirupp::runtime::ProcessMain(argc, argv, "sirupp-sim", Run);
}
