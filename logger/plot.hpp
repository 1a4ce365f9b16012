#pragma once
// Line plots as PNG files, drawn with OpenCV (core, imgproc, imgcodecs): axes with ticks and
// numbers, axis labels with units, a title, a legend, and optional vertical markers. NaN values
// break a line (an empty cell is a gap, not a zero).

#include <cstdint>
#include <string>
#include <vector>

namespace sirupp::logger {

struct PlotColor {
  uint8_t r = 0, g = 0, b = 0;
};

struct PlotSeries {
  std::string label;
  std::vector<double> x, y;
  PlotColor color;
};

struct PlotMarker {
  double x = 0;
  std::string label;
};

struct PlotSpec {
  std::string title;
  std::string x_label;  // with the unit, e.g. "time since the move command (s)"
  std::string y_label;
  std::vector<PlotSeries> series;
  std::vector<PlotMarker> markers;  // dashed vertical lines
  int width = 1000;
  int height = 560;
};

// Draws and writes `path` (PNG). Throws std::runtime_error naming the path if it cannot be
// written, or if no series has a finite point.
void WritePlot(const PlotSpec& spec, const std::string& path);

// "Nice" tick positions (1, 2, 5 x 10^k steps) covering [low, high], about `count` of them.
std::vector<double> NiceTicks(double low, double high, int count);

}  // namespace sirupp::logger
