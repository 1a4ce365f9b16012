#include "logger/plot.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

namespace sirupp::logger {

namespace {

constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;
const cv::Scalar kBlack(0, 0, 0);
const cv::Scalar kGrid(225, 225, 225);
const cv::Scalar kMarker(120, 120, 120);

cv::Scalar ToScalar(const PlotColor& color) { return cv::Scalar(color.b, color.g, color.r); }

std::string TickText(double value, double step) {
  char text[32];
  const int decimals = step >= 1 ? 0 : static_cast<int>(std::ceil(-std::log10(step) - 1e-9));
  std::snprintf(text, sizeof text, "%.*f", std::min(decimals, 6),
                std::abs(value) < step * 1e-6 ? 0.0 : value);
  return text;
}

void PutText(cv::Mat& image, const std::string& text, cv::Point at, double scale, int thickness = 1,
             const cv::Scalar& color = kBlack) {
  cv::putText(image, text, at, kFont, scale, color, thickness, cv::LINE_AA);
}

cv::Size TextSize(const std::string& text, double scale, int thickness = 1) {
  int baseline = 0;
  return cv::getTextSize(text, kFont, scale, thickness, &baseline);
}

void DashedLine(cv::Mat& image, cv::Point from, cv::Point to, const cv::Scalar& color) {
  const double length = std::hypot(to.x - from.x, to.y - from.y);
  const int dashes = std::max(1, static_cast<int>(length / 8));
  for (int i = 0; i < dashes; i += 2) {
    const double a = static_cast<double>(i) / dashes;
    const double b = std::min(1.0, static_cast<double>(i + 1) / dashes);
    cv::line(image, from + (to - from) * a, from + (to - from) * b, color, 1, cv::LINE_AA);
  }
}

}  // namespace

std::vector<double> NiceTicks(double low, double high, int count) {
  std::vector<double> ticks;
  if (!(high > low) || count < 2) return ticks;
  const double raw = (high - low) / (count - 1);
  const double magnitude = std::pow(10.0, std::floor(std::log10(raw)));
  double step = magnitude;
  for (double factor : {1.0, 2.0, 5.0, 10.0}) {
    step = factor * magnitude;
    if (step >= raw) break;
  }
  for (double tick = std::ceil(low / step - 1e-9) * step; tick <= high + step * 1e-9;
       tick += step) {
    ticks.push_back(tick);
  }
  return ticks;
}

namespace {

// The data range of a plot and the pixel rectangle it is drawn in.
struct Frame {
  double x_min = INFINITY, x_max = -INFINITY, y_min = INFINITY, y_max = -INFINITY;
  cv::Rect area;

