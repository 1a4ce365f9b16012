// Tests of the OSMesa renderer: a known pose drawn at 320x240 and checked by pixels. The joint
// origins and link shape centres, projected with the same camera matrices the renderer loads, must
// show the robot's colour; the corners and points far from the arm must show the background. The
// ghost and the real arm appear in their own colours where they stand apart from the virtual arm.

#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "core/kinematics.hpp"
#include "core/model_loader.hpp"
#include "viewer/camera.hpp"
#include "viewer/osmesa_renderer.hpp"
#include "viewer/scene.hpp"

namespace sirupp::viewer {
namespace {

constexpr double kDeg = M_PI / 180.0;
constexpr int kWidth = 320;
constexpr int kHeight = 240;

std::vector<double> Degrees(std::vector<double> values) {
  for (double& value : values) value *= kDeg;
  return values;
}

// A plain dark background (no floor), so that any lit surface differs from it clearly.
RenderOptions TestRender(int supersample = 1) {
  RenderOptions options;
  options.width = kWidth;
  options.height = kHeight;
  options.supersample = supersample;
  options.background = {{0.0F, 0.0F, 0.25F, 1.0F}};
  options.overlay = false;
  return options;
}

const cv::Vec3b kBackground(64, 0, 0);  // BGR of (0, 0, 0.25)

bool IsBackground(const cv::Mat& image, const Eigen::Vector2d& pixel) {
  const cv::Vec3b bgr =
      image.at<cv::Vec3b>(static_cast<int>(pixel.y()), static_cast<int>(pixel.x()));
  return std::abs(bgr[0] - kBackground[0]) <= 2 && bgr[1] <= 2 && bgr[2] <= 2;
}

cv::Vec3b At(const cv::Mat& image, const Eigen::Vector2d& pixel) {
  return image.at<cv::Vec3b>(static_cast<int>(pixel.y()), static_cast<int>(pixel.x()));
}

bool Inside(const Eigen::Vector2d& pixel) {
  return pixel.x() >= 0 && pixel.y() >= 0 && pixel.x() < kWidth && pixel.y() < kHeight;
}

class RenderTest : public ::testing::Test {
 protected:
  core::RobotModel puma_ = core::LoadRobotModel("config/robots/puma260.yaml");
  SceneOptions scene_options_ = [] {
    SceneOptions options;
    options.show_floor = false;
    return options;
  }();
  Camera camera_ = [] {
    Camera camera;
    camera.azimuth_rad = -60 * kDeg;
    camera.elevation_rad = 20 * kDeg;
    camera.distance_m = 1.1;
    camera.target_m = Eigen::Vector3d(0.1, 0, 0.3);
    return camera;
  }();
};

TEST_F(RenderTest, KnownPoseShowsTheRobotWhereItsLinksProjectAndBackgroundElsewhere) {
  const std::vector<double> q = Degrees({30, -60, 120, 0, 30, 0});
  ViewState state;
  state.virtual_position = q;
  const Scene scene = BuildScene(&puma_, nullptr, state, scene_options_);
  OsmesaRenderer renderer(TestRender());
  const cv::Mat image = renderer.Render(scene, camera_).clone();
  ASSERT_EQ(image.cols, kWidth);
  ASSERT_EQ(image.rows, kHeight);
  ASSERT_EQ(image.type(), CV_8UC3);

  // Joint origins 1..5 lie inside link shapes (frame 0 and 6 sit on faces, not inside).
  const core::ForwardResult fk = core::ForwardKinematics(puma_, core::ToJointVector(q));
  int checked = 0;
  for (size_t frame = 1; frame <= 5; ++frame) {
    const auto pixel = ProjectToPixel(camera_, kWidth, kHeight, fk.frames[frame].translation());
    ASSERT_TRUE(pixel && Inside(*pixel)) << "frame " << frame << " out of the picture";
    EXPECT_FALSE(IsBackground(image, *pixel))
        << "frame " << frame << " at " << pixel->transpose() << " shows the background";
    ++checked;
  }
  // Every shape centre of the arm, too; lit light-grey links are bright.
  for (const SceneShape& shape : scene.shapes) {
    const auto pixel = ProjectToPixel(camera_, kWidth, kHeight, shape.pose.translation());
    ASSERT_TRUE(pixel && Inside(*pixel));
    EXPECT_FALSE(IsBackground(image, *pixel)) << "shape of link " << shape.index;
    ++checked;
  }
  EXPECT_GE(checked, 15);
  // Background in the corners, and where the arm is not (low in front, high behind).
  for (const Eigen::Vector2d& corner :
       {Eigen::Vector2d(1, 1), Eigen::Vector2d(kWidth - 2, 1), Eigen::Vector2d(1, kHeight - 2),
        Eigen::Vector2d(kWidth - 2, kHeight - 2)}) {
    EXPECT_TRUE(IsBackground(image, corner)) << corner.transpose();
  }
  for (const Eigen::Vector3d& far :
       {Eigen::Vector3d(0.35, -0.2, 0.1), Eigen::Vector3d(-0.2, 0.1, 0.55)}) {
    const auto pixel = ProjectToPixel(camera_, kWidth, kHeight, far);
    ASSERT_TRUE(pixel && Inside(*pixel));
    EXPECT_TRUE(IsBackground(image, *pixel)) << far.transpose();
  }
  // The base sits low in the image, the wrist high: z is up on screen.
  const auto base = ProjectToPixel(camera_, kWidth, kHeight, fk.frames[0].translation());
  const auto wrist = ProjectToPixel(camera_, kWidth, kHeight, fk.frames[4].translation());
  EXPECT_GT(base->y(), wrist->y() + 40);
}

TEST_F(RenderTest, GhostAndRealArmInTheirOwnColoursApartFromTheVirtualArm) {
  // Seen from above, the three arms point in three directions.
  Camera top = camera_;
  top.elevation_rad = 80 * kDeg;
  top.distance_m = 1.3;
  top.target_m = Eigen::Vector3d(0, 0, 0.2);
  ViewState state;
  state.virtual_position = Degrees({0, 0, 0, 0, 0, 0});    // upper arm along +x
  state.setpoint_position = Degrees({90, 0, 0, 0, 0, 0});  // along +y
  state.real_position = Degrees({-90, 0, 0, 0, 0, 0});     // along -y
  const Scene scene = BuildScene(&puma_, nullptr, state, scene_options_);
  OsmesaRenderer renderer(TestRender());
  const cv::Mat image = renderer.Render(scene, top).clone();
  // The middle of each upper arm (link 2's box centre).
  auto upper_arm_middle = [&](const std::vector<double>& q) {
    const core::ForwardResult fk = core::ForwardKinematics(puma_, core::ToJointVector(q));
    const Eigen::Vector3d centre = fk.frames[2] * puma_.links[2].shapes[0].pose.position_m;
    return *ProjectToPixel(top, kWidth, kHeight, centre);
  };
  const cv::Vec3b ghost = At(image, upper_arm_middle(*state.setpoint_position));
  const cv::Vec3b real = At(image, upper_arm_middle(*state.real_position));
  const cv::Vec3b virt = At(image, upper_arm_middle(*state.virtual_position));
  // Ghost: translucent green over the dark blue background (BGR order).
  EXPECT_GT(ghost[1], ghost[2] + 20) << ghost;
  EXPECT_GT(ghost[1], 50) << ghost;
  // Real arm: orange.
  EXPECT_GT(real[2], real[0] + 60) << real;
  EXPECT_GT(real[2], 120) << real;
  // Virtual arm: its own light grey.
  EXPECT_GT(virt[0], 120) << virt;
  EXPECT_LT(std::abs(virt[0] - virt[2]), 40) << virt;
}

TEST_F(RenderTest, SupersamplingKeepsTheGeometryAndTheOverlayDrawsText) {
  ViewState state;
  state.virtual_position = Degrees({30, -60, 120, 0, 30, 0});
  const Scene scene = BuildScene(&puma_, nullptr, state, scene_options_);
  OsmesaRenderer plain(TestRender(1));
  OsmesaRenderer smooth(TestRender(3));
  const cv::Mat a = plain.Render(scene, camera_).clone();
  const cv::Mat b = smooth.Render(scene, camera_).clone();
  // Same picture up to edge pixels: the mean difference is small.
  cv::Mat difference;
  cv::absdiff(a, b, difference);
  EXPECT_LT(cv::mean(difference)[0], 6.0);
  // Alternating between two renderers (two OSMesa contexts) in one thread works.
  const cv::Mat again = plain.Render(scene, camera_).clone();
  EXPECT_EQ(cv::norm(a, again, cv::NORM_INF), 0.0);

  RenderOptions with_text = TestRender(1);
  with_text.overlay = true;
  OsmesaRenderer texting(with_text);
  const cv::Mat c = texting.Render(scene, camera_).clone();
  const cv::Rect top_left(0, 0, kWidth / 2, 20);
  EXPECT_GT(cv::norm(a(top_left), c(top_left), cv::NORM_L1), 1000.0);
}

TEST(RendererTest, RefusesSizesItCannotDraw) {
  RenderOptions options;
  options.width = 8;
  EXPECT_THROW(OsmesaRenderer{options}, RenderError);
  options.width = 640;
  options.supersample = 5;
  EXPECT_THROW(OsmesaRenderer{options}, RenderError);
}

TEST(RendererTest, AnEmptySceneIsTheBackground) {
  RenderOptions options = TestRender();
  OsmesaRenderer renderer(options);
  const cv::Mat image = renderer.Render(Scene{}, Camera{});
  cv::Mat mask;
  cv::inRange(image, kBackground, kBackground, mask);
  EXPECT_EQ(cv::countNonZero(mask), kWidth * kHeight);
  EXPECT_FALSE(renderer.gl_description().empty());
}

}  // namespace
}  // namespace sirupp::viewer
