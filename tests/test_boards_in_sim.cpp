// The virtual PIC-SERVO boards beside the physics (sim/sim_node.hpp, control/boards.hpp):
// sirupp-control's logic with ControlOptions::boards_in_sim drives sirupp-sim's logic on one
// in-process memq:// bus. The sim runs profile and PID every tick and publishes every tick's
// set-points; the controller answers only the exchange ticks (MODE_BOARDS) and sends moves as
// board commands. Targets and the paper's movement sets reach their goals as with the boards in
// the controller; lockstep gives the same data run to run and a move starts at an exchange tick;
// a trip faults, brakes and is cleared; an e-stop holds; a per-tick participant beside the boards
// still answers every tick.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <sirupp/arm_command_t.hpp>
#include <sirupp/arm_state_t.hpp>
#include <sirupp/board_status_t.hpp>
#include <sirupp/controller_status_t.hpp>
#include <sirupp/estop_t.hpp>
#include <sirupp/joint_target_t.hpp>
#include <sirupp/plan_command_t.hpp>
#include <sirupp/servo_gains_t.hpp>
#include <sirupp/servo_move_t.hpp>
#include <sirupp/servo_setpoint_t.hpp>
#include <string>
#include <vector>

#include "control/control_node.hpp"
#include "control/plan.hpp"
#include "core/model_loader.hpp"
#include "core/translate.hpp"
#include "servo/chip_gains.hpp"
#include "sim/sim_node.hpp"

namespace sirupp::control {
namespace {

constexpr double kDeg = 3.14159265358979323846 / 180;

sirupp::joint_target_t Target(const std::vector<double>& degrees, std::vector<int8_t> active) {
  sirupp::joint_target_t target{};
  target.num_joints = static_cast<int32_t>(degrees.size());
  for (double d : degrees) target.position.push_back(d * kDeg);
  target.max_velocity.assign(degrees.size(), 0.0);
  target.acceleration.assign(degrees.size(), 0.0);
  target.active = std::move(active);
  return target;
}

sim::NodeOptions SimOptions(std::vector<std::string> participants, int tick_batch) {
  sim::NodeOptions options;  // lockstep
  options.participants = std::move(participants);
  options.tick_batch = tick_batch;
  return options;
}

ControlOptions Options(bool boards_in_sim) {
  ControlOptions options;
  options.boards_in_sim = boards_in_sim;
  return options;
}

// FNV-1a over the bytes of what a run published: the same inputs must give the same bytes.
struct Hash {
  uint64_t value = 1469598103934665603ULL;
  void Add(const void* data, size_t size) {
    const auto* bytes = static_cast<const unsigned char*>(data);
    for (size_t i = 0; i < size; ++i) value = (value ^ bytes[i]) * 1099511628211ULL;
  }
  void Add(const std::vector<double>& values) {
    Add(values.data(), values.size() * sizeof(double));
  }
};

struct Rig {
  explicit Rig(bool boards_in_sim = true,
               std::vector<std::string> participants = {"sirupp-control"}, int tick_batch = 16)
      : sim{bus, world, core::Environment{}, SimOptions(std::move(participants), tick_batch)},
        control{bus, model, Options(boards_in_sim)} {
    bus.Subscribe<sirupp::servo_setpoint_t>(
        "ARM_SETPOINT", [this](const sirupp::servo_setpoint_t& m, const core::ReceiveInfo&) {
          setpoints.push_back(m);
          hash.Add(&m.tick, sizeof m.tick);
          hash.Add(m.position);
          hash.Add(m.effort);
        });
    bus.Subscribe<sirupp::arm_state_t>(
        "SIM_ARM_STATE", [this](const sirupp::arm_state_t& m, const core::ReceiveInfo&) {
          ++states;
          ticks.push_back(m.tick);
          state_hash.Add(m.position);
          state_hash.Add(m.velocity);
          hash.Add(m.position);
          hash.Add(m.velocity);
        });
    bus.Subscribe<sirupp::arm_command_t>(
        "SIM_ARM_COMMAND", [this](const sirupp::arm_command_t& m, const core::ReceiveInfo&) {
          if (m.sender == "sirupp-control") answers.push_back(m);
        });
    bus.Subscribe<sirupp::servo_move_t>(
        "ARM_MOVE",
        [this](const sirupp::servo_move_t& m, const core::ReceiveInfo&) { moves.push_back(m); });
  }
  core::RobotModel model = core::LoadRobotModel("config/robots/puma260.yaml");
  core::Bus bus{"memq://"};
  sim::ArmWorld world{model, core::Environment{}};
  sim::SimNode sim;
  ControlNode control;
  std::vector<sirupp::servo_setpoint_t> setpoints;
  std::vector<sirupp::arm_command_t> answers;
  std::vector<sirupp::servo_move_t> moves;
  int64_t states = 0;
  std::vector<int64_t> ticks;  // of every SIM_ARM_STATE, as the subscription saw them
  Hash hash;                   // states and set-points in the order they came
  Hash state_hash;             // the states alone
  int64_t Sent(const std::string& channel) const {
    return bus.StatsFor(channel, core::ChannelSide::kPublishing).messages;
  }

