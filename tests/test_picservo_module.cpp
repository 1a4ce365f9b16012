// One emulated PIC-SERVO SC module (hardware/picservo_module.hpp), byte for byte against
// shared/reference/picservo.md: the daisy-chain addressing of NmcInit, group leaders, the reply
// rules, DEF_STAT and READ_STAT, buffered moves, stops, homing, CLEAR_BITS and the EEPROM reset.

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "hardware/picservo_module.hpp"

namespace sirupp::hardware {
namespace {

using namespace nmc;
using Bytes = std::vector<uint8_t>;

// The power-up status byte: servo off (MOVE_DONE, POS_ERR) with the supply on.
constexpr uint8_t kPowerUpStatus = kStatusMoveDone | kStatusPowerOn | kStatusPositionError;

// N modules on one bus in daisy-chain order. The motor is ideal while the servo drives it (the
// encoder lands on the command position each tick); otherwise it moves pwm / 4 counts per tick.
struct Bus {
  explicit Bus(int n) : modules(static_cast<size_t>(n)), encoders(static_cast<size_t>(n), 0.0) {}

  // Sends a packet; returns every reply (with the index of the module that sent it).
  std::vector<std::pair<int, Bytes>> Send(const Packet& packet, bool checksum_ok = true) {
    std::vector<bool> addr_in(modules.size());
    for (size_t k = 0; k < modules.size(); ++k) addr_in[k] = k == 0 || modules[k - 1].addr_out();
    std::vector<std::pair<int, Bytes>> replies;
    last_baud = 0;
    for (size_t k = 0; k < modules.size(); ++k) {
      PicServoModule::Result r = modules[k].Handle(packet, checksum_ok, addr_in[k]);
      if (r.new_baud) last_baud = r.new_baud;
      if (!r.reply.empty()) replies.emplace_back(static_cast<int>(k), r.reply);
    }
    return replies;
  }
  // The one reply a command must get.
  Bytes Reply(const Packet& packet) {
    const auto replies = Send(packet);
    EXPECT_EQ(replies.size(), 1U) << Describe(packet);
    return replies.empty() ? Bytes{} : replies[0].second;
  }
  void Tick(int ticks = 1) {
    for (int t = 0; t < ticks; ++t) {
      for (size_t k = 0; k < modules.size(); ++k) {
        MotorInputs in = inputs;
        in.encoder_counts = static_cast<int64_t>(std::llround(encoders[k]));
        const int pwm = modules[k].Tick(in);
        if (modules[k].amp_enabled() && modules[k].servo().servo_on()) {
          encoders[k] += static_cast<double>(
              servo::WholeCounts(modules[k].servo().profile().position()) - modules[k].position());
        } else {
          encoders[k] += pwm / 4.0;
        }
      }
    }
  }

