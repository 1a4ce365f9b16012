// sirupp-viewer's frame rate and latency: the PUMA 260 with its set-point ghost, the real arm a
// few degrees off and the table environment (config/environments/table.xml), rendered with OSMesa
// at 640x480 and 1280x720, with and without supersampling (anti-aliasing; the viewer's default is
// 2), render only and render + JPEG encode (what each VIEWER_IMAGE costs). Goal: at least 60
// frames per second at 640x480 on the lab's 2 cores. Then the latency from a SIM_ARM_STATE
// published on memq:// to the VIEWER_IMAGE showing it (the node at --rate 1000, i.e. rendering as
// soon as a state arrives; at --rate R add up to 1/R of waiting for the frame clock).
//
//   build/bin/bench_viewer [--seconds S] [--samples N]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <sirupp/arm_state_t.hpp>
#include <sirupp/image_t.hpp>
#include <string>
#include <thread>
#include <vector>

#include "core/bus.hpp"
#include "core/environment.hpp"
#include "core/model_loader.hpp"
#include "core/translate.hpp"
#include "viewer/image_codec.hpp"
#include "viewer/osmesa_renderer.hpp"
#include "viewer/scene.hpp"
#include "viewer/viewer_node.hpp"

namespace {

using Clock = std::chrono::steady_clock;
namespace viewer = sirupp::viewer;
constexpr double kDeg = M_PI / 180.0;
constexpr double kGoalFps = 60;

// A moving pose: every frame differs, as during a move.
viewer::ViewState PoseAt(int frame) {
  const double s = std::sin(frame * 0.05);
  viewer::ViewState state;
  state.virtual_position = std::vector<double>{
      40 * s * kDeg, (-60 + 20 * s) * kDeg, (110 - 15 * s) * kDeg, 10 * kDeg, 30 * kDeg, 0.0};
  state.setpoint_position = *state.virtual_position;
  (*state.setpoint_position)[0] += 8 * kDeg;
  (*state.setpoint_position)[2] -= 6 * kDeg;
  state.real_position = *state.virtual_position;
  (*state.real_position)[0] -= 3 * kDeg;
  (*state.real_position)[1] += 3 * kDeg;
  state.utime = frame * 100000;
  state.tick = frame;
  state.status_text = "automatic, moving";
  return state;
}

struct Rates {
  double render_fps = 0;
  double encode_fps = 0;
  size_t jpeg_bytes = 0;
};

Rates Measure(const sirupp::core::RobotModel& model, const sirupp::core::Environment& environment,
              int width, int height, int supersample, double seconds) {
  viewer::RenderOptions options;
  options.width = width;
  options.height = height;
  options.supersample = supersample;
  viewer::OsmesaRenderer renderer(options);
  const viewer::SceneOptions scene_options;
  const viewer::Camera camera;
  Rates rates;
  for (int pass = 0; pass < 2; ++pass) {
    const bool encode = pass == 1;
    int frames = 0;
    // Warm-up: the first frames compile Mesa's shaders.
    for (int i = 0; i < 5; ++i) {
      renderer.Render(viewer::BuildScene(&model, &environment, PoseAt(i), scene_options), camera);
    }
    const auto start = Clock::now();
    double elapsed = 0;
    while (elapsed < seconds) {
      const cv::Mat& image = renderer.Render(
          viewer::BuildScene(&model, &environment, PoseAt(frames), scene_options), camera);
      if (encode) {
        const sirupp::image_t message =
            viewer::EncodeImage(image, viewer::ImageFormat::kJpeg, 80, frames, {});
        rates.jpeg_bytes = static_cast<size_t>(message.size);
      }
      ++frames;
      elapsed = std::chrono::duration<double>(Clock::now() - start).count();
    }
    (encode ? rates.encode_fps : rates.render_fps) = frames / elapsed;
  }
  return rates;
}

double Percentile(std::vector<double> values, double fraction) {
  std::sort(values.begin(), values.end());
  const size_t index = std::min(
      values.size() - 1, static_cast<size_t>(std::floor(fraction * (values.size() - 1) + 0.5)));
  return values[index];
}

}  // namespace

