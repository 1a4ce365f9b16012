#include "panel/rig_commands.hpp"

#include <cmath>

#include "control/plan.hpp"
#include "control/plan_collision.hpp"
#include "control/pose_goal.hpp"
#include "core/environment.hpp"
#include "core/errors.hpp"
#include "core/geometry.hpp"
#include "core/inverse_kinematics.hpp"
#include "core/model_loader.hpp"
#include "core/printable.hpp"
#include "core/units.hpp"
#include "logger/recorder.hpp"
#include "planning/collision_model.hpp"
#include "planning/plan_text.hpp"
#include "planning/planner.hpp"
#include "servo/chip_gains.hpp"

namespace sirupp::panel {
namespace {

// The model is needed for every check; without it nothing is sent.
struct NoModel : std::runtime_error {
  NoModel() : std::runtime_error("no robot model yet: is sirupp-sim running on this bus?") {}
};

// Joints in the page's units.
Json DisplayJoints(const core::RobotModel& model, const core::JointVector& q) {
  Json out = Json::array();
  for (size_t j = 0; j < model.joints.size(); ++j) {
    out.push_back(ToDisplay(model.joints[j], q[static_cast<Eigen::Index>(j)]));
  }
  return out;
}

// What a contact is, for the page: the model's sentence and the point (m).
Json ContactJson(const planning::CollisionModel& collision, const planning::SweepFinding& f,
                 const core::RobotModel& model) {
  return Json{
      {"what", collision.Describe(f.contact)},
      {"kind", f.contact.kind == planning::ContactKind::kSelf
                   ? "self"
                   : (f.contact.kind == planning::ContactKind::kFreeObject ? "free" : "static")},
      {"joints", DisplayJoints(model, f.state)},
      {"time_s", f.time_s}};
}

// The tool's path along straight joint-space segments between waypoints (m), for the 3D view.
Json ToolPath(const core::RobotModel& model, const std::vector<planning::JointVector>& path) {
  Json points = Json::array();
  for (size_t i = 0; i + 1 < path.size(); ++i) {
    const double span = (path[i + 1] - path[i]).cwiseAbs().maxCoeff();
    const int pieces = std::max(1, static_cast<int>(std::ceil(span / 0.02)));
    for (int k = 0; k < pieces + (i + 2 == path.size() ? 1 : 0); ++k) {
      const double s = static_cast<double>(k) / pieces;
      const Eigen::Vector3d p =
          core::ToolPose(model, path[i] + s * (path[i + 1] - path[i])).translation();
      points.push_back(Json::array({p.x(), p.y(), p.z()}));
    }
  }
  if (path.size() == 1) {
    const Eigen::Vector3d p = core::ToolPose(model, path[0]).translation();
    points.push_back(Json::array({p.x(), p.y(), p.z()}));
  }
  return points;
}

// The most tree vertices sent to the page (the C-space view draws them).
constexpr size_t kMaxTreeVertices = 4000;

}  // namespace

CommandResult FromAnswer(const client::Answer& answer, const std::string& what, Json detail) {
  detail["request"] = Json{{"channel", answer.request.channel},
                           {"utime", answer.request.utime},
                           {"seq", answer.request.seq}};
  switch (answer.result) {
    case client::Result::kAccepted: {
      detail["move_id"] = answer.move_id;
      detail["status_seq"] = answer.status_seq;
      std::string message = answer.request.channel + ": " + what + " accepted";
      if (answer.move_id >= 0) message += " (move " + std::to_string(answer.move_id) + ")";
      return CommandResult{true, 200, message, std::move(detail)};
    }
    case client::Result::kRefused:
      return CommandResult::Fail(409,
                                 answer.request.channel + ": " + what + " refused: " + answer.error,
                                 std::move(detail));
    case client::Result::kNoAnswer:
      break;
  }
  return CommandResult::Fail(504, answer.error, std::move(detail));
}

CommandResult RigCommands::MoveJoints(const std::vector<std::optional<double>>& targets,
                                      double speed_scale) {
  std::optional<core::RobotModel> model = hub_.Model();
  if (!model) return CommandResult::Fail(503, NoModel().what());
  if (targets.size() != model->joints.size()) {
    return CommandResult::Fail(400, "targets: " + std::to_string(targets.size()) +
                                        " values; the model has " +
                                        std::to_string(model->joints.size()) + " joints");
  }
  if (!(speed_scale > 0 && speed_scale <= 1)) {
    return CommandResult::Fail(400, "speed: " + core::FormatNumber(speed_scale) +
                                        ": allowed (0, 1], a fraction of the default speed");
  }
  const std::optional<std::vector<double>> goals = hub_.PresentGoals();
  client::JointTarget target;
  bool any = false;
  for (size_t j = 0; j < targets.size(); ++j) {
    const core::Joint& joint = model->joints[j];
    double goal = goals ? (*goals)[j] : joint.home;
    if (targets[j]) {
      const double value = *targets[j];
      const double si = FromDisplay(joint, value);
      if (!std::isfinite(value) || si < joint.position_min || si > joint.position_max) {
        return CommandResult::Fail(
            400,
            "joint " + std::to_string(j + 1) + " (" + joint.name + "): " +
                core::FormatNumber(value) + " " + DisplayUnit(joint) + " is outside its limits " +
                core::FormatApprox(ToDisplay(joint, joint.position_min)) + ".." +
                core::FormatApprox(ToDisplay(joint, joint.position_max)) + " " + DisplayUnit(joint),
            Json{{"joint", j}});
      }
      goal = si;
      any = true;
    }
    target.position.push_back(goal);
    target.max_velocity.push_back(joint.servo.default_velocity * speed_scale);
    target.acceleration.push_back(0.0);
    target.active.push_back(targets[j] ? 1 : 0);
  }
  if (!any) return CommandResult::Fail(400, "targets: no joint given");
  return FromAnswer(hub_.WithClient([&](client::Client& rig) { return rig.MoveJoints(target); }),
                    "joint target");
}

CommandResult RigCommands::MovePose(const std::vector<double>& v, const std::string& config,
                                    double speed_scale) {
  std::optional<core::RobotModel> model = hub_.Model();
  if (!model) return CommandResult::Fail(503, NoModel().what());
  if (v.size() != 6) return CommandResult::Fail(400, "pose: expected x y z roll pitch yaw");
  for (double value : v) {
    if (!std::isfinite(value)) return CommandResult::Fail(400, "pose: values must be finite");
  }
  if (!(speed_scale > 0 && speed_scale <= 1)) {
    return CommandResult::Fail(400,
                               "speed: " + core::FormatNumber(speed_scale) + ": allowed (0, 1]");
  }
  control::PoseRequest request;
  request.target.translation() << v[0], v[1], v[2];
  const Eigen::Quaterniond orientation =
      core::QuaternionFromRpy(v[3] * kDeg, v[4] * kDeg, v[5] * kDeg);
  request.target.linear() = orientation.toRotationMatrix();
  if (config != "nearest") {
    const std::optional<core::IkConfiguration> parsed = core::IkConfiguration::Parse(config);
    if (!parsed) {
      return CommandResult::Fail(400, "config '" + config +
                                          "' is not allowed; expected nearest or "
                                          "SHOULDER-ELBOW-WRIST, e.g. right-up-noflip");
    }
    request.SetConfig(*parsed);
  }
  const std::optional<std::vector<double>> present = hub_.VirtualJoints();
  const std::vector<double> reference = present && present->size() == model->joints.size()
                                            ? *present
                                            : control::HomePositions(*model);
  const control::PoseGoal goal =
      control::SolvePoseGoal(*model, request, core::ToJointVector(reference));
  if (!goal.ok) return CommandResult::Fail(400, "no joint solution: " + goal.reason);
  client::PoseTarget target;
  for (size_t i = 0; i < 3; ++i) target.position[i] = v[i];
  target.orientation[0] = orientation.w();
  target.orientation[1] = orientation.x();
  target.orientation[2] = orientation.y();
  target.orientation[3] = orientation.z();
  target.shoulder_left = request.shoulder_left;
  target.elbow_up = request.elbow_up;
  target.wrist_flip = request.wrist_flip;
  target.speed_scale = speed_scale;
  const client::Answer answer =
      hub_.WithClient([&](client::Client& rig) { return rig.MovePose(target); });
  Json expected = Json::array();
  for (size_t j = 0; j < model->joints.size(); ++j) {
    expected.push_back(ToDisplay(model->joints[j], goal.q[static_cast<Eigen::Index>(j)]));
  }
  return FromAnswer(answer, "tool target",
                    Json{{"expected", expected}, {"config", goal.config_name}});
}

CommandResult RigCommands::CheckPlan(const std::string& name, const std::string& text) {
  std::optional<core::RobotModel> model = hub_.Model();
  if (!model) return CommandResult::Fail(503, NoModel().what());
  const std::optional<std::vector<double>> goals = hub_.PresentGoals();
  const std::vector<double> start = goals ? *goals : control::HomePositions(*model);
  try {
    const control::Plan plan = control::ParsePlan(text, name, *model, start);
    Json steps = Json::array();
    for (const control::PlanStep& step : plan.steps) {
      steps.push_back(Json{{"line", step.line}, {"text", step.text}});
    }
    std::string message = name + ": ok: " + std::to_string(plan.steps.size()) + " steps, " +
                          std::to_string(plan.moves()) + " moves";
    Json detail{{"steps", steps}};
    const std::optional<core::Environment> environment = hub_.Environment();
    if (environment && !environment->objects.empty()) {
      planning::CollisionModel collision(*model, *environment, {});
      const control::PlanCollisionReport report =
          control::CheckPlanCollisions(*model, plan, start, collision, control::kPlanCheckStepRad);
      Json notes = Json::array();
      for (const planning::SweepFinding& f : report.free_touches) {
        Json note = ContactJson(collision, f, *model);
        note["line"] = f.step < 0 ? 0 : plan.steps[static_cast<size_t>(f.step)].line;
        notes.push_back(note);
      }
      detail["free_touches"] = notes;
      if (report.error) {
        const planning::SweepFinding& f = *report.error;
        Json contact = ContactJson(collision, f, *model);
        const int line = f.step < 0 ? 0 : plan.steps[static_cast<size_t>(f.step)].line;
        return CommandResult::Fail(
            422, control::FindingError(*model, plan, collision, f),
            Json{
                {"line", line}, {"column", 0}, {"problem", contact["what"]}, {"contact", contact}});
      }
      message += "; no collision with " + environment->name + " or the arm itself (" +
                 std::to_string(report.states_checked) + " set-points checked)";
    }
    return CommandResult{true, 200, message, detail};
  } catch (const core::ConfigError& error) {
    return CommandResult::Fail(422, error.what(),
                               Json{{"line", error.where().line},
                                    {"column", error.where().column},
                                    {"problem", error.problem()}});
  }
}

CommandResult RigCommands::MakePlan(const PlanGoal& goal) {
  std::optional<core::RobotModel> model = hub_.Model();
  if (!model) return CommandResult::Fail(503, NoModel().what());
  const int n = model->num_joints();
  const std::optional<core::Environment> environment = hub_.Environment();
  const core::Environment world = environment ? *environment : core::Environment{};
  const std::optional<std::vector<double>> goals = hub_.PresentGoals();
  const planning::JointVector start =
      core::ToJointVector(goals ? *goals : control::HomePositions(*model));
  planning::CollisionModel collision(*model, world, {});
  planning::JointVector target(n);
  try {
    if (!goal.joints.empty()) {
      if (static_cast<int>(goal.joints.size()) != n) {
        return CommandResult::Fail(400, "goal: " + std::to_string(goal.joints.size()) +
                                            " joints given; the model has " + std::to_string(n));
      }
      for (int j = 0; j < n; ++j) {
        const double v = goal.joints[static_cast<size_t>(j)];
        if (!std::isfinite(v)) return CommandResult::Fail(400, "goal: values must be finite");
        target[j] = FromDisplay(model->joints[static_cast<size_t>(j)], v);
      }
    } else {
      const std::vector<double>& v = goal.tool;
      if (v.size() != 6) return CommandResult::Fail(400, "tool: expected x y z roll pitch yaw");
      for (double value : v) {
        if (!std::isfinite(value)) return CommandResult::Fail(400, "tool: values must be finite");
      }
      Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
      pose.translation() << v[0], v[1], v[2];
      pose.linear() =
          core::QuaternionFromRpy(v[3] * kDeg, v[4] * kDeg, v[5] * kDeg).toRotationMatrix();
      target = planning::ToolGoal(collision, pose, goal.config, start);
    }
    planning::PlanRequest request;
    request.planner = goal.planner;
    request.seed = goal.seed;
    request.keep_tree = true;
    const planning::PlanResult result = planning::PlanPath(collision, start, target, request);
    if (!result.solved) return CommandResult::Fail(422, result.message);
    planning::PlanTextOptions text_options;
    text_options.comments = {
        "planned by the panel: " + result.message,
        "around " + (world.name.empty() ? std::string("no objects")
                                        : "the sim's environment " + world.name)};
    const std::string text = planning::PathToPlanText(*model, result.path, text_options);
    Json waypoints = Json::array(), marks = Json::array();
    for (const planning::JointVector& q : result.path) {
      waypoints.push_back(DisplayJoints(*model, q));
      const Eigen::Vector3d p = core::ToolPose(*model, q).translation();
      marks.push_back(Json::array({p.x(), p.y(), p.z()}));
    }
    Json vertices = Json::array();
    const size_t kept = std::min(result.tree.vertices.size(), kMaxTreeVertices);
    for (size_t i = 0; i < kept; ++i) {
      vertices.push_back(DisplayJoints(*model, result.tree.vertices[i]));
    }
    Json edges = Json::array();
    for (const auto& [a, b] : result.tree.edges) {
      if (static_cast<size_t>(a) < kept && static_cast<size_t>(b) < kept) {
        edges.push_back(Json::array({a, b}));
      }
    }
    return CommandResult{true, 200, result.message,
                         Json{{"text", text},
                              {"waypoints", waypoints},
                              {"tool_path", ToolPath(*model, result.path)},
                              {"tool_waypoints", marks},
                              {"tree", Json{{"vertices", vertices}, {"edges", edges}}},
                              {"length_rad", result.length_rad},
                              {"environment", world.name}}};
  } catch (const std::invalid_argument& error) {
    return CommandResult::Fail(400, error.what());
  }
}

CommandResult RigCommands::CSpace(int joint_a, int joint_b, double step_deg) {
  std::optional<core::RobotModel> model = hub_.Model();
  if (!model) return CommandResult::Fail(503, NoModel().what());
  if (!(step_deg >= 0.5 && step_deg <= 10)) {
    return CommandResult::Fail(400, "step: " + core::FormatNumber(step_deg) +
                                        " deg: allowed 0.5 to 10 (the grid's spacing)");
  }
  const std::optional<core::Environment> environment = hub_.Environment();
  planning::CollisionModel collision(*model, environment ? *environment : core::Environment{}, {});
  const std::optional<std::vector<double>> goals = hub_.PresentGoals();
  const planning::JointVector q =
      core::ToJointVector(goals ? *goals : control::HomePositions(*model));
  try {
    const planning::CSpaceSlice slice =
        planning::ComputeCSpaceSlice(collision, q, joint_a, joint_b, step_deg * kDeg);
    Json a = Json::array(), b = Json::array();
    for (double v : slice.values_a)
      a.push_back(ToDisplay(model->joints[static_cast<size_t>(joint_a)], v));
    for (double v : slice.values_b)
      b.push_back(ToDisplay(model->joints[static_cast<size_t>(joint_b)], v));
    std::string cells(slice.cells.size(), '0');
    for (size_t i = 0; i < cells.size(); ++i) cells[i] = static_cast<char>('0' + slice.cells[i]);
    char took[32];
    std::snprintf(took, sizeof took, "%.0f ms", slice.seconds * 1000);
    return CommandResult{true, 200,
                         "C-space of joints " + std::to_string(joint_a + 1) + " and " +
                             std::to_string(joint_b + 1) + ": " +
                             std::to_string(slice.free_count()) + " of " +
                             std::to_string(cells.size()) + " cells free (" + took + ")",
                         Json{{"joint_a", joint_a},
                              {"joint_b", joint_b},
                              {"values_a", a},
                              {"values_b", b},
                              {"cells", cells},
                              {"fixed", DisplayJoints(*model, q)},
                              {"seconds", slice.seconds}}};
  } catch (const std::invalid_argument& error) {
    return CommandResult::Fail(400, error.what());
  }
}

CommandResult RigCommands::RunPlan(const std::string& name, const std::string& text) {
  CommandResult checked = CheckPlan(name, text);
  if (!checked.ok) return checked;
  const client::Answer answer =
      hub_.WithClient([&](client::Client& rig) { return rig.RunPlan(name, text); });
  return FromAnswer(answer, "plan " + name, checked.detail);
}

CommandResult RigCommands::PlanControl(const std::string& verb) {
  // The words are client's (PlanCommandName / PlanCommandFromName), as for `sirupp plan WORD`.
  const std::optional<client::PlanCommand> command = client::PlanCommandFromName(verb);
  if (!command) {
    std::string allowed;
    for (const client::PlanCommand known : client::kPlanCommands) {
      allowed += (allowed.empty() ? "" : ", ") + std::string(client::PlanCommandName(known));
    }
    return CommandResult::Fail(
        404, "plan command '" + core::Printable(verb) + "' is unknown; allowed: " + allowed);
  }
  return FromAnswer(hub_.WithClient([&](client::Client& rig) { return rig.Plan(*command); }),
                    "plan " + verb);
}

CommandResult RigCommands::SetGains(int joint,
                                    const std::vector<std::pair<std::string, double>>& values) {
  std::optional<core::RobotModel> model = hub_.Model();
  if (!model) return CommandResult::Fail(503, NoModel().what());
  if (joint < -1 || joint >= model->num_joints()) {
    return CommandResult::Fail(400, "joint " + std::to_string(joint + 1) + ": allowed 1.." +
                                        std::to_string(model->num_joints()) + " or all");
  }
  std::optional<sirupp::servo_gains_t> live = hub_.VirtualGains();
  sirupp::servo_gains_t message = live && live->num_joints == model->num_joints()
                                      ? *live
                                      : servo::GainsMessage(servo::ChipGainsFromModel(*model));
  using G = sirupp::servo_gains_t;
  static const std::pair<const char*, std::vector<double> G::*> kFields[] = {
      {"kp", &G::kp},           {"kd", &G::kd},
      {"ki", &G::ki},           {"il", &G::integration_limit},
      {"ol", &G::output_limit}, {"el", &G::error_limit},
      {"db", &G::deadband}};
  if (values.empty()) return CommandResult::Fail(400, "gains: no value given");
  for (const auto& [field, value] : values) {
    std::vector<double> G::*member = nullptr;
    for (const auto& [name, pointer] : kFields) {
      if (field == name) member = pointer;
    }
    if (!member) {
      return CommandResult::Fail(400, "gains: field '" + core::Printable(field) +
                                          "' is unknown; allowed: kp kd ki il ol el db");
    }
    for (size_t j = 0; j < (message.*member).size(); ++j) {
      if (joint < 0 || static_cast<size_t>(joint) == j) (message.*member)[j] = value;
    }
  }
  try {
    servo::ChipGainsFromMessage(message, *model, hub_.channels().arm_gains);
  } catch (const std::exception& error) {
    return CommandResult::Fail(400, error.what());
  }
  return FromAnswer(hub_.WithClient([&](client::Client& rig) { return rig.SetGains(message); }),
                    "gains");
}

CommandResult RigCommands::Estop(bool engaged, const std::string& who, const std::string& reason) {
  // ESTOP has no reply (every process obeys it); who pressed it goes in the reason.
  std::string why = reason.empty() ? (engaged ? "panel e-stop" : "released in the panel")
                                   : core::Printable(reason);
  if (!who.empty()) why += " (" + core::Printable(who) + ")";
  const client::RequestId sent =
      hub_.WithClient([&](client::Client& rig) { return rig.Estop(engaged, why); });
  return CommandResult{true, 200, std::string(engaged ? "engaged " : "released ") + sent.channel,
                       Json::object()};
}

CommandResult RigCommands::Hardware(const std::string& verb) {
  const std::optional<client::HardwareCommand> command = client::HardwareCommandFromName(verb);
  if (!command) {
    return CommandResult::Fail(404, "hardware command '" + core::Printable(verb) +
                                        "' is unknown; allowed: connect, calibrate, arm, disarm, "
                                        "link, unlink, home, clear-faults");
  }
  return FromAnswer(hub_.WithClient([&](client::Client& rig) { return rig.Hardware(*command); }),
                    "hardware " + verb);
}

}  // namespace sirupp::panel

