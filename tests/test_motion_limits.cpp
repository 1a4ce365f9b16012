// The one rule for motion limits (core/motion_limits.hpp) that sirupp-hardware applies to ARM_MOVE
// and the controller can apply before the virtual arm moves: soft limits with their margin, the
// speed cap from the model's velocity_max, the acceleration cap; each refusal names the joint and
// the limit.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <stdexcept>

#include "core/model_loader.hpp"
#include "core/motion_limits.hpp"

namespace sirupp::core {
namespace {

constexpr double kDeg = M_PI / 180;

const RobotModel& Puma() {
  static const RobotModel model = LoadRobotModel("config/robots/puma260.yaml");
  return model;
}

TEST(MotionLimits, DefaultsComeFromTheModel) {
  const MotionLimits limits = DefaultMotionLimits(Puma());
  EXPECT_NEAR(limits.soft_limit_margin, 2 * kDeg, 1e-15);
  EXPECT_EQ(limits.velocity_cap_fraction, 1.0);
  ASSERT_EQ(limits.acceleration_max.size(), 6u);
  EXPECT_NEAR(limits.acceleration_max[1], 4 * Puma().joints[1].servo.default_acceleration, 1e-12);
  EXPECT_NEAR(SoftMax(Puma(), limits, 1), Puma().joints[1].position_max - 2 * kDeg, 1e-12);
  EXPECT_NEAR(SoftMin(Puma(), limits, 1), Puma().joints[1].position_min + 2 * kDeg, 1e-12);
  EXPECT_THROW(SoftMin(Puma(), limits, 6), std::out_of_range);
}

TEST(MotionLimits, AMoveInsideEveryLimitIsAllowed) {
  const MotionLimits limits = DefaultMotionLimits(Puma());
  for (int j = 0; j < 6; ++j) {
    const Joint& joint = Puma().joints[static_cast<size_t>(j)];
    EXPECT_EQ(CheckJointMove(Puma(), limits, j, joint.home, joint.servo.default_velocity,
                             joint.servo.default_acceleration),
              std::nullopt)
        << j;
    EXPECT_EQ(CheckJointMove(Puma(), limits, j, SoftMax(Puma(), limits, j), joint.velocity_max,
                             limits.acceleration_max[static_cast<size_t>(j)]),
              std::nullopt)
        << "the limits themselves are allowed";
  }
}

TEST(MotionLimits, EachRefusalNamesTheJointAndTheLimit) {
  const MotionLimits limits = DefaultMotionLimits(Puma());
  const Joint& shoulder = Puma().joints[1];
  const double v = shoulder.servo.default_velocity;
  const double a = shoulder.servo.default_acceleration;
  // Inside the joint's limits but within the 2 deg margin (issue 23).
  EXPECT_EQ(CheckJointMove(Puma(), limits, 1, 156 * kDeg, v, a),
            "joint j2 (shoulder): goal 156 deg is outside the soft limits [-155.5 deg, 155.5 deg]");
  // The unbounded acceleration, 1e12 rad/s^2.
  const std::optional<std::string> hard = CheckJointMove(Puma(), limits, 0, 0, v, 1e12);
  ASSERT_TRUE(hard.has_value());
  EXPECT_NE(hard->find("joint j1 (waist): acceleration "), std::string::npos) << *hard;
  EXPECT_NE(hard->find("deg/s^2 is outside (0, 360 deg/s^2] (acceleration cap)"), std::string::npos)
      << *hard;
  EXPECT_NE(CheckJointMove(Puma(), limits, 1, 0, 10, a)->find("(velocity cap)"), std::string::npos);
  EXPECT_NE(CheckJointMove(Puma(), limits, 1, 0, 0, a)->find("speed 0 deg/s is outside"),
            std::string::npos);
  EXPECT_NE(CheckJointMove(Puma(), limits, 1, 0, v, 0)->find("acceleration 0 deg/s^2"),
            std::string::npos);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(CheckJointMove(Puma(), limits, 1, nan, v, a)->find("goal nan"), std::string::npos);
  EXPECT_TRUE(CheckJointMove(Puma(), limits, 1, 0, nan, a).has_value());
  // Velocity mode: a signed speed, the goal not looked at.
  EXPECT_EQ(CheckJointMove(Puma(), limits, 1, 1e9, -v, a, true), std::nullopt);
  EXPECT_TRUE(CheckJointMove(Puma(), limits, 1, 0, 0, a, true).has_value());
  // The fraction scales the speed cap.
  MotionLimits slow = limits;
  slow.velocity_cap_fraction = 0.5;
  EXPECT_TRUE(CheckJointMove(Puma(), slow, 1, 0, 0.6 * shoulder.velocity_max, a).has_value());
  EXPECT_THROW(CheckJointMove(Puma(), limits, -1, 0, v, a), std::out_of_range);
}

}  // namespace
}  // namespace sirupp::core
