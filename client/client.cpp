#include "client/client.hpp"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <limits>
#include <sirupp/estop_t.hpp>
#include <sirupp/hardware_command_t.hpp>
#include <sirupp/joint_target_t.hpp>
#include <sirupp/logger_command_t.hpp>
#include <sirupp/plan_command_t.hpp>
#include <sirupp/pose_target_t.hpp>
#include <sirupp/sim_command_t.hpp>
#include <sirupp/sim_reset_t.hpp>
#include <utility>

#include "core/command_reply.hpp"
#include "core/errors.hpp"
#include "core/heartbeat.hpp"
#include "core/real_arm_note.hpp"
#include "core/translate.hpp"

namespace sirupp::client {
namespace {

using Status = sirupp::controller_status_t;
using sirupp::hardware_command_t;
using sirupp::hardware_status_t;

using core::SteadyMicros;

// Keeps `reply` in `replies`, which holds only the newest: a long-lived client (the turn manager on
// the bridge's bus) hears every rig's replies, most of them to other clients' requests.
void KeepReply(std::vector<sirupp::command_reply_t>& replies,
               const sirupp::command_reply_t& reply) {
  constexpr size_t kKept = 256;
  if (replies.size() >= kKept) replies.erase(replies.begin(), replies.begin() + kKept / 2);
  replies.push_back(reply);
}

// Keeps the first real-arm loss a status names (core::kRealArmLost) in `lost`.
void NoteRealArmLost(const sirupp::controller_status_t& status, std::string& lost) {
  if (lost.empty() && status.last_error.rfind(core::kRealArmLost, 0) == 0) {
    lost = status.last_error;
  }
}

std::string DefaultSender() {
  char host[256] = {};
  ::gethostname(host, sizeof host - 1);
  return "sirupp client (pid " + std::to_string(::getpid()) + "@" + host + ")";
}

struct HardwareVerb {
  HardwareCommand command;
  const char* name;
  int8_t wire;
};

constexpr HardwareVerb kHardwareVerbs[] = {
    {HardwareCommand::kConnect, "connect", hardware_command_t::COMMAND_CONNECT},
    {HardwareCommand::kCalibrate, "calibrate", hardware_command_t::COMMAND_CALIBRATE},
    {HardwareCommand::kArm, "arm", hardware_command_t::COMMAND_ARM},
    {HardwareCommand::kDisarm, "disarm", hardware_command_t::COMMAND_DISARM},
    {HardwareCommand::kLink, "link", hardware_command_t::COMMAND_LINK},
    {HardwareCommand::kUnlink, "unlink", hardware_command_t::COMMAND_UNLINK},
    {HardwareCommand::kHome, "home", hardware_command_t::COMMAND_HOME},
    {HardwareCommand::kClearFaults, "clear-faults", hardware_command_t::COMMAND_CLEAR_FAULTS},
};

struct PlanVerb {
  PlanCommand command;
  const char* name;
  core::PlanAction action;
};

constexpr PlanVerb kPlanVerbs[] = {
    {PlanCommand::kPause, "pause", core::PlanAction::kPause},
    {PlanCommand::kResume, "resume", core::PlanAction::kResume},
    {PlanCommand::kAbort, "abort", core::PlanAction::kAbort},
    {PlanCommand::kManual, "manual", core::PlanAction::kManual},
    {PlanCommand::kAutomatic, "automatic", core::PlanAction::kAutomatic},
    {PlanCommand::kClearFault, "clear-fault", core::PlanAction::kClearFault},
};

const PlanVerb& Verb(PlanCommand command) {
  for (const PlanVerb& verb : kPlanVerbs) {
    if (verb.command == command) return verb;
  }
  return kPlanVerbs[0];  // unreachable: every enumerator is in the table
}

const HardwareVerb& Verb(HardwareCommand command) {
  for (const HardwareVerb& verb : kHardwareVerbs) {
    if (verb.command == command) return verb;
  }
  return kHardwareVerbs[0];  // unreachable: every enumerator is in the table
}

}  // namespace

const char* ControllerStateName(int8_t state) {
  switch (state) {
    case Status::STATE_IDLE:
      return "idle";
    case Status::STATE_MOVING:
      return "moving";
    case Status::STATE_WAITING:
      return "waiting";
    case Status::STATE_PAUSED:
      return "paused";
    case Status::STATE_FAULT:
      return "fault";
    case Status::STATE_OFF:
      return "off";
    default:
      return "unknown";
  }
}

const char* ControllerModeName(int8_t mode) {
  return mode == Status::MODE_AUTOMATIC ? "automatic" : "manual";
}

const char* PlanCommandName(PlanCommand command) { return Verb(command).name; }

std::optional<PlanCommand> PlanCommandFromName(const std::string& name) {
  for (const PlanVerb& verb : kPlanVerbs) {
    if (name == verb.name) return verb.command;
  }
  return std::nullopt;
}

const char* HardwareCommandName(HardwareCommand command) { return Verb(command).name; }

std::optional<HardwareCommand> HardwareCommandFromName(const std::string& name) {
  for (const HardwareVerb& verb : kHardwareVerbs) {
    if (name == verb.name) return verb.command;
  }
  return std::nullopt;
}

bool HardwareCommandDone(HardwareCommand command, const hardware_status_t& s) {
  switch (command) {
    case HardwareCommand::kConnect:
    case HardwareCommand::kDisarm:
      return s.state == hardware_status_t::STATE_CONNECTED;
    case HardwareCommand::kCalibrate:
      return s.calibrated == 1;
    case HardwareCommand::kArm:
    case HardwareCommand::kUnlink:
      return s.state == hardware_status_t::STATE_ARMED;
    case HardwareCommand::kLink:
      return s.state == hardware_status_t::STATE_LINKED;
    case HardwareCommand::kHome:
      return s.state == hardware_status_t::STATE_ARMED ||
             s.state == hardware_status_t::STATE_LINKED;
    case HardwareCommand::kClearFaults:
      return s.state != hardware_status_t::STATE_FAULT;
  }
  return false;
}

Client::Client(Options options)
    : options_(std::move(options)),
      owned_bus_(std::make_unique<core::Bus>(options_.lcm_url, options_.prefix)),
      bus_(*owned_bus_) {
  Subscribe();
}

Client::Client(core::Bus& bus, Options options) : options_(std::move(options)), bus_(bus) {
  options_.lcm_url = bus.url();
  options_.prefix = bus.prefix();
  Subscribe();
}

Client::~Client() {
  // A client on a bus it does not own (a rig's, the bridge's) leaves nothing subscribed there.
  for (core::Subscription* subscription : subscriptions_) subscription->Unsubscribe();
  for (core::Subscription* subscription : joint_subscriptions_) subscription->Unsubscribe();
}

void Client::Subscribe() {
  if (options_.sender.empty()) options_.sender = DefaultSender();
  subscriptions_.push_back(&bus_.Subscribe<Status>(
      channels_.controller_status, [this](const Status& message, const core::ReceiveInfo&) {
        snapshot_.controller = message;
        ++snapshot_.controller_statuses;
        last_status_wall_us_ = SteadyMicros();
      }));
  subscriptions_.push_back(&bus_.Subscribe<sirupp::command_reply_t>(
      channels_.controller_reply,
      [this](const sirupp::command_reply_t& message, const core::ReceiveInfo&) {
        KeepReply(controller_replies_, message);
      }));
  subscriptions_.push_back(&bus_.Subscribe<sirupp::command_reply_t>(
      channels_.hardware_reply,
      [this](const sirupp::command_reply_t& message, const core::ReceiveInfo&) {
        KeepReply(hardware_replies_, message);
      }));
  subscriptions_.push_back(&bus_.Subscribe<sirupp::command_reply_t>(
      channels_.sim_reply, [this](const sirupp::command_reply_t& message,
                                  const core::ReceiveInfo&) { KeepReply(sim_replies_, message); }));
  subscriptions_.push_back(&bus_.Subscribe<sirupp::command_reply_t>(
      channels_.logger_reply,
      [this](const sirupp::command_reply_t& message, const core::ReceiveInfo&) {
        KeepReply(logger_replies_, message);
      }));
  subscriptions_.push_back(&bus_.Subscribe<sirupp::sim_status_t>(
      channels_.sim_status, [this](const sirupp::sim_status_t& message, const core::ReceiveInfo&) {
        snapshot_.sim = message;
      }));
  subscriptions_.push_back(&bus_.Subscribe<hardware_status_t>(
      channels_.hardware_status,
      [this](const hardware_status_t& message, const core::ReceiveInfo&) {
        snapshot_.hardware = message;
      }));
  subscriptions_.push_back(&bus_.Subscribe<sirupp::servo_gains_t>(
      channels_.controller_gains,
      [this](const sirupp::servo_gains_t& message, const core::ReceiveInfo&) {
        snapshot_.virtual_gains = message;
      }));
  subscriptions_.push_back(&bus_.Subscribe<sirupp::servo_gains_t>(
      channels_.real_arm_gains,
      [this](const sirupp::servo_gains_t& message, const core::ReceiveInfo&) {
        snapshot_.real_gains = message;
      }));
  subscriptions_.push_back(&bus_.Subscribe<sirupp::heartbeat_t>(
      channels_.heartbeat, [this](const sirupp::heartbeat_t& message, const core::ReceiveInfo&) {
        const std::string key = message.process + "@" + message.host;
        snapshot_.heartbeats[key] = message;
        heartbeat_heard_us_[key] = SteadyMicros();
      }));
  created_us_ = SteadyMicros();
  if (options_.watch_joints) WatchJoints(true);
}

bool Client::Until(const std::function<bool()>& done, double timeout_s) {
  if (!idle_) return core::HandleUntil(bus_, done, timeout_s);
  const auto end = std::chrono::steady_clock::now() +
                   std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                       std::chrono::duration<double>(timeout_s));
  while (!done()) {
    if (std::chrono::steady_clock::now() >= end) return done();
    idle_();
    bus_.HandleAvailable();
  }
  return true;
}

