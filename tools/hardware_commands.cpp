#include "tools/hardware_commands.hpp"

#include <unistd.h>

#include <chrono>
#include <functional>
#include <optional>
#include <ostream>
#include <sirupp/estop_t.hpp>
#include <sirupp/hardware_command_t.hpp>
#include <sirupp/hardware_status_t.hpp>

#include "core/bus.hpp"
#include "core/channels.hpp"
#include "core/errors.hpp"
#include "tools/args.hpp"
#include "tools/rig_args.hpp"

namespace sirupp::tools {

const char* const kHardwareUsage =
    "usage: sirupp hardware COMMAND [--timeout S] [--lcm-url URL] [--prefix PREFIX]\n"
    "Commands for sirupp-hardware (the bridge to the real arm or the emulator), on\n"
    "HARDWARE_COMMAND; the bridge's answer is read from HARDWARE_STATUS:\n"
    "  connect       reset and address the modules, set baud and gains (servos off)\n"
    "  calibrate     define the present pose as the settings' calibration pose (and home)\n"
    "  arm           servos on, holding where the arm is\n"
    "  disarm        stop smoothly, then servos off\n"
    "  link          mirror every ARM_MOVE of the controller to the real arm\n"
    "  unlink        stop mirroring (the arm holds)\n"
    "  home          move every joint to the model's home position\n"
    "  clear-faults  clear latched module bits after a fault (then arm again)\n"
    "  status        print the bridge's state, modules and serial counters\n"
    "Exit 0 when the bridge reached the state the command leads to, 1 when it refused (its reason\n"
    "is printed) or no bridge answered within --timeout (default 5 s), 2 on bad arguments.\n";

const char* const kEstopUsage =
    "usage: sirupp estop [--release] [--reason TEXT] [--lcm-url URL] [--prefix PREFIX]\n"
    "Engages the emergency stop on ESTOP (or releases it): sirupp-hardware stops the real motors\n"
    "abruptly and turns them off, sirupp-control aborts its plan and holds. Release never starts\n"
    "a motion: arm (and link) again afterwards. Prints what the bridge reports, if one runs.\n";

namespace {

using sirupp::hardware_command_t;
using sirupp::hardware_status_t;
using Clock = std::chrono::steady_clock;

struct Verb {
  const char* name;
  int8_t command;
  // Whether a status shows the command done.
  std::function<bool(const hardware_status_t&)> done;
};

const std::vector<Verb>& Verbs() {
  static const std::vector<Verb> verbs = {
      {"connect", hardware_command_t::COMMAND_CONNECT,
       [](const hardware_status_t& s) { return s.state == hardware_status_t::STATE_CONNECTED; }},
      {"calibrate", hardware_command_t::COMMAND_CALIBRATE,
       [](const hardware_status_t& s) { return s.calibrated == 1; }},
      {"arm", hardware_command_t::COMMAND_ARM,
       [](const hardware_status_t& s) { return s.state == hardware_status_t::STATE_ARMED; }},
      {"disarm", hardware_command_t::COMMAND_DISARM,
       [](const hardware_status_t& s) { return s.state == hardware_status_t::STATE_CONNECTED; }},
      {"link", hardware_command_t::COMMAND_LINK,
       [](const hardware_status_t& s) { return s.state == hardware_status_t::STATE_LINKED; }},
      {"unlink", hardware_command_t::COMMAND_UNLINK,
       [](const hardware_status_t& s) { return s.state == hardware_status_t::STATE_ARMED; }},
      {"home", hardware_command_t::COMMAND_HOME,
       [](const hardware_status_t& s) {
         return s.state == hardware_status_t::STATE_ARMED ||
                s.state == hardware_status_t::STATE_LINKED;
       }},
      {"clear-faults", hardware_command_t::COMMAND_CLEAR_FAULTS,
       [](const hardware_status_t& s) { return s.state != hardware_status_t::STATE_FAULT; }},
  };
  return verbs;
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

std::string Sender() {
  char host[256] = {};
  ::gethostname(host, sizeof host - 1);
  return "sirupp CLI (pid " + std::to_string(::getpid()) + "@" + host + ")";
}

// The newest HARDWARE_STATUS, kept up to date while Until() handles messages.
class StatusWatch {
 public:
  explicit StatusWatch(core::Bus& bus) : bus_(bus) {
    bus_.Subscribe<hardware_status_t>(
        core::Channels{}.hardware_status,
        [this](const hardware_status_t& m, const core::ReceiveInfo&) { status = m; });
  }
  bool Until(const std::function<bool()>& done, double timeout_s) {
    return HandleUntil(bus_, done, timeout_s);
  }
  std::optional<hardware_status_t> status;

 private:
  core::Bus& bus_;
};

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
  const Args parsed(std::vector<std::string>(args.begin() + 1, args.end()), "hardware " + verb,
                    WithRigFlags({{"timeout", "seconds to wait for the bridge"}}));
  const double timeout = TimeoutFrom(parsed, 5);
  core::Bus bus = BusFromArgs(parsed);
  StatusWatch watch(bus);
  const std::string channel = bus.FullName(core::Channels{}.hardware_status);
  if (verb == "status") {
    if (!watch.Until([&] { return watch.status.has_value(); }, timeout)) {
      out << "no " << channel << " within " << timeout << " s on " << bus.url()
          << ": is sirupp-hardware running (same --lcm-url and --prefix)?\n";
      return 1;
    }
    PrintStatus(*watch.status, out);
    return 0;
  }
  const Verb* chosen = nullptr;
  for (const Verb& v : Verbs()) {
    if (verb == v.name) chosen = &v;
  }
  if (!chosen) {
    throw core::UsageError("hardware: unknown command '" + verb +
                           "'; allowed: connect, calibrate, arm, disarm, link, unlink, home, "
                           "clear-faults, status");
  }
  // The bridge's present status first, so its answer can be told from what it said before.
  if (!watch.Until([&] { return watch.status.has_value(); }, std::min(timeout, 2.0))) {
    out << "no " << channel << " within " << std::min(timeout, 2.0) << " s on " << bus.url()
        << ": is sirupp-hardware running (same --lcm-url and --prefix)?\n";
    return 1;
  }
  const int64_t base_seq = watch.status->seq;
  const std::string base_error = watch.status->last_error;
  hardware_command_t c{};
  c.utime = WallMicros();
  c.command = chosen->command;
  c.sender = Sender();
  bus.Publish(core::Channels{}.hardware_command, c);
  const std::string refusal = "channel " + bus.FullName(core::Channels{}.hardware_command) + ":";
  bool refused = false;
  const bool answered = watch.Until(
      [&] {
        if (watch.status->seq <= base_seq) return false;
        const std::string& e = watch.status->last_error;
        if (e.rfind(refusal, 0) == 0 && e != base_error) return refused = true;
        return chosen->done(*watch.status);
      },
      timeout);
  if (refused) {
    out << "refused by sirupp-hardware: " << watch.status->last_error << "\n";
    return 1;
  }
  if (!answered) {
    out << verb << ": the bridge did not get there within " << timeout << " s\n";
    PrintStatus(*watch.status, out);
    return 1;
  }
  out << verb << ": done; bridge " << StateName(watch.status->state) << "\n";
  return 0;
}

int RunEstop(const std::vector<std::string>& args, std::ostream& out) {
  const Args parsed(args, "estop",
                    WithRigFlags({{"release", "release the stop"}, {"reason", "why, one line"}}));
  const bool release = parsed.Switch("release");
  core::Bus bus = BusFromArgs(parsed);
  StatusWatch watch(bus);
  sirupp::estop_t m{};
  m.utime = WallMicros();
  m.engaged = release ? 0 : 1;
  m.sender = Sender();
  m.reason =
      parsed.Has("reason") ? parsed.String("reason") : (release ? "released" : "sirupp estop");
  bus.Publish(core::Channels{}.estop, m);
  out << (release ? "released " : "engaged ") << bus.FullName(core::Channels{}.estop) << "\n";
  const bool heard = watch.Until(
      [&] {
        return watch.status &&
               (watch.status->state == hardware_status_t::STATE_ESTOPPED) == !release;
      },
      2.0);
  if (heard) {
    out << "bridge: " << StateName(watch.status->state) << "\n";
  } else {
    out << "no bridge confirmed it within 2 s (none running, or it is on another --prefix)\n";
  }
  return 0;
}

}  // namespace sirupp::tools
