// The one real arm, by turns (turns/turn_manager.hpp, issues 33 and 41), in process and on
// simulated time: three students' rigs (sirupp-sim and sirupp-control in lockstep, each on a
// memq:// bus of its own) and a scripted bridge on a fourth bus. One round of the test is one servo
// tick (0.512 ms) of every rig and of the manager's clock (TurnOptions::clock), so turns, warnings,
// a handover's steps and their timeouts take the same simulated time on any machine, and the
// tests can say exactly when something happened. The manager relays the holder's rig to the
// bridge; between two turns the arm is held, homed at reduced speed, checked and disarmed.

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
#include <sirupp/controller_status_t.hpp>
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
#include "turns/turn_manager.hpp"

namespace sirupp::turns {
namespace {

constexpr double kDeg = 3.14159265358979323846 / 180;
using Status = sirupp::hardware_status_t;
using TimePoint = std::chrono::steady_clock::time_point;

const core::RobotModel& Puma() {
  static const core::RobotModel model = core::LoadRobotModel("config/robots/puma260.yaml");
  return model;
}

std::chrono::steady_clock::duration Seconds(double s) {
  return std::chrono::duration_cast<std::chrono::steady_clock::duration>(
      std::chrono::duration<double>(s));
}

// The bridge as the turn manager meets it, on a clock the test gives: the states (connected,
// armed, linked, fault, e-stopped) and their commands as sirupp-hardware takes them (a move is
// mirrored only while linked; a refused command is answered on HARDWARE_REPLY with the reason and
// shown in last_error), HARDWARE_STATUS at 10 Hz with each module's MOVE_DONE bit, REAL_ARM_STATE
// at 100 Hz. Its joints move at a move's speed, each stopping `short_of_goal_rad` short of the
// goal as static friction holds a PD-driven joint. What it cannot do is scripted: `refuse` (a
// command refused with a reason), Trip() (a joint's position error), Mute() (it goes silent).
// The real bridge on the emulated boards (which run on the wall clock), with the turns, is tested
// by test_class_turns and tests/cli/turns_serve.sh; this one lets a turn and its handover run on
// simulated time.
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
    if (muted_) return;
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

// A student's rig: physics and controller in lockstep on a bus of its own, both on the test's
// clock (the controller's watchdogs and status rate too, as the bridge's silence is on it).
struct StudentRig {
  explicit StudentRig(const std::function<TimePoint()>& clock)
      : sim(bus, world, core::Environment{}, SimOptions(clock)),
        control(bus, Puma(), Control(clock)) {}
  static sim::NodeOptions SimOptions(const std::function<TimePoint()>& clock) {
    sim::NodeOptions options;
    options.clock.now = clock;
    options.clock.sleep_until = [](TimePoint) {};  // the test moves the clock
    return options;
  }
  static control::ControlOptions Control(const std::function<TimePoint()>& clock) {
    control::ControlOptions options;
    options.clock = clock;
    return options;
  }
  core::Bus bus{"memq://"};
  sim::ArmWorld world{Puma(), core::Environment{}};
  sim::SimNode sim;
  control::ControlNode control;
  std::unique_ptr<client::Client> client;
};

struct Class {
  explicit Class(TurnOptions options,
                 const std::vector<std::string>& names = {"alice", "bob", "carol"}) {
    options.clock = [this] { return now; };
    options.log_path = log_path;
    options.on_event = [this](const std::string& line) { events.push_back({Elapsed(), line}); };
    std::remove(log_path.c_str());
    manager = std::make_unique<TurnManager>(arm_bus, Puma(), options);
    arm_bus.Subscribe<Status>(
        core::Channels{}.hardware_status,
        [this](const Status& s, const core::ReceiveInfo&) {
          if (states.empty() || states.back() != s.state) states.push_back(s.state);
          hardware = s;
        },
        100);
    for (const std::string& name : names) {
      auto rig = std::make_unique<StudentRig>([this] { return now; });
      core::Bus* bus = &rig->bus;
      // The rig's own bus (no ownership): its nodes live here.
      manager->AddRig(name,
                      [bus] { return std::shared_ptr<core::Bus>(std::shared_ptr<void>(), bus); });
      rig->client = std::make_unique<client::Client>(rig->bus, client::Options{});
      rig->client->SetIdle([this] { Round(); });
      rigs[name] = std::move(rig);
    }
  }

