#pragma once
// The sirupp-sim process around an ArmWorld: takes joint-effort commands, teleports and e-stops
// from the bus, steps the world in one of the timing modes of docs/timing.md, and publishes the
// arm's state every tick (or every N ticks), SIM_STATUS, the robot model and environment at 1 Hz,
// and a heartbeat.
//
//  - lockstep: the state of tick k goes out, then the node waits until every registered
//    participant has answered tick k, then steps. Same inputs, bit-identical outputs. A participant
//    that has not answered within the timeout is named on stderr and in the heartbeat, and the
//    state is sent again; the node never steps without it.
//  - realtime: lockstep paced by the wall clock. The node still waits for every participant's
//    answer to tick k (physics never integrates an effort computed for another state) and never
//    runs ahead of the wall clock; behind it, it steps as fast as the answers come; further behind
//    than it can catch up, the sim time slips (counted, reported as the real-time factor). A
//    participant silent past the watchdog is named and the arm brakes, paced by the wall clock,
//    until it answers again.
//  - freerun (opt-in): paced by the wall clock, the newest command of each sender is held
//    (zero-order hold); any sender may drive. Under load this integrates stale efforts.
//  - fast: no pacing, no waiting; the newest commands are held.
//
// Bad commands (wrong joint count, NaN or infinite effort, unknown mode, unknown sender where
// participants are registered, a tick from the future) are refused, counted per sender, printed
// the first time per sender and kind, and listed with the reason on SIM_STATUS; a registered
// participant's refused answer counts as "hold", so the arm brakes instead of moving on it.
// ESTOP brakes every joint and makes the node ignore every effort until it is released.
// SIM_COMMAND loads another environment between two ticks (the arm untouched), answered on
// SIM_REPLY; refused while the arm moves or when an object would overlap it.
//
// The virtual PIC-SERVO boards (servo::ServoBank, the chip model the hardware emulator runs too)
// live here, beside the physics, as the real boards sit beside the motors. A participant that
// answers MODE_BOARDS (sirupp-control running no student's controller) lets them drive the arm:
// every tick they run profile and PID against that tick's state and their efforts are that
// participant's share, and each tick's set-points go out on ARM_SETPOINT. Such a participant
// answers only every exchange_ticks ticks, the board status (SIM_BOARD_STATUS: the state and the
// boards) of an exchange tick; its answer covers the ticks up to the next one, so the sim does not
// wait for it in between. What it sent on SIM_BOARD_COMMAND (moves, stops, servo on and off) and
// CONTROLLER_GAINS before an answer is applied at that answer's tick, before the boards tick: a
// move's start is a tick, the same run to run in lockstep. A tripped board brakes the arm (as
// the controller's hold would at its next answer). Participants that answer efforts every tick
// (a student's controller, a disturbance) work as before, and the boards then only run for
// those that answer MODE_BOARDS.
//
// Single-threaded: call Service() in a loop (sirupp-sim's main does), or interleave it with other
// work on the same Bus in tests. Time comes from NodeOptions::clock, so tests can drive the
// pacing, the lockstep gate and the watchdog without waiting on the wall clock.

#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <sirupp/arm_command_t.hpp>
#include <sirupp/estop_t.hpp>
#include <sirupp/servo_gains_t.hpp>
#include <sirupp/servo_move_t.hpp>
#include <sirupp/sim_command_t.hpp>
#include <sirupp/sim_reset_t.hpp>
#include <string>
#include <vector>

#include "core/arm_state.hpp"
#include "core/bus.hpp"
#include "core/channels.hpp"
#include "core/command_reply.hpp"
#include "core/environment.hpp"
#include "core/heartbeat.hpp"
#include "core/messages.hpp"
#include "core/tick_batch.hpp"
#include "servo/servo_bank.hpp"
#include "sim/arm_world.hpp"

