#pragma once
// The one real arm, by turns (issue 33): a queue of rigs (one per student) for the bridge to the
// real PUMA, and a safe handover between two turns.
//
// The bridge (sirupp-hardware) stays one process, on a bus of its own (the arm bus). The manager
// relays the turn holder's rig to it and back. Nobody else's commands reach the arm, but anyone's
// e-stop does (Estop(), or every rig's ESTOP with relay_estop_from_all_rigs).
//   holder's rig -> arm: ARM_MOVE, ARM_GAINS, CONTROLLER_STATUS (the bridge's command expiry),
//                        ROBOT_MODEL (one robot), HARDWARE_COMMAND, ESTOP
//   arm -> holder's rig: REAL_ARM_STATE, REAL_ARM_SETPOINT, HARDWARE_STATUS, HARDWARE_REPLY,
//                        REAL_ARM_GAINS, the bridge's HEARTBEAT
// So the holder's controller, logger and panel see a linked bridge, exactly as on a single-PC lab.
// The holder's data files therefore hold the real arm's columns for the turn.
//
// Handover in (a turn starts):
//   1. the bridge is ready (calibrated, not faulted or e-stopped);
//   2. the rig's plan is aborted and its virtual arm is moved to the real arm's pose;
//   3. the bridge is armed, the relay goes on, and the bridge is linked.
// A turn ends when its time is up, or on Done/Leave (the holder) or EndTurn (the teacher).
// Handover out:
//   1. the relay goes off (the rig is unlinked) and the real arm is held (STOP_SMOOTH);
//   2. the arm is homed at reduced speed;
//   3. its pose is checked: every joint within home_tolerance_deg of home;
//   4. the bridge is unlinked (its reply checked: a refusal stops the queue), then disarmed.
// Only then does the next turn start. If a handover-out step does not finish in time, the bridge
// faults or is e-stopped, or the pose is off home, the queue stops with the reason
// (status().stopped_reason). The next student never gets a faulted arm. The teacher clears it with
// Resume() once the arm has been seen to. If a handover-in step fails before the arm was armed,
// only that student's turn is skipped, with the reason.
//
// Single-threaded, like core::Bus: call Service() often. Everything happens inside Service() and
// the commands.
//
// Built on client/: the bridge is commanded through a client::Client on the arm bus, the holder's
// controller through one on the rig's bus (requests with ids, each step waits for the reply that
// names its request and for the status that reply names; client::HardwareCommandDone and
// client::HardwareMovesDone say when it is carried out; a refusal ends the step with its words).
// Every time the manager reads (a turn's end, warnings, a step's timeout, the bridge's silence,
// its liveness messages) is TurnOptions::clock: the steady clock, or a test's simulated one.

#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <sirupp/arm_state_t.hpp>
#include <sirupp/controller_status_t.hpp>
#include <sirupp/hardware_status_t.hpp>
#include <stdexcept>
#include <string>
#include <vector>

#include "client/client.hpp"
#include "core/bus.hpp"
#include "core/channels.hpp"
#include "core/robot_model.hpp"

