#include "tools/hardware_commands.hpp"

#include <unistd.h>

#include <algorithm>
#include <optional>
#include <ostream>
#include <sirupp/hardware_status_t.hpp>

#include "client/client.hpp"
#include "core/bus.hpp"
#include "core/channels.hpp"
#include "core/errors.hpp"
#include "runtime/args.hpp"
#include "tools/rig_args.hpp"

namespace sirupp::tools {

namespace {
// Each command of sirupp-hardware and what it does; the help of `sirupp hardware` lists them.
const std::vector<std::pair<std::string, std::string>> kVerbs = {
    {"connect", "reset and address the modules, set baud and gains (servos off)"},
    {"calibrate", "define the present pose as the settings' calibration pose (and home)"},
    {"arm", "servos on, holding where the arm is"},
    {"disarm", "stop smoothly, then servos off"},
    {"link", "mirror every ARM_MOVE of the controller to the real arm"},
    {"unlink", "stop mirroring (the arm holds)"},
    {"home", "move every joint to the model's home position"},
    {"clear-faults", "clear latched module bits after a fault (then arm again)"},
    {"status", "print the bridge's state, modules and serial counters"}};
}  // namespace

const char* const kHardwareAbout =
    "A command for sirupp-hardware (the bridge to the real arm or the emulator), on\n"
    "HARDWARE_COMMAND; the bridge's answer is read from HARDWARE_STATUS.\n"
    "Exit 0 when the bridge reached the state the command leads to, 1 when it refused (its reason\n"
    "is printed) or no bridge answered within --timeout (default 5 s), 2 on bad arguments.\n";

std::vector<std::string> HardwareVerbs() {
  std::vector<std::string> verbs;
  for (const auto& [verb, what] : kVerbs) verbs.push_back(verb);
  return verbs;
}

std::string HardwareVerbSummary(const std::string& verb) {
  for (const auto& [name, what] : kVerbs) {
    if (name == verb) return what;
  }
  return "";
}

const char* const kEstopAbout =
    "Engages the emergency stop on ESTOP (or releases it): sirupp-hardware stops the real motors\n"
    "abruptly and turns them off, sirupp-control aborts its plan and holds. Release never starts\n"
    "a motion: arm (and link) again afterwards. Prints what the bridge reports, if one runs.\n";

namespace {

using sirupp::hardware_status_t;

std::string Sender() {
  char host[256] = {};
  ::gethostname(host, sizeof host - 1);
  return "sirupp CLI (pid " + std::to_string(::getpid()) + "@" + host + ")";
}

const char* StateName(int8_t state) {
  switch (state) {
    case hardware_status_t::STATE_DISCONNECTED:
      return "disconnected";
    case hardware_status_t::STATE_CONNECTED:
      return "connected (servos off)";
    case hardware_status_t::STATE_CALIBRATING:
      return "calibrating";
    case hardware_status_t::STATE_ARMED:
      return "armed";
    case hardware_status_t::STATE_LINKED:
      return "linked";
    case hardware_status_t::STATE_FAULT:
      return "fault";
    case hardware_status_t::STATE_ESTOPPED:
      return "emergency stop";
    default:
      return "unknown";
  }
}

void PrintStatus(const hardware_status_t& s, std::ostream& out) {
  out << "bridge: " << StateName(s.state) << (s.calibrated ? ", calibrated" : ", not calibrated")
      << ", " << s.port << " at " << s.baud << " baud\n";
  for (int j = 0; j < s.num_joints; ++j) {
    const auto i = static_cast<size_t>(j);
    out << "  module " << j + 1 << ": status 0x" << std::hex << s.module_status[i] << " aux 0x"
        << s.module_aux_status[i] << std::dec << ", position " << s.position_counts[i]
        << " counts, error " << s.position_error_counts[i] << "\n";
  }
  out << "  serial: " << s.checksum_errors << " checksum errors, " << s.timeouts << " timeouts, "
      << s.resyncs << " resyncs\n";
  out << "  last error: " << (s.last_error.empty() ? "none" : s.last_error) << "\n";
}

}  // namespace

int RunHardware(const std::vector<std::string>& args, std::ostream& out) {
  if (args.empty() || args[0].rfind("--", 0) == 0) {
    throw core::UsageError(
        "hardware: expected a command: connect, calibrate, arm, disarm, link, unlink, home, "
        "clear-faults or status");
  }
  const std::string verb = args[0];
  const std::optional<client::HardwareCommand> command = client::HardwareCommandFromName(verb);
  if (!command && verb != "status") {
    throw core::UsageError("hardware: unknown command '" + verb +
                           "'; allowed: connect, calibrate, arm, disarm, link, unlink, home, "
                           "clear-faults, status");
  }
  const runtime::Args parsed(std::vector<std::string>(args.begin() + 1, args.end()),
                             "hardware " + verb,
                             WithRigFlags({TimeoutFlag("seconds to wait for the bridge (5)")}),
                             HardwareVerbSummary(verb) + ".\n" + kHardwareAbout);
  const double timeout = TimeoutFrom(parsed, 5);
  core::Bus bus = BusFromArgs(parsed);
  client::Options options;
  options.sender = Sender();
  options.answer_timeout_s = timeout;
  client::Client rig(bus, options);
  const std::string channel = bus.FullName(rig.channels().hardware_status);
  // The bridge's present status first: it shows a bridge runs.
  const double first = verb == "status" ? timeout : std::min(timeout, 2.0);
  if (!rig.WaitForHardware(first)) {
    out << "no " << channel << " within " << first << " s on " << bus.url()
        << ": is sirupp-hardware running (same --lcm-url and --prefix)?\n";
    return 1;
  }
  if (!command) {
    PrintStatus(*rig.snapshot().hardware, out);
    return 0;
  }
  const client::Answer answer = rig.Hardware(*command);
  if (answer.result == client::Result::kRefused) {
    out << "refused by sirupp-hardware: " << answer.error << "\n";
    return 1;
  }
  if (answer.result == client::Result::kNoAnswer || !rig.WaitHardwareDone(*command, timeout)) {
    out << verb << ": the bridge did not get there within " << timeout << " s"
        << (answer.accepted() ? "" : " (" + answer.error + ")") << "\n";
    PrintStatus(*rig.snapshot().hardware, out);
    return 1;
  }
  out << verb << ": done; bridge " << StateName(rig.snapshot().hardware->state) << "\n";
  return 0;
}

int RunEstop(const std::vector<std::string>& args, std::ostream& out) {
  const runtime::Args parsed(args, "estop",
                             WithRigFlags({runtime::Flag("release", "release the stop").Switch(),
                                           runtime::Flag("reason", "why, one line").Takes("TEXT")}),
                             kEstopAbout);
  const bool release = parsed.Switch("release");
  core::Bus bus = BusFromArgs(parsed);
  client::Options options;
  options.sender = Sender();
  client::Client rig(bus, options);
  rig.Estop(!release, parsed.Has("reason") ? parsed.String("reason")
                                           : (release ? "released" : "sirupp estop"));
  out << (release ? "released " : "engaged ") << bus.FullName(rig.channels().estop) << "\n";
  if (rig.WaitEstopShown(!release, 2.0)) {
    out << "bridge: " << StateName(rig.snapshot().hardware->state) << "\n";
  } else {
    out << "no bridge confirmed it within 2 s (none running, or it is on another --prefix)\n";
  }
  return 0;
}

}  // namespace sirupp::tools
