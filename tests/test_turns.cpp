// The one real arm, by turns (turns/turn_manager.hpp, issue 33), in process: three students' rigs
// (sirupp-sim and sirupp-control in lockstep, each on a memq:// bus of its own) and the bridge on
// the emulated PIC-SERVO boards on a fourth bus. The manager relays the holder's rig to the bridge;
// between two turns the arm is held, homed at reduced speed, checked and disarmed.

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <functional>
#include <iostream>
#include <map>
#include <memory>
#include <sirupp/command_reply_t.hpp>
#include <sirupp/estop_t.hpp>
#include <sirupp/hardware_command_t.hpp>
#include <sirupp/hardware_status_t.hpp>
#include <sirupp/servo_move_t.hpp>
#include <stdexcept>
#include <string>
#include <vector>

#include "client/client.hpp"
#include "control/control_node.hpp"
#include "core/bus.hpp"
#include "core/command_reply.hpp"
#include "core/messages.hpp"
#include "core/model_loader.hpp"
#include "core/translate.hpp"
#include "sim/sim_node.hpp"
#include "tests/emulated_bridge.hpp"
#include "turns/turn_manager.hpp"

namespace sirupp::turns {
namespace {

constexpr double kDeg = 3.14159265358979323846 / 180;
constexpr double kLongWaitS = 120;  // wall clock; the tests check what happened, not how fast
using Status = sirupp::hardware_status_t;

const core::RobotModel& Puma() {
  static const core::RobotModel model = core::LoadRobotModel("config/robots/puma260.yaml");
  return model;
}

// A student's rig: physics and controller in lockstep on a bus of its own.
struct StudentRig {
  core::Bus bus{"memq://"};
  sim::ArmWorld world{Puma(), core::Environment{}};
  sim::SimNode sim{bus, world, core::Environment{}, sim::NodeOptions{}};
  control::ControlNode control{bus, Puma(), control::ControlOptions{}};
  std::unique_ptr<client::Client> client;
};

struct Class {
  explicit Class(TurnOptions options) {
    arm = std::make_unique<testing::EmulatedBridge>(arm_bus, Puma());
    options.log_path = log_path;
    options.on_event = [this](const std::string& line) { events.push_back(line); };
    std::remove(log_path.c_str());
    manager = std::make_unique<TurnManager>(arm_bus, Puma(), options);
    arm_bus.Subscribe<Status>(
        core::Channels{}.hardware_status,
        [this](const Status& s, const core::ReceiveInfo&) {
          if (states.empty() || states.back() != s.state) states.push_back(s.state);
          hardware = s;
        },
        100);
    arm_bus.Subscribe<sirupp::arm_state_t>(
        core::Channels{}.real_arm_state,
        [this](const sirupp::arm_state_t& s, const core::ReceiveInfo&) { real = s; }, 2);
    for (const char* name : {"alice", "bob", "carol"}) {
      auto rig = std::make_unique<StudentRig>();
      core::Bus* bus = &rig->bus;
      // The rig's own bus (no ownership): its nodes live here.
      manager->AddRig(name,
                      [bus] { return std::shared_ptr<core::Bus>(std::shared_ptr<void>(), bus); });
      rig->client = std::make_unique<client::Client>(rig->bus, client::Options{});
      rig->client->SetIdle([this] { ServiceAll(); });
      rigs[name] = std::move(rig);
    }
  }

  void ServiceAll() {
    for (auto& [name, rig] : rigs) {
      rig->sim.Service(0);
      rig->control.Service(0);
    }
    arm->bridge->Service(0);
    manager->Service();
  }
  bool RunUntil(const std::function<bool()>& done, double seconds) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
    while (std::chrono::steady_clock::now() < end) {
      ServiceAll();
      if (done()) return true;
    }
    return done();
  }
  bool TurnOf(const std::string& student) {
    return RunUntil(
        [&] {
          const TurnStatus s = manager->status();
          return s.phase == Phase::kTurn && s.holder == student;
        },
        kLongWaitS);
  }
  // Moves `student`'s virtual arm; returns once the move is done.
  void Move(const std::string& student, const std::vector<double>& degrees) {
    client::JointTarget target;
    for (double d : degrees) target.position.push_back(d * kDeg);
    client::Client& c = *rigs[student]->client;
    const client::Answer answer = c.MoveJoints(target);
    ASSERT_TRUE(answer.accepted()) << student << ": " << answer.error;
    const client::Outcome outcome = c.WaitForMove(answer.move_id, kLongWaitS, answer.status_seq);
    ASSERT_TRUE(outcome.ok()) << student << ": " << outcome.detail;
  }
  double RealDeg(int joint) const { return real ? real->position[joint] / kDeg : NAN; }
  double HomeOffsetDeg() const {
    double worst = 0;
    for (size_t j = 0; j < Puma().joints.size(); ++j) {
      worst = std::max(worst, std::abs(real->position[j] - Puma().joints[j].home) / kDeg);
    }
    return worst;
  }

