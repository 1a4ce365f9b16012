// sirupp-picservo-emu: a bus of emulated PIC-SERVO SC modules and the arm behind them on a
// pseudo-terminal (hardware/emulator.hpp). Thin main: arguments in, run until a signal, counters
// out. docs/hardware-emulator.md describes it.

#include <chrono>
#include <cstdio>
#include <iostream>
#include <sstream>
#include <thread>

#include "core/errors.hpp"
#include "core/model_loader.hpp"
#include "hardware/emulator.hpp"
#include "runtime/args.hpp"
#include "runtime/data_path.hpp"
#include "runtime/joint_args.hpp"
#include "runtime/process_main.hpp"

namespace {

using sirupp::runtime::Flag;

constexpr const char* kName = "sirupp-picservo-emu";
constexpr const char* kAbout =
    "A bus of N emulated PIC-SERVO SC modules (default: one per joint of the model, default\n"
    "config/robots/puma260.yaml) on a pseudo-terminal, each driving one joint of the emulated "
    "arm.\n"
    "Prints the device to open (--link PATH: also a symbolic link there), runs until SIGINT or\n"
    "SIGTERM, then prints its counters. The arm powers up at --start-pose or --start-joints\n"
    "(degrees; default all joints at 0); the encoders read 0 there.\n"
    "--socket PATH: the line is a Unix socket at PATH instead of a pseudo-terminal\n"
    "(sirupp-hardware --port PATH connects to it); unlike a pty it does not stall on a loaded\n"
    "machine, so the lab layouts and the demo use it.\n"
    "--real-arm FILE: the arm's physical effects (motors, shared supply, gear backlash and\n"
    "compliance, friction per direction, encoder quantum, board latency); default\n"
    "config/hardware/puma260-real.yaml, fitted to the SIRUPP paper's Table II.\n"
    "--friction-scale X: instead, the model's own arm with static and Coulomb friction times X.\n"
    "Faults: --checksum-errors P (probability a command is seen with a bad checksum), "
    "--drop-bytes\n"
    "P (probability a reply byte is lost), --silent-module K (module K, 1..N, hears and answers\n"
    "nothing), --overcurrent K and --pos-error-trip K (trip module K); K@T: T seconds after "
    "start.\n"
    "--rt-priority N: run the modules under SCHED_FIFO at priority N (1..99; needs root or\n"
    "CAP_SYS_NICE): the emulator stands for boards with their own clock, so it should not wait\n"
    "for the rest of the machine.\n"
    "See docs/hardware-emulator.md.\n";

using sirupp::core::UsageError;

struct TimedFault {
  enum Kind { kSilent, kOvercurrent, kPositionError } kind;
  int module_index;
  double at_s;
  bool done = false;
};

// "27.0 ms"
std::string Milliseconds(double s) {
  char text[32];
  std::snprintf(text, sizeof text, "%.1f ms", s * 1e3);
  return text;
}

// "K" or "K@SECONDS", K = 1..modules.
void ParseFaults(const sirupp::runtime::Args& args, const std::string& flag, TimedFault::Kind kind,
                 int modules, std::vector<TimedFault>* faults) {
  if (!args.Has(flag)) return;
  for (const std::string& text : args.Values(flag, -1)) {
    const size_t at = text.find('@');
    const std::string what = std::string(kName) + " --" + flag + " '" + text + "'";
    const double k = sirupp::runtime::ParseNumberArg(text.substr(0, at), what + " module");
    double seconds = 0;
    if (at != std::string::npos) {
      seconds = sirupp::runtime::ParseNumberArg(text.substr(at + 1), what + " seconds");
    }
    if (k < 1 || k > modules || k != static_cast<int>(k) || seconds < 0) {
      throw UsageError(what + ": allowed K or K@SECONDS with K a module 1.." +
                       std::to_string(modules) + " and SECONDS >= 0");
    }
    faults->push_back({kind, static_cast<int>(k) - 1, seconds});
  }
}

// --start-pose NAME: the model's named pose.
std::vector<double> StartPose(const sirupp::runtime::Args& args,
                              const sirupp::core::RobotModel& model) {
  const sirupp::core::NamedPose* pose = model.FindNamedPose(args.String("start-pose"));
  if (pose == nullptr) {
    std::string names;
    for (const auto& named : model.named_poses) {
      names += (names.empty() ? "" : ", ") + named.name;
    }
    throw UsageError(std::string(kName) + ": --start-pose '" + args.String("start-pose") +
                     "': allowed " + names);
  }
  return pose->position;
}

// --start-joints: one value per joint (revolute in degrees, prismatic in metres), as one quoted
// value "a b c" or separate values; SI, each within its joint's limits.
std::vector<double> StartJoints(const sirupp::runtime::Args& args,
                                const sirupp::core::RobotModel& model) {
  const int joints = model.num_joints();
  std::vector<std::string> words;
  for (const std::string& value : args.Values("start-joints", -1)) {
    std::istringstream split(value);
    for (std::string word; split >> word;) words.push_back(word);
  }
  if (static_cast<int>(words.size()) != joints) {
    throw UsageError(std::string(kName) + ": --start-joints: " + std::to_string(words.size()) +
                     " values given; allowed exactly " + std::to_string(joints) +
                     " (one per joint: revolute in degrees, prismatic in metres)");
  }
  std::vector<double> values;
  for (size_t j = 0; j < words.size(); ++j) {
    values.push_back(sirupp::runtime::ParseNumberArg(
        words[j], std::string(kName) + " --start-joints value " + std::to_string(j + 1)));
  }
  std::vector<double> positions = sirupp::runtime::FromDegrees(values, model);
  for (size_t j = 0; j < words.size(); ++j) {
    const sirupp::core::Joint& joint = model.joints[j];
    const double q = positions[j];
    if (!(q >= joint.position_min && q <= joint.position_max)) {
      throw UsageError(std::string(kName) + ": --start-joints value " + std::to_string(j + 1) +
                       " (" + joint.name + ") " + words[j] + ": allowed " +
                       sirupp::core::FormatNumber(joint.position_min) + ".." +
                       sirupp::core::FormatNumber(joint.position_max) + " rad or m");
    }
  }
  return positions;
}

// Fires the timed faults that are due at `t` seconds after the start, each once.
void FireDueFaults(sirupp::hardware::Emulator& emulator, std::vector<TimedFault>& faults,
                   double t) {
  for (TimedFault& fault : faults) {
    if (fault.done || t < fault.at_s) continue;
    fault.done = true;
    if (fault.kind == TimedFault::kSilent) emulator.SetSilent(fault.module_index, true);
    if (fault.kind == TimedFault::kOvercurrent) emulator.TriggerOvercurrent(fault.module_index);
    if (fault.kind == TimedFault::kPositionError) {
      emulator.TriggerPositionErrorTrip(fault.module_index);
    }
    std::cerr << kName << ": fault at " << sirupp::core::FormatNumber(t) << " s on module "
              << fault.module_index + 1 << "\n";
  }
}

void PrintCounters(const sirupp::hardware::Emulator& emulator) {
  const sirupp::hardware::EmulatorCounters c = emulator.counters();
  std::cout << kName << ": stopped: " << c.commands_received << " commands, " << c.checksum_errors
            << " checksum errors, " << c.replies_sent << " replies, " << c.bytes_dropped
            << " bytes dropped, " << c.servo_ticks << " servo ticks stepped (" << c.ticks_caught_up
            << " caught up late, " << c.ticks_slipped << " slipped in " << c.slips
            << " slips; at most " << Milliseconds(c.max_lateness_s) << " behind the wall clock), "
            << c.packet_timeouts << " packet timeouts, " << c.bytes_skipped
            << " bytes skipped, line at " << c.baud << " baud";
  if (emulator.on_socket()) std::cout << ", " << c.connections << " client connections";
  std::cout << std::endl;
}

std::vector<Flag> EmuFlags() {
  return {
      sirupp::runtime::ModelFlag(),
      Flag("modules", "number of modules, 1..32").Takes("N").Integer(1, 32),
      Flag("link", "symbolic link to the device").Takes("PATH"),
      Flag("socket", "Unix socket path for the line, instead of a pty").Takes("PATH"),
      Flag("friction-scale", "static and Coulomb friction factor").Takes("S").AtLeast(0),
      Flag("real-arm", "real-arm effects file").Takes("FILE"),
      Flag("start-pose", "named pose of the model to power up in").Takes("NAME"),
      Flag("start-joints", "joint values to power up in: revolute in degrees, prismatic in metres")
          .Takes("Q", -1),
      Flag("seed", "random seed of the faults").Takes("S").Integer(0, 4294967295L),
      Flag("checksum-errors", "probability 0..1").Takes("P").Range(0, 1),
      Flag("drop-bytes", "probability 0..1").Takes("P").Range(0, 1),
      Flag("silent-module", "K or K@SECONDS").Takes("K[@S]"),
      Flag("overcurrent", "K or K@SECONDS").Takes("K[@S]"),
      Flag("pos-error-trip", "K or K@SECONDS").Takes("K[@S]"),
      sirupp::runtime::RtPriorityFlag()};
}

// Where the modules listen: the device to open (or the socket), and its link.
void PrintLine(const sirupp::hardware::Emulator& emulator,
               const sirupp::hardware::EmulatorOptions& options) {
  std::cout << kName << ": " << emulator.num_modules() << " modules on ";
  if (emulator.on_socket()) {
    std::cout << "the socket " << options.socket;
  } else {
    std::cout << emulator.slave_path();
  }
  if (!options.link.empty()) std::cout << " (linked as " << options.link << ")";
  std::cout << std::endl;
}

int Run(const std::vector<std::string>& argv) {
  const sirupp::runtime::Args args(argv, kName, EmuFlags(), kAbout);
  const int rt_priority = static_cast<int>(args.Integer("rt-priority", 0));
  sirupp::hardware::EmulatorOptions options;
  options.model = sirupp::core::LoadRobotModel(sirupp::runtime::ModelFileArg(args));
  const int joints = options.model.num_joints();
  options.modules = static_cast<int>(args.Integer("modules", options.modules));
  const int modules = options.modules == 0 ? joints : options.modules;
  if (args.Has("link")) options.link = args.String("link");
  if (args.Has("socket")) options.socket = args.String("socket");
  if (args.Has("link") && args.Has("socket")) {
    throw UsageError(std::string(kName) + ": --link and --socket: allowed one of them");
  }
  options.friction_scale = args.Number("friction-scale", options.friction_scale);
  if (args.Has("real-arm") && args.Has("friction-scale")) {
    throw UsageError(std::string(kName) + ": give --real-arm or --friction-scale, not both");
  }
  if (!args.Has("friction-scale")) {
    options.effects = sirupp::hardware::LoadRealArmParams(
        sirupp::runtime::ResolveDataPath(
            args.Has("real-arm") ? args.String("real-arm") : "config/hardware/puma260-real.yaml"),
        options.model);
  }
  if (args.Has("start-pose") && args.Has("start-joints")) {
    throw UsageError(std::string(kName) + ": give --start-pose or --start-joints, not both");
  }
  if (args.Has("start-pose")) options.start_positions = StartPose(args, options.model);
  if (args.Has("start-joints")) options.start_positions = StartJoints(args, options.model);
  options.seed = static_cast<uint32_t>(args.Integer("seed", static_cast<long>(options.seed)));
  options.checksum_error_rate = args.Number("checksum-errors", options.checksum_error_rate);
  options.drop_rate = args.Number("drop-bytes", options.drop_rate);
  std::vector<TimedFault> faults;
  ParseFaults(args, "silent-module", TimedFault::kSilent, modules, &faults);
  ParseFaults(args, "overcurrent", TimedFault::kOvercurrent, modules, &faults);
  ParseFaults(args, "pos-error-trip", TimedFault::kPositionError, modules, &faults);
  for (TimedFault& fault : faults) {
    if (fault.kind == TimedFault::kSilent && fault.at_s == 0) {
      options.silent_modules.push_back(fault.module_index);
      fault.done = true;
    }
  }

  std::unique_ptr<sirupp::hardware::Emulator> emulator;
  try {
    emulator = std::make_unique<sirupp::hardware::Emulator>(options);
  } catch (const std::invalid_argument& error) {
    throw UsageError(std::string(kName) + ": " + error.what());
  }
  sirupp::runtime::RequestRealtimePriority(rt_priority, kName);  // before the thread: it inherits
  emulator->Start();
  PrintLine(*emulator, options);

  const auto start = std::chrono::steady_clock::now();
  sirupp::runtime::ServiceUntilSignal([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    const double t =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    FireDueFaults(*emulator, faults, t);
    return true;
  });
  emulator->Stop();
  PrintCounters(*emulator);
  return 0;
}

}  // namespace

int main(int argc, char** argv) { return sirupp::runtime::ProcessMain(argc, argv, kName, Run); }
