#include "tools/turns_commands.hpp"

#include <poll.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cmath>
#include <iostream>
#include <memory>
#include <sstream>
#include <thread>

#include "core/bus.hpp"
#include "core/errors.hpp"
#include "runtime/args.hpp"
#include "runtime/process_main.hpp"
#include "tools/rig_args.hpp"
#include "turns/turn_manager.hpp"

namespace sirupp::tools {
namespace {

constexpr const char* kTurnsAbout =
    "Shares the one real arm among several rigs by turns (docs/hardware.md, Turns): the bridge\n"
    "(sirupp-hardware) runs on the bus --arm-url; each rig on a bus of its own (--rig\n"
    "NAME=URL ...). The holder's rig is relayed to the bridge, everyone's ESTOP reaches it, and\n"
    "between two turns the arm is held, homed at reduced speed, checked and disarmed. Commands on\n"
    "standard input, one per line: join NAME, leave NAME, done NAME, end, skip NAME, pause,\n"
    "resume, estop NAME, status, may NAME.";

void PrintStatus(const turns::TurnManager& manager, std::ostream& out) {
  const turns::TurnStatus s = manager.status();
  out << "turns: " << turns::PhaseName(s.phase);
  if (!s.holder.empty()) out << ", holder " << s.holder;
  if (s.phase == turns::Phase::kTurn)
    out << " (" << core::FormatApprox(s.turn_left_s) << " s left)";
  if (!s.step.empty()) out << ", step: " << s.step;
  if (s.paused) out << ", paused";
  if (!s.stopped_reason.empty()) out << "\n  stopped: " << s.stopped_reason;
  out << "\n  queue:";
  if (s.queue.empty()) out << " empty";
  for (size_t i = 0; i < s.queue.size(); ++i) {
    out << "\n    " << i + 1 << ". " << s.queue[i].student << " (about "
        << core::FormatApprox(std::round(s.queue[i].estimated_wait_s)) << " s)";
  }
  out << "\n";
}

// One line of the teacher's input.
void Obey(turns::TurnManager& manager, const std::string& line, std::ostream& out) {
  std::istringstream words(line);
  std::string verb;
  std::string name;
  words >> verb >> name;
  if (verb.empty()) return;
  try {
    if (verb == "join") {
      manager.Join(name);
    } else if (verb == "leave") {
      manager.Leave(name);
    } else if (verb == "done") {
      manager.Done(name);
    } else if (verb == "end") {
      manager.EndTurn("the teacher");
    } else if (verb == "skip") {
      manager.Skip(name);
    } else if (verb == "pause") {
      manager.Pause();
    } else if (verb == "resume") {
      manager.Resume();
    } else if (verb == "estop") {
      manager.Estop(name.empty() ? "the teacher" : name, "sirupp turns");
    } else if (verb == "status") {
      PrintStatus(manager, out);
    } else if (verb == "may") {
      const std::string why = manager.MayCommand(name);
      out << name << (why.empty() ? " may command the real arm" : ": " + why) << "\n";
    } else {
      out << "unknown command '" << verb
          << "'; allowed: join NAME, leave NAME, done NAME, end, skip NAME, pause, resume, estop "
             "NAME, status, may NAME\n";
    }
  } catch (const turns::TurnError& error) {
    out << "refused: " << error.what() << "\n";
  }
}

}  // namespace

int RunTurns(const std::vector<std::string>& args, std::istream& in, std::ostream& out,
             std::ostream& err) {
  if (args.empty() || args[0] != "serve") {
    throw core::UsageError("turns: expected 'serve'; see sirupp turns serve --help");
  }
  const std::vector<std::string> rest(args.begin() + 1, args.end());
  const runtime::Args parsed(
      rest, "turns serve",
      {runtime::Flag("arm-url", "the bus of sirupp-hardware (the real arm's bridge)").Takes("URL"),
       runtime::Flag("rig", "each student's rig and its bus").Takes("NAME=URL", -1),
       runtime::Flag("model", "robot model file (home pose, default speeds)").Takes("FILE"),
       runtime::Flag("turn-s", "one turn's length, seconds (default 600)").Takes("S").Above(0),
       runtime::Flag("log", "append one JSON line per event and per turn").Takes("FILE")},
      kTurnsAbout);
  if (!parsed.Has("arm-url")) throw core::UsageError("turns serve: --arm-url URL is needed");
  if (!parsed.Has("rig")) throw core::UsageError("turns serve: --rig NAME=URL ... is needed");
  const core::RobotModel model = ModelFromArgs(parsed);
  turns::TurnOptions options;
  options.turn_s = parsed.Number("turn-s", options.turn_s);
  if (parsed.Has("log")) options.log_path = parsed.String("log");
  options.relay_estop_from_all_rigs = true;
  options.on_event = [&out](const std::string& line) { out << line << "\n" << std::flush; };
  core::Bus arm_bus(parsed.String("arm-url"), "");
  turns::TurnManager manager(arm_bus, model, options);
  for (const std::string& rig : parsed.Values("rig", -1)) {
    const size_t eq = rig.find('=');
    if (eq == std::string::npos || eq == 0 || eq + 1 == rig.size()) {
      throw core::UsageError("turns serve: --rig '" + rig + "': expected NAME=URL");
    }
    const std::string url = rig.substr(eq + 1);
    try {
      manager.AddRig(rig.substr(0, eq), [url] { return std::make_shared<core::Bus>(url, ""); });
    } catch (const turns::TurnError& error) {
      throw core::UsageError(std::string("turns serve: --rig: ") + error.what());
    }
  }
  runtime::InstallStopHandlers();
  out << "sirupp turns: " << parsed.Values("rig", -1).size()
      << " rigs; type 'status' or a command (see --help)\n"
      << std::flush;
  const bool from_terminal = &in == &std::cin;  // standard input: polled
  bool input_open = true;
  std::string line;
  std::string pending;  // standard input read but not yet a whole line
  const auto obey = [&](const std::string& command) {
    Obey(manager, command, out);
    out << std::flush;  // a pipe or file is not line-buffered: the answer now
  };
  while (!runtime::StopRequested()) {
    manager.Service();
    if (input_open && from_terminal) {
      // Read with read(2) what poll(2) says is there, never blocking the relay for a line (lines
      // kept in stdio's buffer by std::getline would be invisible to poll until more came).
      pollfd fd{STDIN_FILENO, POLLIN, 0};
      if (::poll(&fd, 1, 0) > 0) {
        char chunk[4096];
        const ssize_t n = ::read(STDIN_FILENO, chunk, sizeof chunk);
        if (n > 0) {
          pending.append(chunk, static_cast<size_t>(n));
        } else if (n == 0 || (errno != EINTR && errno != EAGAIN)) {
          input_open = false;
          if (!pending.empty()) pending += '\n';  // a last line without its newline
        }
      }
      for (size_t end = pending.find('\n'); end != std::string::npos; end = pending.find('\n')) {
        line = pending.substr(0, end);
        pending.erase(0, end + 1);
        obey(line);
      }
    } else if (input_open) {
      if (std::getline(in, line)) {
        obey(line);
      } else {
        input_open = false;
      }
    }
    const turns::Phase phase = manager.status().phase;
    if (!input_open && (phase == turns::Phase::kIdle || phase == turns::Phase::kStopped) &&
        manager.status().queue.empty()) {
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  (void)err;
  PrintStatus(manager, out);
  return manager.status().phase == turns::Phase::kStopped ? 1 : 0;
}

}  // namespace sirupp::tools
