#pragma once
// The 1 Hz heartbeat every SIRUPP process publishes on HEARTBEAT: name, host, pid, state, one line
// of detail, and the traffic counters of every channel the process's Bus has seen, with rates
// computed between two heartbeats.
//
// While the last heartbeat sent said kStarting, the next one is due after a tenth of the period
// (10 Hz at 1 Hz): a process that is starting says at once when it is ready (the launcher waits
// for a state other than kStarting, docs/launch.md), and a client that listens briefly hears a
// process that is not ready yet (the bridge's start guard, client/client.hpp).

#include <chrono>
#include <cstdint>
#include <map>
#include <optional>
#include <sirupp/heartbeat_t.hpp>
#include <string>

#include "core/bus.hpp"

namespace sirupp::core {

enum class ProcessState : int8_t {
  kStarting = 0,
  kRunning = 1,
  kDegraded = 2,
  kFault = 3,
  kStopping = 4,
};

const char* ProcessStateName(ProcessState state);

// The heartbeat detail of a process that refuses commands for a while after its start (the
// bridge's start guard), sent with kStarting: "start guard: commands are refused for 0.54 s more".
inline constexpr const char* kStartGuardWord = "start guard";
std::string StartGuardDetail(double left_s);
// The seconds left that such a detail names; nullopt for any other detail.
std::optional<double> StartGuardLeft(const std::string& detail);

class Heartbeat {
 public:
  using Clock = std::chrono::steady_clock;

  // `channel`: the heartbeat channel without the rig prefix (Channels::heartbeat).
  Heartbeat(Bus& bus, std::string process_name, std::string channel = "HEARTBEAT",
            double period_s = 1.0);

  // Publishes a heartbeat if a period has passed since the last one (or none was sent yet).
  // Returns true if it published.
  bool PublishIfDue(ProcessState state, const std::string& detail);
  // True when PublishIfDue would publish now: lets a per-tick caller build the detail only then.
  bool Due() const {
    return !sent_any_ || Clock::now() - last_sent_ >=
                             (last_state_ == ProcessState::kStarting ? period_ / 10 : period_);
  }
  // Publishes one now (start-up, state changes, shutdown).
  void Publish(ProcessState state, const std::string& detail);

  // The message Publish would send now, without sending it (tests, status tables).
  sirupp::heartbeat_t Build(ProcessState state, const std::string& detail);

 private:
  Bus& bus_;
  std::string process_;
  std::string channel_;
  std::string host_;
  int32_t pid_ = 0;
  Clock::duration period_;
  Clock::time_point started_;
  Clock::time_point last_sent_;
  bool sent_any_ = false;
  ProcessState last_state_ = ProcessState::kStarting;
  int64_t seq_ = 0;
  // Messages per channel side at the previous heartbeat, for rates.
  std::map<std::string, int64_t> previous_counts_;
  Clock::time_point previous_time_;
};

}  // namespace sirupp::core
