#pragma once
// sirupp_client: a typed C++ API over the bus for driving a running rig, as the `sirupp` CLI,
// `sirupp demo`, a browser panel or a grading harness do: joint and tool moves, sim reset, plans,
// gains, e-stop, fault clearing, the hardware bridge, a status snapshot, and waiting for a move or
// a plan to end.
//
// Every command is a request with an id (RequestId: the channel it went on and the utime and seq
// it carried). sirupp-control answers ARM_TARGET, ARM_POSE_TARGET, ARM_PLAN and ARM_GAINS on
// CONTROLLER_REPLY, sirupp-hardware answers HARDWARE_COMMAND and ARM_GAINS on HARDWARE_REPLY, each
// reply naming the request it answers (core/command_reply.hpp). An Answer is therefore matched to
// its request, never to an error text, and two clients on one rig never take each other's answers.
//
// Nothing here validates against a model: the rig does (and says why in Answer::error). The CLI
// checks limits, IK and plans before it sends, to exit 2 on bad input.
//
// Thread model: single-threaded, like core::Bus. Messages are handled only inside the calls that
// wait (Until, Listen, the commands and the Wait* functions); snapshot() is what they last saw.

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <sirupp/arm_state_t.hpp>
#include <sirupp/command_reply_t.hpp>
#include <sirupp/controller_status_t.hpp>
#include <sirupp/hardware_status_t.hpp>
#include <sirupp/heartbeat_t.hpp>
#include <sirupp/servo_gains_t.hpp>
#include <sirupp/servo_setpoint_t.hpp>
#include <sirupp/sim_status_t.hpp>
#include <string>
#include <utility>
#include <vector>

#include "core/bus.hpp"
#include "core/channels.hpp"
#include "core/messages.hpp"

