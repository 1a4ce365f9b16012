// The virtual PIC-SERVOs (control/servo_bank.hpp) closing the loop around the ODE arm
// (sim/arm_world.hpp) in one thread, tick for tick: the paper's seven movement sets (joints 1, 2
// and 3 from 0 to 90 degrees, alone, in pairs and all three) with the real robot's gains
// (Kp 100, Kd 1000, Ki 0) and the model's default speeds and accelerations.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "control/servo_bank.hpp"
#include "core/model_loader.hpp"
#include "sim/arm_world.hpp"

namespace sirupp::control {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180;

struct SetResult {
  double move_done_s = -1;
  double first_motion_s = -1;  // first joint of the set to move by 0.01 degree
  std::vector<double> final_deg;
  double max_final_speed = 0;
};

SetResult RunSet(const std::vector<int>& joints) {
  const core::RobotModel model = core::LoadRobotModel("config/robots/puma260.yaml");
  sim::ArmWorld world(model, core::Environment{});
  ServoBank bank(model);
  bank.ServoOn(world.State().position);
  std::vector<JointMove> moves(static_cast<size_t>(model.num_joints()));
  for (int j : joints) {
    const core::ServoParams& servo = model.joints[static_cast<size_t>(j)].servo;
    moves[static_cast<size_t>(j)] = {true, 90 * kDeg, servo.default_velocity,
                                     servo.default_acceleration};
  }
  EXPECT_TRUE(bank.Load(moves));
  core::ArmCommand command;
  command.mode = core::CommandMode::kEffort;
  SetResult result;
  for (int k = 0; k < 40000; ++k) {
    command.effort = bank.Tick(world.State().position);
    world.Step(command);
    const core::ArmState state = world.State();
    if (result.first_motion_s < 0 &&
        std::abs(state.position[static_cast<size_t>(joints[0])]) > 0.01 * kDeg) {
      result.first_motion_s = world.time_s();
    }
    if (result.move_done_s < 0 && bank.AllDone()) result.move_done_s = world.time_s();
    if (result.move_done_s > 0 && world.time_s() > result.move_done_s + 2) break;  // settle 2 s
  }
  const core::ArmState state = world.State();
  for (int j = 0; j < model.num_joints(); ++j) {
    result.final_deg.push_back(state.position[static_cast<size_t>(j)] / kDeg);
    result.max_final_speed =
        std::max(result.max_final_speed, std::abs(state.velocity[static_cast<size_t>(j)]));
  }
  return result;
}

TEST(ServoLoop, TheSevenMovementSetsReachNinetyDegreesAndSettle) {
  const std::vector<std::vector<int>> sets = {{0}, {1}, {2}, {0, 1}, {0, 2}, {1, 2}, {0, 1, 2}};
  const char* names[] = {"I", "II", "III", "IV", "V", "VI", "VII"};
  for (size_t s = 0; s < sets.size(); ++s) {
    const SetResult result = RunSet(sets[s]);
    std::printf("set %-3s joints", names[s]);
    for (int j : sets[s]) std::printf(" %d", j + 1);
    std::printf(": profile done %.3f s, first motion %.4f s, final", result.move_done_s,
                result.first_motion_s);
    for (int j = 0; j < 3; ++j) std::printf(" %.3f", result.final_deg[static_cast<size_t>(j)]);
    std::printf(" deg, max speed 2 s later %.1e rad/s\n", result.max_final_speed);
    ASSERT_GT(result.move_done_s, 0) << names[s];
    for (int j = 0; j < 3; ++j) {
      const bool moved = std::find(sets[s].begin(), sets[s].end(), j) != sets[s].end();
      // Moved joints end within 1 degree of 90 (P control against static friction leaves a
      // small error, as on the real arm); the others are disturbed by at most 1.5 degrees.
      EXPECT_NEAR(result.final_deg[static_cast<size_t>(j)], moved ? 90.0 : 0.0, moved ? 1.0 : 1.5)
          << "set " << names[s] << " joint " << j + 1;
    }
    EXPECT_LT(result.max_final_speed, 1e-6) << "set " << names[s] << " has not settled";
  }
}

}  // namespace
}  // namespace sirupp::control