  // One servo tick of simulated time for everyone.
  void Round() {
    now += Seconds(kTickS);
    for (auto& [name, rig] : rigs) {
      rig->sim.Service(0);
      rig->control.Service(0);
    }
    bridge.Service();
    manager->Service();
  }
  double Elapsed() const { return std::chrono::duration<double>(now - start).count(); }
  // Rounds until done() holds or `seconds` of simulated time passed; returns done().
  bool RunUntil(const std::function<bool()>& done, double seconds) {
    const TimePoint end = now + Seconds(seconds);
    while (now < end) {
      Round();
      if (done()) return true;
    }
    return done();
  }
  void RunFor(double seconds) {
    RunUntil([] { return false; }, seconds);
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
    const bool ended = RunUntil(
        [&] {
          const auto& s = c.snapshot().controller;
          return s && s->seq >= answer.status_seq &&
                 (s->state == sirupp::controller_status_t::STATE_FAULT ||
                  (s->move_id == answer.move_id &&
                   s->state == sirupp::controller_status_t::STATE_IDLE));
        },
        kLongWaitS);
    ASSERT_TRUE(ended) << student << ": move " << answer.move_id << " not done";
    ASSERT_NE(c.snapshot().controller->state, sirupp::controller_status_t::STATE_FAULT)
        << student << ": " << c.snapshot().controller->last_error;
  }
  double RealDeg(int joint) const { return bridge.position()[joint] / kDeg; }
  // The simulated time of the first event that contains `text`; -1 if none.
  double EventAt(const std::string& text) const {
    for (const auto& [at, line] : events) {
      if (line.find(text) != std::string::npos) return at;
    }
    return -1;
  }