namespace sirupp::client {

struct Options {
  std::string lcm_url;  // "" = LCM's default (LCM_DEFAULT_URL, else udpm 239.255.76.67:7667)
  std::string prefix;   // the rig's channel prefix, "" for none
  std::string sender;   // who sends (estop_t.sender, hardware_command_t.sender); "" = pid@host
  double answer_timeout_s = 2.0;  // how long a command waits for its reply
  // How long sirupp-control may send no CONTROLLER_STATUS (10 Hz) before a wait for a move or a
  // plan gives up on it (Client::kControllerSilentS by default). Wall clock: a loaded PC can stall
  // a process longer than that (`sirupp demo` gives it room).
  double controller_silent_s = 1.5;
  // Also follow the per-tick channels SIM_ARM_STATE and ARM_SETPOINT (newest only). Costs CPU
  // while waiting; WatchJoints() switches it later.
  bool watch_joints = false;
  // Told, in one line, what a command waits for before it is sent (a bridge's start guard);
  // nullptr: nothing is said.
  std::function<void(const std::string&)> notice;
};

// One request on the wire: the channel it went on (full name, prefix included) and its utime and
// seq. The client gives each of its requests a distinct utime.
struct RequestId {
  std::string channel;
  int64_t utime = 0;
  int64_t seq = 0;
};

enum class Result {
  kAccepted,  // the replier took the command
  kRefused,   // the replier refused it whole; Answer::error says why
  kNoAnswer,  // no reply within the timeout; Answer::error says what was not heard
};

// The answer to one request.
struct Answer {
  RequestId request;
  Result result = Result::kNoAnswer;
  std::string error;     // kRefused: the replier's reason (channel, field, value); kNoAnswer: why
  int64_t move_id = -1;  // accepted target or plan run: the present move after it; else -1
  int64_t status_seq = -1;  // the replier's status that shows the effect (see command_reply_t)
  bool accepted() const { return result == Result::kAccepted; }
};

// A joint-space target (ARM_TARGET). Empty vectors mean the model's defaults (speed,
// acceleration) and every joint active.
struct JointTarget {
  JointTarget() = default;
  // Every joint to `joint_positions` at the default speeds: MoveJoints({{0.5, 0, 0, 0, 0, 0}}).
  JointTarget(std::vector<double> joint_positions)  // NOLINT(google-explicit-constructor)
      : position(std::move(joint_positions)) {}
  std::vector<double> position;      // rad or m, DH convention
  std::vector<double> max_velocity;  // rad/s or m/s, 0 = the joint's default
  std::vector<double> acceleration;  // rad/s^2 or m/s^2, 0 = the joint's default
  std::vector<int8_t> active;        // 1 = move this joint
};

// A tool target in the world frame (ARM_POSE_TARGET). An unset configuration field leaves it
// free; all unset takes the solution nearest the present joints.
struct PoseTarget {
  double position[3] = {0, 0, 0};        // metres
  double orientation[4] = {1, 0, 0, 0};  // unit quaternion w, x, y, z
  bool position_only = false;            // orientation ignored
  std::optional<bool> shoulder_left;
  std::optional<bool> elbow_up;
  std::optional<bool> wrist_flip;
  double speed_scale = 1.0;  // fraction of the default speeds, (0, 1]
};

enum class PlanCommand { kPause, kResume, kAbort, kManual, kAutomatic, kClearFault };
// Every plan command, in the order of PlanCommand.
inline constexpr PlanCommand kPlanCommands[] = {PlanCommand::kPause,     PlanCommand::kResume,
                                                PlanCommand::kAbort,     PlanCommand::kManual,
                                                PlanCommand::kAutomatic, PlanCommand::kClearFault};
// "pause", "resume", "abort", "manual", "automatic", "clear-fault"; and back (nullopt for an
// unknown word).
const char* PlanCommandName(PlanCommand command);
std::optional<PlanCommand> PlanCommandFromName(const std::string& name);

enum class HardwareCommand {
  kConnect,
  kCalibrate,
  kArm,
  kDisarm,
  kLink,
  kUnlink,
  kHome,
  kClearFaults
};
// "connect", "calibrate", ..., "clear-faults"; and back (nullopt for an unknown word).
const char* HardwareCommandName(HardwareCommand command);
std::optional<HardwareCommand> HardwareCommandFromName(const std::string& name);
// Whether a bridge status shows the command carried out (e.g. kArm: STATE_ARMED).
bool HardwareCommandDone(HardwareCommand command, const sirupp::hardware_status_t& status);
// The MOVE_DONE bit of a PIC-SERVO module's status byte (hardware_status_t.module_status).
constexpr int16_t kModuleMoveDone = 0x01;
// Whether every module in a bridge status has its move done (false without modules).
bool HardwareMovesDone(const sirupp::hardware_status_t& status);

// "manual" or "automatic"; "idle", "moving", "waiting", "paused", "fault", "off" ("unknown" else).
const char* ControllerModeName(int8_t mode);
const char* ControllerStateName(int8_t state);

// What the rig last reported, as seen by the calls that handle messages.
struct Snapshot {
  std::optional<sirupp::controller_status_t> controller;
  int64_t controller_statuses = 0;  // CONTROLLER_STATUS messages heard
  std::optional<sirupp::sim_status_t> sim;
  std::optional<sirupp::hardware_status_t> hardware;
  std::optional<sirupp::servo_gains_t> virtual_gains;     // CONTROLLER_GAINS
  std::optional<sirupp::servo_gains_t> real_gains;        // REAL_ARM_GAINS
  std::optional<sirupp::arm_state_t> sim_arm;             // SIM_ARM_STATE (watch_joints)
  std::optional<sirupp::servo_setpoint_t> setpoint;       // ARM_SETPOINT (watch_joints)
  std::map<std::string, sirupp::heartbeat_t> heartbeats;  // by "process@host"
};

// How a wait for a move or a plan ended.
enum class End {
  kDone,              // the move is done / the plan ran to its last step
  kFault,             // the controller faulted (status.last_error names the cause)
  kSuperseded,        // another move or plan replaced it
  kAborted,           // the plan ended before its last step
  kTimeout,           // still going after the timeout
  kControllerSilent,  // sirupp-control stopped sending its status
};
struct Outcome {
  End end = End::kTimeout;
  std::string detail;  // one line for the people: why, with the controller's words where any
  // Not empty when, during the wait, the controller reported the real arm's half of the run
  // lost (its last_error began with core::kRealArmLost): the run is incomplete for the real arm.
  std::string real_arm_lost;
  bool ok() const { return end == End::kDone; }
};

class Client {
 public:
  // Opens its own bus on options.lcm_url and options.prefix.
  explicit Client(Options options = {});
  // Uses `bus` (which must outlive the client; its prefix is the rig's, options.lcm_url and
  // options.prefix are ignored): for a process that already has one, and for in-process tests
  // on memq://, where only one Bus sees the messages.
  Client(core::Bus& bus, Options options);
  // Unsubscribes everything it subscribed (the bus may live on).
  ~Client();
  Client(const Client&) = delete;
  Client& operator=(const Client&) = delete;

