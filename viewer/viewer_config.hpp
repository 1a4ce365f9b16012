#pragma once
// sirupp-viewer's optional settings file (--config FILE, YAML), read strictly with
// core/yaml_reader: unknown keys, wrong types and values out of range are a ConfigError naming
// file:line:column, the key and what is allowed. Every key is optional; command-line flags given
// with --config override the file. Example: config/viewer/default.yaml.
//
//   width: 640                 # pixels, 16..4096
//   height: 480
//   supersample: 2             # anti-aliasing factor, 1..4
//   rate_hz: 10                # frame clock, (0, 1000]
//   keepalive_s: 1.0           # publish at least this often
//   format: jpeg               # jpeg | rgb
//   quality: 80                # JPEG quality, 1..100
//   real_fresh_s: 0.5          # REAL_ARM_STATE older than this is not drawn
//   frames: false              # DH frames as axes
//   ghost: true                # the set-point ghost
//   floor: true                # floor and grid
//   camera: {azimuth_deg: -50, elevation_deg: 22, distance_m: 1.45, target_m: [0.18, 0, 0.3],
//            fov_deg: 40}

#include <string>

#include "viewer/viewer_node.hpp"

namespace sirupp::viewer {

// Applies the settings in `file` to `options` (keys absent from the file leave options as they
// are). Throws core::ConfigError.
void ApplyViewerConfig(const std::string& file, ViewerOptions& options);
// Same, from text (tests); `name` stands for the file in messages.
void ApplyViewerConfigText(const std::string& text, const std::string& name,
                           ViewerOptions& options);

}  // namespace sirupp::viewer