  std::string log_path = ::testing::TempDir() + "/sirupp_turns_test.jsonl";
  core::Bus arm_bus{"memq://"};
  std::unique_ptr<testing::EmulatedBridge> arm;
  std::unique_ptr<TurnManager> manager;
  std::map<std::string, std::unique_ptr<StudentRig>> rigs;
  std::vector<int8_t> states;  // the bridge's states, each change
  std::optional<Status> hardware;
  std::optional<sirupp::arm_state_t> real;
  std::vector<std::string> events;
};

// The bridge as the turn manager meets it, on a clock the test gives: the states (connected,
// armed, linked, fault, e-stopped) and their commands as sirupp-hardware takes them (a move is
// mirrored only while linked; a refused command is answered on HARDWARE_REPLY with the reason and
// shown in last_error), HARDWARE_STATUS at 10 Hz with each module's MOVE_DONE bit, REAL_ARM_STATE
// at 100 Hz. Its joints move at a move's speed, each stopping `short_of_goal_rad` short of the
// goal as static friction holds a PD-driven joint. What it cannot do is scripted: `refuse` (a
// command refused with a reason), Trip() (a joint's position error), Mute() (it goes silent).
// The real bridge on the emulated boards, with the turns, is tested by test_class_turns and
// tests/cli/turns_serve.sh; this one lets a turn and its handover run on simulated time.
class ScriptedBridge {
 public:
  using TimePoint = std::chrono::steady_clock::time_point;

  ScriptedBridge(core::Bus& bus, const core::RobotModel& model, std::function<TimePoint()> clock)
      : bus_(bus),
        model_(model),
        clock_(std::move(clock)),
        replier_(bus, core::Channels{}.hardware_reply, "sirupp-hardware"),
        position_({0, -90 * kDeg, 90 * kDeg, 0, 45 * kDeg, 0}),  // ready, as the boards start
        goal_(position_),
        speed_(position_.size(), 0.0),
        last_(clock_()) {
    const core::Channels c;
    bus_.Subscribe<sirupp::hardware_command_t>(
        c.hardware_command,
        [this](const sirupp::hardware_command_t& m, const core::ReceiveInfo& info) {
          replier_.Answer(
              m, info, [&] { OnCommand(core::HardwareCommandFromMessage(m, info.channel)); },
              [this] {
                return core::ReplyFacts{-1, status_seq_};
              });
        },
        100);
    bus_.Subscribe<sirupp::servo_move_t>(
        c.arm_move,
        [this](const sirupp::servo_move_t& m, const core::ReceiveInfo& info) {
          replier_.Answer(
              m, info, [&] { OnMove(core::ServoMoveFromMessage(m, info.channel)); },
              [this] {
                return core::ReplyFacts{-1, status_seq_};
              });
        },
        100);
    bus_.Subscribe<sirupp::estop_t>(
        c.estop, [this](const sirupp::estop_t& m, const core::ReceiveInfo& info) {
          const core::EStop estop = core::EStopFromMessage(m, info.channel);
          estopped_ = estop.engaged;
          if (estop.engaged) {
            linked_ = false;
            goal_ = position_;
            last_error_ = "emergency stop from '" + estop.sender + "': " + estop.reason;
          } else {
            armed_ = false;  // armed again explicitly after a release
            last_error_.clear();
          }
          PublishStatus();
        });
  }

