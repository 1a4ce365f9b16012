#pragma once
// Files the viewer writes: PNG frames and snapshots into a directory, and a video file (Motion-JPEG
// in AVI, through OpenCV's own AVI writer, so no FFmpeg or GStreamer is involved).

#include <cstdint>
#include <memory>
#include <opencv2/core.hpp>
#include <stdexcept>
#include <string>

namespace cv {
class VideoWriter;
}

namespace sirupp::viewer {

// A PNG directory or a video file that cannot be made or written (names the path and why).
class OutputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// PNG files in one directory: DIR/frame-000001.png, DIR/snapshot-001.png.
class PngDirectory {
 public:
  // Creates the directory if needed; throws OutputError naming it when that fails.
  explicit PngDirectory(std::string dir);

  // Writes bgr as DIR/<stem>-<number, zero-padded to `digits`>.png; returns the path. Throws
  // OutputError naming the file when it cannot be written.
  std::string Write(const cv::Mat& bgr, const std::string& stem, int64_t number, int digits);

  const std::string& dir() const { return dir_; }

 private:
  std::string dir_;
};

// A Motion-JPEG AVI file at a fixed frame rate. The file is complete (index and header sizes
// written) only after Close(), which the destructor also calls.
class VideoFile {
 public:
  // `path` must end in ".avi". Throws std::invalid_argument for a bad name or frame rate,
  // OutputError when the file cannot be opened.
  VideoFile(std::string path, double frames_per_second, cv::Size size);
  ~VideoFile();
  VideoFile(const VideoFile&) = delete;
  VideoFile& operator=(const VideoFile&) = delete;

  void Write(const cv::Mat& bgr);
  void Close();

  const std::string& path() const { return path_; }
  int64_t frames() const { return frames_; }

 private:
  std::string path_;
  std::unique_ptr<cv::VideoWriter> writer_;
  int64_t frames_ = 0;
};

}  // namespace sirupp::viewer
