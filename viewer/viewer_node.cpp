#include "viewer/viewer_node.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sirupp/arm_state_t.hpp>
#include <sirupp/controller_status_t.hpp>
#include <sirupp/environment_t.hpp>
#include <sirupp/robot_model_t.hpp>
#include <sirupp/servo_setpoint_t.hpp>
#include <sirupp/viewer_camera_t.hpp>
#include <stdexcept>
#include <utility>

#include "core/errors.hpp"
#include "core/translate.hpp"

namespace sirupp::viewer {

namespace {

// A generous ceiling on what one frame is asked to draw; beyond it a message is refused rather
// than slowing every frame down.
constexpr size_t kMaxShapes = 20000;
constexpr int kMaxJoints = 64;
// How long the heartbeat reports "degraded" after a refused message.
constexpr double kDegradedAfterRefusalS = 5.0;
// Queue of the high-rate channels between two Handle() calls: a frame may take tens of
// milliseconds at 2 kHz of states.
constexpr int kStateQueue = 2000;

size_t ShapeCount(const core::RobotModel& model) {
  size_t count = 0;
  for (const core::Link& link : model.links) count += link.shapes.size();
  return count;
}

bool SameModel(const core::RobotModel& a, const core::RobotModel& b) {
  return a.name == b.name && a.source_hash == b.source_hash && a.num_joints() == b.num_joints() &&
         a.links.size() == b.links.size() && ShapeCount(a) == ShapeCount(b) &&
         a.base.position_m == b.base.position_m &&
         a.base.orientation.coeffs() == b.base.orientation.coeffs();
}

bool SameEnvironment(const core::Environment& a, const core::Environment& b) {
  if (a.name != b.name || a.objects.size() != b.objects.size()) return false;
  for (size_t i = 0; i < a.objects.size(); ++i) {
    const core::Shape& x = a.objects[i].shape;
    const core::Shape& y = b.objects[i].shape;
    if (x.type != y.type || x.size_m != y.size_m || x.rgba != y.rgba ||
        x.pose.position_m != y.pose.position_m ||
        x.pose.orientation.coeffs() != y.pose.orientation.coeffs()) {
      return false;
    }
  }
  return true;
}

std::string Degrees(double rad) {
  char text[32];
  std::snprintf(text, sizeof text, "%.1f", rad * 180.0 / M_PI);
  return text;
}

}  // namespace

std::string ControllerStatusText(int8_t mode, int8_t state) {
  std::string text;
  switch (mode) {
    case sirupp::controller_status_t::MODE_MANUAL:
      text = "manual";
      break;
    case sirupp::controller_status_t::MODE_AUTOMATIC:
      text = "automatic";
      break;
    default:
      return "";
  }
  static const char* const kStates[] = {"idle", "moving", "waiting", "paused", "fault", "off"};
  if (state >= 0 && state < 6) text += std::string(", ") + kStates[state];
  return text;
}

std::string OptionsProblem(const ViewerOptions& options) {
  using core::FormatNumber;
  const RenderOptions& render = options.render;
  if (render.width < 16 || render.width > OsmesaRenderer::kMaxSize) {
    return "width " + std::to_string(render.width) + ": allowed 16..4096 pixels";
  }
  if (render.height < 16 || render.height > OsmesaRenderer::kMaxSize) {
    return "height " + std::to_string(render.height) + ": allowed 16..4096 pixels";
  }
  if (render.supersample < 1 || render.supersample > 4) {
    return "supersample " + std::to_string(render.supersample) + ": allowed 1..4";
  }
  if (!(options.rate_hz > 0 && options.rate_hz <= 1000)) {
    return "rate " + FormatNumber(options.rate_hz) + " Hz: allowed > 0 and <= 1000";
  }
  if (options.jpeg_quality < 1 || options.jpeg_quality > 100) {
    return "quality " + std::to_string(options.jpeg_quality) + ": allowed 1..100";
  }
  if (!(options.keepalive_s > 0)) {
    return "keepalive " + FormatNumber(options.keepalive_s) + " s: must be > 0";
  }
  if (!(options.real_fresh_s > 0)) {
    return "real arm freshness " + FormatNumber(options.real_fresh_s) + " s: must be > 0";
  }
  if (!(options.png_every_s >= 0) || !std::isfinite(options.png_every_s)) {
    return "png-every " + FormatNumber(options.png_every_s) + " s: must be >= 0";
  }
  if (options.png_every_s > 0 && options.png_dir.empty()) {
    return "png-every needs a PNG directory (--png DIR)";
  }
  const std::string camera = CameraProblem(options.camera);
  if (!camera.empty()) return "camera " + camera;
  return "";
}

ViewerNode::ViewerNode(core::Bus& bus, ViewerOptions options, std::optional<core::RobotModel> model,
                       std::optional<core::Environment> environment)
    : bus_(bus),
      options_(std::move(options)),
      heartbeat_(bus, options_.process_name, options_.channels.heartbeat),
      model_(std::move(model)),
      environment_(std::move(environment)) {
  if (model_) stats_.model = model_->name;
  const std::string problem = OptionsProblem(options_);
  if (!problem.empty()) throw std::invalid_argument(problem);
  renderer_ = std::make_unique<OsmesaRenderer>(options_.render);
  if (!options_.png_dir.empty()) png_.emplace(options_.png_dir);
  if (!options_.video_path.empty()) {
    video_ = std::make_unique<VideoFile>(options_.video_path, options_.rate_hz,
                                         cv::Size(options_.render.width, options_.render.height));
  }
  period_ = std::chrono::duration_cast<Clock::duration>(
      std::chrono::duration<double>(1.0 / options_.rate_hz));
  next_frame_ = Clock::now();
  next_png_ = next_frame_;
  Subscribe();
  // Only the newest state is drawn: the older ones of a batch are never decoded.
  ticks_ = core::TickFeed::Open(bus_,
                                {bus_.FullName(options_.channels.sim_arm_state),
                                 bus_.FullName(options_.channels.arm_setpoint),
                                 bus_.FullName(options_.channels.real_arm_state),
                                 bus_.FullName(options_.channels.sim_arm_ticks)},
                                options_.process_name);
  heartbeat_.Publish(core::ProcessState::kStarting, HeartbeatDetail());
}

ViewerNode::~ViewerNode() {
  try {
    Close();
  } catch (const std::exception&) {  // a failing last heartbeat must not end the process here
  }
}

void ViewerNode::Refuse(const core::MessageError& error) {
  ++stats_.refused;
  stats_.last_refusal = error.what();
  last_refusal_time_ = Clock::now();
  throw error;
}

template <class Decode>
auto ViewerNode::Checked(Decode&& decode) -> decltype(decode()) {
  try {
    return decode();
  } catch (const core::MessageError& error) {
    Refuse(error);
  }
}

void ViewerNode::CheckJointCount(const std::string& channel, size_t count) {
  if (model_)
    Checked([&] { core::CheckJointCount(channel, "num_joints", count, model_->num_joints()); });
}

void ViewerNode::Subscribe() {
  // Each message is decoded by its core/translate.hpp pair; what this viewer can draw (and the
  // model's joint count) is checked here, in the same words.
  const core::Channels& channels = options_.channels;
  using Info = core::ReceiveInfo;
  bus_.Subscribe<sirupp::robot_model_t>(
      channels.robot_model,
      [this](const sirupp::robot_model_t& message, const Info& info) { OnModel(message, info); });
  bus_.Subscribe<sirupp::environment_t>(
      channels.environment, [this](const sirupp::environment_t& message, const Info& info) {
        OnEnvironment(message, info);
      });
  bus_.Subscribe<sirupp::arm_state_t>(
      channels.sim_arm_state,
      [this](const sirupp::arm_state_t& message, const Info& info) {
        const core::ArmState arm = OnArmState(message, info, state_.virtual_position);
        state_.utime = arm.utime;
        state_.tick = arm.tick;
      },
      kStateQueue);
  bus_.Subscribe<sirupp::servo_setpoint_t>(
      channels.arm_setpoint,
      [this](const sirupp::servo_setpoint_t& message, const Info& info) {
        OnSetpoint(message, info);
      },
      kStateQueue);
  bus_.Subscribe<sirupp::arm_state_t>(
      channels.real_arm_state,
      [this](const sirupp::arm_state_t& message, const Info& info) {
        OnArmState(message, info, state_.real_position);
        real_received_ = Clock::now();
      },
      kStateQueue);
  bus_.Subscribe<sirupp::controller_status_t>(
      channels.controller_status, [this](const sirupp::controller_status_t& message,
                                         const Info& info) { OnControllerStatus(message, info); });
  bus_.Subscribe<sirupp::viewer_camera_t>(
      channels.viewer_camera, [this](const sirupp::viewer_camera_t& message, const Info& info) {
        OnCamera(message, info);
      });
}

void ViewerNode::OnModel(const sirupp::robot_model_t& message, const core::ReceiveInfo& info) {
  core::RobotModel model =
      Checked([&] { return core::RobotModelFromMessage(message, info.channel); });
  if (model.num_joints() < 1 || model.num_joints() > kMaxJoints) {
    Checked([&] {
      core::RefuseValue(info.channel, "num_joints", std::to_string(model.num_joints()),
                        "1.." + std::to_string(kMaxJoints) + " (joints this viewer can draw)");
    });
  }
  if (ShapeCount(model) > kMaxShapes) {
    Checked([&] {
      core::RefuseValue(info.channel, "links[].shapes",
                        std::to_string(ShapeCount(model)) + " shapes",
                        "at most " + std::to_string(kMaxShapes) + " (shapes this viewer can draw)");
    });
  }
  if (model_ && SameModel(*model_, model)) return;
  model_ = std::move(model);
  stats_.model = model_->name;
  // Held positions of another joint count belong to the previous model.
  for (auto* held : {&state_.virtual_position, &state_.setpoint_position, &state_.real_position}) {
    if (*held && static_cast<int>((*held)->size()) != model_->num_joints()) held->reset();
  }
  dirty_ = true;
}

void ViewerNode::OnEnvironment(const sirupp::environment_t& message,
                               const core::ReceiveInfo& info) {
  // Before decoding: a huge message is refused without building its objects.
  if (message.num_objects > static_cast<int32_t>(kMaxShapes)) {
    Checked([&] {
      core::RefuseValue(
          info.channel, "num_objects", std::to_string(message.num_objects),
          "at most " + std::to_string(kMaxShapes) + " (objects this viewer can draw)");
    });
  }
  core::Environment environment =
      Checked([&] { return core::EnvironmentFromMessage(message, info.channel); });
  if (environment_ && SameEnvironment(*environment_, environment)) return;
  environment_ = std::move(environment);
  dirty_ = true;
}

core::ArmState ViewerNode::OnArmState(const sirupp::arm_state_t& message,
                                      const core::ReceiveInfo& info,
                                      std::optional<std::vector<double>>& held) {
  core::ArmState arm =
      Checked([&] { return core::ArmStateFromMessage(message, info.channel, -1); });
  CheckJointCount(info.channel, arm.position.size());
  held = arm.position;
  dirty_ = true;
  return arm;
}

void ViewerNode::OnSetpoint(const sirupp::servo_setpoint_t& message,
                            const core::ReceiveInfo& info) {
  const core::ServoSetpoint setpoint =
      Checked([&] { return core::ServoSetpointFromMessage(message, info.channel); });
  CheckJointCount(info.channel, setpoint.joints.size());
  if (!state_.setpoint_position) state_.setpoint_position.emplace();
  state_.setpoint_position->clear();
  for (const core::JointSetpoint& joint : setpoint.joints) {
    state_.setpoint_position->push_back(joint.position);
  }
  if (options_.scene.show_ghost) dirty_ = true;
}

void ViewerNode::OnControllerStatus(const sirupp::controller_status_t& message,
                                    const core::ReceiveInfo& info) {
  const core::ControllerStatus status =
      Checked([&] { return core::ControllerStatusFromMessage(message, info.channel); });
  const auto mode = static_cast<int8_t>(status.mode);
  const auto state = static_cast<int8_t>(status.state);
  if (mode == controller_mode_ && state == controller_state_) return;
  controller_mode_ = mode;
  controller_state_ = state;
  state_.status_text = ControllerStatusText(mode, state);
  dirty_ = true;
}

void ViewerNode::OnCamera(const sirupp::viewer_camera_t& message, const core::ReceiveInfo& info) {
  const core::ViewerCamera command =
      Checked([&] { return core::ViewerCameraFromMessage(message, info.channel); });
  Camera camera = options_.camera;
  if (command.set_camera) {
    // Finite values are core's check; the ranges this camera can take are ours.
    if (std::abs(command.elevation) > kMaxElevationRad) {
      Checked([&] {
        core::RefuseValue(info.channel, "elevation", core::FormatNumber(command.elevation),
                          "[-" + core::FormatNumber(kMaxElevationRad) + ", " +
                              core::FormatNumber(kMaxElevationRad) + "] rad (about +-89 degrees)");
      });
    }
    if (command.distance > kMaxDistanceM) {
      Checked([&] {
        core::RefuseValue(info.channel, "distance", core::FormatNumber(command.distance),
                          "(0, " + core::FormatNumber(kMaxDistanceM) + "] m");
      });
    }
    camera.azimuth_rad = command.azimuth;
    camera.elevation_rad = command.elevation;
    camera.distance_m = command.distance;
    camera.target_m = command.target;
  }
  if (command.snapshot && !png_) {
    Checked([&] {
      core::RefuseValue(info.channel, "snapshot", "1",
                        "0: this viewer writes no PNG files (start it with --png DIR)");
    });
  }
  options_.camera = camera;
  auto apply = [](core::Switch value, bool& flag) {
    if (value == core::Switch::kOn) flag = true;
    if (value == core::Switch::kOff) flag = false;
  };
  apply(command.show_frames, options_.scene.show_frames);
  apply(command.show_ghost, options_.scene.show_ghost);
  if (command.snapshot) snapshot_requested_ = true;
  dirty_ = true;
}

void ViewerNode::Service(int max_wait_ms) {
  Clock::time_point now = Clock::now();
  const auto until_frame =
      std::chrono::duration_cast<std::chrono::milliseconds>(next_frame_ - now).count();
  // The states are drawn only at frame times: they are taken in batches, one wake-up per
  // kBatchMs rather than one per message (which left less CPU to the lockstep loop). At 30 000
  // states a second a batch is 300 of the kStateQueue LCM holds.
  constexpr int64_t kBatchMs = 10;
  const int wait_ms = static_cast<int>(
      std::clamp<int64_t>(until_frame, 0, std::min<int64_t>(max_wait_ms, kBatchMs)));
  bus_.HandleBatched(wait_ms);
  if (ticks_) ticks_->DeliverNewest();
  now = Clock::now();
  if (now >= next_frame_) {
    Frame(now, false);
    next_frame_ += period_;
    if (next_frame_ <= now) next_frame_ = now + period_;  // fell behind: do not catch up in a burst
  }
  const bool degraded =
      !stats_.output_error.empty() ||
      (stats_.refused > 0 &&
       std::chrono::duration<double>(now - last_refusal_time_).count() < kDegradedAfterRefusalS);
  heartbeat_.PublishIfDue(degraded ? core::ProcessState::kDegraded : core::ProcessState::kRunning,
                          HeartbeatDetail());
}

void ViewerNode::FrameNow() {
  dirty_ = true;
  Frame(Clock::now(), true);
}

bool ViewerNode::RequestSnapshot() {
  if (!png_) return false;
  snapshot_requested_ = true;
  return true;
}

void ViewerNode::Frame(Clock::time_point now, bool forced) {
  const bool real_fresh =
      state_.real_position.has_value() &&
      std::chrono::duration<double>(now - real_received_).count() <= options_.real_fresh_s;
  if (real_fresh != real_drawn_) dirty_ = true;
  const bool rendered = dirty_ || image_.empty() || snapshot_requested_;
  if (rendered) Render(now);
  const bool keepalive_due =
      std::chrono::duration<double>(now - last_published_).count() >= options_.keepalive_s;
  if (options_.publish_images && (rendered || keepalive_due || forced)) {
    Publish();
    last_published_ = now;
  }
  if (video_) {
    video_->Write(image_);
    ++stats_.video_frames;
  }
  // A PNG that cannot be written (disk full) is reported on the heartbeat; the images on LCM and
  // the video go on.
  if (png_ && options_.png_every_s > 0 && now >= next_png_) {
    try {
      stats_.last_png = png_->Write(image_, "frame", stats_.png_frames + 1, 6);
      ++stats_.png_frames;
    } catch (const OutputError& error) {
      stats_.output_error = error.what();
    }
    next_png_ += std::chrono::duration_cast<Clock::duration>(
        std::chrono::duration<double>(options_.png_every_s));
    if (next_png_ <= now) {
      next_png_ = now + std::chrono::duration_cast<Clock::duration>(
                            std::chrono::duration<double>(options_.png_every_s));
    }
  }
  if (snapshot_requested_ && png_) {
    snapshot_requested_ = false;
    try {
      stats_.last_png = png_->Write(image_, "snapshot", stats_.snapshots + 1, 3);
      ++stats_.snapshots;
    } catch (const OutputError& error) {
      stats_.output_error = error.what();
    }
  }
}

void ViewerNode::Render(Clock::time_point now) {
  ViewState shown = state_;
  real_drawn_ =
      state_.real_position.has_value() &&
      std::chrono::duration<double>(now - real_received_).count() <= options_.real_fresh_s;
  if (!real_drawn_) shown.real_position.reset();
  scene_ = BuildScene(model_ ? &*model_ : nullptr, environment_ ? &*environment_ : nullptr, shown,
                      options_.scene);
  image_ = renderer_->Render(scene_, options_.camera).clone();
  ++stats_.frames_rendered;
  dirty_ = false;
}

void ViewerNode::Publish() {
  const Camera& camera = options_.camera;
  char camera_text[160];
  std::snprintf(camera_text, sizeof camera_text, "%s %s %.4g %.4g %.4g %.4g",
                Degrees(camera.azimuth_rad).c_str(), Degrees(camera.elevation_rad).c_str(),
                camera.distance_m, camera.target_m.x(), camera.target_m.y(), camera.target_m.z());
  const Metadata metadata = {
      {"seq", std::to_string(image_seq_)},
      {"tick", std::to_string(state_.tick)},
      {"camera", camera_text},
      {"frames", options_.scene.show_frames ? "1" : "0"},
      {"ghost", options_.scene.show_ghost ? "1" : "0"},
      {"model", model_ ? model_->name : ""},
  };
  const sirupp::image_t message =
      EncodeImage(image_, options_.format, options_.jpeg_quality, state_.utime, metadata);
  bus_.Publish(options_.channels.viewer_image, message);
  ++image_seq_;
  ++stats_.images_published;
}

std::string ViewerNode::HeartbeatDetail() const {
  std::string detail =
      std::to_string(options_.render.width) + "x" + std::to_string(options_.render.height) + " " +
      ImageFormatName(options_.format) + ", " + std::to_string(stats_.images_published) + " images";
  if (video_) detail += ", video " + std::to_string(stats_.video_frames) + " frames";
  detail += model_ ? ", model " + model_->name : ", waiting for ROBOT_MODEL";
  const bool recent = stats_.refused > 0 &&
                      std::chrono::duration<double>(Clock::now() - last_refusal_time_).count() <
                          kDegradedAfterRefusalS;
  if (recent) detail += "; refused: " + stats_.last_refusal;
  if (!stats_.output_error.empty()) detail += "; " + stats_.output_error;
  return detail;
}

void ViewerNode::Close() {
  if (closed_) return;
  closed_ = true;
  if (video_) video_->Close();
  heartbeat_.Publish(core::ProcessState::kStopping, HeartbeatDetail());
}

cv::Mat RenderStill(const core::RobotModel* model, const core::Environment* environment,
                    const ViewState& state, const Camera& camera, const SceneOptions& scene,
                    const RenderOptions& render) {
  OsmesaRenderer renderer(render);
  return renderer.Render(BuildScene(model, environment, state, scene), camera).clone();
}

}  // namespace sirupp::viewer