  core::Bus& bus() { return bus_; }
  const core::Channels& channels() const { return channels_; }
  const Options& options() const { return options_; }
  const Snapshot& snapshot() const { return snapshot_; }

  // --- handling messages
  // Handles messages until done() holds or timeout_s passed; returns done().
  bool Until(const std::function<bool()>& done, double timeout_s);
  // Handles messages for `seconds`.
  void Listen(double seconds);
  // Follows SIM_ARM_STATE and ARM_SETPOINT (on) or stops and forgets them (off).
  void WatchJoints(bool on);
  // Called between two rounds of message handling while a call waits (then the bus is polled
  // without blocking): to step an in-process sim in tests, or to serve a GUI. nullptr: none.
  void SetIdle(std::function<void()> idle) { idle_ = std::move(idle); }
  // Waits for a CONTROLLER_STATUS (returns at once if one was heard); false if none came.
  bool WaitForController(double timeout_s = 1.5);
  // Waits for a HARDWARE_STATUS; false if none came.
  bool WaitForHardware(double timeout_s = 2.0);
  // Waits until SIM_ARM_STATE shows the virtual arm at rest (every joint FLAG_AT_REST: the sim
  // keeps a settled arm exactly still, docs/physics.md). A plan or move started then starts from
  // the same state whatever tick it lands on. kNoSimState when no state came within 0.5 s.
  enum class Rest { kAtRest, kNotAtRest, kNoSimState };
  Rest WaitVirtualAtRest(double timeout_s);
  // True when sirupp-control, heard before, sent no status for `seconds` (it sends at 10 Hz).
  bool ControllerSilent(double seconds) const;
  // Seconds since the last CONTROLLER_STATUS (infinity before the first).
  double SinceControllerStatus() const;

  // --- sirupp-control (answers on CONTROLLER_REPLY)
  // MoveJoints, MovePose and RunPlan first wait out the start guard of a process that refuses
  // commands for a while after its start (the bridge: its heartbeat says starting, "start guard:
  // ... 0.54 s more"; it would refuse the move the controller mirrors to it, and the plan would
  // fail). A fresh client listens up to 0.15 s for such a heartbeat (sent at 10 Hz while
  // starting); options.notice hears what it waits for.
  void WaitOutStartGuard();
  Answer MoveJoints(const JointTarget& target);
  Answer MovePose(const PoseTarget& target);
  Answer RunPlan(const std::string& name, const std::string& text);
  Answer Plan(PlanCommand command);
  // ARM_GAINS goes to sirupp-control and, when one runs, sirupp-hardware; the answer is the
  // controller's. The bridge's answer: AwaitHardwareAnswer(answer.request).
  Answer SetGains(const sirupp::servo_gains_t& gains);
  // Whether the rig shows `gains` running: CONTROLLER_GAINS and, when `with_real` (a bridge's
  // REAL_ARM_GAINS was heard before the change), REAL_ARM_GAINS the same as `gains` in
  // SameFilterGains. After an accepted SetGains, `sirupp gains` and the Python module wait for it
  // (WaitGainsShown, kGainsShownS).
  bool GainsShown(const sirupp::servo_gains_t& gains, bool with_real) const;
  // Handles messages until GainsShown or timeout_s passed; returns GainsShown.
  bool WaitGainsShown(const sirupp::servo_gains_t& gains, bool with_real, double timeout_s);
  static constexpr double kGainsShownS = 2.5;

