#include "viewer/image_codec.hpp"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

#include "core/errors.hpp"

namespace sirupp::viewer {

namespace {

std::string Size(const sirupp::image_t& image) {
  return std::to_string(image.width) + "x" + std::to_string(image.height);
}

}  // namespace

const char* ImageFormatName(ImageFormat format) {
  return format == ImageFormat::kJpeg ? "jpeg" : "rgb";
}

sirupp::image_t EncodeImage(const cv::Mat& bgr, ImageFormat format, int jpeg_quality, int64_t utime,
                            const Metadata& metadata) {
  if (bgr.empty() || bgr.type() != CV_8UC3) {
    throw std::invalid_argument("EncodeImage: an 8-bit 3-channel BGR image is needed");
  }
  sirupp::image_t image{};
  image.utime = utime;
  image.width = bgr.cols;
  image.height = bgr.rows;
  if (format == ImageFormat::kJpeg) {
    if (jpeg_quality < 1 || jpeg_quality > 100) {
      throw std::invalid_argument("EncodeImage: JPEG quality " + std::to_string(jpeg_quality) +
                                  " is outside 1..100");
    }
    if (!cv::imencode(".jpg", bgr, image.data, {cv::IMWRITE_JPEG_QUALITY, jpeg_quality})) {
      throw std::runtime_error("EncodeImage: the JPEG encoder failed");
    }
    image.row_stride = 0;
    image.pixelformat = sirupp::image_t::PIXEL_FORMAT_MJPEG;
  } else {
    cv::Mat rgb;
    cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
    image.row_stride = 3 * bgr.cols;
    image.pixelformat = sirupp::image_t::PIXEL_FORMAT_RGB;
    image.data.resize(static_cast<size_t>(image.row_stride) * bgr.rows);
    for (int row = 0; row < rgb.rows; ++row) {
      const uint8_t* from = rgb.ptr<uint8_t>(row);
      std::copy(from, from + image.row_stride,
                image.data.begin() + static_cast<std::ptrdiff_t>(row) * image.row_stride);
    }
  }
  image.size = static_cast<int32_t>(image.data.size());
  for (const auto& [key, value] : metadata) {
    sirupp::image_metadata_t entry{};
    entry.key = key;
    entry.value.assign(value.begin(), value.end());
    entry.n = static_cast<int32_t>(entry.value.size());
    image.metadata.push_back(entry);
  }
  image.nmetadata = static_cast<int32_t>(image.metadata.size());
  return image;
}

cv::Mat DecodeImage(const sirupp::image_t& image, const std::string& channel) {
  if (image.size < 0 || static_cast<size_t>(image.size) != image.data.size()) {
    throw core::MessageError(channel, "size",
                             std::to_string(image.size) + " does not match the " +
                                 std::to_string(image.data.size()) + " bytes sent");
  }
  if (image.width <= 0 || image.height <= 0 || image.width > 16384 || image.height > 16384) {
    throw core::MessageError(channel, "width, height",
                             Size(image) + " is outside 1..16384 pixels per side");
  }
  cv::Mat bgr;
  if (image.pixelformat == sirupp::image_t::PIXEL_FORMAT_MJPEG) {
    const cv::Mat bytes(1, image.size, CV_8UC1, const_cast<uint8_t*>(image.data.data()));
    bgr = image.size > 0 ? cv::imdecode(bytes, cv::IMREAD_COLOR) : cv::Mat();
    if (bgr.empty()) {
      throw core::MessageError(channel, "data",
                               std::to_string(image.size) + " bytes are not a JPEG image");
    }
    if (bgr.cols != image.width || bgr.rows != image.height) {
      throw core::MessageError(channel, "width, height",
                               Size(image) + " but the JPEG is " + std::to_string(bgr.cols) + "x" +
                                   std::to_string(bgr.rows));
    }
    return bgr;
  }
  int channels = 0;
  int conversion = -1;  // -1: copy as is
  const char* name = "";
  switch (image.pixelformat) {
    case sirupp::image_t::PIXEL_FORMAT_RGB:
      channels = 3, conversion = cv::COLOR_RGB2BGR, name = "RGB";
      break;
    case sirupp::image_t::PIXEL_FORMAT_BGR:
      channels = 3, name = "BGR";
      break;
    case sirupp::image_t::PIXEL_FORMAT_RGBA:
      channels = 4, conversion = cv::COLOR_RGBA2BGR, name = "RGBA";
      break;
    case sirupp::image_t::PIXEL_FORMAT_BGRA:
      channels = 4, conversion = cv::COLOR_BGRA2BGR, name = "BGRA";
      break;
    case sirupp::image_t::PIXEL_FORMAT_GRAY:
      channels = 1, conversion = cv::COLOR_GRAY2BGR, name = "GRAY";
      break;
    default:
      throw core::MessageError(channel, "pixelformat",
                               std::to_string(image.pixelformat) +
                                   " is not shown here; allowed: MJPEG, RGB, BGR, RGBA, BGRA, "
                                   "GRAY");
  }
  const int64_t row_bytes = static_cast<int64_t>(image.width) * channels;
  if (image.row_stride < row_bytes) {
    throw core::MessageError(channel, "row_stride",
                             std::to_string(image.row_stride) + " is less than " +
                                 std::to_string(row_bytes) + " bytes for " +
                                 std::to_string(image.width) + " " + name + " pixels");
  }
  const int64_t needed = static_cast<int64_t>(image.row_stride) * (image.height - 1) + row_bytes;
  if (image.size < needed) {
    throw core::MessageError(channel, "size",
                             std::to_string(image.size) + " bytes; " + Size(image) + " " + name +
                                 " with row_stride " + std::to_string(image.row_stride) +
                                 " needs " + std::to_string(needed));
  }
  const cv::Mat view(image.height, image.width, CV_8UC(channels),
                     const_cast<uint8_t*>(image.data.data()),
                     static_cast<size_t>(image.row_stride));
  if (conversion < 0) {
    bgr = view.clone();
  } else {
    cv::cvtColor(view, bgr, conversion);
  }
  return bgr;
}

std::optional<std::string> FindMetadata(const sirupp::image_t& image, const std::string& key) {
  for (const sirupp::image_metadata_t& entry : image.metadata) {
    if (entry.key == key) return std::string(entry.value.begin(), entry.value.end());
  }
  return std::nullopt;
}

}  // namespace sirupp::viewer
