// The real-arm effects of the emulated arm (hardware/real_arm.hpp, hardware/emulated_arm.hpp),
// each on its own against the same arm without it: gear backlash, the shared supply's sag
// coupling the joints, the motor's back-EMF and inductance, per-direction friction, the encoder
// quantum and the boards' command latency; and the real-arm file's validation.

#include <gtest/gtest.h>

#include <cmath>
#include <set>
#include <string>

#include "core/errors.hpp"
#include "core/model_loader.hpp"
#include "hardware/emulated_arm.hpp"
#include "hardware/picservo_module.hpp"
#include "hardware/real_arm.hpp"

namespace sirupp::hardware {
namespace {

constexpr double kDeg = 3.14159265358979323846 / 180;

const core::RobotModel& Puma() {
  static const core::RobotModel model = core::LoadRobotModel("config/robots/puma260.yaml");
  return model;
}

EmulatedArm Arm(const RealArmParams& effects) {
  ArmOptions options;
  options.effects = effects;
  return EmulatedArm(Puma(), options);
}

// Runs `ticks` servo ticks with the same PWM.
void RunTicks(EmulatedArm& arm, const std::vector<int>& pwm, int ticks) {
  for (int t = 0; t < ticks; ++t) arm.Step(pwm);
}

TEST(RealArmEffects, BacklashIsLostMotionBeforeTheLinkMoves) {
  // The waist (no gravity about its axis; the other joints braked), compliant, from rest with the
  // gears centred in their play: the rotor turns through half the gap before the link moves.
  auto rotor_travel_when_link_moves = [](double backlash_deg) {
    RealArmParams p = ModelLikeParams(Puma());
    p.joints[0].stiffness_nm_per_rad = 5000;
    p.joints[0].damping_nm_s_per_rad = 3;
    p.joints[0].backlash_rad = backlash_deg * kDeg;
    EmulatedArm arm = Arm(p);
    arm.SetBrakes({false, true, true, true, true, true});
    for (int t = 0; t < 4000 && std::abs(arm.positions()[0]) < 0.01 * kDeg; ++t) arm.Step({40});
    EXPECT_GE(std::abs(arm.positions()[0]), 0.01 * kDeg) << "the link moved in the end";
    return std::abs(arm.rotor_positions()[0]) / kDeg;
  };
  const double rigid = rotor_travel_when_link_moves(0);
  const double with_gap = rotor_travel_when_link_moves(1.0);
  std::printf(
      "rotor travel before the link moves: %.3f deg without backlash, %.3f deg with 1 "
      "deg\n",
      rigid, with_gap);
  EXPECT_LT(rigid, 0.05);                  // the spring's wind-up only
  EXPECT_GT(with_gap, 0.5);                // half the gap, plus the wind-up
  EXPECT_LT(with_gap, 0.5 + rigid + 0.1);  // and the rotor's overrun while the spring winds up
}

TEST(RealArmEffects, TheSharedSupplySagsAndLowersAnotherJointsCurrent) {
  // The waist braked at full PWM (stalled: its current is duty x V / R), with joints 2 and 3 also
  // at full PWM or idle: with a stiff supply its current is the same; with a source resistance
  // the others' current lowers the voltage, and so the waist's current and torque.
  auto waist_current = [](double resistance, bool others) {
    RealArmParams p = ModelLikeParams(Puma());
    p.supply_voltage_v = 24;
    p.supply_resistance_ohm = resistance;
    EmulatedArm arm = Arm(p);
    arm.SetBrakes({true, false, false, true, true, true});
    double lowest = p.supply_voltage_v;
    for (int t = 0; t < 100; ++t) {
      arm.Step({255, others ? 255 : 0, others ? -255 : 0});
      lowest = std::min(lowest, arm.supply_voltage());
    }
    std::printf("supply %.1f ohm, %s: waist current %.3f A, lowest supply %.2f V\n", resistance,
                others ? "three joints" : "waist alone", arm.motor_current()[0], lowest);
    return arm.motor_current()[0];
  };
  EXPECT_DOUBLE_EQ(waist_current(0, false), waist_current(0, true));
  const double alone = std::abs(waist_current(1.0, false));
  const double together = std::abs(waist_current(1.0, true));
  EXPECT_GT(alone, 1.0);
  EXPECT_LT(together, 0.9 * alone) << "the other joints' current sags the waist's supply";
}

TEST(RealArmEffects, BackEmfLimitsTheSpeedAndInductanceDelaysTheCurrent) {
  RealArmParams p = ModelLikeParams(Puma());
  JointEffects& e = p.joints[0];
  e.static_nm[0] = e.static_nm[1] = e.coulomb_nm[0] = e.coulomb_nm[1] = 0;
  e.viscous_nm_s_per_rad = 0;
  e.motor.torque_constant_nm_per_a = 0.2;
  e.motor.resistance_ohm = 4;
  e.motor.inductance_h = 0.02;  // L / R = 5 ms
  p.supply_voltage_v = 12;
  EmulatedArm arm = Arm(p);
  arm.Step({255});
  // One tick (0.512 ms) into a 5 ms rise: about 10 % of the stall current V / R = 3 A.
  EXPECT_GT(std::abs(arm.motor_current()[0]), 0.05 * 3);
  EXPECT_LT(std::abs(arm.motor_current()[0]), 0.15 * 3);
  RunTicks(arm, {255}, 600);
  // No friction: the speed settles where the back-EMF meets the supply, V / (Kt |gear|).
  const double no_load = 12 / (0.2 * std::abs(Puma().joints[0].servo.gear_ratio));
  std::printf("waist speed at full PWM: %.4f rad/s, V / (Kt N) = %.4f rad/s, current %.3f A\n",
              std::abs(arm.velocities()[0]), no_load, arm.motor_current()[0]);
  EXPECT_NEAR(std::abs(arm.velocities()[0]), no_load, 0.03 * no_load);
  EXPECT_LT(std::abs(arm.motor_current()[0]), 0.1);
}

TEST(RealArmEffects, FrictionDiffersPerDirection) {
  RealArmParams p = ModelLikeParams(Puma());
  p.joints[0].static_nm[0] = 1.0;  // moving positive breaks away at 1 N*m
  p.joints[0].static_nm[1] = 2.0;  // moving negative at 2
  p.joints[0].coulomb_nm[0] = 0.8;
  p.joints[0].coulomb_nm[1] = 1.6;
  auto moved = [&](double effort) {
    EmulatedArm arm = Arm(p);
    arm.SetBrakes({false, true, true, true, true, true});  // the shoulder would fall and pull it
    arm.SetExternalEffort({effort});
    RunTicks(arm, {}, 400);
    return arm.positions()[0];
  };
  EXPECT_GT(moved(1.5), 0.01 * kDeg);
  EXPECT_EQ(moved(-1.5), 0.0) << "1.5 N*m is below the negative break-away level";
  EXPECT_LT(moved(-2.5), -0.01 * kDeg);
}

TEST(RealArmEffects, TheEncoderReadsWholeMultiplesOfItsQuantum) {
  RealArmParams p = ModelLikeParams(Puma());
  p.encoder_quantum_counts = 8;
  EmulatedArm arm = Arm(p);
  std::set<int64_t> seen;
  for (int t = 0; t < 400; ++t) {
    arm.Step({80});
    const int64_t counts = arm.Inputs(0).encoder_counts;
    EXPECT_EQ(counts % 8, 0) << counts;
    seen.insert(counts);
  }
  EXPECT_GT(seen.size(), 5U) << "the joint moved through several quanta";
}

TEST(RealArmEffects, TheBoardStartsAMoveAfterItsCommandLatency) {
  for (int latency : {0, 100}) {
    PicServoModule m;
    m.SetCommandLatencyTicks(latency);
    m.Handle(nmc::SetAddress(0, 1, 0xFF, false), true, true);
    nmc::Gains g;
    g.kp = 100;
    g.kd = 1000;
    g.output_limit = 255;
    g.error_limit = 4000;
    m.Handle(nmc::SetGain(1, g), true, true);
    m.Handle(nmc::StopMotor(1, nmc::kAmpEnable | nmc::kStopAbrupt), true, true);
    m.Tick({});
    nmc::Trajectory t;
    t.control = nmc::kLoadPosition | nmc::kLoadVelocity | nmc::kLoadAcceleration |
                nmc::kEnableServo | nmc::kStartNow;
    t.position = 100000;
    t.velocity = 65536 * 10;
    t.acceleration = 65536;
    const auto reply = m.Handle(nmc::LoadTrajectory(1, t), true, true).reply;
    ASSERT_FALSE(reply.empty()) << "the reply is immediate";
    EXPECT_EQ(reply[0] & nmc::kStatusMoveDone, 0) << "the move is accepted: not done";
    int first_pwm_tick = -1;
    for (int k = 1; k <= 300 && first_pwm_tick < 0; ++k) {
      if (m.Tick({}) != 0) first_pwm_tick = k;
    }
    std::printf("latency %d ticks: first PWM at tick %d\n", latency, first_pwm_tick);
    EXPECT_GE(first_pwm_tick, latency);
    EXPECT_LE(first_pwm_tick, latency + 5);
  }
}

TEST(RealArmFile, TheShippedFileLoadsAndRoundTrips) {
  const RealArmParams p = LoadRealArmParams("config/hardware/puma260-real.yaml", Puma());
  ASSERT_EQ(p.joints.size(), 6U);
  const RealArmParams again =
      ParseRealArmParams(FormatRealArmParams(p, "round trip"), "again.yaml", Puma());
  EXPECT_NEAR(again.command_latency_s, p.command_latency_s, 1e-6);
  EXPECT_NEAR(again.joints[1].static_nm[1], p.joints[1].static_nm[1], 1e-5);
  EXPECT_NEAR(again.joints[2].backlash_rad, p.joints[2].backlash_rad, 1e-7);
  EXPECT_NO_THROW(Arm(p));
}

std::string Problem(const std::string& from, const std::string& to) {
  std::string text = FormatRealArmParams(ModelLikeParams(Puma()), "test");
  const size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) text.replace(at, from.size(), to);
  try {
    ParseRealArmParams(text, "bad.yaml", Puma());
  } catch (const core::ConfigError& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(RealArmFile, BadValuesNameTheLineTheKeyAndTheRange) {
  EXPECT_NE(Problem("voltage_v: 40", "voltage_v: 400").find("bad.yaml:4:21: supply.voltage_v: 400"),
            std::string::npos)
      << Problem("voltage_v: 40", "voltage_v: 400");
  EXPECT_NE(Problem("voltage_v: 40", "voltage_v: 400").find("[12, 80] (V)"), std::string::npos);
  EXPECT_NE(
      Problem("coulomb_nm: [0.7, 0.75]", "coulomb_nm: [1.7, 0.75]").find("exceeds the static"),
      std::string::npos);
  EXPECT_NE(
      Problem("backlash_deg: 0, stiffness_nm_rad: 0", "backlash_deg: 0.5, stiffness_nm_rad: 0")
          .find("backlash needs a compliant gear train"),
      std::string::npos);
  EXPECT_NE(Problem("stiffness_nm_rad: 0", "stiffness_nm_rad: 50").find("allowed 0 (rigid)"),
            std::string::npos);
  EXPECT_NE(Problem("robot: puma260", "robot: kuka").find("another arm"), std::string::npos);
  EXPECT_NE(Problem("encoder_quantum_counts: 1", "encoder_quantum_counts: 0").find("[1, 64]"),
            std::string::npos);
}

}  // namespace
}  // namespace sirupp::hardware
