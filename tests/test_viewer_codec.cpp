// image_t encoding and decoding (viewer/image_codec.hpp): round trips through the LCM wire format
// for JPEG (MJPG) and raw RGB, the formats other tools send, and images that do not add up.

#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "core/errors.hpp"
#include "viewer/image_codec.hpp"

namespace sirupp::viewer {
namespace {

// A test card: gradients and blocks, so that channel swaps and flips show.
cv::Mat TestCard(int width, int height) {
  cv::Mat image(height, width, CV_8UC3);
  for (int row = 0; row < height; ++row) {
    for (int col = 0; col < width; ++col) {
      image.at<cv::Vec3b>(row, col) = cv::Vec3b(static_cast<uint8_t>(col * 255 / width),
                                                static_cast<uint8_t>(row * 255 / height),
                                                static_cast<uint8_t>(col < width / 2 ? 220 : 30));
    }
  }
  cv::rectangle(image, cv::Rect(10, 10, 30, 20), cv::Scalar(0, 0, 255), cv::FILLED);
  return image;
}

// Encodes to bytes and decodes again, as a receiver on the network would.
sirupp::image_t OverTheWire(const sirupp::image_t& sent) {
  std::vector<uint8_t> bytes(static_cast<size_t>(sent.getEncodedSize()));
  EXPECT_EQ(sent.encode(bytes.data(), 0, static_cast<int>(bytes.size())),
            static_cast<int>(bytes.size()));
  sirupp::image_t received;
  EXPECT_EQ(received.decode(bytes.data(), 0, static_cast<int>(bytes.size())),
            static_cast<int>(bytes.size()));
  return received;
}

template <class Fn>
std::string MessageOf(Fn fn) {
  try {
    fn();
  } catch (const core::MessageError& error) {
    return error.what();
  }
  return "(no MessageError)";
}

TEST(ImageCodecTest, RgbRoundTripIsExact) {
  const cv::Mat card = TestCard(160, 120);
  const sirupp::image_t sent =
      EncodeImage(card, ImageFormat::kRgb, 80, 123456, {{"seq", "7"}, {"tick", "42"}});
  EXPECT_EQ(sent.pixelformat, sirupp::image_t::PIXEL_FORMAT_RGB);
  EXPECT_EQ(sent.row_stride, 3 * 160);
  EXPECT_EQ(sent.size, 3 * 160 * 120);
  // RGB order on the wire: the red block's first byte is 255.
  EXPECT_EQ(sent.data[static_cast<size_t>(15 * sent.row_stride + 15 * 3)], 255);
  const sirupp::image_t received = OverTheWire(sent);
  EXPECT_EQ(received.utime, 123456);
  EXPECT_EQ(FindMetadata(received, "seq").value_or(""), "7");
  EXPECT_EQ(FindMetadata(received, "tick").value_or(""), "42");
  EXPECT_FALSE(FindMetadata(received, "nothing").has_value());
  const cv::Mat back = DecodeImage(received);
  EXPECT_EQ(cv::norm(card, back, cv::NORM_INF), 0.0);
}

TEST(ImageCodecTest, JpegRoundTripIsCloseAndSmall) {
  const cv::Mat card = TestCard(320, 240);
  const sirupp::image_t sent = EncodeImage(card, ImageFormat::kJpeg, 90, 1, {});
  EXPECT_EQ(sent.pixelformat, sirupp::image_t::PIXEL_FORMAT_MJPEG);
  EXPECT_EQ(sent.row_stride, 0);
  ASSERT_GT(sent.size, 2);
  EXPECT_EQ(sent.data[0], 0xFF);  // JPEG start-of-image marker
  EXPECT_EQ(sent.data[1], 0xD8);
  EXPECT_LT(sent.size, 320 * 240 * 3 / 4);
  const cv::Mat back = DecodeImage(OverTheWire(sent));
  ASSERT_EQ(back.size(), card.size());
  cv::Mat difference;
  cv::absdiff(card, back, difference);
  const cv::Scalar mean = cv::mean(difference);
  EXPECT_LT(mean[0] + mean[1] + mean[2], 9.0);
  // The red block is still red (channel order kept).
  const cv::Vec3b red = back.at<cv::Vec3b>(20, 25);
  EXPECT_GT(red[2], 200);
  EXPECT_LT(red[0], 60);
}

TEST(ImageCodecTest, DecodesTheOtherRawFormatsWithRowPadding) {
  const cv::Mat card = TestCard(40, 30);
  for (const auto& [format, conversion, channels] : std::vector<std::tuple<int32_t, int, int>>{
           {sirupp::image_t::PIXEL_FORMAT_BGR, -1, 3},
           {sirupp::image_t::PIXEL_FORMAT_RGBA, cv::COLOR_BGR2RGBA, 4},
           {sirupp::image_t::PIXEL_FORMAT_BGRA, cv::COLOR_BGR2BGRA, 4},
           {sirupp::image_t::PIXEL_FORMAT_GRAY, cv::COLOR_BGR2GRAY, 1}}) {
    cv::Mat converted = card;
    if (conversion >= 0) cv::cvtColor(card, converted, conversion);
    sirupp::image_t image{};
    image.width = 40;
    image.height = 30;
    image.row_stride = 40 * channels + 8;  // padded rows
    image.pixelformat = format;
    image.data.assign(static_cast<size_t>(image.row_stride) * 30, 0);
    for (int row = 0; row < 30; ++row) {
      std::copy(converted.ptr<uint8_t>(row), converted.ptr<uint8_t>(row) + 40 * channels,
                image.data.begin() + row * image.row_stride);
    }
    image.size = static_cast<int32_t>(image.data.size());
    const cv::Mat back = DecodeImage(image);
    ASSERT_EQ(back.type(), CV_8UC3);
    if (format == sirupp::image_t::PIXEL_FORMAT_GRAY) {
      cv::Mat gray;
      cv::cvtColor(back, gray, cv::COLOR_BGR2GRAY);
      EXPECT_LE(cv::norm(gray, converted, cv::NORM_INF), 1.0);
    } else {
      EXPECT_EQ(cv::norm(card, back, cv::NORM_INF), 0.0) << format;
    }
  }
}

TEST(ImageCodecTest, ImagesThatDoNotAddUpAreRefusedNamingTheField) {
  const sirupp::image_t good = EncodeImage(TestCard(64, 48), ImageFormat::kRgb, 80, 0, {});
  sirupp::image_t bad = good;
  bad.size = 5;
  EXPECT_EQ(MessageOf([&] { DecodeImage(bad, "RIG1_VIEWER_IMAGE"); }),
            "channel RIG1_VIEWER_IMAGE: size: 5 does not match the 9216 bytes sent");
  bad = good;
  bad.data.resize(100);
  bad.size = 100;
  EXPECT_EQ(MessageOf([&] { DecodeImage(bad); }),
            "channel VIEWER_IMAGE: size: 100 bytes; 64x48 RGB with row_stride 192 needs 9216");
  bad = good;
  bad.row_stride = 10;
  EXPECT_NE(MessageOf([&] { DecodeImage(bad); }).find("row_stride: 10 is less than 192"),
            std::string::npos);
  bad = good;
  bad.pixelformat = sirupp::image_t::PIXEL_FORMAT_NV12;
  EXPECT_NE(MessageOf([&] { DecodeImage(bad); }).find("pixelformat: 842094158 is not shown"),
            std::string::npos);
  bad = good;
  bad.width = 0;
  EXPECT_NE(MessageOf([&] { DecodeImage(bad); }).find("0x48 is outside"), std::string::npos);
  bad = EncodeImage(TestCard(64, 48), ImageFormat::kJpeg, 80, 0, {});
  bad.data.assign(50, 7);
  bad.size = 50;
  EXPECT_EQ(MessageOf([&] { DecodeImage(bad); }),
            "channel VIEWER_IMAGE: data: 50 bytes are not a JPEG image");
  bad = EncodeImage(TestCard(64, 48), ImageFormat::kJpeg, 80, 0, {});
  bad.width = 65;
  EXPECT_NE(MessageOf([&] { DecodeImage(bad); }).find("65x48 but the JPEG is 64x48"),
            std::string::npos);
}

TEST(ImageCodecTest, EncodeRefusesWhatItCannotSend) {
  EXPECT_THROW(EncodeImage(cv::Mat(), ImageFormat::kJpeg, 80, 0, {}), std::invalid_argument);
  EXPECT_THROW(EncodeImage(cv::Mat(4, 4, CV_8UC1), ImageFormat::kRgb, 80, 0, {}),
               std::invalid_argument);
  EXPECT_THROW(EncodeImage(TestCard(16, 16), ImageFormat::kJpeg, 0, 0, {}), std::invalid_argument);
}

}  // namespace
}  // namespace sirupp::viewer
