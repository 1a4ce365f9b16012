#include "runtime/process_main.hpp"

#include <sched.h>
#include <sys/prctl.h>

#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <iostream>

#include "core/bus.hpp"
#include "core/errors.hpp"
#include "runtime/log_prefix.hpp"

namespace sirupp::runtime {
namespace {

std::atomic<bool> g_stop{false};
extern "C" void OnStopSignal(int /*signal*/) { g_stop = true; }

}  // namespace

int ProcessMain(int argc, char** argv, const char* name,
                const std::function<int(const std::vector<std::string>&)>& run) {
  const std::vector<std::string> args(argv + 1, argv + argc);
  // Every line the process writes to std::cerr or std::cout from here on carries the time, its
  // name and a level (log_prefix.hpp).
  const LogPrefix prefix(name);
  try {
    return run(args);
  } catch (const HelpRequested& help) {
    std::ostream(prefix.original(std::cout)) << help.text;  // as it is, unprefixed
    return 0;
  } catch (const core::UsageError& error) {
    LogError(std::cerr) << error.what() << "\n";
    return 2;
  } catch (const core::ConfigError& error) {
    LogError(std::cerr) << name << ": " << error.what() << "\n";
    return 2;
  } catch (const std::exception& error) {
    LogError(std::cerr) << name << ": " << error.what() << "\n";
    return 1;
  }
}

bool RequestRealtimePriority(int priority, const std::string& process_name) {
  if (priority <= 0) return false;
  sched_param param{};
  param.sched_priority = priority;
  if (::sched_setscheduler(0, SCHED_FIFO, &param) != 0) {
    std::cerr << process_name << ": --rt-priority " << priority << " not granted ("
              << std::strerror(errno) << "): running at normal priority; see docs/timing.md\n";
    return false;
  }
  ::prctl(PR_SET_TIMERSLACK, 1UL);  // wake-ups to the microsecond, not the default 50 us
  std::cerr << process_name << ": SCHED_FIFO priority " << priority << "\n";
  return true;
}

Flag RtPriorityFlag() {
  return Flag("rt-priority",
              "run under SCHED_FIFO at priority N (needs root or CAP_SYS_NICE); 0: off")
      .Takes("N")
      .Integer(0, 99);
}

void InstallStopHandlers() {
  std::signal(SIGINT, OnStopSignal);
  std::signal(SIGTERM, OnStopSignal);
}

bool StopRequested() { return g_stop; }

void ServiceUntilSignal(const std::function<bool()>& service) {
  InstallStopHandlers();
  while (!g_stop) {
    try {
      if (!service()) break;
    } catch (const core::BusError&) {
      if (g_stop) break;  // the signal interrupted LCM's wait
      throw;
    }
  }
}

}  // namespace sirupp::runtime
