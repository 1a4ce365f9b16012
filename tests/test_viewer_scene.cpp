// Tests of the viewer's GL-free half: the scene builder against forward kinematics (every link
// shape sits at its DH frame composed with the shape's pose), the ghost, the real arm, the DH
// axes switch, the environment, refused inputs; the camera matrices; the settings file.

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "core/environment.hpp"
#include "core/errors.hpp"
#include "core/kinematics.hpp"
#include "core/model_loader.hpp"
#include "viewer/camera.hpp"
#include "viewer/scene.hpp"
#include "viewer/viewer_config.hpp"

namespace sirupp::viewer {
namespace {

constexpr double kDeg = M_PI / 180.0;

std::vector<double> Degrees(std::vector<double> values) {
  for (double& value : values) value *= kDeg;
  return values;
}

std::vector<const SceneShape*> WithRole(const Scene& scene, Role role) {
  std::vector<const SceneShape*> found;
  for (const SceneShape& shape : scene.shapes) {
    if (shape.role == role) found.push_back(&shape);
  }
  return found;
}

// Every shape of links first_link..n, in model order, must sit at FK(q).frames[link] * shape.pose.
void ExpectArmOnForwardKinematics(const core::RobotModel& model, const std::vector<double>& q,
                                  const std::vector<const SceneShape*>& shapes, int first_link) {
  const core::ForwardResult fk = core::ForwardKinematics(model, core::ToJointVector(q));
  size_t next = 0;
  for (int link = first_link; link < static_cast<int>(model.links.size()); ++link) {
    for (const core::Shape& shape : model.links[static_cast<size_t>(link)].shapes) {
      ASSERT_LT(next, shapes.size()) << "missing shapes from link " << link;
      const SceneShape& drawn = *shapes[next++];
      const Eigen::Isometry3d expected =
          fk.frames[static_cast<size_t>(link)] * shape.pose.ToIsometry();
      EXPECT_EQ(drawn.index, link);
      EXPECT_EQ(drawn.type, shape.type);
      EXPECT_TRUE(drawn.size_m.isApprox(shape.size_m));
      EXPECT_LT((drawn.pose.translation() - expected.translation()).norm(), 1e-12)
          << "link " << link;
      EXPECT_LT((drawn.pose.linear() - expected.linear()).norm(), 1e-12) << "link " << link;
    }
  }
  EXPECT_EQ(next, shapes.size()) << "extra shapes";
}

class SceneTest : public ::testing::Test {
 protected:
  core::RobotModel puma_ = core::LoadRobotModel("config/robots/puma260.yaml");
  core::Environment table_ = core::LoadEnvironment("config/environments/table.xml");
  SceneOptions options_;
};

TEST_F(SceneTest, VirtualArmShapesSitOnForwardKinematicsFrames) {
  for (const std::vector<double>& pose :
       {Degrees({0, 0, 0, 0, 0, 0}), Degrees({30, -60, 120, 10, 30, -20}),
        Degrees({-140, 150, -140, 300, -110, 250})}) {
    ViewState state;
    state.virtual_position = pose;
    const Scene scene = BuildScene(&puma_, nullptr, state, options_);
    ExpectArmOnForwardKinematics(puma_, pose, WithRole(scene, Role::kVirtualArm), 0);
    // The virtual arm keeps the model's own colours.
    const std::vector<const SceneShape*> shapes = WithRole(scene, Role::kVirtualArm);
    EXPECT_EQ(shapes.back()->rgba, puma_.links.back().shapes.back().rgba);
  }
}

TEST_F(SceneTest, OtherArmsToo) {
  for (const char* file : {"config/robots/planar3.yaml", "config/robots/stanford.yaml"}) {
    const core::RobotModel model = core::LoadRobotModel(file);
    std::vector<double> q;
    for (const core::Joint& joint : model.joints) {
      q.push_back(0.3 * joint.position_min + 0.7 * joint.position_max);
    }
    ViewState state;
    state.virtual_position = q;
    state.setpoint_position = q;
    const Scene scene = BuildScene(&model, nullptr, state, options_);
    ExpectArmOnForwardKinematics(model, q, WithRole(scene, Role::kVirtualArm), 0);
    ExpectArmOnForwardKinematics(model, q, WithRole(scene, Role::kGhostArm), 1);
  }
}

TEST_F(SceneTest, GhostFollowsTheSetPointTranslucent) {
  ViewState state;
  state.virtual_position = Degrees({0, 0, 0, 0, 0, 0});
  state.setpoint_position = Degrees({90, -45, 60, 0, 20, 0});
  const Scene scene = BuildScene(&puma_, nullptr, state, options_);
  const std::vector<const SceneShape*> ghost = WithRole(scene, Role::kGhostArm);
  ExpectArmOnForwardKinematics(puma_, *state.setpoint_position, ghost, 1);  // no second base
  for (const SceneShape* shape : ghost) {
    EXPECT_EQ(shape->rgba, options_.ghost_rgba);
    EXPECT_LT(shape->rgba[3], 1.0F);
  }
  options_.show_ghost = false;
  EXPECT_TRUE(WithRole(BuildScene(&puma_, nullptr, state, options_), Role::kGhostArm).empty());
}

TEST_F(SceneTest, RealArmOnlyWhenPresentInItsOwnColour) {
  ViewState state;
  state.virtual_position = Degrees({10, -30, 40, 0, 0, 0});
  EXPECT_TRUE(WithRole(BuildScene(&puma_, nullptr, state, options_), Role::kRealArm).empty());
  state.real_position = Degrees({12, -28, 43, 0, 5, 0});
  const Scene scene = BuildScene(&puma_, nullptr, state, options_);
  const std::vector<const SceneShape*> real = WithRole(scene, Role::kRealArm);
  ExpectArmOnForwardKinematics(puma_, *state.real_position, real, 1);
  for (const SceneShape* shape : real) EXPECT_EQ(shape->rgba, options_.real_rgba);
  EXPECT_NE(options_.real_rgba, puma_.links[2].shapes[0].rgba);
  ASSERT_GE(scene.overlay.size(), 3u);
  EXPECT_EQ(scene.overlay.back().rfind("real", 0), 0u) << scene.overlay.back();
  EXPECT_NE(scene.overlay.back().find("12.0"), std::string::npos) << scene.overlay.back();
}

TEST_F(SceneTest, DhFramesAsAxesOnlyWhenSwitchedOn) {
  ViewState state;
  state.virtual_position = Degrees({20, -50, 70, 30, 40, 50});
  auto axes = [](const Scene& scene) {
    std::vector<SceneLine> found;
    for (const SceneLine& line : scene.lines) {
      if (line.role == Role::kFrameAxis) found.push_back(line);
    }
    return found;
  };
  EXPECT_TRUE(axes(BuildScene(&puma_, nullptr, state, options_)).empty());
  options_.show_frames = true;
  const std::vector<SceneLine> lines = axes(BuildScene(&puma_, nullptr, state, options_));
  ASSERT_EQ(lines.size(), 3u * 7u);  // frames 0..6, x y z each
  const core::ForwardResult fk =
      core::ForwardKinematics(puma_, core::ToJointVector(*state.virtual_position));
  for (size_t i = 0; i < lines.size(); ++i) {
    const Eigen::Isometry3d& frame = fk.frames[i / 3];
    EXPECT_EQ(lines[i].index, static_cast<int>(i / 3));
    EXPECT_LT((lines[i].from_m - frame.translation()).norm(), 1e-12);
    const Eigen::Vector3d direction = (lines[i].to_m - lines[i].from_m) / options_.axis_length_m;
    EXPECT_LT((direction - frame.linear().col(static_cast<int>(i % 3))).norm(), 1e-12);
  }
  // x red, y green, z blue.
  EXPECT_GT(lines[0].rgba[0], 0.8F);
  EXPECT_GT(lines[1].rgba[1], 0.7F);
  EXPECT_GT(lines[2].rgba[2], 0.8F);
}

TEST_F(SceneTest, EnvironmentObjectsAndFloor) {
  const Scene scene = BuildScene(&puma_, &table_, ViewState{}, options_);
  const std::vector<const SceneShape*> objects = WithRole(scene, Role::kEnvironment);
  ASSERT_EQ(objects.size(), table_.objects.size());
  for (size_t i = 0; i < objects.size(); ++i) {
    EXPECT_TRUE(objects[i]->pose.isApprox(table_.objects[i].shape.pose.ToIsometry()));
    EXPECT_EQ(objects[i]->rgba, table_.objects[i].shape.rgba);
    EXPECT_EQ(objects[i]->index, static_cast<int>(i));
  }
  const std::vector<const SceneShape*> floor = WithRole(scene, Role::kFloor);
  ASSERT_EQ(floor.size(), 1u);
  EXPECT_NEAR(floor[0]->pose.translation().z() + floor[0]->size_m.z() / 2, 0.0, 1e-12);
  options_.show_floor = false;
  EXPECT_TRUE(WithRole(BuildScene(&puma_, &table_, ViewState{}, options_), Role::kFloor).empty());
}

TEST_F(SceneTest, WithoutAStateTheArmStandsAtHome) {
  ViewState state;
  state.setpoint_position = std::vector<double>(5, 0.0);  // wrong joint count: left out
  const Scene scene = BuildScene(&puma_, nullptr, state, options_);
  std::vector<double> home;
  for (const core::Joint& joint : puma_.joints) home.push_back(joint.home);
  ExpectArmOnForwardKinematics(puma_, home, WithRole(scene, Role::kVirtualArm), 0);
  EXPECT_TRUE(WithRole(scene, Role::kGhostArm).empty());
  EXPECT_NE(scene.overlay[0].find("no arm state"), std::string::npos) << scene.overlay[0];
}

TEST_F(SceneTest, NonFinitePositionsAreLeftOut) {
  ViewState state;
  state.virtual_position = Degrees({0, 0, 0, 0, 0, 0});
  state.real_position = Degrees({0, 0, 0, 0, 0, 0});
  (*state.real_position)[2] = std::nan("");
  EXPECT_TRUE(WithRole(BuildScene(&puma_, nullptr, state, options_), Role::kRealArm).empty());
}

TEST_F(SceneTest, NoModelYet) {
  const Scene scene = BuildScene(nullptr, &table_, ViewState{}, options_);
  EXPECT_TRUE(WithRole(scene, Role::kVirtualArm).empty());
  EXPECT_EQ(WithRole(scene, Role::kEnvironment).size(), table_.objects.size());
  ASSERT_EQ(scene.overlay.size(), 1u);
  EXPECT_NE(scene.overlay[0].find("waiting for ROBOT_MODEL"), std::string::npos);
}

TEST_F(SceneTest, OverlayShowsTimeModeAndJointAnglesInDegrees) {
  ViewState state;
  state.virtual_position = Degrees({90, -45.26, 0, 0, 0, 0});
  state.utime = 12345678;
  state.tick = 24112;
  state.status_text = "automatic, moving";
  const Scene scene = BuildScene(&puma_, nullptr, state, options_);
  ASSERT_GE(scene.overlay.size(), 2u);
  EXPECT_NE(scene.overlay[0].find("t 12.346 s"), std::string::npos) << scene.overlay[0];
  EXPECT_NE(scene.overlay[0].find("tick 24112"), std::string::npos) << scene.overlay[0];
  EXPECT_NE(scene.overlay[0].find("automatic, moving"), std::string::npos) << scene.overlay[0];
  EXPECT_NE(scene.overlay[1].find("90.0"), std::string::npos) << scene.overlay[1];
  EXPECT_NE(scene.overlay[1].find("-45.3"), std::string::npos) << scene.overlay[1];
  EXPECT_NE(scene.overlay[1].find("deg"), std::string::npos) << scene.overlay[1];
}

TEST(CameraTest, TargetProjectsToTheImageCentreAndZIsUp) {
  Camera camera;
  const std::optional<Eigen::Vector2d> centre = ProjectToPixel(camera, 640, 480, camera.target_m);
  ASSERT_TRUE(centre.has_value());
  EXPECT_NEAR(centre->x(), 320, 1e-9);
  EXPECT_NEAR(centre->y(), 240, 1e-9);
  const std::optional<Eigen::Vector2d> above =
      ProjectToPixel(camera, 640, 480, camera.target_m + Eigen::Vector3d(0, 0, 0.1));
  ASSERT_TRUE(above.has_value());
  EXPECT_LT(above->y(), 240 - 10);  // higher in the world = higher in the image
  EXPECT_NEAR(above->x(), 320, 1e-6);
  // Behind the eye: not in the image.
  const Eigen::Vector3d behind = camera.Eye() + (camera.Eye() - camera.target_m);
  EXPECT_FALSE(ProjectToPixel(camera, 640, 480, behind).has_value());
  // The eye sits at the distance, azimuth and elevation given.
  camera.azimuth_rad = 0;
  camera.elevation_rad = 0;
  EXPECT_TRUE(camera.Eye().isApprox(camera.target_m + Eigen::Vector3d(camera.distance_m, 0, 0)));
}

TEST(CameraTest, ProblemsNameTheValueAndTheRange) {
  Camera camera;
  EXPECT_EQ(CameraProblem(camera), "");
  camera.elevation_rad = 1.6;
  EXPECT_NE(CameraProblem(camera).find("elevation 1.6 rad is outside [-1.55, 1.55]"),
            std::string::npos)
      << CameraProblem(camera);
  camera = Camera{};
  camera.distance_m = 0;
  EXPECT_NE(CameraProblem(camera).find("distance 0 m"), std::string::npos);
  camera = Camera{};
  camera.target_m.y() = std::nan("");
  EXPECT_NE(CameraProblem(camera).find("target[1] nan"), std::string::npos);
}

TEST(ViewerConfigTest, SettingsApplyAndBadOnesNameFileLineAndKey) {
  ViewerOptions options;
  ApplyViewerConfig("config/viewer/default.yaml", options);
  EXPECT_EQ(options.render.width, 640);
  EXPECT_NEAR(options.camera.azimuth_rad, -50 * kDeg, 1e-12);
  ApplyViewerConfigText("width: 320\nformat: rgb\nframes: true\ncamera: {distance_m: 2}\n",
                        "a.yaml", options);
  EXPECT_EQ(options.render.width, 320);
  EXPECT_EQ(options.format, ImageFormat::kRgb);
  EXPECT_TRUE(options.scene.show_frames);
  EXPECT_EQ(options.camera.distance_m, 2);
  EXPECT_EQ(options.render.height, 480);  // untouched
  try {
    ApplyViewerConfigText("width: 640\nformat: bmp\n", "b.yaml", options);
    ADD_FAILURE() << "format bmp accepted";
  } catch (const core::ConfigError& error) {
    const std::string text = error.what();
    EXPECT_NE(text.find("b.yaml:2"), std::string::npos) << text;
    EXPECT_NE(text.find("format"), std::string::npos) << text;
    EXPECT_NE(text.find("bmp"), std::string::npos) << text;
  }
  EXPECT_THROW(ApplyViewerConfigText("colour: red\n", "c.yaml", options), core::ConfigError);
  EXPECT_THROW(ApplyViewerConfigText("camera: {elevation_deg: 95}\n", "d.yaml", options),
               core::ConfigError);
}

}  // namespace
}  // namespace sirupp::viewer