void Client::Listen(double seconds) {
  Until([] { return false; }, seconds);
}

void Client::WatchJoints(bool on) {
  if (!on) {
    for (core::Subscription* subscription : joint_subscriptions_) subscription->Unsubscribe();
    joint_subscriptions_.clear();
    snapshot_.sim_arm.reset();  // not followed any more: an old value would mislead
    snapshot_.setpoint.reset();
    return;
  }
  if (!joint_subscriptions_.empty()) return;
  // Per-tick channels: a queue of 2, the newest message is all that is kept.
  joint_subscriptions_.push_back(&bus_.Subscribe<sirupp::servo_setpoint_t>(
      channels_.arm_setpoint,
      [this](const sirupp::servo_setpoint_t& message, const core::ReceiveInfo&) {
        snapshot_.setpoint = message;
      },
      2));
  joint_subscriptions_.push_back(&bus_.Subscribe<sirupp::arm_state_t>(
      channels_.sim_arm_state,
      [this](const sirupp::arm_state_t& message, const core::ReceiveInfo&) {
        snapshot_.sim_arm = message;
      },
      2));
}

Client::Rest Client::WaitVirtualAtRest(double timeout_s) {
  const bool watching = !joint_subscriptions_.empty();
  WatchJoints(true);
  snapshot_.sim_arm.reset();  // only a state heard from now on
  auto at_rest = [this] {
    const std::optional<sirupp::arm_state_t>& state = snapshot_.sim_arm;
    return state.has_value() && !state->flags.empty() &&
           std::all_of(state->flags.begin(), state->flags.end(), [](int8_t flags) {
             return (flags & sirupp::arm_state_t::FLAG_AT_REST) != 0;
           });
  };
  Rest rest = Rest::kNoSimState;
  if (Until([this] { return snapshot_.sim_arm.has_value(); }, std::min(timeout_s, 0.5))) {
    rest = Until(at_rest, timeout_s) ? Rest::kAtRest : Rest::kNotAtRest;
  }
  if (!watching) WatchJoints(false);
  return rest;
}

