// The virtual PIC-SERVO (servo/picservo.hpp): profile properties and the PID against sequences
// computed by hand.

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "servo/picservo.hpp"

namespace sirupp::servo {
namespace {

constexpr int64_t kOne = int64_t{1} << 16;  // one count (or count/tick, count/tick^2) in 16.16

// Runs the profile to the end (at most `limit` ticks); returns the command positions.
std::vector<int64_t> RunToEnd(TrapezoidalProfile& profile, int limit = 1000000) {
  std::vector<int64_t> positions;
  for (int k = 0; k < limit && !profile.done(); ++k) positions.push_back(profile.Tick());
  return positions;
}

// Checks speed and acceleration bounds along a trajectory that started at rest at `start`.
void ExpectWithinLimits(const std::vector<int64_t>& positions, int64_t start, int64_t vmax,
                        int64_t a) {
  int64_t previous = start;
  int64_t previous_velocity = 0;
  for (size_t k = 0; k < positions.size(); ++k) {
    const int64_t velocity = positions[k] - previous;
    EXPECT_LE(std::llabs(velocity), vmax) << "tick " << k;
    EXPECT_LE(std::llabs(velocity - previous_velocity), a) << "tick " << k;
    previous = positions[k];
    previous_velocity = velocity;
  }
  EXPECT_LE(std::llabs(previous_velocity), a) << "the last tick must be able to stop";
}

TEST(TrapezoidalProfile, LandsExactlyOnTheGoalWithinSpeedAndAcceleration) {
  for (const int64_t goal : {int64_t{100000}, int64_t{-37123}, int64_t{5}}) {
    TrapezoidalProfile profile(0);
    const int64_t vmax = 50 * kOne + 1234, a = kOne / 3;
    profile.SetGoal(goal * kOne, vmax, a);
    const std::vector<int64_t> positions = RunToEnd(profile);
    ASSERT_TRUE(profile.done());
    EXPECT_EQ(positions.back(), goal * kOne) << "goal " << goal;
    EXPECT_EQ(profile.velocity(), 0);
    ExpectWithinLimits(positions, 0, vmax, a);
  }
}

TEST(TrapezoidalProfile, TakesTheTimeOfTheTrapezoid) {
  // 100000 counts at 50 counts/tick and 0.25 counts/tick^2: T = D / v + v / a = 2000 + 200 ticks.
  TrapezoidalProfile profile(0);
  profile.SetGoal(100000 * kOne, 50 * kOne, kOne / 4);
  const std::vector<int64_t> positions = RunToEnd(profile);
  EXPECT_NEAR(static_cast<double>(positions.size()), 2200.0, 3.0);
  // It slews at exactly the top speed in the middle.
  EXPECT_EQ(positions[1100] - positions[1099], 50 * kOne);
}

TEST(TrapezoidalProfile, ShortMovesAreTriangular) {
  // 400 counts at 0.25 counts/tick^2 never reaches 50 counts/tick: peak ~ sqrt(a D) = 10.
  TrapezoidalProfile profile(0);
  profile.SetGoal(400 * kOne, 50 * kOne, kOne / 4);
  const std::vector<int64_t> positions = RunToEnd(profile);
  int64_t peak = 0, previous = 0;
  for (int64_t p : positions) {
    peak = std::max(peak, p - previous);
    previous = p;
  }
  EXPECT_NEAR(static_cast<double>(peak) / kOne, 10.0, 0.5);
  EXPECT_EQ(positions.back(), 400 * kOne);
  EXPECT_NEAR(static_cast<double>(positions.size()), 2 * std::sqrt(400 / 0.25), 3.0);
}

TEST(TrapezoidalProfile, ANewGoalMidMoveIsTakenFromThePresentMotion) {
  TrapezoidalProfile profile(0);
  const int64_t vmax = 40 * kOne, a = kOne / 2;
  profile.SetGoal(50000 * kOne, vmax, a);
  std::vector<int64_t> positions;
  for (int k = 0; k < 300; ++k) positions.push_back(profile.Tick());
  // Retarget behind the present position: it brakes, turns and lands exactly.
  profile.SetGoal(1000 * kOne, vmax, a);
  const std::vector<int64_t> rest = RunToEnd(profile);
  positions.insert(positions.end(), rest.begin(), rest.end());
  EXPECT_EQ(positions.back(), 1000 * kOne);
  ExpectWithinLimits(positions, 0, vmax, a);
}

TEST(TrapezoidalProfile, StopSmoothDeceleratesToRestAtTheLoadedAcceleration) {
  TrapezoidalProfile profile(0);
  const int64_t vmax = 30 * kOne, a = kOne / 4;
  profile.SetGoal(100000 * kOne, vmax, a);
  std::vector<int64_t> positions;
  for (int k = 0; k < 500; ++k) positions.push_back(profile.Tick());
  profile.StopSmooth();
  const std::vector<int64_t> rest = RunToEnd(profile);
  positions.insert(positions.end(), rest.begin(), rest.end());
  EXPECT_TRUE(profile.done());
  EXPECT_EQ(rest.size(), 120U);  // 30 counts/tick at 0.25 per tick
  ExpectWithinLimits(positions, 0, vmax, a);
}

TEST(TrapezoidalProfile, RefusesZeroSpeedOrAcceleration) {
  TrapezoidalProfile profile(0);
  EXPECT_THROW(profile.SetGoal(10 * kOne, 0, kOne), std::invalid_argument);
  EXPECT_THROW(profile.SetGoal(10 * kOne, kOne, -1), std::invalid_argument);
}

// Holds command 0 and feeds the actual positions; returns the PWM outputs.
std::vector<int> Outputs(const ServoGains& gains, const std::vector<int64_t>& actual,
                         PicServo* servo_out = nullptr) {
  PicServo servo;
  servo.SetGains(gains);
  servo.ServoOn(0);
  std::vector<int> outputs;
  for (int64_t position : actual) outputs.push_back(servo.Tick(position));
  if (servo_out != nullptr) *servo_out = servo;
  return outputs;
}

TEST(PicServo, PdOutputsMatchHandComputedValues) {
  // Errors 0, 1, 3, 3: u = 100 e + 1000 (e - e_prev) = 0, 1100, 2300, 300; PWM = u / 256.
  ServoGains gains;  // Kp 100, Kd 1000, Ki 0
  EXPECT_EQ(Outputs(gains, {0, -1, -3, -3}), std::vector<int>({0, 4, 8, 1}));
  gains.deadband = 2;  // nonzero outputs grow by 2 in their own direction
  EXPECT_EQ(Outputs(gains, {0, -1, -3, -3}), std::vector<int>({0, 6, 10, 3}));
  EXPECT_EQ(Outputs(gains, {0, 1, 3, 3}), std::vector<int>({0, -6, -10, -3}));
}

TEST(PicServo, IntegralTermAndItsLimitMatchHandComputedValues) {
  // Ki 512: integral 0, 1, 4, 7 counts; Ki * I / 256 = 0, 2, 8, 14.
  ServoGains gains;
  gains.ki = 512;
  gains.integration_limit = 10;  // |I| <= 10 * 256: not reached here
  EXPECT_EQ(Outputs(gains, {0, -1, -3, -3}), std::vector<int>({0, 4, 9, 1}));
  // With IL = 0 the integral stays 0.
  gains.integration_limit = 0;
  EXPECT_EQ(Outputs(gains, {0, -1, -3, -3}), std::vector<int>({0, 4, 8, 1}));
}

TEST(PicServo, OutputLimitClipsAndFlagsSaturation) {
  ServoGains gains;
  gains.output_limit = 5;
  PicServo servo;
  EXPECT_EQ(Outputs(gains, {0, -1, -3}, &servo), std::vector<int>({0, 4, 5}));
  EXPECT_TRUE(servo.status() & kSaturated);
}

TEST(PicServo, ErrorLimitTurnsTheServoOffAndLatches) {
  ServoGains gains;
  gains.error_limit = 2;
  PicServo servo;
  EXPECT_EQ(Outputs(gains, {0, -1, -3, -3}, &servo), std::vector<int>({0, 4, 0, 0}));
  EXPECT_FALSE(servo.servo_on());
  EXPECT_TRUE(servo.status() & kPositionError);
  EXPECT_FALSE(servo.LoadTrajectory(100, kOne, kOne)) << "a move while off is ignored";
  servo.ServoOn(-3);
  EXPECT_TRUE(servo.servo_on());
  EXPECT_FALSE(servo.status() & kPositionError);
}

TEST(PicServo, FollowsItsProfileAndReportsMoveDone) {
  PicServo servo;
  servo.ServoOn(0);
  ASSERT_TRUE(servo.LoadTrajectory(1000, 10 * kOne, kOne));
  int ticks = 0;
  while (!(servo.status() & kMoveDone) && ticks < 10000) {
    // A perfect plant: the arm is where the command was.
    servo.Tick(WholeCounts(servo.profile().position()));
    ++ticks;
  }
  EXPECT_EQ(WholeCounts(servo.profile().position()), 1000);
  EXPECT_NEAR(ticks, 1000 / 10 + 10, 2);
  servo.MotorOff();
  EXPECT_EQ(servo.Tick(0), 0);
  EXPECT_FALSE(servo.servo_on());
}

TEST(PicServo, RefusesGainsOutOfTheChipsRange) {
  PicServo servo;
  ServoGains gains;
  gains.output_limit = 300;
  EXPECT_THROW(servo.SetGains(gains), std::invalid_argument);
  gains = ServoGains{};
  gains.kp = -1;
  EXPECT_THROW(servo.SetGains(gains), std::invalid_argument);
}

// ---- The chip's other modes (used by the hardware emulator). ------------------------------------

TEST(TrapezoidalProfile, VelocityModeRampsToTheSpeedAndKeepsIt) {
  TrapezoidalProfile profile(0);
  profile.SetVelocity(-10 * kOne, kOne / 2);  // 20 ticks of ramp
  EXPECT_FALSE(profile.done());
  int ticks = 0;
  while (!profile.done() && ticks < 1000) {
    profile.Tick();
    EXPECT_EQ(profile.phase(), kAccelerating);
    ++ticks;
  }
  EXPECT_EQ(ticks, 20);
  EXPECT_EQ(profile.velocity(), -10 * kOne);
  // Ramp: 0.5 + 1 + ... + 10 counts = 105 counts down.
  EXPECT_EQ(profile.position(), -105 * kOne);
  const int64_t before = profile.position();
  profile.Tick();
  EXPECT_TRUE(profile.done()) << "done stays set at the target speed";
  EXPECT_EQ(profile.phase(), kSlewing);
  EXPECT_EQ(profile.position() - before, -10 * kOne) << "the position keeps moving";
  // A new, lower speed of the other sign: it decelerates, then accelerates the other way.
  profile.SetVelocity(4 * kOne, kOne);
  profile.Tick();
  EXPECT_EQ(profile.phase(), kDecelerating);
  for (int k = 0; k < 20; ++k) profile.Tick();
  EXPECT_TRUE(profile.done());
  EXPECT_EQ(profile.velocity(), 4 * kOne);
  // Stop smooth from velocity mode ends at rest in position mode.
  profile.StopSmooth();
  const std::vector<int64_t> rest = RunToEnd(profile);
  EXPECT_EQ(rest.size(), 4U);
  EXPECT_EQ(profile.velocity(), 0);
  EXPECT_FALSE(profile.velocity_mode());
  EXPECT_THROW(profile.SetVelocity(kOne, 0), std::invalid_argument);
}

TEST(TrapezoidalProfile, APositionGoalAfterVelocityModeStartsFromThePresentSpeed) {
  TrapezoidalProfile profile(0);
  profile.SetVelocity(20 * kOne, kOne);
  for (int k = 0; k < 40; ++k) profile.Tick();
  const int64_t start = profile.position();
  profile.SetGoal(start + 10000 * kOne, 20 * kOne, kOne);
  std::vector<int64_t> positions = RunToEnd(profile);
  EXPECT_EQ(positions.back(), start + 10000 * kOne);
  // The first tick continues at 20 counts/tick (no jump to 0).
  EXPECT_EQ(positions.front() - start, 20 * kOne);
}

TEST(PicServo, VelocityModeReportsMoveDoneOnceTheSpeedIsReached) {
  PicServo servo;
  servo.ServoOn(0);
  ASSERT_TRUE(servo.LoadVelocity(5 * kOne, kOne));
  EXPECT_FALSE(servo.status() & kMoveDone);
  EXPECT_FALSE(servo.chip_flags().move_done);
  int64_t actual = 0;
  int ticks = 0;
  while (!(servo.status() & kMoveDone) && ticks < 100) {
    servo.Tick(actual);
    actual = WholeCounts(servo.profile().position());
    ++ticks;
  }
  EXPECT_EQ(ticks, 5);
  EXPECT_TRUE(servo.chip_flags().accel_done) << "the last phase change was an acceleration";
  servo.Tick(actual);
  EXPECT_TRUE(servo.chip_flags().slew_done);
  servo.StopSmooth();
  servo.Tick(actual);
  EXPECT_FALSE(servo.chip_flags().move_done) << "braking";
  EXPECT_FALSE(servo.chip_flags().accel_done) << "decelerating clears ACCEL_DONE";
  EXPECT_FALSE(servo.chip_flags().slew_done);
  servo.MotorOff();
  EXPECT_FALSE(servo.LoadVelocity(kOne, kOne)) << "ignored while the servo is off";
}

TEST(PicServo, PwmModeDrivesOpenLoopWithoutTheServo) {
  PicServo servo;
  servo.SetPwm(-300);
  EXPECT_EQ(servo.output(), -255) << "clamped to the PWM's full scale";
  EXPECT_TRUE(servo.pwm_mode());
  EXPECT_FALSE(servo.servo_on());
  EXPECT_EQ(servo.Tick(1234), -255);
  EXPECT_EQ(servo.Tick(-50), -255) << "no feedback in PWM mode";
  EXPECT_TRUE(servo.chip_flags().move_done);
  EXPECT_TRUE(servo.chip_flags().position_error) << "POS_ERR is set whenever the servo is off";
  servo.ServoOn(-50);
  EXPECT_FALSE(servo.pwm_mode());
  EXPECT_EQ(servo.Tick(-50), 0);
  servo.SetPwm(40);
  servo.MotorOff();
  EXPECT_EQ(servo.Tick(0), 0);
}

TEST(PicServo, PositionErrorIsLatchedUntilClearedAndWhileTheServoIsOff) {
  PicServo servo;
  EXPECT_TRUE(servo.chip_flags().position_error) << "power-up: servo off";
  servo.ServoOn(0);
  EXPECT_TRUE(servo.chip_flags().position_error) << "still latched: servo-on does not clear it";
  servo.ClearLatches();
  EXPECT_FALSE(servo.chip_flags().position_error);
  servo.Tick(0);
  EXPECT_FALSE(servo.chip_flags().position_error);
  servo.TripPositionError();
  EXPECT_FALSE(servo.servo_on());
  EXPECT_TRUE(servo.chip_flags().position_error);
  servo.ClearLatches();
  EXPECT_TRUE(servo.chip_flags().position_error) << "the servo is still off";
  servo.ServoOn(0);
  servo.ClearLatches();
  EXPECT_FALSE(servo.chip_flags().position_error);
  servo.MotorOff();
  EXPECT_TRUE(servo.chip_flags().position_error) << "MOTOR_OFF sets POS_ERR";
}

TEST(PicServo, StopHereJumpsTheCommandAndResetPositionMovesBoth) {
  PicServo servo;
  servo.StopHere(100, 90);  // servo off: switched on at 90, then the command jumps to 100
  EXPECT_TRUE(servo.servo_on());
  EXPECT_EQ(WholeCounts(servo.profile().position()), 100);
  servo.Tick(90);
  EXPECT_EQ(servo.position_error(), 10);
  ASSERT_TRUE(servo.LoadTrajectory(5000, 10 * kOne, kOne));
  for (int k = 0; k < 50; ++k) servo.Tick(WholeCounts(servo.profile().position()));
  servo.StopHere(777, 700);
  EXPECT_TRUE(servo.status() & kMoveDone);
  EXPECT_TRUE(servo.profile().done());
  EXPECT_EQ(servo.profile().velocity(), 0);
  servo.Tick(777);
  EXPECT_EQ(servo.position_error(), 0);
  // RESET_POS: counter and command go to the new value together.
  servo.ResetPosition(-20);
  EXPECT_EQ(WholeCounts(servo.profile().position()), -20);
  EXPECT_EQ(servo.Tick(-20), 0);
}

}  // namespace
}  // namespace sirupp::servo