namespace sirupp::sim {

enum class TimingMode { kLockstep, kRealtime, kFast, kFreeRun };

const char* TimingModeName(TimingMode mode);
// "lockstep", "realtime", "fast" or "freerun"; throws std::invalid_argument naming the bad text.
TimingMode ParseTimingMode(const std::string& text);

// Where the node reads the time and how it sleeps. The default is the steady clock; a test gives
// a clock it advances itself (sleep_until then just moves it).
struct NodeClock {
  using TimePoint = std::chrono::steady_clock::time_point;
  std::function<TimePoint()> now;
  std::function<void(TimePoint)> sleep_until;
  static NodeClock Steady();
};

struct NodeOptions {
  TimingMode mode = TimingMode::kLockstep;
  // Lockstep and realtime: the senders (arm_command_t.sender) whose answer every published tick
  // waits for.
  std::vector<std::string> participants = {"sirupp-control"};
  // Publish SIM_ARM_STATE every this many ticks (>= 1). The participants answer the published ticks
  // and their command holds for the ticks in between.
  int state_every = 1;
  // Lockstep: report (and send the state again) after this long without every answer, seconds.
  double lockstep_timeout_s = 1.0;
  // Realtime: a participant silent this long (wall clock) brakes the arm and the sim goes on
  // without it. Until then the sim only waits (its time slips), so a slow answer never changes
  // the physics; a brake does, so it is kept for a participant that is really gone.
  // Freerun: a command older than this brakes the arm (sirupp-sim gives 0.05 s there).
  double watchdog_s = 0.5;
  // Realtime: the sim sleeps once per this many ticks and then runs them back to back, each still
  // waiting for every answer (1..64; 1 = a sleep per tick). Its time then lags the wall clock by
  // up to this many ticks, never leads it; in return sim and controller trade the tick with a
  // switch between them instead of a wake-up from idle per tick, which is most of a rig's CPU on
  // a virtual machine (docs/timing.md, "Sleeping once per few ticks").
  int pace_ticks = 1;
  // The virtual boards' exchange (1..4096 ticks, a multiple of state_every): SIM_BOARD_STATUS
  // goes out every this many ticks, and a MODE_BOARDS answer covers the ticks up to the next one.
  // 16 ticks = 8.2 ms, a little faster than sirupp-hardware polls the real boards.
  int exchange_ticks = 16;
  // While every participant lets the boards drive the arm (and answers only the exchange ticks),
  // SIM_ARM_STATE and ARM_SETPOINT go out this many ticks at a time in one message on
  // SIM_ARM_TICKS (1..64; 1 = each tick on its own channel, as a per-tick participant always gets
  // them). Sent at each exchange tick, when full, before the sim sends per tick again and when it
  // stops. The Bus hands each tick to the readers of the two channels (core/tick_batch.hpp).
  // Realtime then sleeps once per batch (pace_ticks if larger) and takes messages at each sleep
  // and exchange, not every tick.
  int tick_batch = 16;
  // Stop after this much simulated time; 0 = run until RequestStop().
  double duration_s = 0;
  // What the arm does before a participant (or, in freerun and fast, any sender) has answered:
  // kHold (brakes on, the default) or kLimp (motors off, the arm falls).
  core::CommandMode idle = core::CommandMode::kHold;
  std::string process_name = "sirupp-sim";
  core::Channels channels;
  NodeClock clock = NodeClock::Steady();
};

// What the node has done, for tests, the heartbeat and the exit summary.
struct NodeCounters {
  int64_t steps = 0;
  int64_t states_published = 0;
  int64_t commands_accepted = 0;
  int64_t commands_rejected = 0;
  int64_t commands_late = 0;      // answered a tick that was already stepped
  int64_t lockstep_timeouts = 0;  // times a participant was reported late
  int64_t watchdog_holds = 0;     // ticks braked because a participant (or every sender) was silent
  int64_t resets = 0;
  int64_t estop_ticks = 0;  // ticks stepped with the emergency stop engaged
  // realtime: ticks stepped later than their wall-clock time (caught up); freerun: ticks that
  // started more than one step late
  int64_t overruns = 0;
  // freerun: ticks stepped before any answer to the latest state had arrived (an older command
  // held)
  int64_t ticks_late = 0;
  double slipped_s = 0;         // realtime: wall time given up when too far behind to catch up
  int64_t board_ticks = 0;      // ticks the virtual boards drove the arm
  int64_t board_commands = 0;   // SIM_BOARD_COMMAND messages applied
  int64_t board_exchanges = 0;  // SIM_BOARD_STATUS messages sent
  int64_t tick_batches = 0;     // SIM_ARM_TICKS messages sent
};

// Throws std::invalid_argument naming the bad option (the text SimNode's constructor gives).
void CheckNodeOptions(const NodeOptions& options);

class SimNode {
 public:
  // Subscribes to the command, reset and e-stop channels and publishes the model and environment
  // at once. Throws std::invalid_argument naming the bad option.
  SimNode(core::Bus& bus, ArmWorld& world, core::Environment environment, NodeOptions options);
  ~SimNode();
  SimNode(const SimNode&) = delete;
  SimNode& operator=(const SimNode&) = delete;

  // Does what is due (handle messages, step, publish), waiting at most max_wait_ms for messages.
  // Returns false once the run is over (duration reached or RequestStop()).
  bool Service(int max_wait_ms);
  void RequestStop() { stop_requested_ = true; }
  // Sends the ticks gathered for SIM_ARM_TICKS now (sirupp-sim's main when it ends; the
  // destructor too).
  void Flush();