bool Client::WaitForController(double timeout_s) {
  return Until([this] { return snapshot_.controller.has_value(); }, timeout_s);
}

bool Client::WaitForHardware(double timeout_s) {
  return Until([this] { return snapshot_.hardware.has_value(); }, timeout_s);
}

double Client::SinceControllerStatus() const {
  if (!snapshot_.controller) return std::numeric_limits<double>::infinity();
  return static_cast<double>(SteadyMicros() - last_status_wall_us_) * 1e-6;
}

bool Client::ControllerSilent(double seconds) const {
  return snapshot_.controller.has_value() && SinceControllerStatus() >= seconds;
}

template <class Msg>
RequestId Client::Send(const std::string& channel, Msg message) {
  // A distinct utime per request of this client: with the seq, the request's id.
  last_utime_ = std::max(core::WallMicros(), last_utime_ + 1);
  message.utime = last_utime_;
  message.seq = seq_[channel]++;
  bus_.Publish(channel, message);
  RequestId id{bus_.FullName(channel), message.utime, message.seq};
  constexpr size_t kKept = 16;
  if (sent_.size() >= kKept) sent_.erase(sent_.begin());
  sent_.push_back(Sent{id, [this, channel, message] { bus_.Publish(channel, message); }});
  return id;
}

Answer Client::Await(const RequestId& request, double timeout_s, Replier replier) {
  const bool hardware = replier == Replier::kHardware;
  std::vector<sirupp::command_reply_t>& replies = replier == Replier::kHardware ? hardware_replies_
                                                  : replier == Replier::kSim    ? sim_replies_
                                                  : replier == Replier::kLogger
                                                      ? logger_replies_
                                                      : controller_replies_;
  Answer answer;
  answer.request = request;
  std::optional<sirupp::command_reply_t> reply;
  const auto heard = [&] {
    for (auto it = replies.begin(); it != replies.end(); ++it) {
      if (core::RepliesTo(*it, request.channel, request.utime, request.seq)) {
        reply = *it;
        replies.erase(it);
        return true;
      }
    }
    return false;
  };
  const auto same = [&](const Sent& s) {
    return s.id.channel == request.channel && s.id.utime == request.utime &&
           s.id.seq == request.seq;
  };
  std::function<void()> publish_again;
  const auto sent = std::find_if(sent_.begin(), sent_.end(), same);
  if (sent != sent_.end()) publish_again = sent->publish_again;
  // Until() may return before its timeout (nothing to wait on): send again only once a whole
  // kResendAfterS has passed since the last copy.
  const int64_t end_us = SteadyMicros() + static_cast<int64_t>(timeout_s * 1e6);
  const auto resend_us = static_cast<int64_t>(kResendAfterS * 1e6);
  int64_t next_copy_us = SteadyMicros() + resend_us;
  while (
      !Until(heard, 1e-6 * static_cast<double>(std::min(end_us, next_copy_us) - SteadyMicros()))) {
    const int64_t now = SteadyMicros();
    if (now >= end_us) break;
    if (publish_again && now >= next_copy_us) {
      publish_again();
      next_copy_us = now + resend_us;
    }
  }
  sent_.erase(std::remove_if(sent_.begin(), sent_.end(), same), sent_.end());
  // Replies to requests of other clients are of no use here; keep the list short.
  if (replies.size() > 64) replies.erase(replies.begin(), replies.end() - 64);
  if (!reply) {
    const std::string& replies_on = replier == Replier::kHardware ? channels_.hardware_reply
                                    : replier == Replier::kSim    ? channels_.sim_reply
                                    : replier == Replier::kLogger ? channels_.logger_reply
                                                                  : channels_.controller_reply;
    const char* process = replier == Replier::kHardware ? "sirupp-hardware"
                          : replier == Replier::kSim    ? "sirupp-sim"
                          : replier == Replier::kLogger ? "sirupp-logger"
                                                        : "sirupp-control";
    answer.error = "no reply on " + bus_.FullName(replies_on) + " within " +
                   core::FormatApprox(timeout_s) + " s to the request on " + request.channel +
                   " (is " + process + " running, on the same --lcm-url and --prefix?)";
    return answer;
  }
  answer.result = reply->result == sirupp::command_reply_t::RESULT_ACCEPTED ? Result::kAccepted
                                                                            : Result::kRefused;
  answer.error = reply->error;
  answer.move_id = reply->move_id;
  answer.status_seq = reply->status_seq;
  // The status sent with the reply shows the command's effect: wait for it (briefly; LCM may
  // drop it, and the next one comes within 0.1 s).
  if (reply->status_seq >= 0 && (hardware || replier == Replier::kController)) {
    Until(
        [&] {
          if (hardware) return snapshot_.hardware && snapshot_.hardware->seq >= reply->status_seq;
          return snapshot_.controller && snapshot_.controller->seq >= reply->status_seq;
        },
        0.5);
  }
  return answer;
}

