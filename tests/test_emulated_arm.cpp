// The emulated arm behind the modules (hardware/emulated_arm.hpp): the servo holds the PUMA 260
// against gravity, a motor switched off lets the shoulder fall, stiction holds a joint below its
// break-away effort, hard stops and limit switches, encoder counts and the index.

#include <gtest/gtest.h>

#include <cmath>

#include "core/dynamics.hpp"
#include "core/model_loader.hpp"
#include "hardware/emulated_arm.hpp"
#include "servo/servo_units.hpp"

namespace sirupp::hardware {
namespace {

constexpr double kDeg = 3.14159265358979323846 / 180;

const core::RobotModel& Puma() {
  static const core::RobotModel model = core::LoadRobotModel("config/robots/puma260.yaml");
  return model;
}

// Servos with the model's gains on every joint of `arm`, switched on where the arm is.
std::vector<servo::PicServo> Servos(const EmulatedArm& arm) {
  std::vector<servo::PicServo> servos(static_cast<size_t>(arm.num_joints()));
  for (int j = 0; j < arm.num_joints(); ++j) {
    servos[static_cast<size_t>(j)].SetGains(
        servo::GainsFromModel(Puma().joints[static_cast<size_t>(j)].servo));
    servos[static_cast<size_t>(j)].ServoOn(arm.Inputs(j).encoder_counts);
  }
  return servos;
}

void RunServoed(EmulatedArm& arm, std::vector<servo::PicServo>& servos, double seconds) {
  const int ticks = static_cast<int>(seconds / arm.tick_s());
  std::vector<int> pwm(servos.size());
  for (int t = 0; t < ticks; ++t) {
    for (size_t j = 0; j < servos.size(); ++j) {
      pwm[j] = servos[j].Tick(arm.Inputs(static_cast<int>(j)).encoder_counts);
    }
    arm.Step(pwm);
  }
}

TEST(EmulatedArm, TheServoHoldsTheArmAgainstGravity) {
  {
    ArmOptions sim_like;
    sim_like.friction_scale = 1.0;
    EmulatedArm arm(Puma(), sim_like);
    std::vector<servo::PicServo> servos = Servos(arm);
    RunServoed(arm, servos, 2.0);
    std::printf("shoulder sag under the servo, friction x1: %.4f deg\n", arm.positions()[1] / kDeg);
  }
  EmulatedArm arm(Puma(), ArmOptions{});
  std::vector<servo::PicServo> servos = Servos(arm);
  RunServoed(arm, servos, 2.0);
  // The shoulder carries the most: Kp alone (no integral) leaves a sag of G / Kp = 5.96 N*m /
  // 358 N*m/rad = 0.95 deg, give or take the friction band 1.8 / 358 rad = 0.29 deg.
  const double gravity = core::GravityEffort(Puma(), Eigen::VectorXd::Zero(6))[1];
  ASSERT_GT(std::abs(gravity), 3.0) << "the zero pose loads the shoulder";
  for (int j = 0; j < 6; ++j) {
    EXPECT_LT(std::abs(arm.positions()[static_cast<size_t>(j)]), 1.5 * kDeg) << "joint " << j + 1;
    EXPECT_TRUE(servos[static_cast<size_t>(j)].servo_on()) << "joint " << j + 1;
  }
  // The servo's effort balances gravity, less what friction takes (1.5 x static 1.2 N*m).
  EXPECT_NEAR(arm.motor_effort()[1], gravity, 1.5 * 1.2 + 0.1);
  std::printf("shoulder sag under the servo: %.4f deg, motor %.3f N*m vs gravity %.3f N*m\n",
              arm.positions()[1] / kDeg, arm.motor_effort()[1], gravity);
}

TEST(EmulatedArm, AMotorOffLetsTheShoulderFall) {
  EmulatedArm arm(Puma(), ArmOptions{});
  const double gravity = core::GravityEffort(Puma(), Eigen::VectorXd::Zero(6))[1];
  for (int t = 0; t < 2000; ++t) arm.Step({});
  // It falls the way gravity pushes it, and far.
  EXPECT_GT(-gravity * arm.positions()[1], 30 * kDeg * std::abs(gravity));
  std::printf("limp shoulder after %.3f s: %.1f deg\n", arm.time_s(), arm.positions()[1] / kDeg);
}

// Efforts that hold every joint against gravity at the zero pose, plus `waist` on joint 1.
std::vector<double> Holding(double waist) {
  const Eigen::VectorXd g = core::GravityEffort(Puma(), Eigen::VectorXd::Zero(6));
  std::vector<double> effort;
  for (Eigen::Index j = 0; j < g.size(); ++j) effort.push_back(g[j]);
  effort.front() += waist;
  return effort;
}

TEST(EmulatedArm, StictionHoldsAJointBelowItsBreakAwayEffort) {
  // The waist axis is vertical: no gravity on it; the other joints are held against gravity (else
  // their fall would turn the waist). Static 0.9 N*m, times 1.5 by default.
  for (const double scale : {1.0, 1.5}) {
    ArmOptions options;
    options.friction_scale = scale;
    EmulatedArm below(Puma(), options);
    below.SetExternalEffort(Holding(0.97 * 0.9 * scale));
    for (int t = 0; t < 2000; ++t) below.Step({});
    EXPECT_EQ(below.positions()[0], 0.0) << "scale " << scale;
    EXPECT_TRUE(below.sticking(0));
    EmulatedArm above(Puma(), options);
    above.SetExternalEffort(Holding(1.03 * 0.9 * scale));
    for (int t = 0; t < 2000; ++t) above.Step({});
    EXPECT_GT(above.positions()[0], 0.001) << "scale " << scale;
  }
  // 1.2 N*m moves the sim's friction (static 0.9) but not the emulator's default (1.35).
  EmulatedArm arm(Puma(), ArmOptions{});
  arm.SetExternalEffort(Holding(1.2));
  for (int t = 0; t < 2000; ++t) arm.Step({});
  EXPECT_EQ(arm.positions()[0], 0.0);
}

TEST(EmulatedArm, ASlidingJointStopsAndSticksWhenThePushEnds) {
  EmulatedArm arm(Puma(), ArmOptions{});
  arm.SetExternalEffort({3.0});
  for (int t = 0; t < 1000; ++t) arm.Step({});
  EXPECT_GT(arm.velocities()[0], 0.1);
  arm.SetExternalEffort({});
  for (int t = 0; t < 2000; ++t) arm.Step({});
  EXPECT_EQ(arm.velocities()[0], 0.0);
  EXPECT_TRUE(arm.sticking(0));
  const double rest = arm.positions()[0];
  for (int t = 0; t < 1000; ++t) arm.Step({});
  EXPECT_EQ(arm.positions()[0], rest) << "no creep";
}

TEST(EmulatedArm, HardStopsAndLimitSwitches) {
  EmulatedArm arm(Puma(), ArmOptions{});
  arm.SetExternalEffort({10.0});  // waist, positive: towards +145 deg
  const double max = Puma().joints[0].position_max;
  for (int t = 0; t < 20000 && arm.positions()[0] < max; ++t) arm.Step({});
  for (int t = 0; t < 100; ++t) arm.Step({});
  EXPECT_DOUBLE_EQ(arm.positions()[0], max);
  EXPECT_EQ(arm.velocities()[0], 0.0);
  // The waist's gear is negative: counts run down as the joint runs up, so the upper end is the
  // reverse end, LIMIT2.
  EXPECT_TRUE(arm.Inputs(0).limit2);
  EXPECT_FALSE(arm.Inputs(0).limit1);
  EXPECT_FALSE(arm.Inputs(1).limit1 || arm.Inputs(1).limit2);
}

TEST(EmulatedArm, EncoderCountsStartAtZeroAndTheIndexComesOncePerMotorTurn) {
  ArmOptions options;
  options.start_positions = {10 * kDeg, 0, 0, 0, 0, 0};
  EmulatedArm arm(Puma(), options);
  EXPECT_EQ(arm.Inputs(0).encoder_counts, 0) << "the counter reads 0 at power-up";
  const servo::JointDrive drive(Puma().joints[0], Puma().servo_tick_s);
  arm.SetExternalEffort({2.5});
  int crossings = 0;
  for (int t = 0; t < 4000; ++t) {
    arm.Step({});
    const MotorInputs in = arm.Inputs(0);
    if (in.index_crossed) {
      ++crossings;
      // Edges sit on whole motor turns of the absolute count.
      EXPECT_EQ((in.index_edge_counts + drive.ToCounts(10 * kDeg)) % 1000, 0);
    }
  }
  const double moved = arm.positions()[0] - 10 * kDeg;
  EXPECT_EQ(arm.Inputs(0).encoder_counts,
            drive.ToCounts(arm.positions()[0]) - drive.ToCounts(10 * kDeg));
  const double turns = std::abs(moved * drive.counts_per_unit()) / 1000;
  EXPECT_NEAR(crossings, turns, 1.0);
  EXPECT_GT(crossings, 3);
}

TEST(EmulatedArm, CurrentSenseIsProportionalToPwm) {
  EmulatedArm arm(Puma(), ArmOptions{});
  arm.Step({255, -128, 0});
  EXPECT_EQ(arm.Inputs(0).current_ad, 200);
  EXPECT_EQ(arm.Inputs(1).current_ad, 100);
  EXPECT_EQ(arm.Inputs(2).current_ad, 0);
}

TEST(EmulatedArm, RefusesBadStartPositions) {
  ArmOptions options;
  options.start_positions = {0, 0};
  EXPECT_THROW(EmulatedArm(Puma(), options), std::invalid_argument);
  options.start_positions = {0, 0, 0, 0, 200 * kDeg, 0};
  EXPECT_THROW(EmulatedArm(Puma(), options), std::invalid_argument);
}

}  // namespace
}  // namespace sirupp::hardware
