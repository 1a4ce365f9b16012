// SI <-> PIC-SERVO unit conversions (servo/servo_units.hpp), checked on the PUMA 260's drives
// with numbers worked out by hand.

#include <gtest/gtest.h>

#include <cmath>

#include "core/model_loader.hpp"
#include "servo/servo_units.hpp"

namespace sirupp::servo {
namespace {

constexpr double kPi = 3.14159265358979323846;

TEST(JointDrive, PumaShoulderCountsSpeedsAndEfforts) {
  const core::RobotModel model = core::LoadRobotModel("config/robots/puma260.yaml");
  const core::Joint& shoulder = model.joints[1];  // 1000 counts/rev, gear 69.9733, 0.30 N*m motor
  const JointDrive drive(shoulder, 0.000512);
  // 1000 * 69.9733 / (2 pi) = 11136.6 counts per radian.
  EXPECT_NEAR(drive.counts_per_unit(), 1000 * 69.9733 / (2 * kPi), 1e-9);
  EXPECT_EQ(drive.ToCounts(kPi / 2), 17493);  // 90 degrees: a quarter of 69973.3 counts
  EXPECT_NEAR(drive.FromCounts(drive.ToCounts(0.3)), 0.3, 0.5 / drive.counts_per_unit());
  // 45 deg/s = 8747 counts/s = 4.4784 counts/tick = 293,500 in 16.16.
  const double speed = 45 * kPi / 180;
  EXPECT_EQ(drive.VelocityWord(speed),
            std::llround(speed * drive.counts_per_unit() * 0.000512 * 65536));
  EXPECT_NEAR(drive.SpeedFromWord(drive.VelocityWord(speed)), speed, 1e-5);
  // The acceleration word is coarse: one unit is 1 / (65536 tick^2 counts-per-rad) = 0.0052
  // rad/s^2 here, so the round trip is exact to half of that.
  const double acceleration_lsb = 1 / (65536 * 0.000512 * 0.000512 * drive.counts_per_unit());
  EXPECT_NEAR(acceleration_lsb, 0.0052, 0.0001);
  EXPECT_NEAR(drive.AccelerationFromWord(drive.AccelerationWord(2.0)), 2.0, acceleration_lsb / 2);
  // Full PWM: 0.30 N*m at the motor times 69.97 = 20.99 N*m at the joint.
  EXPECT_NEAR(drive.EffortFromPwm(255), 0.30 * 69.9733, 1e-9);
  EXPECT_NEAR(drive.EffortFromPwm(-51), -0.2 * 0.30 * 69.9733, 1e-9);
}

TEST(JointDrive, ANegativeGearRatioTurnsCountsAndEffortAround) {
  const core::RobotModel model = core::LoadRobotModel("config/robots/puma260.yaml");
  const JointDrive waist(model.joints[0], 0.000512);  // gear -46.72
  EXPECT_LT(waist.counts_per_unit(), 0);
  EXPECT_LT(waist.ToCounts(0.1), 0);
  // Positive PWM drives the counts up, so the joint down: negative joint effort.
  EXPECT_LT(waist.EffortFromPwm(100), 0);
  // Speed and acceleration words are magnitudes.
  EXPECT_GT(waist.VelocityWord(1.0), 0);
  EXPECT_GT(waist.AccelerationWord(-1.0), 0);
}

TEST(JointDrive, RefusesADriveThatCannotBeConverted) {
  core::Joint joint;
  joint.name = "broken";
  joint.servo.gear_ratio = 0;
  EXPECT_THROW(JointDrive(joint, 0.000512), std::invalid_argument);
  joint.servo.gear_ratio = 10;
  EXPECT_THROW(JointDrive(joint, 0), std::invalid_argument);
}

}  // namespace
}  // namespace sirupp::servo
