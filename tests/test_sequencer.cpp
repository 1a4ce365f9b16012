// The sequencer of sirupp-control (control/sequencer.hpp) without a bus or a sim: states are fed
// by hand from a perfect arm (each state is where the set-points were), commands as plain structs.
// Plan stepping and waits counted in ticks, pause/resume/abort, the e-stop latch and its release,
// refusals and their reasons, mode switches, target limits, faults (trip, student's law, bridge,
// lost and restarted sim) and the order of what it asks to send.

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <stdexcept>

#include "control/sequencer.hpp"
#include "core/errors.hpp"
#include "core/model_loader.hpp"

namespace sirupp::control {
namespace {

constexpr double kDeg = 3.14159265358979323846 / 180;
constexpr int64_t kTickUs = 512;  // puma260.yaml servo_tick_s: 0.000512

// A sequencer and an arm that follows its set-points exactly.
struct Rig {
  core::RobotModel model = core::LoadRobotModel("config/robots/puma260.yaml");
  Sequencer sequencer;
  int64_t tick = 0;
  std::vector<double> q = std::vector<double>(6, 0.0);
  int8_t flags = 0;  // every joint's arm_state_t flags in the next states

  explicit Rig(SequencerOptions options = {}) : sequencer(model, std::move(options)) {}

