#include "sim/sim_node.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <random>
#include <stdexcept>
#include <thread>
#include <utility>

#include "core/errors.hpp"
#include "core/translate.hpp"
#include "servo/chip_gains.hpp"
#include "sim/model_change.hpp"

namespace sirupp::sim {
namespace {

using TimePoint = NodeClock::TimePoint;

// Ticks run per Service() call in fast mode between two looks at the bus.
constexpr int kFastBatch = 64;
// Realtime and freerun: further behind than this, the node gives up catching up (the sim time
// slips) and reports it.
constexpr double kMaxCatchUpS = 0.1;
// A problem stays in the heartbeat (state degraded) this long after it last happened.
constexpr double kProblemMemoryS = 5.0;
// SIM_STATUS: at least once a second, at most this often when something changed.
constexpr double kStatusMinPeriodS = 0.1;
// Refusals: at most this many senders remembered (the rest counted together), at most this many
// lines printed per second.
constexpr size_t kMaxRefusingSenders = 32;
constexpr int kMaxRefusalLinesPerSecond = 10;
// Board commands waiting for the next answer of the participant that drives the boards.
constexpr size_t kMaxBoardQueue = 256;
// Lockstep: ticks stepped in one Service() call while every participant's answer covers them.
constexpr int kCoveredBatch = 64;
// Freerun and fast: at most this many senders held, each forgotten after this long without a word.
constexpr size_t kMaxFreeSenders = 64;
constexpr double kForgetSenderS = 10.0;

std::string JoinNames(const std::vector<std::string>& names) {
  std::string joined;
  for (const std::string& name : names) joined += (joined.empty() ? "" : ", ") + name;
  return joined;
}

double Seconds(std::chrono::steady_clock::duration duration) {
  return std::chrono::duration<double>(duration).count();
}

std::chrono::steady_clock::duration Duration(double seconds) {
  return std::chrono::duration_cast<std::chrono::steady_clock::duration>(
      std::chrono::duration<double>(seconds));
}

std::string Fixed(double value, int digits) {
  char text[48];
  std::snprintf(text, sizeof text, "%.*f", digits, value);
  return text;
}

int64_t NewRunId() {
  std::random_device device;
  std::uniform_int_distribution<int64_t> pick(1, INT64_MAX);
  return pick(device);
}

int64_t WallMicros() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

}  // namespace

NodeClock NodeClock::Steady() {
  NodeClock clock;
  clock.now = [] { return std::chrono::steady_clock::now(); };
  clock.sleep_until = [](TimePoint until) { std::this_thread::sleep_until(until); };
  return clock;
}

const char* TimingModeName(TimingMode mode) {
  switch (mode) {
    case TimingMode::kLockstep:
      return "lockstep";
    case TimingMode::kRealtime:
      return "realtime";
    case TimingMode::kFast:
      return "fast";
    case TimingMode::kFreeRun:
      return "freerun";
  }
  return "unknown";
}

TimingMode ParseTimingMode(const std::string& text) {
  if (text == "lockstep") return TimingMode::kLockstep;
  if (text == "realtime") return TimingMode::kRealtime;
  if (text == "fast") return TimingMode::kFast;
  if (text == "freerun") return TimingMode::kFreeRun;
  throw std::invalid_argument("timing mode '" + text +
                              "': allowed lockstep, realtime, fast, freerun");
}

void CheckNodeOptions(const NodeOptions& options) {
  auto bad = [](const std::string& what) { throw std::invalid_argument(what); };
  if (!options.clock.now || !options.clock.sleep_until) bad("clock: now and sleep_until needed");
  if (options.state_every < 1) {
    bad("state_every " + std::to_string(options.state_every) + ": allowed 1 or more ticks");
  }
  if (!(options.lockstep_timeout_s > 0) || !std::isfinite(options.lockstep_timeout_s)) {
    bad("lockstep timeout " + core::FormatNumber(options.lockstep_timeout_s) + " s: allowed > 0");
  }
  if (!(options.watchdog_s > 0) || !std::isfinite(options.watchdog_s)) {
    bad("watchdog " + core::FormatNumber(options.watchdog_s) + " s: allowed > 0");
  }
  if (options.pace_ticks < 1 || options.pace_ticks > 64) {
    bad("pace_ticks " + std::to_string(options.pace_ticks) + ": allowed 1 to 64 ticks");
  }
  if (options.exchange_ticks < 1 || options.exchange_ticks > 4096 ||
      (options.state_every >= 1 && options.exchange_ticks % options.state_every != 0)) {
    bad("exchange_ticks " + std::to_string(options.exchange_ticks) +
        ": allowed 1 to 4096 ticks, a multiple of state_every (" +
        std::to_string(options.state_every) + ")");
  }
  if (options.tick_batch < 1 || options.tick_batch > core::kTickBatchMaxTicks) {
    bad("tick_batch " + std::to_string(options.tick_batch) + ": allowed 1 to " +
        std::to_string(core::kTickBatchMaxTicks) + " ticks (1 = every tick on its own)");
  }
  if (!(options.duration_s >= 0) || !std::isfinite(options.duration_s)) {
    bad("duration " + core::FormatNumber(options.duration_s) + " s: allowed >= 0 (0 = no end)");
  }
  if (options.idle == core::CommandMode::kEffort) bad("idle: allowed hold or limp");
  if (options.mode == TimingMode::kLockstep || options.mode == TimingMode::kRealtime) {
    if (options.participants.empty()) {
      bad(std::string(TimingModeName(options.mode)) + " needs at least one participant");
    }
    for (const std::string& name : options.participants) {
      if (name.empty()) bad("participant names must not be empty");
      if (std::count(options.participants.begin(), options.participants.end(), name) > 1) {
        bad("participant '" + name + "' is listed twice");
      }
    }
  }
}

SimNode::SimNode(core::Bus& bus, ArmWorld& world, core::Environment environment,
                 NodeOptions options)
    : bus_(bus),
      world_(world),
      environment_(std::move(environment)),
      options_(std::move(options)),
      heartbeat_(bus, options_.process_name, options_.channels.heartbeat),
      replier_(bus, options_.channels.sim_reply, options_.process_name),
      run_id_(NewRunId()),
      boards_(world.model()),
      // Checked with the other options below; a bad value must not throw before that.
      tick_batch_(std::clamp(options_.tick_batch, 1, core::kTickBatchMaxTicks)) {
  CheckNodeOptions(options_);
  const auto n = static_cast<size_t>(world_.model().num_joints());
  board_effort_.assign(n, 0.0);
  board_setpoint_.tick = -1;
  for (int j = 0; j < boards_.num_joints(); ++j) {
    core::JointSetpoint joint;
    joint.status = static_cast<int8_t>(boards_.Status(j));
    board_setpoint_.joints.push_back(joint);
  }
  if (Gated()) {
    for (const std::string& name : options_.participants) {
      Participant participant;
      participant.name = name;
      participants_.push_back(participant);
    }
  }
  bus_.Subscribe<sirupp::arm_command_t>(
      options_.channels.sim_arm_command,
      [this](const sirupp::arm_command_t& message, const core::ReceiveInfo& info) {
        OnCommand(message, info);
      },
      1000);
  bus_.Subscribe<sirupp::servo_move_t>(
      options_.channels.sim_board_command,
      [this](const sirupp::servo_move_t& message, const core::ReceiveInfo& info) {
        OnBoardCommand(message, info);
      },
      1000);
  bus_.Subscribe<sirupp::servo_gains_t>(
      options_.channels.controller_gains,
      [this](const sirupp::servo_gains_t& message, const core::ReceiveInfo& info) {
        OnBoardGains(message, info);
      });
  bus_.Subscribe<sirupp::sim_reset_t>(
      options_.channels.sim_reset,
      [this](const sirupp::sim_reset_t& message, const core::ReceiveInfo& info) {
        OnReset(message, info);
      });
  bus_.Subscribe<sirupp::estop_t>(
      options_.channels.estop, [this](const sirupp::estop_t& message,
                                      const core::ReceiveInfo& info) { OnEstop(message, info); });
  bus_.Subscribe<sirupp::sim_command_t>(
      options_.channels.sim_command,
      [this](const sirupp::sim_command_t& message, const core::ReceiveInfo& info) {
        replier_.Answer(
            message, info, [&] { OnSimCommand(message, info); }, [] { return core::ReplyFacts{}; });
      });
  // The answers are read in this thread from a socket of their own (udpm): no hand-over from
  // LCM's receive thread, and in realtime no wake-up for an answer that comes before its tick
  // ends (ServiceRealtime).
  // The board commands and gains come on the same socket, so each is taken before the answer
  // its sender published after it.
  bus_.ReadDirectly({bus_.FullName(options_.channels.sim_arm_command),
                     bus_.FullName(options_.channels.sim_board_command),
                     bus_.FullName(options_.channels.controller_gains)},
                    options_.process_name);
  heartbeat_.Publish(core::ProcessState::kStarting, "");
  PublishLatched(true);
}

SimNode::~SimNode() {
  try {
    Flush();
  } catch (const std::exception& error) {  // the bus failed: nothing more can be sent anyway
    std::cerr << options_.process_name << ": the last ticks were not sent: " << error.what()
              << "\n";
  }
}

SimNode::Participant* SimNode::FindParticipant(const std::string& name) {
  for (Participant& participant : participants_) {
    if (participant.name == name) return &participant;
  }
  return nullptr;
}

void SimNode::NoteProblem(const std::string& what, bool print) {
  detail_ = what;
  last_problem_ = Now();
  if (print) std::cerr << options_.process_name << ": " << what << "\n";
}

void SimNode::NoteRefusal(const std::string& sender, const std::string& kind,
                          const std::string& reason) {
  const TimePoint now = Now();
  ++counters_.commands_rejected;
  auto it = refusals_.find(sender);
  if (it == refusals_.end()) {
    if (refusals_.size() >= kMaxRefusingSenders) {
      // Forget the sender refused longest ago; its count joins the others'.
      auto oldest = std::min_element(
          refusals_.begin(), refusals_.end(),
          [](const auto& a, const auto& b) { return a.second.last < b.second.last; });
      refused_others_ += oldest->second.count;
      refusals_.erase(oldest);
    }
    it = refusals_.emplace(sender, Refusals{}).first;
  }
  Refusals& refusals = it->second;
  ++refusals.count;
  refusals.reason = reason;
  refusals.last = now;
  detail_ = reason;
  last_problem_ = now;
  const bool new_kind = std::find(refusals.kinds_printed.begin(), refusals.kinds_printed.end(),
                                  kind) == refusals.kinds_printed.end();
  if (Seconds(now - refusal_second_) >= 1.0) {
    refusal_second_ = now;
    refusal_lines_this_second_ = 0;
  }
  if (new_kind && refusal_lines_this_second_ < kMaxRefusalLinesPerSecond) {
    ++refusal_lines_this_second_;
    refusals.kinds_printed.push_back(kind);
    std::cerr << options_.process_name << ": refused a command from '" << sender << "': " << reason
              << " (further refusals of this kind from '" << sender
              << "' are counted on SIM_STATUS, not printed)\n";
    status_due_ = true;
  }
}

void SimNode::SetPresence(Participant& participant, Presence presence, const std::string& why) {
  if (participant.presence == presence) return;
  participant.presence = presence;
  status_due_ = true;
  if (presence == Presence::kAnswering) {
    // Good news: said, but not a problem that degrades the heartbeat.
    std::cerr << options_.process_name << ": " << why << "\n";
  } else {
    NoteProblem(why, true);
  }
}

void SimNode::OnCommand(const sirupp::arm_command_t& message, const core::ReceiveInfo& info) {
  const TimePoint now = Now();
  Participant* participant = FindParticipant(message.sender);
  core::ArmCommand command;
  try {
    command = core::ArmCommandFromMessage(message, info.channel, world_.model().num_joints());
    if (Gated() && participant == nullptr) {
      throw core::MessageError(info.channel, "sender",
                               "'" + message.sender + "' is not a registered participant (" +
                                   JoinNames(options_.participants) +
                                   "; sirupp-sim --participants names them)");
    }
    if (Gated() && message.tick > awaited_tick_) {
      throw core::MessageError(info.channel, "tick",
                               std::to_string(message.tick) +
                                   " is ahead of the sim, which waits for answers to tick " +
                                   std::to_string(awaited_tick_));
    }
  } catch (const core::MessageError& error) {
    NoteRefusal(message.sender, error.field_path(), error.what());
    // A registered participant's answer for this tick is "hold": the arm brakes rather than act.
    core::ArmCommand hold = IdleCommand(core::CommandMode::kHold);
    hold.sender = message.sender;
    hold.tick = message.tick;
    if (participant != nullptr && message.tick == awaited_tick_ && !participant->answered) {
      participant->answered = true;
      participant->answer = hold;
    } else if (!Gated() && newest_.count(message.sender) != 0) {
      newest_[message.sender] = Answer{hold, now};
    }
    throw;  // the Bus counts it as rejected on the channel, with this reason
  }
  if (!Gated()) {
    ++counters_.commands_accepted;
    if (newest_.count(message.sender) == 0 && newest_.size() >= kMaxFreeSenders) {
      ForgetOldSenders(now);
      if (newest_.size() >= kMaxFreeSenders) {
        NoteRefusal(message.sender, "sender",
                    "channel " + info.channel + ": sender '" + message.sender + "': already " +
                        std::to_string(kMaxFreeSenders) +
                        " senders drive the arm; allowed at most " +
                        std::to_string(kMaxFreeSenders) + " at once");
        return;
      }
    }
    newest_[message.sender] = Answer{std::move(command), now};
    return;
  }
  // A participant that had not answered (yet, or for longer than the watchdog) joins again with
  // any answer; from the next tick on the sim waits for it.
  if (participant->presence != Presence::kAnswering) {
    const bool first = participant->presence == Presence::kNeverSeen;
    // A newcomer learns at once which robot this is (it checks the model against its own).
    if (first && Seconds(now - last_latched_) >= kStatusMinPeriodS) PublishLatched(true);
    SetPresence(*participant, Presence::kAnswering,
                "participant '" + participant->name + "' " + (first ? "answers" : "answers again") +
                    " (tick " + std::to_string(message.tick) + ")");
  }
  if (command.mode == core::CommandMode::kBoards) participant->drives_boards = true;
  if (message.tick < awaited_tick_ || participant->answered) {
    ++counters_.commands_late;
    bus_.NoteLate(info);
    // A driver of the boards that joins (or comes back) between two exchange ticks is asked
    // for the present one at once.
    if (participant->drives_boards && !participant->answered) PublishBoardStatus();
    return;
  }
  ++counters_.commands_accepted;
  participant->answered = true;
  participant->answer = std::move(command);
  if (participant->drives_boards) {
    participant->answer_until = NextExchange(awaited_tick_);
    ApplyBoardCommands();  // what its sender sent before this answer starts at this tick
  } else {
    participant->answer_until =
        awaited_tick_ + options_.state_every - awaited_tick_ % options_.state_every;
  }
  // Read directly, an answer may wait in the socket until the tick ends: its time is the
  // kernel's reception time.
  const double latency_ms = bus_.reads_directly()
                                ? static_cast<double>(info.recv_utime - waiting_since_utime_) * 1e-3
                                : Seconds(now - waiting_since_) * 1e3;
  participant->latency_sum_ms += latency_ms;
  participant->latency_max_ms = std::max(participant->latency_max_ms, latency_ms);
  ++participant->latency_count;
}

void SimNode::OnSimCommand(const sirupp::sim_command_t& message, const core::ReceiveInfo& info) {
  const core::SimCommand command = core::SimCommandFromMessage(message, info.channel);
  const bool model = command.action == core::SimAction::kLoadModel;
  const std::string name = !command.name.empty() ? command.name
                           : model               ? "(model text)"
                                                 : "(environment text)";
  // The file's own error names name:line and the field.
  const core::Environment environment =
      model ? environment_ : core::ParseEnvironment(command.text, name);
  // A moving arm would meet objects it was not planned around, or change under its controller:
  // load while it stands still.
  const core::ArmState state = world_.State();
  for (size_t j = 0; j < state.velocity.size(); ++j) {
    if (std::abs(state.velocity[j]) > kStillSpeed) {
      throw std::runtime_error("the arm moves (joint " + std::to_string(j + 1) + " at " +
                               core::FormatNumber(state.velocity[j]) + " rad/s or m/s): load " +
                               (model ? "a model" : "an environment") + " while it stands still");
    }
  }
  if (model) {
    LoadModelText(world_, command.text, name);  // throws, the arm unchanged, when refused
    // The boards follow the new model's joints; a joint whose encoder is unchanged keeps its
    // servo (servo/servo_bank.hpp).
    const bool on = boards_.num_joints() > 0 && boards_.servo(0).servo_on();
    boards_.ReplaceModel(world_.model(), world_.State().position, on);
    std::cerr << options_.process_name << ": model '" << world_.model().name << "' from " << name
              << " loaded by '" << message.sender << "' at tick " << world_.tick() << "\n";
    PublishLatched(true);
    return;
  }
  world_.ReplaceEnvironment(environment);  // throws when an object would overlap the arm
  environment_ = environment;
  std::cerr << options_.process_name << ": environment '" << environment_.name << "' from " << name
            << " (" << environment_.objects.size() << " objects) loaded by '" << message.sender
            << "' at tick " << world_.tick() << "\n";
  PublishLatched(true);
}

void SimNode::OnReset(const sirupp::sim_reset_t& message, const core::ReceiveInfo& info) {
  core::SimReset reset;
  try {
    reset = core::SimResetFromMessage(message, info.channel);
    core::CheckJointCount(info.channel, "num_joints", reset.position.size(),
                          world_.model().num_joints());
    try {
      world_.SetJointState(reset.position, reset.velocity, reset.reset_objects);
    } catch (const std::invalid_argument& error) {
      throw core::MessageError(info.channel, "position", error.what());
    }
  } catch (const core::MessageError& error) {
    NoteProblem(error.what(), false);
    throw;
  }
  ++counters_.resets;
  std::cerr << options_.process_name << ": reset by '" << reset.sender << "' at tick "
            << world_.tick() << "\n";
  if (Gated()) {
    // Answers to the state before the teleport no longer apply: ask again.
    for (Participant& participant : participants_) {
      participant.answered = false;
      participant.answer_until = world_.tick();
    }
    awaited_tick_ = world_.tick();
    waiting_since_ = Now();
    waiting_since_utime_ = WallMicros();
  }
  PublishState();
}

void SimNode::OnEstop(const sirupp::estop_t& message, const core::ReceiveInfo& info) {
  const core::EStop estop = core::EStopFromMessage(message, info.channel);
  if (!estop.engaged) {
    if (estop_.empty()) return;
    estop_.clear();
    std::cerr << options_.process_name << ": emergency stop released by '" << estop.sender
              << "'; efforts are applied again\n";
  } else {
    const bool already = !estop_.empty();
    estop_ = "emergency stop from '" + estop.sender + "': " + estop.reason;
    if (already) return;
    std::cerr << options_.process_name << ": " << estop_
              << ": every joint braked, efforts ignored until released\n";
  }
  status_due_ = true;
}

core::ArmCommand SimNode::IdleCommand(core::CommandMode mode) const {
  core::ArmCommand idle;
  idle.mode = mode;
  idle.tick = world_.tick();
  idle.sender = options_.process_name;
  idle.effort.assign(static_cast<size_t>(world_.model().num_joints()), 0.0);
  return idle;
}

core::ArmCommand SimNode::Combine(const std::vector<const core::ArmCommand*>& answers,
                                  bool* boards) const {
  const int n = world_.model().num_joints();
  core::ArmCommand combined = IdleCommand(core::CommandMode::kLimp);
  bool any_effort = false;
  bool any_hold = !estop_.empty();
  for (const core::ArmCommand* answer : answers) {
    if (answer->mode == core::CommandMode::kHold) {
      any_hold = true;
    } else if (answer->mode == core::CommandMode::kBoards) {
      any_effort = true;  // the boards' efforts are added tick by tick (StepTicks)
      if (boards != nullptr) *boards = true;
    } else if (answer->mode == core::CommandMode::kEffort) {
      any_effort = true;
      for (int j = 0; j < n; ++j) {
        combined.effort[static_cast<size_t>(j)] += answer->effort[static_cast<size_t>(j)];
      }
    }
  }
  combined.mode = any_hold     ? core::CommandMode::kHold
                  : any_effort ? core::CommandMode::kEffort
                               : core::CommandMode::kLimp;
  if (any_hold) combined.effort.assign(static_cast<size_t>(n), 0.0);
  return combined;
}

core::ArmCommand SimNode::CombineParticipants(bool* boards, bool* board_rows) {
  const core::ArmCommand hold = IdleCommand(core::CommandMode::kHold);
  const core::ArmCommand idle = IdleCommand(options_.idle);
  std::vector<const core::ArmCommand*> in_order;
  bool braked_for_silence = false;
  *board_rows = false;
  for (const Participant& participant : participants_) {
    if (participant.answered) {
      in_order.push_back(&participant.answer);
      if (participant.drives_boards) *board_rows = true;
    } else if (participant.presence == Presence::kNeverSeen) {
      in_order.push_back(&idle);
    } else {
      in_order.push_back(&hold);
      braked_for_silence = true;
    }
  }
  if (braked_for_silence) ++counters_.watchdog_holds;
  *boards = false;
  return Combine(in_order, boards);
}

void SimNode::StepTicks(const core::ArmCommand& command, int ticks, bool boards, bool board_rows) {
  for (int k = 0; k < ticks && !Finished(); ++k) {
    if (boards || board_rows) {
      core::ArmCommand step = command;
      BoardTick(step, boards && command.mode == core::CommandMode::kEffort);
      world_.Step(step);
    } else {
      world_.Step(command);
    }
    ++counters_.steps;
    if (!estop_.empty()) ++counters_.estop_ticks;
    if (world_.tick() % options_.state_every == 0 || Finished()) PublishState();
  }
}

void SimNode::PublishState(bool again) {
  const bool due = BoardAnswerDue();
  if (Batching()) {
    if (!again) {
      tick_batch_.Add(core::ToMessage(world_.State(), state_seq_++), WallMicros());
      ++counters_.states_published;
    }
    // Every tick up to the exchange is out before the board status that asks for an answer.
    if (due || tick_batch_.Full() || Finished()) Flush();
  } else {
    Flush();  // what was gathered goes out before the next tick on its own
    bus_.Publish(options_.channels.sim_arm_state, core::ToMessage(world_.State(), state_seq_++));
    ++counters_.states_published;
  }
  if (due) PublishBoardStatus();
}

int SimNode::PaceTicks() const {
  return Batching() ? std::max(options_.pace_ticks, options_.tick_batch) : options_.pace_ticks;
}

bool SimNode::Batching() const {
  if (options_.tick_batch <= 1 || !Gated() || participants_.empty()) return false;
  return std::all_of(participants_.begin(), participants_.end(), [](const Participant& p) {
    return p.drives_boards && p.presence == Presence::kAnswering;
  });
}

void SimNode::PublishSetpoint(const core::ServoSetpoint& setpoint) {
  if (Batching()) {
    tick_batch_.Add(core::ToMessage(setpoint), WallMicros());
    return;
  }
  Flush();
  bus_.Publish(options_.channels.arm_setpoint, core::ToMessage(setpoint));
}

void SimNode::Flush() {
  if (tick_batch_.empty()) return;
  bus_.Publish(options_.channels.sim_arm_ticks, tick_batch_.Take(WallMicros()));
  ++counters_.tick_batches;
}

// ---- The virtual boards

int64_t SimNode::NextExchange(int64_t tick) const {
  const int64_t every = options_.exchange_ticks;
  return (tick / every + 1) * every;
}

bool SimNode::BoardAnswerDue() const {
  if (world_.tick() % options_.exchange_ticks == 0) return true;
  for (const Participant& participant : participants_) {
    if (participant.drives_boards && !participant.answered) return true;
  }
  return false;
}

void SimNode::PublishBoardStatus() {
  core::BoardStatus status;
  status.arm = world_.State();
  status.utime = status.arm.utime;
  status.seq = board_status_seq_++;
  status.tick = status.arm.tick;
  status.next_tick = NextExchange(status.tick);
  status.command_seq = board_command_seq_;
  status.boards = board_setpoint_;
  bus_.Publish(options_.channels.sim_board_status, core::ToMessage(status));
  ++counters_.board_exchanges;
}

void SimNode::OnBoardCommand(const sirupp::servo_move_t& message, const core::ReceiveInfo& info) {
  const core::ServoMove move = core::ServoMoveFromMessage(message, info.channel);
  core::CheckJointCount(info.channel, "num_joints", move.joints.size(),
                        world_.model().num_joints());
  const core::ArmState state = world_.State();
  try {
    servo::ServoBank trial = boards_;  // refused whole, the boards untouched
    servo::ApplyMove(trial, move, state.position);
  } catch (const std::invalid_argument& error) {
    NoteProblem("channel " + info.channel + ": " + error.what(), true);
    throw core::MessageError(info.channel, "", error.what());
  }
  if (!Gated()) {
    board_queue_.push_back(move);
    ApplyBoardCommands();
    return;
  }
  if (board_queue_.size() >= kMaxBoardQueue) {
    throw core::MessageError(info.channel, "",
                             "already " + std::to_string(kMaxBoardQueue) +
                                 " board commands wait for the next answer of the participant "
                                 "that drives the boards; allowed at most " +
                                 std::to_string(kMaxBoardQueue));
  }
  board_queue_.push_back(move);
}

void SimNode::OnBoardGains(const sirupp::servo_gains_t& message, const core::ReceiveInfo& info) {
  std::vector<servo::ServoGains> gains;
  for (const servo::ChipGains& chip :
       servo::ChipGainsFromMessage(message, world_.model(), info.channel)) {
    gains.push_back(servo::ToServoGains(chip));
  }
  board_gains_ = std::move(gains);
  if (!Gated()) ApplyBoardCommands();
}

void SimNode::ApplyBoardCommands() {
  if (board_gains_) {
    for (int j = 0; j < boards_.num_joints(); ++j) {
      boards_.SetGains(j, (*board_gains_)[static_cast<size_t>(j)]);
    }
    board_gains_.reset();
  }
  if (board_queue_.empty()) return;
  const core::ArmState state = world_.State();
  for (const core::ServoMove& move : board_queue_) {
    try {
      servo::ApplyMove(boards_, move, state.position);
    } catch (const std::invalid_argument& error) {  // checked when it came; a model change since
      NoteProblem("channel " + options_.channels.sim_board_command.name() + ": command " +
                      std::to_string(move.seq) + " not applied: " + error.what(),
                  true);
    }
    board_command_seq_ = move.seq;
    board_move_id_ = move.move_id;
    ++counters_.board_commands;
  }
  board_queue_.clear();
}

void SimNode::BoardTick(core::ArmCommand& command, bool run) {
  const core::ArmState state = world_.State();
  const auto n = static_cast<size_t>(boards_.num_joints());
  if (run && boards_.TrippedJoint() >= 0) {
    // A board past its error limit: held, as sirupp-control's fault will hold it.
    command.mode = core::CommandMode::kHold;
    command.effort.assign(n, 0.0);
    board_effort_.assign(n, 0.0);
  } else if (run) {
    board_effort_ = boards_.Tick(state.position);
    ++counters_.board_ticks;
    for (size_t j = 0; j < n; ++j) command.effort[j] += board_effort_[j];
  }
  core::ServoSetpoint& setpoint = board_setpoint_;
  setpoint.utime = state.utime;
  setpoint.seq = setpoint_seq_++;
  setpoint.tick = state.tick;
  setpoint.move_id = board_move_id_;
  for (size_t j = 0; j < n; ++j) {
    const int joint = static_cast<int>(j);
    core::JointSetpoint& row = setpoint.joints[j];
    row.position = boards_.SetpointPosition(joint);
    row.velocity = boards_.SetpointVelocity(joint);
    row.goal = boards_.Goal(joint);
    row.position_error = boards_.PositionError(joint);
    row.effort = board_effort_[j];
    row.status = static_cast<int8_t>(boards_.Status(joint));
  }
  PublishSetpoint(setpoint);
}

void SimNode::PublishLatched(bool force) {
  const TimePoint now = Now();
  if (!force && latched_sent_ && Seconds(now - last_latched_) < 1.0) return;
  const auto utime = static_cast<int64_t>(std::llround(world_.time_s() * 1e6));
  bus_.Publish(options_.channels.robot_model, core::ToMessage(world_.model(), utime, model_seq_++));
  bus_.Publish(options_.channels.environment,
               core::ToMessage(environment_, utime, environment_seq_++));
  last_latched_ = now;
  latched_sent_ = true;
}

double SimNode::RealtimeFactor() const {
  if (!started_) return 1;
  const double wall = Seconds(Now() - start_wall_);
  if (wall <= 0) return 1;
  return static_cast<double>(world_.tick() - start_tick_) * world_.step_s() / wall;
}

void SimNode::PublishStatus(bool force) {
  const TimePoint now = Now();
  const double since = Seconds(now - last_status_);
  const bool due = since >= 1.0 || (status_due_ && since >= kStatusMinPeriodS);
  if (!force && !due) return;
  if (since >= 1.0 || status_tick_ == 0) {
    // The factor and the answer times over the second that ended.
    const double wall = Seconds(now - status_time_);
    if (started_ && wall > 0) {
      recent_factor_ = static_cast<double>(world_.tick() - status_tick_) * world_.step_s() / wall;
    }
    status_tick_ = world_.tick();
    status_time_ = now;
    for (Participant& p : participants_) {
      p.last_mean_ms = p.latency_count > 0 ? p.latency_sum_ms / p.latency_count : -1;
      p.last_max_ms = p.latency_count > 0 ? p.latency_max_ms : -1;
      p.latency_sum_ms = p.latency_max_ms = 0;
      p.latency_count = 0;
    }
  }
  core::SimStatus status;
  status.utime = WallMicros();
  status.seq = status_seq_++;
  status.run_id = run_id_;
  status.mode = options_.mode == TimingMode::kLockstep   ? core::TimingMode::kLockstep
                : options_.mode == TimingMode::kRealtime ? core::TimingMode::kRealtime
                : options_.mode == TimingMode::kFast     ? core::TimingMode::kFast
                                                         : core::TimingMode::kFreerun;
  status.tick = world_.tick();
  status.sim_time_s = world_.time_s();
  status.realtime_factor = recent_factor_;
  status.realtime_factor_run = RealtimeFactor();
  status.slipped_s = counters_.slipped_s;
  status.estop = !estop_.empty();
  status.estop_reason = estop_;
  for (const Participant& p : participants_) {
    status.participants.push_back({p.name, p.presence, p.last_mean_ms, p.last_max_ms});
  }
  for (const auto& [sender, refusals] : refusals_) {
    status.refused.push_back({sender, refusals.count, refusals.reason});
  }
  status.refused_others = refused_others_;
  const bool troubled = !detail_.empty() && Seconds(now - last_problem_) < kProblemMemoryS;
  status.detail = troubled ? detail_ : "";
  bus_.Publish(options_.channels.sim_status, core::ToMessage(status));
  last_status_ = now;
  status_due_ = false;
}

bool SimNode::Finished() const {
  if (stop_requested_) return true;
  return options_.duration_s > 0 && world_.time_s() >= options_.duration_s - 0.5 * world_.step_s();
}

void SimNode::Start() {
  if (started_) return;
  started_ = true;
  const TimePoint now = Now();
  start_wall_ = pace_wall_ = status_time_ = now;
  start_tick_ = pace_tick_ = batch_end_tick_ = world_.tick();
  awaited_tick_ = world_.tick();
  waiting_since_ = now;
  waiting_since_utime_ = WallMicros();
  PublishState();
  PublishStatus(true);
}

bool SimNode::Service(int max_wait_ms) {
  if (Finished()) return false;
  switch (options_.mode) {
    case TimingMode::kLockstep:
      ServiceLockstep(max_wait_ms);
      break;
    case TimingMode::kRealtime:
      ServiceRealtime(max_wait_ms);
      break;
    case TimingMode::kFast:
    case TimingMode::kFreeRun:
      ServiceFree(max_wait_ms);
      break;
  }
  PublishLatched(false);
  PublishStatus(false);
  if (!heartbeat_.Due()) return !Finished();  // the detail is built once a second, not per tick
  const TimePoint now = Now();
  const bool troubled = !detail_.empty() && Seconds(now - last_problem_) < kProblemMemoryS;
  std::string detail = troubled ? detail_ : "";
  if (options_.mode == TimingMode::kRealtime && !troubled) {
    detail = "realtime factor " + Fixed(recent_factor_, 3);
  }
  if (!estop_.empty()) detail = estop_ + "; arm braked";
  heartbeat_.PublishIfDue(
      troubled || !estop_.empty() ? core::ProcessState::kDegraded : core::ProcessState::kRunning,
      detail);
  return !Finished();
}

bool SimNode::GateOpen() const {
  for (const Participant& participant : participants_) {
    if (participant.presence == Presence::kAnswering && !participant.answered) return false;
  }
  return true;
}

void SimNode::StepGate() {
  bool boards = false;
  bool board_rows = false;
  const core::ArmCommand combined = CombineParticipants(&boards, &board_rows);
  const int ticks = options_.state_every - static_cast<int>(world_.tick() % options_.state_every);
  // The answers that cover the ticks after this segment (a driver of the boards' up to the next
  // exchange) still count: the state published at its end asks only the others.
  for (Participant& participant : participants_) {
    participant.answered = participant.answer_until > world_.tick() + ticks;
  }
  StepTicks(combined, ticks, boards, board_rows);
  for (Participant& participant : participants_) {
    participant.answered = participant.answered && participant.answer_until > world_.tick();
  }
  awaited_tick_ = world_.tick();
  waiting_since_ = Now();
  waiting_since_utime_ = WallMicros();
}

void SimNode::WaitUntil(TimePoint until, int max_wait_ms) {
  const double wait_s = Seconds(until - Now());
  if (wait_s <= 0) return;
  if (wait_s >= 0.002 && max_wait_ms > 0) {
    bus_.Handle(std::min(max_wait_ms, static_cast<int>(wait_s * 1e3) - 1));
  } else if (wait_s < 0.002) {
    options_.clock.sleep_until(until);
  }
}

void SimNode::ServiceLockstep(int max_wait_ms) {
  Start();
  // Lockstep waits for every participant, including one not seen yet.
  auto all_answered = [this] {
    return std::all_of(participants_.begin(), participants_.end(),
                       [](const Participant& p) { return p.answered; });
  };
  bus_.HandleAvailable();
  if (!all_answered()) bus_.Handle(max_wait_ms);
  if (all_answered()) {
    StepGate();
    // Answers that cover the next ticks too (the boards' driver between two exchanges): step
    // them without looking at the bus in between.
    for (int k = 1; k < kCoveredBatch && all_answered() && !Finished(); ++k) StepGate();
    return;
  }
  const TimePoint now = Now();
  // A state sent before a participant subscribed (the usual start-up order) or lost on the way is
  // sent again every 0.1 s without a report; only the full timeout is reported.
  if (Seconds(now - last_resend_) >= kResendPeriodS &&
      Seconds(now - waiting_since_) >= kResendPeriodS) {
    PublishState(true);
    last_resend_ = now;
  }
  if (Seconds(now - waiting_since_) >= options_.lockstep_timeout_s) {
    std::vector<std::string> missing;
    for (const Participant& p : participants_) {
      if (!p.answered) missing.push_back(p.name);
    }
    ++counters_.lockstep_timeouts;
    NoteProblem("lockstep: tick " + std::to_string(awaited_tick_) + ": no answer from " +
                    JoinNames(missing) + " for " + Fixed(Seconds(now - waiting_since_), 2) +
                    " s; waiting (state sent again)",
                true);
    status_due_ = true;
    PublishState(true);
    waiting_since_ = now;
    waiting_since_utime_ = WallMicros();
  }
}

void SimNode::ServiceRealtime(int max_wait_ms) {
  Start();
  const double step = world_.step_s();
  const auto end_of_tick = [&] {
    return pace_wall_ + Duration(static_cast<double>(world_.tick() + 1 - pace_tick_) * step);
  };
  // Reading the answers directly, nothing needs this thread before the tick ends: it sleeps to
  // then and finds the answer waiting (one wake-up per tick instead of two; the answer's time is
  // still its reception's). Through LCM (memq://) it waits for the answer as before.
  // One poll then takes every answer waiting and one message of LCM's (the rest on later ticks):
  // HandleAvailable would poll once more to find nothing.
  // Ticks step in batches of pace_ticks: the sim waits until that many are due (their ends have
  // passed), then steps every due tick as soon as its answers are in; 1 = each tick at its end.
  const auto wake_at = [&] {
    return end_of_tick() + Duration(static_cast<double>(PaceTicks() - 1) * step);
  };
  const auto may_step = [&](TimePoint at) {
    return world_.tick() < batch_end_tick_ || at >= wake_at();
  };
  if (bus_.reads_directly()) {
    const bool slept = !may_step(Now());
    if (slept) options_.clock.sleep_until(wake_at());
    // Inside a batch the answer to the state just sent is seldom in yet: the wait below polls for
    // it (and LCM's messages) once, so a poll here would only find nothing (one system call of
    // the tick's few).
    // While the ticks go out in batches nobody answers between two exchanges: the messages
    // (board commands, an e-stop) are taken once per sleep, and at the exchange below.
    if (slept || (GateOpen() && !Batching()) || max_wait_ms <= 0) bus_.Handle(0);
  } else {
    bus_.HandleAvailable();
  }
  TimePoint now = Now();
  if (!GateOpen()) {
    const TimePoint deadline = waiting_since_ + Duration(options_.watchdog_s);
    if (now < deadline) {
      if (max_wait_ms > 0) {
        const int until_deadline_ms = static_cast<int>(std::ceil(Seconds(deadline - now) * 1e3));
        bus_.Handle(std::max(1, std::min(max_wait_ms, until_deadline_ms)));
      }
      now = Now();
      if (Seconds(now - last_resend_) >= kResendPeriodS &&
          Seconds(now - waiting_since_) >= kResendPeriodS) {
        PublishState(true);  // lost on the way: ask again
        last_resend_ = now;
      }
      if (!GateOpen() && Now() < deadline) return;
    }
    if (!GateOpen()) {
      // Silent past the watchdog: named, and the arm brakes for it until it answers again.
      for (Participant& participant : participants_) {
        if (participant.presence == Presence::kAnswering && !participant.answered) {
          SetPresence(participant, Presence::kSilent,
                      "realtime: no answer from '" + participant.name + "' to tick " +
                          std::to_string(awaited_tick_) + " for " +
                          core::FormatNumber(options_.watchdog_s * 1e3) +
                          " ms (watchdog): arm braked until it answers again");
        }
      }
    }
  }
  // Every answering participant has answered: step when the wall clock has reached the tick's
  // end (the batch's last tick's, between batches), at once when behind it, and let the sim time
  // slip when too far behind to catch up.
  now = Now();
  if (!may_step(now)) {
    WaitUntil(wake_at(), max_wait_ms);
    now = Now();
    if (!may_step(now)) return;
  }
  if (world_.tick() >= batch_end_tick_) {
    // A new batch: every tick whose end has passed (tick t ends at pace_wall_ + (t + 1 -
    // pace_tick_) x step), so none steps before the wall clock reached its end.
    batch_end_tick_ =
        pace_tick_ + static_cast<int64_t>(std::floor(Seconds(now - pace_wall_) / step));
  }
  const double behind_s = Seconds(now - end_of_tick());
  if (behind_s > kMaxCatchUpS) {
    counters_.slipped_s += behind_s;
    pace_wall_ = now;
    pace_tick_ = world_.tick() + 1;
    batch_end_tick_ = pace_tick_;  // this tick now; the next when its end has come
    if (Seconds(now - last_slip_report_) >= 1.0) {
      last_slip_report_ = now;
      NoteProblem("realtime: " + core::FormatApprox(behind_s * 1e3) +
                      " ms behind the wall clock; the sim time slips (realtime factor " +
                      Fixed(RealtimeFactor(), 3) + " since start)",
                  true);
    }
  } else if (behind_s > static_cast<double>(PaceTicks()) * step) {
    ++counters_.overruns;  // later than a batch makes it
  }
  StepGate();
}

void SimNode::ForgetOldSenders(TimePoint now) {
  for (auto it = newest_.begin(); it != newest_.end();) {
    it = Seconds(now - it->second.received) > kForgetSenderS ? newest_.erase(it) : std::next(it);
  }
}

void SimNode::ServiceFree(int max_wait_ms) {
  Start();
  const TimePoint now = Now();
  bus_.HandleAvailable();
  bool boards = false;
  auto command_now = [this, &boards](TimePoint at) {
    boards = false;
    if (newest_.empty()) {
      const core::ArmCommand idle = IdleCommand(options_.idle);
      return Combine({&idle});
    }
    std::vector<const core::ArmCommand*> fresh;
    for (const auto& [sender, answer] : newest_) {
      if (options_.mode == TimingMode::kFast ||
          Seconds(at - answer.received) <= options_.watchdog_s) {
        fresh.push_back(&answer.command);
      }
    }
    if (fresh.empty()) {
      ++counters_.watchdog_holds;
      if (detail_.rfind("watchdog", 0) != 0 || Seconds(at - last_problem_) > 1.0) {
        NoteProblem("watchdog: no command for more than " +
                        core::FormatNumber(options_.watchdog_s * 1e3) + " ms: arm braked",
                    true);
      }
      last_problem_ = at;
      return IdleCommand(core::CommandMode::kHold);
    }
    return Combine(fresh, &boards);
  };
  if (options_.mode == TimingMode::kFast) {
    for (int k = 0; k < kFastBatch && !Finished(); ++k) {
      const core::ArmCommand command = command_now(now);
      StepTicks(command, 1, boards, boards);
    }
    return;
  }
  ForgetOldSenders(now);
  // Freerun: run every tick whose wall-clock time has come, with the newest commands.
  const double step = world_.step_s();
  const auto due = static_cast<int64_t>(std::floor(Seconds(now - pace_wall_) / step)) -
                   (world_.tick() - pace_tick_);
  if (due > static_cast<int64_t>(kMaxCatchUpS / step)) {
    counters_.overruns += due;
    counters_.slipped_s += static_cast<double>(due) * step;
    NoteProblem("freerun: " + core::FormatApprox(static_cast<double>(due) * step * 1e3) +
                    " ms behind the wall clock; clock restarted",
                true);
    pace_wall_ = now;
    pace_tick_ = world_.tick();
    const core::ArmCommand command = command_now(now);
    StepTicks(command, 1, boards, boards);
    return;
  }
  if (due > 1) counters_.overruns += due - 1;
  auto answered = [this] {
    int64_t latest = -1;
    for (const auto& [sender, answer] : newest_) latest = std::max(latest, answer.command.tick);
    return latest >= world_.tick();  // some sender has answered the state of the present tick
  };
  for (int64_t k = 0; k < due && !Finished(); ++k) {
    if (!newest_.empty() && !answered()) {
      // The tick holds an older command: counted late (docs/timing.md).
      ++counters_.ticks_late;
      bus_.NoteLate(options_.channels.sim_arm_command);
    }
    const core::ArmCommand command = command_now(Now());
    StepTicks(command, 1, boards, boards);
  }
  WaitUntil(pace_wall_ + Duration(static_cast<double>(world_.tick() - pace_tick_ + 1) * step),
            max_wait_ms);
}

std::string SimNode::Summary() const {
  const NodeCounters& c = counters_;
  std::string line =
      "stopped at tick " + std::to_string(world_.tick()) +
      " (t = " + core::FormatApprox(world_.time_s()) + " s): " + std::to_string(c.steps) +
      " steps, " + std::to_string(c.states_published) + " states sent, " +
      std::to_string(c.commands_accepted) + " commands accepted, " +
      std::to_string(c.commands_rejected) + " rejected, " + std::to_string(c.commands_late) +
      " late, " + std::to_string(c.lockstep_timeouts) + " lockstep timeouts, " +
      std::to_string(c.watchdog_holds) + " ticks braked for a silent sender, " +
      std::to_string(c.resets) + " resets, " + std::to_string(c.estop_ticks) +
      " ticks under e-stop";
  line += "; realtime factor " + Fixed(RealtimeFactor(), 3);
  if (options_.mode == TimingMode::kRealtime) {
    line += ", " + std::to_string(c.overruns) + " ticks caught up late, " +
            core::FormatApprox(c.slipped_s) + " s slipped, 0 ticks stepped with a stale effort";
  } else if (options_.mode == TimingMode::kFreeRun) {
    line += ", " + std::to_string(c.ticks_late) + " ticks with a stale (held) command, " +
            std::to_string(c.overruns) + " overruns";
  }
  if (c.board_ticks > 0 || c.board_commands > 0) {
    line += "; the virtual boards drove " + std::to_string(c.board_ticks) + " ticks (" +
            std::to_string(c.board_commands) + " board commands, " +
            std::to_string(c.board_exchanges) + " exchanges)";
  }
  if (c.commands_rejected > 0) {
    line += "; refused:";
    for (const auto& [sender, refusals] : refusals_) {
      line += " '" + sender + "' x" + std::to_string(refusals.count) + " (" + refusals.reason + ")";
    }
    if (refused_others_ > 0) line += " others x" + std::to_string(refused_others_);
  }
  if (!participants_.empty()) {
    std::string slowest;
    double slowest_ms = -1;
    for (const Participant& p : participants_) {
      if (p.last_max_ms > slowest_ms) {
        slowest_ms = p.last_max_ms;
        slowest = p.name;
      }
    }
    if (slowest_ms >= 0) {
      line += "; slowest participant " + slowest + " (up to " + Fixed(slowest_ms, 2) +
              " ms per answer in the last second)";
    }
  }
  return line;
}

}  // namespace sirupp::sim
