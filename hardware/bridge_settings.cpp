#include "hardware/bridge_settings.hpp"

#include <cmath>
#include <stdexcept>

#include "core/units.hpp"
#include "core/yaml_reader.hpp"
#include "hardware/nmc_protocol.hpp"

namespace sirupp::hardware {
namespace {

const std::vector<std::string> kKeys = {"port",
                                        "baud",
                                        "poll_rate_hz",
                                        "reply_margin_ms",
                                        "retries",
                                        "group_address",
                                        "emulated",
                                        "start_guard_s",
                                        "command_timeout_s",
                                        "soft_limit_margin_deg",
                                        "velocity_cap_fraction",
                                        "acceleration_max_deg_s2",
                                        "pass_motor_off",
                                        "calibration",
                                        "units"};

JointHoming ReadHoming(const core::YamlValue& value) {
  const core::YamlMap map = value.Map({"method", "speed_deg_s", "home_angle_deg"});
  JointHoming h;
  const std::string method = map.Get("method", "one of: none, index, limit1, limit2")
                                 .Choice({"none", "index", "limit1", "limit2"});
  h.method = method == "index"    ? HomingMethod::kIndex
             : method == "limit1" ? HomingMethod::kLimit1
             : method == "limit2" ? HomingMethod::kLimit2
                                  : HomingMethod::kNone;
  const core::NumberRule speed{-90, 90, true, true, "deg/s, nonzero"};
  if (auto v = map.Find("speed_deg_s")) {
    const double s = v->Number(speed);
    if (s == 0) v->Fail("0 deg/s; the search speed must be nonzero (its sign is the direction)");
    h.speed = s * kDeg;
  } else if (h.method != HomingMethod::kNone) {
    map.Get("speed_deg_s", "the search speed in deg/s, its sign the direction");
  }
  h.home_angle = map.NumberOr("home_angle_deg", 0, core::AnyNumber("deg")) * kDeg;
  return h;
}

}  // namespace

const char* HomingMethodName(HomingMethod method) {
  switch (method) {
    case HomingMethod::kIndex:
      return "index";
    case HomingMethod::kLimit1:
      return "limit1";
    case HomingMethod::kLimit2:
      return "limit2";
    case HomingMethod::kNone:
      break;
  }
  return "none";
}

BridgeSettings DefaultBridgeSettings(const core::RobotModel& model) {
  BridgeSettings s;
  s.motion_limits = core::DefaultMotionLimits(model);
  s.homing.assign(model.joints.size(), JointHoming{});
  return s;
}

BridgeSettings ParseBridgeSettings(const std::string& text, const std::string& name,
                                   const core::RobotModel& model) {
  const core::YamlDocument doc = core::YamlDocument::Parse(text, name);
  BridgeSettings s = DefaultBridgeSettings(model);
  const core::YamlValue root = doc.Root();
  if (root.IsNull()) return s;
  const core::YamlMap map = root.Map(kKeys);
  if (auto units = map.Find("units")) {
    units->Choice({"deg"});  // documents the file's angles; only degrees are used
  }
  s.port = map.StringOr("port", s.port);
  if (auto v = map.Find("baud")) {
    const int64_t baud = v->Integer(9600, 230400);
    if (!nmc::IsSupportedBaud(static_cast<int>(baud))) {
      v->Fail(std::to_string(baud) + " baud; allowed: " + nmc::SupportedBauds());
    }
    s.baud = static_cast<int>(baud);
  }
  s.poll_rate_hz = map.NumberOr("poll_rate_hz", s.poll_rate_hz, core::NumberInRange(1, 1000, "Hz"));
  if (auto v = map.Find("reply_margin_ms"))
    s.reply_margin_ms = static_cast<int>(v->Integer(1, 1000));
  if (auto v = map.Find("retries")) s.retries = static_cast<int>(v->Integer(0, 10));
  if (auto v = map.Find("group_address"))
    s.group_address = static_cast<int>(v->Integer(0x80, 0xFE));
  if (auto v = map.Find("emulated")) s.emulated = v->Bool();
  s.start_guard_s = map.NumberOr("start_guard_s", s.start_guard_s, core::NumberInRange(0, 60, "s"));
  s.command_timeout_s =
      map.NumberOr("command_timeout_s", s.command_timeout_s, core::NumberInRange(0.01, 60, "s"));
  core::MotionLimits& limits = s.motion_limits;
  if (auto v = map.Find("soft_limit_margin_deg")) {
    limits.soft_limit_margin = v->Number(core::NumberInRange(0, 30, "deg")) * kDeg;
  }
  limits.velocity_cap_fraction = map.NumberOr("velocity_cap_fraction", limits.velocity_cap_fraction,
                                              core::NumberInRange(0.01, 1, ""));
  if (auto v = map.Find("acceleration_max_deg_s2")) {
    const std::vector<double> a = v->Numbers(model.joints.size(), core::PositiveNumber("deg/s^2"));
    for (size_t j = 0; j < a.size(); ++j) limits.acceleration_max[j] = a[j] * kDeg;
    s.acceleration_from_file = true;
  }
  if (auto v = map.Find("pass_motor_off")) s.pass_motor_off = v->Bool();
  if (auto v = map.Find("calibration")) {
    const core::YamlMap cal = v->Map({"pose", "homing", "homing_timeout_s"});
    if (auto pose = cal.Find("pose")) {
      const std::string pose_name = pose->String();
      if (!model.FindNamedPose(pose_name)) {
        std::string names;
        for (const core::NamedPose& p : model.named_poses)
          names += (names.empty() ? "" : ", ") + p.name;
        pose->Fail("'" + pose_name + "' is not a named pose of " + model.name +
                   "; allowed: " + names);
      }
      s.calibration_pose = pose_name;
    }
    if (auto homing = cal.Find("homing")) {
      const std::vector<core::YamlValue> rows =
          homing->Sequence(model.joints.size(), model.joints.size());
      for (size_t j = 0; j < rows.size(); ++j) s.homing[j] = ReadHoming(rows[j]);
    }
    s.homing_timeout_s =
        cal.NumberOr("homing_timeout_s", s.homing_timeout_s, core::NumberInRange(1, 600, "s"));
  }
  return s;
}

BridgeSettings LoadBridgeSettings(const std::string& file, const core::RobotModel& model) {
  const core::YamlDocument doc = core::YamlDocument::Load(file);
  return ParseBridgeSettings(doc.text(), file, model);
}

BridgeSettings SettingsForModel(const BridgeSettings& settings, const core::RobotModel& model) {
  if (settings.homing.size() != model.joints.size()) {
    throw std::runtime_error("the settings are for " + std::to_string(settings.homing.size()) +
                             " joints; " + model.name + " has " +
                             std::to_string(model.joints.size()));
  }
  if (!model.FindNamedPose(settings.calibration_pose)) {
    throw std::runtime_error("the calibration pose '" + settings.calibration_pose +
                             "' is not a named pose of " + model.name);
  }
  BridgeSettings s = settings;
  if (!s.acceleration_from_file) {
    s.motion_limits.acceleration_max = core::DefaultMotionLimits(model).acceleration_max;
  }
  return s;
}

double SoftMin(const core::RobotModel& model, const BridgeSettings& s, int j) {
  return core::SoftMin(model, s.motion_limits, j);
}
double SoftMax(const core::RobotModel& model, const BridgeSettings& s, int j) {
  return core::SoftMax(model, s.motion_limits, j);
}

}  // namespace sirupp::hardware