  void RunFor(double seconds) {
    const double until = world.time_s() + seconds;
    for (int k = 0; k < 10000000 && world.time_s() < until; ++k) {
      sim.Service(0);
      control.Service(0);
    }
  }
  double RunPlan(double limit_s) {
    const double start = world.time_s();
    while (control.plan_running() && world.time_s() - start < limit_s) RunFor(0.01);
    return world.time_s() - start;
  }
  void RunPlanFile(const std::string& path) {
    sirupp::plan_command_t message{};
    message.command = sirupp::plan_command_t::COMMAND_RUN;
    message.name = path;
    message.text = ReadPlanText(path);
    bus.Publish("ARM_PLAN", message);
  }
  double Degrees(int joint) const {
    return world.State().position[static_cast<size_t>(joint)] / kDeg;
  }
};

TEST(BoardsInSim, AJointTargetMovesTheArmWithNoPerTickAnswerFromTheController) {
  Rig rig;
  rig.RunFor(0.01);
  rig.bus.Publish("ARM_TARGET", Target({90, 0, 0, 0, 0, 0}, {1, 0, 0, 0, 0, 0}));
  rig.RunFor(4.5);
  EXPECT_NEAR(rig.Degrees(0), 90.0, 1.0);
  EXPECT_EQ(rig.control.state(), sirupp::controller_status_t::STATE_IDLE)
      << rig.control.last_error();
  ASSERT_EQ(rig.moves.size(), 1u) << "the bridge gets the move on ARM_MOVE as before";
  EXPECT_NEAR(rig.moves[0].goal[0], 90 * kDeg, 1e-12);
  // Every tick's set-points, from the sim; one answer per exchange (16 ticks) from the controller.
  const int64_t ticks = rig.world.tick();
  EXPECT_GE(static_cast<int64_t>(rig.setpoints.size()), ticks - 1);
  EXPECT_LE(static_cast<int64_t>(rig.answers.size()), ticks / 16 + 2);
  EXPECT_GE(static_cast<int64_t>(rig.answers.size()), ticks / 16 - 1);
  for (const sirupp::arm_command_t& answer : rig.answers) {
    EXPECT_EQ(answer.mode, sirupp::arm_command_t::MODE_BOARDS);
    EXPECT_EQ(answer.tick % 16, 0);
  }
  for (size_t i = 1; i < rig.setpoints.size(); ++i) {
    ASSERT_EQ(rig.setpoints[i].tick, rig.setpoints[i - 1].tick + 1) << "a set-point every tick";
  }
  EXPECT_EQ(rig.setpoints.back().move_id, 1);
  EXPECT_EQ(rig.sim.counters().lockstep_timeouts, 0);
  EXPECT_GT(rig.sim.counters().board_ticks, ticks - 32);
}

TEST(BoardsInSim, AMoveStartsAtAnExchangeTickAndLockstepGivesTheSameDataRunToRun) {
  auto run = [](uint64_t* hash, int64_t* first_tick) {
    Rig rig;
    rig.RunFor(0.0105);  // between two exchanges: tick 20
    rig.bus.Publish("ARM_TARGET", Target({30, -20, 0, 0, 0, 0}, {1, 1, 0, 0, 0, 0}));
    rig.RunFor(0.5);
    rig.RunPlanFile("config/plans/set4.plan");
    rig.RunFor(0.01);
    rig.RunPlan(20);
    *hash = rig.hash.value;
    *first_tick = -1;
    for (const sirupp::servo_setpoint_t& setpoint : rig.setpoints) {
      if (setpoint.move_id == 1) {
        *first_tick = setpoint.tick;
        break;
      }
    }
  };
  uint64_t first = 0, second = 0;
  int64_t start_first = 0, start_second = 0;
  run(&first, &start_first);
  run(&second, &start_second);
  EXPECT_EQ(first, second) << "the same inputs give the same states and set-points";
  EXPECT_EQ(start_first, start_second);
  EXPECT_GT(start_first, 0);
  EXPECT_EQ(start_first % 16, 0) << "a target taken between two exchanges starts at the next";
}

// The paper's seven movement sets reach 90 degrees and settle with the boards in the sim, as
// test_control_node checks with them in the controller, and both end within 0.1 degrees of each
// other.
TEST(BoardsInSim, TheSevenMovementSetsEndWhereTheyEndWithTheBoardsInTheController) {
  const std::vector<std::vector<int>> sets = {{0}, {1}, {2}, {0, 1}, {0, 2}, {1, 2}, {0, 1, 2}};
  for (size_t set = 0; set < sets.size(); ++set) {
    const std::string path = "config/plans/set" + std::to_string(set + 1) + ".plan";
    SCOPED_TRACE(path);
    std::vector<double> ends[2];
    double took[2] = {0, 0};
    for (int where = 0; where < 2; ++where) {
      Rig rig(where == 0);
      rig.RunFor(0.01);
      rig.RunPlanFile(path);
      rig.RunFor(0.01);
      ASSERT_TRUE(rig.control.plan_running()) << rig.control.last_error();
      took[where] = rig.RunPlan(20);
      EXPECT_FALSE(rig.control.plan_running());
      EXPECT_EQ(rig.control.last_error(), "");
      for (int j = 0; j < 6; ++j) {
        const bool moved = std::find(sets[set].begin(), sets[set].end(), j) != sets[set].end();
        EXPECT_NEAR(rig.Degrees(j), moved ? 90.0 : 0.0, moved ? 1.0 : 1.5) << "joint " << j + 1;
        ends[where].push_back(rig.Degrees(j));
      }
    }
    for (int j = 0; j < 6; ++j) EXPECT_NEAR(ends[0][j], ends[1][j], 0.1) << "joint " << j + 1;
    EXPECT_NEAR(took[0], took[1], 0.05) << "a plan step waits at most an exchange longer";
  }
}

TEST(BoardsInSim, ATripInTheSimFaultsTheControllerBrakesTheArmAndIsCleared) {
  Rig rig;
  rig.RunFor(0.01);
  // An error limit of 1 count on joint 1: the first move trips it.
  std::vector<servo::ChipGains> gains = servo::ChipGainsFromModel(rig.model);
  gains[0].error_limit = 1;
  rig.bus.Publish("ARM_GAINS", servo::GainsMessage(gains));
  rig.RunFor(0.01);
  rig.bus.Publish("ARM_TARGET", Target({90, 0, 0, 0, 0, 0}, {1, 0, 0, 0, 0, 0}));
  rig.RunFor(0.5);
  ASSERT_NE(rig.control.fault().find("joint j1 tripped its position-error limit"),
            std::string::npos)
      << rig.control.fault();
  EXPECT_EQ(rig.answers.back().mode, sirupp::arm_command_t::MODE_HOLD) << "a trip brakes";
  EXPECT_NE(rig.world.State().flags[0] & sirupp::arm_state_t::FLAG_BRAKED, 0);
  const double held = rig.Degrees(0);
  rig.RunFor(0.2);
  EXPECT_NEAR(rig.Degrees(0), held, 0.01);
  // Gains back, fault cleared: the servos come on where the arm is and the arm moves again.
  rig.bus.Publish("ARM_GAINS", servo::GainsMessage(servo::ChipGainsFromModel(rig.model)));
  sirupp::plan_command_t clear{};
  clear.command = sirupp::plan_command_t::COMMAND_CLEAR_FAULT;
  rig.bus.Publish("ARM_PLAN", clear);
  rig.RunFor(0.05);
  EXPECT_TRUE(rig.control.fault().empty()) << rig.control.fault();
  EXPECT_EQ(rig.control.state(), sirupp::controller_status_t::STATE_IDLE)
      << rig.control.last_error();
  EXPECT_EQ(rig.answers.back().mode, sirupp::arm_command_t::MODE_BOARDS);
  rig.bus.Publish("ARM_TARGET", Target({20, 0, 0, 0, 0, 0}, {1, 0, 0, 0, 0, 0}));
  rig.RunFor(2.0);
  EXPECT_NEAR(rig.Degrees(0), 20.0, 1.0);
}

TEST(BoardsInSim, AnEstopAbortsThePlanAndHoldsTheArmWhereItIs) {
  Rig rig;
  rig.RunFor(0.01);
  rig.RunPlanFile("config/plans/set1.plan");
  rig.RunFor(0.8);
  ASSERT_TRUE(rig.control.plan_running());
  sirupp::estop_t estop{};
  estop.engaged = true;
  estop.sender = "test";
  estop.reason = "hand on the button";
  rig.bus.Publish("ESTOP", estop);
  rig.RunFor(0.3);
  EXPECT_FALSE(rig.control.plan_running());
  const double stopped = rig.Degrees(0);
  rig.RunFor(0.5);
  EXPECT_NEAR(rig.Degrees(0), stopped, 0.05);
  estop.engaged = false;
  rig.bus.Publish("ESTOP", estop);
  rig.RunFor(1.0);
  EXPECT_NEAR(rig.Degrees(0), stopped, 0.5) << "a release starts no motion";
  EXPECT_TRUE(rig.control.fault().empty()) << rig.control.fault();
}

// A disturbance generator answering every state beside the controller that drives the boards:
// the sim waits for it every tick, and for the controller only at the exchange ticks.
TEST(BoardsInSim, APerTickParticipantBesideTheBoardsAnswersEveryTick) {
  Rig rig(true, {"sirupp-control", "disturbance"});
  int64_t answered = 0;
  int64_t last_tick = -1;
  rig.bus.Subscribe<sirupp::arm_state_t>(
      "SIM_ARM_STATE", [&](const sirupp::arm_state_t& state, const core::ReceiveInfo&) {
        if (state.tick == last_tick) return;
        last_tick = state.tick;
        sirupp::arm_command_t push{};
        push.tick = state.tick;
        push.utime = state.utime;
        push.sender = "disturbance";
        push.mode = sirupp::arm_command_t::MODE_EFFORT;
        push.num_joints = state.num_joints;
        push.effort.assign(static_cast<size_t>(state.num_joints), 0.0);
        push.effort[0] = 0.2;  // N*m on joint 1, which the servo works against
        rig.bus.Publish("SIM_ARM_COMMAND", push);
        ++answered;
      });
  rig.RunFor(0.01);
  rig.bus.Publish("ARM_TARGET", Target({45, 0, 0, 0, 0, 0}, {1, 0, 0, 0, 0, 0}));
  rig.RunFor(3.0);
  EXPECT_NEAR(rig.Degrees(0), 45.0, 1.0);
  EXPECT_GE(answered, rig.world.tick() - 1);
  EXPECT_EQ(rig.sim.counters().lockstep_timeouts, 0);
  EXPECT_LE(static_cast<int64_t>(rig.answers.size()), rig.world.tick() / 16 + 2);
  EXPECT_EQ(rig.sim.counters().tick_batches, 0) << "a per-tick participant gets every tick alone";
  EXPECT_EQ(rig.Sent("SIM_ARM_TICKS"), 0);
}

// While the controller only answers the exchanges, the ticks go out 16 at a time on SIM_ARM_TICKS:
// a subscription of SIM_ARM_STATE and ARM_SETPOINT still gets every tick, in order, the same
// states and set-points as when each tick is sent alone, counted on its own channel.
TEST(BoardsInSim, TheTicksGoOutSixteenAtATimeAndEveryReaderStillGetsEachTick) {
  auto run = [](int tick_batch, uint64_t* hash) {
    Rig rig(true, {"sirupp-control"}, tick_batch);
    rig.RunFor(0.01);
    rig.bus.Publish("ARM_TARGET", Target({40, -10, 0, 0, 0, 0}, {1, 1, 0, 0, 0, 0}));
    rig.RunFor(3.0);
    rig.sim.Flush();
    rig.control.Service(0);
    // The two streams each in order (batched, a tick's set-point and state arrive in another
    // interleaving than alone).
    Hash streams;
    for (const sirupp::servo_setpoint_t& m : rig.setpoints) {
      streams.Add(&m.tick, sizeof m.tick);
      streams.Add(m.position);
      streams.Add(m.effort);
    }
    streams.Add(&rig.state_hash.value, sizeof rig.state_hash.value);
    *hash = streams.value;
    const int64_t ticks = rig.world.tick();
    EXPECT_EQ(rig.states, ticks + 1) << "tick 0 and every tick after it";
    for (size_t i = 1; i < rig.ticks.size(); ++i) {
      EXPECT_EQ(rig.ticks[i], rig.ticks[i - 1] + 1) << "at " << i;
      if (rig.ticks[i] != rig.ticks[i - 1] + 1) break;
    }
    for (size_t i = 1; i < rig.setpoints.size(); ++i) {
      ASSERT_EQ(rig.setpoints[i].tick, rig.setpoints[i - 1].tick + 1) << "a set-point every tick";
    }
    EXPECT_EQ(rig.bus.StatsFor("SIM_ARM_STATE").gaps, 0);
    EXPECT_EQ(rig.bus.StatsFor("ARM_SETPOINT").gaps, 0);
    EXPECT_EQ(rig.bus.StatsFor("SIM_ARM_STATE").messages, rig.states);
    if (tick_batch == 1) {
      EXPECT_EQ(rig.Sent("SIM_ARM_TICKS"), 0);
      EXPECT_EQ(rig.Sent("SIM_ARM_STATE"), ticks + 1);
    } else {
      // Alone only until the controller's first MODE_BOARDS answer (the first exchange).
      EXPECT_LE(rig.Sent("SIM_ARM_STATE"), 17);
      EXPECT_LE(rig.Sent("ARM_SETPOINT"), 17);
      EXPECT_GE(rig.Sent("SIM_ARM_TICKS"), ticks / 16 - 1);
      EXPECT_LE(rig.Sent("SIM_ARM_TICKS"), ticks / 16 + 2);
      EXPECT_EQ(rig.sim.counters().tick_batches, rig.Sent("SIM_ARM_TICKS"));
    }
    EXPECT_NEAR(rig.Degrees(0), 40.0, 1.0);
  };
  uint64_t alone = 0, batched = 0;
  run(1, &alone);
  run(16, &batched);
  EXPECT_EQ(alone, batched) << "the same states and set-points either way";
}

// A student's controller never has the boards in the sim: with one, the controller keeps its
// per-tick loop (tested in test_control_node and test_plugin_controller); here, the option alone
// without a law gives board status answers, and `--boards control` the per-tick ones.
TEST(BoardsInSim, WithTheBoardsInTheControllerItAnswersEveryTickAsBefore) {
  Rig rig(false);
  rig.RunFor(0.05);
  EXPECT_GE(static_cast<int64_t>(rig.answers.size()), rig.world.tick() - 1);
  for (const sirupp::arm_command_t& answer : rig.answers) {
    EXPECT_EQ(answer.mode, sirupp::arm_command_t::MODE_EFFORT);
  }
  EXPECT_EQ(rig.sim.counters().board_ticks, 0);
}

}  // namespace
}  // namespace sirupp::control
