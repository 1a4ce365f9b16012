// Properties of the generated message types that lab tools rely on: image_t's libbot2 wire layout
// and FOURCC codes, and distinct fingerprints (lcm-spy picks a decoder by fingerprint alone).
#include <gtest/gtest.h>

#include <cstring>
#include <set>
#include <sirupp/arm_command_t.hpp>
#include <sirupp/arm_state_t.hpp>
#include <sirupp/command_reply_t.hpp>
#include <sirupp/controller_status_t.hpp>
#include <sirupp/environment_t.hpp>
#include <sirupp/estop_t.hpp>
#include <sirupp/hardware_command_t.hpp>
#include <sirupp/hardware_status_t.hpp>
#include <sirupp/heartbeat_t.hpp>
#include <sirupp/image_t.hpp>
#include <sirupp/joint_target_t.hpp>
#include <sirupp/plan_command_t.hpp>
#include <sirupp/pose_target_t.hpp>
#include <sirupp/robot_model_t.hpp>
#include <sirupp/servo_gains_t.hpp>
#include <sirupp/servo_move_t.hpp>
#include <sirupp/servo_setpoint_t.hpp>
#include <vector>

namespace {

int32_t Fourcc(const char code[5]) {
  return static_cast<int32_t>(static_cast<uint32_t>(static_cast<uint8_t>(code[0])) |
                              static_cast<uint32_t>(static_cast<uint8_t>(code[1])) << 8 |
                              static_cast<uint32_t>(static_cast<uint8_t>(code[2])) << 16 |
                              static_cast<uint32_t>(static_cast<uint8_t>(code[3])) << 24);
}

TEST(LcmTypes, ImagePixelFormatsAreFourccCodes) {
  using sirupp::image_t;
  EXPECT_EQ(image_t::PIXEL_FORMAT_RGB, Fourcc("RGB3"));
  EXPECT_EQ(image_t::PIXEL_FORMAT_BGR, Fourcc("BGR3"));
  EXPECT_EQ(image_t::PIXEL_FORMAT_RGBA, Fourcc("RGB4"));
  EXPECT_EQ(image_t::PIXEL_FORMAT_BGRA, Fourcc("BGR4"));
  EXPECT_EQ(image_t::PIXEL_FORMAT_GRAY, Fourcc("GREY"));
  EXPECT_EQ(image_t::PIXEL_FORMAT_MJPEG, Fourcc("MJPG"));
  EXPECT_EQ(image_t::PIXEL_FORMAT_UYVY, Fourcc("UYVY"));
  EXPECT_EQ(image_t::PIXEL_FORMAT_YUYV, Fourcc("YUYV"));
  EXPECT_EQ(image_t::PIXEL_FORMAT_I420, Fourcc("I420"));
  EXPECT_EQ(image_t::PIXEL_FORMAT_NV12, Fourcc("NV12"));
  EXPECT_EQ(image_t::PIXEL_FORMAT_BAYER_BGGR, Fourcc("BA81"));
  EXPECT_EQ(image_t::PIXEL_FORMAT_LE_GRAY16, Fourcc("LG16"));
  EXPECT_EQ(image_t::PIXEL_FORMAT_FLOAT_GRAY32, Fourcc("FG32"));
}

uint64_t BigEndian(const uint8_t* bytes, int n) {
  uint64_t value = 0;
  for (int i = 0; i < n; ++i) value = value << 8 | bytes[i];
  return value;
}

TEST(LcmTypes, ImageWireLayoutIsLibbot2s) {
  // bot_core.image_t: utime, width, height, row_stride, pixelformat, size, data[size], nmetadata,
  // metadata[nmetadata]; big-endian after the 8-byte fingerprint.
  sirupp::image_t image{};
  image.utime = 0x0102030405060708;
  image.width = 2;
  image.height = 1;
  image.row_stride = 6;
  image.pixelformat = sirupp::image_t::PIXEL_FORMAT_RGB;
  image.data = {10, 20, 30, 40, 50, 60};
  image.size = 6;
  image.nmetadata = 0;
  std::vector<uint8_t> wire(static_cast<size_t>(image.getEncodedSize()));
  ASSERT_EQ(image.encode(wire.data(), 0, static_cast<int>(wire.size())),
            static_cast<int>(wire.size()));
  ASSERT_EQ(wire.size(), 8U + 8 + 5 * 4 + 6 + 4);
  const uint8_t* p = wire.data() + 8;
  EXPECT_EQ(BigEndian(p, 8), 0x0102030405060708U);
  EXPECT_EQ(BigEndian(p + 8, 4), 2U);
  EXPECT_EQ(BigEndian(p + 12, 4), 1U);
  EXPECT_EQ(BigEndian(p + 16, 4), 6U);
  EXPECT_EQ(BigEndian(p + 20, 4), static_cast<uint32_t>(sirupp::image_t::PIXEL_FORMAT_RGB));
  EXPECT_EQ(BigEndian(p + 24, 4), 6U);
  EXPECT_EQ(std::memcmp(p + 28, image.data.data(), 6), 0);
  EXPECT_EQ(BigEndian(p + 34, 4), 0U);
}

TEST(LcmTypes, EveryTopLevelTypeHasItsOwnFingerprint) {
  const std::vector<int64_t> hashes = {
      sirupp::arm_state_t::getHash(),         sirupp::arm_command_t::getHash(),
      sirupp::servo_move_t::getHash(),        sirupp::servo_setpoint_t::getHash(),
      sirupp::servo_gains_t::getHash(),       sirupp::joint_target_t::getHash(),
      sirupp::pose_target_t::getHash(),       sirupp::plan_command_t::getHash(),
      sirupp::controller_status_t::getHash(), sirupp::hardware_status_t::getHash(),
      sirupp::hardware_command_t::getHash(),  sirupp::estop_t::getHash(),
      sirupp::heartbeat_t::getHash(),         sirupp::robot_model_t::getHash(),
      sirupp::environment_t::getHash(),       sirupp::image_t::getHash(),
      sirupp::command_reply_t::getHash()};
  EXPECT_EQ(std::set<int64_t>(hashes.begin(), hashes.end()).size(), hashes.size());
}

}  // namespace
