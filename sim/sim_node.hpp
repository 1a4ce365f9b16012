#pragma once
// The sirupp-sim process around an ArmWorld: takes joint-effort commands and teleports from the
// bus, steps the world in one of the three timing modes of docs/timing.md, and publishes the arm's
// state every tick (or every N ticks), the robot model and environment at 1 Hz, and a heartbeat.
//
//  - lockstep: state of tick k goes out, then the node waits until every registered participant
//    has answered tick k, then steps. Same inputs, bit-identical outputs. A participant that has
//    not answered within the timeout is named on stderr and in the heartbeat, and the state is sent
//    again; the node never steps without it.
//  - realtime: paced by the wall clock; the newest command of each sender is held. When no sender
//    has a command younger than the watchdog timeout, every joint is braked (held still).
//  - fast: no pacing, no waiting; the newest commands are held.
//
// Bad commands (wrong joint count, NaN or infinite effort, unknown mode, unknown sender in
// lockstep, a tick from the future) are refused, counted on the channel and named in the
// heartbeat; the sender's answer counts as "hold", so the arm brakes instead of moving on them.
//
// Single-threaded: call Service() in a loop (sirupp-sim's main does), or interleave it with other
// work on the same Bus in tests.

#include <chrono>
#include <cstdint>
#include <map>
#include <sirupp/arm_command_t.hpp>
#include <sirupp/sim_reset_t.hpp>
#include <string>
#include <vector>

#include "core/arm_state.hpp"
#include "core/bus.hpp"
#include "core/channels.hpp"
#include "core/environment.hpp"
#include "core/heartbeat.hpp"
#include "sim/arm_world.hpp"

namespace sirupp::sim {

enum class TimingMode { kLockstep, kRealtime, kFast };

const char* TimingModeName(TimingMode mode);
// "lockstep", "realtime" or "fast"; throws std::invalid_argument naming the bad text otherwise.
TimingMode ParseTimingMode(const std::string& text);

struct NodeOptions {
  TimingMode mode = TimingMode::kLockstep;
  // Lockstep: the senders (arm_command_t.sender) whose answer every published tick waits for.
  std::vector<std::string> participants = {"sirupp-control"};
  // Publish SIM_ARM_STATE every this many ticks (>= 1). In lockstep the participants answer the
  // published ticks and their command holds for the ticks in between.
  int state_every = 1;
  // Lockstep: report (and send the state again) after this long without every answer, seconds.
  double lockstep_timeout_s = 1.0;
  // Realtime: a command older than this (wall clock) brakes the arm, seconds.
  double watchdog_s = 0.05;
  // Stop after this much simulated time; 0 = run until RequestStop().
  double duration_s = 0;
  // What the arm does before any command arrives in realtime and fast modes: kHold (brakes on, the
  // default) or kLimp (motors off, the arm falls).
  core::CommandMode idle = core::CommandMode::kHold;
  std::string process_name = "sirupp-sim";
  core::Channels channels;
};

// What the node has done, for tests, the heartbeat and the exit summary.
struct NodeCounters {
  int64_t steps = 0;
  int64_t states_published = 0;
  int64_t commands_accepted = 0;
  int64_t commands_rejected = 0;
  int64_t commands_late = 0;      // answered a tick that was already stepped
  int64_t lockstep_timeouts = 0;  // times a participant was reported late
  int64_t watchdog_holds = 0;     // realtime ticks braked because no command was fresh
  int64_t resets = 0;
  int64_t overruns = 0;  // realtime: ticks that started later than one step behind
  // realtime: ticks stepped before any answer to the latest state had arrived (counted as late on
  // SIM_ARM_COMMAND too); the tick then holds an older command
  int64_t ticks_late = 0;
};

class SimNode {
 public:
  // Subscribes to the command and reset channels and publishes the model and environment at once.
  // Throws std::invalid_argument naming the bad option.
  SimNode(core::Bus& bus, ArmWorld& world, core::Environment environment, NodeOptions options);
  ~SimNode();
  SimNode(const SimNode&) = delete;
  SimNode& operator=(const SimNode&) = delete;

  // Does what is due (handle messages, step, publish), waiting at most max_wait_ms for messages.
  // Returns false once the run is over (duration reached or RequestStop()).
  bool Service(int max_wait_ms);
  void RequestStop() { stop_requested_ = true; }

  const NodeCounters& counters() const { return counters_; }
  const ArmWorld& world() const { return world_; }
  // One line on the present condition (the heartbeat's detail).
  const std::string& detail() const { return detail_; }

 private:
  struct Answer {
    core::ArmCommand command;
    std::chrono::steady_clock::time_point received;
  };

  void OnCommand(const sirupp::arm_command_t& message, const core::ReceiveInfo& info);
  void OnReset(const sirupp::sim_reset_t& message, const core::ReceiveInfo& info);
  // The command the world steps with, combined from the participants' answers: efforts add up;
  // any hold brakes the arm; limp answers add nothing.
  core::ArmCommand Combine(const std::vector<const core::ArmCommand*>& answers) const;
  void StepTicks(const core::ArmCommand& command, int ticks);
  void PublishState();
  void PublishLatched(bool force);
  void ServiceLockstep(int max_wait_ms);
  void ServiceFree(int max_wait_ms);
  bool Finished() const;

  core::Bus& bus_;
  ArmWorld& world_;
  core::Environment environment_;
  NodeOptions options_;
  core::Heartbeat heartbeat_;
  NodeCounters counters_;
  std::string detail_;
  std::chrono::steady_clock::time_point last_problem_;
  bool stop_requested_ = false;
  int64_t state_seq_ = 0;
  int64_t model_seq_ = 0;
  int64_t environment_seq_ = 0;
  std::chrono::steady_clock::time_point last_latched_;
  bool latched_sent_ = false;

  // Lockstep: the tick waiting for answers, and the answers so far.
  int64_t awaited_tick_ = 0;
  std::map<std::string, core::ArmCommand> answers_;
  std::chrono::steady_clock::time_point waiting_since_;
  std::chrono::steady_clock::time_point last_resend_;
  static constexpr double kResendPeriodS = 0.1;  // lockstep: unanswered state sent again
  // Realtime and fast: the newest command of each sender.
  std::map<std::string, Answer> newest_;
  std::chrono::steady_clock::time_point start_wall_;
  int64_t start_tick_ = 0;
  bool started_ = false;
};

}  // namespace sirupp::sim