int main(int argc, char** argv) {
  double seconds = 3;
  int samples = 200;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (std::strcmp(argv[i], "--seconds") == 0) seconds = std::atof(argv[i + 1]);
    if (std::strcmp(argv[i], "--samples") == 0) samples = std::atoi(argv[i + 1]);
  }
  if (!(seconds > 0) || samples < 10) {
    std::fprintf(stderr, "usage: bench_viewer [--seconds S > 0] [--samples N >= 10]\n");
    return 2;
  }
  const sirupp::core::RobotModel model = sirupp::core::LoadRobotModel("config/robots/puma260.yaml");
  const sirupp::core::Environment environment =
      sirupp::core::LoadEnvironment("config/environments/table.xml");
  {
    viewer::OsmesaRenderer probe(viewer::RenderOptions{});
    std::printf("OSMesa: %s\n", probe.gl_description().c_str());
  }
  const viewer::Scene scene =
      viewer::BuildScene(&model, &environment, PoseAt(0), viewer::SceneOptions{});
  std::printf(
      "scene: PUMA 260 + ghost + real arm + %zu environment objects + floor: %zu shapes, "
      "%zu lines\n\n",
      environment.objects.size(), scene.shapes.size(), scene.lines.size());
  std::printf("%-10s %-12s %12s %10s %16s %10s %11s\n", "size", "supersample", "render fps",
              "vs 60", "render+JPEG fps", "vs 60", "JPEG bytes");
  for (const auto& [width, height] : {std::pair{640, 480}, std::pair{1280, 720}}) {
    for (int supersample : {1, 2}) {
      const Rates rates = Measure(model, environment, width, height, supersample, seconds);
      std::printf("%4dx%-5d %-12d %12.1f %9.2fx %16.1f %9.2fx %11zu\n", width, height, supersample,
                  rates.render_fps, rates.render_fps / kGoalFps, rates.encode_fps,
                  rates.encode_fps / kGoalFps, rates.jpeg_bytes);
    }
  }

  // Latency: a state published on memq:// to the image showing it, through the viewer node.
  std::printf("\nlatency SIM_ARM_STATE -> VIEWER_IMAGE (memq://, node at --rate 1000):\n");
  for (const auto& [width, height] : {std::pair{640, 480}, std::pair{1280, 720}}) {
    sirupp::core::Bus bus("memq://");
    viewer::ViewerOptions options;
    options.render.width = width;
    options.render.height = height;
    options.rate_hz = 1000;
    viewer::ViewerNode node(bus, options, model, environment);
    int64_t wanted_tick = -1;
    bool got = false;
    bus.Subscribe<sirupp::image_t>(
        "VIEWER_IMAGE", [&](const sirupp::image_t& image, const sirupp::core::ReceiveInfo&) {
          if (image.utime == wanted_tick * 512) got = true;
        });
    std::vector<double> latency_ms;
    for (int i = 0; i < samples + 5; ++i) {
      sirupp::arm_state_t state{};
      state.tick = i;
      state.seq = i;
      state.utime = i * 512;
      const viewer::ViewState pose = PoseAt(i);
      state.num_joints = 6;
      state.position = *pose.virtual_position;
      state.velocity.assign(6, 0.0);
      state.effort.assign(6, 0.0);
      state.flags.assign(6, 0);
      wanted_tick = i;
      got = false;
      // Let the frame clock come due first, so the wait measured is the viewer's own work.
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
      const auto sent = Clock::now();
      bus.Publish("SIM_ARM_STATE", state);
      while (!got) node.Service(1);
      if (i >= 5) {
        latency_ms.push_back(
            std::chrono::duration<double, std::milli>(Clock::now() - sent).count());
      }
    }
    std::printf("  %4dx%-4d  median %6.2f ms   p95 %6.2f ms   max %6.2f ms   (%d samples)\n", width,
                height, Percentile(latency_ms, 0.5), Percentile(latency_ms, 0.95),
                Percentile(latency_ms, 1.0), samples);
  }
  return 0;
}