  // Moves the joints to the clock's time and publishes what is due.
  void Service() {
    const TimePoint now = clock_();
    const double dt = std::chrono::duration<double>(now - last_).count();
    last_ = now;
    if (armed_ && !estopped_ && !faulted_) {
      for (size_t j = 0; j < position_.size(); ++j) {
        const double step = std::clamp(goal_[j] - position_[j], -speed_[j] * dt, speed_[j] * dt);
        position_[j] += step;
      }
    }
    if (muted_) return;
    if (now >= next_state_) {
      next_state_ = now + std::chrono::milliseconds(10);
      core::ArmState state;
      state.utime = core::WallMicros();
      state.source = core::StateSource::kEmulated;
      state.position = position_;
      bus_.Publish(core::Channels{}.real_arm_state, core::ToMessage(state, state_seq_++));
    }
    if (now >= next_status_) PublishStatus();
  }

  void Trip(int joint) {  // 1-based, as the boards' fault names it
    faulted_ = true;
    linked_ = false;
    goal_ = position_;
    fault_ = "joint " + std::to_string(joint) + ": position error limit exceeded";
    last_error_ = fault_;
    PublishStatus();
  }
  void Mute() { muted_ = true; }

  std::map<core::HardwareAction, std::string> refuse;  // command -> the reason it is refused
  std::vector<double> short_of_goal_rad;               // per joint; empty = none
  std::vector<int64_t> mirrored_moves;                 // the move ids taken while linked
  std::vector<core::HardwareAction> commands;          // every command, in order

  int8_t State() const {
    using S = sirupp::hardware_status_t;
    if (faulted_) return S::STATE_FAULT;
    if (estopped_) return S::STATE_ESTOPPED;
    if (linked_) return S::STATE_LINKED;
    return armed_ ? S::STATE_ARMED : S::STATE_CONNECTED;
  }
  const std::vector<double>& position() const { return position_; }

 private:
  void OnCommand(const core::HardwareCommand& command) {
    commands.push_back(command.command);
    try {
      if (auto it = refuse.find(command.command); it != refuse.end()) {
        throw std::runtime_error(it->second);
      }
      switch (command.command) {
        case core::HardwareAction::kArm:
          if (estopped_) throw std::runtime_error("arm: the emergency stop is engaged");
          if (faulted_) throw std::runtime_error("arm: clear the fault first (" + fault_ + ")");
          armed_ = true;
          goal_ = position_;
          break;
        case core::HardwareAction::kDisarm:
          linked_ = false;
          armed_ = false;
          break;
        case core::HardwareAction::kLink:
          if (estopped_) throw std::runtime_error("link: the emergency stop is engaged");
          if (faulted_) throw std::runtime_error("link: clear the fault first (" + fault_ + ")");
          if (!armed_) throw std::runtime_error("link: arm first");
          linked_ = true;
          break;
        case core::HardwareAction::kUnlink:
          linked_ = false;
          break;
        case core::HardwareAction::kClearFaults:
          faulted_ = false;
          armed_ = false;
          break;
        default:
          break;
      }
    } catch (const std::exception& e) {
      last_error_ = e.what();
      PublishStatus();
      throw;
    }
    last_error_.clear();
    PublishStatus();
  }

  void OnMove(const core::ServoMove& move) {
    if (!linked_) return;  // the virtual arm's moves: mirrored only while linked
    if (estopped_) throw std::runtime_error("move: emergency stop engaged");
    if (faulted_) throw std::runtime_error("move: fault: " + fault_);
    mirrored_moves.push_back(move.move_id);
    for (size_t j = 0; j < move.joints.size() && j < position_.size(); ++j) {
      const core::JointMove& m = move.joints[j];
      if ((m.flags & sirupp::servo_move_t::FLAG_ACTIVE) == 0) continue;
      if (move.command != core::MoveCommand::kMove) {
        goal_[j] = position_[j];
        continue;
      }
      const double distance = m.goal - position_[j];
      const double short_by = j < short_of_goal_rad.size() ? short_of_goal_rad[j] : 0.0;
      goal_[j] = std::abs(distance) <= short_by ? position_[j]
                                                : m.goal - std::copysign(short_by, distance);
      speed_[j] = m.max_velocity > 0 ? m.max_velocity : model_.joints[j].servo.default_velocity;
    }
  }

