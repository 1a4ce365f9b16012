// The sirupp-sim process logic (sim/sim_node.hpp) on an in-process memq:// bus: lockstep waiting
// and late-participant reports, command checks, teleports, realtime watchdog, fast mode, latched
// and heartbeat messages, and bit-identical lockstep runs. tests/test_sim_process.cpp runs the real
// process over UDP.

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstring>
#include <sirupp/arm_state_t.hpp>
#include <sirupp/board_status_t.hpp>
#include <sirupp/environment_t.hpp>
#include <sirupp/estop_t.hpp>
#include <sirupp/heartbeat_t.hpp>
#include <sirupp/robot_model_t.hpp>
#include <sirupp/servo_move_t.hpp>
#include <sirupp/servo_setpoint_t.hpp>
#include <sirupp/sim_status_t.hpp>

#include "core/bus.hpp"
#include "core/model_loader.hpp"
#include "core/translate.hpp"
#include "sim/sim_node.hpp"

namespace sirupp::sim {
namespace {

core::RobotModel Puma() { return core::LoadRobotModel("config/robots/puma260.yaml"); }

// A participant on the same bus: answers every state with a PD law towards `target`, or with
// whatever `make` returns.
class Participant {
 public:
  Participant(core::Bus& bus, std::string name, std::vector<double> target)
      : bus_(bus), name_(std::move(name)), target_(std::move(target)) {
    bus_.Subscribe<sirupp::arm_state_t>(
        "SIM_ARM_STATE", [this](const sirupp::arm_state_t& state, const core::ReceiveInfo&) {
          states.push_back(state);
          if (silent) return;
          sirupp::arm_command_t command{};
          command.tick = state.tick;
          command.utime = state.utime;
          command.seq = seq_++;
          command.sender = name_;
          command.mode = sirupp::arm_command_t::MODE_EFFORT;
          command.num_joints = state.num_joints;
          for (int j = 0; j < state.num_joints; ++j) {
            command.effort.push_back(
                20.0 * (target_[static_cast<size_t>(j)] - state.position[static_cast<size_t>(j)]) -
                0.5 * state.velocity[static_cast<size_t>(j)]);
          }
          if (tamper) tamper(command);
          bus_.Publish("SIM_ARM_COMMAND", command);
        });
  }
  std::vector<sirupp::arm_state_t> states;
  bool silent = false;
  std::function<void(sirupp::arm_command_t&)> tamper;

