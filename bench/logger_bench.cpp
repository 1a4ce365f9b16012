// bench_logger: sirupp-logger as a process taking three streams at the servo tick (SIM_ARM_STATE,
// ARM_SETPOINT and REAL_ARM_STATE, 1953.125 Hz each, six joints) over LCM udpm (ttl=0, a port of
// the run's own) for D seconds (60). Prints the messages lost (published minus received, and the
// logger's own count of sequence gaps and overflow), the rows and filled cells in its file, and
// the CPU share it used: (user + system CPU time of the process) / wall time from its start to its
// exit. The goal of issue 7: zero lost samples.
//
// usage: bench_logger [--seconds D] [--port P] [--logger PATH]

#include <signal.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <optional>
#include <sirupp/arm_state_t.hpp>
#include <sirupp/servo_setpoint_t.hpp>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "core/bus.hpp"
#include "logger/data_file.hpp"
#include "proc/rig.hpp"

#ifndef SIRUPP_LOGGER_PATH
#define SIRUPP_LOGGER_PATH "sirupp-logger"
#endif

namespace {

using Clock = std::chrono::steady_clock;
constexpr int kJoints = 6;
constexpr int64_t kTickUs = 512;

std::string LoadAverage() {
  std::ifstream in("/proc/loadavg");
  std::string one, five, fifteen;
  in >> one >> five >> fifteen;
  return one + " " + five + " " + fifteen;
}

int64_t WallMicros() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

struct Options {
  double seconds = 60;
  int port = 7790;
  std::string logger = SIRUPP_LOGGER_PATH;
};

// The options, or nullopt after a message on stderr.
std::optional<Options> ParseOptions(int argc, char** argv) {
  Options options;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--seconds" && i + 1 < argc) {
      options.seconds = std::atof(argv[++i]);
    } else if (arg == "--port" && i + 1 < argc) {
      options.port = std::atoi(argv[++i]);
    } else if (arg == "--logger" && i + 1 < argc) {
      options.logger = argv[++i];
    } else {
      std::cerr << "usage: bench_logger [--seconds D] [--port P] [--logger PATH]\n";
      return std::nullopt;
    }
  }
  if (!(options.seconds > 0)) {
    std::cerr << "bench_logger: --seconds must be > 0\n";
    return std::nullopt;
  }
  return options;
}

// Starts sirupp-logger on `url`, writing bench.csv into `dir` and its stderr to `err_path`; it
// dies with this process.
pid_t StartLogger(const std::string& logger, const std::string& url,
                  const std::filesystem::path& dir, const std::string& err_path) {
  const pid_t parent = getpid();
  const pid_t child = fork();
  if (child < 0) throw std::runtime_error("fork failed");
  if (child == 0) {
    prctl(PR_SET_PDEATHSIG, SIGKILL);
    if (getppid() != parent) _exit(127);
    const std::string out_dir = dir.string();
    std::freopen(err_path.c_str(), "w", stderr);
    execl(logger.c_str(), logger.c_str(), "--lcm-url", url.c_str(), "--out", out_dir.c_str(),
          "--name", "bench", "--split", "none", static_cast<char*>(nullptr));
    _exit(127);
  }
  return child;
}

