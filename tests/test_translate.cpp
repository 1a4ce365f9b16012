#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "core/errors.hpp"
#include "core/model_loader.hpp"
#include "core/translate.hpp"
#include "tests/helpers.hpp"

namespace sirupp::core {
namespace {

using sirupp::testing::ErrorText;

using sirupp::testing::ThroughTheWire;

void ExpectSameModel(const RobotModel& a, const RobotModel& b) {
  EXPECT_EQ(a.name, b.name);
  EXPECT_EQ(a.source_hash, b.source_hash);
  EXPECT_EQ(a.file_angle_unit, b.file_angle_unit);
  EXPECT_EQ(a.dh_convention, b.dh_convention);
  EXPECT_TRUE(a.base.ToIsometry().isApprox(b.base.ToIsometry(), 1e-15));
  ASSERT_EQ(a.joints.size(), b.joints.size());
  for (size_t i = 0; i < a.joints.size(); ++i) {
    const Joint& x = a.joints[i];
    const Joint& y = b.joints[i];
    EXPECT_EQ(x.name, y.name);
    EXPECT_EQ(x.type, y.type);
    EXPECT_EQ(x.dh.d_m, y.dh.d_m);
    EXPECT_EQ(x.dh.alpha_rad, y.dh.alpha_rad);
    EXPECT_EQ(x.position_max, y.position_max);
    EXPECT_EQ(x.friction.coulomb_negative, y.friction.coulomb_negative);
    EXPECT_EQ(x.servo.gear_ratio, y.servo.gear_ratio);
    EXPECT_EQ(x.servo.kd, y.servo.kd);
  }
  ASSERT_EQ(a.links.size(), b.links.size());
  for (size_t i = 0; i < a.links.size(); ++i) {
    EXPECT_EQ(a.links[i].mass_kg, b.links[i].mass_kg);
    EXPECT_EQ(a.links[i].com_m, b.links[i].com_m);
    EXPECT_EQ(a.links[i].inertia_kg_m2, b.links[i].inertia_kg_m2);
    ASSERT_EQ(a.links[i].shapes.size(), b.links[i].shapes.size());
    for (size_t k = 0; k < a.links[i].shapes.size(); ++k) {
      EXPECT_EQ(a.links[i].shapes[k].size_m, b.links[i].shapes[k].size_m);
      EXPECT_EQ(a.links[i].shapes[k].rgba, b.links[i].shapes[k].rgba);
    }
  }
  ASSERT_EQ(a.named_poses.size(), b.named_poses.size());
  EXPECT_EQ(a.named_poses.back().position, b.named_poses.back().position);
}

TEST(Translate, EveryShippedModelSurvivesTheWire) {
  for (const char* file : {"config/robots/puma260.yaml", "config/robots/planar3.yaml",
                           "config/robots/stanford.yaml"}) {
    SCOPED_TRACE(file);
    const RobotModel model = LoadRobotModel(file);
    const sirupp::robot_model_t message = ThroughTheWire(ToMessage(model, 42, 7));
    EXPECT_EQ(message.utime, 42);
    EXPECT_EQ(message.seq, 7);
    EXPECT_EQ(message.num_links, message.num_joints + 1);
    ExpectSameModel(model, RobotModelFromMessage(message, "ROBOT_MODEL"));
  }
}

TEST(Translate, ModelMessageWithBadInertiaIsRefused) {
  sirupp::robot_model_t message = ToMessage(LoadRobotModel("config/robots/puma260.yaml"), 0, 0);
  message.links[3].inertia[0] = 0.066;
  message.links[3].inertia[1] = 0.086;
  message.links[3].inertia[2] = 0.0125;
  message.links[3].inertia[3] = message.links[3].inertia[4] = message.links[3].inertia[5] = 0;
  const std::string error =
      ErrorText<MessageError>([&] { RobotModelFromMessage(message, "RIG1_ROBOT_MODEL"); });
  EXPECT_EQ(
      error.rfind("channel RIG1_ROBOT_MODEL: links[3].shapes: give an inertia that breaks the "
                  "triangle inequality",
                  0),
      0U)
      << error;
}

TEST(Translate, ModelMessageWithWrongCountsIsRefused) {
  sirupp::robot_model_t message = ToMessage(LoadRobotModel("config/robots/planar3.yaml"), 0, 0);
  message.num_links = 2;
  EXPECT_EQ(ErrorText<MessageError>([&] { RobotModelFromMessage(message, "ROBOT_MODEL"); }),
            "channel ROBOT_MODEL: num_links: count 2 does not match the 4 entries sent");
  message = ToMessage(LoadRobotModel("config/robots/planar3.yaml"), 0, 0);
  message.joints[1].position_min = std::nan("");
  EXPECT_EQ(ErrorText<MessageError>([&] { RobotModelFromMessage(message, "ROBOT_MODEL"); }),
            "channel ROBOT_MODEL: joints[1].limits: are not finite; expected two finite numbers, "
            "min < max");
}

TEST(Translate, ArmStateRoundTrip) {
  ArmState state;
  state.utime = 1024;
  state.tick = 2;
  state.source = StateSource::kEmulated;
  state.position = {0.1, -4.0, 7.5};  // unwrapped: beyond +-pi is legal
  state.velocity = {1, 2, 3};
  state.effort = {-0.5, 0, 0.5};
  state.flags = {0, sirupp::arm_state_t::FLAG_STICKING, 0};
  const ArmState back =
      ArmStateFromMessage(ThroughTheWire(ToMessage(state, 9)), "SIM_ARM_STATE", 3);
  EXPECT_EQ(back.utime, 1024);
  EXPECT_EQ(back.tick, 2);
  EXPECT_EQ(back.source, StateSource::kEmulated);
  EXPECT_EQ(back.position, state.position);
  EXPECT_EQ(back.velocity, state.velocity);
  EXPECT_EQ(back.effort, state.effort);
  EXPECT_EQ(back.flags, state.flags);
}

TEST(Translate, ArmStateFillsMissingArraysWithZeros) {
  ArmState state;
  state.position = {1, 2};
  const sirupp::arm_state_t message = ToMessage(state, 0);
  EXPECT_EQ(message.velocity, std::vector<double>({0, 0}));
  EXPECT_EQ(message.flags.size(), 2U);
}

TEST(Translate, BadArmStatesAreRefused) {
  ArmState state;
  state.position = {0, 0};
  sirupp::arm_state_t message = ToMessage(state, 0);
  EXPECT_EQ(ErrorText<MessageError>([&] { ArmStateFromMessage(message, "SIM_ARM_STATE", 6); }),
            "channel SIM_ARM_STATE: num_joints: 2 is not allowed; expected 6 (the model's joints)");
  message.velocity[1] = std::nan("");
  EXPECT_EQ(ErrorText<MessageError>([&] { ArmStateFromMessage(message, "SIM_ARM_STATE", 2); }),
            "channel SIM_ARM_STATE: velocity[1]: nan is not allowed; expected a finite number");
  EXPECT_NO_THROW(ArmStateFromMessage(ToMessage(state, 0), "SIM_ARM_STATE", -1));
}

TEST(Translate, ArmCommandRoundTripAndChecks) {
  ArmCommand command;
  command.tick = 17;
  command.sender = "student-pid";
  command.mode = CommandMode::kHold;
  command.effort = {1.5, -2.5};
  const ArmCommand back =
      ArmCommandFromMessage(ThroughTheWire(ToMessage(command, 3)), "SIM_ARM_COMMAND", 2);
  EXPECT_EQ(back.tick, 17);
  EXPECT_EQ(back.sender, "student-pid");
  EXPECT_EQ(back.mode, CommandMode::kHold);
  EXPECT_EQ(back.effort, command.effort);

  sirupp::arm_command_t message = ToMessage(command, 0);
  message.mode = 9;
  EXPECT_EQ(ErrorText<MessageError>([&] { ArmCommandFromMessage(message, "SIM_ARM_COMMAND", 2); }),
            "channel SIM_ARM_COMMAND: mode: 9 is not allowed; expected 0..3 (MODE_*)");
  message = ToMessage(command, 0);
  message.effort[0] = INFINITY;
  EXPECT_EQ(ErrorText<MessageError>([&] { ArmCommandFromMessage(message, "SIM_ARM_COMMAND", 2); }),
            "channel SIM_ARM_COMMAND: effort[0]: inf is not allowed; expected a finite number");
}

}  // namespace
}  // namespace sirupp::core