Answer Client::AwaitControllerAnswer(const RequestId& request, double timeout_s) {
  return Await(request, timeout_s, Replier::kController);
}

Answer Client::AwaitHardwareAnswer(const RequestId& request, double timeout_s) {
  return Await(request, timeout_s, Replier::kHardware);
}

Answer Client::AwaitSimAnswer(const RequestId& request, double timeout_s) {
  return Await(request, timeout_s, Replier::kSim);
}

Answer Client::AwaitLoggerAnswer(const RequestId& request, double timeout_s) {
  return Await(request, timeout_s, Replier::kLogger);
}

void Client::WaitOutStartGuard() {
  constexpr int64_t kListenUs = 150000;  // a starting process beats at 10 Hz
  // In process (memq://, or a caller stepping the sim between polls) nothing starts on its own.
  const bool in_process = idle_ || bus_.url().rfind("memq://", 0) == 0;
  const int64_t listened = SteadyMicros() - created_us_;
  if (!in_process && listened < kListenUs) {
    Listen(static_cast<double>(kListenUs - listened) * 1e-6);
  }
  // The guarded processes heard in the last second, and the longest time left.
  std::vector<std::string> guarded;
  double left_s = 0;
  for (const auto& [key, beat] : snapshot_.heartbeats) {
    if (beat.state != sirupp::heartbeat_t::STATE_STARTING) continue;
    if (SteadyMicros() - heartbeat_heard_us_[key] > 1000000) continue;
    if (const std::optional<double> left = core::StartGuardLeft(beat.detail)) {
      guarded.push_back(key);
      left_s = std::max(left_s, *left);
    }
  }
  if (guarded.empty()) return;
  if (options_.notice) {
    options_.notice("waiting " + core::FormatApprox(left_s) + " s for the start guard of " +
                    guarded.front() + " (it refuses commands just after its start)");
  }
  Until(
      [&] {
        return std::none_of(guarded.begin(), guarded.end(), [&](const std::string& key) {
          return snapshot_.heartbeats[key].state == sirupp::heartbeat_t::STATE_STARTING;
        });
      },
      left_s + 1.0);
}