  core::ArmState State() const {
    core::ArmState state;
    state.tick = tick;
    state.utime = tick * kTickUs;
    state.position = q;
    state.velocity.assign(6, 0.0);
    state.effort.assign(6, 0.0);
    state.flags.assign(6, flags);
    return state;
  }
  // One state in; the arm then stands where the set-points went.
  std::optional<core::ArmCommand> Step() {
    std::optional<core::ArmCommand> command = sequencer.OnState(State());
    ++tick;
    for (int j = 0; j < 6; ++j) q[static_cast<size_t>(j)] = sequencer.servos().SetpointPosition(j);
    return command;
  }
  void Steps(int n) {
    for (int k = 0; k < n; ++k) Step();
  }
  // Steps until the plan has ended; returns the ticks it took (-1 past `limit`).
  int StepUntilPlanEnds(int limit = 200000) {
    for (int k = 1; k <= limit; ++k) {
      Step();
      if (!sequencer.plan_running()) return k;
    }
    return -1;
  }
  void Run(const std::string& text, const std::string& name = "test.plan") {
    sequencer.Plan({"ARM_PLAN", PlanAction::kRun, name, text});
  }
  void Do(PlanAction action) { sequencer.Plan({"ARM_PLAN", action, "", ""}); }
  std::vector<SequencerOutput> Take() { return sequencer.TakeOutputs(); }
};

JointTargetCommand Target(const std::vector<double>& degrees, std::vector<int8_t> active) {
  JointTargetCommand target;
  target.source = "ARM_TARGET";
  for (size_t j = 0; j < degrees.size(); ++j) {
    target.joints.push_back({degrees[j] * kDeg, 0, 0, active[j] != 0});
  }
  return target;
}

JointTargetCommand J1(double degrees) {
  return Target({degrees, 0, 0, 0, 0, 0}, {1, 0, 0, 0, 0, 0});
}

// The refusal's text, or "" when `f` did not throw core::MessageError.
template <class F>
std::string Refusal(F&& f) {
  try {
    f();
  } catch (const core::MessageError& error) {
    return error.what();
  }
  return "";
}

std::vector<MoveOrder> Moves(const std::vector<SequencerOutput>& outputs) {
  std::vector<MoveOrder> moves;
  for (const SequencerOutput& output : outputs) {
    if (const auto* move = std::get_if<MoveOrder>(&output)) moves.push_back(*move);
  }
  return moves;
}

std::vector<StatusReport> Statuses(const std::vector<SequencerOutput>& outputs) {
  std::vector<StatusReport> statuses;
  for (const SequencerOutput& output : outputs) {
    if (const auto* status = std::get_if<StatusReport>(&output)) statuses.push_back(*status);
  }
  return statuses;
}

TEST(Sequencer, OffUntilTheFirstStateThenATargetMovesAndIsDone) {
  Rig rig;
  EXPECT_EQ(rig.sequencer.state(), ControlState::kOff);
  EXPECT_FALSE(rig.sequencer.has_state());
  // A target before any state is kept and loaded with the first one.
  rig.sequencer.Target(J1(10));
  std::vector<SequencerOutput> out = rig.Take();
  ASSERT_EQ(out.size(), 2U);
  const auto& move = std::get<MoveOrder>(out[0]);
  EXPECT_EQ(move.kind, MoveKind::kMove);
  EXPECT_EQ(move.move_id, 1);
  EXPECT_TRUE(move.moves[0].active);
  EXPECT_FALSE(move.moves[1].active);
  EXPECT_DOUBLE_EQ(move.moves[0].goal, 10 * kDeg);
  // 0 = the joint's default speed and acceleration (degrees in the model file).
  EXPECT_NEAR(move.moves[0].velocity, 45 * kDeg, 1e-12);
  EXPECT_NEAR(move.moves[0].acceleration, 90 * kDeg, 1e-12);
  EXPECT_EQ(std::get<StatusReport>(out[1]).move_id, 1);
  const std::optional<core::ArmCommand> command = rig.Step();
  ASSERT_TRUE(command);
  EXPECT_EQ(command->tick, 0);
  EXPECT_EQ(command->sender, "sirupp-control");
  EXPECT_EQ(command->mode, core::CommandMode::kEffort);
  EXPECT_EQ(command->effort.size(), 6U);
  EXPECT_EQ(rig.sequencer.state(), ControlState::kMoving);
  rig.Steps(2000);  // 10 degrees at 45 deg/s, 90 deg/s^2: 0.72 s = 1407 ticks
  EXPECT_EQ(rig.sequencer.state(), ControlState::kIdle);
  EXPECT_NEAR(rig.q[0], 10 * kDeg, 1e-4);
  EXPECT_EQ(rig.sequencer.mode(), ControlMode::kManual);
}

TEST(Sequencer, TheSameTickAgainIsNotAnsweredAfresh) {
  Rig rig;
  ASSERT_TRUE(rig.sequencer.OnState(rig.State()));
  EXPECT_FALSE(rig.sequencer.OnState(rig.State())) << "the caller sends its previous answer";
}

TEST(Sequencer, TargetLimitsAndRefusalsNameTheFieldAndNothingMoves) {
  Rig rig;
  rig.Step();
  rig.Take();
  struct Case {
    JointTargetCommand target;
    const char* expected;
  };
  JointTargetCommand five = Target({0, 0, 0, 0, 0}, {1, 1, 1, 1, 1});
  // Finiteness and signs were core::JointTargetFromMessage's (test_control_node sends them).
  const Case cases[] = {
      // radians: the model's +-145 degrees
      {J1(200), "position[0]: 3.490658503988659 is not allowed; expected within joint 1's limits"},
      {J1(-200), "is not allowed; expected within joint 1's limits [-2.53"},
      {five, "channel ARM_TARGET: num_joints: 5 is not allowed; expected 6 (the model's joints)"},
      {Target({0, 0, 0, 0, 0, 0}, {0, 0, 0, 0, 0, 0}),
       "channel ARM_TARGET: active: no active joint is not allowed; expected at least one"},
  };
  for (const Case& c : cases) {
    const std::string error = Refusal([&] { rig.sequencer.Target(c.target); });
    EXPECT_NE(error.find(c.expected), std::string::npos) << error;
    EXPECT_EQ(rig.sequencer.last_error(), error);
    const std::vector<SequencerOutput> out = rig.Take();
    EXPECT_TRUE(Moves(out).empty());
    ASSERT_EQ(Statuses(out).size(), 1U) << "one status shows the refusal";
    EXPECT_EQ(Statuses(out)[0].last_error, error);
  }
  EXPECT_EQ(rig.sequencer.move_id(), 0);
  // A speed above the joint's maximum is cut to it; an accepted target clears the last error.
  JointTargetCommand fast = J1(10);
  fast.joints[0].max_velocity = 1000;
  rig.sequencer.Target(fast);
  EXPECT_EQ(rig.sequencer.last_error(), "");
  const std::vector<MoveOrder> moves = Moves(rig.Take());
  ASSERT_EQ(moves.size(), 1U);
  EXPECT_DOUBLE_EQ(moves[0].moves[0].velocity, rig.model.joints[0].velocity_max);
}

TEST(Sequencer, AMoveTheBridgeWouldRefuseIsRefusedHere) {
  Rig rig;
  rig.Step();
  JointTargetCommand target = J1(10);
  target.joints[0].acceleration = 1e6;  // far above any motion limit
  const std::string error = Refusal([&] { rig.sequencer.Target(target); });
  EXPECT_NE(error.find("channel ARM_TARGET: joint[0]: "), std::string::npos) << error;
  EXPECT_NE(error.find("(the real arm's bridge refuses it too)"), std::string::npos) << error;
  EXPECT_EQ(rig.sequencer.move_id(), 0);
}

TEST(Sequencer, PoseTargetsNeedAStateAndAJointSolution) {
  // Field by field (finite position, unit quaternion, configuration, speed scale) is
  // core::PoseTargetFromMessage's check; test_control_node sends bad ones through the bus.
  Rig rig;
  PoseTargetCommand pose;
  pose.source = "ARM_POSE_TARGET";
  pose.target.position = {0.254, -0.142, 0.4};
  pose.target.position_only = true;
  EXPECT_NE(Refusal([&] {
              rig.sequencer.PoseTarget(pose);
            }).find("no arm state yet on SIM_ARM_STATE: the IK needs the present joints"),
            std::string::npos);
  rig.Step();
  PoseTargetCommand bad = pose;
  bad.target.position = {5, 0, 0};
  EXPECT_NE(Refusal([&] {
              rig.sequencer.PoseTarget(bad);
            }).find("position/orientation: no joint solution: "),
            std::string::npos);
  EXPECT_EQ(rig.sequencer.move_id(), 0);
  pose.target.speed_scale = 0.5;
  rig.sequencer.PoseTarget(pose);
  const std::vector<MoveOrder> moves = Moves(rig.Take());
  ASSERT_EQ(moves.size(), 1U);
  for (const JointMove& move : moves[0].moves) EXPECT_TRUE(move.active);
  EXPECT_NEAR(moves[0].moves[0].velocity, 0.5 * 45 * kDeg, 1e-12) << "half the default speed";
}

TEST(Sequencer, APlanStepsMovesAndWaitsTickByTick) {
  Rig rig;
  rig.Step();  // tick 0
  rig.Take();
  rig.Run("units deg\nmove j1=5\nwait done\nwait 0.01\nmove j2=-5 j3=5\nwait done\n");
  ASSERT_TRUE(rig.sequencer.plan_running());
  EXPECT_EQ(rig.sequencer.mode(), ControlMode::kAutomatic);
  EXPECT_EQ(rig.sequencer.plan_step(), 0);
  // The first move starts with the next state: all moves of a step in one tick.
  rig.Step();  // tick 1
  std::vector<SequencerOutput> out = rig.Take();
  std::vector<MoveOrder> moves = Moves(out);
  ASSERT_EQ(moves.size(), 1U);
  EXPECT_EQ(moves[0].move_id, 1);
  EXPECT_EQ(moves[0].utime, 1 * kTickUs);
  EXPECT_TRUE(moves[0].moves[0].active);
  EXPECT_FALSE(moves[0].moves[1].active);
  EXPECT_EQ(rig.sequencer.plan_step(), 1) << "at `wait done`";
  EXPECT_EQ(Statuses(out).back().plan_line, 3);
  // `wait done` holds until the servo's move-done bit; then `wait 0.01` starts.
  int ticks = 0;
  while (!rig.sequencer.servos().AllDone() && ticks < 100000) {
    rig.Step();
    ++ticks;
  }
  EXPECT_EQ(rig.sequencer.plan_step(), 1);
  rig.Step();  // move-done seen: the wait starts at this tick's time
  const int64_t wait_start = rig.tick - 1;
  EXPECT_EQ(rig.sequencer.plan_step(), 2);
  EXPECT_EQ(rig.sequencer.state(), ControlState::kWaiting);
  // 0.01 s = 19.53 ticks of 512 us: the 20th tick after the start moves on.
  rig.Steps(19);
  EXPECT_EQ(rig.sequencer.plan_step(), 2);
  rig.Take();
  rig.Step();
  EXPECT_EQ(rig.tick - 1 - wait_start, 20);
  out = rig.Take();
  moves = Moves(out);
  ASSERT_EQ(moves.size(), 1U);
  EXPECT_EQ(moves[0].move_id, 2);
  EXPECT_TRUE(moves[0].moves[1].active && moves[0].moves[2].active);
  EXPECT_EQ(rig.sequencer.plan_step(), 4);
  const int to_end = rig.StepUntilPlanEnds();
  ASSERT_GT(to_end, 0);
  EXPECT_TRUE(rig.sequencer.servos().AllDone()) << "the plan ends when its last move is done";
  EXPECT_EQ(rig.sequencer.plan_step(), 5);
  EXPECT_EQ(rig.sequencer.mode(), ControlMode::kManual);
  EXPECT_EQ(rig.sequencer.state(), ControlState::kIdle);
  EXPECT_EQ(rig.sequencer.last_error(), "");
  const StatusReport last = Statuses(rig.Take()).back();
  EXPECT_EQ(last.plan_name, "test.plan");
  EXPECT_EQ(last.plan_step, 5);
  EXPECT_EQ(last.plan_steps, 5);
  EXPECT_EQ(last.plan_line, 0);
  EXPECT_NEAR(rig.q[1], -5 * kDeg, 1e-4);
}

TEST(Sequencer, PauseStopsAtTheNextStepAndResumeMovesAWaitOnByThePause) {
  Rig rig;
  rig.Step();
  rig.Run("wait 0.01\nmove j1=1\nwait done\n");
  rig.Step();  // the wait starts at tick 1: it ends at 1 * 512 + 10000 us, tick 21
  rig.Steps(5);
  rig.Do(PlanAction::kPause);
  EXPECT_EQ(rig.sequencer.state(), ControlState::kPaused);
  EXPECT_NE(Refusal([&] {
              rig.Do(PlanAction::kPause);
            }).find("channel ARM_PLAN: command: pause: no plan is running (it is paused already)"),
            std::string::npos);
  rig.Steps(100);  // paused after tick 6's state, for 100 ticks
  EXPECT_EQ(rig.sequencer.plan_step(), 0);
  EXPECT_EQ(rig.sequencer.move_id(), 0);
  rig.Do(PlanAction::kResume);
  EXPECT_NE(Refusal([&] { rig.Do(PlanAction::kResume); }).find("resume: no plan is paused"),
            std::string::npos);
  // The wait had 15 ticks to go when it was paused: it ends at tick 21 + 100.
  rig.Take();
  while (rig.sequencer.move_id() == 0 && rig.tick < 1000) rig.Step();
  EXPECT_EQ(rig.tick - 1, 121);
  // Pausing during a move lets the move finish; the plan waits at the next step.
  rig.Do(PlanAction::kPause);
  rig.Steps(3000);
  EXPECT_TRUE(rig.sequencer.servos().AllDone());
  EXPECT_TRUE(rig.sequencer.plan_running());
  EXPECT_EQ(rig.sequencer.plan_step(), 2);
  rig.Do(PlanAction::kResume);
  EXPECT_EQ(rig.StepUntilPlanEnds(), 1);
}

TEST(Sequencer, AbortStopsSmoothlyEndsThePlanAndTargetsAreTakenAgain) {
  Rig rig;
  rig.Step();
  rig.Run("move j1=30\nwait done\nmove j1=0\n", "slow.plan");
  rig.Steps(100);
  const std::string busy = Refusal([&] { rig.sequencer.Target(J1(5)); });
  EXPECT_NE(busy.find("channel ARM_TARGET: plan slow.plan is running (step 2 of 3); targets are "
                      "taken in manual mode only: abort the plan first (sirupp plan abort)"),
            std::string::npos)
      << busy;
  const std::string again = Refusal([&] { rig.Run("wait 1\n", "other.plan"); });
  EXPECT_NE(again.find("run other.plan: plan slow.plan is still running"), std::string::npos)
      << again;
  rig.Take();
  rig.Do(PlanAction::kAbort);
  const std::vector<SequencerOutput> out = rig.Take();
  const std::vector<MoveOrder> moves = Moves(out);
  ASSERT_EQ(moves.size(), 1U);
  EXPECT_EQ(moves[0].kind, MoveKind::kStopSmooth);
  EXPECT_EQ(moves[0].move_id, 1) << "a stop is no new move";
  for (int j = 0; j < 6; ++j) {
    EXPECT_DOUBLE_EQ(moves[0].moves[static_cast<size_t>(j)].goal,
                     rig.sequencer.servos().SetpointPosition(j));
  }
  EXPECT_FALSE(rig.sequencer.plan_running());
  EXPECT_EQ(rig.sequencer.mode(), ControlMode::kManual);
  EXPECT_EQ(rig.sequencer.last_error(), again) << "an abort asked for adds no error";
  const double stopped_from = rig.q[0];
  rig.Steps(2000);
  EXPECT_EQ(rig.sequencer.state(), ControlState::kIdle);
  EXPECT_GT(rig.q[0], stopped_from) << "decelerated, not held";
  EXPECT_LT(rig.q[0], 30 * kDeg);
  rig.sequencer.Target(J1(0));
  EXPECT_EQ(rig.sequencer.move_id(), 2);
}

TEST(Sequencer, TheEstopLatchesHoldsAndRefusesUntilReleased) {
  Rig rig;
  rig.Step();
  rig.Run("move j1=30\nwait done\n", "long.plan");
  rig.Steps(300);
  rig.Take();
  rig.sequencer.Estop({true, "panel", "button"});
  const std::vector<SequencerOutput> out = rig.Take();
  const std::vector<MoveOrder> moves = Moves(out);
  ASSERT_EQ(moves.size(), 1U);
  EXPECT_EQ(moves[0].kind, MoveKind::kStopAbrupt);
  EXPECT_FALSE(rig.sequencer.plan_running());
  const std::string cause = "emergency stop from 'panel': button";
  EXPECT_EQ(rig.sequencer.estop(), cause);
  EXPECT_EQ(rig.sequencer.last_error(), cause + "; plan long.plan aborted");
  // Held where it is: the servos' command position is the last measured position.
  const double held = rig.sequencer.servos().SetpointPosition(0);
  EXPECT_NEAR(held, rig.State().position[0], 1e-3);
  rig.Steps(500);
  EXPECT_NEAR(rig.q[0], held, 1e-9);
  EXPECT_NE(Refusal([&] { rig.sequencer.Target(J1(5)); })
                .find("channel ARM_TARGET: target: " + cause +
                      " is engaged; release it first (sirupp estop --release)"),
            std::string::npos);
  EXPECT_NE(Refusal([&] { rig.Run("wait 1\n", "next.plan"); }).find("run next.plan: " + cause),
            std::string::npos);
  EXPECT_EQ(rig.sequencer.move_id(), 1);
  rig.Take();
  // A release when none is engaged changes nothing.
  rig.sequencer.Estop({false, "panel", ""});
  EXPECT_EQ(rig.sequencer.estop(), "");
  EXPECT_EQ(rig.sequencer.last_error(), "");
  EXPECT_EQ(Statuses(rig.Take()).size(), 1U);
  rig.sequencer.Estop({false, "panel", ""});
  EXPECT_TRUE(rig.Take().empty());
  rig.sequencer.Target(J1(5));
  EXPECT_EQ(rig.sequencer.move_id(), 2);
}

TEST(Sequencer, AutomaticModeLocksOutTargetsUntilManualAndManualEndsAPlan) {
  Rig rig;
  rig.Step();
  rig.Do(PlanAction::kAutomatic);
  EXPECT_EQ(rig.sequencer.mode(), ControlMode::kAutomatic);
  EXPECT_NE(Refusal([&] { rig.sequencer.Target(J1(5)); })
                .find("the controller is locked in automatic mode; targets are taken in manual "
                      "mode only (sirupp plan manual)"),
            std::string::npos);
  rig.Run("move j1=20\nwait done\n");
  rig.Steps(50);
  rig.Take();
  rig.Do(PlanAction::kManual);
  EXPECT_EQ(Moves(rig.Take()).at(0).kind, MoveKind::kStopSmooth);
  EXPECT_FALSE(rig.sequencer.plan_running());
  EXPECT_EQ(rig.sequencer.mode(), ControlMode::kManual);
  rig.sequencer.Target(J1(5));
  EXPECT_EQ(rig.sequencer.move_id(), 2);
}

TEST(Sequencer, APlanIsRefusedBeforeTheFirstStateAndABadPlanWhole) {
  Rig rig;
  EXPECT_NE(Refusal([&] {
              rig.Run("wait 1\n");
            }).find("run test.plan: no arm state yet on SIM_ARM_STATE (is sirupp-sim running?)"),
            std::string::npos);
  rig.Step();
  const std::string error = Refusal([&] { rig.Run("move j1=10\nmove j2=900\n", "bad.plan"); });
  EXPECT_NE(error.find("channel ARM_PLAN: text: bad.plan:2:"), std::string::npos) << error;
  EXPECT_FALSE(rig.sequencer.plan_running());
  EXPECT_EQ(rig.sequencer.plan(), nullptr);
  rig.Step();
  EXPECT_EQ(rig.sequencer.move_id(), 0) << "not even the first, good, line ran";
}

TEST(Sequencer, ATripFaultsHoldsTheArmAndClearFaultTakesItWhereItIs) {
  Rig rig;
  rig.Step();
  rig.Run("move j1=30\nwait done\n", "trip.plan");
  rig.Steps(10);
  rig.q[0] += 1.0;  // the arm is knocked a radian away: far beyond 4000 counts
  std::optional<core::ArmCommand> command = rig.Step();
  ASSERT_TRUE(command);
  EXPECT_EQ(rig.sequencer.state(), ControlState::kFault);
  EXPECT_NE(rig.sequencer.fault().find("joint j1 tripped its position-error limit (4000 counts) "
                                       "at tick 11: the arm is braked"),
            std::string::npos)
      << rig.sequencer.fault();
  EXPECT_NE(rig.sequencer.last_error().find("; plan trip.plan aborted"), std::string::npos);
  EXPECT_FALSE(rig.sequencer.plan_running());
  command = rig.Step();
  EXPECT_EQ(command->mode, core::CommandMode::kHold);
  EXPECT_EQ(command->effort, std::vector<double>(6, 0.0));
  EXPECT_NE(Refusal([&] {
              rig.sequencer.Target(J1(5));
            }).find("target: the controller is faulted: joint j1 tripped"),
            std::string::npos);
  EXPECT_NE(Refusal([&] { rig.Do(PlanAction::kResume); }).find("resume: the controller is faulted"),
            std::string::npos);
  // A later cause is a consequence: the first is kept.
  rig.sequencer.Fault("something else");
  EXPECT_NE(rig.sequencer.fault().find("joint j1 tripped"), std::string::npos);
  rig.Do(PlanAction::kClearFault);
  EXPECT_EQ(rig.sequencer.fault(), "");
  EXPECT_EQ(rig.sequencer.last_error(), "");
  command = rig.Step();
  EXPECT_EQ(command->mode, core::CommandMode::kEffort);
  EXPECT_EQ(rig.sequencer.state(), ControlState::kIdle);
  EXPECT_NEAR(rig.sequencer.servos().SetpointPosition(0), rig.q[0], 1e-3) << "held where it is";
}

TEST(Sequencer, AStateTheSimBrakesRepeatsTheLastEffortsAndHoldsTheProfiles) {
  Rig rig;
  rig.Step();
  rig.sequencer.Target(J1(20));
  rig.Steps(100);
  const std::optional<core::ArmCommand> before = rig.Step();
  const double setpoint = rig.sequencer.servos().SetpointPosition(0);
  rig.flags = kFlagBraked;
  for (int k = 0; k < 500; ++k) {
    const std::optional<core::ArmCommand> braked = rig.Step();
    ASSERT_TRUE(braked);
    EXPECT_EQ(braked->effort, before->effort);
  }
  EXPECT_DOUBLE_EQ(rig.sequencer.servos().SetpointPosition(0), setpoint) << "the profile waited";
  EXPECT_NE(rig.sequencer.state(), ControlState::kFault);
  rig.flags = 0;
  rig.Steps(3000);
  EXPECT_EQ(rig.sequencer.state(), ControlState::kIdle);
  EXPECT_NEAR(rig.q[0], 20 * kDeg, 1e-4);
}

TEST(Sequencer, ALostSimStopsTheRealArmAndRefusesMovesUntilStatesComeAgain) {
  Rig rig;
  rig.sequencer.SimLost(0.5);
  EXPECT_FALSE(rig.sequencer.sim_lost()) << "no state yet: nothing to lose";
  rig.Step();
  rig.Run("move j1=30\nwait done\n", "lost.plan");
  rig.Steps(20);
  rig.Take();
  rig.sequencer.SimLost(0.5);
  EXPECT_TRUE(rig.sequencer.sim_lost());
  EXPECT_EQ(rig.sequencer.state(), ControlState::kFault);
  EXPECT_EQ(Moves(rig.Take()).at(0).kind, MoveKind::kStopSmooth);
  EXPECT_EQ(rig.sequencer.last_error(),
            "no state from sirupp-sim on SIM_ARM_STATE for 0.5 s: the sim is lost (stopped, "
            "crashed or stalled); plan lost.plan aborted");
  EXPECT_NE(Refusal([&] {
              rig.sequencer.Target(J1(5));
            }).find("target: no state from sirupp-sim on SIM_ARM_STATE (is it running?)"),
            std::string::npos);
  rig.Step();
  EXPECT_FALSE(rig.sequencer.sim_lost());
  rig.sequencer.Target(J1(5));
  EXPECT_EQ(rig.sequencer.last_error(), "");
}

TEST(Sequencer, ARestartedSimAbortsThePlanAndTakesTheNewArm) {
  Rig rig;
  rig.Step();
  rig.Run("move j1=30\nwait done\n", "restart.plan");
  rig.Steps(200);
  rig.Take();
  rig.tick = 0;
  rig.q = {0.1, 0.2, 0.3, 0, 0, 0};
  ASSERT_TRUE(rig.Step());
  const std::vector<SequencerOutput> out = rig.Take();
  EXPECT_EQ(Moves(out).at(0).kind, MoveKind::kStopSmooth);
  EXPECT_FALSE(rig.sequencer.plan_running());
  EXPECT_NE(rig.sequencer.last_error().find("sirupp-sim restarted (its tick went from 200 back to "
                                            "0): the arm is taken where the new sim has it; plan "
                                            "restart.plan aborted"),
            std::string::npos)
      << rig.sequencer.last_error();
  EXPECT_NEAR(rig.sequencer.servos().SetpointPosition(2), 0.3, 1e-3);
}

TEST(Sequencer, TheBridgeRefusingAMoveStopsTheVirtualArm) {
  Rig rig;
  rig.Step();
  rig.sequencer.Target(J1(30));
  rig.Steps(50);
  rig.Take();
  rig.sequencer.MoveRefused("joint 1 speed too high");
  EXPECT_EQ(Moves(rig.Take()).at(0).kind, MoveKind::kStopSmooth);
  EXPECT_EQ(rig.sequencer.last_error(), "sirupp-hardware refused move 1 (joint 1 speed too high)");
  rig.Steps(3000);
  EXPECT_LT(rig.q[0], 20 * kDeg);
}

// A student's law that throws on its `fail_at`th call, or returns NaN.
class FakeLaw : public EffortLaw {
 public:
  const std::string& name() const override { return name_; }
  void Reset(const ControlInput&) override { ++resets; }
  void Update(const ControlInput& input, std::vector<double>& effort) override {
    ++calls;
    last_goal = input.goal.at(0);
    if (calls == fail_at) throw std::runtime_error("boom");
    effort.assign(6, nan ? std::numeric_limits<double>::quiet_NaN() : 100.0);
  }
  int resets = 0;
  int calls = 0;
  int fail_at = -1;
  bool nan = false;
  double last_goal = 0;

