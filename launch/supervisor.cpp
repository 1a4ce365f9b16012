#include "launch/supervisor.hpp"

#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <deque>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <ostream>
#include <sirupp/heartbeat_t.hpp>
#include <sstream>
#include <thread>

#include "core/bus.hpp"
#include "core/channels.hpp"
#include "core/errors.hpp"
#include "core/signal_name.hpp"
#include "proc/child.hpp"
#include "runtime/log_prefix.hpp"

namespace sirupp::launch {

namespace fs = std::filesystem;

struct Supervisor::Child {
  ProcessSpec spec;
  std::vector<std::string> command;  // expanded, LCM flags added, program resolved
  std::string log_file;
  proc::Child process;
  pid_t pid = 0;                  // process.pid() while it runs, else 0
  std::string state = "waiting";  // waiting, starting, running, done, failed, stopped, restarting
  Clock::time_point started{};
  Clock::time_point restart_at{};
  bool restart_pending = false;
  int restarts = 0;
  bool ever_started = false;
  std::vector<pid_t> pids;  // every pid it has had, so old heartbeats are not taken for others
};

struct Supervisor::Heard {
  sirupp::heartbeat_t beat;
  Clock::time_point when;
};

namespace {

// The launcher's own lines (its event log, launch.log, and what it notes in each process's log):
// the same time, name and level prefix as every process's lines (runtime/log_prefix.hpp).
std::string LaunchLogLine(const std::string& text) {
  return runtime::FormatLogLine(std::chrono::system_clock::now(), "sirupp-launch", text);
}

const char* HeartbeatState(int8_t state) {
  switch (state) {
    case sirupp::heartbeat_t::STATE_STARTING:
      return "starting";
    case sirupp::heartbeat_t::STATE_RUNNING:
      return "running";
    case sirupp::heartbeat_t::STATE_DEGRADED:
      return "degraded";
    case sirupp::heartbeat_t::STATE_FAULT:
      return "FAULT";
    case sirupp::heartbeat_t::STATE_STOPPING:
      return "stopping";
  }
  return "?";
}

std::string DescribeStatus(int status) {
  if (WIFEXITED(status)) return "exit code " + std::to_string(WEXITSTATUS(status));
  if (WIFSIGNALED(status)) {
    return "killed by " + core::SignalName(WTERMSIG(status));
  }
  return "status " + std::to_string(status);
}

bool CleanExit(int status) { return WIFEXITED(status) && WEXITSTATUS(status) == 0; }

double Seconds(std::chrono::steady_clock::duration d) {
  return std::chrono::duration<double>(d).count();
}

}  // namespace

std::string ResolveProgram(const std::string& program, const std::string& bin_dir) {
  if (program.find('/') != std::string::npos) return program;
  if (!bin_dir.empty()) {
    const fs::path candidate = fs::path(bin_dir) / program;
    if (::access(candidate.c_str(), X_OK) == 0) return candidate.string();
  }
  const char* path = std::getenv("PATH");
  std::istringstream dirs(path ? path : "/usr/local/bin:/usr/bin:/bin");
  for (std::string dir; std::getline(dirs, dir, ':');) {
    if (dir.empty()) continue;
    const fs::path candidate = fs::path(dir) / program;
    if (::access(candidate.c_str(), X_OK) == 0) return candidate.string();
  }
  return "";
}

Supervisor::Supervisor(Layout layout, SupervisorOptions options)
    : layout_(std::move(layout)), options_(std::move(options)) {
  const std::vector<std::pair<std::string, std::string>> base = {{"RUN_DIR", options_.run_dir},
                                                                 {"LAB", layout_.lab},
                                                                 {"HOST", options_.host},
                                                                 {"LCM_URL", layout_.lcm_url},
                                                                 {"PREFIX", layout_.prefix}};
  for (const auto& v : base) options_.variables.push_back(v);
  for (const ProcessSpec& spec : layout_.ProcessesOn(options_.host)) {
    auto child = std::make_unique<Child>();
    child->spec = spec;
    child->command = CommandOf(spec);  // throws ConfigError at the entry's line
    child->log_file = (fs::path(options_.run_dir) / "logs" / (spec.name + ".log")).string();
    children_.push_back(std::move(child));
  }
  bus_ = std::make_unique<core::Bus>(layout_.lcm_url, layout_.prefix);
  bus_->Subscribe<sirupp::heartbeat_t>(
      core::Channels{}.heartbeat,
      [this](const sirupp::heartbeat_t& beat, const core::ReceiveInfo&) {
        const std::string key = beat.process + "@" + beat.host + "#" + std::to_string(beat.pid);
        std::unique_ptr<Heard>& slot = heard_[key];
        if (!slot) slot = std::make_unique<Heard>();
        slot->beat = beat;
        slot->when = Clock::now();
      },
      256);
}

Supervisor::~Supervisor() { Stop(); }

std::vector<std::string> Supervisor::CommandOf(const ProcessSpec& spec) const {
  std::vector<std::string> command;
  try {
    for (const std::string& word : spec.command) {
      command.push_back(Expand(word, options_.variables));
    }
  } catch (const std::invalid_argument& e) {
    throw core::ConfigError({layout_.file, spec.line, 0}, "processes." + spec.name + ".run",
                            e.what());
  }
  const std::string program = ResolveProgram(command.front(), options_.bin_dir);
  if (program.empty()) {
    throw core::ConfigError({layout_.file, spec.line, 0}, "processes." + spec.name + ".run",
                            "program '" + command.front() + "' not found in " +
                                (options_.bin_dir.empty() ? "" : options_.bin_dir + " or ") +
                                "PATH; build it (scripts/build.sh) or give its path");
  }
  command.front() = program;
  if (spec.lcm) {
    if (!layout_.lcm_url.empty()) {
      command.push_back("--lcm-url");
      command.push_back(layout_.lcm_url);
    }
    if (!layout_.prefix.empty()) {
      command.push_back("--prefix");
      command.push_back(layout_.prefix);
    }
  }
  return command;
}

pid_t Supervisor::PidOf(const std::string& name) const {
  for (const auto& c : children_) {
    if (c->spec.name == name) return c->pid;
  }
  return 0;
}

void Supervisor::Event(const std::string& line) const {
  if (options_.events)
    *options_.events << LaunchLogLine("[" + options_.host + "] " + line) << std::endl;
}

void Supervisor::NoteInLog(const Child& child, const std::string& line) const {
  std::ofstream log(child.log_file, std::ios::app);
  log << LaunchLogLine(line) << "\n";
}

std::string Supervisor::LogTail(const Child& child) const {
  // The last lines before a usage text (a program that refused its arguments prints its error,
  // then its usage), else the last lines of the file.
  std::ifstream in(child.log_file);
  std::deque<std::string> lines;
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("usage: ", 0) == 0) break;
    lines.push_back(line);
    if (lines.size() > 4) lines.pop_front();
  }
  std::string out;
  for (const std::string& l : lines) out += "\n    | " + l;
  return out;
}

