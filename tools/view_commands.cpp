#include "tools/view_commands.hpp"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <opencv2/highgui.hpp>
#include <opencv2/imgcodecs.hpp>
#include <optional>
#include <ostream>
#include <sirupp/image_t.hpp>
#include <sirupp/viewer_camera_t.hpp>
#include <sstream>

#include "core/bus.hpp"
#include "core/channels.hpp"
#include "core/errors.hpp"
#include "core/translate.hpp"
#include "runtime/args.hpp"
#include "tools/rig_args.hpp"
#include "viewer/image_codec.hpp"

namespace sirupp::tools {

const char* const kViewAbout =
    "  Shows sirupp-viewer's images (--channel, default VIEWER_IMAGE) in a window; needs a\n"
    "  display ($DISPLAY). Keys: j / l turn the camera left / right, i / k up / down, + / -\n"
    "  closer / farther, f DH frames on / off, g ghost on / off, p the viewer writes a PNG\n"
    "  snapshot (if started with --png DIR), s saves the shown image as DIR/view-NNN.png\n"
    "  (--save, default the current directory), q or Esc quits.\n";

namespace {

constexpr double kDegToRad = M_PI / 180.0;

bool HasDisplay() {
  for (const char* name : {"DISPLAY", "WAYLAND_DISPLAY"}) {
    const char* value = std::getenv(name);
    if (value != nullptr && *value != '\0') return true;
  }
  return false;
}

// Camera of an image from its "camera" metadata ("AZ_DEG EL_DEG DIST X Y Z").
std::optional<sirupp::viewer_camera_t> CameraOf(const sirupp::image_t& image) {
  const std::optional<std::string> text = viewer::FindMetadata(image, "camera");
  if (!text) return std::nullopt;
  std::istringstream in(*text);
  double az = 0, el = 0, dist = 0, x = 0, y = 0, z = 0;
  if (!(in >> az >> el >> dist >> x >> y >> z)) return std::nullopt;
  core::ViewerCamera camera;
  camera.set_camera = true;
  camera.azimuth = az * kDegToRad;
  camera.elevation = el * kDegToRad;
  camera.distance = dist;
  camera.target = Eigen::Vector3d(x, y, z);
  return core::ToMessage(camera);
}

}  // namespace

namespace {

// The camera or switch request for a key, from the newest image's camera and switch state;
// nothing for a key that asks for none or while no image has told the camera.
std::optional<sirupp::viewer_camera_t> RequestForKey(int key, const sirupp::image_t& newest) {
  std::optional<sirupp::viewer_camera_t> camera = CameraOf(newest);
  if (!camera) return std::nullopt;
  sirupp::viewer_camera_t& c = *camera;
  const bool frames_on = viewer::FindMetadata(newest, "frames").value_or("0") == "1";
  const bool ghost_on = viewer::FindMetadata(newest, "ghost").value_or("1") == "1";
  switch (key) {
    case 'j':
      c.azimuth -= 10 * kDegToRad;
      break;
    case 'l':
      c.azimuth += 10 * kDegToRad;
      break;
    case 'i':
      c.elevation = std::min(c.elevation + 5 * kDegToRad, 85 * kDegToRad);
      break;
    case 'k':
      c.elevation = std::max(c.elevation - 5 * kDegToRad, -85 * kDegToRad);
      break;
    case '+':
    case '=':
      c.distance *= 0.9;
      break;
    case '-':
      c.distance /= 0.9;
      break;
    case 'f':
      c.set_camera = 0;
      c.show_frames =
          frames_on ? sirupp::viewer_camera_t::SWITCH_OFF : sirupp::viewer_camera_t::SWITCH_ON;
      break;
    case 'g':
      c.set_camera = 0;
      c.show_ghost =
          ghost_on ? sirupp::viewer_camera_t::SWITCH_OFF : sirupp::viewer_camera_t::SWITCH_ON;
      break;
    case 'p':
      c.set_camera = 0;
      c.snapshot = 1;
      break;
    default:
      return std::nullopt;
  }
  return camera;
}

// Saves the shown image as DIR/view-NNN.png (NNN = number) and says where, or that it could not.
void SaveShown(const cv::Mat& shown, const std::string& save_dir, int number, std::ostream& out,
               std::ostream& err) {
  std::filesystem::create_directories(save_dir);
  char name[32];
  std::snprintf(name, sizeof name, "view-%03d.png", number);
  const std::string path = (std::filesystem::path(save_dir) / name).string();
  if (cv::imwrite(path, shown)) {
    out << "saved " << path << std::endl;
  } else {
    err << "sirupp view: cannot write " << path << "\n";
  }
}

// --duration in seconds (> 0 by its declaration); 0 (no limit) without it.
double DurationOf(const runtime::Args& parsed) { return parsed.Number("duration", 0); }

}  // namespace

int RunView(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  const runtime::Args parsed(
      args, "view",
      WithRigFlags({runtime::Flag("channel", "image channel (VIEWER_IMAGE)").Takes("NAME"),
                    runtime::Flag("save", "folder to save the frames as PNG").Takes("DIR"),
                    runtime::Flag("duration", "exit after S seconds").Takes("S").Above(0)}),
      kViewAbout);
  const std::string channel =
      parsed.Has("channel") ? parsed.String("channel") : core::Channels{}.viewer_image;
  const std::string save_dir = parsed.Has("save") ? parsed.String("save") : ".";
  const double duration_s = DurationOf(parsed);
  if (!HasDisplay()) {
    err << "sirupp view: no display ($DISPLAY is not set): run it on a PC with a screen, or "
           "let sirupp-viewer write files (--png DIR, --video FILE.avi)\n";
    return 1;
  }
  core::Bus bus = BusFromArgs(parsed);
  const std::string title = "sirupp view: " + bus.FullName(channel);
  try {
    cv::namedWindow(title, cv::WINDOW_AUTOSIZE);
  } catch (const cv::Exception& error) {
    err << "sirupp view: cannot open a window: " << error.what() << "\n";
    return 1;
  }

  cv::Mat shown;
  bool fresh = false;
  std::optional<sirupp::image_t> newest;  // for the camera and switch state in its metadata
  bus.Subscribe<sirupp::image_t>(
      channel, [&](const sirupp::image_t& image, const core::ReceiveInfo& info) {
        shown = viewer::DecodeImage(image, info.channel);  // a bad image is counted, not shown
        newest = image;
        fresh = true;
      });
  int64_t camera_seq = 0;
  int saved = 0;
  out << "sirupp view: waiting for " << bus.FullName(channel) << " on " << bus.url() << " (q quits)"
      << std::endl;
  const auto start = std::chrono::steady_clock::now();
  while (true) {
    bus.HandleAvailable();
    if (fresh) {
      cv::imshow(title, shown);
      fresh = false;
    }
    const int key = cv::waitKey(15) & 0xff;
    if (key == 'q' || key == 27) break;
    if (cv::getWindowProperty(title, cv::WND_PROP_VISIBLE) < 1) break;  // closed by the user
    if (duration_s > 0 &&
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() >=
            duration_s) {
      break;
    }
    if (key == 's' && !shown.empty()) {
      SaveShown(shown, save_dir, ++saved, out, err);
      continue;
    }
    if (!newest) continue;
    std::optional<sirupp::viewer_camera_t> request = RequestForKey(key, *newest);
    if (!request) continue;
    request->utime = WallMicros();
    request->seq = camera_seq++;
    bus.Publish(core::Channels{}.viewer_camera, *request);
  }
  cv::destroyAllWindows();
  const core::ChannelStats stats = bus.StatsFor(channel);
  out << "sirupp view: " << stats.messages << " images received";
  if (stats.rejected + stats.decode_errors > 0) {
    out << ", " << stats.rejected + stats.decode_errors << " not shown (" << stats.last_error
        << ")";
  }
  out << std::endl;  // flushed: a sanitizer report at exit must not swallow it
  return 0;
}

}  // namespace sirupp::tools