Answer Client::MoveJoints(const JointTarget& target) {
  WaitOutStartGuard();
  // Unset speeds and accelerations are 0 (the joint's default); unset `active` moves every joint.
  auto at = [](const auto& values, size_t i, auto unset) {
    return i < values.size() ? values[i] : unset;
  };
  core::JointTarget message;
  for (size_t i = 0; i < target.position.size(); ++i) {
    message.joints.push_back({target.position[i], at(target.max_velocity, i, 0.0),
                              at(target.acceleration, i, 0.0),
                              target.active.empty() || at(target.active, i, int8_t{0}) != 0});
  }
  return AwaitControllerAnswer(Send(channels_.arm_target, core::ToMessage(message)),
                               options_.answer_timeout_s);
}

Answer Client::MovePose(const PoseTarget& target) {
  WaitOutStartGuard();
  using core::ArmChoice;
  // kFirst is LEFT, UP and NO_FLIP on the wire (core/messages.hpp).
  auto choice = [](const std::optional<bool>& first) {
    return !first ? ArmChoice::kAny : *first ? ArmChoice::kFirst : ArmChoice::kSecond;
  };
  core::PoseTarget message;
  message.position = Eigen::Vector3d(target.position[0], target.position[1], target.position[2]);
  message.orientation = Eigen::Quaterniond(target.orientation[0], target.orientation[1],
                                           target.orientation[2], target.orientation[3]);
  message.position_only = target.position_only;
  message.shoulder = choice(target.shoulder_left);
  message.elbow = choice(target.elbow_up);
  message.wrist = !target.wrist_flip   ? ArmChoice::kAny
                  : *target.wrist_flip ? ArmChoice::kSecond
                                       : ArmChoice::kFirst;
  message.speed_scale = target.speed_scale;
  return AwaitControllerAnswer(Send(channels_.arm_pose_target, core::ToMessage(message)),
                               options_.answer_timeout_s);
}