namespace sirupp::turns {

// A refused command (unknown student, already queued, not the holder, ...): the text says why.
class TurnError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct TurnOptions {
  double turn_s = 600;                           // one turn's length
  std::vector<double> warn_before_s = {60, 10};  // warnings this long before a turn's end
  double home_speed_fraction = 0.5;              // of each joint's default velocity
  double home_tolerance_deg = 1.0;               // the pose check after homing
  // The virtual arm at the real pose before a link: within this of it, at rest under its PID
  // (which lets it sag a little under gravity).
  double pose_tolerance_deg = 2.0;
  double step_timeout_s = 15;              // a handover step (homing: plus its travel time)
  std::string log_path;                    // one JSON line per event and per turn; "" none
  std::string sender = "sirupp turns";     // hardware_command_t / estop_t sender
  bool relay_estop_from_all_rigs = false;  // subscribe ESTOP on every rig (standalone)
  // Each event as one line for people (turn starts, warnings, handovers, the queue stopping).
  std::function<void(const std::string&)> on_event;
  // "" when `student` may have the real arm, else why not (for example: the controller on their
  // rig is a submission that has not passed the class's safety tasks). Asked on Join and again
  // when their turn comes (then their turn is skipped with the reason). None: everyone may.
  std::function<std::string(const std::string& student)> admit;
  // Where the manager reads the time. The steady clock by default; a test gives a clock it moves
  // itself, so turns and handovers run on simulated time through the same steps.
  std::function<std::chrono::steady_clock::time_point()> clock = [] {
    return std::chrono::steady_clock::now();
  };
};

enum class Phase { kIdle, kHandoverIn, kTurn, kHandoverOut, kStopped };
const char* PhaseName(Phase phase);  // "idle", "handover in", "turn", "handover out", "stopped"

struct Waiting {
  std::string student;
  double estimated_wait_s = 0;  // until this student's turn starts
};

struct TurnStatus {
  Phase phase = Phase::kIdle;
  std::string holder;          // the rig in or being handed the turn; "" none
  double turn_left_s = 0;      // kTurn
  std::string step;            // the handover step under way
  bool paused = false;         // no new turn starts (the present one goes on)
  std::string stopped_reason;  // kStopped: why; the teacher resumes once the arm is seen to
  std::string bridge;          // the bridge as last heard: "linked", "e-stopped", "silent 3.0 s"...
  std::vector<Waiting> queue;  // in order
  std::string last_event;
};

// One turn, as logged.
struct TurnRecord {
  std::string student;
  int64_t start_wall_us = 0;       // the link (the turn's start)
  int64_t end_wall_us = 0;         // the turn's end (the handover out follows)
  std::vector<std::string> plans;  // the plans the rig ran during the turn
  std::string ended;               // "time up", "done", "left", "ended by NAME"
  double handover_in_s = 0;
  double handover_out_s = 0;    // 0 until it finished
  std::string handover_result;  // "ok", or why the queue stopped
};

class TurnManager {
 public:
  using Clock = std::chrono::steady_clock;
  // A rig's bus, made when the rig takes part in a handover or turn and dropped after it: a bus on
  // a rig's udpm port receives all of its per-tick traffic, so none is held for idle rigs.
  using BusFactory = std::function<std::shared_ptr<core::Bus>()>;

  // `arm_bus` is the bridge's bus; `model` the robot (home pose, default speeds). Both must
  // outlive the manager.
  TurnManager(core::Bus& arm_bus, const core::RobotModel& model, TurnOptions options = {});
  ~TurnManager();
  TurnManager(const TurnManager&) = delete;
  TurnManager& operator=(const TurnManager&) = delete;

  // A student's rig. Throws TurnError for a name already added.
  void AddRig(const std::string& student, BusFactory bus);

  // --- students
  void Join(const std::string& student);   // to the end of the queue
  void Leave(const std::string& student);  // out of the queue, or ends their turn
  void Done(const std::string& student);   // the holder ends their own turn early
  // "" when `student` may command the real arm now (holder, turn running); else why not.
  std::string MayCommand(const std::string& student) const;
  // Anyone: the real arm's e-stop (ESTOP on the arm bus).
  void Estop(const std::string& by, const std::string& reason);
  // In the queue, or holding or being handed the arm (their rig must keep running).
  bool Involved(const std::string& student) const;

  // --- the teacher
  void EndTurn(const std::string& by);
  void Skip(const std::string& student);  // out of the queue
  void Pause();
  void Resume();  // also restarts a stopped queue (after the arm was seen to)
  // Releases the real arm's e-stop (ESTOP engaged=false on the arm bus); the bridge then needs
  // arming again, which the next handover does.
  void ReleaseEstop(const std::string& by);

  // Relays, watches and steps the handover; call often (every few ms).
  void Service();

  TurnStatus status() const;
  const std::vector<TurnRecord>& history() const { return history_; }
  const TurnOptions& options() const { return options_; }

