#pragma once
// sirupp-viewer's logic over a core::Bus: keeps the newest model, environment and arm states,
// builds the scene (viewer/scene.hpp), renders it off-screen (viewer/osmesa_renderer.hpp) and
// sends the frames out.
//
// In:  ROBOT_MODEL, ENVIRONMENT (1 Hz from the sim; or given at start from files), SIM_ARM_STATE
//      (the virtual arm), ARM_SETPOINT (the ghost: servo_setpoint_t.position), REAL_ARM_STATE (the
//      real arm, drawn while its newest message is younger than real_fresh_s), CONTROLLER_STATUS
//      (mode and state for the overlay), VIEWER_CAMERA (camera, DH frames, ghost, snapshot).
// Out: VIEWER_IMAGE (image_t, JPEG as MJPG or raw RGB, metadata "seq", "tick", "camera", ...),
//      PNG files, a Motion-JPEG AVI video, HEARTBEAT.
//
// Frames: a frame clock ticks at rate_hz in wall time. On a tick, the scene is rendered again only
// when something drawn changed since the last frame (a state, the model, the camera, ...); the
// image is published when it was rendered anew, or when keepalive_s passed since the last one (so
// a viewer started late or a dropped datagram is soon made up for). The video gets one frame per
// tick (the last image when nothing changed), so its time runs with the wall clock. State messages
// only replace the held values: a 2 kHz SIM_ARM_STATE costs a decode and a copy, never a render.
//
// Bad input: a model the viewer cannot draw, an environment it refuses, a state or set-point with
// the wrong joint count or a non-finite position, a bad camera: the handler throws
// core::MessageError, the Bus counts it as rejected on that channel (HEARTBEAT's counters), the
// heartbeat turns "degraded" naming the last refusal for a few seconds, and the last good scene
// stays on screen.
//
// Single-threaded like the Bus; the OSMesa context lives on the thread that built the node.

#include <chrono>
#include <cstdint>
#include <memory>
#include <opencv2/core.hpp>
#include <optional>
#include <sirupp/arm_state_t.hpp>
#include <sirupp/controller_status_t.hpp>
#include <sirupp/environment_t.hpp>
#include <sirupp/image_t.hpp>
#include <sirupp/robot_model_t.hpp>
#include <sirupp/servo_setpoint_t.hpp>
#include <sirupp/viewer_camera_t.hpp>
#include <string>
#include <vector>

#include "core/arm_state.hpp"
#include "core/bus.hpp"
#include "core/channels.hpp"
#include "core/environment.hpp"
#include "core/errors.hpp"
#include "core/heartbeat.hpp"
#include "core/robot_model.hpp"
#include "core/tick_reader.hpp"
#include "viewer/camera.hpp"
#include "viewer/frame_outputs.hpp"
#include "viewer/image_codec.hpp"
#include "viewer/osmesa_renderer.hpp"
#include "viewer/scene.hpp"

namespace sirupp::viewer {

struct ViewerOptions {
  RenderOptions render;      // width, height (640x480), supersample, background
  double rate_hz = 10;       // frame clock, wall time
  double keepalive_s = 1.0;  // publish at least this often, even when nothing moves
  ImageFormat format = ImageFormat::kJpeg;
  int jpeg_quality = 80;
  bool publish_images = true;
  Camera camera;
  SceneOptions scene;
  double real_fresh_s = 0.5;  // REAL_ARM_STATE older than this is not drawn
  std::string png_dir;        // "" = no PNG files (and no snapshots)
  double png_every_s = 0;     // > 0: a PNG frame this often; 0: snapshots only
  std::string video_path;     // "" = no video; else a .avi file at rate_hz
  core::Channels channels;    // names without the rig prefix (the Bus adds it)
  std::string process_name = "sirupp-viewer";
};

// "" when the options can be used, else the first problem naming the setting, its value and what
// is allowed (flags and the config file are checked with it).
std::string OptionsProblem(const ViewerOptions& options);

struct ViewerStats {
  int64_t frames_rendered = 0;
  int64_t images_published = 0;
  int64_t video_frames = 0;
  int64_t png_frames = 0;
  int64_t snapshots = 0;
  int64_t refused = 0;       // messages refused by the viewer's own checks
  std::string last_refusal;  // what() of the latest refusal
  std::string last_png;      // path of the latest PNG written
  std::string output_error;  // the latest PNG that could not be written (disk full, ...)
  std::string model;         // name of the model drawn, "" before one arrived
};

class ViewerNode {
 public:
  // `model` / `environment`: what to draw until ROBOT_MODEL / ENVIRONMENT arrive (optional).
  // Creates the renderer, the PNG directory and the video file at once, so bad options fail here
  // (RenderError, std::runtime_error, std::invalid_argument), before any traffic is handled.
  ViewerNode(core::Bus& bus, ViewerOptions options,
             std::optional<core::RobotModel> model = std::nullopt,
             std::optional<core::Environment> environment = std::nullopt);
  ~ViewerNode();
  ViewerNode(const ViewerNode&) = delete;
  ViewerNode& operator=(const ViewerNode&) = delete;

