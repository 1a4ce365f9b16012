#include "tools/process_main.hpp"

#include <atomic>
#include <csignal>
#include <exception>
#include <iostream>

#include "core/bus.hpp"
#include "core/errors.hpp"

namespace sirupp::tools {
namespace {

std::atomic<bool> g_stop{false};
extern "C" void OnStopSignal(int /*signal*/) { g_stop = true; }

}  // namespace

int ProcessMain(int argc, char** argv, const char* name, const char* usage,
                const std::function<int(const std::vector<std::string>&)>& run) {
  const std::vector<std::string> args(argv + 1, argv + argc);
  for (const std::string& arg : args) {
    if (arg == "--help" || arg == "-h") {
      std::cout << usage;
      return 0;
    }
  }
  try {
    return run(args);
  } catch (const core::UsageError& error) {
    std::cerr << error.what() << "\n" << usage;
    return 2;
  } catch (const core::ConfigError& error) {
    std::cerr << name << ": " << error.what() << "\n";
    return 2;
  } catch (const std::exception& error) {
    std::cerr << name << ": " << error.what() << "\n";
    return 1;
  }
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

}  // namespace sirupp::tools