 private:
  core::Bus& bus_;
  std::string name_;
  std::vector<double> target_;
  int64_t seq_ = 0;
};

// A clock the test moves: the node's pacing, gate and watchdog read it instead of the wall clock.
// sleep_until moves it only when `sleeping_moves_time` (a node that sleeps then finds the time
// has come, as on a real clock).
struct TestClock {
  NodeClock::TimePoint now{};
  bool sleeping_moves_time = true;
  NodeClock Clock() {
    NodeClock clock;
    clock.now = [this] { return now; };
    clock.sleep_until = [this](NodeClock::TimePoint until) {
      if (sleeping_moves_time && until > now) now = until;
    };
    return clock;
  }
  void Advance(double seconds) {
    now += std::chrono::duration_cast<std::chrono::steady_clock::duration>(
        std::chrono::duration<double>(seconds));
  }
};

// Lockstep on a clock that stands still unless the test gives its own: no report of a late
// participant can come from a loaded machine.
NodeOptions Lockstep(std::vector<std::string> participants) {
  NodeOptions options;
  options.mode = TimingMode::kLockstep;
  options.participants = std::move(participants);
  options.lockstep_timeout_s = 0.05;
  options.clock.now = [] { return NodeClock::TimePoint{}; };
  options.clock.sleep_until = [](NodeClock::TimePoint) {};
  return options;
}

void ServiceUntil(SimNode& node, int64_t tick, const ArmWorld& world) {
  for (int k = 0; k < 100000 && world.tick() < tick; ++k) node.Service(0);
}

TEST(SimNode, LockstepStepsOnlyWhenEveryParticipantHasAnswered) {
  core::Bus bus("memq://");
  ArmWorld world(Puma(), core::Environment{});
  SimNode node(bus, world, core::Environment{}, Lockstep({"a", "b"}));
  Participant a(bus, "a", {0, 0.2, 0, 0, 0, 0});
  Participant b(bus, "b", {0, 0, 0, 0, 0, 0});
  ServiceUntil(node, 200, world);
  EXPECT_EQ(world.tick(), 200);
  // Every tick was published once, in order.
  ASSERT_GE(a.states.size(), 200U);
  for (size_t k = 0; k < 200; ++k) EXPECT_EQ(a.states[k].tick, static_cast<int64_t>(k));
  EXPECT_EQ(node.counters().commands_accepted, 400);
  EXPECT_EQ(node.counters().lockstep_timeouts, 0);
}

TEST(SimNode, ALateParticipantIsNamedAndNeverSkipped) {
  core::Bus bus("memq://");
  ArmWorld world(Puma(), core::Environment{});
  TestClock clock;
  NodeOptions options = Lockstep({"a", "slowpoke"});  // reported after 0.05 s
  options.clock = clock.Clock();
  SimNode node(bus, world, core::Environment{}, options);
  Participant a(bus, "a", {0, 0, 0, 0, 0, 0});
  Participant slow(bus, "slowpoke", {0, 0, 0, 0, 0, 0});
  slow.silent = true;
  // 20 services 12 ms apart (0 to 0.228 s): reported at 0.06, 0.12 and 0.18 s, each time the
  // state sent again.
  for (int k = 0; k < 20; ++k) {
    node.Service(0);
    clock.Advance(0.012);
  }
  EXPECT_EQ(world.tick(), 0) << "stepped without slowpoke's answer";
  EXPECT_EQ(node.counters().lockstep_timeouts, 3);
  EXPECT_NE(node.detail().find("no answer from slowpoke"), std::string::npos) << node.detail();
  EXPECT_EQ(node.detail().find("no answer from a"), std::string::npos);
  // The state was sent again, so a participant that starts late still gets it.
  EXPECT_EQ(a.states.size(), 4U);
  for (const auto& state : a.states) EXPECT_EQ(state.tick, 0);
  slow.silent = false;
  // It answers the next state sent again (at 0.24 s, the next service): the run goes on, one tick
  // per service, with no further report.
  for (int k = 0; k < 11; ++k) {
    node.Service(0);
    clock.Advance(0.012);
  }
  EXPECT_EQ(world.tick(), 10);
  EXPECT_EQ(node.counters().lockstep_timeouts, 4);
}

TEST(SimNode, BadCommandsAreRefusedCountedAndBrakeTheArm) {
  struct Case {
    const char* name;
    std::function<void(sirupp::arm_command_t&)> tamper;
    const char* reason;
  };
  const std::vector<Case> cases = {
      {"nan", [](sirupp::arm_command_t& c) { c.effort[2] = NAN; }, "effort"},
      {"infinity", [](sirupp::arm_command_t& c) { c.effort[0] = INFINITY; }, "effort"},
      {"joint count",
       [](sirupp::arm_command_t& c) {
         c.num_joints = 5;
         c.effort.resize(5);
       },
       "num_joints"},
      {"mode", [](sirupp::arm_command_t& c) { c.mode = 7; }, "mode"},
      {"sender", [](sirupp::arm_command_t& c) { c.sender = "intruder"; }, "not a registered"},
      {"future tick", [](sirupp::arm_command_t& c) { c.tick += 5; }, "ahead of the sim"},
  };
  for (const Case& bad : cases) {
    core::Bus bus("memq://");
    ArmWorld world(Puma(), core::Environment{});
    const std::vector<double> q0 = world.State().position;
    SimNode node(bus, world, core::Environment{}, Lockstep({"a"}));
    Participant a(bus, "a", {1, 1, 1, 1, 1, 1});  // would move the arm a lot
    a.tamper = bad.tamper;
    for (int k = 0; k < 300; ++k) node.Service(0);
    const core::ChannelStats stats = bus.StatsFor("SIM_ARM_COMMAND", core::ChannelSide::kReceiving);
    EXPECT_GT(stats.rejected, 0) << bad.name;
    EXPECT_NE(stats.last_error.find(bad.reason), std::string::npos)
        << bad.name << ": " << stats.last_error;
    EXPECT_GT(node.counters().commands_rejected, 0) << bad.name;
    EXPECT_EQ(node.counters().commands_accepted, 0) << bad.name;
    const core::ArmState state = world.State();
    for (int j = 0; j < 6; ++j) {
      EXPECT_NEAR(state.position[static_cast<size_t>(j)], q0[static_cast<size_t>(j)], 1e-6)
          << bad.name << " moved joint " << j;
    }
    if (std::string(bad.name) != "sender" && std::string(bad.name) != "future tick") {
      // The refused answer counts as hold: the sim went on, braked.
      EXPECT_GT(world.tick(), 0) << bad.name;
      EXPECT_TRUE(state.flags[1] & sirupp::arm_state_t::FLAG_BRAKED) << bad.name;
    }
  }
}

TEST(SimNode, AnswersToTicksAlreadySteppedAreCountedLate) {
  core::Bus bus("memq://");
  ArmWorld world(Puma(), core::Environment{});
  SimNode node(bus, world, core::Environment{}, Lockstep({"a"}));
  Participant a(bus, "a", {0, 0, 0, 0, 0, 0});
  ServiceUntil(node, 5, world);
  sirupp::arm_command_t old{};
  old.tick = 1;
  old.sender = "a";
  old.mode = sirupp::arm_command_t::MODE_EFFORT;
  old.num_joints = 6;
  old.effort.assign(6, 0.0);
  bus.Publish("SIM_ARM_COMMAND", old);
  node.Service(0);
  EXPECT_EQ(node.counters().commands_late, 1);
  EXPECT_EQ(bus.StatsFor("SIM_ARM_COMMAND", core::ChannelSide::kReceiving).late, 1);
}

sirupp::sim_reset_t Reset(std::vector<double> position) {
  sirupp::sim_reset_t reset{};
  reset.sender = "test";
  reset.num_joints = static_cast<int32_t>(position.size());
  reset.position = std::move(position);
  return reset;
}

TEST(SimNode, ResetTeleportsTheArmAndBadResetsAreRefused) {
  core::Bus bus("memq://");
  ArmWorld world(Puma(), core::Environment{});
  SimNode node(bus, world, core::Environment{}, Lockstep({"a"}));
  Participant a(bus, "a", {0.5, 0.5, 0.5, 0.5, 0.5, 0.5});
  ServiceUntil(node, 20, world);
  bus.Publish("SIM_RESET", Reset({0.5, 0.5, 0.5, 0.5, 0.5, 0.5}));
  node.Service(0);
  EXPECT_EQ(node.counters().resets, 1);
  // The teleported state went out, exactly, for the tick it happened at.
  bool seen = false;
  for (const auto& state : a.states) {
    seen = seen || (state.tick == 20 &&
                    state.position == std::vector<double>({0.5, 0.5, 0.5, 0.5, 0.5, 0.5}));
  }
  EXPECT_TRUE(seen);
  const std::vector<double> before = world.State().position;
  bus.Publish("SIM_RESET", Reset({0, 0, 0, 9, 0, 0}));  // wrist roll beyond +-310 degrees
  bus.Publish("SIM_RESET", Reset({0, 0, 0}));
  node.Service(0);
  core::ChannelStats stats = bus.StatsFor("SIM_RESET", core::ChannelSide::kReceiving);
  EXPECT_EQ(stats.rejected, 2);
  EXPECT_EQ(stats.last_error,
            "channel SIM_RESET: num_joints: 3 is not allowed; expected 6 (the model's joints)");
  // Counts, finiteness and flags are core::SimResetFromMessage's, with its one text.
  sirupp::sim_reset_t bad = Reset({0, std::nan(""), 0, 0, 0, 0});
  bus.Publish("SIM_RESET", bad);
  node.Service(0);
  stats = bus.StatsFor("SIM_RESET", core::ChannelSide::kReceiving);
  EXPECT_EQ(stats.last_error,
            "channel SIM_RESET: position[1]: nan is not allowed; expected a finite number");
  bad = Reset({0, 0, 0, 0, 0, 0});
  bad.num_velocities = 3;
  bad.velocity.assign(3, 0.0);
  bus.Publish("SIM_RESET", bad);
  bad = Reset({0, 0, 0, 0, 0, 0});
  bad.reset_objects = 2;
  bus.Publish("SIM_RESET", bad);
  node.Service(0);
  stats = bus.StatsFor("SIM_RESET", core::ChannelSide::kReceiving);
  EXPECT_EQ(stats.rejected, 5);
  EXPECT_EQ(stats.last_error,
            "channel SIM_RESET: reset_objects: 2 is not allowed; expected 0 or 1");
  EXPECT_EQ(node.counters().resets, 1);
}

NodeOptions Realtime(TestClock& clock, std::vector<std::string> participants) {
  NodeOptions options;
  options.mode = TimingMode::kRealtime;
  options.participants = std::move(participants);
  options.watchdog_s = 0.05;
  options.clock = clock.Clock();
  return options;
}

TEST(SimNode, RealtimeNeverRunsAheadOfTheClockAndWaitsForEveryAnswer) {
  core::Bus bus("memq://");
  ArmWorld world(Puma(), core::Environment{});
  TestClock clock;
  clock.sleeping_moves_time = false;
  SimNode node(bus, world, core::Environment{}, Realtime(clock, {"a"}));
  Participant a(bus, "a", {0, 0.2, 0, 0, 0, 0});
  for (int k = 0; k < 200; ++k) node.Service(0);
  EXPECT_EQ(world.tick(), 0) << "the clock has not moved: no tick is due";
  clock.Advance(10 * world.step_s() + 1e-7);
  for (int k = 0; k < 200; ++k) node.Service(0);
  EXPECT_EQ(world.tick(), 10) << "exactly the ticks the clock allows";
  // Every tick stepped with the answer to its own state: accepted = ticks stepped + the one
  // answer to the state now waiting, nothing late, nothing braked.
  EXPECT_EQ(node.counters().commands_accepted, 11);
  EXPECT_EQ(node.counters().commands_late, 0);
  EXPECT_EQ(node.counters().watchdog_holds, 0);
  // A participant that has not answered yet holds the next tick, although it is due.
  a.silent = true;
  clock.Advance(5 * world.step_s());
  for (int k = 0; k < 200; ++k) node.Service(0);
  EXPECT_EQ(world.tick(), 11) << "the answer to tick 10 was in; tick 11's is not";
}

// --pace-ticks N (the class server's rigs): the sim waits until N ticks are due, then steps them
// back to back, each with the answer to its own state; never a tick before the clock reached its
// end, and no tick counted late for the batch's own lag.
TEST(SimNode, RealtimeInBatchesStepsOnlyDueTicksWithTheirAnswers) {
  core::Bus bus("memq://");
  ArmWorld world(Puma(), core::Environment{});
  TestClock clock;
  clock.sleeping_moves_time = false;
  NodeOptions options = Realtime(clock, {"a"});
  options.pace_ticks = 4;
  SimNode node(bus, world, core::Environment{}, options);
  Participant a(bus, "a", {0, 0.2, 0, 0, 0, 0});
  const double step = world.step_s();
  node.Service(0);  // starts the clock
  const auto service = [&node] {
    for (int k = 0; k < 200; ++k) node.Service(0);
  };
  clock.Advance(3.9 * step);
  service();
  EXPECT_EQ(world.tick(), 0) << "three ticks due: the batch waits for the fourth";
  clock.Advance(0.1 * step + 1e-7);
  service();
  EXPECT_EQ(world.tick(), 4) << "four due: all four, at once";
  clock.Advance(2.5 * step);
  service();
  EXPECT_EQ(world.tick(), 4);
  clock.Advance(1.5 * step);
  service();
  EXPECT_EQ(world.tick(), 8);
  // Behind by more than a batch (a hiccup of 10 ticks): every due tick, and the overrun counted.
  clock.Advance(10 * step);
  service();
  EXPECT_EQ(world.tick(), 18);
  EXPECT_GT(node.counters().overruns, 0);
  EXPECT_EQ(node.counters().commands_late, 0);
  EXPECT_EQ(node.counters().watchdog_holds, 0);
  EXPECT_EQ(node.counters().commands_accepted, 19) << "every tick stepped with its own answer";
  // A participant that has not answered holds the batch, although its ticks are due.
  a.silent = true;
  clock.Advance(4 * step);
  service();
  EXPECT_EQ(world.tick(), 19) << "the answer to tick 18 was in; tick 19's is not";
  options.pace_ticks = 65;
  EXPECT_THROW(CheckNodeOptions(options), std::invalid_argument);
}

TEST(SimNode, RealtimeBehindTheClockCatchesUpThenSlipsWhenTooFarBehind) {
  core::Bus bus("memq://");
  ArmWorld world(Puma(), core::Environment{});
  TestClock clock;
  clock.sleeping_moves_time = false;
  SimNode node(bus, world, core::Environment{}, Realtime(clock, {"a"}));
  Participant a(bus, "a", {0, 0, 0, 0, 0, 0});
  node.Service(0);  // starts the clock
  // 50 ms of hiccup: caught up tick by tick.
  clock.Advance(0.05);
  for (int k = 0; k < 2000 && world.tick() < 97; ++k) node.Service(0);
  EXPECT_EQ(world.tick(), 97);
  EXPECT_EQ(node.counters().slipped_s, 0);
  // One second behind: more than the 0.1 s the node catches up; the sim time slips.
  clock.Advance(1.0);
  for (int k = 0; k < 2000; ++k) node.Service(0);
  // It steps the one tick due at once and gives up the rest: 1.05 s on the clock, 98 ticks.
  EXPECT_EQ(world.tick(), 98);
  EXPECT_NEAR(node.counters().slipped_s, 1.05 - 98 * world.step_s(), 1e-9);
  EXPECT_NEAR(node.RealtimeFactor(), 98 * world.step_s() / 1.05, 1e-9);
  EXPECT_NE(node.detail().find("the sim time slips"), std::string::npos) << node.detail();
  EXPECT_EQ(node.counters().commands_late, 0) << "no tick ever stepped without its answer";
}

TEST(SimNode, RealtimeBrakesForASilentParticipantAndTakesItBack) {
  core::Bus bus("memq://");
  ArmWorld world(Puma(), core::Environment{});
  TestClock clock;
  SimNode node(bus, world, core::Environment{}, Realtime(clock, {"a"}));
  Participant a(bus, "a", {0, 0, 0, 0, 0, 0});
  for (int k = 0; k < 100; ++k) node.Service(0);
  const int64_t answered_until = world.tick();
  EXPECT_EQ(answered_until, 100) << "one tick per service: sleeping moves the clock to it";
  a.silent = true;
  // Waits up to the watchdog (50 ms) for the answer, then brakes, paced by the clock.
  for (int k = 0; k < 400; ++k) {
    node.Service(0);
    clock.Advance(0.0005);
  }
  // 100 services (50 ms) waiting for the answer to tick 100, then one braked tick per service.
  EXPECT_EQ(world.tick(), answered_until + 300);
  EXPECT_EQ(node.counters().watchdog_holds, 300);
  EXPECT_TRUE(world.State().flags[1] & sirupp::arm_state_t::FLAG_BRAKED);
  EXPECT_NE(node.detail().find("no answer from 'a'"), std::string::npos) << node.detail();
  // It answers again: from then on every tick waits for it.
  a.silent = false;
  for (int k = 0; k < 200; ++k) node.Service(0);
  const int64_t holds = node.counters().watchdog_holds;
  for (int k = 0; k < 200; ++k) node.Service(0);
  EXPECT_EQ(node.counters().watchdog_holds, holds);
  EXPECT_FALSE(world.State().flags[1] & sirupp::arm_state_t::FLAG_BRAKED);
}

TEST(SimNode, EstopBrakesEveryJointAndEffortsAreIgnoredUntilReleased) {
  core::Bus bus("memq://");
  ArmWorld world(Puma(), core::Environment{});
  TestClock clock;
  SimNode node(bus, world, core::Environment{}, Realtime(clock, {"student"}));
  // A student's process pushing joint 1 hard.
  Participant student(bus, "student", {2.0, 0, 0, 0, 0, 0});
  sirupp::estop_t stop{};
  stop.engaged = 1;
  stop.sender = "test";
  stop.reason = "button";
  bus.Publish("ESTOP", stop);
  for (int k = 0; k < 400; ++k) node.Service(0);
  const double q1 = world.State().position[0];
  for (int k = 0; k < 400; ++k) node.Service(0);
  EXPECT_NEAR(world.State().position[0], q1, 1e-9) << "braked under the e-stop";
  for (int8_t flags : world.State().flags) EXPECT_TRUE(flags & sirupp::arm_state_t::FLAG_BRAKED);
  EXPECT_GT(node.counters().estop_ticks, 0);
  // A malformed e-stop (engaged neither 0 nor 1) is refused with core's text: the brake stays.
  stop.engaged = 2;
  bus.Publish("ESTOP", stop);
  for (int k = 0; k < 400; ++k) node.Service(0);
  EXPECT_EQ(bus.StatsFor("ESTOP", core::ChannelSide::kReceiving).last_error,
            "channel ESTOP: engaged: 2 is not allowed; expected 0 (release) or 1 (engage)");
  EXPECT_NEAR(world.State().position[0], q1, 1e-9) << "still braked";
  stop.engaged = 0;
  bus.Publish("ESTOP", stop);
  for (int k = 0; k < 400; ++k) node.Service(0);
  EXPECT_GT(world.State().position[0], q1 + 1e-4) << "efforts apply again after the release";
}

TEST(SimNode, RefusalsAreNamedPerSenderOnSimStatusAndStayBounded) {
  core::Bus bus("memq://");
  ArmWorld world(Puma(), core::Environment{});
  TestClock clock;
  SimNode node(bus, world, core::Environment{}, Realtime(clock, {"student-cpp"}));
  sirupp::sim_status_t last{};
  int statuses = 0;
  bus.Subscribe<sirupp::sim_status_t>(
      "SIM_STATUS", [&](const sirupp::sim_status_t& status, const core::ReceiveInfo&) {
        last = status;
        ++statuses;
      });
  sirupp::arm_command_t command{};
  command.mode = sirupp::arm_command_t::MODE_EFFORT;
  command.num_joints = 6;
  command.effort.assign(6, 0.0);
  command.sender = "student_cpp";  // misspelled
  for (int k = 0; k < 59; ++k) bus.Publish("SIM_ARM_COMMAND", command);
  // 20 000 distinct senders: counted, but the sim remembers at most 32 of them.
  for (int k = 0; k < 20000; ++k) {
    command.sender = "s" + std::to_string(k);
    command.seq = k;
    bus.Publish("SIM_ARM_COMMAND", command);
  }
  for (int k = 0; k < 50; ++k) {
    node.Service(0);
    clock.Advance(0.05);
  }
  ASSERT_GT(statuses, 0);
  EXPECT_EQ(last.run_id, node.run_id());
  EXPECT_LE(last.num_refused, 32);
  int64_t total = last.refused_others;
  for (int64_t count : last.refused_count) total += count;
  EXPECT_EQ(total, 20059);
  EXPECT_EQ(node.counters().commands_rejected, 20059);
  ASSERT_EQ(last.num_participants, 1);
  EXPECT_EQ(last.participant[0], "student-cpp");
  EXPECT_EQ(last.participant_state[0], sirupp::sim_status_t::PARTICIPANT_NEVER_SEEN);
  // The misspelled name's refusal names the registered participant.
  command.sender = "student_cpp";
  bus.Publish("SIM_ARM_COMMAND", command);
  for (int k = 0; k < 5; ++k) {
    node.Service(0);
    clock.Advance(0.3);
  }
  bool found = false;
  for (int32_t i = 0; i < last.num_refused; ++i) {
    if (last.refused_sender[static_cast<size_t>(i)] == "student_cpp") {
      found = true;
      EXPECT_NE(last.refused_reason[static_cast<size_t>(i)].find(
                    "not a registered participant (student-cpp"),
                std::string::npos)
          << last.refused_reason[static_cast<size_t>(i)];
    }
  }
  EXPECT_TRUE(found);
}

TEST(SimNode, FreerunHoldsTheNewestCommandAndBrakesWhenCommandsStop) {
  core::Bus bus("memq://");
  ArmWorld world(Puma(), core::Environment{});
  TestClock clock;
  NodeOptions options;
  options.mode = TimingMode::kFreeRun;
  options.watchdog_s = 0.02;
  options.idle = core::CommandMode::kLimp;
  clock.sleeping_moves_time = false;
  options.clock = clock.Clock();
  SimNode node(bus, world, core::Environment{}, options);
  // One command, then silence: for 20 ms it is held, then the watchdog brakes.
  sirupp::arm_command_t command{};
  command.sender = "student";
  command.mode = sirupp::arm_command_t::MODE_EFFORT;
  command.num_joints = 6;
  command.effort.assign(6, 0.0);
  bus.Publish("SIM_ARM_COMMAND", command);
  for (int k = 0; k < 300; ++k) {
    node.Service(0);
    clock.Advance(0.0005);
  }
  // The last service is at 299 * 0.5 ms = 149.5 ms: floor(149.5 / 0.512) = 291 ticks due. The
  // services up to 20 ms held the command (floor(20 / 0.512) = 39 ticks); the rest braked.
  EXPECT_EQ(world.tick(), 291);
  EXPECT_EQ(node.counters().watchdog_holds, 291 - 39);
  EXPECT_TRUE(world.State().flags[1] & sirupp::arm_state_t::FLAG_BRAKED);
  EXPECT_NE(node.detail().find("watchdog"), std::string::npos);
}

TEST(SimNode, FastModeRunsFreeAndPublishesModelEnvironmentAndHeartbeat) {
  core::Bus bus("memq://");
  int models = 0, environments = 0, heartbeats = 0;
  bus.Subscribe<sirupp::robot_model_t>(
      "ROBOT_MODEL", [&](const sirupp::robot_model_t& m, const core::ReceiveInfo&) {
        EXPECT_EQ(m.name, "puma260");
        ++models;
      });
  bus.Subscribe<sirupp::environment_t>(
      "ENVIRONMENT",
      [&](const sirupp::environment_t&, const core::ReceiveInfo&) { ++environments; });
  bus.Subscribe<sirupp::heartbeat_t>("HEARTBEAT",
                                     [&](const sirupp::heartbeat_t& h, const core::ReceiveInfo&) {
                                       EXPECT_EQ(h.process, "sirupp-sim");
                                       ++heartbeats;
                                     });
  ArmWorld world(Puma(), core::Environment{});
  const double q1 = world.State().position[1];
  NodeOptions options;
  options.mode = TimingMode::kFast;
  options.idle = core::CommandMode::kLimp;
  options.duration_s = 0.5;
  SimNode node(bus, world, core::Environment{}, options);
  while (node.Service(0)) {
  }
  bus.HandleAvailable();
  EXPECT_NEAR(world.time_s(), 0.5, world.step_s());
  EXPECT_GT(std::abs(world.State().position[1] - q1), 0.01) << "a limp arm falls";
  EXPECT_GE(models, 1);
  EXPECT_GE(environments, 1);
  EXPECT_GE(heartbeats, 1);
}

// The one test on the steady clock (a smoke test): realtime steps, and never ahead of the wall
// clock.
TEST(SimNode, RealtimeOnTheSteadyClockStepsAndNeverRunsAhead) {
  core::Bus bus("memq://");
  ArmWorld world(Puma(), core::Environment{});
  NodeOptions options;
  options.mode = TimingMode::kRealtime;
  options.participants = {"a"};
  SimNode node(bus, world, core::Environment{}, options);
  Participant a(bus, "a", {0, 0, 0, 0, 0, 0});
  const auto start = std::chrono::steady_clock::now();
  for (int k = 0; k < 100000 && world.tick() < 20; ++k) node.Service(1);
  const double elapsed_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_GE(world.tick(), 20);
  EXPECT_LE(static_cast<double>(world.tick()), elapsed_s / world.step_s() + 1);
  EXPECT_EQ(node.counters().commands_late, 0);
}

TEST(SimNode, LockstepRunsAreBitIdentical) {
  auto run = [] {
    core::Bus bus("memq://");
    ArmWorld world(Puma(), core::Environment{});
    SimNode node(bus, world, core::Environment{}, Lockstep({"a", "b"}));
    Participant a(bus, "a", {0.3, 0.5, -0.4, 0.2, 0.3, 0.1});
    Participant b(bus, "b", {0, 0, 0, 0, 0, 0});
    ServiceUntil(node, 1500, world);
    std::vector<double> trace;
    for (const auto& state : a.states) {
      trace.insert(trace.end(), state.position.begin(), state.position.end());
      trace.insert(trace.end(), state.velocity.begin(), state.velocity.end());
      trace.insert(trace.end(), state.effort.begin(), state.effort.end());
    }
    return trace;
  };
  const std::vector<double> first = run();
  const std::vector<double> second = run();
  ASSERT_EQ(first.size(), second.size());
  ASSERT_GE(first.size(), 1500U * 18);
  EXPECT_EQ(std::memcmp(first.data(), second.data(), first.size() * sizeof(double)), 0);
}

// ---- The virtual boards beside the physics

// A participant that drives the sim's boards, as sirupp-control does with --boards sim: answers
// each board status with MODE_BOARDS, switching the servos on with its first answer.
class BoardDriver {
 public:
  BoardDriver(core::Bus& bus, std::string name) : bus_(bus), name_(std::move(name)) {
    bus_.Subscribe<sirupp::board_status_t>(
        "SIM_BOARD_STATUS", [this](const sirupp::board_status_t& status, const core::ReceiveInfo&) {
          statuses.push_back(status);
          if (silent || status.tick == last_answered_) return;
          if (!on_) {
            Command(sirupp::servo_move_t::COMMAND_SERVO_ON, status.arm.position, 0);
            on_ = true;
          }
          last_answered_ = status.tick;
          sirupp::arm_command_t answer{};
          answer.tick = status.tick;
          answer.utime = status.utime;
          answer.seq = answer_seq_++;
          answer.sender = name_;
          answer.mode = sirupp::arm_command_t::MODE_BOARDS;
          answer.num_joints = status.arm.num_joints;
          answer.effort.assign(static_cast<size_t>(answer.num_joints), 0.0);
          bus_.Publish("SIM_ARM_COMMAND", answer);
          ++answers;
        });
  }
  // One board command on SIM_BOARD_COMMAND: every joint active, to `goals`.
  void Command(int8_t command, const std::vector<double>& goals, int64_t move_id) {
    sirupp::servo_move_t move{};
    move.seq = command_seq_++;
    move.move_id = move_id;
    move.command = command;
    move.num_joints = static_cast<int32_t>(goals.size());
    move.goal = goals;
    move.max_velocity.assign(goals.size(), 1.0);
    move.acceleration.assign(goals.size(), 2.0);
    move.flags.assign(goals.size(), sirupp::servo_move_t::FLAG_ACTIVE);
    bus_.Publish("SIM_BOARD_COMMAND", move);
  }
  std::vector<sirupp::board_status_t> statuses;
  int answers = 0;
  bool silent = false;