 private:
  std::string name_ = "fake";
};

TEST(Sequencer, AStudentsLawGivesTheEffortsClampedAndItsFailureIsAFault) {
  auto law = std::make_shared<FakeLaw>();
  SequencerOptions options;
  options.effort_law = law;
  Rig rig(options);
  rig.sequencer.Target(J1(10));
  std::optional<core::ArmCommand> command = rig.Step();
  EXPECT_EQ(law->resets, 1);
  EXPECT_NEAR(law->last_goal, 10 * kDeg, 1e-4) << "the law sees the move's goal (in counts)";
  EXPECT_DOUBLE_EQ(command->effort[0], rig.model.joints[0].effort_max) << "clamped";
  law->fail_at = law->calls + 2;
  rig.Step();
  command = rig.Step();
  EXPECT_EQ(command->mode, core::CommandMode::kHold);
  EXPECT_EQ(rig.sequencer.state(), ControlState::kFault);
  EXPECT_EQ(rig.sequencer.fault(), "controller 'fake' at tick 2: boom");
  const int calls = law->calls;
  rig.Steps(10);
  EXPECT_EQ(law->calls, calls) << "not asked again until clear-fault";
  rig.Do(PlanAction::kClearFault);
  law->nan = true;
  command = rig.Step();
  EXPECT_EQ(law->resets, 2) << "clear-fault starts the law afresh";
  EXPECT_EQ(command->mode, core::CommandMode::kHold);
  EXPECT_NE(rig.sequencer.fault().find("returned effort nan for joint 1 (allowed: finite values)"),
            std::string::npos)
      << rig.sequencer.fault();
}

TEST(Sequencer, GainsChangeTheServosAndLogWhatChanged) {
  Rig rig;
  std::vector<ServoGains> gains;
  for (int j = 0; j < 6; ++j) gains.push_back(rig.sequencer.servos().Gains(j));
  gains[1].kp = 321;
  rig.sequencer.SetGains(gains);
  EXPECT_EQ(rig.sequencer.servos().Gains(1).kp, 321);
  const std::vector<SequencerOutput> out = rig.Take();
  ASSERT_EQ(out.size(), 2U);
  EXPECT_NE(std::get<LogNote>(out[0]).text.find("new gains: j2 Kp 321"), std::string::npos);
  EXPECT_EQ(std::get<StatusReport>(out[1]).state, ControlState::kOff);
}

}  // namespace
}  // namespace sirupp::control