  const NodeCounters& counters() const { return counters_; }
  const ArmWorld& world() const { return world_; }
  // One line on the present condition (the heartbeat's detail).
  const std::string& detail() const { return detail_; }
  // Simulated seconds per wall second since the run started (1 before it started).
  double RealtimeFactor() const;
  // Random per start; SIM_STATUS carries it so peers recognise a restarted sim.
  int64_t run_id() const { return run_id_; }
  // The one-line summary sirupp-sim prints when it ends.
  std::string Summary() const;

 private:
  using Presence = core::ParticipantState;  // kAnswering, kNeverSeen, kSilent, as SIM_STATUS says
  struct Participant {
    std::string name;
    Presence presence = Presence::kNeverSeen;
    bool answered = false;  // has answered the awaited tick
    core::ArmCommand answer;
    double latency_sum_ms = 0;  // answer times in the present second
    double latency_max_ms = 0;
    int latency_count = 0;
    double last_mean_ms = -1;  // ... and in the second before, as published
    double last_max_ms = -1;
    // The ticks before this one are covered by its answer: the segment it answered, or for a
    // participant that drives the boards (it answered MODE_BOARDS), up to the next exchange.
    int64_t answer_until = 0;
    bool drives_boards = false;
  };
  struct Answer {  // freerun and fast: the newest command of a sender
    core::ArmCommand command;
    NodeClock::TimePoint received;
  };
  struct Refusals {
    int64_t count = 0;
    std::string reason;
    NodeClock::TimePoint last;
    std::vector<std::string> kinds_printed;
  };

  NodeClock::TimePoint Now() const { return options_.clock.now(); }
  bool Gated() const {
    return options_.mode == TimingMode::kLockstep || options_.mode == TimingMode::kRealtime;
  }
  Participant* FindParticipant(const std::string& name);
  void OnCommand(const sirupp::arm_command_t& message, const core::ReceiveInfo& info);
  void OnReset(const sirupp::sim_reset_t& message, const core::ReceiveInfo& info);
  void OnEstop(const sirupp::estop_t& message, const core::ReceiveInfo& info);
  // SIM_BOARD_COMMAND and CONTROLLER_GAINS: checked now, applied at the next answer of a
  // participant that drives the boards (at once in fast and freerun).
  void OnBoardCommand(const sirupp::servo_move_t& message, const core::ReceiveInfo& info);
  void OnBoardGains(const sirupp::servo_gains_t& message, const core::ReceiveInfo& info);
  void ApplyBoardCommands();
  // The first exchange tick after `tick`.
  int64_t NextExchange(int64_t tick) const;
  // A participant that drives the boards must answer the present tick (an exchange tick, or a
  // tick it joins or comes back at): the board status goes out with the state.
  bool BoardAnswerDue() const;
  void PublishBoardStatus();
  // One tick of the boards against the present state: their efforts are added to `command`
  // (hold when a board tripped), and the tick's set-points go out on ARM_SETPOINT. `run`: false
  // when the arm is held (the profiles wait) or the driver answered hold or limp.
  void BoardTick(core::ArmCommand& command, bool run);
  // SIM_COMMAND: loads an environment between two ticks (answered on SIM_REPLY).
  void OnSimCommand(const sirupp::sim_command_t& message, const core::ReceiveInfo& info);
  // Counts a refusal of `sender`'s command, prints it the first time per sender and kind.
  void NoteRefusal(const std::string& sender, const std::string& kind, const std::string& reason);
  void NoteProblem(const std::string& what, bool print);
  void SetPresence(Participant& participant, Presence presence, const std::string& why);
  // The command the world steps with, combined from the answers: efforts add up; any hold brakes
  // the arm; limp answers add nothing. An engaged e-stop brakes whatever was asked.
  // `boards`, when given, is set when an answer is MODE_BOARDS (counted as an effort answer; the
  // boards' efforts are added per tick by StepTicks).
  core::ArmCommand Combine(const std::vector<const core::ArmCommand*>& answers,
                           bool* boards = nullptr) const;
  core::ArmCommand IdleCommand(core::CommandMode mode) const;
  // The participants' answers (hold for a silent one, the idle command for one never seen), in
  // the order they were listed, so sums are reproducible.
  // `boards`: an answer is MODE_BOARDS; `board_rows`: a participant that drives the boards
  // answered (their set-points go out each tick).
  core::ArmCommand CombineParticipants(bool* boards, bool* board_rows);
  // `boards`: the virtual boards take part (a MODE_BOARDS answer); `board_rows`: a participant
  // drives the boards, so each tick's set-points are published even while they wait.
  void StepTicks(const core::ArmCommand& command, int ticks, bool boards = false,
                 bool board_rows = false);
  // Steps the gate's tick(s) with the participants' answers and opens the next tick.
  void StepGate();
  bool GateOpen() const;
  // The state of the present tick (into the batch while Batching()); `again`: the same tick once
  // more, to a participant that may have missed it (a batch already has it).
  void PublishState(bool again = false);
  // Every participant answers MODE_BOARDS (none needs a tick when it is stepped): the ticks go out
  // in batches.
  bool Batching() const;
  // Realtime: the ticks stepped per sleep. While the ticks go out in batches nobody answers
  // between two exchanges, so the sim sleeps once per batch (at least options_.pace_ticks).
  int PaceTicks() const;
  void PublishSetpoint(const core::ServoSetpoint& setpoint);
  void PublishLatched(bool force);
  void PublishStatus(bool force);
  void Start();
  void ServiceLockstep(int max_wait_ms);
  void ServiceRealtime(int max_wait_ms);
  void ServiceFree(int max_wait_ms);
  // Sleeps or handles messages until `until` or max_wait_ms, whichever comes first.
  void WaitUntil(NodeClock::TimePoint until, int max_wait_ms);
  void ForgetOldSenders(NodeClock::TimePoint now);
  bool Finished() const;

