// The one rule for gains messages (servo/chip_gains.hpp): the model's gains round-trip through a
// message; the first bad value is refused naming channel, field, joint, value and range.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

#include "core/errors.hpp"
#include "core/model_loader.hpp"
#include "servo/chip_gains.hpp"

namespace sirupp::servo {
namespace {

const core::RobotModel& Puma() {
  static const core::RobotModel model = core::LoadRobotModel("config/robots/puma260.yaml");
  return model;
}

std::string Refusal(const sirupp::servo_gains_t& m) {
  try {
    ChipGainsFromMessage(m, Puma(), "ARM_GAINS");
  } catch (const core::MessageError& e) {
    return e.what();
  }
  return "accepted";
}

TEST(ChipGains, TheModelsGainsRoundTripThroughAMessage) {
  const std::vector<ChipGains> model = ChipGainsFromModel(Puma());
  ASSERT_EQ(model.size(), 6u);
  EXPECT_EQ(model[1].kp, 100);
  EXPECT_EQ(model[1].kd, 1000);
  EXPECT_EQ(model[1].servo_rate_divisor, 1);
  const sirupp::servo_gains_t m = GainsMessage(model);
  EXPECT_EQ(m.num_joints, 6);
  EXPECT_EQ(ChipGainsFromMessage(m, Puma(), "ARM_GAINS"), model);
  EXPECT_EQ(ToServoGains(model[1]).kp, 100);
}

TEST(ChipGains, TheFirstBadValueIsNamedAndNothingIsReturned) {
  const sirupp::servo_gains_t good = GainsMessage(ChipGainsFromModel(Puma()));
  sirupp::servo_gains_t m = good;
  m.kp[1] = 40000;
  EXPECT_EQ(Refusal(m),
            "channel ARM_GAINS: kp[1]: 40000 (joint j2 shoulder) is not allowed; expected a whole "
            "number 0..32767");
  m = good;
  m.output_limit[5] = 255.5;
  EXPECT_EQ(
      Refusal(m),
      "channel ARM_GAINS: output_limit[5]: 255.5 (joint j6 flange) is not allowed; expected a "
      "whole number 0..255");
  m = good;
  m.error_limit[0] = 20000;
  EXPECT_NE(Refusal(m).find("error_limit[0]: 20000 (joint j1 waist) is not allowed; expected a "
                            "whole number 0..16383"),
            std::string::npos)
      << Refusal(m);
  m = good;
  m.ki[3] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(Refusal(m).find("ki[3]: nan"), std::string::npos) << Refusal(m);
  m = good;
  m.servo_rate_divisor[2] = 2;
  EXPECT_EQ(
      Refusal(m),
      "channel ARM_GAINS: servo_rate_divisor[2]: 2 (joint j3 elbow) is not allowed; expected 1 "
      "(the virtual servos run every tick, and the boards run the same law)");
  m = good;
  m.deadband[4] = -1;
  EXPECT_NE(Refusal(m).find("deadband[4]: -1"), std::string::npos) << Refusal(m);
  m = good;
  m.num_joints = 5;
  EXPECT_EQ(Refusal(m), "channel ARM_GAINS: kp: 6 entries sent; num_joints says 5");
  // Consistent counts, but not the model's joints: the receiver's own check, in the same words.
  m = GainsMessage(ChipGainsFromModel(Puma()));
  m.num_joints = 5;
  for (std::vector<double>* v :
       {&m.kp, &m.kd, &m.ki, &m.integration_limit, &m.output_limit, &m.current_limit,
        &m.error_limit, &m.servo_rate_divisor, &m.deadband}) {
    v->pop_back();
  }
  EXPECT_EQ(Refusal(m),
            "channel ARM_GAINS: num_joints: 5 is not allowed; expected 6 (the model's joints)");
  m = good;
  m.kd.pop_back();
  EXPECT_NE(Refusal(m).find("num_joints"), std::string::npos);
}

}  // namespace
}  // namespace sirupp::servo