 private:
  struct Rig;
  struct Step {
    std::string name;
    std::function<void()> enter;
    // true: done; false: not yet; a throw (TurnError): the step failed, with the reason.
    std::function<bool()> done;
    double timeout_s = 0;
    bool arm_touched = true;  // a failure stops the queue (else: the student is skipped)
  };

  Rig& RigOf(const std::string& student);
  const Rig* FindRig(const std::string& student) const;
  void Event(const std::string& text);
  void LogJson(const std::string& json_line);
  void StartHandoverIn(const std::string& student);
  void StartTurn();
  void EndTurnNow(const std::string& why);
  void StartHandoverOut();
  void FinishHandoverOut();
  void StepHandover();
  void Fail(const std::string& reason);
  // Relay off. The holder's rig is told the bridge is no longer linked to it (a last
  // HARDWARE_STATUS, state ARMED), so that its controller does not take the silence for a lost
  // bridge.
  void RelayOff();
  void Attach(Rig& rig);
  void Detach(Rig& rig);
  Clock::time_point Now() const;
  double Since(Clock::time_point t) const;  // seconds on the manager's clock
  // Our requests to the bridge, through arm_client_: the latest is request_, answer_ its answer
  // once heard.
  void Command(client::HardwareCommand command);
  void Move(bool stop, const std::vector<double>& goal, double speed_fraction);
  // Why the bridge cannot go on (fault, e-stop, refusal), or "".
  std::string BridgeTrouble() const;
  // Its last HARDWARE_STATUS is older than kBridgeSilentS: what it said may be stale.
  bool BridgeSilent() const;
  void ThrowOnBridgeTrouble() const;  // TurnError(BridgeTrouble()), if any
  // Our last ARM_MOVE was accepted by the bridge and a status polled after it shows every
  // module's MOVE_DONE (no fixed time: a busy machine may delay the bridge past any). Throws
  // TurnError on BridgeTrouble(), as CommandDone does.
  bool MoveDone() const;
  // Our last HARDWARE_COMMAND was accepted and the status its reply names shows it carried out.
  bool CommandDone(client::HardwareCommand command) const;
  // A step that sends `command` to the bridge and waits until CommandDone (a failure touches the
  // arm: the queue stops).
  Step CommandStep(const std::string& name, client::HardwareCommand command);
  // The largest |real - goal| in degrees and its joint (1-based), from REAL_ARM_STATE.
  std::pair<double, int> RealOffset(const std::vector<double>& goal) const;
  std::vector<double> HomePose() const;
  double EstimatedHandoverS() const;

  core::Bus& arm_bus_;
  const core::RobotModel& model_;
  TurnOptions options_;
  core::Channels channels_;
  std::map<std::string, std::unique_ptr<Rig>> rigs_;
  std::vector<std::string> queue_;
  std::vector<core::Subscription*> arm_subscriptions_;

  Phase phase_ = Phase::kIdle;
  bool paused_ = false;
  std::string stopped_reason_;
  std::string last_event_;
  Rig* holder_ = nullptr;  // in handover in, turn or handover out
  bool relay_on_ = false;
  std::vector<Step> steps_;
  size_t step_ = 0;
  Clock::time_point step_started_;
  bool step_entered_ = false;
  Clock::time_point handover_started_;
  Clock::time_point turn_end_;
  std::vector<bool> warned_;
  std::string end_reason_;
  std::vector<double> handover_durations_s_;
  std::vector<TurnRecord> history_;

  // What the bridge last said (arm bus).
  std::optional<sirupp::hardware_status_t> hardware_;
  Clock::time_point hardware_at_;
  std::optional<sirupp::arm_state_t> real_;
  std::unique_ptr<client::Client> arm_client_;
  std::optional<client::RequestId> request_;  // our latest HARDWARE_COMMAND or ARM_MOVE
  std::optional<client::Answer> answer_;      // its answer, once heard
  int corrections_ = 0;                       // the pose check's correction moves so far
  Clock::time_point correction_at_;
  int64_t seq_ = 0;
  int64_t move_id_ = 1000000;
  Clock::time_point last_liveness_;
};

}  // namespace sirupp::turns
