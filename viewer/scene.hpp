#pragma once
// The scene builder, free of OpenGL: from the robot model, the environment and the arms' joint
// positions it makes the list of shapes (with world poses and colours) and lines that the renderer
// draws, and the overlay text. A pure function of its inputs, so tests check it against forward
// kinematics without rendering.
//
// What it draws:
//  - the virtual arm (SIM_ARM_STATE) solid, in the model's link colours, base included;
//  - the set-point arm (ARM_SETPOINT) as a translucent ghost, links 1..n (the base is shared);
//  - the real arm (REAL_ARM_STATE, while fresh) solid in a second colour, links 1..n;
//  - the environment's objects at their poses; a floor with a grid (z = 0);
//  - optionally each DH frame 0..n as three axes (x red, y green, z blue), for lessons.
// Link i's shapes sit in DH frame i (core/kinematics.hpp), so a shape's world pose is
// ForwardKinematics(q).frames[i] * shape.pose.

#include <Eigen/Geometry>
#include <array>
#include <optional>
#include <string>
#include <vector>

#include "core/environment.hpp"
#include "core/geometry.hpp"
#include "core/robot_model.hpp"

namespace sirupp::viewer {

using Rgba = std::array<float, 4>;  // red, green, blue, opacity; each 0..1

// What a shape or line stands for; the renderer orders its passes by it (opaque, then the real arm
// behind ties with the virtual one, then translucent).
enum class Role { kVirtualArm, kGhostArm, kRealArm, kEnvironment, kFloor, kFrameAxis };

struct SceneShape {
  core::ShapeType type = core::ShapeType::kBox;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();  // world pose of the shape's centre
  Eigen::Vector3d size_m = Eigen::Vector3d::Zero();        // as core::Shape::size_m
  Rgba rgba{{0.7F, 0.7F, 0.7F, 1.0F}};
  Role role = Role::kVirtualArm;
  int index = -1;  // link index for arm shapes, object index for environment objects
};

struct SceneLine {
  Eigen::Vector3d from_m = Eigen::Vector3d::Zero();  // world frame
  Eigen::Vector3d to_m = Eigen::Vector3d::Zero();
  Rgba rgba{{0.0F, 0.0F, 0.0F, 1.0F}};
  Role role = Role::kFloor;
  int index = -1;  // DH frame number for frame axes
};

struct Scene {
  std::vector<SceneShape> shapes;
  std::vector<SceneLine> lines;
  std::vector<std::string> overlay;  // text lines for the top-left corner, top to bottom
};

struct SceneOptions {
  bool show_ghost = true;
  bool show_frames = false;
  bool show_floor = true;
  double floor_half_size_m = 0.8;  // the floor spans +-this in x and y around the world origin
  double grid_step_m = 0.1;
  double axis_length_m = 0.06;                    // of each DH frame's axes
  Rgba ghost_rgba{{0.35F, 0.85F, 0.45F, 0.35F}};  // translucent green
  Rgba real_rgba{{0.95F, 0.55F, 0.15F, 1.0F}};    // orange
  Rgba floor_rgba{{0.80F, 0.82F, 0.85F, 1.0F}};
  Rgba grid_rgba{{0.55F, 0.58F, 0.62F, 1.0F}};
};

// The joint positions (rad or m) of the three arms and what the overlay shows. An absent arm is
// not drawn, except the virtual one: without a state it is drawn at the joints' home positions.
struct ViewState {
  std::optional<std::vector<double>> virtual_position;
  std::optional<std::vector<double>> setpoint_position;
  std::optional<std::vector<double>> real_position;
  int64_t utime = 0;        // of the virtual state (sim time), microseconds
  int64_t tick = 0;         // of the virtual state
  std::string status_text;  // controller mode and state, "" when unknown
};

// Builds the scene. `model` or `environment` may be null (not received yet); a position vector
// whose size differs from the model's joint count, or that holds a non-finite value, is left out
// (the viewer node refuses such messages before they get here).
Scene BuildScene(const core::RobotModel* model, const core::Environment* environment,
                 const ViewState& state, const SceneOptions& options);

// Joint values for the overlay: revolute joints in degrees, prismatic in millimetres, e.g.
// "virt  q  12.0  -45.3 ...". `label` is padded to five characters.
std::string JointLine(const std::string& label, const core::RobotModel& model,
                      const std::vector<double>& position);

}  // namespace sirupp::viewer