  // --- sirupp-sim: SIM_RESET has no reply (the sim counts a refusal in SIM_STATUS).
  RequestId ResetSim(const std::vector<double>& position, bool reset_objects = false,
                     const std::vector<double>& velocity = {});

  // --- sirupp-sim commands (answers on SIM_REPLY)
  // Replaces the sim's environment objects with those of `xml` (an environment file's text;
  // `name` is the file it came from, for messages), the arm untouched. Refused with the parser's
  // name:line error, while the arm moves, or when an object would overlap the arm.
  Answer LoadEnvironment(const std::string& name, const std::string& xml);
  // Loads another robot model (`yaml`, the text of file `name`) into the running rig, the arm
  // untouched: sirupp-control is told first (ARM_PLAN COMMAND_LOAD_MODEL; it refuses while the arm
  // moves, a plan runs, a fault or e-stop holds, or for a bad file with its name:line), then
  // sirupp-sim loads it (SIM_COMMAND LOAD_MODEL) and publishes it on ROBOT_MODEL, which the
  // controller, viewer, logger and panel follow. When the sim refuses, the controller is told to
  // drop it. The answer is the refusing process's, or the sim's acceptance.
  Answer LoadModel(const std::string& name, const std::string& yaml);

  // --- sirupp-logger (answers on LOGGER_REPLY)
  // Starts recording run `name` ("" = the logger's default name) / stops the present run.
  Answer StartRecording(const std::string& name);
  Answer StopRecording();

  // --- sirupp-hardware (answers on HARDWARE_REPLY)
  Answer Hardware(HardwareCommand command);
  // After an accepted Hardware(): waits until HARDWARE_STATUS shows it carried out.
  bool WaitHardwareDone(HardwareCommand command, double timeout_s);
  // Engages (or releases) the emergency stop on ESTOP. No reply: every process obeys it; the
  // bridge shows it in HARDWARE_STATUS (WaitEstopShown).
  RequestId Estop(bool engage, const std::string& reason);
  // True when a bridge status shows the stop engaged (or released) within timeout_s.
  bool WaitEstopShown(bool engaged, double timeout_s);

  // --- without waiting, for a caller that services the bus in a loop of its own
  // (turns::TurnManager): a request goes out at once, and its answer is looked up later among the
  // replies heard by then (whoever handles the bus hears them). None of these handles messages.
  RequestId SendHardware(HardwareCommand command);
  // ARM_MOVE, as a controller sends it: sirupp-hardware mirrors it while linked and answers it on
  // HARDWARE_REPLY either way.
  RequestId SendServoMove(const core::ServoMove& move);
  // ARM_TARGET and ARM_PLAN from core's values (utime and seq are the client's), answered by
  // sirupp-control on CONTROLLER_REPLY.
  RequestId SendJointTarget(const core::JointTarget& target);
  RequestId SendPlanCommand(const core::PlanCommand& command);
  // The answer to `request` once its reply on HARDWARE_REPLY (CONTROLLER_REPLY) was heard
  // (status_seq: the replier's status that shows the command's effect), else nullopt.
  std::optional<Answer> HeardHardwareAnswer(const RequestId& request);
  std::optional<Answer> HeardControllerAnswer(const RequestId& request);

