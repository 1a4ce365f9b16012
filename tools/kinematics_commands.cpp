#include "tools/kinematics_commands.hpp"

#include <cmath>
#include <cstdio>
#include <ostream>
#include <sstream>

#include "core/errors.hpp"
#include "core/inverse_kinematics.hpp"
#include "core/model_loader.hpp"
#include "runtime/args.hpp"
#include "runtime/data_path.hpp"
#include "tools/json_output.hpp"

namespace sirupp::tools {

const char* const kFkAbout =
    "  Tool pose for the given joints. --deg: revolute joints in degrees; --rad: in radians;\n"
    "  prismatic joints in metres either way. Joint i follows the model's DH convention.\n"
    "  Prints the position in metres and in the model file's length unit, the rotation matrix,\n"
    "  roll-pitch-yaw in degrees (R = Rz(yaw) Ry(pitch) Rx(roll), fixed axes) and the quaternion\n"
    "  (w x y z), all in the world frame (the frame the model's base pose is given in).\n";

const char* const kIkAbout =
    "  Joint solutions that put the tool at the pose: X Y Z in metres, ROLL PITCH YAW in degrees\n"
    "  (R = Rz(yaw) Ry(pitch) Rx(roll)), world frame. PUMA-type arms use the closed-form solver\n"
    "  (8 configurations, named SHOULDER-ELBOW-WRIST: left|right, up|down, noflip|flip); other "
    "arms,\n"
    "  or --numeric, the damped-least-squares solver.\n"
    "  --config all (default): every solution; nearest: the one nearest --from (degrees / metres,\n"
    "  default the home pose); or a configuration name such as right-up-noflip.\n"
    "  --position-only: ignore the orientation (numeric solver; for arms with fewer than 6 "
    "joints).\n"
    "  Exit code 0 with solutions, 1 with the reason when there is none, 2 for bad arguments.\n";

namespace {

constexpr const char* kJointUnits = "deg (revolute), m (prismatic)";

std::string Fixed(double value, int decimals = 4) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.*f", decimals, value);
  const std::string text = buffer;
  // "-0.000" reads as a sign that is not there.
  return text.find_first_not_of("-0.") == std::string::npos && text[0] == '-' ? text.substr(1)
                                                                              : text;
}

// Joint values for people: degrees for revolute joints, metres for prismatic ones.
std::vector<double> ForPeople(const core::RobotModel& model, const core::JointVector& q) {
  std::vector<double> values;
  for (int i = 0; i < q.size(); ++i) {
    const bool revolute = model.joints[static_cast<size_t>(i)].type == core::JointType::kRevolute;
    values.push_back(revolute ? q[i] * 180.0 / M_PI : q[i]);
  }
  return values;
}

core::JointVector FromPeople(const core::RobotModel& model, const std::vector<double>& values,
                             bool degrees) {
  core::JointVector q(static_cast<Eigen::Index>(values.size()));
  for (size_t i = 0; i < values.size(); ++i) {
    const bool revolute = model.joints[i].type == core::JointType::kRevolute;
    q[static_cast<Eigen::Index>(i)] = revolute && degrees ? values[i] * M_PI / 180.0 : values[i];
  }
  return q;
}

// Names of the joints of q outside their limits, "" when none.
std::string OutsideLimits(const core::RobotModel& model, const core::JointVector& q) {
  std::string names;
  for (int i = 0; i < q.size(); ++i) {
    const core::Joint& joint = model.joints[static_cast<size_t>(i)];
    if (q[i] < joint.position_min || q[i] > joint.position_max) {
      names += (names.empty() ? "" : ", ") + joint.name;
    }
  }
  return names;
}

std::string JointText(const std::vector<double>& values) {
  std::string text;
  for (double v : values) text += (text.empty() ? "" : " ") + Fixed(v, 3);
  return "[" + text + "]";
}

std::string Join(const std::vector<std::string>& names) {
  std::string text;
  for (const std::string& name : names) text += (text.empty() ? "" : ", ") + name;
  return text;
}

// "  NAME  [q1 .. qn] deg" for one solution.
std::string SolutionText(const core::RobotModel& model, const core::IkSolution& s) {
  return "  " + (s.config ? s.config->Name() : std::string("solution")) + "  " +
         JointText(ForPeople(model, s.q)) + " deg";
}

}  // namespace

