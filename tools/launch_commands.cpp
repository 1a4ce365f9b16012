#include "tools/launch_commands.hpp"

#include <unistd.h>

#include <chrono>
#include <ctime>
#include <filesystem>
#include <iostream>
#include <memory>
#include <ostream>
#include <sstream>

#include "core/bus.hpp"
#include "core/errors.hpp"
#include "launch/layout.hpp"
#include "launch/supervisor.hpp"
#include "runtime/args.hpp"
#include "runtime/data_path.hpp"
#include "runtime/process_main.hpp"
#include "tools/cli.hpp"

namespace sirupp::tools {

namespace fs = std::filesystem;

const char* const kLaunchAbout =
    "Starts the processes LAYOUT (config/labs/*.yaml) puts on this host, in order, each once the\n"
    "previous is ready, with the layout's LCM URL and channel prefix; restarts those the layout\n"
    "says; shows a status table of every process heard on the bus (its own and other hosts');\n"
    "Ctrl-C stops them all (SIGINT, then SIGKILL after each one's stop_timeout_s).\n"
    "Exit: 0 every process ran and stopped cleanly, 1 one failed, 2 bad layout or arguments.\n"
    "Layouts: config/labs/single-pc.yaml, config/labs/multi-pc.yaml; format in docs/launch.md.\n";

std::string MachineName() {
  char name[256] = {};
  if (::gethostname(name, sizeof name - 1) != 0) return "localhost";
  return name;
}

std::string LocalTimestamp() {
  const std::time_t now = std::time(nullptr);
  std::tm local{};
  ::localtime_r(&now, &local);
  char text[32];
  std::strftime(text, sizeof text, "%Y%m%d-%H%M%S", &local);
  return text;
}

std::string ProgramDir() {
  std::error_code ec;
  const fs::path self = fs::read_symlink("/proc/self/exe", ec);
  return ec ? std::string() : self.parent_path().string();
}

namespace {

// The last `count` lines of `text`.
std::string LastLines(const std::string& text, size_t count) {
  size_t start = text.size();
  for (size_t found = 0; start > 0 && found <= count;) {
    --start;
    if (text[start] == '\n' && start + 1 < text.size()) ++found;
    if (found > count) {
      ++start;
      break;
    }
  }
  return text.substr(start);
}

}  // namespace

namespace {

// A --FLAG of seconds > 0, or `fallback` without it.
double PositiveSecondsArg(const runtime::Args& parsed, const std::string& flag, double fallback) {
  if (!parsed.Has(flag)) return fallback;
  const double seconds = runtime::ParseNumberArg(parsed.String(flag), "--" + flag);
  if (seconds <= 0) throw core::UsageError("--" + flag + ": expected seconds > 0");
  return seconds;
}

// --dry-run: the layout checked, and the command line of each process this host runs.
void PrintDryRun(const std::string& file, const launch::Layout& layout, const std::string& host,
                 const launch::Supervisor& supervisor, std::ostream& out) {
  out << file << ": ok: lab " << layout.lab << ", " << layout.processes.size() << " processes on "
      << layout.hosts.size() << " host(s); host " << host << " runs:\n";
  for (const launch::ProcessSpec& spec : layout.ProcessesOn(host)) {
    std::string line;
    for (const std::string& w : supervisor.CommandOf(spec)) line += " " + w;
    out << "  " << spec.name << " (restart " << launch::RestartName(spec.restart)
        << (spec.critical ? ", critical" : "") << "):" << line << "\n";
  }
}

// How the process table is shown while the processes run.
struct TableDisplay {
  bool tty = false;                    // redrawn in place every second, recent events under it
  double every_s = 10;                 // otherwise printed this often
  const std::ostringstream* recent{};  // the events, when on a terminal
};

// Services the processes until a stop is asked, one of them ends the run, or `duration` s
// (0: no limit) since `started` have passed, showing the table; then the final table.
void Supervise(launch::Supervisor& supervisor, const launch::Layout& layout,
               const std::string& host, std::chrono::steady_clock::time_point started,
               double duration, const TableDisplay& display, std::ostream& out) {
  auto elapsed = [&] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  };
  double next_table = 0;
  while (!runtime::StopRequested() && (duration <= 0 || elapsed() < duration)) {
    if (!supervisor.Service(200)) break;
    if (elapsed() >= next_table) {
      if (display.tty) out << "\033[H\033[J";  // redraw in place, like top
      out << "-- " << layout.lab << " @ " << host << ", " << static_cast<int>(elapsed())
          << " s --\n"
          << launch::FormatTable(supervisor.Table());
      if (display.tty) out << "recent events:\n" << LastLines(display.recent->str(), 8);
      out << std::flush;
      next_table = elapsed() + (display.tty ? 1.0 : display.every_s);
    }
  }
  supervisor.Service(0);
  out << "-- final --\n" << launch::FormatTable(supervisor.Table());
}

}  // namespace