bool Supervisor::Spawn(Child& child) {
  std::string command_line;
  for (const std::string& w : child.command) command_line += (command_line.empty() ? "" : " ") + w;
  proc::ProcessSpec spec;
  spec.argv = child.command;
  spec.log_path = child.log_file;
  spec.death_signal = SIGTERM;  // no process outlives its launcher
  spec.exec_failed_line = LaunchLogLine("error: exec failed: " + command_line);
  NoteInLog(child, "starting " + child.spec.name + ": " + command_line);
  try {
    child.process.Start(spec);  // its own group: the terminal's Ctrl-C reaches the launcher only
  } catch (const std::exception& e) {
    failures_.push_back(child.spec.name + ": " + e.what());
    Event(failures_.back());
    return false;
  }
  const pid_t pid = child.process.pid();
  child.pid = pid;
  child.pids.push_back(pid);
  child.started = Clock::now();
  child.state = "starting";
  child.ever_started = true;
  Event("started " + child.spec.name + " (pid " + std::to_string(pid) + "): " + command_line);
  return true;
}

const Supervisor::Heard* Supervisor::HeardFrom(const Child& child) const {
  for (const auto& [key, heard] : heard_) {
    if (heard->beat.pid == child.pid && heard->beat.host == options_.machine) return heard.get();
  }
  return nullptr;
}

