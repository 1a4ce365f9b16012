// sirupp-viewer's node on an in-process memq:// bus: it builds itself from ROBOT_MODEL and
// ENVIRONMENT, draws the states, publishes image_t on VIEWER_IMAGE with the metadata, refuses bad
// messages (counted on the bus and named on the heartbeat) while keeping the last good scene,
// follows VIEWER_CAMERA, writes PNG files and a finalised video, and renders the frames of a short
// recorded LCM log replayed into it.

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <lcm/lcm-cpp.hpp>
#include <sirupp/arm_state_t.hpp>
#include <sirupp/controller_status_t.hpp>
#include <sirupp/heartbeat_t.hpp>
#include <sirupp/image_t.hpp>
#include <sirupp/servo_setpoint_t.hpp>
#include <sirupp/viewer_camera_t.hpp>
#include <string>
#include <thread>
#include <vector>

#include "core/bus.hpp"
#include "core/environment.hpp"
#include "core/model_loader.hpp"
#include "core/translate.hpp"
#include "viewer/image_codec.hpp"
#include "viewer/viewer_node.hpp"

namespace sirupp::viewer {
namespace {

namespace fs = std::filesystem;
constexpr double kDeg = M_PI / 180.0;

sirupp::arm_state_t State(int64_t tick, const std::vector<double>& deg) {
  sirupp::arm_state_t state{};
  state.utime = tick * 512;
  state.seq = tick;
  state.tick = tick;
  state.num_joints = static_cast<int32_t>(deg.size());
  for (double value : deg) state.position.push_back(value * kDeg);
  state.velocity.assign(deg.size(), 0.0);
  state.effort.assign(deg.size(), 0.0);
  state.flags.assign(deg.size(), 0);
  return state;
}

sirupp::servo_setpoint_t Setpoint(int64_t tick, const std::vector<double>& deg) {
  sirupp::servo_setpoint_t setpoint{};
  setpoint.utime = tick * 512;
  setpoint.seq = tick;
  setpoint.tick = tick;
  setpoint.move_id = 1;
  const size_t n = deg.size();
  setpoint.num_joints = static_cast<int32_t>(n);
  for (double value : deg) setpoint.position.push_back(value * kDeg);
  setpoint.velocity.assign(n, 0.0);
  setpoint.goal = setpoint.position;
  setpoint.position_error.assign(n, 0.0);
  setpoint.effort.assign(n, 0.0);
  setpoint.status.assign(n, 0);
  return setpoint;
}

// A fresh directory under the system's temporary directory, removed at the end of the test.
class TempDir {
 public:
  TempDir() {
    path_ = fs::temp_directory_path() /
            ("sirupp-viewer-test-" + std::to_string(::getpid()) + "-" + std::to_string(count_++));
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~TempDir() { fs::remove_all(path_); }
  const fs::path& path() const { return path_; }

 private:
  static inline int count_ = 0;
  fs::path path_;
};

std::string FileStart(const fs::path& path, size_t bytes) {
  std::ifstream file(path, std::ios::binary);
  std::string text(bytes, '\0');
  file.read(text.data(), static_cast<std::streamsize>(bytes));
  text.resize(static_cast<size_t>(file.gcount()));
  return text;
}

std::string FileText(const fs::path& path) {
  std::error_code error;
  const auto size = fs::file_size(path, error);
  return error ? std::string() : FileStart(path, static_cast<size_t>(size));
}

class ViewerNodeTest : public ::testing::Test {
 protected:
  ViewerNodeTest() {
    options_.render.width = 160;
    options_.render.height = 120;
    options_.render.supersample = 1;
    options_.rate_hz = 200;  // frames follow the traffic closely; timing is not checked
  }

  // Services the node until `done` or about 5 s of wall time (generous for a loaded machine).
  bool ServiceUntil(ViewerNode& node, const std::function<bool()>& done) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
    while (std::chrono::steady_clock::now() < deadline) {
      node.Service(10);
      if (done()) return true;
    }
    return done();
  }

