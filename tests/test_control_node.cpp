// sirupp-control's logic (control/control_node.hpp) driving sirupp-sim's logic in lockstep on one
// in-process memq:// bus: joint targets become moves on ARM_MOVE and reach their goal; bad targets
// are refused and nothing moves.

#include <gtest/gtest.h>

#include <cmath>
#include <sirupp/controller_status_t.hpp>
#include <sirupp/servo_move_t.hpp>
#include <sirupp/servo_setpoint_t.hpp>

#include "control/control_node.hpp"
#include "core/model_loader.hpp"
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

struct Rig {
  core::RobotModel model = core::LoadRobotModel("config/robots/puma260.yaml");
  core::Bus bus{"memq://"};
  sim::ArmWorld world{model, core::Environment{}};
  sim::SimNode sim{bus, world, core::Environment{},
                   sim::NodeOptions{}};  // lockstep, sirupp-control
  ControlNode control{bus, model, ControlOptions{}};

  void RunFor(double seconds) {
    const double until = world.time_s() + seconds;
    for (int k = 0; k < 10000000 && world.time_s() < until; ++k) sim.Service(0);
  }
};

TEST(ControlNode, AJointTargetMovesTheSimulatedArmInLockstep) {
  Rig rig;
  int moves = 0, setpoints = 0, statuses = 0;
  rig.bus.Subscribe<sirupp::servo_move_t>(
      "ARM_MOVE", [&](const sirupp::servo_move_t& move, const core::ReceiveInfo&) {
        EXPECT_EQ(move.command, sirupp::servo_move_t::COMMAND_MOVE);
        EXPECT_NEAR(move.goal[0], 90 * kDeg, 1e-12);
        EXPECT_EQ(move.flags[0], sirupp::servo_move_t::FLAG_ACTIVE);
        EXPECT_EQ(move.flags[1], 0);
        ++moves;
      });
  rig.bus.Subscribe<sirupp::servo_setpoint_t>(
      "ARM_SETPOINT",
      [&](const sirupp::servo_setpoint_t&, const core::ReceiveInfo&) { ++setpoints; });
  rig.bus.Subscribe<sirupp::controller_status_t>(
      "CONTROLLER_STATUS",
      [&](const sirupp::controller_status_t&, const core::ReceiveInfo&) { ++statuses; });
  rig.RunFor(0.01);  // the servos come on with the first state
  rig.bus.Publish("ARM_TARGET", Target({90, 0, 0, 0, 0, 0}, {1, 0, 0, 0, 0, 0}));
  rig.RunFor(4.5);
  EXPECT_EQ(moves, 1);
  EXPECT_GT(setpoints, 8000);
  EXPECT_GT(statuses, 0);
  EXPECT_NEAR(rig.world.State().position[0] / kDeg, 90.0, 1.0);
  EXPECT_TRUE(rig.control.servos().AllDone());
  EXPECT_EQ(rig.sim.counters().lockstep_timeouts, 0);
  EXPECT_EQ(rig.control.states_answered(), rig.world.tick());
}

TEST(ControlNode, BadTargetsAreRefusedAndNothingMoves) {
  // The arm with refused targets must do exactly what it does with none (the servos hold it,
  // sagging slightly under gravity as a P controller does).
  Rig quiet;
  quiet.RunFor(0.01);
  quiet.RunFor(1.0);
  Rig rig;
  rig.RunFor(0.01);
  rig.bus.Publish("ARM_TARGET", Target({0, 0, 0, 400, 0, 0}, {0, 0, 0, 1, 0, 0}));  // beyond 310
  rig.bus.Publish("ARM_TARGET", Target({90, 0, 0}, {1, 1, 1}));                     // 3 joints
  sirupp::joint_target_t nan_target = Target({90, 0, 0, 0, 0, 0}, {1, 0, 0, 0, 0, 0});
  nan_target.position[0] = NAN;
  rig.bus.Publish("ARM_TARGET", nan_target);
  sirupp::joint_target_t negative = Target({10, 0, 0, 0, 0, 0}, {1, 0, 0, 0, 0, 0});
  negative.max_velocity[0] = -1;
  rig.bus.Publish("ARM_TARGET", negative);
  rig.RunFor(1.0);
  const core::ChannelStats stats = rig.bus.StatsFor("ARM_TARGET", core::ChannelSide::kReceiving);
  EXPECT_EQ(stats.rejected, 4);
  EXPECT_NE(stats.last_error.find("max_velocity"), std::string::npos) << stats.last_error;
  EXPECT_EQ(rig.control.move_id(), 0);
  EXPECT_EQ(rig.world.tick(), quiet.world.tick());
  EXPECT_EQ(rig.world.State().position, quiet.world.State().position);
}

}  // namespace
}  // namespace sirupp::control
