#include "runtime/joint_args.hpp"

#include "core/errors.hpp"

namespace sirupp::runtime {

namespace {
constexpr double kPi = 3.14159265358979323846;
}

std::vector<Flag> JointFlags() {
  return {
      Flag("pose", "one of the model's named poses").Takes("NAME"),
      Flag("deg", "Q.. (one per joint): revolute in degrees, prismatic in metres").Takes("Q", -1),
      Flag("rad", "Q.. (one per joint): revolute in radians, prismatic in metres").Takes("Q", -1)};
}

Flag DegreesFlag(const std::string& name, const std::string& what) {
  return Flag(name, "Q.. (one per joint) " + what + ": revolute in degrees, prismatic in metres")
      .Takes("Q", -1);
}

std::vector<double> FromDegrees(std::vector<double> values, const core::RobotModel& model) {
  for (size_t j = 0; j < values.size() && j < model.joints.size(); ++j) {
    if (model.joints[j].type == core::JointType::kRevolute) values[j] *= kPi / 180;
  }
  return values;
}

std::optional<std::vector<double>> DegreesArg(const Args& args, const std::string& flag,
                                              const core::RobotModel& model) {
  if (!args.Has(flag)) return std::nullopt;
  return FromDegrees(args.Numbers(flag, model.num_joints()), model);
}

std::optional<std::vector<double>> PositionsArg(const Args& args, const core::RobotModel& model,
                                                const std::string& command, bool required) {
  const int given =
      (args.Has("pose") ? 1 : 0) + (args.Has("deg") ? 1 : 0) + (args.Has("rad") ? 1 : 0);
  if (given == 0 && !required) return std::nullopt;
  if (given != 1) throw core::UsageError(command + ": give exactly one of --pose, --deg, --rad");
  std::vector<double> position;
  if (args.Has("pose")) {
    const core::NamedPose* pose = model.FindNamedPose(args.String("pose"));
    if (pose == nullptr) {
      std::string names;
      for (const auto& named : model.named_poses) names += (names.empty() ? "" : ", ") + named.name;
      throw core::UsageError(command + ": --pose '" + args.String("pose") + "': " + model.name +
                             " has " + names);
    }
    position = pose->position;
  } else if (args.Has("deg")) {
    position = *DegreesArg(args, "deg", model);
  } else {
    position = args.Numbers("rad", model.num_joints());
  }
  for (int j = 0; j < model.num_joints(); ++j) {
    const core::Joint& joint = model.joints[static_cast<size_t>(j)];
    const double q = position[static_cast<size_t>(j)];
    if (q < joint.position_min || q > joint.position_max) {
      throw core::UsageError(command + ": joint " + std::to_string(j + 1) + " (" + joint.name +
                             "): " + core::FormatApprox(q) + " is outside the limits [" +
                             core::FormatApprox(joint.position_min) + ", " +
                             core::FormatApprox(joint.position_max) + "] (rad or m)");
    }
  }
  return position;
}

}  // namespace sirupp::runtime