  // Handles traffic for at most max_wait_ms (less when a frame falls due before), then makes the
  // frame if one is due, and publishes the heartbeat when due.
  void Service(int max_wait_ms);
  // Renders, publishes and writes a frame now, whatever the frame clock says (tests, benchmarks).
  void FrameNow();
  // Writes the next frame as DIR/snapshot-NNN.png; false (and nothing done) without --png DIR.
  bool RequestSnapshot();
  // Finalises the video file and sends a last heartbeat. Idempotent; the destructor calls it.
  void Close();

  ViewerStats stats() const { return stats_; }
  const cv::Mat& last_image() const { return image_; }
  const Scene& last_scene() const { return scene_; }
  const Camera& camera() const { return options_.camera; }
  bool has_model() const { return model_.has_value(); }
  const std::string& gl_description() const { return renderer_->gl_description(); }

 private:
  using Clock = std::chrono::steady_clock;

  void Subscribe();
  void Frame(Clock::time_point now, bool forced);
  void Render(Clock::time_point now);
  void Publish();
  [[noreturn]] void Refuse(const core::MessageError& error);
  // decode()'s value; a MessageError it throws is counted as this viewer's refusal and rethrown.
  template <class Decode>
  auto Checked(Decode&& decode) -> decltype(decode());
  // Refuses a joint count other than the model's (when one is known).
  void CheckJointCount(const std::string& channel, size_t count);
  void OnModel(const sirupp::robot_model_t& message, const core::ReceiveInfo& info);
  void OnEnvironment(const sirupp::environment_t& message, const core::ReceiveInfo& info);
  // Holds the state's positions in `held` (the virtual or the real arm's); returns the state.
  core::ArmState OnArmState(const sirupp::arm_state_t& message, const core::ReceiveInfo& info,
                            std::optional<std::vector<double>>& held);
  void OnSetpoint(const sirupp::servo_setpoint_t& message, const core::ReceiveInfo& info);
  void OnControllerStatus(const sirupp::controller_status_t& message,
                          const core::ReceiveInfo& info);
  void OnCamera(const sirupp::viewer_camera_t& message, const core::ReceiveInfo& info);
  std::string HeartbeatDetail() const;

  core::Bus& bus_;
  // On udpm: SIM_ARM_STATE, ARM_SETPOINT and REAL_ARM_STATE from a socket of the viewer's own,
  // each one's newest message per batch (core/tick_reader.hpp); LCM no longer wakes for them.
  std::unique_ptr<core::TickFeed> ticks_;
  ViewerOptions options_;
  core::Heartbeat heartbeat_;
  std::unique_ptr<OsmesaRenderer> renderer_;
  std::optional<PngDirectory> png_;
  std::unique_ptr<VideoFile> video_;

  std::optional<core::RobotModel> model_;
  std::optional<core::Environment> environment_;
  ViewState state_;  // real_position held here even when stale; Render decides
  Clock::time_point real_received_{};
  bool real_drawn_ = false;
  int8_t controller_mode_ = -1;
  int8_t controller_state_ = -1;

  bool dirty_ = true;
  bool snapshot_requested_ = false;
  Scene scene_;
  cv::Mat image_;
  int64_t image_seq_ = 0;
  Clock::duration period_;
  Clock::time_point next_frame_;
  Clock::time_point last_published_{};
  Clock::time_point next_png_{};
  Clock::time_point last_refusal_time_{};
  ViewerStats stats_;
  bool closed_ = false;
};

// One frame without a bus (sirupp-viewer --once, docs images, benchmarks): the scene of `state`
// seen by `camera`, as an 8-bit BGR image.
cv::Mat RenderStill(const core::RobotModel* model, const core::Environment* environment,
                    const ViewState& state, const Camera& camera, const SceneOptions& scene,
                    const RenderOptions& render);

// The controller_status_t mode and state as words for the overlay, e.g. "manual, moving".
std::string ControllerStatusText(int8_t mode, int8_t state);

}  // namespace sirupp::viewer
