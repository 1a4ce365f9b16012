// bench_system: the whole system on this machine, started from a lab layout by the same supervisor
// as `sirupp launch`.
//   1. lockstep: sirupp-sim (lockstep) + sirupp-control + sirupp-logger + sirupp-viewer, the arm
//      running movement set VII over and over: ticks per second, as a multiple of real time.
//   2. realtime at the servo rate (1953 Hz for the PUMA 260) for --seconds (default 60) with the
//      emulated real arm linked (sirupp-picservo-emu + sirupp-hardware) as well: the real-time
//      factor reached (sim time / wall time, goal >= 0.99 at idle), the sim time slipped, the
//      ticks braked for a silent participant and the ticks stepped with a stale effort (0 in the
//      gated realtime mode by construction; counted from SIM_STATUS and the heartbeat).
//   3. the same with one CPU-bound loop per core at normal priority (a browser, an IDE, a build
//      beside it), unless --no-load: the factor it reaches under load.
//   Sim and controller run at normal priority (as the shipped layouts); --rt asks for
//   --rt-priority 50 for them (SCHED_FIFO, granted to root).
//   For each phase: CPU share (of one core) and resident memory of every process.
// Prints figures only; it passes or fails nothing. Run it on a quiet machine.
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <optional>
#include <sirupp/heartbeat_t.hpp>
#include <sirupp/sim_status_t.hpp>
#include <sstream>
#include <string>
#include <thread>

#include "core/bus.hpp"
#include "core/channels.hpp"
#include "launch/layout.hpp"
#include "launch/supervisor.hpp"
#include "proc/rig.hpp"

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
using sirupp::launch::Supervisor;

double Since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

struct ProcSample {
  double cpu_s = 0;  // user + system time
  long rss_kib = 0;
  long hwm_kib = 0;
};

ProcSample Sample(pid_t pid) {
  ProcSample s;
  std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
  std::string text;
  std::getline(stat, text);  // one line
  const size_t close = text.rfind(')');
  if (close != std::string::npos) {
    std::istringstream rest(text.substr(close + 2));
    std::string field;
    unsigned long long utime = 0, stime = 0;
    for (int i = 3; i <= 15 && rest >> field; ++i) {
      if (i == 14) utime = std::stoull(field);
      if (i == 15) stime = std::stoull(field);
    }
    s.cpu_s = static_cast<double>(utime + stime) / static_cast<double>(::sysconf(_SC_CLK_TCK));
  }
  std::ifstream status("/proc/" + std::to_string(pid) + "/status");
  for (std::string line; std::getline(status, line);) {
    if (line.rfind("VmRSS:", 0) == 0) s.rss_kib = std::stol(line.substr(6));
    if (line.rfind("VmHWM:", 0) == 0) s.hwm_kib = std::stol(line.substr(6));
  }
  return s;
}

bool g_rt = false;  // --rt: sim and controller under SCHED_FIFO 50

std::string Layout(const std::string& url, bool realtime, const std::string& bin,
                   const std::string& plan) {
  std::ostringstream y;
  y << "lab: bench-system\nlcm_url: " << url << "\nprocesses:\n";
  if (realtime) {
    y << "  - name: emulator\n    run: sirupp-picservo-emu --link ${RUN_DIR}/bus --start-pose "
         "ready\n"
         "    lcm: false\n    ready: file\n    ready_file: ${RUN_DIR}/bus\n";
    y << "  - name: sim\n    run: sirupp-sim --mode realtime --pose ready"
      << (g_rt ? " --rt-priority 50" : "") << "\n";
  } else {
    y << "  - name: sim\n    run: sirupp-sim --mode lockstep --pose ready\n";
  }
  y << "  - name: control\n    run: sirupp-control" << (realtime && g_rt ? " --rt-priority 50" : "")
    << "\n";
  if (realtime) {
    y << "  - name: hardware\n    run: sirupp-hardware --port ${RUN_DIR}/bus --emulated "
         "--calibrate --arm --link\n";
  }
  y << "  - name: logger\n    run: sirupp-logger --out ${RUN_DIR}/data\n";
  y << "  - name: viewer\n    run: sirupp-viewer\n";
  // The arm keeps moving: movement set VII again and again (after the bridge's start guard).
  y << "  - name: plans\n    run: [sh, -c, 'sleep 2.5; while " << bin << "/sirupp plan run " << plan
    << " --wait --lcm-url \"" << url << "\" >/dev/null; do :; done']\n    lcm: false\n";
  return y.str();
}

struct Window {
  int64_t ticks = 0;
  int64_t batches = 0;  // SIM_ARM_TICKS: ticks sent 16 at a time (docs/timing.md)
  int64_t late = 0;
};