// Ready: its newest heartbeat says it is no longer starting (a process that heartbeats says
// STATE_STARTING until it takes commands: the bridge through its start guard).
bool Supervisor::HeardReady(const Child& child) const {
  const Heard* heard = HeardFrom(child);
  return heard != nullptr && heard->beat.state != sirupp::heartbeat_t::STATE_STARTING;
}

std::string Supervisor::NotReadyWhy(const Child& child) const {
  const Heard* heard = HeardFrom(child);
  if (heard == nullptr) return "no heartbeat from pid " + std::to_string(child.pid);
  return "its heartbeat still says starting" +
         (heard->beat.detail.empty() ? std::string() : ": " + heard->beat.detail);
}

bool Supervisor::WaitReady(Child& child, const std::function<bool()>& keep_going) {
  const auto deadline =
      child.started + std::chrono::duration_cast<Clock::duration>(
                          std::chrono::duration<double>(child.spec.ready_timeout_s));
  if (child.spec.ready == Ready::kStarted) {  // ready once started, even if it ends at once
    child.state = "running";
    return true;
  }
  while (true) {
    Reap();
    if (child.pid == 0) {
      failures_.push_back(child.spec.name + ": ended before it was ready (" + child.state + ")");
      return false;
    }
    bool ready = false;
    switch (child.spec.ready) {
      case Ready::kStarted:  // handled above
        ready = true;
        break;
      case Ready::kFile:
        ready = fs::exists(Expand(child.spec.ready_file, options_.variables));
        break;
      case Ready::kHeartbeat:
        ready = HeardReady(child);
        break;
    }
    if (ready) {
      child.state = "running";
      Event(child.spec.name + " is ready after " +
            core::FormatApprox(Seconds(Clock::now() - child.started)) + " s");
      return true;
    }
    if (Clock::now() > deadline) {
      failures_.push_back(child.spec.name + ": not ready within " +
                          core::FormatNumber(child.spec.ready_timeout_s) + " s (" +
                          (child.spec.ready == Ready::kHeartbeat
                               ? NotReadyWhy(child)
                               : "no file " + child.spec.ready_file) +
                          ")" + LogTail(child));
      Event(failures_.back());
      return false;
    }
    if (keep_going && !keep_going()) return false;
    HandleHeartbeats(50);
  }
}

bool Supervisor::Start(const std::function<bool()>& keep_going) {
  Event("lab " + layout_.lab + ", host " + options_.host + ": " + std::to_string(children_.size()) +
        " processes; output in " + options_.run_dir + "/logs; LCM " +
        (layout_.lcm_url.empty() ? "default URL" : layout_.lcm_url) +
        (layout_.prefix.empty() ? "" : ", prefix " + layout_.prefix));
  for (auto& child : children_) {
    if (keep_going && !keep_going()) {
      Stop();
      return false;
    }
    if (!fs::exists(child->command.front())) {
      failures_.push_back(child->spec.name + ": program " + child->command.front() + " is gone");
      Event(failures_.back());
      Stop();
      return false;
    }
    if (!Spawn(*child) || !WaitReady(*child, keep_going)) {
      Stop();
      return false;
    }
  }
  return true;
}

