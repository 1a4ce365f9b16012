// sirupp-hardware: the bridge to the real PUMA (PIC-SERVO SC boards on an NMC serial bus), or to
// sirupp-picservo-emu. Thin main: flags, settings, then BridgeNode until a signal.

#include <algorithm>
#include <cmath>
#include <iostream>
#include <memory>
#include <string>

#include "core/bus.hpp"
#include "core/errors.hpp"
#include "core/model_loader.hpp"
#include "hardware/arm_link.hpp"
#include "hardware/bridge_node.hpp"
#include "hardware/bridge_settings.hpp"
#include "hardware/nmc_protocol.hpp"
#include "hardware/serial_port.hpp"
#include "runtime/args.hpp"
#include "runtime/data_path.hpp"
#include "runtime/process_main.hpp"

namespace {

using sirupp::runtime::Flag;

constexpr const char* kAbout =
    "The bridge to the real arm: starts the PIC-SERVO modules as the vendor library does (reset,\n"
    "address, ids, baud, gains), then obeys HARDWARE_COMMAND (connect, calibrate, arm, disarm,\n"
    "link, unlink, home, clear-faults; `sirupp hardware --help`) and ESTOP, mirrors every\n"
    "ARM_MOVE to the boards while linked, and publishes REAL_ARM_STATE and REAL_ARM_SETPOINT at\n"
    "the poll rate and HARDWARE_STATUS at 10 Hz.\n"
    "--settings: serial line, poll rate and every safety threshold (default\n"
    "  config/hardware/puma260.yaml; docs/hardware.md). --port, --baud and --rate override it.\n"
    "--calibrate, --arm, --link: do these steps at start-up, in that order (the operator's\n"
    "  decision; the start guard applies to bus commands only).\n"
    "--emulated: mark REAL_ARM_STATE as SOURCE_EMULATED (the arm is sirupp-picservo-emu), and\n"
    "  wait at least 100 ms for a late reply (reply_margin_ms) before retrying.\n"
    "--trace: print every packet and reply.\n"
    "--rt-priority N: poll under SCHED_FIFO at priority N (1..99; needs root or CAP_SYS_NICE), so\n"
    "  a busy machine does not delay the replies past their timeout (docs/timing.md).\n"
    "On SIGINT or SIGTERM, and on a fatal error: motors stop, servos off, amplifiers disabled.\n";

// The settings file (--settings, default config/hardware/puma260.yaml) with --port, --baud,
// --rate and --emulated over it.
sirupp::hardware::BridgeSettings SettingsFromArgs(const sirupp::runtime::Args& args,
                                                  const sirupp::core::RobotModel& model) {
  using sirupp::core::UsageError;
  sirupp::hardware::BridgeSettings settings = sirupp::hardware::LoadBridgeSettings(
      sirupp::runtime::ResolveDataPath(args.Has("settings") ? args.String("settings")
                                                            : "config/hardware/puma260.yaml"),
      model);
  if (args.Has("port")) settings.port = args.String("port");
  if (settings.port.empty()) {
    throw UsageError(
        "sirupp-hardware: no serial port: give --port DEVICE (or port: in the settings)");
  }
  if (args.Has("baud")) {
    const double baud = args.Numbers("baud", 1)[0];
    if (!(baud >= 0 && baud <= 1e7) || baud != std::floor(baud) ||
        !sirupp::hardware::nmc::IsSupportedBaud(static_cast<int>(baud))) {
      throw UsageError("sirupp-hardware: --baud " + sirupp::core::FormatNumber(baud) +
                       " is not allowed; allowed: " + sirupp::hardware::nmc::SupportedBauds());
    }
    settings.baud = static_cast<int>(baud);
  }
  settings.poll_rate_hz = args.Number("rate", settings.poll_rate_hz);
  if (args.Switch("emulated")) {
    settings.emulated = true;
    // The emulator is a thread of a user process on a shared machine: a reply held up by the
    // scheduler is not a broken line, so it gets longer to come (only failed exchanges wait it).
    settings.reply_margin_ms = std::max(settings.reply_margin_ms, 100);
  }
  return settings;
}

// What to do at start-up, in this order (--no-connect, --calibrate, --arm, --link).
struct StartSteps {
  bool connect = true;
  bool calibrate = false;
  bool arm = false;
  bool link = false;
};

StartSteps StartStepsFromArgs(const sirupp::runtime::Args& args) {
  using sirupp::core::UsageError;
  StartSteps steps;
  steps.connect = !args.Switch("no-connect");
  steps.calibrate = args.Switch("calibrate");
  steps.arm = args.Switch("arm");
  steps.link = args.Switch("link");
  if ((steps.calibrate || steps.arm || steps.link) && !steps.connect) {
    throw UsageError(
        "sirupp-hardware: --calibrate, --arm and --link need the connection (drop --no-connect)");
  }
  if ((steps.arm && !steps.calibrate) || (steps.link && !steps.arm)) {
    throw UsageError("sirupp-hardware: --link needs --arm, and --arm needs --calibrate");
  }
  return steps;
}

// Connects, calibrates, arms and links as asked. A refused calibration is not an error of the
// process: it stays up, connected and uncalibrated, saying why, and neither arms nor links.
void DoStartSteps(sirupp::hardware::BridgeNode& node, sirupp::hardware::ArmLink& link,
                  const sirupp::hardware::BridgeSettings& settings, const StartSteps& steps) {
  if (steps.connect) {
    node.Connect();  // prints how it found the boards when they had kept power
    std::cerr << "sirupp-hardware: " << link.bus().modules().size() << " modules on "
              << settings.port << " at " << settings.baud << " baud\n";
  }
  bool calibrated = link.calibrated();
  if (steps.calibrate && link.resumed()) {
    std::cerr << "sirupp-hardware: calibration kept from the boards' counters; not calibrating "
                 "again\n";
  } else if (steps.calibrate) {
    try {
      node.Calibrate();
      calibrated = true;
      std::cerr << "sirupp-hardware: calibrated (pose " << settings.calibration_pose << ")\n";
    } catch (const sirupp::hardware::CalibrationRefused& refused) {
      std::cerr << "sirupp-hardware: " << refused.what() << "\n";
      if (steps.arm || steps.link) {
        std::cerr << "sirupp-hardware: not arming or linking: not calibrated\n";
      }
    }
  }
  if (steps.arm && calibrated) node.Arm();
  if (steps.link && calibrated) node.Link();
}

int Run(const std::vector<std::string>& argv) {
  const sirupp::runtime::Args args(
      argv, "sirupp-hardware",
      {Flag("port", "serial device").Takes("DEVICE"),
       Flag("settings", "bridge settings file").Takes("FILE"), sirupp::runtime::ModelFlag(),
       Flag("baud", "baud rate").Takes("N"),
       Flag("rate", "poll rate in Hz").Takes("HZ").Range(1, 1000),
       Flag("emulated", "the arm is the emulator").Switch(),
       Flag("calibrate", "calibrate at start-up").Switch(), Flag("arm", "arm at start-up").Switch(),
       Flag("link", "link at start-up").Switch(),
       Flag("no-connect", "do not connect at start-up").Switch(),
       Flag("trace", "print every packet").Switch(), Flag("name", "process name").Takes("NAME"),
       Flag("lcm-url", "LCM URL").Takes("URL"),
       Flag("prefix", "channel prefix of the rig").Takes("PREFIX"),
       sirupp::runtime::RtPriorityFlag()},
      kAbout);
  const int rt_priority = static_cast<int>(args.Integer("rt-priority", 0));
  const sirupp::core::RobotModel model =
      sirupp::core::LoadRobotModel(sirupp::runtime::ModelFileArg(args));
  const sirupp::hardware::BridgeSettings settings = SettingsFromArgs(args, model);
  const StartSteps steps = StartStepsFromArgs(args);

  sirupp::runtime::RequestRealtimePriority(rt_priority, "sirupp-hardware");
  sirupp::hardware::SerialPort port(settings.port, sirupp::hardware::nmc::kPowerUpBaud);
  sirupp::hardware::ArmLink link(model, settings, port);
  if (args.Switch("trace")) {
    link.bus().set_trace([](const std::string& line) { std::cerr << line << "\n"; });
  }
  sirupp::core::Bus bus(args.Has("lcm-url") ? args.String("lcm-url") : "",
                        args.Has("prefix") ? args.String("prefix") : "");
  sirupp::hardware::BridgeOptions options;
  if (args.Has("name")) options.name = args.String("name");
  sirupp::hardware::BridgeNode node(bus, model, link, settings, options);
  try {
    DoStartSteps(node, link, settings, steps);
    std::cerr << "sirupp-hardware: " << model.name << ", "
              << (node.linked()               ? "linked"
                  : link.armed()              ? "armed"
                  : link.calibrated()         ? "calibrated"
                  : link.blind_reason() != "" ? "not calibrated"
                                              : "ready")
              << ", polling at " << settings.poll_rate_hz << " Hz, on " << bus.url() << "\n";
    sirupp::runtime::ServiceUntilSignal([&node] {
      node.Service(20);
      return true;
    });
  } catch (...) {
    node.Shutdown();  // motors off before the error is reported
    throw;
  }
  node.Shutdown();
  const sirupp::hardware::BusCounters& c = link.bus().counters();
  std::cerr << "sirupp-hardware: stopped (motors off, amplifiers disabled) after " << node.polls()
            << " polls, " << node.moves_mirrored() << " moves mirrored; " << c.exchanges
            << " exchanges, " << c.timeouts << " timeouts, "
            << c.checksum_errors + c.module_checksum_errors << " checksum errors, " << c.resyncs
            << " resyncs\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return sirupp::runtime::ProcessMain(argc, argv, "sirupp-hardware", Run);
}
