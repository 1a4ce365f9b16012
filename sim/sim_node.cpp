#include "sim/sim_node.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <sirupp/sim_reset_t.hpp>
#include <stdexcept>
#include <thread>
#include <utility>

#include "core/errors.hpp"
#include "core/translate.hpp"

namespace sirupp::sim {
namespace {

using Clock = std::chrono::steady_clock;

// Ticks run per Service() call in fast mode between two looks at the bus.
constexpr int kFastBatch = 64;
// Realtime: further behind than this, the node stops catching up and restarts its clock.
constexpr double kMaxCatchUpS = 0.1;
// A problem stays in the heartbeat (state degraded) this long after it last happened.
constexpr double kProblemMemoryS = 5.0;

std::string JoinNames(const std::vector<std::string>& names) {
  std::string joined;
  for (const std::string& name : names) joined += (joined.empty() ? "" : ", ") + name;
  return joined;
}

double Seconds(Clock::duration duration) { return std::chrono::duration<double>(duration).count(); }

}  // namespace

const char* TimingModeName(TimingMode mode) {
  switch (mode) {
    case TimingMode::kLockstep:
      return "lockstep";
    case TimingMode::kRealtime:
      return "realtime";
    case TimingMode::kFast:
      return "fast";
  }
  return "unknown";
}

TimingMode ParseTimingMode(const std::string& text) {
  if (text == "lockstep") return TimingMode::kLockstep;
  if (text == "realtime") return TimingMode::kRealtime;
  if (text == "fast") return TimingMode::kFast;
  throw std::invalid_argument("timing mode '" + text + "': allowed lockstep, realtime, fast");
}

SimNode::SimNode(core::Bus& bus, ArmWorld& world, core::Environment environment,
                 NodeOptions options)
    : bus_(bus),
      world_(world),
      environment_(std::move(environment)),
      options_(std::move(options)),
      heartbeat_(bus, options_.process_name, options_.channels.heartbeat) {
  auto bad = [](const std::string& what) { throw std::invalid_argument(what); };
  if (options_.state_every < 1) {
    bad("state_every " + std::to_string(options_.state_every) + ": allowed 1 or more ticks");
  }
  if (!(options_.lockstep_timeout_s > 0)) {
    bad("lockstep timeout " + core::FormatNumber(options_.lockstep_timeout_s) + " s: allowed > 0");
  }
  if (!(options_.watchdog_s > 0)) {
    bad("watchdog " + core::FormatNumber(options_.watchdog_s) + " s: allowed > 0");
  }
  if (!(options_.duration_s >= 0) || !std::isfinite(options_.duration_s)) {
    bad("duration " + core::FormatNumber(options_.duration_s) + " s: allowed >= 0 (0 = no end)");
  }
  if (options_.idle == core::CommandMode::kEffort) bad("idle: allowed hold or limp");
  if (options_.mode == TimingMode::kLockstep) {
    if (options_.participants.empty()) bad("lockstep needs at least one participant");
    for (const std::string& name : options_.participants) {
      if (name.empty()) bad("participant names must not be empty");
      if (std::count(options_.participants.begin(), options_.participants.end(), name) > 1) {
        bad("participant '" + name + "' is listed twice");
      }
    }
  }
  bus_.Subscribe<sirupp::arm_command_t>(
      options_.channels.sim_arm_command,
      [this](const sirupp::arm_command_t& message, const core::ReceiveInfo& info) {
        OnCommand(message, info);
      },
      1000);
  bus_.Subscribe<sirupp::sim_reset_t>(
      options_.channels.sim_reset,
      [this](const sirupp::sim_reset_t& message, const core::ReceiveInfo& info) {
        OnReset(message, info);
      });
  heartbeat_.Publish(core::ProcessState::kStarting, "");
  PublishLatched(true);
}

SimNode::~SimNode() = default;

void SimNode::OnCommand(const sirupp::arm_command_t& message, const core::ReceiveInfo& info) {
  const Clock::time_point now = Clock::now();
  const bool lockstep = options_.mode == TimingMode::kLockstep;
  const bool registered = std::find(options_.participants.begin(), options_.participants.end(),
                                    message.sender) != options_.participants.end();
  core::ArmCommand command;
  try {
    command = core::ArmCommandFromMessage(message, info.channel, world_.model().num_joints());
    if (lockstep && !registered) {
      throw core::MessageError(info.channel, "sender",
                               "'" + message.sender + "' is not a registered participant (" +
                                   JoinNames(options_.participants) + ")");
    }
    if (lockstep && message.tick > awaited_tick_) {
      throw core::MessageError(info.channel, "tick",
                               std::to_string(message.tick) +
                                   " is ahead of the sim, which waits "
                                   "for answers to tick " +
                                   std::to_string(awaited_tick_));
    }
  } catch (const core::MessageError& error) {
    ++counters_.commands_rejected;
    detail_ = error.what();
    last_problem_ = now;
    // The sender's answer for this tick is "hold": the arm brakes rather than acting on it.
    core::ArmCommand hold;
    hold.mode = core::CommandMode::kHold;
    hold.sender = message.sender;
    hold.tick = message.tick;
    if (lockstep && registered && message.tick == awaited_tick_) {
      answers_[message.sender] = hold;
    } else if (!lockstep) {
      newest_[message.sender] = Answer{hold, now};
    }
    throw;  // the Bus counts it as rejected on the channel, with this reason
  }
  if (lockstep && message.tick < awaited_tick_) {
    ++counters_.commands_late;
    bus_.NoteLate(info);
    return;
  }
  ++counters_.commands_accepted;
  if (lockstep) {
    answers_[message.sender] = std::move(command);
  } else {
    newest_[message.sender] = Answer{std::move(command), now};
  }
}

void SimNode::OnReset(const sirupp::sim_reset_t& message, const core::ReceiveInfo& info) {
  const int n = world_.model().num_joints();
  try {
    if (message.num_joints != n || static_cast<int>(message.position.size()) != n) {
      throw core::MessageError(
          info.channel, "num_joints",
          std::to_string(message.num_joints) + " joints; the model has " + std::to_string(n));
    }
    if (message.num_velocities != 0 && message.num_velocities != n) {
      throw core::MessageError(
          info.channel, "num_velocities",
          std::to_string(message.num_velocities) + ": allowed 0 or " + std::to_string(n));
    }
    if (message.reset_objects != 0 && message.reset_objects != 1) {
      throw core::MessageError(info.channel, "reset_objects",
                               std::to_string(message.reset_objects) + ": allowed 0 or 1");
    }
    try {
      world_.SetJointState(message.position, message.velocity, message.reset_objects == 1);
    } catch (const std::invalid_argument& error) {
      throw core::MessageError(info.channel, "position", error.what());
    }
  } catch (const core::MessageError& error) {
    detail_ = error.what();
    last_problem_ = Clock::now();
    throw;
  }
  ++counters_.resets;
  std::cerr << options_.process_name << ": reset by '" << message.sender << "' at tick "
            << world_.tick() << "\n";
  if (options_.mode == TimingMode::kLockstep) {
    // Answers to the state before the teleport no longer apply: ask again.
    answers_.clear();
    awaited_tick_ = world_.tick();
    waiting_since_ = Clock::now();
  }
  PublishState();
}

core::ArmCommand SimNode::Combine(const std::vector<const core::ArmCommand*>& answers) const {
  const int n = world_.model().num_joints();
  core::ArmCommand combined;
  combined.tick = world_.tick();
  combined.sender = options_.process_name;
  combined.effort.assign(static_cast<size_t>(n), 0.0);
  bool any_effort = false;
  bool any_hold = false;
  for (const core::ArmCommand* answer : answers) {
    if (answer->mode == core::CommandMode::kHold) {
      any_hold = true;
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
  return combined;
}

void SimNode::StepTicks(const core::ArmCommand& command, int ticks) {
  for (int k = 0; k < ticks && !Finished(); ++k) {
    world_.Step(command);
    ++counters_.steps;
    if (world_.tick() % options_.state_every == 0 || Finished()) PublishState();
  }
}

void SimNode::PublishState() {
  bus_.Publish(options_.channels.sim_arm_state, core::ToMessage(world_.State(), state_seq_++));
  ++counters_.states_published;
}

void SimNode::PublishLatched(bool force) {
  const Clock::time_point now = Clock::now();
  if (!force && latched_sent_ && Seconds(now - last_latched_) < 1.0) return;
  const auto utime = static_cast<int64_t>(std::llround(world_.time_s() * 1e6));
  bus_.Publish(options_.channels.robot_model, core::ToMessage(world_.model(), utime, model_seq_++));
  bus_.Publish(options_.channels.environment,
               core::ToMessage(environment_, utime, environment_seq_++));
  last_latched_ = now;
  latched_sent_ = true;
}

bool SimNode::Finished() const {
  if (stop_requested_) return true;
  return options_.duration_s > 0 && world_.time_s() >= options_.duration_s - 0.5 * world_.step_s();
}

bool SimNode::Service(int max_wait_ms) {
  if (Finished()) return false;
  if (options_.mode == TimingMode::kLockstep) {
    ServiceLockstep(max_wait_ms);
  } else {
    ServiceFree(max_wait_ms);
  }
  PublishLatched(false);
  const bool troubled = !detail_.empty() && Seconds(Clock::now() - last_problem_) < kProblemMemoryS;
  heartbeat_.PublishIfDue(troubled ? core::ProcessState::kDegraded : core::ProcessState::kRunning,
                          troubled ? detail_ : "");
  return !Finished();
}

void SimNode::ServiceLockstep(int max_wait_ms) {
  if (!started_) {
    started_ = true;
    awaited_tick_ = world_.tick();
    waiting_since_ = Clock::now();
    PublishState();
  }
  auto all_answered = [this] {
    for (const std::string& name : options_.participants) {
      if (answers_.count(name) == 0) return false;
    }
    return true;
  };
  bus_.HandleAvailable();
  if (!all_answered()) bus_.Handle(max_wait_ms);
  if (all_answered()) {
    std::vector<const core::ArmCommand*> in_order;  // participants' order: sums are reproducible
    for (const std::string& name : options_.participants) in_order.push_back(&answers_.at(name));
    const core::ArmCommand combined = Combine(in_order);
    answers_.clear();
    StepTicks(combined,
              options_.state_every - static_cast<int>(world_.tick() % options_.state_every));
    awaited_tick_ = world_.tick();
    waiting_since_ = Clock::now();
    return;
  }
  const Clock::time_point now = Clock::now();
  // A state sent before a participant subscribed (the usual start-up order) or lost on the way is
  // sent again every 0.1 s without a report; only the full timeout is reported.
  if (Seconds(now - last_resend_) >= kResendPeriodS &&
      Seconds(now - waiting_since_) >= kResendPeriodS) {
    PublishState();
    last_resend_ = now;
  }
  if (Seconds(now - waiting_since_) >= options_.lockstep_timeout_s) {
    std::vector<std::string> missing;
    for (const std::string& name : options_.participants) {
      if (answers_.count(name) == 0) missing.push_back(name);
    }
    ++counters_.lockstep_timeouts;
    char waited[32];
    std::snprintf(waited, sizeof waited, "%.2f", Seconds(now - waiting_since_));
    detail_ = "lockstep: tick " + std::to_string(awaited_tick_) + ": no answer from " +
              JoinNames(missing) + " for " + waited + " s; waiting (state sent again)";
    last_problem_ = now;
    std::cerr << options_.process_name << ": " << detail_ << "\n";
    PublishState();
    waiting_since_ = now;
  }
}

void SimNode::ServiceFree(int max_wait_ms) {
  const Clock::time_point now = Clock::now();
  if (!started_) {
    started_ = true;
    start_wall_ = now;
    start_tick_ = world_.tick();
    PublishState();
  }
  bus_.HandleAvailable();
  auto command_now = [this](Clock::time_point at) {
    if (newest_.empty()) {
      core::ArmCommand idle;
      idle.mode = options_.idle;
      idle.effort.assign(static_cast<size_t>(world_.model().num_joints()), 0.0);
      return idle;
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
        detail_ = "watchdog: no command for more than " +
                  core::FormatNumber(options_.watchdog_s * 1e3) + " ms: arm braked";
        std::cerr << options_.process_name << ": " << detail_ << "\n";
      }
      last_problem_ = at;
      core::ArmCommand hold;
      hold.mode = core::CommandMode::kHold;
      return hold;
    }
    return Combine(fresh);
  };
  if (options_.mode == TimingMode::kFast) {
    const core::ArmCommand command = command_now(now);
    for (int k = 0; k < kFastBatch && !Finished(); ++k) StepTicks(command, 1);
    return;
  }
  // Realtime: run every tick whose wall-clock time has come.
  const double step = world_.step_s();
  const auto due = static_cast<int64_t>(std::floor(Seconds(now - start_wall_) / step)) -
                   (world_.tick() - start_tick_);
  if (due > static_cast<int64_t>(kMaxCatchUpS / step)) {
    counters_.overruns += due;
    detail_ = "realtime: " + core::FormatApprox(static_cast<double>(due) * step * 1e3) +
              " ms behind the wall clock; clock restarted";
    last_problem_ = now;
    std::cerr << options_.process_name << ": " << detail_ << "\n";
    start_wall_ = now;
    start_tick_ = world_.tick();
    StepTicks(command_now(now), 1);
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
      // On time but the answer is not in yet: give it up to a quarter of a step (the tick starts
      // that much later) rather than step with the previous command.
      const Clock::time_point grace = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                                         std::chrono::duration<double>(step / 4));
      while (k == 0 && due == 1 && !answered() && Clock::now() < grace) bus_.HandleAvailable();
      if (!answered()) {
        // The tick holds an older command: counted late (docs/timing.md).
        ++counters_.ticks_late;
        bus_.NoteLate(options_.channels.sim_arm_command);
      }
    }
    StepTicks(command_now(Clock::now()), 1);
  }
  // Wait for the next tick, handling messages meanwhile.
  const Clock::time_point next =
      start_wall_ + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(
                        static_cast<double>(world_.tick() - start_tick_ + 1) * step));
  const double wait_s = Seconds(next - Clock::now());
  if (wait_s >= 0.002) {
    bus_.Handle(std::min(max_wait_ms, static_cast<int>(wait_s * 1e3) - 1));
  } else if (wait_s > 0) {
    std::this_thread::sleep_until(next);
  }
}

}  // namespace sirupp::sim