Answer Client::RunPlan(const std::string& name, const std::string& text) {
  WaitOutStartGuard();
  const core::PlanCommand message{0, 0, core::PlanAction::kRun, name, text};
  return AwaitControllerAnswer(Send(channels_.arm_plan, core::ToMessage(message)),
                               options_.answer_timeout_s);
}

Answer Client::Plan(PlanCommand command) {
  core::PlanCommand message;
  message.command = Verb(command).action;
  return AwaitControllerAnswer(Send(channels_.arm_plan, core::ToMessage(message)),
                               options_.answer_timeout_s);
}

Answer Client::SetGains(const sirupp::servo_gains_t& gains) {
  return AwaitControllerAnswer(Send(channels_.arm_gains, gains), options_.answer_timeout_s);
}

bool Client::GainsShown(const sirupp::servo_gains_t& gains, bool with_real) const {
  return snapshot_.virtual_gains && SameFilterGains(*snapshot_.virtual_gains, gains) &&
         (!with_real || (snapshot_.real_gains && SameFilterGains(*snapshot_.real_gains, gains)));
}

bool Client::WaitGainsShown(const sirupp::servo_gains_t& gains, bool with_real, double timeout_s) {
  return Until([&] { return GainsShown(gains, with_real); }, timeout_s);
}

RequestId Client::ResetSim(const std::vector<double>& position, bool reset_objects,
                           const std::vector<double>& velocity) {
  const core::SimReset message{0, 0, options_.sender, position, velocity, reset_objects};
  return Send(channels_.sim_reset, core::ToMessage(message));
}

Answer Client::LoadEnvironment(const std::string& name, const std::string& xml) {
  const core::SimCommand message{0,    0,  options_.sender, core::SimAction::kLoadEnvironment,
                                 name, xml};
  return AwaitSimAnswer(Send(channels_.sim_command, core::ToMessage(message)),
                        options_.answer_timeout_s);
}

Answer Client::LoadModel(const std::string& name, const std::string& yaml) {
  const core::PlanCommand announce{0, 0, core::PlanAction::kLoadModel, name, yaml};
  const Answer controller = AwaitControllerAnswer(
      Send(channels_.arm_plan, core::ToMessage(announce)), options_.answer_timeout_s);
  if (!controller.accepted()) return controller;
  const core::SimCommand load{0, 0, options_.sender, core::SimAction::kLoadModel, name, yaml};
  const Answer sim =
      AwaitSimAnswer(Send(channels_.sim_command, core::ToMessage(load)), options_.answer_timeout_s);
  if (!sim.accepted()) {
    // The controller stops waiting for a model that will not come (an empty text cancels).
    const core::PlanCommand cancel{0, 0, core::PlanAction::kLoadModel, name, ""};
    AwaitControllerAnswer(Send(channels_.arm_plan, core::ToMessage(cancel)),
                          options_.answer_timeout_s);
  }
  return sim;
}

