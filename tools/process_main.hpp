#pragma once
// What every SIRUPP process main shares: the same exit codes and messages, and a service loop that
// stops cleanly on Ctrl-C or SIGTERM.

#include <functional>
#include <string>
#include <vector>

namespace sirupp::tools {

// Runs `run` on the arguments after the program name. --help or -h anywhere prints `usage` and
// exits 0. core::UsageError: its message and the usage, exit 2. core::ConfigError (a bad model,
// environment or plan file): "NAME: file:line: ...", exit 2. Any other exception: "NAME: what",
// exit 1.
int ProcessMain(int argc, char** argv, const char* name, const char* usage,
                const std::function<int(const std::vector<std::string>&)>& run);

// Calls `service` until it returns false or SIGINT / SIGTERM arrives. A core::BusError raised
// because the signal interrupted LCM's wait ends the loop quietly; any other error propagates.
// Catches SIGINT and SIGTERM from now on; StopRequested() tells whether one arrived.
void InstallStopHandlers();
bool StopRequested();

void ServiceUntilSignal(const std::function<bool()>& service);

}  // namespace sirupp::tools