  core::RobotModel puma_ = core::LoadRobotModel("config/robots/puma260.yaml");
  core::Environment table_ = core::LoadEnvironment("config/environments/table.xml");
  core::Bus bus_{"memq://"};
  core::Latest<sirupp::image_t> images_{bus_, "VIEWER_IMAGE"};
  core::Latest<sirupp::heartbeat_t> heartbeats_{bus_, "HEARTBEAT"};
  ViewerOptions options_;
};

TEST_F(ViewerNodeTest, WaitsForTheModelThenDrawsTheStatesItReceives) {
  ViewerNode node(bus_, options_);
  // Before the sim starts: images with an empty scene, so a watcher sees the viewer is alive.
  ASSERT_TRUE(ServiceUntil(node, [&] { return images_.Has(); }));
  EXPECT_FALSE(node.has_model());
  EXPECT_EQ(FindMetadata(images_.Get(), "model").value_or("?"), "");

  bus_.Publish("ROBOT_MODEL", core::ToMessage(puma_, 0, 0));
  bus_.Publish("ENVIRONMENT", core::ToMessage(table_, 0, 0));
  bus_.Publish("SIM_ARM_STATE", State(1000, {30, -60, 120, 0, 30, 0}));
  bus_.Publish("ARM_SETPOINT", Setpoint(1000, {40, -50, 110, 0, 30, 0}));
  ASSERT_TRUE(ServiceUntil(node, [&] {
    return images_.Has() && FindMetadata(images_.Get(), "tick").value_or("") == "1000";
  }));
  EXPECT_TRUE(node.has_model());
  const sirupp::image_t& image = images_.Get();
  EXPECT_EQ(image.utime, 1000 * 512);
  EXPECT_EQ(image.pixelformat, sirupp::image_t::PIXEL_FORMAT_MJPEG);
  EXPECT_EQ(FindMetadata(image, "model").value_or(""), "puma260");
  EXPECT_GE(std::stoll(FindMetadata(image, "seq").value_or("-1")), 1);
  const cv::Mat decoded = DecodeImage(image);
  EXPECT_EQ(decoded.cols, 160);
  EXPECT_EQ(decoded.rows, 120);
  // The scene shows the arm, its ghost and the table.
  int virt = 0, ghost = 0, environment = 0;
  for (const SceneShape& shape : node.last_scene().shapes) {
    virt += shape.role == Role::kVirtualArm;
    ghost += shape.role == Role::kGhostArm;
    environment += shape.role == Role::kEnvironment;
  }
  EXPECT_GT(virt, 10);
  EXPECT_GT(ghost, 5);
  EXPECT_EQ(environment, static_cast<int>(table_.objects.size()));
  EXPECT_EQ(bus_.StatsFor("SIM_ARM_STATE").rejected, 0);
}

TEST_F(ViewerNodeTest, RawRgbOnRequest) {
  options_.format = ImageFormat::kRgb;
  ViewerNode node(bus_, options_, puma_);
  ASSERT_TRUE(ServiceUntil(node, [&] { return images_.Has(); }));
  EXPECT_EQ(images_.Get().pixelformat, sirupp::image_t::PIXEL_FORMAT_RGB);
  EXPECT_EQ(images_.Get().size, 160 * 120 * 3);
  EXPECT_EQ(DecodeImage(images_.Get()).cols, 160);
}

TEST_F(ViewerNodeTest, BadMessagesAreCountedAndNamedWhileTheLastGoodSceneStays) {
  ViewerNode node(bus_, options_);
  bus_.Publish("ROBOT_MODEL", core::ToMessage(puma_, 0, 0));
  bus_.Publish("SIM_ARM_STATE", State(5, {10, 20, 30, 40, 50, 60}));
  ASSERT_TRUE(ServiceUntil(node, [&] {
    return images_.Has() && FindMetadata(images_.Get(), "tick").value_or("") == "5";
  }));
  const std::vector<SceneShape> good = node.last_scene().shapes;

  bus_.Publish("SIM_ARM_STATE", State(6, {10, 20, 30, 40, 50}));  // five joints
  sirupp::arm_state_t nan_state = State(7, {10, 20, 30, 40, 50, 60});
  nan_state.position[3] = std::nan("");
  bus_.Publish("SIM_ARM_STATE", nan_state);
  bus_.Publish("ARM_SETPOINT", Setpoint(7, {1, 2, 3}));
  sirupp::controller_status_t status{};
  status.mode = 7;
  bus_.Publish("CONTROLLER_STATUS", status);
  sirupp::arm_state_t bad_source = State(8, {10, 20, 30, 40, 50, 60});
  bad_source.source = 9;
  bus_.Publish("REAL_ARM_STATE", bad_source);
  sirupp::robot_model_t broken = core::ToMessage(puma_, 0, 1);
  broken.num_joints = 5;  // counts no longer match the arrays: cannot be drawn
  bus_.Publish("ROBOT_MODEL", broken);
  sirupp::robot_model_t zero_mass = core::ToMessage(puma_, 0, 2);
  zero_mass.links[2].mass = -1;
  bus_.Publish("ROBOT_MODEL", zero_mass);
  ASSERT_TRUE(ServiceUntil(node, [&] { return node.stats().refused >= 7; }));
  EXPECT_NE(
      bus_.StatsFor("CONTROLLER_STATUS").last_error.find("mode: 7 is not allowed; expected 0..1"),
      std::string::npos);
  EXPECT_NE(bus_.StatsFor("REAL_ARM_STATE").last_error.find("source: 9"), std::string::npos);
  EXPECT_EQ(bus_.StatsFor("SIM_ARM_STATE").rejected, 2);
  EXPECT_EQ(bus_.StatsFor("ARM_SETPOINT").rejected, 1);
  EXPECT_EQ(bus_.StatsFor("ROBOT_MODEL").rejected, 2);
  EXPECT_NE(bus_.StatsFor("ARM_SETPOINT")
                .last_error.find("channel ARM_SETPOINT: num_joints: 3 is not allowed; expected 6"),
            std::string::npos)
      << bus_.StatsFor("ARM_SETPOINT").last_error;
  EXPECT_NE(bus_.StatsFor("SIM_ARM_STATE").last_error.find("position[3]: nan is not allowed"),
            std::string::npos)
      << bus_.StatsFor("SIM_ARM_STATE").last_error;
  // Still drawing: the arm where the last good state put it.
  node.FrameNow();
  int same = 0;
  for (size_t i = 0; i < good.size() && i < node.last_scene().shapes.size(); ++i) {
    same += good[i].pose.isApprox(node.last_scene().shapes[i].pose);
  }
  EXPECT_EQ(same, static_cast<int>(good.size()));
  EXPECT_EQ(FindMetadata(images_.Get(), "tick").value_or(""), "5");
  // The heartbeat turns degraded and names the last refusal (it is sent once a second).
  ASSERT_TRUE(ServiceUntil(node, [&] {
    return heartbeats_.Has() && heartbeats_.Get().state == sirupp::heartbeat_t::STATE_DEGRADED;
  }));
  EXPECT_NE(heartbeats_.Get().detail.find("refused: channel ROBOT_MODEL"), std::string::npos)
      << heartbeats_.Get().detail;
  EXPECT_EQ(heartbeats_.Get().process, "sirupp-viewer");
}

TEST_F(ViewerNodeTest, RealArmOnlyWhileFresh) {
  options_.real_fresh_s = 0.3;
  ViewerNode node(bus_, options_, puma_);
  auto real_shapes = [&] {
    int count = 0;
    for (const SceneShape& shape : node.last_scene().shapes) count += shape.role == Role::kRealArm;
    return count;
  };
  bus_.Publish("REAL_ARM_STATE", State(1, {5, -10, 20, 0, 0, 0}));
  ASSERT_TRUE(ServiceUntil(node, [&] { return real_shapes() > 0; }));
  // No new real state: it disappears after real_fresh_s.
  ASSERT_TRUE(ServiceUntil(node, [&] { return real_shapes() == 0; }));
}

TEST_F(ViewerNodeTest, CameraMessagesMoveTheCameraAndBadOnesAreRefused) {
  TempDir dir;
  options_.png_dir = dir.path().string();
  ViewerNode node(bus_, options_, puma_);
  sirupp::viewer_camera_t camera{};
  camera.set_camera = 1;
  camera.azimuth = 90 * kDeg;
  camera.elevation = 30 * kDeg;
  camera.distance = 2.0;
  camera.target[2] = 0.4;
  camera.show_frames = sirupp::viewer_camera_t::SWITCH_ON;
  camera.show_ghost = sirupp::viewer_camera_t::SWITCH_OFF;
  camera.snapshot = 1;
  bus_.Publish("VIEWER_CAMERA", camera);
  ASSERT_TRUE(ServiceUntil(node, [&] { return node.stats().snapshots == 1; }));
  EXPECT_NEAR(node.camera().azimuth_rad, 90 * kDeg, 1e-12);
  EXPECT_EQ(node.camera().distance_m, 2.0);
  EXPECT_TRUE(fs::exists(dir.path() / "snapshot-001.png"));
  EXPECT_EQ(FileStart(dir.path() / "snapshot-001.png", 4), "\x89PNG");
  ASSERT_TRUE(ServiceUntil(node, [&] {
    return images_.Has() && FindMetadata(images_.Get(), "frames").value_or("") == "1";
  }));
  EXPECT_EQ(FindMetadata(images_.Get(), "ghost").value_or(""), "0");
  EXPECT_EQ(FindMetadata(images_.Get(), "camera").value_or("").rfind("90.0 30.0 2 ", 0), 0u)
      << FindMetadata(images_.Get(), "camera").value_or("");

  camera.elevation = 2.0;  // beyond +-1.55 rad
  camera.snapshot = 0;
  bus_.Publish("VIEWER_CAMERA", camera);
  camera.elevation = 0.1;
  camera.show_ghost = 7;
  bus_.Publish("VIEWER_CAMERA", camera);
  ASSERT_TRUE(ServiceUntil(node, [&] { return bus_.StatsFor("VIEWER_CAMERA").rejected == 2; }));
  EXPECT_NE(bus_.StatsFor("VIEWER_CAMERA").last_error.find("show_ghost: 7"), std::string::npos);
  EXPECT_NEAR(node.camera().elevation_rad, 30 * kDeg, 1e-12);  // unchanged
}

TEST_F(ViewerNodeTest, SnapshotWithoutAPngDirectoryIsRefused) {
  ViewerNode node(bus_, options_, puma_);
  EXPECT_FALSE(node.RequestSnapshot());
  sirupp::viewer_camera_t camera{};
  camera.snapshot = 1;
  bus_.Publish("VIEWER_CAMERA", camera);
  ASSERT_TRUE(ServiceUntil(node, [&] { return bus_.StatsFor("VIEWER_CAMERA").rejected == 1; }));
  EXPECT_NE(bus_.StatsFor("VIEWER_CAMERA").last_error.find("--png DIR"), std::string::npos);
}

TEST_F(ViewerNodeTest, PngFramesAndAFinalisedVideo) {
  TempDir dir;
  options_.rate_hz = 50;
  options_.png_dir = (dir.path() / "png").string();
  options_.png_every_s = 0.05;
  options_.video_path = (dir.path() / "run.avi").string();
  {
    ViewerNode node(bus_, options_, puma_, table_);
    int64_t tick = 0;
    ASSERT_TRUE(ServiceUntil(node, [&] {
      bus_.Publish("SIM_ARM_STATE",
                   State(++tick, {static_cast<double>(tick % 90), -40, 80, 0, 0, 0}));
      return node.stats().video_frames >= 10 && node.stats().png_frames >= 3;
    }));
    node.Close();
    EXPECT_EQ(node.stats().output_error, "");
  }
  EXPECT_EQ(FileStart(dir.path() / "png" / "frame-000001.png", 4), "\x89PNG");
  const std::string video = FileText(dir.path() / "run.avi");
  ASSERT_GT(video.size(), 1000u);
  EXPECT_EQ(video.substr(0, 4), "RIFF");
  EXPECT_EQ(video.substr(8, 4), "AVI ");
  EXPECT_NE(video.find("MJPG"), std::string::npos);
  EXPECT_NE(video.find("idx1"), std::string::npos) << "the index is written when finalised";
}

TEST_F(ViewerNodeTest, BadOptionsFailAtStart) {
  options_.video_path = "/nonexistent-dir/x.avi";
  EXPECT_THROW(ViewerNode(bus_, options_), OutputError);
  options_.video_path = "x.mp4";
  EXPECT_THROW(ViewerNode(bus_, options_), std::invalid_argument);
  options_.video_path.clear();
  options_.rate_hz = 0;
  EXPECT_THROW(ViewerNode(bus_, options_), std::invalid_argument);
  EXPECT_NE(OptionsProblem(options_).find("rate 0 Hz"), std::string::npos);
}

// A short recorded run, written with lcm::LogFile as lcm-logger would, replayed into the node in
// recorded order (as lcm-logplayer sends it): frames come out and the last shows the last state.
TEST_F(ViewerNodeTest, RendersFramesFromAShortRecordedLog) {
  TempDir dir;
  const std::string log_path = (dir.path() / "run.lcm").string();
  {
    lcm::LogFile log(log_path, "w");
    ASSERT_TRUE(log.good());
    int64_t event = 0;
    auto write = [&](const std::string& channel, const auto& message, int64_t utime) {
      std::vector<uint8_t> bytes(static_cast<size_t>(message.getEncodedSize()));
      message.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
      lcm::LogEvent entry;
      entry.eventnum = event++;
      entry.timestamp = utime;
      entry.channel = channel;
      entry.datalen = static_cast<int32_t>(bytes.size());
      entry.data = bytes.data();
      ASSERT_EQ(log.writeEvent(&entry), 0);
    };
    write("ROBOT_MODEL", core::ToMessage(puma_, 0, 0), 1000);
    write("ENVIRONMENT", core::ToMessage(table_, 0, 0), 1001);
    for (int64_t tick = 1; tick <= 200; ++tick) {
      const double joint1 = 0.45 * static_cast<double>(tick);  // 0 .. 90 degrees
      write("SIM_ARM_STATE", State(tick, {joint1, -45, 90, 0, 30, 0}), 2000 + tick * 512);
      write("ARM_SETPOINT", Setpoint(tick, {joint1 + 5, -45, 90, 0, 30, 0}), 2001 + tick * 512);
    }
  }
  options_.rate_hz = 1000;  // render whenever something changed
  ViewerNode node(bus_, options_);
  lcm::LogFile log(log_path, "r");
  ASSERT_TRUE(log.good());
  int events = 0;
  cv::Mat first;
  for (const lcm::LogEvent* event = log.readNextEvent(); event != nullptr;
       event = log.readNextEvent()) {
    bus_.raw_lcm().publish(event->channel, event->data, static_cast<unsigned>(event->datalen));
    if (++events % 40 == 0) {
      node.FrameNow();
      if (first.empty() && node.has_model()) first = node.last_image().clone();
    }
    bus_.HandleAvailable();
  }
  EXPECT_EQ(events, 402);
  ASSERT_TRUE(ServiceUntil(node, [&] {
    return images_.Has() && FindMetadata(images_.Get(), "tick").value_or("") == "200";
  }));
  EXPECT_GE(node.stats().frames_rendered, 10);
  EXPECT_EQ(bus_.StatsFor("SIM_ARM_STATE").messages, 200);
  EXPECT_EQ(bus_.StatsFor("SIM_ARM_STATE").rejected, 0);
  ASSERT_FALSE(first.empty());
  // The waist turned between the first and the last frame: the pictures differ.
  EXPECT_GT(cv::norm(first, node.last_image(), cv::NORM_L1), 1000.0);
}

}  // namespace
}  // namespace sirupp::viewer