  std::vector<PicServoModule> modules;
  std::vector<double> encoders;
  MotorInputs inputs;
  int last_baud = 0;
};

Gains TestGains() {
  Gains g;
  g.kp = 100;
  g.kd = 1000;
  g.output_limit = 255;
  g.error_limit = 4000;
  return g;
}

// Addresses modules 1..n like NmcInit, then switches each servo on with the test gains.
void Bringup(Bus& bus) {
  for (size_t k = 0; k < bus.modules.size(); ++k) {
    const auto a = static_cast<uint8_t>(k + 1);
    bus.Reply(SetAddress(0, a, 0xFF, false));
    bus.Reply(SetGain(a, TestGains()));
    bus.Reply(StopMotor(a, kAmpEnable | kStopAbrupt));
    bus.Reply(ClearBits(a));
  }
}

TEST(PicServoModule, NmcInitAddressesTheChainInOrderAndEachAnswersItsId) {
  Bus bus(3);
  // NmcInit: two hard resets to 0xFF (no replies), then SET_ADDR to address 0 until none answers.
  EXPECT_TRUE(bus.Send(HardReset(kBroadcast)).empty());
  EXPECT_TRUE(bus.Send(HardReset(kBroadcast)).empty());
  EXPECT_EQ(bus.last_baud, kPowerUpBaud);
  // Only the first module of the chain listens at address 0 before anything is addressed.
  EXPECT_EQ(bus.Send(Nop(0)).size(), 1U);
  for (uint8_t a = 1; a <= 3; ++a) {
    const auto replies = bus.Send(SetAddress(0, a, 0xFF, false));
    ASSERT_EQ(replies.size(), 1U) << "address " << int{a};
    EXPECT_EQ(replies[0].first, a - 1) << "the chain's next module takes address " << int{a};
    // Reply: status, checksum = status (the test NmcInit makes).
    EXPECT_EQ(replies[0].second, Bytes({kPowerUpStatus, kPowerUpStatus}));
    // READ_STAT(SEND_ID): status, type 0, version 10, checksum.
    EXPECT_EQ(bus.Reply(ReadStatus(a, kSendId)),
              Bytes({kPowerUpStatus, 0x00, 0x0A, static_cast<uint8_t>(kPowerUpStatus + 0x0A)}));
  }
  EXPECT_TRUE(bus.Send(SetAddress(0, 4, 0xFF, false)).empty()) << "no fourth module";
  for (int k = 0; k < 3; ++k) EXPECT_EQ(bus.modules[static_cast<size_t>(k)].address(), k + 1);
  // The byte sequence of the reference: SET_ADDR from 0 to 1, group 0xFF = AA 00 21 01 FF 21.
  EXPECT_EQ(Encode(SetAddress(0, 1, 0xFF, false)), Bytes({0xAA, 0x00, 0x21, 0x01, 0xFF, 0x21}));
  // After a hard reset everything is unaddressed again and the chain starts over.
  EXPECT_TRUE(bus.Send(HardReset(kBroadcast)).empty());
  EXPECT_TRUE(bus.Send(Nop(1)).empty());
  const auto again = bus.Send(SetAddress(0, 7, 0xFF, false));
  ASSERT_EQ(again.size(), 1U);
  EXPECT_EQ(again[0].first, 0);
}

TEST(PicServoModule, OnlyTheGroupLeaderRepliesToAGroupCommand) {
  Bus bus(3);
  bus.Reply(SetAddress(0, 1, 0x80, true));  // leader of group 0x80: byte 2 = 0x00
  bus.Reply(SetAddress(0, 2, 0x80, false));
  bus.Reply(SetAddress(0, 3, 0x80, false));
  EXPECT_TRUE(bus.modules[0].leader());
  EXPECT_EQ(bus.modules[1].group(), 0x80);
  const auto replies = bus.Send(Nop(0x80));
  ASSERT_EQ(replies.size(), 1U);
  EXPECT_EQ(replies[0].first, 0);
  // Every member executed it: a group DEF_STAT changes all three, only the leader answers.
  EXPECT_EQ(bus.Send(DefineStatus(0x80, kSendPosition)).size(), 1U);
  EXPECT_EQ(bus.Reply(Nop(3)).size(), 6U);
  // Without a leader nobody replies.
  bus.Reply(SetAddress(1, 1, 0x80, false));
  EXPECT_TRUE(bus.Send(Nop(0x80)).empty());
  EXPECT_TRUE(bus.Send(Nop(0xFF)).empty()) << "the default group has no leader";
}

TEST(PicServoModule, ABadChecksumGetsAReplyWithCksumErrorAndIsNotExecuted) {
  Bus bus(1);
  bus.Reply(SetAddress(0, 1, 0xFF, false));
  const auto replies = bus.Send(DefineStatus(1, kSendPosition), /*checksum_ok=*/false);
  ASSERT_EQ(replies.size(), 1U);
  const uint8_t bad = kPowerUpStatus | kStatusChecksumError;
  EXPECT_EQ(replies[0].second, Bytes({bad, bad})) << "DEF_STAT not executed: still no items";
  // The next good command clears the bit.
  EXPECT_EQ(bus.Reply(Nop(1)), Bytes({kPowerUpStatus, kPowerUpStatus}));
  // A data length the command does not allow is treated the same way (documented choice).
  Packet odd = Nop(1);
  odd.data = {0x00};
  EXPECT_EQ(bus.Reply(odd), Bytes({bad, bad}));
  Packet stop = StopMotor(1, kAmpEnable | kStopAbrupt);
  stop.data.push_back(0);  // 2 bytes: not allowed
  EXPECT_EQ(bus.Reply(stop)[0] & kStatusChecksumError, kStatusChecksumError);
  EXPECT_FALSE(bus.modules[0].servo().servo_on()) << "the bad STOP_MOTOR did not run";
  // A group command with a bad checksum: silent members stay silent.
  EXPECT_TRUE(bus.Send(Nop(0xFF), false).empty());
}

TEST(PicServoModule, HardResetAndSetBaudNeverReply) {
  Bus bus(2);
  bus.Reply(SetAddress(0, 1, 0x80, true));
  bus.Reply(SetAddress(0, 2, 0x80, false));
  EXPECT_TRUE(bus.Send(SetBaud(1, BaudDivisor(115200))).empty());
  EXPECT_EQ(bus.last_baud, 115200);
  EXPECT_TRUE(bus.Send(SetBaud(0x80, BaudDivisor(57600))).empty()) << "even to a led group";
  EXPECT_EQ(bus.last_baud, 57600);
  EXPECT_TRUE(bus.Send(SetBaud(0xFF, 99)).empty());
  EXPECT_EQ(bus.last_baud, 0) << "an unknown divisor leaves the speed";
  EXPECT_TRUE(bus.Send(HardReset(2)).empty());
  EXPECT_EQ(bus.modules[1].address(), 0);
  EXPECT_EQ(bus.last_baud, kPowerUpBaud);
}

TEST(PicServoModule, DefStatIsPermanentAndItsOwnReplyUsesItReadStatIsOnce) {
  Bus bus(1);
  bus.Reply(SetAddress(0, 1, 0xFF, false));
  bus.Reply(ResetPosition(1));
  bus.Reply(SetPosition(1, 0x01020304));
  const uint8_t items = kSendPosition | kSendAux;
  const Bytes def = bus.Reply(DefineStatus(1, items));
  ASSERT_EQ(def.size(), ReplyLength(items)) << "the DEF_STAT reply already carries the items";
  const Status s = DecodeStatus(def.data(), def.size(), items);
  EXPECT_EQ(s.position, 0x01020304);
  // Aux: SLEW_DONE (at rest).
  EXPECT_EQ(def, Bytes({kPowerUpStatus, 0x04, 0x03, 0x02, 0x01, kAuxSlewDone,
                        static_cast<uint8_t>(kPowerUpStatus + 0x0A + kAuxSlewDone)}));
  EXPECT_EQ(bus.Reply(Nop(1)).size(), ReplyLength(items));
  const Bytes once = bus.Reply(ReadStatus(1, kSendId | kSendHome));
  ASSERT_EQ(once.size(), ReplyLength(kSendId | kSendHome));
  EXPECT_EQ(DecodeStatus(once.data(), once.size(), kSendId | kSendHome).version, 10);
  EXPECT_EQ(bus.Reply(Nop(1)).size(), ReplyLength(items)) << "READ_STAT did not change DEF_STAT";
}

TEST(PicServoModule, LoadTrajWaitsForStartMoveToTheGroup) {
  Bus bus(2);
  bus.Reply(SetAddress(0, 1, 0x80, true));
  bus.Reply(SetAddress(0, 2, 0x80, false));
  for (uint8_t a = 1; a <= 2; ++a) {
    bus.Reply(SetGain(a, TestGains()));
    bus.Reply(StopMotor(a, kAmpEnable | kStopAbrupt));
    bus.Reply(ClearBits(a));
  }
  Trajectory t;
  t.control = kLoadPosition | kLoadVelocity | kLoadAcceleration | kEnableServo;
  t.position = 2000;
  t.velocity = 20 << 16;
  t.acceleration = 1 << 16;
  bus.Reply(LoadTrajectory(1, t));
  t.position = -1000;
  bus.Reply(LoadTrajectory(2, t));
  t.position = -3000;  // a second LOAD_TRAJ overwrites the buffer
  bus.Reply(LoadTrajectory(2, t));
  bus.Tick(100);
  EXPECT_EQ(bus.modules[0].servo().profile().goal(), 0) << "nothing moves before START_MOVE";
  EXPECT_TRUE(bus.modules[0].status_byte() & kStatusMoveDone);
  const auto replies = bus.Send(StartMove(0x80));
  ASSERT_EQ(replies.size(), 1U);
  EXPECT_FALSE(replies[0].second[0] & kStatusMoveDone) << "the leader's reply: moving";
  bus.Tick(1);
  EXPECT_FALSE(bus.modules[1].status_byte() & kStatusMoveDone);
  bus.Tick(3000);
  EXPECT_TRUE(bus.modules[0].status_byte() & kStatusMoveDone);
  EXPECT_NEAR(bus.modules[0].position(), 2000, 3);
  EXPECT_NEAR(bus.modules[1].position(), -3000, 3);
  // A second START_MOVE has nothing buffered.
  bus.Send(StartMove(0x80));
  bus.Tick(1);
  EXPECT_TRUE(bus.modules[0].status_byte() & kStatusMoveDone);
  // Parameters not flagged keep their values: a position-only move with START_NOW, then a
  // relative one (REVERSE in position mode on the SC) from that goal.
  Trajectory p;
  p.control = kLoadPosition | kEnableServo | kStartNow;
  p.position = 500;
  bus.Reply(LoadTrajectory(1, p));
  p.control |= kReverse;
  p.position = 100;
  bus.Reply(LoadTrajectory(1, p));
  bus.Tick(3000);
  EXPECT_NEAR(bus.modules[0].position(), 600, 3);
}

TEST(PicServoModule, VelocityAndPwmModes) {
  Bus bus(1);
  Bringup(bus);
  Trajectory t;
  t.control =
      kLoadVelocity | kLoadAcceleration | kEnableServo | kVelocityMode | kReverse | kStartNow;
  t.velocity = 3 << 16;
  t.acceleration = 1 << 15;
  bus.Reply(LoadTrajectory(1, t));
  bus.Tick(2);
  EXPECT_FALSE(bus.modules[0].status_byte() & kStatusMoveDone) << "ramping";
  EXPECT_TRUE(bus.modules[0].aux_byte() & kAuxAccelDone);
  bus.Tick(10);
  EXPECT_TRUE(bus.modules[0].status_byte() & kStatusMoveDone) << "the speed is reached";
  bus.Tick(400);
  EXPECT_LT(bus.modules[0].position(), -1000);
  EXPECT_NEAR(bus.modules[0].StatusNow().velocity, -3, 1);
  // PWM mode: open loop, servo off.
  Trajectory pwm;
  pwm.control = kLoadPwm | kStartNow;
  pwm.pwm = 80;
  bus.Reply(LoadTrajectory(1, pwm));
  bus.Tick(1);
  EXPECT_EQ(bus.modules[0].pwm(), 80);
  EXPECT_FALSE(bus.modules[0].aux_byte() & kAuxServoOn);
  EXPECT_TRUE(bus.modules[0].status_byte() & kStatusPositionError);
  // STOP_SMOOTH in PWM mode: output 0.
  bus.Reply(StopMotor(1, kAmpEnable | kStopSmooth));
  bus.Tick(1);
  EXPECT_EQ(bus.modules[0].pwm(), 0);
}

TEST(PicServoModule, StopMotorForms) {
  Bus bus(1);
  Bringup(bus);
  EXPECT_TRUE(bus.modules[0].aux_byte() & kAuxServoOn);
  Trajectory t;
  t.control = kLoadPosition | kLoadVelocity | kLoadAcceleration | kEnableServo | kStartNow;
  t.position = 100000;
  t.velocity = 10 << 16;
  t.acceleration = 1 << 14;
  bus.Reply(LoadTrajectory(1, t));
  bus.Tick(1000);
  // STOP_SMOOTH: MOVE_DONE clear while braking, set at rest.
  bus.Reply(StopMotor(1, kAmpEnable | kStopSmooth));
  bus.Tick(1);
  EXPECT_FALSE(bus.modules[0].status_byte() & kStatusMoveDone);
  EXPECT_FALSE(bus.modules[0].aux_byte() & kAuxSlewDone);
  bus.Tick(100);
  EXPECT_TRUE(bus.modules[0].status_byte() & kStatusMoveDone);
  EXPECT_LT(bus.modules[0].servo().profile().goal() >> 16, 100000);
  // AMP_ENABLE off: the servo runs but the motor gets nothing.
  bus.Reply(StopMotor(1, kStopAbrupt));
  bus.encoders[0] += 50;
  bus.Tick(1);
  EXPECT_TRUE(bus.modules[0].aux_byte() & kAuxServoOn);
  EXPECT_NE(bus.modules[0].servo().output(), 0);
  EXPECT_EQ(bus.modules[0].pwm(), 0);
  // STOP_HERE: the command jumps to the given position.
  const int32_t here = bus.modules[0].position() + 30;
  bus.Reply(StopHere(1, kAmpEnable, here));
  bus.Tick(1);
  EXPECT_EQ(bus.modules[0].StatusNow().position_error,
            30 - (bus.modules[0].position() - here + 30));
  bus.Tick(500);
  EXPECT_NEAR(bus.modules[0].position(), here, 2);
  // MOTOR_OFF: servo off, MOVE_DONE and POS_ERR.
  const Bytes off = bus.Reply(StopMotor(1, kAmpEnable | kMotorOff));
  EXPECT_EQ(off[0] & (kStatusMoveDone | kStatusPositionError),
            kStatusMoveDone | kStatusPositionError);
  EXPECT_FALSE(bus.modules[0].aux_byte() & kAuxServoOn);
  // STOP_ABRUPT switches it on again where it is; POS_ERR stays until CLEAR_BITS.
  const Bytes on = bus.Reply(StopMotor(1, kAmpEnable | kStopAbrupt));
  EXPECT_TRUE(bus.modules[0].aux_byte() & kAuxServoOn);
  EXPECT_TRUE(on[0] & kStatusPositionError);
  EXPECT_FALSE(bus.Reply(ClearBits(1))[0] & kStatusPositionError);
}

TEST(PicServoModule, ClearBitsClearsLatchedFaults) {
  Bus bus(1);
  Bringup(bus);
  bus.modules[0].TriggerOvercurrent();
  bus.Tick(1);
  const uint8_t s = bus.Reply(Nop(1))[0];
  EXPECT_TRUE(s & kStatusOvercurrent);
  EXPECT_TRUE(s & kStatusPositionError) << "the trip turned the motor off";
  bus.Reply(StopMotor(1, kAmpEnable | kStopAbrupt));
  EXPECT_TRUE(bus.Reply(Nop(1))[0] & kStatusOvercurrent) << "latched";
  const uint8_t cleared = bus.Reply(ClearBits(1))[0];
  EXPECT_FALSE(cleared & kStatusOvercurrent);
  EXPECT_FALSE(cleared & kStatusPositionError);
  // The position-error trip.
  bus.modules[0].TriggerPositionErrorTrip();
  bus.Tick(1);
  EXPECT_TRUE(bus.Reply(Nop(1))[0] & kStatusPositionError);
  EXPECT_FALSE(bus.modules[0].aux_byte() & kAuxServoOn);
  // The current limit: CL odd trips above it.
  Gains g = TestGains();
  g.current_limit = 9;
  bus.Reply(ClearBits(1));
  bus.Reply(SetGain(1, g));
  bus.Reply(StopMotor(1, kAmpEnable | kStopAbrupt));
  bus.inputs.current_ad = 10;
  bus.Tick(1);
  EXPECT_TRUE(bus.Reply(Nop(1))[0] & kStatusOvercurrent);
}

TEST(PicServoModule, HomingOnTheIndexLatchesTheEdgeAndStops) {
  Bus bus(1);
  Bringup(bus);
  bus.Reply(DefineStatus(1, kSendHome));
  const Bytes start = bus.Reply(SetHoming(1, kHomeOnIndex | kHomeStopAbrupt));
  EXPECT_TRUE(start[0] & kStatusHomeInProgress);
  Trajectory t;
  t.control = kLoadVelocity | kLoadAcceleration | kEnableServo | kVelocityMode | kStartNow;
  t.velocity = 2 << 16;
  t.acceleration = 1 << 14;
  bus.Reply(LoadTrajectory(1, t));
  bus.Tick(50);
  EXPECT_TRUE(bus.Reply(Nop(1))[0] & kStatusHomeInProgress);
  bus.inputs.index_crossed = true;
  bus.inputs.index_edge_counts = 37;
  bus.Tick(1);
  bus.inputs.index_crossed = false;
  const Bytes homed = bus.Reply(Nop(1));
  EXPECT_FALSE(homed[0] & kStatusHomeInProgress);
  EXPECT_EQ(DecodeStatus(homed.data(), homed.size(), kSendHome).home, 37);
  EXPECT_TRUE(homed[0] & kStatusMoveDone) << "stopped abruptly";
  // RESET_POS REL_HOME makes the home position the new zero.
  const int32_t before = bus.modules[0].position();
  bus.Reply(ResetToHome(1));
  EXPECT_EQ(bus.modules[0].position(), before - 37);
  // Homing on limit 2, then the motor off.
  bus.Reply(SetHoming(1, kHomeOnLimit2 | kHomeMotorOff));
  bus.inputs.limit2 = true;
  bus.Tick(1);
  EXPECT_FALSE(bus.modules[0].status_byte() & kStatusHomeInProgress);
  EXPECT_TRUE(bus.modules[0].status_byte() & kStatusLimit2);
  EXPECT_FALSE(bus.modules[0].aux_byte() & kAuxServoOn);
  // SAVE_AS_HOME copies the position; SET_HOMING 0 cancels.
  bus.Reply(SaveAsHome(1));
  EXPECT_EQ(bus.modules[0].StatusNow().home, bus.modules[0].position());
  bus.Reply(SetHoming(1, kHomeOnLimit1));
  EXPECT_FALSE(bus.Reply(SetHoming(1, 0))[0] & kStatusHomeInProgress);
}

TEST(PicServoModule, LimitStopTurnsTheMotorOffWhenMovingIntoTheSwitch) {
  Bus bus(1);
  Bringup(bus);
  bus.Reply(IoControl(1, kLimitStopOff));
  Trajectory t;
  t.control = kLoadVelocity | kLoadAcceleration | kEnableServo | kVelocityMode | kStartNow;
  t.velocity = 2 << 16;
  t.acceleration = 1 << 14;
  bus.Reply(LoadTrajectory(1, t));
  bus.Tick(20);
  bus.inputs.limit2 = true;  // limit 2 guards the other direction
  bus.Tick(5);
  EXPECT_TRUE(bus.modules[0].aux_byte() & kAuxServoOn);
  bus.inputs.limit1 = true;
  bus.Tick(1);
  EXPECT_FALSE(bus.modules[0].aux_byte() & kAuxServoOn);
  EXPECT_TRUE(bus.modules[0].status_byte() & kStatusLimit1);
}

TEST(PicServoModule, HardResetWithSaveDataKeepsTheConfigurationInEeprom) {
  Bus bus(2);
  Bringup(bus);
  const Gains g = TestGains();
  EXPECT_TRUE(bus.Send(HardResetConfig(2, 0x01 | 0x02 | 0x04)).empty());  // SAVE, RESTORE_ADDR, AMP
  EXPECT_TRUE(bus.modules[1].eeprom().valid);
  EXPECT_EQ(bus.modules[1].address(), 2) << "address restored from the EEPROM";
  EXPECT_TRUE(bus.modules[1].amp_enabled());
  EXPECT_EQ(bus.modules[1].gains().kp, g.kp);
  EXPECT_FALSE(bus.modules[1].aux_byte() & kAuxServoOn) << "EPU_SERVO was not set";
  EXPECT_EQ(bus.Reply(Nop(2))[0], kPowerUpStatus);
  // A plain hard reset keeps the EEPROM; the 1-byte form with 0 erases it.
  bus.Send(HardReset(0xFF));
  EXPECT_EQ(bus.modules[1].address(), 2);
  EXPECT_EQ(bus.modules[0].address(), 0);
  bus.Send(HardResetConfig(2, 0));
  EXPECT_FALSE(bus.modules[1].eeprom().valid);
  EXPECT_EQ(bus.modules[1].address(), 0);
  EXPECT_EQ(bus.modules[1].gains().kp, 0);
}

TEST(PicServoModule, ResetPosAndSetPosMoveCounterAndCommandTogether) {
  Bus bus(1);
  Bringup(bus);
  bus.encoders[0] = 1234;
  bus.Tick(1);
  bus.Reply(SetPosition(1, -5000));
  EXPECT_EQ(bus.modules[0].position(), -5000);
  EXPECT_EQ(bus.modules[0].servo().profile().goal() / 65536, -5000);
  bus.Tick(10);
  EXPECT_NEAR(bus.modules[0].position(), -5000, 2) << "no jump of the servo";
  bus.Reply(ResetPosition(1));
  EXPECT_EQ(bus.modules[0].position(), 0);
  bus.Tick(10);
  EXPECT_NEAR(bus.modules[0].position(), 0, 2);
}

TEST(PicServoModule, PathPointsAreBufferedAndPlayed) {
  Bus bus(1);
  Bringup(bus);
  bus.Reply(DefineStatus(1, kSendNumPoints));
  // Two points of 2 counts per tick (512/256) at 60 Hz (33 ticks each), forward.
  const Bytes r = bus.Reply(AddPathpoints(1, {512, 512}));
  EXPECT_EQ(r[1], 2) << "two points buffered";
  bus.Reply(StartPathMode(1));
  bus.Tick(1);
  EXPECT_TRUE(bus.modules[0].aux_byte() & kAuxPathMode);
  bus.Tick(200);
  EXPECT_FALSE(bus.modules[0].aux_byte() & kAuxPathMode);
  EXPECT_NEAR(bus.modules[0].servo().profile().goal() / 65536, 2 * 2 * 33, 4);
}

}  // namespace
}  // namespace sirupp::hardware