Answer Client::StartRecording(const std::string& name) {
  const core::LoggerCommand message{0, 0, options_.sender, core::LoggerAction::kStart, name};
  return AwaitLoggerAnswer(Send(channels_.logger_command, core::ToMessage(message)),
                           options_.answer_timeout_s);
}

Answer Client::StopRecording() {
  const core::LoggerCommand message{0, 0, options_.sender, core::LoggerAction::kStop, ""};
  return AwaitLoggerAnswer(Send(channels_.logger_command, core::ToMessage(message)),
                           options_.answer_timeout_s);
}

Answer Client::Hardware(HardwareCommand command) {
  // The verb's wire value is its core::HardwareAction (both follow hardware_command_t).
  const core::HardwareCommand message{0, 0, static_cast<core::HardwareAction>(Verb(command).wire),
                                      options_.sender};
  return AwaitHardwareAnswer(Send(channels_.hardware_command, core::ToMessage(message)),
                             options_.answer_timeout_s);
}

bool Client::WaitHardwareDone(HardwareCommand command, double timeout_s) {
  return Until(
      [&] { return snapshot_.hardware && HardwareCommandDone(command, *snapshot_.hardware); },
      timeout_s);
}

RequestId Client::Estop(bool engage, const std::string& reason) {
  const core::EStop message{0, 0, engage, options_.sender, reason};
  return Send(channels_.estop, core::ToMessage(message));
}

bool Client::WaitEstopShown(bool engaged, double timeout_s) {
  return Until(
      [&] {
        return snapshot_.hardware &&
               (snapshot_.hardware->state == hardware_status_t::STATE_ESTOPPED) == engaged;
      },
      timeout_s);
}

bool HardwareMovesDone(const hardware_status_t& status) {
  return !status.module_status.empty() &&
         std::all_of(status.module_status.begin(), status.module_status.end(),
                     [](int16_t module) { return (module & kModuleMoveDone) != 0; });
}

RequestId Client::SendHardware(HardwareCommand command) {
  const core::HardwareCommand message{0, 0, static_cast<core::HardwareAction>(Verb(command).wire),
                                      options_.sender};
  return Send(channels_.hardware_command, core::ToMessage(message));
}

RequestId Client::SendServoMove(const core::ServoMove& move) {
  return Send(channels_.arm_move, core::ToMessage(move));
}

RequestId Client::SendJointTarget(const core::JointTarget& target) {
  return Send(channels_.arm_target, core::ToMessage(target));
}

RequestId Client::SendPlanCommand(const core::PlanCommand& command) {
  return Send(channels_.arm_plan, core::ToMessage(command));
}

std::optional<Answer> Client::HeardHardwareAnswer(const RequestId& request) {
  return Heard(hardware_replies_, request);
}

std::optional<Answer> Client::HeardControllerAnswer(const RequestId& request) {
  return Heard(controller_replies_, request);
}

std::optional<Answer> Client::Heard(std::vector<sirupp::command_reply_t>& replies,
                                    const RequestId& request) {
  for (auto it = replies.begin(); it != replies.end(); ++it) {
    if (!core::RepliesTo(*it, request.channel, request.utime, request.seq)) continue;
    Answer answer;
    answer.request = request;
    answer.result = it->result == sirupp::command_reply_t::RESULT_ACCEPTED ? Result::kAccepted
                                                                           : Result::kRefused;
    answer.error = it->error;
    answer.move_id = it->move_id;
    answer.status_seq = it->status_seq;
    replies.erase(it);
    return answer;
  }
  return std::nullopt;
}