  cv::Point2d ToPixel(double x, double y) const {
    return cv::Point2d(area.x + (x - x_min) / (x_max - x_min) * area.width,
                       area.y + area.height - (y - y_min) / (y_max - y_min) * area.height);
  }
};

// The finite points' range, widened where it is empty and padded by 5 % in y.
Frame FrameOf(const PlotSpec& spec, const std::string& path) {
  Frame f;
  for (const PlotSeries& series : spec.series) {
    for (size_t i = 0; i < series.x.size() && i < series.y.size(); ++i) {
      if (!std::isfinite(series.x[i]) || !std::isfinite(series.y[i])) continue;
      f.x_min = std::min(f.x_min, series.x[i]);
      f.x_max = std::max(f.x_max, series.x[i]);
      f.y_min = std::min(f.y_min, series.y[i]);
      f.y_max = std::max(f.y_max, series.y[i]);
    }
  }
  if (!std::isfinite(f.x_min)) throw std::runtime_error(path + ": nothing to plot (no data)");
  if (f.x_max - f.x_min < 1e-9) f.x_max = f.x_min + 1;
  if (f.y_max - f.y_min < 1e-9) {
    f.y_min -= 1;
    f.y_max += 1;
  }
  const double y_pad = 0.05 * (f.y_max - f.y_min);
  f.y_min -= y_pad;
  f.y_max += y_pad;
  const int left = 90, right = 30, top = 50, bottom = 70;
  f.area = cv::Rect(left, top, spec.width - left - right, spec.height - top - bottom);
  return f;
}

// Grid lines, ticks with their numbers, and the frame around the plot area.
void DrawAxes(cv::Mat& image, const Frame& f) {
  const cv::Rect& area = f.area;
  const std::vector<double> x_ticks = NiceTicks(f.x_min, f.x_max, 8);
  const std::vector<double> y_ticks = NiceTicks(f.y_min, f.y_max, 7);
  const double x_step = x_ticks.size() > 1 ? x_ticks[1] - x_ticks[0] : 1;
  const double y_step = y_ticks.size() > 1 ? y_ticks[1] - y_ticks[0] : 1;
  for (double tick : x_ticks) {
    const int px = static_cast<int>(std::lround(f.ToPixel(tick, f.y_min).x));
    cv::line(image, {px, area.y}, {px, area.y + area.height}, kGrid, 1);
    cv::line(image, {px, area.y + area.height}, {px, area.y + area.height + 5}, kBlack, 1);
    const std::string text = TickText(tick, x_step);
    PutText(image, text, {px - TextSize(text, 0.45).width / 2, area.y + area.height + 22}, 0.45);
  }
  for (double tick : y_ticks) {
    const int py = static_cast<int>(std::lround(f.ToPixel(f.x_min, tick).y));
    cv::line(image, {area.x, py}, {area.x + area.width, py}, kGrid, 1);
    cv::line(image, {area.x - 5, py}, {area.x, py}, kBlack, 1);
    const std::string text = TickText(tick, y_step);
    PutText(image, text, {area.x - 10 - TextSize(text, 0.45).width, py + 5}, 0.45);
  }
  cv::rectangle(image, area, kBlack, 1);
}

// The legend goes to the right-hand corner (top or bottom) with fewer points under it.
bool LegendOnTop(const PlotSpec& spec, const Frame& f) {
  int upper = 0, lower = 0;
  for (const PlotSeries& series : spec.series) {
    for (size_t i = 0; i < series.x.size() && i < series.y.size(); ++i) {
      if (!std::isfinite(series.x[i]) || !std::isfinite(series.y[i])) continue;
      if (series.x[i] < f.x_min + 0.6 * (f.x_max - f.x_min)) continue;
      const double height = (series.y[i] - f.y_min) / (f.y_max - f.y_min);
      upper += height > 0.7 ? 1 : 0;
      lower += height < 0.3 ? 1 : 0;
    }
  }
  return upper <= lower;
}

// Dashed vertical lines with their labels, on the side the legend leaves free.
void DrawMarkers(cv::Mat& image, const PlotSpec& spec, const Frame& f, bool legend_top) {
  const cv::Rect& area = f.area;
  int marker_row = 0;  // labels of neighbouring markers on different lines
  for (const PlotMarker& marker : spec.markers) {
    if (marker.x < f.x_min || marker.x > f.x_max) continue;
    const int px = static_cast<int>(std::lround(f.ToPixel(marker.x, f.y_min).x));
    DashedLine(image, {px, area.y}, {px, area.y + area.height}, kMarker);
    const int row = 14 * (marker_row++ % 3);
    PutText(image, marker.label,
            {px + 4, legend_top ? area.y + area.height - 8 - row : area.y + 14 + row}, 0.4, 1,
            kMarker);
  }
}

// Each series as lines through its finite points; a gap (non-finite point) breaks the line.
void DrawSeries(cv::Mat& image, const PlotSpec& spec, const Frame& f) {
  const cv::Rect& area = f.area;
  cv::Mat plot_area = image(area);
  for (const PlotSeries& series : spec.series) {
    std::vector<cv::Point> run;
    auto draw = [&] {
      if (run.size() >= 2) {
        cv::polylines(plot_area, run, false, ToScalar(series.color), 2, cv::LINE_AA);
      } else if (run.size() == 1) {
        cv::circle(plot_area, run[0], 2, ToScalar(series.color), cv::FILLED);
      }
      run.clear();
    };
    for (size_t i = 0; i < series.x.size() && i < series.y.size(); ++i) {
      if (!std::isfinite(series.x[i]) || !std::isfinite(series.y[i])) {
        draw();
        continue;
      }
      const cv::Point2d p = f.ToPixel(series.x[i], series.y[i]);
      const cv::Point point(static_cast<int>(std::lround(p.x)) - area.x,
                            static_cast<int>(std::lround(p.y)) - area.y);
      if (run.empty() || run.back() != point) run.push_back(point);
    }
    draw();
  }
}

// The title, the x label and the y label turned by 90 degrees.
void DrawLabels(cv::Mat& image, const PlotSpec& spec, const Frame& f) {
  const cv::Rect& area = f.area;
  PutText(image, spec.title, {(spec.width - TextSize(spec.title, 0.6, 2).width) / 2, 30}, 0.6, 2);
  PutText(image, spec.x_label,
          {area.x + (area.width - TextSize(spec.x_label, 0.5).width) / 2, spec.height - 18}, 0.5);
  const cv::Size size = TextSize(spec.y_label, 0.5);
  cv::Mat label(size.height + 10, size.width + 4, CV_8UC3, cv::Scalar(255, 255, 255));
  PutText(label, spec.y_label, {2, size.height + 2}, 0.5);
  cv::Mat rotated;
  cv::rotate(label, rotated, cv::ROTATE_90_COUNTERCLOCKWISE);
  const int y0 = std::max(0, area.y + (area.height - rotated.rows) / 2);
  const int rows = std::min(rotated.rows, spec.height - y0);
  rotated(cv::Rect(0, 0, rotated.cols, rows)).copyTo(image(cv::Rect(8, y0, rotated.cols, rows)));
}

// A boxed legend in the chosen right-hand corner: a line of each series' colour and its label.
void DrawLegend(cv::Mat& image, const PlotSpec& spec, const Frame& f, bool legend_top) {
  const cv::Rect& area = f.area;
  int legend_width = 0;
  for (const PlotSeries& series : spec.series) {
    legend_width = std::max(legend_width, TextSize(series.label, 0.45).width);
  }
  const int legend_height = 20 * static_cast<int>(spec.series.size());
  const int legend_x = area.x + area.width - legend_width - 50;
  int legend_y = legend_top ? area.y + 10 : area.y + area.height - legend_height - 10;
  cv::rectangle(image, {legend_x - 8, legend_y - 4},
                {area.x + area.width - 6, legend_y + 20 * static_cast<int>(spec.series.size())},
                cv::Scalar(255, 255, 255), cv::FILLED);
  cv::rectangle(image, {legend_x - 8, legend_y - 4},
                {area.x + area.width - 6, legend_y + 20 * static_cast<int>(spec.series.size())},
                kGrid, 1);
  for (const PlotSeries& series : spec.series) {
    cv::line(image, {legend_x, legend_y + 8}, {legend_x + 28, legend_y + 8}, ToScalar(series.color),
             2, cv::LINE_AA);
    PutText(image, series.label, {legend_x + 36, legend_y + 13}, 0.45);
    legend_y += 20;
  }
}

void Save(const cv::Mat& image, const std::string& path) {
  bool written = false;
  try {
    written = cv::imwrite(path, image);
  } catch (const cv::Exception& error) {
    throw std::runtime_error(path + ": cannot write the plot: " + error.what());
  }
  if (!written) throw std::runtime_error(path + ": cannot write the plot");
}

}  // namespace

void WritePlot(const PlotSpec& spec, const std::string& path) {
  const Frame frame = FrameOf(spec, path);
  cv::Mat image(spec.height, spec.width, CV_8UC3, cv::Scalar(255, 255, 255));
  DrawAxes(image, frame);
  const bool legend_top = LegendOnTop(spec, frame);
  DrawMarkers(image, spec, frame, legend_top);
  DrawSeries(image, spec, frame);
  DrawLabels(image, spec, frame);
  DrawLegend(image, spec, frame, legend_top);
  Save(image, path);
}

}  // namespace sirupp::logger