  // Faster than this (rad/s or m/s) a joint counts as moving: no environment is loaded then.
  static constexpr double kStillSpeed = 0.01;
  core::Bus& bus_;
  ArmWorld& world_;
  core::Environment environment_;
  NodeOptions options_;
  core::Heartbeat heartbeat_;
  core::Replier replier_;  // SIM_REPLY
  NodeCounters counters_;
  std::string detail_;
  NodeClock::TimePoint last_problem_;
  bool stop_requested_ = false;
  int64_t run_id_ = 0;
  int64_t state_seq_ = 0;
  int64_t model_seq_ = 0;
  int64_t environment_seq_ = 0;
  int64_t status_seq_ = 0;
  NodeClock::TimePoint last_latched_;
  bool latched_sent_ = false;
  NodeClock::TimePoint last_status_;
  bool status_due_ = false;  // something changed: publish SIM_STATUS soon (rate-limited)
  int64_t status_tick_ = 0;  // tick and time of the previous status, for the factor over a second
  NodeClock::TimePoint status_time_;
  double recent_factor_ = 1;

  // Lockstep and realtime: the tick waiting for answers, and who answers.
  std::vector<Participant> participants_;
  int64_t awaited_tick_ = 0;
  NodeClock::TimePoint waiting_since_;  // when the awaited tick's state was first sent
  int64_t waiting_since_utime_ = 0;     // the same on the wall clock (us since the epoch)
  NodeClock::TimePoint last_resend_;
  static constexpr double kResendPeriodS = 0.1;  // unanswered state sent again
  // Realtime pacing: tick pace_tick_ is due at pace_wall_; tick k at pace_wall_ + (k - pace_tick_)
  // steps. Moved forward when the sim time slips.
  NodeClock::TimePoint pace_wall_;
  int64_t pace_tick_ = 0;
  // Realtime: the ticks before this one are due (their end has passed) and step as soon as every
  // answer is in; past it the sim waits for the next options_.pace_ticks to be due.
  int64_t batch_end_tick_ = 0;
  NodeClock::TimePoint last_slip_report_;
  // Freerun and fast: the newest command of each sender (bounded: forgotten after a while).
  std::map<std::string, Answer> newest_;
  // Refused commands per sender (bounded), and those of forgotten senders.
  std::map<std::string, Refusals> refusals_;
  int64_t refused_others_ = 0;
  int refusal_lines_this_second_ = 0;
  NodeClock::TimePoint refusal_second_;
  // E-stop: who engaged it and why; empty when released.
  std::string estop_;
  NodeClock::TimePoint start_wall_;
  int64_t start_tick_ = 0;
  bool started_ = false;

  // The virtual boards and what waits for the next answer of the participant that drives them.
  servo::ServoBank boards_;
  std::vector<core::ServoMove> board_queue_;
  std::optional<std::vector<servo::ServoGains>> board_gains_;
  int64_t board_command_seq_ = -1;  // seq of the last SIM_BOARD_COMMAND applied
  int64_t board_move_id_ = 0;       // move_id of the last one (the set-points' move)
  std::vector<double> board_effort_;
  core::ServoSetpoint board_setpoint_;  // the boards after their last tick (tick -1 before)
  int64_t board_status_seq_ = 0;
  int64_t setpoint_seq_ = 0;
  core::TickBatch tick_batch_;  // SIM_ARM_TICKS: the ticks since the last one sent
};

}  // namespace sirupp::sim