int RunFk(const std::vector<std::string>& raw, std::ostream& out) {
  const runtime::Args args(
      raw, "fk",
      // One or more values, named "Q1 .. QN" in messages; the model gives N (checked where read).
      {runtime::ModelFlag(), runtime::Flag("deg", "Q1 .. QN").Takes("", -1),
       runtime::Flag("rad", "Q1 .. QN").Takes("", -1),
       runtime::Flag("json", "one JSON object").Switch()},
      kFkAbout);
  const core::RobotModel model = core::LoadRobotModel(runtime::ModelFileArg(args));
  const int n = model.num_joints();
  if (args.Has("deg") == args.Has("rad")) {
    throw core::UsageError("fk: give the joints with exactly one of --deg or --rad (" +
                           std::to_string(n) + " values for " + model.name + ")");
  }
  const bool degrees = args.Has("deg");
  const core::JointVector q = FromPeople(model, args.Numbers(degrees ? "deg" : "rad", n), degrees);
  const bool json = args.Switch("json");

  const Eigen::Isometry3d tool = core::ToolPose(model, q);
  const Eigen::Vector3d p = tool.translation();
  const Eigen::Matrix3d r = tool.linear();
  const Eigen::Vector3d rpy = core::RollPitchYaw(r) * 180.0 / M_PI;
  const Eigen::Quaterniond quat(r);
  const double manipulability = core::Manipulability(core::GeometricJacobian(model, q));
  const std::vector<std::string> singular = core::Singularities(model, q);
  const double unit = model.file_length_unit_m;

  if (json) {
    WriteJsonLine(out, Json{{"model", model.name},
                            {"joints", ForPeople(model, q)},
                            {"joint_units", kJointUnits},
                            {"position_m", {p.x(), p.y(), p.z()}},
                            {"position_file_units", {p.x() / unit, p.y() / unit, p.z() / unit}},
                            {"file_length_unit", model.file_length_unit},
                            {"rotation",
                             {{r(0, 0), r(0, 1), r(0, 2)},
                              {r(1, 0), r(1, 1), r(1, 2)},
                              {r(2, 0), r(2, 1), r(2, 2)}}},
                            {"rpy_deg", {rpy.x(), rpy.y(), rpy.z()}},
                            {"quaternion_wxyz", {quat.w(), quat.x(), quat.y(), quat.z()}},
                            {"manipulability", manipulability},
                            {"singularities", singular}});
    return 0;
  }
  out << model.name << " at joints " << JointText(ForPeople(model, q))
      << " (deg for revolute, m for prismatic)\n";
  out << "tool position     [" << Fixed(p.x(), 6) << " " << Fixed(p.y(), 6) << " "
      << Fixed(p.z(), 6) << "] m = [" << Fixed(p.x() / unit) << " " << Fixed(p.y() / unit) << " "
      << Fixed(p.z() / unit) << "] " << model.file_length_unit << "\n";
  out << "rotation matrix   ";
  for (int row = 0; row < 3; ++row) {
    out << (row ? "                  " : "") << "[" << Fixed(r(row, 0), 6) << " "
        << Fixed(r(row, 1), 6) << " " << Fixed(r(row, 2), 6) << "]\n";
  }
  out << "roll pitch yaw    [" << Fixed(rpy.x()) << " " << Fixed(rpy.y()) << " " << Fixed(rpy.z())
      << "] deg (R = Rz(yaw) Ry(pitch) Rx(roll))\n";
  out << "quaternion w x y z [" << Fixed(quat.w(), 6) << " " << Fixed(quat.x(), 6) << " "
      << Fixed(quat.y(), 6) << " " << Fixed(quat.z(), 6) << "]\n";
  out << "manipulability    " << core::FormatApprox(manipulability) << "\n";
  out << "singularities     " << (singular.empty() ? "none" : Join(singular)) << "\n";
  return 0;
}

