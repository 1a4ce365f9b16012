// The NMC packet layer (hardware/nmc_protocol.hpp) against the byte sequences of
// shared/reference/picservo.md, and its parsers against damaged input.
#include <gtest/gtest.h>

#include <vector>

#include "hardware/nmc_protocol.hpp"

namespace sirupp::hardware::nmc {
namespace {

using Bytes = std::vector<uint8_t>;

TEST(NmcProtocol, ReferenceExamples) {
  EXPECT_EQ(Encode(Nop(1)), (Bytes{0xAA, 0x01, 0x0E, 0x0F}));
  EXPECT_EQ(Encode(HardReset(0xFF)), (Bytes{0xAA, 0xFF, 0x0F, 0x0E}));
  EXPECT_EQ(Encode(SetAddress(0x00, 1, 0xFF, false)), (Bytes{0xAA, 0x00, 0x21, 0x01, 0xFF, 0x21}));
  // The manual's worked example: to -1500 at vel 100000, acc 100, start now.
  Trajectory t;
  t.control = kLoadPosition | kLoadVelocity | kLoadAcceleration | kEnableServo | kStartNow;
  t.position = -1500;
  t.velocity = 100000;
  t.acceleration = 100;
  const Bytes b = Encode(LoadTrajectory(1, t));
  ASSERT_EQ(b.size(), 17u);
  EXPECT_EQ(b[2], 0xD4);
  EXPECT_EQ(b[3], 0x97);
  EXPECT_EQ((Bytes(b.begin() + 4, b.begin() + 8)), (Bytes{0x24, 0xFA, 0xFF, 0xFF}));   // -1500
  EXPECT_EQ((Bytes(b.begin() + 8, b.begin() + 12)), (Bytes{0xA0, 0x86, 0x01, 0x00}));  // 100000
  unsigned sum = 0;
  for (size_t i = 1; i + 1 < b.size(); ++i) sum += b[i];
  EXPECT_EQ(b.back(), sum & 0xFF);
}

TEST(NmcProtocol, CommandBytesOfEveryCommand) {
  EXPECT_EQ(Encode(ResetPosition(2))[2], 0x00);
  EXPECT_EQ(Encode(ResetToHome(2))[2], 0x10);
  EXPECT_EQ(Encode(SetPosition(2, -7)),
            (Bytes{0xAA, 0x02, 0x50, 0x02, 0xF9, 0xFF, 0xFF, 0xFF,
                   static_cast<uint8_t>(0x02 + 0x50 + 0x02 + 0xF9 + 0xFF * 3)}));
  EXPECT_EQ(Encode(DefineStatus(3, kSendPosition | kSendAux))[2], 0x12);
  EXPECT_EQ(Encode(ReadStatus(3, kSendId))[2], 0x13);
  EXPECT_EQ(Encode(StartMove(0x80))[2], 0x05);
  Gains g;
  g.kp = 100;
  g.kd = 1000;
  g.error_limit = 4000;
  g.output_limit = 255;
  EXPECT_EQ(Encode(SetGain(1, g))[2], 0xE6);
  EXPECT_EQ(Encode(SetGain(1, g, true))[2], 0xF6);
  EXPECT_EQ(Encode(StopMotor(1, kAmpEnable | kStopAbrupt)), (Bytes{0xAA, 0x01, 0x17, 0x05, 0x1D}));
  EXPECT_EQ(Encode(StopHere(1, kAmpEnable, 10))[2], 0x57);
  EXPECT_EQ(Encode(IoControl(1, kLimitStopOff))[2], 0x18);
  EXPECT_EQ(Encode(SetHoming(1, kHomeOnIndex | kHomeStopSmooth))[2], 0x19);
  EXPECT_EQ(Encode(SetBaud(0xFF, BaudDivisor(115200))), (Bytes{0xAA, 0xFF, 0x1A, 10, 0x23}));
  EXPECT_EQ(Encode(ClearBits(1))[2], 0x0B);
  EXPECT_EQ(Encode(SaveAsHome(0x80))[2], 0x0C);
  EXPECT_EQ(Encode(StartPathMode(1))[2], 0x0D);
  EXPECT_EQ(Encode(AddPathpoints(1, {1, 2, 3}))[2], 0x6D);
  EXPECT_EQ(Encode(HardResetConfig(1, 0x01))[2], 0x1F);
  EXPECT_THROW(AddPathpoints(1, std::vector<uint16_t>(8, 1)), std::invalid_argument);
  // Group leader: bit 7 of the group byte cleared.
  EXPECT_EQ(SetAddress(0, 2, 0x80, true).data, (Bytes{2, 0x00}));
}

TEST(NmcProtocol, BaudDivisors) {
  EXPECT_EQ(BaudDivisor(19200), 64);
  EXPECT_EQ(BaudDivisor(57600), 21);
  EXPECT_EQ(BaudDivisor(115200), 10);
  EXPECT_EQ(BaudDivisor(230400), 5);
  EXPECT_EQ(BaudFromDivisor(5), 230400);
  EXPECT_EQ(BaudFromDivisor(3), 0);
  try {
    BaudDivisor(38400);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("38400"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("230400"), std::string::npos);
  }
}

TEST(NmcProtocol, TrajectoryAndGainsRoundTrip) {
  Trajectory t;
  t.control = kLoadPosition | kLoadAcceleration | kLoadPwm | kEnableServo;
  t.position = -123456;
  t.acceleration = 0x7FFFFFFF;
  t.pwm = 200;
  std::string problem;
  const auto back = DecodeTrajectory(LoadTrajectory(1, t).data, &problem);
  ASSERT_TRUE(back) << problem;
  EXPECT_EQ(back->position, -123456);
  EXPECT_EQ(back->acceleration, 0x7FFFFFFFu);
  EXPECT_EQ(back->pwm, 200);
  EXPECT_EQ(back->velocity, 0u);

  Gains g;
  g.kp = 1200;
  g.kd = -5;
  g.ki = 200;
  g.integration_limit = 200;
  g.output_limit = 230;
  g.current_limit = 25;
  g.error_limit = 16383;
  g.servo_rate = 1;
  g.deadband = 120;
  g.step_multiplier = 5;
  const auto gb = DecodeGains(SetGain(1, g, true).data, &problem);
  ASSERT_TRUE(gb);
  EXPECT_EQ(gb->kd, -5);
  EXPECT_EQ(gb->error_limit, 16383);
  EXPECT_EQ(gb->step_multiplier, 5);
  EXPECT_EQ(DecodeGains(SetGain(1, g).data, &problem)->step_multiplier, 1);
}

TEST(NmcProtocol, DataLengthChecks) {
  EXPECT_EQ(CheckDataLength(Nop(1)), "");
  Packet bad = Nop(1);
  bad.data = {1};
  EXPECT_EQ(CheckDataLength(bad), "NOP with 1 data bytes; allowed: 0");
  Packet traj = LoadTrajectory(1, Trajectory{kLoadPosition, 5, 0, 0, 0});
  traj.data.pop_back();
  EXPECT_EQ(CheckDataLength(traj), "LOAD_TRAJ control byte 0x01 needs 5 data bytes, got 4");
  Packet stop = StopMotor(1, kStopAbrupt);
  stop.data[0] |= kStopHere;
  EXPECT_NE(CheckDataLength(stop).find("STOP_HERE"), std::string::npos);
  EXPECT_EQ(CheckDataLength(StopHere(1, 0, 3)), "");
  Packet reset = ResetPosition(1);
  reset.data = {0x07};
  EXPECT_EQ(CheckDataLength(reset), "RESET_POS option 0x07; allowed: 0x01 (REL_HOME)");
  EXPECT_THROW(Encode(Packet{1, kNop, Bytes(16, 0)}), std::invalid_argument);
}

TEST(NmcProtocol, ReaderSkipsNoiseAndFlagsBadChecksums) {
  PacketReader reader;
  Bytes stream{0x00, 0x00, 0x13};  // a resync burst and noise
  const Bytes nop = Encode(Nop(1));
  stream.insert(stream.end(), nop.begin(), nop.end());
  Bytes damaged = Encode(StopMotor(2, kMotorOff));
  damaged.back() ^= 0x40;
  stream.insert(stream.end(), damaged.begin(), damaged.end());
  std::vector<PacketReader::Result> got;
  for (uint8_t b : stream) {
    if (auto r = reader.Feed(b)) got.push_back(*r);
  }
  ASSERT_EQ(got.size(), 2u);
  EXPECT_EQ(reader.skipped_bytes(), 3u);
  EXPECT_TRUE(got[0].checksum_ok);
  EXPECT_EQ(got[0].packet, Nop(1));
  EXPECT_FALSE(got[1].checksum_ok);
  EXPECT_EQ(got[1].packet.address, 2);
  EXPECT_EQ(got[1].packet.command, kStopMotor);
}

TEST(NmcProtocol, StatusRepliesInItemOrder) {
  EXPECT_EQ(ReplyLength(0), 2u);
  EXPECT_EQ(ReplyLength(0xFF), 19u);
  Status s;
  s.status = kStatusMoveDone | kStatusPowerOn;
  s.position = -100000;
  s.ad = 7;
  s.velocity = -3;
  s.aux = kAuxServoOn;
  s.home = 42;
  s.type = kTypePicServo;
  s.version = kVersionPicServoSc;
  s.position_error = -12;
  s.num_points = 9;
  const Bytes b = EncodeStatus(s, 0xFF);
  ASSERT_EQ(b.size(), 19u);
  const Status back = DecodeStatus(b.data(), b.size(), 0xFF);
  EXPECT_EQ(back.position, -100000);
  EXPECT_EQ(back.velocity, -3);
  EXPECT_EQ(back.home, 42);
  EXPECT_EQ(back.version, 10);
  EXPECT_EQ(back.position_error, -12);
  EXPECT_EQ(back.num_points, 9);
  // Default reply: the checksum equals the status byte (what NmcInit tests).
  EXPECT_EQ(EncodeStatus(s, 0), (Bytes{0x09, 0x09}));
  // SEND_ID alone: status, type, version, checksum.
  EXPECT_EQ(EncodeStatus(s, kSendId), (Bytes{0x09, 0x00, 0x0A, 0x13}));

  Bytes bad = b;
  bad[3] ^= 1;
  try {
    DecodeStatus(bad.data(), bad.size(), 0xFF);
    FAIL();
  } catch (const ProtocolError& e) {
    EXPECT_NE(std::string(e.what()).find("checksum"), std::string::npos);
  }
  EXPECT_THROW(DecodeStatus(b.data(), 5, 0xFF), ProtocolError);
  EXPECT_EQ(DescribeStatusBits(0x19), "MOVE_DONE|POWER_ON|POS_ERR");
  EXPECT_EQ(DescribeStatusBits(0), "-");
}

}  // namespace
}  // namespace sirupp::hardware::nmc
