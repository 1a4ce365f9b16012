#include "viewer/frame_outputs.hpp"

#include <cstdio>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>
#include <stdexcept>
#include <utility>

#include "core/errors.hpp"

namespace sirupp::viewer {

PngDirectory::PngDirectory(std::string dir) : dir_(std::move(dir)) {
  namespace fs = std::filesystem;
  std::error_code error;
  fs::create_directories(dir_, error);
  if (!fs::is_directory(dir_)) {
    throw OutputError(dir_ + ": cannot create the directory" +
                      (error ? ": " + error.message() : ""));
  }
}

std::string PngDirectory::Write(const cv::Mat& bgr, const std::string& stem, int64_t number,
                                int digits) {
  char name[64];
  std::snprintf(name, sizeof name, "-%0*lld.png", digits, static_cast<long long>(number));
  const std::string path = (std::filesystem::path(dir_) / (stem + name)).string();
  bool written = false;
  try {
    written = cv::imwrite(path, bgr);
  } catch (const cv::Exception& error) {
    throw OutputError(path + ": cannot write the PNG: " + error.what());
  }
  if (!written) throw OutputError(path + ": cannot write the PNG");
  return path;
}

VideoFile::VideoFile(std::string path, double frames_per_second, cv::Size size)
    : path_(std::move(path)) {
  const std::string extension = std::filesystem::path(path_).extension().string();
  if (extension != ".avi") {
    throw std::invalid_argument("video file " + path_ +
                                ": the name must end in .avi (Motion-JPEG in AVI)");
  }
  if (!(frames_per_second > 0 && frames_per_second <= 1000)) {
    throw std::invalid_argument("video frame rate " + core::FormatNumber(frames_per_second) +
                                " is outside (0, 1000]");
  }
  writer_ = std::make_unique<cv::VideoWriter>();
  bool opened = false;
  try {
    opened = writer_->open(path_, cv::CAP_OPENCV_MJPEG, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'),
                           frames_per_second, size, true);
  } catch (const cv::Exception& error) {
    throw OutputError(path_ + ": cannot open the video file: " + error.what());
  }
  if (!opened) throw OutputError(path_ + ": cannot open the video file for writing");
}

VideoFile::~VideoFile() { Close(); }

void VideoFile::Write(const cv::Mat& bgr) {
  if (!writer_) return;
  writer_->write(bgr);
  ++frames_;
}

void VideoFile::Close() {
  if (!writer_) return;
  writer_->release();
  writer_.reset();
}

}  // namespace sirupp::viewer
