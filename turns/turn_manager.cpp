#include "turns/turn_manager.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <set>
#include <sirupp/estop_t.hpp>
#include <sirupp/heartbeat_t.hpp>
#include <sirupp/joint_target_t.hpp>
#include <sirupp/plan_command_t.hpp>
#include <sirupp/robot_model_t.hpp>
#include <sirupp/servo_gains_t.hpp>
#include <sirupp/servo_move_t.hpp>
#include <sirupp/servo_setpoint_t.hpp>
#include <utility>

#include "core/errors.hpp"
#include "core/messages.hpp"
#include "core/translate.hpp"

namespace sirupp::turns {
namespace {

using Clock = TurnManager::Clock;
using Status = sirupp::hardware_status_t;
constexpr double kDeg = 3.14159265358979323846 / 180;
constexpr double kLivenessPeriodS = 0.1;  // our CONTROLLER_STATUS while we drive the arm
constexpr int kHomeCorrections = 3;       // the pose check's correction moves, at most
// HARDWARE_STATUS comes at 10 Hz; this long without one, a handover step waits (its timeout ends
// the wait). A loaded machine delays it past 1 s now and then, and a bridge busy with a command
// over a slow line past 3 s (both seen with a build beside the tests); the boards finish a loaded
// move alone, so the wait costs only time.
constexpr double kBridgeSilentS = 3.0;
constexpr double kMaxCorrectionDeg = 5.0;  // larger errors are not friction: no correction

std::string Fixed1(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%.1f", value);
  return text;
}

// A JSON string literal (the log's lines).
std::string Quoted(const std::string& text) {
  std::string out = "\"";
  for (char c : text) {
    if (c == '"' || c == '\\') {
      out += '\\';
      out += c;
    } else if (static_cast<unsigned char>(c) < 0x20) {
      char escaped[8];
      std::snprintf(escaped, sizeof escaped, "\\u%04x", c);
      out += escaped;
    } else {
      out += c;
    }
  }
  return out + "\"";
}

std::string BridgeStateName(int8_t state) {
  switch (state) {
    case Status::STATE_DISCONNECTED:
      return "disconnected";
    case Status::STATE_CONNECTED:
      return "connected";
    case Status::STATE_CALIBRATING:
      return "calibrating";
    case Status::STATE_ARMED:
      return "armed";
    case Status::STATE_LINKED:
      return "linked";
    case Status::STATE_FAULT:
      return "fault";
    case Status::STATE_ESTOPPED:
      return "e-stopped";
  }
  return "state " + std::to_string(state);
}

}  // namespace

const char* PhaseName(Phase phase) {
  switch (phase) {
    case Phase::kIdle:
      return "idle";
    case Phase::kHandoverIn:
      return "handover in";
    case Phase::kTurn:
      return "turn";
    case Phase::kHandoverOut:
      return "handover out";
    case Phase::kStopped:
      return "stopped";
  }
  return "unknown";
}

// A student's rig: its bus while it takes part, and what the manager watches on it.
struct TurnManager::Rig {
  std::string student;
  BusFactory factory;
  std::shared_ptr<core::Bus> bus;  // while attached
  std::vector<core::Subscription*> subscriptions;
  // Commands to the rig's controller (requests with ids) and its status: client/ on the rig's bus.
  std::unique_ptr<client::Client> client;
  std::optional<client::RequestId> request;        // the move to the real arm's pose
  std::optional<client::Answer> answer;            // its answer, once heard
  std::optional<sirupp::arm_state_t> virtual_arm;  // handover in only (per tick)
  core::Subscription* virtual_subscription = nullptr;
  std::set<std::string> plans;  // plan names run during the turn
  // Standalone: ESTOP heard on every rig.
  std::shared_ptr<core::Bus> estop_bus;
};

TurnManager::TurnManager(core::Bus& arm_bus, const core::RobotModel& model, TurnOptions options)
    : arm_bus_(arm_bus), model_(model), options_(std::move(options)) {
  if (!options_.clock) throw std::invalid_argument("TurnOptions::clock is empty");
  client::Options client_options;
  client_options.sender = options_.sender;
  arm_client_ = std::make_unique<client::Client>(arm_bus_, client_options);
  const core::Channels& c = channels_;
  // The bridge's side, always: what it says is kept, and passed to the holder while relayed.
  auto to_holder = [this](const auto& channel) {
    using Msg = typename std::decay_t<decltype(channel)>::Message;
    arm_subscriptions_.push_back(&arm_bus_.Subscribe<Msg>(
        channel,
        [this, channel](const Msg& message, const core::ReceiveInfo&) {
          if (relay_on_ && holder_ != nullptr && holder_->bus)
            holder_->bus->Publish(channel, message);
        },
        1000));
  };
  to_holder(c.real_arm_state);
  to_holder(c.real_arm_setpoint);
  to_holder(c.real_arm_gains);
  to_holder(c.hardware_status);
  to_holder(c.hardware_reply);
  arm_subscriptions_.push_back(&arm_bus_.Subscribe<sirupp::heartbeat_t>(
      c.heartbeat,
      [this](const sirupp::heartbeat_t& beat, const core::ReceiveInfo&) {
        if (relay_on_ && holder_ != nullptr && holder_->bus &&
            beat.process.rfind("sirupp-hardware", 0) == 0) {
          holder_->bus->Publish(channels_.heartbeat, beat);
        }
      },
      100));
  arm_subscriptions_.push_back(&arm_bus_.Subscribe<Status>(
      c.hardware_status,
      [this](const Status& status, const core::ReceiveInfo& info) {
        core::HardwareStatusFromMessage(status, info.channel);  // a bad one is refused, counted
        hardware_ = status;
        hardware_at_ = Now();
      },
      100));
  arm_subscriptions_.push_back(&arm_bus_.Subscribe<sirupp::arm_state_t>(
      c.real_arm_state,
      [this](const sirupp::arm_state_t& state, const core::ReceiveInfo&) { real_ = state; }, 2));
}

TurnManager::~TurnManager() {
  for (auto& [name, rig] : rigs_) Detach(*rig);
  for (core::Subscription* s : arm_subscriptions_) s->Unsubscribe();
}

void TurnManager::AddRig(const std::string& student, BusFactory bus) {
  if (student.empty()) throw TurnError("a rig needs a student's name");
  if (rigs_.count(student) != 0) throw TurnError("rig '" + student + "' is already added");
  auto rig = std::make_unique<Rig>();
  rig->student = student;
  rig->factory = std::move(bus);
  if (options_.relay_estop_from_all_rigs) {
    rig->estop_bus = rig->factory();
    rig->estop_bus->Subscribe<sirupp::estop_t>(
        channels_.estop,
        [this, name = student](const sirupp::estop_t& estop, const core::ReceiveInfo&) {
          if (holder_ != nullptr && holder_->student == name && relay_on_) return;  // relayed
          arm_bus_.Publish(channels_.estop, estop);
        },
        100);
  }
  rigs_[student] = std::move(rig);
}

TurnManager::Rig& TurnManager::RigOf(const std::string& student) {
  auto it = rigs_.find(student);
  if (it == rigs_.end()) throw TurnError("no rig '" + student + "' in this class");
  return *it->second;
}

const TurnManager::Rig* TurnManager::FindRig(const std::string& student) const {
  auto it = rigs_.find(student);
  return it == rigs_.end() ? nullptr : it->second.get();
}

void TurnManager::Event(const std::string& text) {
  last_event_ = text;
  if (options_.on_event) options_.on_event(text);
  LogJson("{\"time_us\": " + std::to_string(core::WallMicros()) + ", \"event\": " + Quoted(text) +
          "}");
}

void TurnManager::LogJson(const std::string& json_line) {
  if (options_.log_path.empty()) return;
  std::ofstream log(options_.log_path, std::ios::app);
  log << json_line << "\n";
}

Clock::time_point TurnManager::Now() const { return options_.clock(); }

double TurnManager::Since(Clock::time_point t) const {
  return std::chrono::duration<double>(Now() - t).count();
}

// --- students and the teacher

void TurnManager::Join(const std::string& student) {
  RigOf(student);
  if (options_.admit) {
    if (const std::string why = options_.admit(student); !why.empty()) throw TurnError(why);
  }
  if (holder_ != nullptr && holder_->student == student) {
    throw TurnError(student + " has the real arm now (" + PhaseName(phase_) + ")");
  }
  if (std::find(queue_.begin(), queue_.end(), student) != queue_.end()) {
    throw TurnError(student + " is already in the queue");
  }
  queue_.push_back(student);
  Event(student + " joined the queue (place " + std::to_string(queue_.size()) + ")");
}

void TurnManager::Leave(const std::string& student) {
  RigOf(student);
  auto it = std::find(queue_.begin(), queue_.end(), student);
  if (it != queue_.end()) {
    queue_.erase(it);
    Event(student + " left the queue");
    return;
  }
  if (holder_ != nullptr && holder_->student == student) {
    if (phase_ == Phase::kTurn) {
      EndTurnNow("left");
      return;
    }
    if (phase_ == Phase::kHandoverIn) {
      Fail(student + " left during the handover");
      return;
    }
  }
  throw TurnError(student + " is neither in the queue nor holding the real arm");
}

void TurnManager::Done(const std::string& student) {
  if (phase_ != Phase::kTurn || holder_ == nullptr || holder_->student != student) {
    throw TurnError(student + " has no turn to end: " + MayCommand(student));
  }
  EndTurnNow("done");
}

std::string TurnManager::MayCommand(const std::string& student) const {
  if (FindRig(student) == nullptr) return "no rig '" + student + "' in this class";
  if (phase_ == Phase::kTurn && holder_ != nullptr && holder_->student == student) return "";
  if (holder_ == nullptr) {
    return "the real arm is nobody's turn now" +
           std::string(phase_ == Phase::kStopped
                           ? " (the queue is stopped: " + stopped_reason_ + ")"
                           : "") +
           "; join the queue";
  }
  const auto place = std::find(queue_.begin(), queue_.end(), student);
  std::string text = "the real arm is in " + holder_->student + "'s turn (" + PhaseName(phase_);
  if (phase_ == Phase::kTurn) {
    text += ", " + Fixed1(std::max(0.0, std::chrono::duration<double>(turn_end_ - Now()).count())) +
            " s left";
  }
  text += ")";
  if (holder_->student == student) return text + "; your turn has not started yet";
  if (place == queue_.end()) return text + "; you are not in the queue";
  return text + "; you are number " + std::to_string(place - queue_.begin() + 1) + " in the queue";
}

void TurnManager::Estop(const std::string& by, const std::string& reason) {
  core::EStop estop;
  estop.utime = core::WallMicros();
  estop.seq = seq_++;
  estop.engaged = true;
  estop.sender = by;
  estop.reason = reason;
  arm_bus_.Publish(channels_.estop, core::ToMessage(estop));
  Event("e-stop of the real arm by " + by + (reason.empty() ? "" : ": " + reason));
}

void TurnManager::ReleaseEstop(const std::string& by) {
  core::EStop estop;
  estop.utime = core::WallMicros();
  estop.seq = seq_++;
  estop.engaged = false;
  estop.sender = by;
  estop.reason = "released";
  arm_bus_.Publish(channels_.estop, core::ToMessage(estop));
  Event("the real arm's e-stop released by " + by);
}

bool TurnManager::Involved(const std::string& student) const {
  if (holder_ != nullptr && holder_->student == student) return true;
  return std::find(queue_.begin(), queue_.end(), student) != queue_.end();
}

void TurnManager::EndTurn(const std::string& by) {
  if (phase_ != Phase::kTurn)
    throw TurnError(std::string("no turn to end (") + PhaseName(phase_) + ")");
  EndTurnNow("ended by " + by);
}

void TurnManager::Skip(const std::string& student) {
  auto it = std::find(queue_.begin(), queue_.end(), student);
  if (it == queue_.end()) throw TurnError(student + " is not in the queue");
  queue_.erase(it);
  Event(student + " was skipped by the teacher");
}

void TurnManager::Pause() {
  paused_ = true;
  Event("the queue is paused (the present turn goes on)");
}

void TurnManager::Resume() {
  paused_ = false;
  if (phase_ == Phase::kStopped) {
    phase_ = Phase::kIdle;
    Event("the queue resumed after: " + stopped_reason_);
    stopped_reason_.clear();
    return;
  }
  Event("the queue resumed");
}

// --- rig buses

void TurnManager::Attach(Rig& rig) {
  if (rig.bus) return;
  rig.bus = rig.factory();
  rig.plans.clear();
  client::Options client_options;
  client_options.sender = options_.sender;
  rig.client = std::make_unique<client::Client>(*rig.bus, client_options);
  rig.request.reset();
  rig.answer.reset();
  const core::Channels& c = channels_;
  auto to_arm = [this, &rig](const auto& channel, bool always) {
    using Msg = typename std::decay_t<decltype(channel)>::Message;
    rig.subscriptions.push_back(&rig.bus->Subscribe<Msg>(
        channel,
        [this, channel, always, &rig](const Msg& message, const core::ReceiveInfo&) {
          if (always || (relay_on_ && holder_ == &rig)) arm_bus_.Publish(channel, message);
        },
        1000));
  };
  to_arm(c.arm_move, false);
  to_arm(c.arm_gains, false);
  to_arm(c.controller_status, false);
  to_arm(c.robot_model, false);
  to_arm(c.hardware_command, false);
  if (!options_.relay_estop_from_all_rigs) to_arm(c.estop, true);
  rig.subscriptions.push_back(&rig.bus->Subscribe<sirupp::controller_status_t>(
      c.controller_status,
      [this, &rig](const sirupp::controller_status_t& status, const core::ReceiveInfo&) {
        if (phase_ == Phase::kTurn && !status.plan_name.empty() && status.plan_step >= 0) {
          rig.plans.insert(status.plan_name);
        }
      },
      100));
  rig.virtual_subscription = &rig.bus->Subscribe<sirupp::arm_state_t>(
      c.sim_arm_state,
      [&rig](const sirupp::arm_state_t& state, const core::ReceiveInfo&) {
        rig.virtual_arm = state;
      },
      2);
  rig.subscriptions.push_back(rig.virtual_subscription);
}

void TurnManager::Detach(Rig& rig) {
  for (core::Subscription* s : rig.subscriptions) s->Unsubscribe();
  rig.subscriptions.clear();
  rig.virtual_subscription = nullptr;
  rig.virtual_arm.reset();
  rig.client.reset();  // unsubscribes from the rig's bus
  rig.bus.reset();
}

// --- the arm

void TurnManager::Command(client::HardwareCommand command) {
  request_ = arm_client_->SendHardware(command);
  answer_.reset();
}

void TurnManager::Move(bool stop, const std::vector<double>& goal, double speed_fraction) {
  core::ServoMove move;
  move.move_id = ++move_id_;
  move.command = stop ? core::MoveCommand::kStopSmooth : core::MoveCommand::kMove;
  for (size_t j = 0; j < model_.joints.size(); ++j) {
    const core::ServoParams& p = model_.joints[j].servo;
    move.joints.push_back({stop ? 0.0 : goal[j], p.default_velocity * speed_fraction,
                           p.default_acceleration, sirupp::servo_move_t::FLAG_ACTIVE});
  }
  request_ = arm_client_->SendServoMove(move);
  answer_.reset();
}

std::string TurnManager::BridgeTrouble() const {
  if (!hardware_) return "no HARDWARE_STATUS from sirupp-hardware";
  if (hardware_->state == Status::STATE_FAULT)
    return "the bridge faulted: " + hardware_->last_error;
  if (hardware_->state == Status::STATE_ESTOPPED) {
    return "the real arm is e-stopped: " + hardware_->last_error;
  }
  if (answer_ && !answer_->accepted()) return "the bridge refused: " + answer_->error;
  return "";
}

void TurnManager::ThrowOnBridgeTrouble() const {
  if (const std::string trouble = BridgeTrouble(); !trouble.empty()) throw TurnError(trouble);
}

TurnManager::Step TurnManager::CommandStep(const std::string& name,
                                           client::HardwareCommand command) {
  return {name, [this, command] { Command(command); },
          [this, command] { return CommandDone(command); }, options_.step_timeout_s, true};
}

bool TurnManager::BridgeSilent() const { return hardware_ && Since(hardware_at_) > kBridgeSilentS; }

bool TurnManager::MoveDone() const {
  ThrowOnBridgeTrouble();
  // The reply names the bridge's last status before the move; the modules' MOVE_DONE bits are
  // about the move only in a status polled after it: the second one after the reply.
  return answer_ && answer_->accepted() && hardware_ && hardware_->seq >= answer_->status_seq + 2 &&
         client::HardwareMovesDone(*hardware_);
}

bool TurnManager::CommandDone(client::HardwareCommand command) const {
  ThrowOnBridgeTrouble();
  // The status the reply names shows the command's effect.
  return answer_ && answer_->accepted() && hardware_ && hardware_->seq >= answer_->status_seq &&
         client::HardwareCommandDone(command, *hardware_);
}

std::pair<double, int> TurnManager::RealOffset(const std::vector<double>& goal) const {
  std::pair<double, int> worst{std::numeric_limits<double>::infinity(), 0};
  if (!real_ || real_->position.size() != goal.size()) return worst;
  worst.first = 0;
  for (size_t j = 0; j < goal.size(); ++j) {
    const double off = std::abs(real_->position[j] - goal[j]) / kDeg;
    if (off > worst.first || worst.second == 0) worst = {off, static_cast<int>(j) + 1};
  }
  return worst;
}

std::vector<double> TurnManager::HomePose() const {
  std::vector<double> home;
  for (const core::Joint& j : model_.joints) home.push_back(j.home);
  return home;
}

double TurnManager::EstimatedHandoverS() const {
  if (handover_durations_s_.empty()) return 10;
  std::vector<double> sorted = handover_durations_s_;
  std::sort(sorted.begin(), sorted.end());
  return sorted[sorted.size() / 2];
}

// --- handovers

void TurnManager::StartHandoverIn(const std::string& student) {
  Rig& rig = RigOf(student);
  std::string refusal = options_.admit ? options_.admit(student) : "";
  if (refusal.empty()) {
    try {
      Attach(rig);  // the rig's bus (a rig that stopped has none)
    } catch (const std::exception& e) {
      Detach(rig);
      refusal = e.what();
    }
  }
  if (!refusal.empty()) {
    Event("handover to " + student + " not begun: " + refusal + "; their turn is skipped");
    return;
  }
  holder_ = &rig;
  phase_ = Phase::kHandoverIn;
  handover_started_ = Now();
  Event("handover to " + student + " begins");
  std::vector<Step> steps;
  steps.push_back({"the bridge is ready", nullptr,
                   [this] {
                     if (const std::string trouble = BridgeTrouble(); !trouble.empty()) {
                       if (!hardware_ || Since(hardware_at_) > kBridgeSilentS)
                         return false;  // may come
                       throw TurnError(trouble);
                     }
                     if (!hardware_->calibrated) throw TurnError("the real arm is not calibrated");
                     return hardware_->state == Status::STATE_CONNECTED ||
                            hardware_->state == Status::STATE_ARMED;
                   },
                   options_.step_timeout_s, false});
  steps.push_back(
      {"the virtual arm to the real arm's pose",
       [this] {
         if (!real_) throw TurnError("no REAL_ARM_STATE from sirupp-hardware");
         Rig& holder = *holder_;
         core::PlanCommand abort;  // refused when no plan runs: nothing to abort
         abort.command = core::PlanAction::kAbort;
         holder.client->SendPlanCommand(abort);
         core::JointTarget target;
         for (double q : real_->position) target.joints.push_back({q, 0, 0, true});
         holder.request = holder.client->SendJointTarget(target);
         holder.answer.reset();
       },
       [this] {
         Rig& holder = *holder_;
         const auto& c = holder.client->snapshot().controller;
         if (c && c->state == sirupp::controller_status_t::STATE_FAULT) {
           throw TurnError(holder.student + "'s rig is faulted: " + c->last_error);
         }
         if (!holder.answer) holder.answer = holder.client->HeardControllerAnswer(*holder.request);
         if (!holder.answer) return false;
         if (!holder.answer->accepted()) {
           throw TurnError(holder.student + "'s rig refused the move to the real arm's pose: " +
                           holder.answer->error);
         }
         const auto& v = holder.virtual_arm;
         if (!c || !v || !real_ || v->position.size() != real_->position.size()) return false;
         // A status sent after the move was taken, showing it ended.
         if (c->seq < holder.answer->status_seq ||
             c->state != sirupp::controller_status_t::STATE_IDLE) {
           return false;
         }
         for (size_t j = 0; j < v->position.size(); ++j) {
           if (std::abs(v->position[j] - real_->position[j]) > options_.pose_tolerance_deg * kDeg) {
             return false;
           }
         }
         return true;
       },
       options_.step_timeout_s + 10, false});
  steps.push_back(CommandStep("arm the real arm", client::HardwareCommand::kArm));
  steps.push_back({"link the rig",
                   [this] {
                     relay_on_ = true;
                     if (holder_->virtual_subscription != nullptr) {
                       holder_->virtual_subscription->Unsubscribe();  // per tick: not needed now
                       auto& subs = holder_->subscriptions;
                       subs.erase(
                           std::remove(subs.begin(), subs.end(), holder_->virtual_subscription),
                           subs.end());
                       holder_->virtual_subscription = nullptr;
                     }
                     Command(client::HardwareCommand::kLink);
                   },
                   [this] { return CommandDone(client::HardwareCommand::kLink); },
                   options_.step_timeout_s, true});
  steps_ = std::move(steps);
  step_ = 0;
  step_entered_ = false;
}

void TurnManager::StartTurn() {
  phase_ = Phase::kTurn;
  steps_.clear();
  const double handover_s = Since(handover_started_);
  handover_durations_s_.push_back(handover_s);
  turn_end_ = Now() + std::chrono::duration_cast<Clock::duration>(
                          std::chrono::duration<double>(options_.turn_s));
  warned_.assign(options_.warn_before_s.size(), false);
  TurnRecord record;
  record.student = holder_->student;
  record.start_wall_us = core::WallMicros();
  record.handover_in_s = handover_s;
  history_.push_back(record);
  Event(holder_->student + "'s turn on the real arm begins (" + Fixed1(options_.turn_s) +
        " s; handover " + Fixed1(handover_s) + " s)");
}

void TurnManager::EndTurnNow(const std::string& why) {
  TurnRecord& record = history_.back();
  record.end_wall_us = core::WallMicros();
  record.ended = why;
  record.plans.assign(holder_->plans.begin(), holder_->plans.end());
  Event(holder_->student + "'s turn ends: " + why);
  StartHandoverOut();
}

void TurnManager::StartHandoverOut() {
  phase_ = Phase::kHandoverOut;
  handover_started_ = Now();
  const std::vector<double> home = HomePose();
  std::vector<Step> steps;
  steps.push_back({"unlink the rig and hold the arm",
                   [this] {
                     RelayOff();
                     Move(true, {}, 1.0);
                   },
                   [this] { return MoveDone() && Since(step_started_) > 0.3; },
                   options_.step_timeout_s, true});
  // The farthest joint's travel at the reduced speed, as the step's extra time.
  double travel_s = 0;
  if (real_) {
    for (size_t j = 0; j < home.size() && j < real_->position.size(); ++j) {
      const double v = model_.joints[j].servo.default_velocity * options_.home_speed_fraction;
      if (v > 0) travel_s = std::max(travel_s, std::abs(real_->position[j] - home[j]) / v);
    }
  }
  steps.push_back({"home at reduced speed",
                   [this, home] { Move(false, home, options_.home_speed_fraction); },
                   [this] { return MoveDone() && Since(step_started_) > 0.3; },
                   options_.step_timeout_s + travel_s, true});
  // The check: every joint within home_tolerance_deg of home. A joint held short of home by its
  // static friction (the PD law has no integral by default, so it stops where its torque no longer
  // overcomes it) is corrected: a slow move to home plus the error, which stops again about that
  // far short, i.e. at home; at most kHomeCorrections times, each for errors of at most
  // kMaxCorrectionDeg (a larger one is no friction: the check fails at once).
  steps.push_back(
      {"check the pose", [this] { corrections_ = 0; },
       [this, home] {
         // A correction under way is judged once done: passing within the tolerance on its way
         // is not arriving (the arm would be disarmed mid-move).
         if (corrections_ > 0 && !MoveDone()) return false;
         const auto [offset, joint] = RealOffset(home);
         if (offset <= options_.home_tolerance_deg) return true;
         const double since = corrections_ == 0 ? Since(step_started_) : Since(correction_at_);
         if (since < 1.0) return false;  // let it settle
         const std::string off = "joint " + std::to_string(joint) + " is " + Fixed1(offset) +
                                 " deg away (allowed " + Fixed1(options_.home_tolerance_deg) +
                                 " deg)";
         if (corrections_ >= kHomeCorrections || offset > kMaxCorrectionDeg) {
           throw TurnError("the arm did not reach home: " + off +
                           (corrections_ > 0
                                ? " after " + std::to_string(corrections_) + " correction(s)"
                                : ""));
         }
         std::vector<double> goal = home;
         for (size_t j = 0; j < goal.size() && j < real_->position.size(); ++j) {
           const double error = home[j] - real_->position[j];
           if (std::abs(error) > 0.25 * kDeg) goal[j] = home[j] + error;
         }
         Event("homing: " + off + "; correction " + std::to_string(corrections_ + 1) +
               ": a slow move to home plus that error (held short by friction)");
         Move(false, goal, options_.home_speed_fraction * 0.5);
         ++corrections_;
         correction_at_ = Now();
         return false;
       },
       options_.step_timeout_s + 10, true});
  // One command per step, each waited for: a refused UNLINK (the bridge may still be linked to
  // the rig) stops the queue with the bridge's reason instead of going on to disarm.
  steps.push_back(CommandStep("unlink the bridge", client::HardwareCommand::kUnlink));
  steps.push_back(CommandStep("disarm", client::HardwareCommand::kDisarm));
  steps_ = std::move(steps);
  step_ = 0;
  step_entered_ = false;
}

void TurnManager::FinishHandoverOut() {
  const double handover_s = Since(handover_started_);
  handover_durations_s_.push_back(handover_s);
  TurnRecord& record = history_.back();
  record.handover_out_s = handover_s;
  record.handover_result = "ok";
  const auto [offset, joint] = RealOffset(HomePose());
  std::string plans = "[";
  for (size_t i = 0; i < record.plans.size(); ++i) {
    plans += (i > 0 ? ", " : "") + Quoted(record.plans[i]);
  }
  plans += "]";
  LogJson("{\"turn\": " + Quoted(record.student) +
          ", \"start_us\": " + std::to_string(record.start_wall_us) +
          ", \"end_us\": " + std::to_string(record.end_wall_us) + ", \"plans\": " + plans +
          ", \"ended\": " + Quoted(record.ended) + ", \"handover_in_s\": " +
          Fixed1(record.handover_in_s) + ", \"handover_out_s\": " + Fixed1(handover_s) +
          ", \"home_offset_deg\": " + std::to_string(offset) + ", \"handover\": \"ok\"}");
  Event("handover after " + record.student + "'s turn done in " + Fixed1(handover_s) +
        " s: the arm is home (joint " + std::to_string(joint) + " off by " + Fixed1(offset) +
        " deg at most) and disarmed");
  Detach(*holder_);
  holder_ = nullptr;
  phase_ = Phase::kIdle;
  steps_.clear();
}

void TurnManager::RelayOff() {
  if (relay_on_ && holder_ != nullptr && holder_->bus && hardware_) {
    Status unlinked = *hardware_;
    if (unlinked.state == Status::STATE_LINKED) unlinked.state = Status::STATE_ARMED;
    unlinked.utime = core::WallMicros();
    unlinked.last_error = "unlinked from this rig: the turn ended";
    holder_->bus->Publish(channels_.hardware_status, unlinked);
  }
  relay_on_ = false;
}

void TurnManager::Fail(const std::string& reason) {
  const Step& step = steps_[step_];
  const std::string student = holder_ != nullptr ? holder_->student : "";
  RelayOff();
  if (phase_ == Phase::kHandoverIn && !step.arm_touched) {
    // Nothing of the arm was touched: only this student's turn is skipped.
    Event("handover to " + student + " failed at '" + step.name + "': " + reason +
          "; their turn is skipped");
    Detach(*holder_);
    holder_ = nullptr;
    phase_ = Phase::kIdle;
    steps_.clear();
    return;
  }
  stopped_reason_ = std::string(phase_ == Phase::kHandoverIn ? "handover to " : "handover after ") +
                    student + (phase_ == Phase::kHandoverIn ? "" : "'s turn") + " failed at '" +
                    step.name + "': " + reason;
  if (phase_ == Phase::kHandoverOut && !history_.empty()) {
    history_.back().handover_result = stopped_reason_;
    LogJson("{\"turn\": " + Quoted(student) + ", \"ended\": " + Quoted(history_.back().ended) +
            ", \"handover\": " + Quoted(stopped_reason_) + "}");
  }
  phase_ = Phase::kStopped;
  if (holder_ != nullptr) Detach(*holder_);
  holder_ = nullptr;
  steps_.clear();
  Event("the queue is STOPPED: " + stopped_reason_ +
        ". Nobody gets the arm until the teacher has seen to it and resumes the queue.");
}

void TurnManager::StepHandover() {
  while (step_ < steps_.size()) {
    Step& step = steps_[step_];
    bool done = false;
    try {
      if (!step_entered_) {
        step_entered_ = true;
        step_started_ = Now();
        if (step.enter) step.enter();
      }
      // A bridge silent for a while (a command that takes it long on a loaded machine, or a
      // bridge that is gone) is waited for: what it said last may be stale. The step's timeout
      // ends the wait, naming the silence.
      done = !BridgeSilent() && step.done();
    } catch (const TurnError& error) {
      Fail(error.what());
      return;
    }
    if (!done) {
      if (Since(step_started_) > step.timeout_s) {
        Fail("not done within " + Fixed1(step.timeout_s) + " s" +
             (BridgeSilent() ? " (sirupp-hardware silent for " + Fixed1(Since(hardware_at_)) + " s)"
              : hardware_    ? " (bridge " + BridgeStateName(hardware_->state) + ")"
                             : ""));
      }
      return;
    }
    ++step_;
    step_entered_ = false;
  }
  if (phase_ == Phase::kHandoverIn) {
    StartTurn();
  } else {
    FinishHandoverOut();
  }
}

void TurnManager::Service() {
  arm_bus_.HandleAvailable();
  // The holder's bus carries all of the rig's per-tick traffic: drained in slices with the arm's
  // bus between them, so that a backlog (a loaded machine) never leaves the bridge's status
  // unread long enough to look silent.
  if (holder_ != nullptr && holder_->bus) {
    constexpr int kSlice = 200;
    for (int slice = 0; slice < 100; ++slice) {
      const int handled = holder_->bus ? holder_->bus->HandleAvailable(kSlice) : 0;
      arm_bus_.HandleAvailable();
      if (handled < kSlice) break;
    }
  }
  for (auto& [name, rig] : rigs_) {
    if (rig->estop_bus) rig->estop_bus->HandleAvailable();
  }
  // The answer to our latest request, once the bridge's reply was heard.
  if (request_ && !answer_) answer_ = arm_client_->HeardHardwareAnswer(*request_);
  // While we drive the arm ourselves (hold, home), the bridge's command expiry hears from us.
  if (phase_ == Phase::kHandoverOut && !relay_on_ && Since(last_liveness_) >= kLivenessPeriodS) {
    sirupp::controller_status_t alive{};
    alive.utime = core::WallMicros();
    alive.seq = seq_++;
    alive.last_error = "";
    arm_bus_.Publish(channels_.controller_status, alive);
    last_liveness_ = Now();
  }
  switch (phase_) {
    case Phase::kIdle:
      if (!paused_ && !queue_.empty()) {
        const std::string next = queue_.front();
        queue_.erase(queue_.begin());
        StartHandoverIn(next);
        if (phase_ == Phase::kHandoverIn) StepHandover();  // else skipped
      }
      break;
    case Phase::kHandoverIn:
    case Phase::kHandoverOut:
      StepHandover();
      break;
    case Phase::kTurn: {
      const double left = std::chrono::duration<double>(turn_end_ - Now()).count();
      for (size_t i = 0; i < options_.warn_before_s.size(); ++i) {
        if (!warned_[i] && left <= options_.warn_before_s[i] && left > 0) {
          warned_[i] = true;
          Event(holder_->student + ": your turn on the real arm ends in " +
                Fixed1(options_.warn_before_s[i]) + " s");
        }
      }
      if (left <= 0) EndTurnNow("time up");
      break;
    }
    case Phase::kStopped:
      break;
  }
}

TurnStatus TurnManager::status() const {
  TurnStatus s;
  s.phase = phase_;
  s.holder = holder_ != nullptr ? holder_->student : "";
  if (phase_ == Phase::kTurn) {
    s.turn_left_s = std::max(0.0, std::chrono::duration<double>(turn_end_ - Now()).count());
  }
  if ((phase_ == Phase::kHandoverIn || phase_ == Phase::kHandoverOut) && step_ < steps_.size()) {
    s.step = steps_[step_].name;
  }
  s.paused = paused_;
  s.stopped_reason = stopped_reason_;
  if (!hardware_) {
    s.bridge = "not heard";
  } else if (Since(hardware_at_) > kBridgeSilentS) {
    s.bridge = "silent " + Fixed1(Since(hardware_at_)) + " s";
  } else {
    s.bridge = BridgeStateName(hardware_->state) +
               (hardware_->last_error.empty() ? "" : " (" + hardware_->last_error + ")");
  }
  s.last_event = last_event_;
  // The wait: what is left of the present turn and its handover, then a turn and a handover for
  // each student ahead.
  double ahead = 0;
  const double handover = EstimatedHandoverS();
  if (phase_ == Phase::kTurn) ahead = s.turn_left_s + handover;
  if (phase_ == Phase::kHandoverIn) ahead = options_.turn_s + 2 * handover;
  if (phase_ == Phase::kHandoverOut) ahead = handover;
  for (const std::string& student : queue_) {
    s.queue.push_back({student, ahead});
    ahead += options_.turn_s + 2 * handover;
  }
  return s;
}

}  // namespace sirupp::turns