// The sim's own counters from its heartbeat: states sent alone, batches and late commands.
Window SimCounters(const sirupp::heartbeat_t& beat, const std::string& state_channel,
                   const std::string& command_channel) {
  Window w;
  const std::string batch_channel = sirupp::core::Channels{}.sim_arm_ticks.name();
  for (const auto& c : beat.channels) {
    if (c.publishing && c.channel == state_channel) w.ticks = c.messages;
    if (c.publishing && c.channel == batch_channel) w.batches = c.messages;
    if (!c.publishing && c.channel == command_channel) w.late = c.late;
  }
  return w;
}

// One CPU-bound process per core at normal priority, ended by the destructor.
class BusyLoops {
 public:
  explicit BusyLoops(bool on) {
    if (!on) return;
    for (long i = 0; i < ::sysconf(_SC_NPROCESSORS_ONLN); ++i) {
      const pid_t pid = ::fork();
      if (pid == 0) {
        volatile unsigned long spin = 0;
        for (;;) spin = spin + 1;
      }
      if (pid > 0) pids_.push_back(pid);
    }
  }
  ~BusyLoops() {
    for (pid_t pid : pids_) ::kill(pid, SIGKILL);
    for (pid_t pid : pids_) ::waitpid(pid, nullptr, 0);
  }
  BusyLoops(const BusyLoops&) = delete;
  BusyLoops& operator=(const BusyLoops&) = delete;

 private:
  std::vector<pid_t> pids_;
};