 private:
  core::Bus& bus_;
  std::string name_;
  bool on_ = false;
  int64_t last_answered_ = -1;
  int64_t answer_seq_ = 0;
  int64_t command_seq_ = 0;
};

TEST(SimNode, TheBoardsDriveTheArmAndTheirDriverAnswersOnlyTheExchangeTicks) {
  core::Bus bus("memq://");
  ArmWorld world(Puma(), core::Environment{});
  // With a per-tick participant beside it (no effort of its own), the sim steps one tick at a
  // time, so the test can send a board command between two exchanges.
  SimNode node(bus, world, core::Environment{}, Lockstep({"ctl", "a"}));
  BoardDriver driver(bus, "ctl");
  Participant a(bus, "a", {0, 0, 0, 0, 0, 0});
  a.tamper = [](sirupp::arm_command_t& command) {
    command.effort.assign(command.effort.size(), 0.0);
  };
  std::vector<sirupp::servo_setpoint_t> setpoints;
  bus.Subscribe<sirupp::servo_setpoint_t>(
      "ARM_SETPOINT", [&](const sirupp::servo_setpoint_t& setpoint, const core::ReceiveInfo&) {
        setpoints.push_back(setpoint);
      });
  ServiceUntil(node, 5, world);
  ASSERT_EQ(world.tick(), 5);
  // A move sent between two exchanges waits for the driver's next answer (tick 16).
  std::vector<double> goals = world.State().position;
  goals[0] += 0.3;
  driver.Command(sirupp::servo_move_t::COMMAND_MOVE, goals, 1);
  ServiceUntil(node, 400, world);
  bus.HandleAvailable();  // what the last tick published
  EXPECT_EQ(driver.answers, 26) << "ticks 0, 16, ..., 400";
  EXPECT_GE(a.states.size(), 400u) << "the per-tick participant saw every state";
  for (const sirupp::board_status_t& status : driver.statuses) EXPECT_EQ(status.tick % 16, 0);
  ASSERT_EQ(setpoints.size(), 400u) << "a set-point every tick, from the sim";
  for (size_t i = 0; i < setpoints.size(); ++i) {
    ASSERT_EQ(setpoints[i].tick, static_cast<int64_t>(i));
    EXPECT_EQ(setpoints[i].move_id, i < 16 ? 0 : 1) << "tick " << i;
    if (i < 16) {
      EXPECT_LT(setpoints[i].goal[0], goals[0] - 0.1) << "tick " << i;
    }
  }
  // (the goal in whole encoder counts)
  EXPECT_NEAR(setpoints[16].goal[0], goals[0], 1e-3) << "the move starts at tick 16";
  EXPECT_GT(setpoints[16].velocity[0], 0);
  EXPECT_EQ(setpoints[15].velocity[0], 0);
  // 0.19 s at 2 rad/s^2: about 0.036 rad.
  EXPECT_GT(world.State().position[0], goals[0] - 0.3 + 0.02) << "the boards moved joint 1";
  EXPECT_EQ(node.counters().board_ticks, 400);
  EXPECT_EQ(node.counters().board_commands, 2);
  EXPECT_EQ(driver.statuses.back().command_seq, 1);
  // A bad board command is refused whole and counted; the boards keep their move.
  sirupp::servo_move_t bad{};
  bad.num_joints = 6;
  bad.goal.assign(6, 0.0);
  bad.max_velocity.assign(6, -1.0);
  bad.acceleration.assign(6, 1.0);
  bad.flags.assign(6, sirupp::servo_move_t::FLAG_ACTIVE);
  bus.Publish("SIM_BOARD_COMMAND", bad);
  ServiceUntil(node, 480, world);
  EXPECT_EQ(bus.StatsFor("SIM_BOARD_COMMAND", core::ChannelSide::kReceiving).rejected, 1);
  EXPECT_EQ(node.counters().board_commands, 2);
  EXPECT_NEAR(setpoints.back().goal[0], goals[0], 1e-3);
}

TEST(SimNode, RealtimeWaitsForTheBoardsDriverAtExchangeTicksAndBrakesWhenItFallsSilent) {
  core::Bus bus("memq://");
  ArmWorld world(Puma(), core::Environment{});
  TestClock clock;
  SimNode node(bus, world, core::Environment{}, Realtime(clock, {"ctl"}));
  BoardDriver driver(bus, "ctl");
  // Once the driver answers, the ticks go out in batches and the sim steps 16 per sleep: the wall
  // clock moves here by a quarter of a tick per service (and a sleep moves it too).
  auto run = [&](int services) {
    for (int k = 0; k < services; ++k) {
      node.Service(0);
      clock.Advance(0.000128);
    }
  };
  run(800);
  EXPECT_GE(world.tick(), 180) << "paced by the wall clock; the driver joined at tick 0";
  EXPECT_EQ(node.counters().watchdog_holds, 0);
  EXPECT_GE(node.counters().board_ticks, 170);
  EXPECT_GT(node.counters().tick_batches, 0);
  driver.silent = true;
  // At the next exchange tick the sim waits up to the watchdog (50 ms), then brakes.
  for (int k = 0; k < 400; ++k) {
    node.Service(0);
    clock.Advance(0.0005);
  }
  EXPECT_GT(node.counters().watchdog_holds, 0);
  EXPECT_TRUE(world.State().flags[1] & sirupp::arm_state_t::FLAG_BRAKED);
  EXPECT_NE(node.detail().find("no answer from 'ctl'"), std::string::npos) << node.detail();
  // It answers again (it is asked at once for the present tick): the boards drive the arm again.
  driver.silent = false;
  run(400);
  const int64_t holds = node.counters().watchdog_holds;
  run(800);
  EXPECT_EQ(node.counters().watchdog_holds, holds);
  EXPECT_FALSE(world.State().flags[1] & sirupp::arm_state_t::FLAG_BRAKED);
}

}  // namespace
}  // namespace sirupp::sim
