#include "hardware/bridge_node.hpp"

#include <poll.h>

#include <algorithm>
#include <ctime>
#include <iostream>
#include <sirupp/arm_state_t.hpp>
#include <sirupp/robot_model_t.hpp>

#include "core/errors.hpp"
#include "core/translate.hpp"

namespace sirupp::hardware {
namespace {

using sirupp::hardware_command_t;
using sirupp::hardware_status_t;

constexpr double kStatusPeriodS = 0.1;  // HARDWARE_STATUS at 10 Hz (and on every change)
constexpr double kGainsPeriodS = 1.0;   // REAL_ARM_GAINS at 1 Hz (and on every change)
constexpr double kServoTickS = 0.000512;

const char* CommandName(core::HardwareAction c) {
  switch (c) {
    case core::HardwareAction::kConnect:
      return "connect";
    case core::HardwareAction::kCalibrate:
      return "calibrate";
    case core::HardwareAction::kArm:
      return "arm";
    case core::HardwareAction::kDisarm:
      return "disarm";
    case core::HardwareAction::kLink:
      return "link";
    case core::HardwareAction::kUnlink:
      return "unlink";
    case core::HardwareAction::kHome:
      return "home";
    case core::HardwareAction::kClearFaults:
      return "clear-faults";
  }
  return "?";
}

std::string JointLabel(const core::RobotModel& model, size_t j) {
  return "module " + std::to_string(j + 1) + " (j" + std::to_string(j + 1) + " " +
         model.joints[j].name + ")";
}

// A bus error during `what` (a move, a command): named by the joint of the module that failed,
// as a fault found by a poll is, so a module that goes silent is one fault whenever it happens.
std::string BusFault(const core::RobotModel& model, const std::string& what, const BusError& e) {
  const size_t module = e.address();
  const std::string text = what + ": " + e.what();
  if (module < 1 || module > model.joints.size()) return text;
  return JointLabel(model, module - 1) + ": " + text;
}

}  // namespace

BridgeNode::BridgeNode(core::Bus& bus, const core::RobotModel& model, ArmLink& link,
                       BridgeSettings settings, BridgeOptions options)
    : bus_(bus),
      model_(model),
      link_(link),
      settings_(std::move(settings)),
      options_(std::move(options)),
      model_watch_(std::in_place, model_, options_.name),
      heartbeat_(bus, options_.name, options_.channels.heartbeat),
      replier_(bus, options_.channels.hardware_reply, options_.name),
      started_(Clock::now()),
      next_cycle_(Clock::now()) {
  const core::Channels& c = options_.channels;
  bus_.Subscribe<hardware_command_t>(
      c.hardware_command, [this](const hardware_command_t& m, const core::ReceiveInfo& info) {
        replier_.Answer(
            m, info, [&] { OnCommand(m, info); }, [this] { return Facts(); });
      });
  bus_.Subscribe<sirupp::servo_move_t>(
      c.arm_move,
      [this](const sirupp::servo_move_t& m, const core::ReceiveInfo& info) {
        replier_.Answer(
            m, info, [&] { OnMove(m, info); }, [this] { return Facts(); });
      },
      100);
  bus_.Subscribe<sirupp::servo_gains_t>(
      c.arm_gains, [this](const sirupp::servo_gains_t& m, const core::ReceiveInfo& info) {
        replier_.Answer(
            m, info, [&] { OnGains(m, info); }, [this] { return Facts(); });
      });
  bus_.Subscribe<sirupp::estop_t>(
      c.estop,
      [this](const sirupp::estop_t& m, const core::ReceiveInfo& info) { OnEstop(m, info); });
  bus_.Subscribe<sirupp::controller_status_t>(
      c.controller_status,
      [this](const sirupp::controller_status_t& m, const core::ReceiveInfo& info) {
        // Only a status a controller could have sent shows that one is alive; others are refused.
        core::ControllerStatusFromMessage(m, info.channel);
        NoteController();
      });
  // One robot: the real arm is not driven for a model other than the one the sim runs.
  bus_.Subscribe<sirupp::robot_model_t>(
      c.robot_model,
      [this](const sirupp::robot_model_t& m, const core::ReceiveInfo& info) { OnModel(m, info); });
  heartbeat_.Publish(core::ProcessState::kStarting, settings_.start_guard_s > 0
                                                        ? core::StartGuardDetail(StartGuardLeft())
                                                        : ModelDetail());
}

// The model file this bridge keeps, in its heartbeat's detail while all is well, so that a panel
// can tell a model load it would fault on (panel/panel_hub.hpp, BridgeRefusal).
std::string BridgeNode::ModelDetail() const {
  return "model " + model_.name + " hash " + model_.source_hash;
}

void BridgeNode::OnModel(const sirupp::robot_model_t& message, const core::ReceiveInfo& info) {
  if (!model_watch_->Check(message, info.channel) || model_watch_->mismatch().empty()) return;
  if (linked_) {
    Fault(model_watch_->mismatch());  // the arm was driven for the old one: it stops
    return;
  }
  // Not driving the arm: take the sim's model, so that a later link drives the robot it runs.
  core::RobotModel sims = core::RobotModelFromMessage(message, info.channel);
  const auto take = [&] {
    model_ = std::move(sims);
    model_watch_.emplace(model_, options_.name);
    model_watch_->Check(message, info.channel);  // now a match
  };
  try {
    const BridgeSettings settings = SettingsForModel(settings_, sims);
    link_.ReplaceModel(sims, settings);
    settings_ = settings;
  } catch (const BusError& e) {
    take();  // taken, but a module did not take the new model's gains
    Fault(std::string("the new model's gains: ") + e.what());
    return;
  } catch (const std::exception& e) {
    last_error_ = model_watch_->mismatch() + " (not taken: " + e.what() + ")";
    std::cerr << options_.name << ": " << last_error_ << "\n";
    PublishStatus();
    return;
  }
  take();
  last_error_.clear();
  std::cerr << options_.name << ": not linked: took the sim's " << ModelDetail() << " from "
            << model_.source_file << "\n";
  PublishStatus();
}

core::ReplyFacts BridgeNode::Facts() const {
  core::ReplyFacts facts;
  facts.status_seq = status_seq_ - 1;
  return facts;
}

int8_t BridgeNode::state() const {
  if (estopped_) return hardware_status_t::STATE_ESTOPPED;
  if (faulted_) return hardware_status_t::STATE_FAULT;
  if (!link_.connected()) return hardware_status_t::STATE_DISCONNECTED;
  if (!link_.armed()) return hardware_status_t::STATE_CONNECTED;
  return linked_ ? hardware_status_t::STATE_LINKED : hardware_status_t::STATE_ARMED;
}

void BridgeNode::Connect() {
  linked_ = false;
  faulted_ = false;
  link_.Connect();
  // Boards that had kept power without a calibration: the refusal to come is shown at once.
  last_error_ = link_.blind_reason().empty() ? "" : link_.connect_report();
  if (!link_.connect_report().empty()) {
    std::cerr << options_.name << ": " << link_.connect_report() << "\n";
  }
  PublishGains();  // the modules hold the gains sent during start-up
}
void BridgeNode::Calibrate() {
  try {
    link_.Calibrate();
  } catch (const CalibrationRefused& e) {
    last_error_ = e.what();
    PublishStatus();
    throw;
  }
  last_error_.clear();
}
void BridgeNode::Arm() {
  if (estopped_) throw std::runtime_error("arm: the emergency stop is engaged; release it first");
  if (faulted_) throw std::runtime_error("arm: clear the fault first (" + fault_ + ")");
  if (!model_watch_->mismatch().empty())
    throw std::runtime_error("arm: " + model_watch_->mismatch());
  link_.Arm();
  last_error_.clear();
}
void BridgeNode::Link() {
  if (estopped_) throw std::runtime_error("link: the emergency stop is engaged");
  if (faulted_) throw std::runtime_error("link: clear the fault first (" + fault_ + ")");
  if (!model_watch_->mismatch().empty())
    throw std::runtime_error("link: " + model_watch_->mismatch());
  if (!link_.armed()) throw std::runtime_error("link: arm first");
  linked_ = true;
  expired_ = false;
  NoteController();
}

void BridgeNode::Refuse(const std::string& channel, const std::string& problem) {
  last_error_ = core::MessageError(channel, "", problem).what();
  PublishStatus();
  throw core::MessageError(channel, "", problem);
}

void BridgeNode::CheckStartGuard(const std::string& channel) {
  const double left = StartGuardLeft();
  if (left > 0) {
    Refuse(channel, std::string(core::kStartGuardWord) + ": commands are refused for the first " +
                        core::FormatNumber(settings_.start_guard_s) + " s after start-up (" +
                        core::FormatApprox(left) + " s left)");
  }
}

template <class Value, class Msg>
Value BridgeNode::Decoded(Value (*from_message)(const Msg&, const std::string&), const Msg& message,
                          const std::string& channel) {
  try {
    return from_message(message, channel);
  } catch (const core::MessageError& error) {
    last_error_ = error.what();  // shown on HARDWARE_STATUS too; nothing moves
    PublishStatus();
    throw;
  }
}

void BridgeNode::OnCommand(const hardware_command_t& m, const core::ReceiveInfo& info) {
  const core::HardwareCommand command = Decoded(core::HardwareCommandFromMessage, m, info.channel);
  CheckStartGuard(info.channel);
  ++state_commands_;
  const std::string what =
      std::string(CommandName(command.command)) + " from '" + command.sender + "'";
  try {
    Do(command.command, what, info.channel);
  } catch (const core::MessageError&) {
    throw;
  } catch (const BusError& e) {
    Fault(BusFault(model_, what, e));
    throw core::MessageError(info.channel, "", what + ": " + e.what());
  } catch (const std::exception& e) {
    Refuse(info.channel, what + ": " + e.what());
  }
  last_error_.clear();
  PublishStatus();
}

void BridgeNode::Do(core::HardwareAction action, const std::string& what,
                    const std::string& channel) {
  switch (action) {
    case core::HardwareAction::kConnect:
      if (link_.armed()) Refuse(channel, what + ": disarm first");
      Connect();
      break;
    case core::HardwareAction::kCalibrate:
      if (link_.armed()) Refuse(channel, what + ": disarm first (servos must be off)");
      Calibrate();
      break;
    case core::HardwareAction::kArm:
      Arm();
      break;
    case core::HardwareAction::kDisarm:
      linked_ = false;
      link_.Disarm();
      break;
    case core::HardwareAction::kLink:
      Link();
      break;
    case core::HardwareAction::kUnlink:
      linked_ = false;
      break;
    case core::HardwareAction::kHome: {
      if (estopped_ || faulted_ || !link_.armed()) Refuse(channel, what + ": the arm is not armed");
      std::vector<double> home;
      for (const core::Joint& j : model_.joints) home.push_back(j.home);
      const std::string refusal = link_.MoveAllTo(home);
      if (!refusal.empty()) Refuse(channel, what + ": " + refusal);
      break;
    }
    case core::HardwareAction::kClearFaults:
      link_.ClearFaults();
      faulted_ = false;
      if (link_.armed()) link_.Disarm();  // re-arm explicitly after a fault
      break;
  }
}

void BridgeNode::OnMove(const sirupp::servo_move_t& m, const core::ReceiveInfo& info) {
  NoteController();
  if (!linked_) return;  // the virtual arm's moves; mirrored only while linked
  const core::ServoMove move = Decoded(core::ServoMoveFromMessage, m, info.channel);
  CheckStartGuard(info.channel);
  const std::string what = "move " + std::to_string(move.move_id);
  if (estopped_) Refuse(info.channel, what + ": emergency stop engaged");
  if (faulted_) Refuse(info.channel, what + ": fault: " + fault_);
  const std::string refusal = link_.CheckMove(move);
  if (!refusal.empty()) Refuse(info.channel, what + ": " + refusal);
  try {
    link_.Execute(move);
  } catch (const BusError& e) {
    Fault(BusFault(model_, what, e));
    throw;
  }
  move_id_ = move.move_id;
  expired_ = false;
  ++moves_mirrored_;
}

void BridgeNode::OnEstop(const sirupp::estop_t& m, const core::ReceiveInfo& info) {
  const core::EStop estop = Decoded(core::EStopFromMessage, m, info.channel);
  ++state_commands_;
  if (estop.engaged) {
    linked_ = false;
    estopped_ = true;
    if (link_.connected()) link_.EmergencyStop();
    last_error_ = "emergency stop from '" + estop.sender + "': " + estop.reason;
    std::cerr << options_.name << ": " << last_error_ << ": motors stopped and off\n";
  } else if (estopped_) {
    estopped_ = false;  // the arm stays disarmed: nothing moves until ARM (and LINK)
    last_error_ = faulted_ ? fault_ : "";
  }
  PublishStatus();
}

void BridgeNode::OnGains(const sirupp::servo_gains_t& m, const core::ReceiveInfo& info) {
  std::vector<servo::ChipGains> gains;
  try {
    gains = servo::ChipGainsFromMessage(m, model_, info.channel);  // all of it, or nothing
  } catch (const core::MessageError& e) {
    last_error_ = e.what();
    PublishStatus();
    throw;
  }
  std::string changes;
  const std::vector<servo::ChipGains>& before = link_.gains();
  for (size_t j = 0; j < gains.size(); ++j) {
    const servo::ChipGains& a = before[j];
    const servo::ChipGains& b = gains[j];
    if (a == b) continue;
    changes += (changes.empty() ? " " : "; ") + std::string("j") + std::to_string(j + 1);
    const auto note = [&changes](const char* name, int from, int to) {
      if (from != to)
        changes += " " + std::string(name) + " " + std::to_string(from) + "->" + std::to_string(to);
    };
    note("Kp", a.kp, b.kp);
    note("Kd", a.kd, b.kd);
    note("Ki", a.ki, b.ki);
    note("IL", a.integration_limit, b.integration_limit);
    note("OL", a.output_limit, b.output_limit);
    note("CL", a.current_limit, b.current_limit);
    note("EL", a.error_limit, b.error_limit);
    note("DB", a.deadband, b.deadband);
  }
  try {
    link_.SetGains(gains);
  } catch (const BusError& e) {
    Fault("gains from " + info.channel + ": " + e.what());
    throw core::MessageError(info.channel, "", std::string("SET_GAIN failed: ") + e.what());
  }
  std::cerr << options_.name << ": gains from " << info.channel << ":"
            << (changes.empty() ? " unchanged" : changes)
            << (link_.connected() ? "; sent to every module" : "; kept for the next connect")
            << "\n";
  PublishGains();
}

void BridgeNode::PublishGains() {
  last_gains_ = Clock::now();
  if (!link_.connected()) return;
  std::vector<servo::ChipGains> held;
  for (const auto& g : link_.board_gains()) {
    if (!g) return;  // a module's gains are unknown (a failed SET_GAIN): nothing to claim
    held.push_back(*g);
  }
  sirupp::servo_gains_t m = servo::GainsMessage(held);
  m.utime = std::chrono::duration_cast<std::chrono::microseconds>(
                std::chrono::system_clock::now().time_since_epoch())
                .count();
  m.seq = gains_seq_++;
  bus_.Publish(options_.channels.real_arm_gains, m);
}

void BridgeNode::Fault(const std::string& problem) {
  const bool first = !faulted_;
  faulted_ = true;
  linked_ = false;
  last_error_ = problem;
  if (first) fault_ = problem;
  if (first) std::cerr << options_.name << ": FAULT: " << problem << "\n";
  if (first && link_.connected()) {
    try {
      link_.StopAllSmoothly();
    } catch (const std::exception&) {
      // the port itself failed; the next poll reports it
    }
  }
  PublishStatus();
}

void BridgeNode::CheckSafety() {
  const ArmReading& r = reading_;
  const size_t n = r.answered.size();
  for (size_t j = 0; j < n; ++j) {
    if (!r.answered[j]) {
      Fault(JointLabel(model_, j) + ": " + r.errors[j]);
      return;
    }
  }
  if (link_.armed() && !faulted_) {
    for (size_t j = 0; j < n; ++j) {
      if (r.status[j] & nmc::kStatusOvercurrent) {
        Fault(JointLabel(model_, j) + ": OVERCURRENT (current limit tripped)");
        return;
      }
      if (r.status[j] & nmc::kStatusPositionError) {
        Fault(JointLabel(model_, j) + ": POS_ERR: position error over the limit of " +
              std::to_string(std::lround(model_.joints[j].servo.error_limit)) +
              " counts, servo off");
        return;
      }
    }
  }
  // Velocity-mode joints stop at the soft limits.
  for (size_t j = 0; j < n; ++j) {
    if (!link_.velocity_mode()[j]) continue;
    const int jj = static_cast<int>(j);
    const double q = r.position[j];
    if ((q < SoftMin(model_, settings_, jj) && r.velocity[j] < 0) ||
        (q > SoftMax(model_, settings_, jj) && r.velocity[j] > 0)) {
      link_.StopAllSmoothly();
      last_error_ = JointLabel(model_, j) + ": reached its soft limit in velocity mode; stopped";
    }
  }
  // Command expiry: linked and moving, with the controller silent.
  bool moving = false;
  for (size_t j = 0; j < n; ++j) moving |= !(r.status[j] & nmc::kStatusMoveDone);
  const double silent = std::chrono::duration<double>(Clock::now() - last_controller_).count();
  if (linked_ && moving && !expired_ && silent > settings_.command_timeout_s) {
    expired_ = true;
    link_.StopAllSmoothly();
    last_error_ = "commands expired: nothing from the controller for " +
                  core::FormatApprox(silent) + " s (limit " +
                  core::FormatNumber(settings_.command_timeout_s) + " s); stopped smoothly";
  }
}

void BridgeNode::Cycle() {
  if (link_.connected()) {
    try {
      reading_ = link_.Poll();
    } catch (const std::exception& e) {  // the port itself failed
      Fault(std::string("serial port: ") + e.what());
      return;
    }
    ++polls_;
    if (first_poll_us_ == 0) first_poll_us_ = reading_.wall_us;
    // What arrived during a slow poll first: the controller's liveness is judged on it.
    const int64_t commands_before = state_commands_;
    bus_.HandleAvailable();
    // A reading taken before a command changed the arm's state (arming clears POS_ERR, which is
    // set while a servo is off) says nothing about the new state: the next poll is judged.
    if (state_commands_ == commands_before) CheckSafety();
    PublishState();
  }
  const double since = std::chrono::duration<double>(Clock::now() - last_status_).count();
  if (since >= kStatusPeriodS || state() != last_published_state_) PublishStatus();
  if (std::chrono::duration<double>(Clock::now() - last_gains_).count() >= kGainsPeriodS) {
    PublishGains();
  }
  const bool bad = faulted_ || estopped_;
  // Not ready while the start guard refuses commands: the launcher, `sirupp demo`, the panel's
  // process table and a client about to send a move all wait for the next state (docs/launch.md).
  const double guard_left = StartGuardLeft();
  if (!bad && guard_left > 0) {
    heartbeat_.PublishIfDue(core::ProcessState::kStarting, core::StartGuardDetail(guard_left));
    return;
  }
  heartbeat_.PublishIfDue(bad ? core::ProcessState::kFault : core::ProcessState::kRunning,
                          bad                   ? last_error_
                          : last_error_.empty() ? ModelDetail()
                                                : ModelDetail() + "; " + last_error_);
}

double BridgeNode::StartGuardLeft() const {
  return settings_.start_guard_s - std::chrono::duration<double>(Clock::now() - started_).count();
}

void BridgeNode::Service(int max_wait_ms) {
  const auto now = Clock::now();
  if (now >= next_cycle_) {
    Cycle();
    const auto period = std::chrono::duration_cast<Clock::duration>(
        std::chrono::duration<double>(1.0 / settings_.poll_rate_hz));
    next_cycle_ += period;
    if (next_cycle_ < Clock::now()) next_cycle_ = Clock::now();  // late: no burst to catch up
  }
  // Until the next poll, to the microsecond: LCM's own wait counts whole milliseconds, and the
  // rest of one would be spent spinning (at real-time priority, a core taken from the others).
  const int64_t wait_us = std::clamp<int64_t>(
      std::chrono::duration_cast<std::chrono::microseconds>(next_cycle_ - Clock::now()).count(), 0,
      int64_t{max_wait_ms} * 1000);
  pollfd readable{bus_.Fileno(), POLLIN, 0};
  const timespec timeout{static_cast<time_t>(wait_us / 1000000),
                         static_cast<long>(wait_us % 1000000) * 1000};
  if (::ppoll(&readable, 1, &timeout, nullptr) > 0) bus_.HandleAvailable();
}

void BridgeNode::PublishState() {
  const ArmReading& r = reading_;
  const size_t n = r.position.size();
  core::ArmState s;
  s.utime = r.wall_us;
  s.tick =
      static_cast<int64_t>(static_cast<double>(r.wall_us - first_poll_us_) * 1e-6 / kServoTickS);
  s.source = settings_.emulated ? core::StateSource::kEmulated : core::StateSource::kReal;
  s.position = r.position;
  s.velocity = r.velocity;
  s.effort = r.effort;
  s.flags.assign(n, 0);
  // REAL_ARM_SETPOINT: the chips' own command position; they report no profile velocity (0).
  core::ServoSetpoint sp;
  sp.utime = r.wall_us;
  sp.seq = setpoint_seq_++;
  sp.tick = s.tick;
  sp.move_id = move_id_;
  const std::vector<double>& goals = link_.goals();
  sp.joints.resize(n);
  for (size_t j = 0; j < n; ++j) {
    core::JointSetpoint& joint = sp.joints[j];
    joint.position = r.setpoint[j];
    joint.goal = j < goals.size() ? goals[j] : 0.0;
    joint.position_error = r.setpoint[j] - r.position[j];
    joint.effort = r.effort[j];
    int8_t& f = s.flags[j];
    if (r.status[j] & nmc::kStatusLimit1) f |= sirupp::arm_state_t::FLAG_AT_LOWER_LIMIT;
    if (r.status[j] & nmc::kStatusLimit2) f |= sirupp::arm_state_t::FLAG_AT_UPPER_LIMIT;
    if (!r.answered[j] ||
        (r.status[j] & (nmc::kStatusOvercurrent | nmc::kStatusPositionError) && link_.armed())) {
      f |= sirupp::arm_state_t::FLAG_FAULT;
    }
    int8_t& st = joint.status;
    if (r.status[j] & nmc::kStatusMoveDone) st |= sirupp::servo_setpoint_t::STATUS_MOVE_DONE;
    if (r.aux[j] & nmc::kAuxServoOn) st |= sirupp::servo_setpoint_t::STATUS_SERVO_ON;
    if (r.status[j] & nmc::kStatusPositionError) st |= sirupp::servo_setpoint_t::STATUS_POS_ERROR;
  }
  bus_.Publish(options_.channels.real_arm_state, core::ToMessage(s, state_seq_++));
  bus_.Publish(options_.channels.real_arm_setpoint, core::ToMessage(sp));
}

void BridgeNode::PublishStatus() {
  core::HardwareStatus status;
  status.utime = std::chrono::duration_cast<std::chrono::microseconds>(
                     std::chrono::system_clock::now().time_since_epoch())
                     .count();
  status.seq = status_seq_++;
  status.state = static_cast<core::BridgeState>(state());
  status.calibrated = link_.calibrated();
  status.port = link_.bus().port().name();
  status.baud = link_.bus().port().baud();
  status.modules.resize(static_cast<size_t>(link_.num_joints()));
  for (size_t j = 0; j < status.modules.size() && j < reading_.answered.size(); ++j) {
    status.modules[j] = {reading_.status[j], reading_.aux[j], reading_.counts[j],
                         reading_.position_error[j]};
  }
  const BusCounters& c = link_.bus().counters();
  status.checksum_errors = c.checksum_errors + c.module_checksum_errors;
  status.timeouts = c.timeouts;
  status.resyncs = c.resyncs;
  status.last_error = last_error_;
  bus_.Publish(options_.channels.hardware_status, core::ToMessage(status));
  last_status_ = Clock::now();
  last_published_state_ = static_cast<int8_t>(status.state);
}

void BridgeNode::Shutdown() {
  linked_ = false;
  link_.Shutdown();
  try {
    PublishStatus();
    heartbeat_.Publish(core::ProcessState::kStopping, "motors off, amplifiers disabled");
  } catch (const std::exception&) {
    // the bus is going away too
  }
}

}  // namespace sirupp::hardware