namespace {

// --config NAME as a configuration; nothing for all and nearest.
std::optional<core::IkConfiguration> WantedConfig(const std::string& config_text) {
  if (config_text == "all" || config_text == "nearest") return std::nullopt;
  std::optional<core::IkConfiguration> wanted = core::IkConfiguration::Parse(config_text);
  if (!wanted) {
    throw core::UsageError("ik: --config '" + config_text +
                           "' is not allowed; expected all, nearest, or SHOULDER-ELBOW-WRIST with "
                           "left|right, up|down, noflip|flip (e.g. right-up-noflip)");
  }
  return wanted;
}

// X Y Z (m) ROLL PITCH YAW (deg) as a pose.
Eigen::Isometry3d PoseTarget(const std::vector<double>& pose) {
  Eigen::Isometry3d target = Eigen::Isometry3d::Identity();
  target.translation() << pose[0], pose[1], pose[2];
  target.linear() =
      core::QuaternionFromRpy(pose[3] * M_PI / 180, pose[4] * M_PI / 180, pose[5] * M_PI / 180)
          .toRotationMatrix();
  return target;
}

// The solutions to show: within the limits, of the wanted configuration if one is asked, only
// the nearest for --config nearest.
std::vector<const core::IkSolution*> ShownSolutions(
    const core::IkResult& result, const std::optional<core::IkConfiguration>& wanted,
    const std::string& config_text) {
  std::vector<const core::IkSolution*> shown;
  for (const core::IkSolution& s : result.solutions) {
    if (!s.within_limits) continue;
    if (wanted && !(s.config && *s.config == *wanted)) continue;
    shown.push_back(&s);
  }
  if (config_text == "nearest" && !shown.empty()) shown.resize(1);  // sorted nearest first
  return shown;
}

// What `ik` found, as the pieces its two outputs show.
struct IkAnswer {
  bool closed_form = false;
  core::IkResult result;
  std::vector<const core::IkSolution*> shown;
  std::string failure;  // empty: solved
};

int PrintIkJson(const core::RobotModel& model, const IkAnswer& answer, std::ostream& out) {
  Json solutions = Json::array();
  for (const core::IkSolution* s : answer.shown) {
    solutions.push_back({{"config", s->config ? Json(s->config->Name()) : Json(nullptr)},
                         {"joints", ForPeople(model, s->q)},
                         {"position_error_m", s->error.position_m},
                         {"rotation_error_rad", s->error.rotation_rad},
                         {"singularities", s->singularities}});
  }
  const std::string& failure = answer.failure;
  WriteJsonLine(out,
                Json{{"model", model.name},
                     {"solver", answer.closed_form ? "closed-form" : "numeric"},
                     {"ok", failure.empty()},
                     {"reason", failure.empty()
                                    ? Json(nullptr)
                                    : Json(std::string(core::IkFailureName(answer.result.failure)) +
                                           ": " + failure)},
                     {"joint_units", kJointUnits},
                     {"solutions", std::move(solutions)}});
  return failure.empty() ? 0 : 1;
}

int PrintIkText(const core::RobotModel& model, const std::vector<double>& pose,
                const std::string& config_text, const IkAnswer& answer, std::ostream& out) {
  const core::IkResult& result = answer.result;
  out << model.name << ": target [" << Fixed(pose[0], 4) << " " << Fixed(pose[1], 4) << " "
      << Fixed(pose[2], 4) << "] m, rpy [" << Fixed(pose[3], 2) << " " << Fixed(pose[4], 2) << " "
      << Fixed(pose[5], 2) << "] deg; " << (answer.closed_form ? "closed-form" : "numeric")
      << " solver\n";
  if (!answer.failure.empty()) {
    out << "no solution: " << core::IkFailureName(result.failure) << ": " << answer.failure << "\n";
    for (const core::IkSolution& s : result.solutions) {
      out << SolutionText(model, s) << "  (outside: " << OutsideLimits(model, s.q) << ")\n";
    }
    return 1;
  }
  for (const core::IkSolution* s : answer.shown) {
    char error[96];
    std::snprintf(error, sizeof error, "  |error| %.1e m %.1e rad", s->error.position_m,
                  s->error.rotation_rad);
    out << SolutionText(model, *s) << error;
    if (!s->singularities.empty()) out << "  singular: " << Join(s->singularities);
    out << "\n";
  }
  if (config_text == "all") {
    bool header = false;
    for (const core::IkSolution& s : result.solutions) {
      if (s.within_limits) continue;
      if (!header) out << "  outside the joint limits:\n";
      header = true;
      out << SolutionText(model, s) << "  (" << OutsideLimits(model, s.q) << ")\n";
    }
  }
  return 0;
}

}  // namespace

int RunIk(const std::vector<std::string>& raw, std::ostream& out) {
  const runtime::Args args(
      raw, "ik",
      {runtime::ModelFlag(),
       runtime::Flag("pose", "tool pose in the world frame: metres and degrees")
           .Takes("X Y Z ROLL PITCH YAW", 6),
       runtime::Flag("config", "SHOULDER-ELBOW-WRIST, all or nearest").Takes("NAME"),
       runtime::Flag("from", "Q1 .. QN").Takes("", -1),
       runtime::Flag("numeric", "the numeric solver").Switch(),
       runtime::Flag("position-only", "position only, orientation free (numeric)").Switch(),
       runtime::Flag("json", "one JSON object").Switch()},
      kIkAbout);
  const core::RobotModel model = core::LoadRobotModel(runtime::ModelFileArg(args));
  const int n = model.num_joints();
  const std::vector<double> pose = args.Numbers("pose", 6);
  const std::string config_text = args.Has("config") ? args.String("config") : "all";
  const std::optional<core::IkConfiguration> wanted = WantedConfig(config_text);
  core::JointVector reference(n);
  for (int i = 0; i < n; ++i) reference[i] = model.joints[static_cast<size_t>(i)].home;
  if (args.Has("from")) reference = FromPeople(model, args.Numbers("from", n), true);
  const bool numeric = args.Switch("numeric");
  const bool position_only = args.Switch("position-only");
  const bool json = args.Switch("json");
  const Eigen::Isometry3d target = PoseTarget(pose);

  IkAnswer answer;
  const core::IkRequest request{numeric, position_only};
  const core::IkSolverChoice choice = core::ChooseIkSolver(model, request);
  answer.closed_form = choice.closed_form;
  if (wanted && !answer.closed_form) {
    throw core::UsageError("ik: --config " + config_text +
                           " needs the closed-form solver, which does not apply here (" +
                           choice.not_closed_form + "); use all or nearest");
  }
  answer.result = core::SolveIk(model, target, reference, request);
  answer.shown = ShownSolutions(answer.result, wanted, config_text);
  answer.failure = answer.result.ok() ? "" : answer.result.reason;
  if (answer.result.ok() && answer.shown.empty() && wanted) {
    answer.failure = "configuration " + config_text + " has no solution inside the joint limits";
  }
  return json ? PrintIkJson(model, answer, out)
              : PrintIkText(model, pose, config_text, answer, out);
}

}  // namespace sirupp::tools