namespace sirupp::panel {

CommandResult RigCommands::LoadEnvironment(const std::string& name, const std::string& text) {
  try {
    core::ParseEnvironment(text, name);
  } catch (const core::ConfigError& error) {
    return CommandResult::Fail(
        422, error.what(), Json{{"line", error.where().line}, {"column", error.where().column}});
  }
  return FromAnswer(
      hub_.WithClient([&](client::Client& rig) { return rig.LoadEnvironment(name, text); }),
      "environment " + name);
}

CommandResult RigCommands::LoadModel(const std::string& name, const std::string& text) {
  std::string bridge;
  try {
    bridge = hub_.BridgeRefusal(core::ParseRobotModel(text, name));
  } catch (const core::ConfigError& error) {
    return CommandResult::Fail(
        422, error.what(), Json{{"line", error.where().line}, {"column", error.where().column}});
  }
  // Refused before anything is sent: the controller and the sim would take it, the bridge not.
  if (!bridge.empty()) return CommandResult::Fail(409, bridge);
  return FromAnswer(hub_.WithClient([&](client::Client& rig) { return rig.LoadModel(name, text); }),
                    "model " + name);
}

CommandResult RigCommands::StartRecording(const std::string& name) {
  if (!name.empty()) {
    try {
      logger::Recorder::CheckRunName(name);
    } catch (const std::invalid_argument& error) {
      return CommandResult::Fail(400, error.what());
    }
  }
  return FromAnswer(hub_.WithClient([&](client::Client& rig) { return rig.StartRecording(name); }),
                    "start recording " + (name.empty() ? std::string("(default name)") : name));
}

CommandResult RigCommands::StopRecording() {
  return FromAnswer(hub_.WithClient([&](client::Client& rig) { return rig.StopRecording(); }),
                    "stop recording");
}

}  // namespace sirupp::panel
