#pragma once
// Draws a Scene (viewer/scene.hpp) off-screen with OSMesa (Mesa's software rasteriser: no GPU, no
// display) and returns the image with the overlay text. It only draws: every decision about what is
// in the picture is the scene builder's.
//
// Pipeline: fixed-function OpenGL 1.x in an OSMesa context of (width x height) x supersample
// pixels; two directional lights fixed to the camera; depth test; opaque shapes, then the real arm
// pushed slightly back (so that where it coincides with the virtual arm the virtual one shows),
// then translucent shapes (ghost) with a depth pre-pass so only their front surfaces blend; then
// lines. Anti-aliasing by supersampling: the frame is drawn `supersample` times larger in each
// direction and averaged down (cv::INTER_AREA). The overlay is drawn on the final image with
// OpenCV's Hershey font.
//
// Threads: an OSMesa context is current on one thread at a time; use a renderer from one thread.
// Several renderers may live in one process (each Render makes its own context current).

#include <memory>
#include <opencv2/core.hpp>

#include "viewer/camera.hpp"
#include "viewer/scene.hpp"

namespace sirupp::viewer {

struct RenderOptions {
  int width = 640;  // of the image returned, pixels
  int height = 480;
  int supersample = 2;  // 1 (none) .. 4
  Rgba background{{0.93F, 0.95F, 0.98F, 1.0F}};
  bool overlay = true;  // draw Scene::overlay
};

// Thrown when OSMesa cannot make a context or the options are out of range.
class RenderError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class OsmesaRenderer {
 public:
  // Limits of width and height, pixels (OSMesa's own maximum is larger).
  static constexpr int kMaxSize = 4096;

  explicit OsmesaRenderer(const RenderOptions& options);
  ~OsmesaRenderer();
  OsmesaRenderer(const OsmesaRenderer&) = delete;
  OsmesaRenderer& operator=(const OsmesaRenderer&) = delete;

  // Draws `scene` seen by `camera`; returns an 8-bit BGR image of width x height (valid until the
  // next call).
  const cv::Mat& Render(const Scene& scene, const Camera& camera);

  const RenderOptions& options() const { return options_; }
  // "Mesa 22.3.6 llvmpipe (LLVM 15.0.6, 256 bits)": what GL_VERSION and GL_RENDERER report.
  const std::string& gl_description() const { return gl_description_; }

 private:
  struct Impl;
  RenderOptions options_;
  std::unique_ptr<Impl> impl_;
  std::string gl_description_;
};

// Draws text lines in the top-left corner of `image` (white on a dark outline), scaled to the
// image height. Used by the renderer for Scene::overlay.
void DrawOverlay(cv::Mat& image, const std::vector<std::string>& lines);

}  // namespace sirupp::viewer
