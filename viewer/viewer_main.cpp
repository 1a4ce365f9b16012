// sirupp-viewer: renders the arm, its set-point ghost, the real arm and the environment off-screen
// (OSMesa) and sends the images on VIEWER_IMAGE, as PNG files and as a video. Thin main over
// viewer/viewer_node.hpp; --once renders a single frame from joint values, without LCM.

#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <filesystem>
#include <iostream>
#include <opencv2/imgcodecs.hpp>
#include <optional>
#include <string>
#include <vector>

#include "core/bus.hpp"
#include "core/environment.hpp"
#include "core/errors.hpp"
#include "core/model_loader.hpp"
#include "runtime/args.hpp"
#include "runtime/data_path.hpp"
#include "runtime/joint_args.hpp"
#include "runtime/process_main.hpp"
#include "viewer/viewer_config.hpp"
#include "viewer/viewer_node.hpp"

namespace {

using sirupp::runtime::Flag;

using sirupp::core::FormatNumber;
using sirupp::core::UsageError;
using sirupp::runtime::Args;
namespace viewer = sirupp::viewer;

constexpr double kDegToRad = M_PI / 180.0;

constexpr const char* kAbout =
    "Renders the virtual arm (SIM_ARM_STATE), its set-point ghost (ARM_SETPOINT), the real arm\n"
    "(REAL_ARM_STATE, while fresh) and the environment off-screen with OSMesa (no GPU, no\n"
    "display needed) and publishes the frames as image_t on VIEWER_IMAGE: JPEG (MJPG, default)\n"
    "or raw RGB, W x H (640x480), at most HZ frames per second (10) of wall time, a frame only\n"
    "when something drawn changed and at least one every --keepalive S (1). The model and\n"
    "environment come from ROBOT_MODEL and ENVIRONMENT (start before or after the sim);\n"
    "--model/--environment files are drawn until those arrive. Camera: azimuth and elevation in\n"
    "degrees about the target (X Y Z, metres), distance in metres; VIEWER_CAMERA changes it at\n"
    "run time (`sirupp view` keys). --png DIR: snapshots (VIEWER_CAMERA, or kill -USR1) and, with\n"
    "--png-every S, a frame every S seconds. --video FILE.avi: Motion-JPEG at HZ, finalised on\n"
    "Ctrl-C, SIGTERM or the end of --duration. --supersample N: anti-aliasing (2).\n"
    "--once renders one frame to OUT.png (joint values as everywhere: revolute in degrees,\n"
    "prismatic in metres, docs/command-line.md; default model the PUMA 260, home pose) and\n"
    "exits. See viewer/README.md.\n";

std::atomic<int> g_snapshot_signals{0};
extern "C" void OnSnapshotSignal(int /*signal*/) { ++g_snapshot_signals; }

int WholeNumber(const Args& args, const std::string& flag, int min, int max) {
  const double value = args.Numbers(flag, 1)[0];
  if (value != std::floor(value) || value < min || value > max) {
    throw UsageError("sirupp-viewer: --" + flag + " " + FormatNumber(value) +
                     ": allowed whole numbers " + std::to_string(min) + ".." + std::to_string(max));
  }
  return static_cast<int>(value);
}

double PositiveNumber(const Args& args, const std::string& flag, const std::string& unit) {
  const double value = args.Numbers(flag, 1)[0];
  if (!(value > 0)) {
    throw UsageError("sirupp-viewer: --" + flag + " " + FormatNumber(value) + ": must be > 0 " +
                     unit);
  }
  return value;
}

viewer::ViewerOptions OptionsFromArgs(const Args& args) {
  viewer::ViewerOptions options;
  if (args.Has("config")) {
    viewer::ApplyViewerConfig(sirupp::runtime::ResolveDataPath(args.String("config")), options);
  }
  if (args.Has("width")) options.render.width = WholeNumber(args, "width", 16, 4096);
  if (args.Has("height")) options.render.height = WholeNumber(args, "height", 16, 4096);
  if (args.Has("supersample")) options.render.supersample = WholeNumber(args, "supersample", 1, 4);
  if (args.Has("rate")) {
    options.rate_hz = PositiveNumber(args, "rate", "Hz");
    if (options.rate_hz > 1000) {
      throw UsageError("sirupp-viewer: --rate " + FormatNumber(options.rate_hz) +
                       ": allowed > 0 and <= 1000 Hz");
    }
  }
  if (args.Has("keepalive")) options.keepalive_s = PositiveNumber(args, "keepalive", "s");
  if (args.Has("real-fresh")) options.real_fresh_s = PositiveNumber(args, "real-fresh", "s");
  if (args.Has("format")) {
    const std::string format = args.String("format");
    if (format != "jpeg" && format != "rgb") {
      throw UsageError("sirupp-viewer: --format '" + format +
                       "' is not allowed; allowed: jpeg, rgb");
    }
    options.format = format == "jpeg" ? viewer::ImageFormat::kJpeg : viewer::ImageFormat::kRgb;
  }
  if (args.Has("quality")) options.jpeg_quality = WholeNumber(args, "quality", 1, 100);
  if (args.Has("png")) options.png_dir = args.String("png");
  if (args.Has("png-every")) {
    if (!args.Has("png")) throw UsageError("sirupp-viewer: --png-every needs --png DIR");
    options.png_every_s = PositiveNumber(args, "png-every", "s");
  }
  if (args.Has("video")) {
    options.video_path = args.String("video");
    if (std::filesystem::path(options.video_path).extension() != ".avi") {
      throw UsageError("sirupp-viewer: --video '" + options.video_path +
                       "': the file name must end in .avi (Motion-JPEG in AVI)");
    }
  }
  if (args.Has("camera")) {
    const std::vector<double> camera = args.Numbers("camera", 3);
    options.camera.azimuth_rad = camera[0] * kDegToRad;
    options.camera.elevation_rad = camera[1] * kDegToRad;
    options.camera.distance_m = camera[2];
    if (std::abs(camera[1]) > 88.8) {
      throw UsageError("sirupp-viewer: --camera elevation " + FormatNumber(camera[1]) +
                       " deg: allowed -88.8..88.8");
    }
    if (!(camera[2] > 0 && camera[2] <= viewer::kMaxDistanceM)) {
      throw UsageError("sirupp-viewer: --camera distance " + FormatNumber(camera[2]) +
                       " m: allowed > 0 and <= 100");
    }
  }
  if (args.Has("target")) {
    const std::vector<double> target = args.Numbers("target", 3);
    options.camera.target_m = Eigen::Vector3d(target[0], target[1], target[2]);
  }
  if (args.Has("fov")) {
    const double fov = args.Numbers("fov", 1)[0];
    if (!(fov >= 5 && fov <= 150)) {
      throw UsageError("sirupp-viewer: --fov " + FormatNumber(fov) + ": allowed 5..150 degrees");
    }
    options.camera.fov_y_rad = fov * kDegToRad;
  }
  if (args.Switch("axes")) options.scene.show_frames = true;
  if (args.Switch("no-ghost")) options.scene.show_ghost = false;
  if (args.Switch("no-floor")) options.scene.show_floor = false;
  const std::string problem = viewer::OptionsProblem(options);
  if (!problem.empty()) throw UsageError("sirupp-viewer: " + problem);
  return options;
}

int RenderOnce(const Args& args, const viewer::ViewerOptions& options) {
  const std::string out = args.String("once");
  if (std::filesystem::path(out).extension() != ".png") {
    throw UsageError("sirupp-viewer: --once '" + out + "': the file name must end in .png");
  }
  const sirupp::core::RobotModel model =
      sirupp::core::LoadRobotModel(sirupp::runtime::ModelFileArg(args));
  std::optional<sirupp::core::Environment> environment;
  if (args.Has("environment")) {
    environment =
        sirupp::core::LoadEnvironment(sirupp::runtime::ResolveDataPath(args.String("environment")));
  }
  viewer::ViewState state;
  state.virtual_position = sirupp::runtime::DegreesArg(args, "deg", model);
  state.setpoint_position = sirupp::runtime::DegreesArg(args, "ghost-deg", model);
  state.real_position = sirupp::runtime::DegreesArg(args, "real-deg", model);
  const cv::Mat image = viewer::RenderStill(&model, environment ? &*environment : nullptr, state,
                                            options.camera, options.scene, options.render);
  if (!cv::imwrite(out, image)) throw std::runtime_error(out + ": cannot write the PNG");
  std::cerr << "sirupp-viewer: wrote " << out << " (" << image.cols << "x" << image.rows << ")\n";
  return 0;
}

int Run(const std::vector<std::string>& argv) {
  const Args args(
      argv, "sirupp-viewer",
      {Flag("width", "image width in pixels (640)").Takes("W"),
       Flag("height", "image height in pixels (480)").Takes("H"),
       Flag("rate", "at most this many frames per second of wall time (10)").Takes("HZ"),
       Flag("keepalive", "a frame at least every S seconds even when nothing changed (1)")
           .Takes("S"),
       Flag("format", "frame encoding on VIEWER_IMAGE (jpeg)").Takes("MODE").OneOf({"jpeg", "rgb"}),
       Flag("quality", "JPEG quality 1..100").Takes("Q"),
       Flag("supersample", "anti-aliasing factor (2)").Takes("N"),
       Flag("png", "folder for PNG snapshots").Takes("DIR"),
       Flag("png-every", "with --png: a snapshot every S seconds").Takes("S"),
       Flag("video", "record Motion-JPEG at HZ, finalised on exit").Takes("FILE.avi"),
       Flag("camera", "azimuth and elevation (deg) about the target, distance (m)")
           .Takes("AZ EL DIST", 3),
       Flag("target", "the point the camera looks at, metres").Takes("X Y Z", 3),
       Flag("fov", "vertical field of view, degrees").Takes("DEG"),
       Flag("axes", "draw each joint frame's axes").Switch(),
       Flag("no-ghost", "do not draw the set-point ghost").Switch(),
       Flag("no-floor", "do not draw the floor").Switch(),
       Flag("real-fresh", "draw the real arm while its state is younger than S").Takes("S"),
       sirupp::runtime::ModelFlag(),
       Flag("environment", "environment file").Takes("FILE"),
       Flag("config", "viewer settings file (YAML)").Takes("FILE"),
       Flag("duration", "exit after S seconds").Takes("S"),
       Flag("once", "render one frame to this PNG and exit").Takes("OUT.png"),
       sirupp::runtime::DegreesFlag("deg", "the virtual arm for --once"),
       sirupp::runtime::DegreesFlag("ghost-deg", "the set-point ghost for --once"),
       sirupp::runtime::DegreesFlag("real-deg", "the real arm for --once"),
       Flag("lcm-url", "LCM URL").Takes("URL"),
       Flag("prefix", "channel prefix of the rig").Takes("PREFIX")},
      kAbout);
  const viewer::ViewerOptions options = OptionsFromArgs(args);
  if (args.Has("once")) return RenderOnce(args, options);
  for (const char* flag : {"deg", "ghost-deg", "real-deg"}) {
    if (args.Has(flag)) {
      throw UsageError(std::string("sirupp-viewer: --") + flag + " only goes with --once OUT.png");
    }
  }
  const double duration_s = args.Has("duration") ? PositiveNumber(args, "duration", "s") : 0;
  std::optional<sirupp::core::RobotModel> model;
  if (args.Has("model")) {
    model = sirupp::core::LoadRobotModel(sirupp::runtime::ResolveDataPath(args.String("model")));
  }
  std::optional<sirupp::core::Environment> environment;
  if (args.Has("environment")) {
    environment =
        sirupp::core::LoadEnvironment(sirupp::runtime::ResolveDataPath(args.String("environment")));
  }
  sirupp::core::Bus bus(args.Has("lcm-url") ? args.String("lcm-url") : "",
                        args.Has("prefix") ? args.String("prefix") : "");
  std::optional<viewer::ViewerNode> made;
  try {
    made.emplace(bus, options, model, environment);
  } catch (const viewer::OutputError& error) {
    throw UsageError(std::string("sirupp-viewer: ") + error.what());
  }
  viewer::ViewerNode& node = *made;
  std::cerr << "sirupp-viewer: " << options.render.width << "x" << options.render.height << " "
            << viewer::ImageFormatName(options.format) << " at " << FormatNumber(options.rate_hz)
            << " Hz on " << bus.url() << " (" << node.gl_description() << ")" << std::endl;
  std::signal(SIGUSR1, OnSnapshotSignal);
  int snapshots_seen = 0;
  const auto start = std::chrono::steady_clock::now();
  sirupp::runtime::ServiceUntilSignal([&] {
    try {
      node.Service(50);
    } catch (const sirupp::core::BusError&) {
      if (g_snapshot_signals == snapshots_seen) throw;  // not our signal interrupting LCM's wait
    }
    if (g_snapshot_signals != snapshots_seen) {
      snapshots_seen = g_snapshot_signals;
      if (!node.RequestSnapshot()) {
        std::cerr << "sirupp-viewer: SIGUSR1 asks for a snapshot, but there is no --png DIR\n";
      }
    }
    return duration_s <= 0 ||
           std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() <
               duration_s;
  });
  node.Close();
  const viewer::ViewerStats stats = node.stats();
  std::cerr << "sirupp-viewer: " << stats.frames_rendered << " frames rendered, "
            << stats.images_published << " images published, "
            << (stats.model.empty() ? "no model received" : "model " + stats.model);
  if (!options.video_path.empty()) {
    std::cerr << ", " << stats.video_frames << " video frames in " << options.video_path;
  }
  if (stats.png_frames + stats.snapshots > 0) {
    std::cerr << ", " << stats.png_frames << " PNG frames and " << stats.snapshots
              << " snapshots in " << options.png_dir;
  }
  if (!stats.output_error.empty()) std::cerr << "; " << stats.output_error;
  if (stats.refused > 0) {
    std::cerr << "; " << stats.refused << " messages refused, last: " << stats.last_refusal;
  }
  std::cerr << "\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return sirupp::runtime::ProcessMain(argc, argv, "sirupp-viewer", Run);
}