void Supervisor::Ended(Child& child, int status) {
  const double ran = Seconds(Clock::now() - child.started);
  const std::string how = DescribeStatus(status);
  NoteInLog(child, child.spec.name + " (pid " + std::to_string(child.pid) + ") ended: " + how);
  child.pid = 0;
  if (stopping_) {
    child.state = "stopped";
    return;
  }
  const bool clean = CleanExit(status);
  if (!clean) {
    failures_.push_back(child.spec.name + ": " + how + " after " + core::FormatApprox(ran) + " s");
  }
  const bool again = child.spec.restart == Restart::kAlways ||
                     (child.spec.restart == Restart::kOnFailure && !clean);
  if (again && child.restarts < child.spec.max_restarts) {
    child.state = "restarting";
    child.restart_pending = true;
    child.restart_at = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                          std::chrono::duration<double>(options_.restart_delay_s));
    Event(child.spec.name + " ended (" + how + "); restart " + std::to_string(child.restarts + 1) +
          " of " + std::to_string(child.spec.max_restarts) + " in " +
          core::FormatNumber(options_.restart_delay_s) + " s" + LogTail(child));
    return;
  }
  child.state = clean ? "done" : "failed";
  Event(child.spec.name + " ended (" + how + ")" + (again ? "; no restart left" : "") +
        (clean ? "" : LogTail(child)));
  if (child.spec.critical) {
    critical_ended_ = true;
    Event(child.spec.name + " is critical: stopping this host's processes");
  }
}

void Supervisor::Reap() {
  for (auto& child : children_) {
    if (child->pid == 0) continue;
    if (!child->process.Running()) Ended(*child, child->process.status());
  }
}

void Supervisor::HandleHeartbeats(int wait_ms) {
  const auto until = Clock::now() + std::chrono::milliseconds(wait_ms);
  while (true) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(until - Clock::now());
    if (left.count() <= 0) break;
    try {
      if (bus_->Handle(static_cast<int>(left.count())) > 0) bus_->HandleAvailable();
    } catch (const core::BusError&) {
      if (errno == EINTR) return;  // a signal (Ctrl-C): the caller decides what comes next
      throw;
    }
  }
}

bool Supervisor::Service(int wait_ms) {
  Reap();
  for (auto& child : children_) {
    if (child->restart_pending && Clock::now() >= child->restart_at && !stopping_) {
      child->restart_pending = false;
      ++child->restarts;
      Spawn(*child);
    }
    if (child->state == "starting" && child->pid != 0) {
      if (child->spec.ready != Ready::kHeartbeat || HeardReady(*child)) child->state = "running";
    }
  }
  HandleHeartbeats(wait_ms);
  Reap();
  return !critical_ended_;
}

void Supervisor::Stop() {
  if (stopping_) return;
  stopping_ = true;
  for (auto& child : children_) child->restart_pending = false;
  // One at a time, last started first, each gone before the next is asked: the order of the
  // layout is the order of dependence (sirupp-hardware must stop the motors through the boards'
  // emulator before the emulator ends, as a real arm's boards outlive the bridge).
  for (auto it = children_.rbegin(); it != children_.rend(); ++it) {
    Child& child = **it;
    if (child.pid == 0) continue;
    child.state = "stopping";
    // SIGINT to its group, SIGKILL after the timeout; back when nothing of the group is left.
    const bool ended = child.process.Stop(child.spec.stop_timeout_s, SIGINT);
    const int status = child.process.status();
    if (ended) {
      const std::string how = DescribeStatus(status);
      const bool fine = CleanExit(status) || (WIFSIGNALED(status) && WTERMSIG(status) == SIGINT);
      if (!fine) failures_.push_back(child.spec.name + ": stopped with " + how);
      NoteInLog(child, child.spec.name + " (pid " + std::to_string(child.pid) +
                           ") ended: stopped (" + how + ")");
      Event("stopped " + child.spec.name + " (" + how + ")");
      child.state = "stopped";
    } else {
      NoteInLog(child, "error: " + child.spec.name + " (pid " + std::to_string(child.pid) +
                           ") ended: did not stop within " +
                           core::FormatNumber(child.spec.stop_timeout_s) + " s of SIGINT; killed");
      failures_.push_back(child.spec.name + ": did not stop within " +
                          core::FormatNumber(child.spec.stop_timeout_s) + " s of SIGINT; killed");
      Event(failures_.back());
      child.state = "killed";
    }
    child.pid = 0;
  }
}

