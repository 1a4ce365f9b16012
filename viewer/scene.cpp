#include "viewer/scene.hpp"

#include <cmath>
#include <cstdio>

#include "core/kinematics.hpp"

namespace sirupp::viewer {

namespace {

bool Usable(const core::RobotModel& model, const std::optional<std::vector<double>>& position) {
  if (!position || static_cast<int>(position->size()) != model.num_joints()) return false;
  for (double value : *position) {
    if (!std::isfinite(value)) return false;
  }
  return true;
}

// Adds the shapes of links first_link..n at joint positions q.
void AddArm(const core::RobotModel& model, const std::vector<double>& q, Role role,
            const std::optional<Rgba>& colour, int first_link, Scene& scene) {
  const core::ForwardResult fk = core::ForwardKinematics(model, core::ToJointVector(q));
  for (int link = first_link; link < static_cast<int>(model.links.size()); ++link) {
    for (const core::Shape& shape : model.links[static_cast<size_t>(link)].shapes) {
      SceneShape out;
      out.type = shape.type;
      out.pose = fk.frames[static_cast<size_t>(link)] * shape.pose.ToIsometry();
      out.size_m = shape.size_m;
      out.rgba = colour ? *colour : shape.rgba;
      out.role = role;
      out.index = link;
      scene.shapes.push_back(out);
    }
  }
}

void AddFrames(const core::RobotModel& model, const std::vector<double>& q, double length_m,
               Scene& scene) {
  const core::ForwardResult fk = core::ForwardKinematics(model, core::ToJointVector(q));
  const Rgba colours[3] = {
      {{0.9F, 0.1F, 0.1F, 1.0F}}, {{0.1F, 0.75F, 0.1F, 1.0F}}, {{0.1F, 0.2F, 0.95F, 1.0F}}};
  for (size_t frame = 0; frame < fk.frames.size(); ++frame) {
    const Eigen::Isometry3d& pose = fk.frames[frame];
    for (int axis = 0; axis < 3; ++axis) {
      SceneLine line;
      line.from_m = pose.translation();
      line.to_m = pose.translation() + length_m * pose.linear().col(axis);
      line.rgba = colours[axis];
      line.role = Role::kFrameAxis;
      line.index = static_cast<int>(frame);
      scene.lines.push_back(line);
    }
  }
}

void AddFloor(const SceneOptions& options, Scene& scene) {
  const double half = options.floor_half_size_m;
  SceneShape floor;
  floor.type = core::ShapeType::kBox;
  floor.pose.translation() = Eigen::Vector3d(0, 0, -0.001);
  floor.size_m = Eigen::Vector3d(2 * half, 2 * half, 0.002);  // top face at z = 0
  floor.rgba = options.floor_rgba;
  floor.role = Role::kFloor;
  scene.shapes.push_back(floor);
  if (!(options.grid_step_m > 0)) return;
  const int steps = static_cast<int>(std::floor(half / options.grid_step_m + 1e-9));
  for (int i = -steps; i <= steps; ++i) {
    const double at = i * options.grid_step_m;
    SceneLine along_x;
    along_x.from_m = Eigen::Vector3d(-half, at, 0);
    along_x.to_m = Eigen::Vector3d(half, at, 0);
    along_x.rgba = options.grid_rgba;
    SceneLine along_y = along_x;
    along_y.from_m = Eigen::Vector3d(at, -half, 0);
    along_y.to_m = Eigen::Vector3d(at, half, 0);
    scene.lines.push_back(along_x);
    scene.lines.push_back(along_y);
  }
}

}  // namespace

std::string JointLine(const std::string& label, const core::RobotModel& model,
                      const std::vector<double>& position) {
  std::string line = label;
  line.resize(std::max<size_t>(label.size(), 5), ' ');
  for (size_t i = 0; i < position.size() && i < model.joints.size(); ++i) {
    const bool prismatic = model.joints[i].type == core::JointType::kPrismatic;
    char value[32];
    std::snprintf(value, sizeof value, " %7.1f%s",
                  prismatic ? position[i] * 1000.0 : position[i] * 180.0 / M_PI,
                  prismatic ? "mm" : "");
    line += value;
  }
  return line;
}

Scene BuildScene(const core::RobotModel* model, const core::Environment* environment,
                 const ViewState& state, const SceneOptions& options) {
  Scene scene;
  if (options.show_floor) AddFloor(options, scene);
  if (environment != nullptr) {
    for (size_t i = 0; i < environment->objects.size(); ++i) {
      const core::EnvironmentObject& object = environment->objects[i];
      SceneShape out;
      out.type = object.shape.type;
      out.pose = object.shape.pose.ToIsometry();
      out.size_m = object.shape.size_m;
      out.rgba = object.shape.rgba;
      out.role = Role::kEnvironment;
      out.index = static_cast<int>(i);
      scene.shapes.push_back(out);
    }
  }

  char head[160];
  std::snprintf(head, sizeof head, "t %.3f s  tick %lld", static_cast<double>(state.utime) * 1e-6,
                static_cast<long long>(state.tick));
  if (model == nullptr) {
    scene.overlay.push_back(std::string(head) + "  waiting for ROBOT_MODEL");
    return scene;
  }
  std::string first = model->name + "  " + head;
  if (!state.status_text.empty()) first += "  " + state.status_text;

  std::vector<double> virtual_q;
  if (Usable(*model, state.virtual_position)) {
    virtual_q = *state.virtual_position;
  } else {
    for (const core::Joint& joint : model->joints) virtual_q.push_back(joint.home);
    first += "  (no arm state: home pose)";
  }
  scene.overlay.push_back(first);
  const bool any_prismatic = [&] {
    for (const core::Joint& joint : model->joints) {
      if (joint.type == core::JointType::kPrismatic) return true;
    }
    return false;
  }();
  scene.overlay.push_back(JointLine("virt", *model, virtual_q) + (any_prismatic ? "" : "  deg"));
  AddArm(*model, virtual_q, Role::kVirtualArm, std::nullopt, 0, scene);

  if (options.show_ghost && Usable(*model, state.setpoint_position)) {
    AddArm(*model, *state.setpoint_position, Role::kGhostArm, options.ghost_rgba, 1, scene);
    scene.overlay.push_back(JointLine("set", *model, *state.setpoint_position));
  }
  if (Usable(*model, state.real_position)) {
    AddArm(*model, *state.real_position, Role::kRealArm, options.real_rgba, 1, scene);
    scene.overlay.push_back(JointLine("real", *model, *state.real_position));
  }
  if (options.show_frames) AddFrames(*model, virtual_q, options.axis_length_m, scene);
  return scene;
}

}  // namespace sirupp::viewer