int RunPhase(const char* title, bool realtime, double seconds, const std::string& bin,
             const std::string& url, const fs::path& dir, double servo_hz, bool load = false) {
  std::cout << "\n== " << title << " ==\n";
  const BusyLoops busy(load);
  const sirupp::launch::Layout layout = sirupp::launch::ParseLayout(
      Layout(url, realtime, bin, fs::absolute("config/plans/set7.plan").string()), "bench");
  sirupp::launch::SupervisorOptions o;
  o.host = "local";
  char host[256] = {};
  ::gethostname(host, sizeof host - 1);
  o.machine = host;
  o.bin_dir = bin;
  o.run_dir = (dir / (realtime ? (load ? "realtime-load" : "realtime") : "lockstep")).string();
  std::ostringstream events;
  o.events = &events;
  Supervisor supervisor(layout, o);
  if (!supervisor.Start(nullptr)) {
    std::cout << "could not start the system:\n" << events.str();
    return 1;
  }
  const sirupp::core::Channels names;
  std::map<std::string, sirupp::heartbeat_t> beats;
  std::optional<sirupp::sim_status_t> sim_status;
  // Only supervises for s seconds: this program is off the bus, so it does not receive every
  // datagram of the loop it measures (each process on udpm gets every datagram of the group).
  auto idle = [&](double s) {
    const auto until = Clock::now() + std::chrono::duration<double>(s);
    while (Clock::now() < until) {
      supervisor.Service(0);
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  };
  // On the bus for s seconds: the newest heartbeats and SIM_STATUS (about 1 Hz each), taken in
  // 20 ms batches.
  auto pump = [&](double s) {
    sirupp::core::Bus bus(url);
    bus.Subscribe<sirupp::heartbeat_t>(
        names.heartbeat, [&](const sirupp::heartbeat_t& b, const sirupp::core::ReceiveInfo&) {
          beats[b.process] = b;
        });
    bus.Subscribe<sirupp::sim_status_t>(
        names.sim_status,
        [&](const sirupp::sim_status_t& m, const sirupp::core::ReceiveInfo&) { sim_status = m; });
    const auto until = Clock::now() + std::chrono::duration<double>(s);
    while (Clock::now() < until) {
      supervisor.Service(0);
      bus.HandleBatched(20);
    }
  };
  idle(2.8);  // start-up, first plan under way
  pump(1.2);  // a heartbeat and a SIM_STATUS to start the window from
  const std::vector<std::string> order =
      realtime
          ? std::vector<std::string>{"sim", "control", "hardware", "emulator", "logger", "viewer"}
          : std::vector<std::string>{"sim", "control", "logger", "viewer"};
  std::map<std::string, ProcSample> before;
  for (const std::string& n : order) before[n] = Sample(supervisor.PidOf(n));
  const auto window_start = Clock::now();
  const Window sim_before =
      SimCounters(beats["sirupp-sim"], names.sim_arm_state, names.sim_arm_command);
  const std::optional<sirupp::sim_status_t> status_before = sim_status;
  int64_t shown = 0;
  while (Since(window_start) < seconds) {
    idle(1.0);
    if (++shown % 10 == 0) std::cout << "  " << shown << " s ..." << std::endl;
  }
  pump(1.2);  // one more heartbeat, so its counters cover the window
  const double wall = Since(window_start);
  const Window sim_after =
      SimCounters(beats["sirupp-sim"], names.sim_arm_state, names.sim_arm_command);
  char line[256];
  if (!realtime) {
    // The sim's own tick and clock from its first and last SIM_STATUS (1 Hz) in the window.
    if (!status_before || !sim_status || sim_status->utime <= status_before->utime) {
      std::cout << "lockstep: no SIM_STATUS heard\n";
    } else {
      const double tps = static_cast<double>(sim_status->tick - status_before->tick) /
                         (static_cast<double>(sim_status->utime - status_before->utime) * 1e-6);
      std::snprintf(line, sizeof line,
                    "lockstep: %.0f ticks/s over %.0f s = %.2f x real time (servo rate %.0f Hz)\n",
                    tps, wall, tps / servo_hz, servo_hz);
      std::cout << line;
    }
  } else {
    const int64_t ticks = sim_after.ticks - sim_before.ticks;
    if (!status_before || !sim_status) {
      std::cout << "realtime: no SIM_STATUS heard\n";
    } else {
      const double sim_s = static_cast<double>(sim_status->tick - status_before->tick) / servo_hz;
      const double status_wall =
          static_cast<double>(sim_status->utime - status_before->utime) * 1e-6;
      std::snprintf(line, sizeof line,
                    "realtime%s: real-time factor %.4f (%.1f s of sim time in %.1f s of wall "
                    "time; goal >= 0.99 at idle), %.3f s slipped\n",
                    load ? " under load" : "", sim_s / status_wall, sim_s, status_wall,
                    sim_status->slipped_s - status_before->slipped_s);
      std::cout << line;
    }
    std::snprintf(line, sizeof line,
                  "  %lld states sent alone and %lld batches of ticks; 0 ticks stepped with a "
                  "stale effort (every tick waited for its answer); %lld answers arrived after "
                  "their tick was stepped (re-sent or braked for)\n",
                  static_cast<long long>(ticks),
                  static_cast<long long>(sim_after.batches - sim_before.batches),
                  static_cast<long long>(sim_after.late - sim_before.late));
    std::cout << line;
  }
  std::cout << "  process            CPU (% of one core)   RSS (MiB)   peak RSS (MiB)\n";
  double total = 0;
  for (const std::string& n : order) {
    const ProcSample after = Sample(supervisor.PidOf(n));
    const double cpu = 100.0 * (after.cpu_s - before[n].cpu_s) / wall;
    total += cpu;
    std::snprintf(line, sizeof line, "  %-18s %10.1f %18.1f %14.1f\n", n.c_str(), cpu,
                  static_cast<double>(after.rss_kib) / 1024.0,
                  static_cast<double>(after.hwm_kib) / 1024.0);
    std::cout << line;
  }
  std::snprintf(line, sizeof line, "  %-18s %10.1f   (2 cores = 200 %%)\n", "all", total);
  std::cout << line;
  supervisor.Stop();
  if (!supervisor.failures().empty()) {
    std::cout << "problems:\n";
    for (const std::string& f : supervisor.failures()) std::cout << "  " << f << "\n";
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  double seconds = 60, lockstep_seconds = 10;
  bool with_load = true;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--no-load") {
      with_load = false;
    } else if (a == "--rt") {
      g_rt = true;
    } else if (a == "--seconds" && i + 1 < argc) {
      seconds = std::stod(argv[++i]);
    } else if (a == "--lockstep-seconds" && i + 1 < argc) {
      lockstep_seconds = std::stod(argv[++i]);
    } else {
      std::cerr << "usage: bench_system [--seconds S (60)] [--lockstep-seconds S (10)] [--no-load] "
                   "[--rt]\n"
                   "Run from the source root, after building (scripts/build.sh).\n";
      return a == "--help" ? 0 : 2;
    }
  }
  const std::string bin = fs::canonical("/proc/self/exe").parent_path().string();
  const std::string url = sirupp::proc::RigUrl(20000 + ::getpid() % 20000);
  const fs::path dir = fs::temp_directory_path() / ("bench-system-" + std::to_string(::getpid()));
  std::cout << "bench_system: the whole system on this machine (" << ::sysconf(_SC_NPROCESSORS_ONLN)
            << " cores), bus " << url << "\n";
  const double servo_hz = 1.0 / 0.000512;
  int rc = RunPhase("lockstep, as fast as the loop goes", false, lockstep_seconds, bin, url, dir,
                    servo_hz);
  rc |= RunPhase("realtime at the servo rate, emulated real arm linked", true, seconds, bin, url,
                 dir, servo_hz);
  if (with_load) {
    rc |= RunPhase("realtime, emulated real arm linked, one busy loop per core", true, seconds, bin,
                   url, dir, servo_hz, true);
  }
  fs::remove_all(dir);
  return rc;
}
