#include "viewer/viewer_config.hpp"

#include <cmath>

#include "core/yaml_reader.hpp"

namespace sirupp::viewer {

namespace {

constexpr double kDegToRad = M_PI / 180.0;

void Apply(const core::YamlDocument& document, ViewerOptions& options) {
  const core::YamlValue root = document.Root();
  if (root.IsNull()) return;  // an empty file changes nothing
  const core::YamlMap map =
      root.Map({"width", "height", "supersample", "rate_hz", "keepalive_s", "format", "quality",
                "real_fresh_s", "frames", "ghost", "floor", "camera"});
  if (auto value = map.Find("width")) {
    options.render.width = static_cast<int>(value->Integer(16, OsmesaRenderer::kMaxSize));
  }
  if (auto value = map.Find("height")) {
    options.render.height = static_cast<int>(value->Integer(16, OsmesaRenderer::kMaxSize));
  }
  if (auto value = map.Find("supersample")) {
    options.render.supersample = static_cast<int>(value->Integer(1, 4));
  }
  if (auto value = map.Find("rate_hz")) {
    core::NumberRule rule = core::NumberInRange(0, 1000, "Hz");
    rule.min_inclusive = false;
    options.rate_hz = value->Number(rule);
  }
  if (auto value = map.Find("keepalive_s")) {
    options.keepalive_s = value->Number(core::PositiveNumber("s"));
  }
  if (auto value = map.Find("format")) {
    options.format =
        value->Choice({"jpeg", "rgb"}) == "jpeg" ? ImageFormat::kJpeg : ImageFormat::kRgb;
  }
  if (auto value = map.Find("quality")) {
    options.jpeg_quality = static_cast<int>(value->Integer(1, 100));
  }
  if (auto value = map.Find("real_fresh_s")) {
    options.real_fresh_s = value->Number(core::PositiveNumber("s"));
  }
  if (auto value = map.Find("frames")) options.scene.show_frames = value->Bool();
  if (auto value = map.Find("ghost")) options.scene.show_ghost = value->Bool();
  if (auto value = map.Find("floor")) options.scene.show_floor = value->Bool();
  if (auto value = map.Find("camera")) {
    const core::YamlMap camera =
        value->Map({"azimuth_deg", "elevation_deg", "distance_m", "target_m", "fov_deg"});
    Camera& out = options.camera;
    if (auto angle = camera.Find("azimuth_deg")) {
      out.azimuth_rad = angle->Number(core::NumberInRange(-3600, 3600, "deg")) * kDegToRad;
    }
    if (auto angle = camera.Find("elevation_deg")) {
      out.elevation_rad = angle->Number(core::NumberInRange(-88.8, 88.8, "deg")) * kDegToRad;
    }
    if (auto distance = camera.Find("distance_m")) {
      core::NumberRule rule = core::NumberInRange(0, kMaxDistanceM, "m");
      rule.min_inclusive = false;
      out.distance_m = distance->Number(rule);
    }
    if (auto target = camera.Find("target_m")) {
      const std::vector<double> xyz = target->Numbers(3, core::AnyNumber("m"));
      out.target_m = Eigen::Vector3d(xyz[0], xyz[1], xyz[2]);
    }
    if (auto fov = camera.Find("fov_deg")) {
      out.fov_y_rad = fov->Number(core::NumberInRange(5, 150, "deg")) * kDegToRad;
    }
  }
}

}  // namespace

void ApplyViewerConfig(const std::string& file, ViewerOptions& options) {
  Apply(core::YamlDocument::Load(file), options);
}

void ApplyViewerConfigText(const std::string& text, const std::string& name,
                           ViewerOptions& options) {
  Apply(core::YamlDocument::Parse(text, name), options);
}

}  // namespace sirupp::viewer