  void PublishStatus() {
    next_status_ = clock_() + std::chrono::milliseconds(100);
    core::HardwareStatus status;
    status.utime = core::WallMicros();
    status.seq = ++status_seq_;
    status.state = static_cast<core::BridgeState>(State());
    status.calibrated = true;
    status.port = "scripted";
    for (size_t j = 0; j < position_.size(); ++j) {
      const bool done = !armed_ || std::abs(goal_[j] - position_[j]) < 1e-9;
      status.modules.push_back({static_cast<int16_t>(0x08 | (done ? 0x01 : 0)), 0, 0, 0});
    }
    status.last_error = last_error_;
    bus_.Publish(core::Channels{}.hardware_status, core::ToMessage(status));
  }

  core::Bus& bus_;
  const core::RobotModel& model_;
  std::function<TimePoint()> clock_;
  core::Replier replier_;
  std::vector<double> position_, goal_, speed_;
  bool armed_ = false, linked_ = false, estopped_ = false, faulted_ = false, muted_ = false;
  std::string fault_, last_error_;
  int64_t status_seq_ = 0, state_seq_ = 0;
  TimePoint last_, next_state_{}, next_status_{};
};

TurnOptions ShortTurns() {
  TurnOptions options;
  options.turn_s = 10.0;  // wall clock: long enough for a few moves on a loaded machine
  options.warn_before_s = {2.0};
  // The rigs run in lockstep on this test's one thread, slower than real time on a loaded machine
  // (at load 18 the virtual arm did not reach the real pose within the default 15 + 10 s).
  options.step_timeout_s = 60;
  return options;
}

// Three students take turns. Between two turns the arm is homed within 1 deg and disarmed before
// the next link; a student out of turn cannot move the real arm (their moves stay virtual, and
// MayCommand says why); an e-stop from a student without a turn stops the real arm, and the
// handover that follows cannot finish: the queue stops and says why.
TEST(Turns, ThreeStudentsTakeTurnsOnTheRealArm) {
  Class c(ShortTurns());
  for (const char* name : {"alice", "bob", "carol"}) c.manager->Join(name);
  EXPECT_THROW(c.manager->Join("alice"), TurnError);
  EXPECT_THROW(c.manager->Join("mallory"), TurnError);

  // Alice's turn: the bridge linked to her rig, her moves on the real arm too.
  ASSERT_TRUE(c.TurnOf("alice")) << c.manager->status().last_event;
  EXPECT_EQ(c.hardware->state, Status::STATE_LINKED);
  EXPECT_EQ(c.manager->MayCommand("alice"), "");
  const std::string bob_may = c.manager->MayCommand("bob");
  EXPECT_NE(bob_may.find("in alice's turn"), std::string::npos) << bob_may;
  EXPECT_NE(bob_may.find("number 1 in the queue"), std::string::npos) << bob_may;
  c.Move("alice", {20, -90, 90, 0, 45, 0});
  EXPECT_TRUE(c.RunUntil([&] { return std::abs(c.RealDeg(0) - 20) < 1.5; }, 10))
      << "real joint 1 at " << c.RealDeg(0);
  // Bob, out of turn, moves his own arm: the real arm stays where Alice put it.
  c.Move("bob", {-30, 0, 0, 0, 0, 0});
  c.RunUntil([] { return false; }, 0.5);
  EXPECT_NEAR(c.RealDeg(0), 20, 1.5);

  // Time up: the handover homes the arm and disarms it, then Bob's turn begins.
  ASSERT_TRUE(c.TurnOf("bob")) << c.manager->status().last_event;
  ASSERT_EQ(c.manager->history().size(), 2u);
  EXPECT_EQ(c.manager->history()[0].ended, "time up");
  EXPECT_EQ(c.manager->history()[0].handover_result, "ok");
  c.Move("bob", {0, -20, 30, 0, 0, 0});
  EXPECT_TRUE(c.RunUntil([&] { return std::abs(c.RealDeg(1) + 20) < 1.5; }, 10))
      << "real joint 2 at " << c.RealDeg(1);
  c.manager->Done("bob");

  ASSERT_TRUE(c.TurnOf("carol")) << c.manager->status().last_event;
  EXPECT_EQ(c.manager->history()[1].ended, "done");
  EXPECT_EQ(c.manager->history()[1].handover_result, "ok");
  // Between the turns: linked, then disarmed (connected) at home, then linked again.
  int links = 0;
  for (size_t i = 0; i < c.states.size(); ++i) {
    if (c.states[i] != Status::STATE_LINKED) continue;
    ++links;
    if (links > 1) {
      bool disarmed_between = false;
      for (size_t k = i; k-- > 0 && c.states[k] != Status::STATE_LINKED;) {
        disarmed_between |= c.states[k] == Status::STATE_CONNECTED;
      }
      EXPECT_TRUE(disarmed_between) << "link " << links << " without a disarm before it";
    }
  }
  EXPECT_EQ(links, 3);
  for (const std::string& event : c.events) {
    if (event.find("handover after") == std::string::npos) continue;
    EXPECT_NE(event.find("the arm is home"), std::string::npos) << event;
  }

  // Carol moves; Alice, without a turn, e-stops the real arm.
  c.Move("carol", {15, 0, 0, 0, 0, 0});
  c.manager->Estop("alice", "test: an e-stop from a student without a turn");
  EXPECT_TRUE(c.RunUntil([&] { return c.hardware->state == Status::STATE_ESTOPPED; }, 5));
  c.manager->EndTurn("teacher");
  EXPECT_TRUE(c.RunUntil([&] { return c.manager->status().phase == Phase::kStopped; }, 30));
  const TurnStatus stopped = c.manager->status();
  EXPECT_NE(stopped.stopped_reason.find("handover after carol's turn failed"), std::string::npos)
      << stopped.stopped_reason;
  EXPECT_NE(stopped.stopped_reason.find("e-stopped"), std::string::npos) << stopped.stopped_reason;
  // Nobody gets the arm now.
  c.manager->Join("alice");
  c.RunUntil([] { return false; }, 1.0);
  EXPECT_EQ(c.manager->status().phase, Phase::kStopped);
  EXPECT_EQ(c.manager->status().holder, "");

  // Every turn is in the log: who, when, what ran, how it ended.
  std::ifstream log(c.log_path);
  std::string line;
  int turns = 0;
  std::cout << "the session's log (" << c.log_path << "):\n";
  while (std::getline(log, line)) {
    std::cout << "  " << line << "\n";
    turns += line.rfind("{\"turn\": ", 0) == 0 ? 1 : 0;
  }
  EXPECT_EQ(turns, 3);
}

// A joint that trips while the arm is homed: the handover cannot finish, the queue stops with the
// reason for the teacher and the next student never gets the arm.
TEST(Turns, AHandoverThatCannotHomeStopsTheQueue) {
  TurnOptions options = ShortTurns();
  options.turn_s = 1.0;
  Class c(options);
  c.manager->Join("alice");
  c.manager->Join("bob");
  ASSERT_TRUE(c.TurnOf("alice"));
  c.Move("alice", {30, -60, 60, 0, 45, 0});
  ASSERT_TRUE(
      c.RunUntil([&] { return c.manager->status().step == "home at reduced speed"; }, kLongWaitS));
  c.RunUntil([] { return false; }, 0.5);  // under way
  c.arm->emulator->TriggerPositionErrorTrip(1);
  ASSERT_TRUE(c.RunUntil([&] { return c.manager->status().phase == Phase::kStopped; }, 30))
      << c.manager->status().last_event;
  const std::string reason = c.manager->status().stopped_reason;
  EXPECT_NE(reason.find("handover after alice's turn failed at 'home at reduced speed'"),
            std::string::npos)
      << reason;
  c.RunUntil([] { return false; }, 1.0);
  EXPECT_EQ(c.manager->status().holder, "");
  ASSERT_EQ(c.manager->status().queue.size(), 1u);
  EXPECT_EQ(c.manager->status().queue[0].student, "bob");
  EXPECT_NE(c.events.back().find("STOPPED"), std::string::npos) << c.events.back();
  // The teacher sees to the arm (clears the fault, re-arms nothing) and resumes: bob's turn may
  // begin only with a bridge that is ready again.
  EXPECT_NE(c.manager->MayCommand("bob").find("queue is stopped"), std::string::npos);
}

// Who may have the arm (TurnOptions::admit; the class server asks whether the student's controller
// passed the class's safety tasks): a refused student cannot join, with the reason; one refused
// by the time their turn comes is skipped with it, and the arm is never armed for them.
TEST(Turns, OnlyAnAdmittedStudentGetsTheArm) {
  std::string refused;  // the student refused now
  TurnOptions options = ShortTurns();
  options.admit = [&refused](const std::string& student) {
    return student == refused ? student + "'s controller failed the class's safety tasks" : "";
  };
  Class c(options);
  refused = "bob";
  try {
    c.manager->Join("bob");
    ADD_FAILURE() << "bob joined";
  } catch (const TurnError& error) {
    EXPECT_NE(std::string(error.what()).find("failed the class's safety tasks"), std::string::npos)
        << error.what();
  }
  refused = "";
  c.manager->Join("alice");
  refused = "alice";  // alice switches to a controller that did not pass before her turn
  c.RunUntil([] { return false; }, 0.5);
  EXPECT_EQ(c.manager->status().phase, Phase::kIdle);
  EXPECT_EQ(c.manager->status().holder, "");
  EXPECT_TRUE(c.manager->status().queue.empty());
  EXPECT_NE(c.manager->status().last_event.find("handover to alice not begun: alice's controller"),
            std::string::npos)
      << c.manager->status().last_event;
  for (int8_t state : c.states) EXPECT_NE(state, Status::STATE_ARMED);
}

// Defect 3 (issue 41): a bridge that refuses UNLINK during the handover after a turn. The handover
// must stop there with the bridge's reason, in the status and the turn log, and not go on to
// disarm as if the rig were unlinked.
TEST(Turns, ABridgeThatRefusesUnlinkStopsTheHandover) {
  core::Bus arm_bus{"memq://"};
  ScriptedBridge bridge(arm_bus, Puma(), [] { return std::chrono::steady_clock::now(); });
  bridge.refuse[core::HardwareAction::kUnlink] = "unlink: refused by the test's bridge";
  TurnOptions options = ShortTurns();
  options.turn_s = 0.5;
  options.log_path = ::testing::TempDir() + "/sirupp_turns_unlink.jsonl";
  std::remove(options.log_path.c_str());
  TurnManager manager(arm_bus, Puma(), options);
  StudentRig alice;
  manager.AddRig("alice", [&alice] {
    return std::shared_ptr<core::Bus>(std::shared_ptr<void>(), &alice.bus);
  });
  manager.Join("alice");
  const auto end = std::chrono::steady_clock::now() +
                   std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                       std::chrono::duration<double>(kLongWaitS));
  while (std::chrono::steady_clock::now() < end && manager.status().phase != Phase::kStopped &&
         (manager.history().empty() || manager.history().back().handover_result.empty())) {
    alice.sim.Service(0);
    alice.control.Service(0);
    bridge.Service();
    manager.Service();
  }
  const TurnStatus status = manager.status();
  ASSERT_EQ(status.phase, Phase::kStopped) << status.last_event;
  EXPECT_NE(status.stopped_reason.find("handover after alice's turn failed at 'unlink the bridge'"),
            std::string::npos)
      << status.stopped_reason;
  EXPECT_NE(status.stopped_reason.find("unlink: refused by the test's bridge"), std::string::npos)
      << status.stopped_reason;
  ASSERT_EQ(manager.history().size(), 1u);
  EXPECT_EQ(manager.history()[0].handover_result, status.stopped_reason);
  // It did not go on to disarm a bridge that may still be linked.
  EXPECT_EQ(
      std::count(bridge.commands.begin(), bridge.commands.end(), core::HardwareAction::kDisarm), 0);
  std::ifstream log(options.log_path);
  std::string line, last_turn;
  while (std::getline(log, line)) {
    if (line.rfind("{\"turn\": ", 0) == 0) last_turn = line;
  }
  EXPECT_NE(last_turn.find("unlink: refused by the test's bridge"), std::string::npos) << last_turn;
}

}  // namespace
}  // namespace sirupp::turns