  static constexpr double kTickS = 0.000512;  // puma260.yaml's servo_tick_s
  // Simulated seconds: long enough for anything a test waits for (a handover takes about 10).
  static constexpr double kLongWaitS = 120;
  TimePoint start = TimePoint(std::chrono::hours(1));
  TimePoint now = start;
  std::string log_path = ::testing::TempDir() + "/sirupp_turns_test.jsonl";
  core::Bus arm_bus{"memq://"};
  ScriptedBridge bridge{arm_bus, Puma(), [this] { return now; }};
  // Before the manager: it is destroyed first, while the rig it may hold still has its bus.
  std::map<std::string, std::unique_ptr<StudentRig>> rigs;
  std::unique_ptr<TurnManager> manager;
  std::vector<int8_t> states;  // the bridge's states, each change
  std::optional<Status> hardware;
  std::vector<std::pair<double, std::string>> events;  // simulated time, line
};

TurnOptions ShortTurns() {
  TurnOptions options;
  options.turn_s = 4.0;  // simulated: enough for a few moves
  options.warn_before_s = {1.0};
  return options;
}

// Three students take turns. Between two turns the arm is homed within 1 deg and disarmed before
// the next link; a student out of turn cannot move the real arm (their moves stay virtual, and
// MayCommand says why); an e-stop from a student without a turn stops the real arm, and the
// handover that follows cannot finish: the queue stops and says why. A turn lasts turn_s to the
// tick, its warning comes warn_before_s before its end.
TEST(Turns, ThreeStudentsTakeTurnsOnTheRealArm) {
  Class c(ShortTurns());
  for (const char* name : {"alice", "bob", "carol"}) c.manager->Join(name);
  EXPECT_THROW(c.manager->Join("alice"), TurnError);
  EXPECT_THROW(c.manager->Join("mallory"), TurnError);

  // Alice's turn: the bridge linked to her rig, her moves on the real arm too.
  ASSERT_TRUE(c.TurnOf("alice")) << c.manager->status().last_event;
  const double alice_from = c.Elapsed();
  EXPECT_EQ(c.hardware->state, Status::STATE_LINKED);
  EXPECT_EQ(c.manager->MayCommand("alice"), "");
  const std::string bob_may = c.manager->MayCommand("bob");
  EXPECT_NE(bob_may.find("in alice's turn"), std::string::npos) << bob_may;
  EXPECT_NE(bob_may.find("number 1 in the queue"), std::string::npos) << bob_may;
  c.Move("alice", {20, -90, 90, 0, 45, 0});
  EXPECT_TRUE(c.RunUntil([&] { return std::abs(c.RealDeg(0) - 20) < 0.1; }, 2))
      << "real joint 1 at " << c.RealDeg(0);
  // Bob, out of turn, moves his own arm: the real arm stays where Alice put it.
  const size_t mirrored = c.bridge.mirrored_moves.size();
  c.Move("bob", {-30, 0, 0, 0, 0, 0});
  c.RunFor(0.5);
  EXPECT_NEAR(c.RealDeg(0), 20, 0.1);
  EXPECT_EQ(c.bridge.mirrored_moves.size(), mirrored);

  // Time up, to the tick; the warning a second before. The handover homes the arm and disarms
  // it, then Bob's turn begins.
  ASSERT_TRUE(c.RunUntil([&] { return c.manager->status().phase == Phase::kHandoverOut; }, 10));
  EXPECT_NEAR(c.Elapsed() - alice_from, 4.0, 2 * Class::kTickS);
  EXPECT_NEAR(c.EventAt("alice: your turn on the real arm ends in 1.0 s") - alice_from, 3.0,
              2 * Class::kTickS);
  ASSERT_TRUE(c.TurnOf("bob")) << c.manager->status().last_event;
  ASSERT_EQ(c.manager->history().size(), 2u);
  EXPECT_EQ(c.manager->history()[0].ended, "time up");
  EXPECT_EQ(c.manager->history()[0].handover_result, "ok");
  c.Move("bob", {0, -20, 30, 0, 0, 0});
  EXPECT_TRUE(c.RunUntil([&] { return std::abs(c.RealDeg(1) + 20) < 0.1; }, 2))
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
  int handovers = 0;
  for (const auto& [at, event] : c.events) {
    if (event.find("handover after") == std::string::npos) continue;
    ++handovers;
    EXPECT_NE(event.find("the arm is home"), std::string::npos) << event;
  }
  EXPECT_EQ(handovers, 2);

  // Carol moves; Alice, without a turn, e-stops the real arm.
  c.Move("carol", {15, 0, 0, 0, 0, 0});
  c.manager->Estop("alice", "test: an e-stop from a student without a turn");
  EXPECT_TRUE(c.RunUntil([&] { return c.hardware->state == Status::STATE_ESTOPPED; }, 1));
  c.manager->EndTurn("teacher");
  EXPECT_TRUE(c.RunUntil([&] { return c.manager->status().phase == Phase::kStopped; }, 5));
  const TurnStatus stopped = c.manager->status();
  EXPECT_NE(stopped.stopped_reason.find("handover after carol's turn failed"), std::string::npos)
      << stopped.stopped_reason;
  EXPECT_NE(stopped.stopped_reason.find("e-stopped"), std::string::npos) << stopped.stopped_reason;
  // Nobody gets the arm now.
  c.manager->Join("alice");
  c.RunFor(1.0);
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
  ASSERT_TRUE(c.RunUntil([&] { return c.manager->status().step == "home at reduced speed"; },
                         Class::kLongWaitS));
  c.RunFor(0.5);  // under way
  c.bridge.Trip(2);
  ASSERT_TRUE(c.RunUntil([&] { return c.manager->status().phase == Phase::kStopped; }, 1))
      << c.manager->status().last_event;
  const std::string reason = c.manager->status().stopped_reason;
  EXPECT_NE(reason.find("handover after alice's turn failed at 'home at reduced speed'"),
            std::string::npos)
      << reason;
  EXPECT_NE(reason.find("joint 2: position error"), std::string::npos) << reason;
  c.RunFor(1.0);
  EXPECT_EQ(c.manager->status().holder, "");
  ASSERT_EQ(c.manager->status().queue.size(), 1u);
  EXPECT_EQ(c.manager->status().queue[0].student, "bob");
  EXPECT_NE(c.events.back().second.find("STOPPED"), std::string::npos) << c.events.back().second;
  // The teacher sees to the arm before resuming: until then bob is told why he waits.
  EXPECT_NE(c.manager->MayCommand("bob").find("queue is stopped"), std::string::npos);
}

// A joint that static friction holds short of home (the PD law has no integral by default): the
// pose check corrects it with a slow move to home plus its error, and the handover finishes.
TEST(Turns, AJointHeldShortOfHomeIsCorrected) {
  TurnOptions options = ShortTurns();
  options.turn_s = 1.0;
  Class c(options, {"alice"});
  c.bridge.short_of_goal_rad = {0, 2 * kDeg, 0, 0, 0, 0};
  c.manager->Join("alice");
  ASSERT_TRUE(c.TurnOf("alice"));
  ASSERT_TRUE(
      c.RunUntil([&] { return c.manager->status().phase == Phase::kIdle; }, Class::kLongWaitS))
      << c.manager->status().last_event;
  ASSERT_EQ(c.manager->history().size(), 1u);
  EXPECT_EQ(c.manager->history()[0].handover_result, "ok");
  EXPECT_GE(c.EventAt("homing: joint 2 is 2.0 deg away (allowed 1.0 deg); correction 1"), 0);
  EXPECT_LT(c.EventAt("correction 2"), 0);
  EXPECT_NEAR(c.RealDeg(1), Puma().joints[1].home / kDeg, 0.01);
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
  c.RunFor(0.5);
  EXPECT_EQ(c.manager->status().phase, Phase::kIdle);
  EXPECT_EQ(c.manager->status().holder, "");
  EXPECT_TRUE(c.manager->status().queue.empty());
  EXPECT_NE(c.manager->status().last_event.find("handover to alice not begun: alice's controller"),
            std::string::npos)
      << c.manager->status().last_event;
  for (int8_t state : c.states) EXPECT_NE(state, Status::STATE_ARMED);
}

// A rig whose controller refuses the move to the real arm's pose (here: locked in automatic mode)
// is skipped at once with the controller's words, and the arm is never armed for it; the next
// student's turn follows.
TEST(Turns, ARigThatRefusesTheMoveToTheRealPoseIsSkippedWithItsReason) {
  Class c(ShortTurns(), {"alice", "bob"});
  ASSERT_TRUE(c.rigs["alice"]->client->Plan(client::PlanCommand::kAutomatic).accepted());
  c.manager->Join("alice");
  c.manager->Join("bob");
  const double from = c.Elapsed();
  ASSERT_TRUE(c.RunUntil([&] { return c.EventAt("handover to alice failed") >= 0; }, 1.0))
      << c.manager->status().last_event;
  EXPECT_LT(c.EventAt("handover to alice failed") - from, 0.05);  // at the reply, not a timeout
  const std::string& skipped =
      c.events[static_cast<size_t>(std::find_if(c.events.begin(), c.events.end(),
                                                [](const auto& e) {
                                                  return e.second.find(
                                                             "handover to alice failed") !=
                                                         std::string::npos;
                                                }) -
                                   c.events.begin())]
          .second;
  EXPECT_NE(
      skipped.find("at 'the virtual arm to the real arm's pose': alice's rig refused the move "
                   "to the real arm's pose"),
      std::string::npos)
      << skipped;
  EXPECT_NE(skipped.find("locked in automatic mode"), std::string::npos) << skipped;
  EXPECT_NE(skipped.find("their turn is skipped"), std::string::npos) << skipped;
  ASSERT_TRUE(c.TurnOf("bob")) << c.manager->status().last_event;
  ASSERT_EQ(c.manager->history().size(), 1u);
  EXPECT_EQ(c.manager->history()[0].student, "bob");
}

// Defect 3 (issue 41): a bridge that refuses UNLINK during the handover after a turn. The handover
// must stop there with the bridge's reason, in the status and the turn log, and not go on to
// disarm as if the rig were unlinked.
TEST(Turns, ABridgeThatRefusesUnlinkStopsTheHandover) {
  TurnOptions options = ShortTurns();
  options.turn_s = 0.5;
  Class c(options, {"alice"});
  c.bridge.refuse[core::HardwareAction::kUnlink] = "unlink: refused by the test's bridge";
  c.manager->Join("alice");
  ASSERT_TRUE(c.RunUntil(
      [&] {
        return c.manager->status().phase == Phase::kStopped ||
               (!c.manager->history().empty() &&
                !c.manager->history().back().handover_result.empty());
      },
      Class::kLongWaitS));
  const TurnStatus status = c.manager->status();
  ASSERT_EQ(status.phase, Phase::kStopped) << status.last_event;
  EXPECT_NE(status.stopped_reason.find("handover after alice's turn failed at 'unlink the bridge'"),
            std::string::npos)
      << status.stopped_reason;
  EXPECT_NE(status.stopped_reason.find("unlink: refused by the test's bridge"), std::string::npos)
      << status.stopped_reason;
  ASSERT_EQ(c.manager->history().size(), 1u);
  EXPECT_EQ(c.manager->history()[0].handover_result, status.stopped_reason);
  // It did not go on to disarm a bridge that may still be linked.
  EXPECT_EQ(
      std::count(c.bridge.commands.begin(), c.bridge.commands.end(), core::HardwareAction::kDisarm),
      0);
  std::ifstream log(c.log_path);
  std::string line, last_turn;
  while (std::getline(log, line)) {
    if (line.rfind("{\"turn\": ", 0) == 0) last_turn = line;
  }
  EXPECT_NE(last_turn.find("unlink: refused by the test's bridge"), std::string::npos) << last_turn;
}

// A bridge that goes silent during a handover: the step waits for it (what it said last may be
// stale) and fails at its timeout, to the tick, naming the silence.
TEST(Turns, ASilentBridgeFailsTheStepAtItsTimeout) {
  TurnOptions options = ShortTurns();
  options.turn_s = 0.5;
  options.step_timeout_s = 5;
  Class c(options, {"alice"});
  c.manager->Join("alice");
  ASSERT_TRUE(c.TurnOf("alice"));
  c.bridge.Mute();
  ASSERT_TRUE(c.RunUntil([&] { return c.manager->status().phase == Phase::kHandoverOut; }, 1));
  const double from = c.Elapsed();
  ASSERT_TRUE(c.RunUntil([&] { return c.manager->status().phase == Phase::kStopped; }, 10));
  EXPECT_NEAR(c.Elapsed() - from, 5.0, 3 * Class::kTickS);
  const std::string reason = c.manager->status().stopped_reason;
  EXPECT_NE(reason.find("failed at 'unlink the rig and hold the arm': not done within 5.0 s "
                        "(sirupp-hardware silent for "),
            std::string::npos)
      << reason;
  EXPECT_NE(c.manager->status().bridge.find("silent"), std::string::npos)
      << c.manager->status().bridge;
}

}  // namespace
}  // namespace sirupp::turns