// Publishes the three streams at the servo tick for `ticks` ticks; returns the seconds it took.
double PublishTicks(const std::string& url, int64_t ticks) {
  sirupp::core::Bus bus(url);
  sirupp::arm_state_t state{};
  state.num_joints = kJoints;
  state.position.assign(kJoints, 0.1);
  state.velocity.assign(kJoints, 0.0);
  state.effort.assign(kJoints, 0.0);
  state.flags.assign(kJoints, 0);
  sirupp::arm_state_t real = state;
  real.source = sirupp::arm_state_t::SOURCE_EMULATED;
  sirupp::servo_setpoint_t setpoint{};
  setpoint.num_joints = kJoints;
  setpoint.move_id = 1;
  for (auto* field : {&setpoint.position, &setpoint.velocity, &setpoint.goal,
                      &setpoint.position_error, &setpoint.effort}) {
    field->assign(kJoints, 0.1);
  }
  setpoint.status.assign(kJoints, sirupp::servo_setpoint_t::STATUS_SERVO_ON);

  const Clock::time_point start = Clock::now();
  for (int64_t tick = 0; tick < ticks; ++tick) {
    const Clock::time_point due = start + std::chrono::microseconds(tick * kTickUs);
    std::this_thread::sleep_until(due);
    const double q = 0.001 * static_cast<double>(tick % 1000);
    state.utime = setpoint.utime = tick * kTickUs;
    state.seq = setpoint.seq = real.seq = tick;
    state.tick = setpoint.tick = real.tick = tick;
    state.position[0] = setpoint.position[0] = q;
    real.position[0] = q + 0.01;
    real.utime = WallMicros();
    bus.Publish("SIM_ARM_STATE", state);
    bus.Publish("ARM_SETPOINT", setpoint);
    bus.Publish("REAL_ARM_STATE", real);
  }
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// The logger's closing line: rows, files, messages and losses per stream (set, virt, real).
struct Summary {
  long long rows = 0, files = 0, got[3] = {0, 0, 0}, lost[3] = {0, 0, 0};
};

std::optional<Summary> ParseSummary(const std::string& text) {
  Summary s;
  const size_t summary = text.find(" rows in ");
  if (summary == std::string::npos ||
      std::sscanf(
          text.c_str() + text.rfind("sirupp-logger info: ", summary),
          "sirupp-logger info: %lld rows in %lld file(s); messages set %lld, virt %lld, real "
          "%lld; lost set %lld, virt %lld, real %lld",
          &s.rows, &s.files, &s.got[0], &s.got[1], &s.got[2], &s.lost[0], &s.lost[1],
          &s.lost[2]) != 8) {
    return std::nullopt;
  }
  return s;
}

int Run(int argc, char** argv) {
  const std::optional<Options> options = ParseOptions(argc, argv);
  if (!options) return 2;
  const double seconds = options->seconds;
  const std::string url = sirupp::proc::RigUrl(options->port);
  char pattern[] = "/tmp/sirupp_bench_logger_XXXXXX";
  const std::filesystem::path dir = mkdtemp(pattern);
  const std::string err_path = (dir / "logger.err").string();
  std::cout << "bench_logger: sirupp-logger taking 3 streams x 1953.125 Hz for " << seconds
            << " s on " << url << "\nload average at start: " << LoadAverage() << "\n";

  const Clock::time_point spawned = Clock::now();
  const pid_t child = StartLogger(options->logger, url, dir, err_path);
  std::this_thread::sleep_for(std::chrono::milliseconds(500));  // let it subscribe
  const int64_t ticks = static_cast<int64_t>(seconds * 1e6 / kTickUs);
  const double publish_s = PublishTicks(url, ticks);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  kill(child, SIGINT);
  int status = 0;
  rusage usage{};
  wait4(child, &status, 0, &usage);
  const double wall_s = std::chrono::duration<double>(Clock::now() - spawned).count();
  const double cpu_s = static_cast<double>(usage.ru_utime.tv_sec + usage.ru_stime.tv_sec) +
                       1e-6 * static_cast<double>(usage.ru_utime.tv_usec + usage.ru_stime.tv_usec);

  std::ifstream err_file(err_path);
  std::stringstream err_text;
  err_text << err_file.rdbuf();
  const std::optional<Summary> summary = ParseSummary(err_text.str());
  if (!summary) {
    std::cerr << "bench_logger: sirupp-logger (exit status " << status << ") did not print its "
              << "summary; its output:\n"
              << err_text.str();
    std::filesystem::remove_all(dir);
    return 1;
  }
  const sirupp::logger::RunTable table = sirupp::logger::ReadDataFile((dir / "bench.csv").string());
  std::filesystem::remove_all(dir);

  const char* names[3] = {"ARM_SETPOINT", "SIM_ARM_STATE", "REAL_ARM_STATE"};
  long long total_lost = 0;
  std::printf("published %lld ticks in %.2f s (%.1f Hz per stream)\n",
              static_cast<long long>(ticks), publish_s, static_cast<double>(ticks) / publish_s);
  for (int s = 0; s < 3; ++s) {
    const long long missing = ticks - summary->got[s];
    total_lost += missing;
    std::printf(
        "  %-15s received %lld, lost %lld (the logger's own count of gaps and overflow: "
        "%lld); cells in the file %lld\n",
        names[s], summary->got[s], missing, summary->lost[s],
        static_cast<long long>(table.cells[s]));
  }
  std::printf("rows in the file: %zu (one per tick: %lld); closed with '# end': %s\n", table.rows(),
              static_cast<long long>(ticks), table.closed ? "yes" : "no");
  std::printf("lost samples: %lld (goal 0)\n", total_lost);
  std::printf("sirupp-logger CPU: %.2f s user+system in %.2f s wall = %.1f %% of one core\n", cpu_s,
              wall_s, 100.0 * cpu_s / wall_s);
  std::printf("load average at end: %s\n", LoadAverage().c_str());
  return total_lost == 0 ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return Run(argc, argv);
  } catch (const std::exception& error) {
    std::cerr << "bench_logger: " << error.what() << "\n";
    return 1;
  }
}