int RunLaunch(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  const runtime::Args parsed(
      args, "launch",
      {runtime::Flag("layout", "a file in config/labs/").Positional("LAYOUT"),
       runtime::Flag("host",
                     "which host of the layout this is (default: the only host, or the one "
                     "named like this machine)")
           .Takes("NAME"),
       runtime::Flag("run-dir",
                     "${RUN_DIR}: the processes' output (DIR/logs/NAME.log) and whatever the "
                     "layout writes there (default runs/LAB-HOST-YYYYmmdd-HHMMSS)")
           .Takes("DIR"),
       runtime::Flag("duration", "stop everything after S seconds").Takes("S"),
       runtime::Flag("status-every",
                     "print the table every S s when the output is not a terminal (default 10; "
                     "on a terminal it is redrawn every second)")
           .Takes("S"),
       runtime::Flag("lcm-url", "instead of the layout's (e.g. one port per team)").Takes("URL"),
       runtime::Flag("prefix", "instead of the layout's (e.g. one prefix per team)")
           .Takes("PREFIX"),
       runtime::Flag("dry-run", "check the layout and print the command lines, start nothing")
           .Switch()},
      kLaunchAbout);
  const std::string file = runtime::ResolveDataPath(parsed.String("layout"));
  const double duration = PositiveSecondsArg(parsed, "duration", 0);
  const double status_every = PositiveSecondsArg(parsed, "status-every", 10);
  launch::Layout layout = launch::LoadLayout(file);
  if (parsed.Has("lcm-url")) layout.lcm_url = parsed.String("lcm-url");
  if (parsed.Has("prefix")) layout.prefix = parsed.String("prefix");
  launch::SupervisorOptions options;
  options.machine = MachineName();
  options.host =
      launch::ChooseHost(layout, parsed.Has("host") ? parsed.String("host") : "", options.machine);
  options.bin_dir = ProgramDir();
  options.run_dir = parsed.Has("run-dir")
                        ? parsed.String("run-dir")
                        : "runs/" + layout.lab + "-" + options.host + "-" + LocalTimestamp();
  // On a terminal the table is redrawn in place; the events (start, ready, exit, restart, stop)
  // are then kept and their latest lines shown under it.
  const bool tty = ::isatty(STDOUT_FILENO) == 1 && &out == &std::cout;
  std::ostringstream recent;
  options.events = tty ? static_cast<std::ostream*>(&recent) : &out;
  // The supervisor checks every command line and opens the bus: a bad URL or prefix (from the
  // flags or the layout) is bad input, exit 2.
  auto make = [&] {
    try {
      return std::make_unique<launch::Supervisor>(layout, options);
    } catch (const core::BusError& e) {
      throw core::UsageError(std::string("launch: ") + e.what());
    }
  };
  if (parsed.Switch("dry-run")) {
    const std::unique_ptr<launch::Supervisor> checked = make();
    PrintDryRun(file, layout, options.host, *checked, out);
    return 0;
  }
  runtime::InstallStopHandlers();
  const std::unique_ptr<launch::Supervisor> owned = make();
  launch::Supervisor& supervisor = *owned;
  const auto started = std::chrono::steady_clock::now();
  const bool up = supervisor.Start([] { return !runtime::StopRequested(); });
  if (tty) out << recent.str();
  if (up) {
    out << "all " << layout.ProcessesOn(options.host).size() << " processes of host "
        << options.host << " are up; Ctrl-C stops them\n";
    Supervise(supervisor, layout, options.host, started, duration, {tty, status_every, &recent},
              out);
  }
  const size_t before_stop = recent.str().size();
  supervisor.Stop();
  if (tty) out << recent.str().substr(before_stop);
  if (supervisor.failures().empty()) {
    out << "every process ran and stopped cleanly; output in " << options.run_dir << "/logs\n";
  } else {
    err << "sirupp launch: " << supervisor.failures().size() << " problem(s):\n";
    for (const std::string& f : supervisor.failures()) err << "  " << f << "\n";
  }
  return supervisor.ExitCode();
}

}  // namespace sirupp::tools