std::optional<Outcome> Client::Follow(const std::function<bool(const Status&)>& ended,
                                      double timeout_s, int64_t from_status_seq) {
  Outcome outcome;
  if (!snapshot_.controller) {
    outcome.end = End::kControllerSilent;
    outcome.detail = "no " + bus_.FullName(channels_.controller_status) + " heard";
    return outcome;
  }
  bool silent = false;
  const bool done = Until(
      [&] {
        if ((silent = ControllerSilent(options_.controller_silent_s))) return true;
        const Status& s = *snapshot_.controller;
        return s.seq >= from_status_seq && ended(s);
      },
      timeout_s);
  if (silent) {
    outcome.end = End::kControllerSilent;
    outcome.detail = "sirupp-control stopped answering: no " +
                     bus_.FullName(channels_.controller_status) + " for " +
                     core::FormatApprox(SinceControllerStatus()) +
                     " s (it crashed or was stopped; its log says why)";
    return outcome;
  }
  if (!done) {
    outcome.end = End::kTimeout;
    outcome.detail = std::string("still ") + ControllerStateName(snapshot_.controller->state) +
                     " after " + core::FormatApprox(timeout_s) + " s";
    return outcome;
  }
  return std::nullopt;
}

Outcome Client::WaitForMove(int64_t move_id, double timeout_s, int64_t from_status_seq) {
  std::string real_arm_lost;
  if (std::optional<Outcome> cut = Follow(
          [&](const Status& s) {
            NoteRealArmLost(s, real_arm_lost);
            return s.state == Status::STATE_FAULT || s.move_id != move_id ||
                   s.state == Status::STATE_IDLE;
          },
          timeout_s, from_status_seq)) {
    cut->real_arm_lost = real_arm_lost;
    return *cut;
  }
  const Status& s = *snapshot_.controller;
  Outcome outcome;
  if (s.state == Status::STATE_FAULT) {
    outcome.end = End::kFault;
    outcome.detail = "fault: " + s.last_error;
  } else if (s.move_id != move_id) {
    outcome.end = End::kSuperseded;
    outcome.detail = "superseded by move " + std::to_string(s.move_id);
  } else {
    outcome.end = End::kDone;
    outcome.detail = "move " + std::to_string(move_id) + " done";
  }
  outcome.real_arm_lost = real_arm_lost;
  return outcome;
}

Outcome Client::WaitForPlan(const std::string& name, int steps, double timeout_s,
                            const std::function<void(int)>& on_step, int64_t from_status_seq) {
  int shown_step = -1;
  std::string real_arm_lost;
  if (std::optional<Outcome> cut = Follow(
          [&](const Status& s) {
            NoteRealArmLost(s, real_arm_lost);
            if (s.plan_name != name) return true;  // another plan replaced it
            if (s.plan_step != shown_step && s.plan_step < steps && s.plan_step >= 0) {
              shown_step = s.plan_step;
              if (on_step) on_step(shown_step);
            }
            return s.state == Status::STATE_FAULT || s.state == Status::STATE_IDLE;
          },
          timeout_s, from_status_seq)) {
    cut->real_arm_lost = real_arm_lost;
    return *cut;
  }
  const Status& s = *snapshot_.controller;
  Outcome outcome;
  if (s.state == Status::STATE_FAULT) {
    outcome.end = End::kFault;
    outcome.detail = "plan failed: " + s.last_error;
  } else if (s.plan_name != name) {
    outcome.end = End::kSuperseded;
    outcome.detail = "plan " + name + " was replaced by " +
                     (s.plan_name.empty() ? std::string("no plan") : s.plan_name);
  } else if (s.plan_step < steps) {
    // Ended early: a step that failed names itself in last_error; an abort leaves it empty.
    outcome.end = End::kAborted;
    outcome.detail = s.last_error.empty()
                         ? "plan ended at step " + std::to_string(s.plan_step + 1) + " of " +
                               std::to_string(steps) + " (aborted)"
                         : "plan failed: " + s.last_error;
  } else {
    outcome.end = End::kDone;
    outcome.detail = "plan " + name + " finished";
  }
  outcome.real_arm_lost = real_arm_lost;
  return outcome;
}

bool Client::SameFilterGains(const sirupp::servo_gains_t& a, const sirupp::servo_gains_t& b) {
  return a.num_joints == b.num_joints && a.kp == b.kp && a.kd == b.kd && a.ki == b.ki &&
         a.integration_limit == b.integration_limit && a.output_limit == b.output_limit &&
         a.error_limit == b.error_limit && a.deadband == b.deadband;
}

}  // namespace sirupp::client
