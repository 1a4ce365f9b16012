#pragma once
// image_t (the libbot2 bot_core.image_t layout, lcmtypes/image_t.lcm) to and from OpenCV images.
// Encoding makes the VIEWER_IMAGE messages of sirupp-viewer; decoding is what `sirupp view` (and
// tests) use to show them. Pure functions: no network, no clocks.

#include <cstdint>
#include <opencv2/core.hpp>
#include <optional>
#include <sirupp/image_t.hpp>
#include <string>
#include <utility>
#include <vector>

namespace sirupp::viewer {

enum class ImageFormat {
  kJpeg,  // PIXEL_FORMAT_MJPEG: data is a complete JPEG file
  kRgb,   // PIXEL_FORMAT_RGB: 3 bytes per pixel, rows top to bottom, row_stride = 3 * width
};

const char* ImageFormatName(ImageFormat format);  // "jpeg", "rgb"

using Metadata = std::vector<std::pair<std::string, std::string>>;

// `bgr`: 8-bit, 3 channels (OpenCV's order). jpeg_quality 1..100 (used for kJpeg only).
// Throws std::invalid_argument for another image type or quality, std::runtime_error if the JPEG
// encoder fails.
sirupp::image_t EncodeImage(const cv::Mat& bgr, ImageFormat format, int jpeg_quality, int64_t utime,
                            const Metadata& metadata);

// Decodes MJPEG, RGB, BGR, RGBA, BGRA and GRAY images into an 8-bit BGR image. Anything else, or
// sizes, strides and counts that do not fit the data, throws core::MessageError naming `channel`
// and the field, e.g. "channel VIEWER_IMAGE: size: 100 bytes; 640x480 RGB with row_stride 1920
// needs 921600".
cv::Mat DecodeImage(const sirupp::image_t& image, const std::string& channel = "VIEWER_IMAGE");

// The value of metadata `key` as text, or nullopt.
std::optional<std::string> FindMetadata(const sirupp::image_t& image, const std::string& key);

}  // namespace sirupp::viewer