std::vector<ProcessRow> Supervisor::Table() const {
  std::vector<ProcessRow> rows;
  const auto now = Clock::now();
  std::vector<const Heard*> used;
  auto fill = [&](ProcessRow& row, const Heard& heard) {
    const sirupp::heartbeat_t& b = heard.beat;
    for (const sirupp::channel_stats_t& c : b.channels) {
      (c.publishing ? row.out_hz : row.in_hz) += c.rate_hz;
      row.rejected += c.rejected + c.decode_errors;
      row.late += c.late;
    }
    row.detail = b.detail;
    row.uptime_s = b.uptime_s;
  };
  for (const auto& child : children_) {
    ProcessRow row;
    row.name = child->spec.name;
    row.host = options_.host;
    row.pid = child->pid;
    row.restarts = child->restarts;
    row.ours = true;
    row.state = child->state;
    if (child->pid != 0) row.uptime_s = Seconds(now - child->started);
    const Heard* latest = nullptr;
    for (const auto& [key, heard] : heard_) {
      if (heard->beat.host != options_.machine) continue;
      if (child->pid != 0 && heard->beat.pid == child->pid) latest = heard.get();
    }
    for (const auto& [key, heard] : heard_) {
      // every pid this child ever had is ours, so restarts do not show up as other processes
      const std::vector<pid_t>& pids = child->pids;
      if (heard->beat.host == options_.machine &&
          std::find(pids.begin(), pids.end(), heard->beat.pid) != pids.end()) {
        used.push_back(heard.get());
      }
    }
    if (latest) {
      fill(row, *latest);
      if (child->state == "running") {
        row.state = Seconds(now - latest->when) > options_.silent_after_s
                        ? "silent"
                        : HeartbeatState(latest->beat.state);
      }
    }
    rows.push_back(row);
  }
  // Processes heard on the bus that this supervisor did not start (other hosts, other launchers).
  for (const auto& [key, heard] : heard_) {
    if (std::find(used.begin(), used.end(), heard.get()) != used.end()) continue;
    const double age = Seconds(now - heard->when);
    if (age > 10 * options_.silent_after_s) continue;  // long gone
    ProcessRow row;
    row.name = heard->beat.process;
    row.host = heard->beat.host;
    row.pid = heard->beat.pid;
    row.state = age > options_.silent_after_s ? "silent" : HeartbeatState(heard->beat.state);
    fill(row, *heard);
    rows.push_back(row);
  }
  return rows;
}

std::string FormatTable(const std::vector<ProcessRow>& rows) {
  std::ostringstream out;
  out << std::left << std::setw(20) << "process" << std::setw(12) << "host" << std::right
      << std::setw(8) << "pid"
      << "  " << std::left << std::setw(11) << "state" << std::right << std::setw(9) << "up s"
      << std::setw(5) << "rst" << std::setw(10) << "in/s" << std::setw(10) << "out/s"
      << std::setw(9) << "rejected" << std::setw(7) << "late"
      << "  detail\n";
  for (const ProcessRow& r : rows) {
    std::ostringstream up, in, outr;
    up << std::fixed << std::setprecision(1) << r.uptime_s;
    in << std::fixed << std::setprecision(0) << r.in_hz;
    outr << std::fixed << std::setprecision(0) << r.out_hz;
    std::string detail = r.detail;
    if (detail.size() > 60) detail = detail.substr(0, 57) + "...";
    // Names and hosts are cut to their columns, so one long name cannot shift the row.
    std::string name = r.ours ? r.name : "(" + r.name + ")";
    if (name.size() > 19) name = name.substr(0, 18) + "~";
    std::string host = r.host.size() > 11 ? r.host.substr(0, 10) + "~" : r.host;
    out << std::left << std::setw(20) << name << std::setw(12) << host << std::right << std::setw(8)
        << (r.pid ? std::to_string(r.pid) : "-") << "  " << std::left << std::setw(11) << r.state
        << std::right << std::setw(9) << up.str() << std::setw(5)
        << (r.ours ? std::to_string(r.restarts) : "") << std::setw(10) << in.str() << std::setw(10)
        << outr.str() << std::setw(9) << r.rejected << std::setw(7) << r.late << "  " << detail
        << "\n";
  }
  return out.str();
}

}  // namespace sirupp::launch