  // --- answers
  // Waits for the reply to `request` on CONTROLLER_REPLY (or HARDWARE_REPLY), then for the status
  // it names, so snapshot() shows the command's effect. Replies that came earlier are kept.
  Answer AwaitControllerAnswer(const RequestId& request, double timeout_s);
  Answer AwaitHardwareAnswer(const RequestId& request, double timeout_s);
  Answer AwaitSimAnswer(const RequestId& request, double timeout_s);
  Answer AwaitLoggerAnswer(const RequestId& request, double timeout_s);

  // --- waiting for the end
  // Both judge only statuses with seq >= from_status_seq (pass Answer::status_seq, so a status
  // sent before the command was taken is never read as its end).
  // Follows move `move_id` until the controller is idle with it, faults, moves on, or goes silent.
  Outcome WaitForMove(int64_t move_id, double timeout_s, int64_t from_status_seq = -1);
  // Follows plan `name` (of `steps` steps) to its end; on_step(k) is called once per step k
  // (0-based) the controller reports starting.
  Outcome WaitForPlan(const std::string& name, int steps, double timeout_s,
                      const std::function<void(int)>& on_step = nullptr,
                      int64_t from_status_seq = -1);

  // Gains a status must show as sent: Kp, Kd, Ki, IL, OL, EL, DB (not CL, SR).
  static bool SameFilterGains(const sirupp::servo_gains_t& a, const sirupp::servo_gains_t& b);

  // How long sirupp-control may be silent before a wait gives up (it sends at 10 Hz): the default
  // of Options::controller_silent_s.
  static constexpr double kControllerSilentS = 1.5;
  // How long a command waits for its reply before it sends the same request again.
  static constexpr double kResendAfterS = 0.5;

 private:
  void Subscribe();
  template <class Msg>
  RequestId Send(const std::string& channel, Msg message);
  // Who answers a request: its reply list, reply channel and process name.
  enum class Replier { kController, kHardware, kSim, kLogger };
  Answer Await(const RequestId& request, double timeout_s, Replier replier);
  // The answer in `replies` to `request`, taken out of the list; nullopt if none.
  static std::optional<Answer> Heard(std::vector<sirupp::command_reply_t>& replies,
                                     const RequestId& request);
  // Handles messages until ended() holds for a status with seq >= from_status_seq. Returns the
  // outcome when the wait was cut short (no controller, silent, timeout), nullopt when it ended.
  std::optional<Outcome> Follow(
      const std::function<bool(const sirupp::controller_status_t&)>& ended, double timeout_s,
      int64_t from_status_seq);

  Options options_;
  std::unique_ptr<core::Bus> owned_bus_;
  core::Bus& bus_;
  std::function<void()> idle_;
  core::Channels channels_;
  Snapshot snapshot_;
  int64_t last_status_wall_us_ = 0;  // steady clock of the last CONTROLLER_STATUS, microseconds
  int64_t created_us_ = 0;           // steady clock when this client began to listen
  std::map<std::string, int64_t> heartbeat_heard_us_;  // steady clock, by snapshot_.heartbeats key
  int64_t last_utime_ = 0;              // utime of the last request (each request gets a new one)
  std::map<std::string, int64_t> seq_;  // per channel
  // The last requests sent, to send again while their answer is awaited and not heard: UDP
  // multicast drops a request or its reply when a process falls behind, and the replier answers
  // a repeated request with its first reply (core::Replier), without carrying it out again.
  struct Sent {
    RequestId id;
    std::function<void()> publish_again;
  };
  std::vector<Sent> sent_;
  std::vector<sirupp::command_reply_t> controller_replies_;
  std::vector<sirupp::command_reply_t> hardware_replies_;
  std::vector<sirupp::command_reply_t> sim_replies_;
  std::vector<sirupp::command_reply_t> logger_replies_;
  std::vector<core::Subscription*> joint_subscriptions_;
  std::vector<core::Subscription*> subscriptions_;  // Subscribe()'s
};

}  // namespace sirupp::client
