#pragma once
// What every SIRUPP process main shares: the same exit codes and messages, and a service loop that
// stops cleanly on Ctrl-C or SIGTERM.

#include <functional>
#include <string>
#include <vector>

#include "runtime/args.hpp"

namespace sirupp::runtime {

// Runs `run` on the arguments after the program name; `run` parses them with Args. --help and
// --version (HelpRequested): the text on stdout, exit 0. core::UsageError: its one line (the
// flag, the bad value, what is allowed), exit 2. core::ConfigError (a bad model, environment or
// plan file): "NAME: file:line: ...", exit 2. Any other exception: "NAME: what", exit 1.
int ProcessMain(int argc, char** argv, const char* name,
                const std::function<int(const std::vector<std::string>&)>& run);

// Calls `service` until it returns false or SIGINT / SIGTERM arrives. A core::BusError raised
// because the signal interrupted LCM's wait ends the loop quietly; any other error propagates.
// Catches SIGINT and SIGTERM from now on; StopRequested() tells whether one arrived.
void InstallStopHandlers();
bool StopRequested();

// --rt-priority N (1..99) of sirupp-sim and sirupp-control: runs the calling process under
// SCHED_FIFO at priority N, so a waking servo loop preempts ordinary processes at once instead of
// waiting out the scheduler's wake-up granularity (milliseconds on two cores). Needs root,
// CAP_SYS_NICE or an rtprio limit; when refused, one line on stderr and the process carries on at
// normal priority. Returns whether it was granted. 0 does nothing.
bool RequestRealtimePriority(int priority, const std::string& process_name);
// The declaration of --rt-priority N (a whole number 0..99; 0: off); read it with
// args.Integer("rt-priority", 0).
Flag RtPriorityFlag();

void ServiceUntilSignal(const std::function<bool()>& service);

}  // namespace sirupp::runtime
