#include "hardware/real_arm.hpp"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>
#include <stdexcept>

#include "core/errors.hpp"
#include "core/units.hpp"
#include "core/yaml_reader.hpp"

namespace sirupp::hardware {
namespace {

using core::NumberInRange;
using core::NumberRule;
using core::YamlMap;
using core::YamlValue;
namespace range = real_arm_range;

constexpr const char* kFormat = "sirupp-real-arm-1";

NumberRule Rule(ParamRange r, double scale, const std::string& unit) {
  return NumberInRange(r.min * scale, r.max * scale, unit);
}

// The largest stiffness the integrator resolves for this rotor at the emulator's substep:
// omega h <= 0.3, omega = sqrt(k / J).
double MaxStiffness(double armature, double tick_s) {
  const double h = tick_s / 2;  // the emulator's default 2 substeps per tick
  return 0.09 * armature / (h * h);
}

JointEffects ReadJoint(const YamlValue& value, const core::Joint& joint, double tick_s) {
  const YamlMap map = value.Map({"name", "motor", "armature_kg_m2", "transmission", "friction"});
  JointEffects e;
  if (map.Has("name") && map.String("name") != joint.name) {
    map.Get("name", "")
        .Fail("joint name '" + map.String("name") + "': the model's joint here is '" + joint.name +
              "' (joints are listed in the model's order)");
  }
  const YamlMap motor =
      map.Get("motor", "a mapping")
          .Map({"resistance_ohm", "inductance_mh", "torque_constant_nm_a", "current_limit_a"});
  e.motor.resistance_ohm = motor.Number("resistance_ohm", Rule(range::kResistance, 1, "ohm"));
  e.motor.inductance_h = motor.Number("inductance_mh", Rule(range::kInductance, 1e3, "mH")) / 1e3;
  e.motor.torque_constant_nm_per_a =
      motor.Number("torque_constant_nm_a", Rule(range::kTorqueConstant, 1, "N*m/A"));
  e.motor.current_limit_a = motor.Number("current_limit_a", Rule(range::kCurrentLimit, 1, "A"));
  e.armature_kg_m2 = map.Number("armature_kg_m2", Rule(range::kArmature, 1, "kg*m^2"));

  const YamlMap gear = map.Get("transmission", "a mapping")
                           .Map({"backlash_deg", "stiffness_nm_rad", "damping_nm_s_rad"});
  e.stiffness_nm_per_rad = gear.Number("stiffness_nm_rad", core::NonNegativeNumber("N*m/rad"));
  const double max_k = std::min(range::kStiffness.max, MaxStiffness(e.armature_kg_m2, tick_s));
  if (e.stiffness_nm_per_rad != 0 &&
      (e.stiffness_nm_per_rad < range::kStiffness.min || e.stiffness_nm_per_rad > max_k)) {
    gear.Get("stiffness_nm_rad", "")
        .Fail("stiffness " + core::FormatNumber(e.stiffness_nm_per_rad) + " N*m/rad: allowed 0 " +
              "(rigid) or " + core::FormatNumber(range::kStiffness.min) + ".." +
              core::FormatNumber(std::floor(max_k)) +
              " N*m/rad (the upper end: the stiffest spring the emulator integrates stably for "
              "this armature at its substep)");
  }
  e.backlash_rad = gear.Number("backlash_deg", Rule(range::kBacklash, 1 / kDeg, "deg")) * kDeg;
  if (e.backlash_rad > 0 && e.stiffness_nm_per_rad == 0) {
    gear.Get("backlash_deg", "")
        .Fail("backlash needs a compliant gear train: give stiffness_nm_rad > 0, or backlash 0");
  }
  e.damping_nm_s_per_rad =
      gear.NumberOr("damping_nm_s_rad", 0, Rule(range::kDamping, 1, "N*m*s/rad"));

  const YamlMap friction =
      map.Get("friction", "a mapping")
          .Map({"static_nm", "coulomb_nm", "viscous_nm_s_rad", "stribeck_deg_s"});
  const YamlValue static_value = friction.Get("static_nm", "[positive, negative] in N*m");
  const YamlValue coulomb_value = friction.Get("coulomb_nm", "[positive, negative] in N*m");
  const std::vector<double> st = static_value.Numbers(2, Rule(range::kStatic, 1, "N*m"));
  const std::vector<double> co = coulomb_value.Numbers(2, Rule(range::kStatic, 1, "N*m"));
  for (int d = 0; d < 2; ++d) {
    if (co[static_cast<size_t>(d)] > st[static_cast<size_t>(d)]) {
      coulomb_value.Fail("Coulomb friction " + core::FormatNumber(co[static_cast<size_t>(d)]) +
                         " N*m moving " + (d == 0 ? "positive" : "negative") +
                         " exceeds the static " + core::FormatNumber(st[static_cast<size_t>(d)]) +
                         " N*m: allowed 0..static (a joint breaks away at its static level)");
    }
    e.static_nm[d] = st[static_cast<size_t>(d)];
    e.coulomb_nm[d] = co[static_cast<size_t>(d)];
  }
  e.viscous_nm_s_per_rad =
      friction.Number("viscous_nm_s_rad", Rule(range::kViscous, 1, "N*m*s/rad"));
  e.stribeck_rad_s =
      friction.Number("stribeck_deg_s", Rule(range::kStribeck, 1 / kDeg, "deg/s")) * kDeg;
  return e;
}

void CheckRange(double value, ParamRange r, const std::string& what) {
  if (!(value >= r.min && value <= r.max)) {
    throw std::invalid_argument(what + " " + core::FormatNumber(value) + ": allowed " +
                                core::FormatNumber(r.min) + ".." + core::FormatNumber(r.max));
  }
}

std::string Num(double v) {
  std::ostringstream s;
  s << std::setprecision(6) << v;
  return s.str();
}

}  // namespace

double RealArmParams::StallTorque(const core::RobotModel& model, int joint) const {
  const JointEffects& e = joints[static_cast<size_t>(joint)];
  const double current =
      std::min(supply_voltage_v / e.motor.resistance_ohm, e.motor.current_limit_a);
  return current * e.motor.torque_constant_nm_per_a *
         std::abs(model.joints[static_cast<size_t>(joint)].servo.gear_ratio);
}

RealArmParams ModelLikeParams(const core::RobotModel& model) {
  RealArmParams p;
  p.source = "built-in (the model's own values)";
  p.robot = model.name;
  p.supply_voltage_v = 40;
  for (const core::Joint& joint : model.joints) {
    JointEffects e;
    // Stall torque = motor_torque_max: Kt V / R; a small Kt keeps back-EMF negligible.
    e.motor.resistance_ohm = 4;
    e.motor.inductance_h = 0.0005;
    e.motor.torque_constant_nm_per_a = joint.servo.motor_torque_max_nm * 4 / 40;
    e.motor.current_limit_a = 30;
    e.armature_kg_m2 = std::max(joint.armature, range::kArmature.min);
    e.static_nm[0] = e.static_nm[1] = joint.friction.static_effort;
    e.coulomb_nm[0] = joint.friction.coulomb_positive;
    e.coulomb_nm[1] = joint.friction.coulomb_negative;
    e.viscous_nm_s_per_rad = joint.friction.viscous;
    e.stribeck_rad_s = joint.friction.stribeck_velocity;
    p.joints.push_back(e);
  }
  return p;
}

void CheckRealArmParams(const RealArmParams& p, const core::RobotModel& model) {
  if (p.joints.size() != model.joints.size()) {
    throw std::invalid_argument("real-arm parameters for " + std::to_string(p.joints.size()) +
                                " joints; the model has " + std::to_string(model.joints.size()));
  }
  CheckRange(p.supply_voltage_v, range::kSupplyVoltage, "supply voltage (V)");
  CheckRange(p.supply_resistance_ohm, range::kSupplyResistance, "supply resistance (ohm)");
  CheckRange(p.command_latency_s, range::kCommandLatency, "command latency (s)");
  CheckRange(p.encoder_quantum_counts, range::kEncoderQuantum, "encoder quantum (counts)");
  for (size_t j = 0; j < p.joints.size(); ++j) {
    const JointEffects& e = p.joints[j];
    const std::string at = "joint " + std::to_string(j + 1) + " ";
    CheckRange(e.motor.resistance_ohm, range::kResistance, at + "motor resistance (ohm)");
    CheckRange(e.motor.inductance_h, range::kInductance, at + "motor inductance (H)");
    CheckRange(e.motor.torque_constant_nm_per_a, range::kTorqueConstant,
               at + "torque constant (N*m/A)");
    CheckRange(e.motor.current_limit_a, range::kCurrentLimit, at + "current limit (A)");
    CheckRange(e.armature_kg_m2, range::kArmature, at + "armature (kg*m^2)");
    CheckRange(e.backlash_rad, range::kBacklash, at + "backlash (rad)");
    if (e.stiffness_nm_per_rad != 0) {
      CheckRange(
          e.stiffness_nm_per_rad,
          {range::kStiffness.min,
           std::min(range::kStiffness.max, MaxStiffness(e.armature_kg_m2, model.servo_tick_s))},
          at + "stiffness (N*m/rad)");
    } else if (e.backlash_rad > 0) {
      throw std::invalid_argument(at + "backlash needs a stiffness > 0");
    }
    CheckRange(e.damping_nm_s_per_rad, range::kDamping, at + "damping (N*m*s/rad)");
    for (int d = 0; d < 2; ++d) {
      CheckRange(e.static_nm[d], range::kStatic, at + "static friction (N*m)");
      CheckRange(e.coulomb_nm[d], {0, e.static_nm[d]}, at + "Coulomb friction (N*m)");
    }
    CheckRange(e.viscous_nm_s_per_rad, range::kViscous, at + "viscous friction (N*m*s/rad)");
    CheckRange(e.stribeck_rad_s, range::kStribeck, at + "Stribeck speed (rad/s)");
  }
}

RealArmParams ParseRealArmParams(const std::string& text, const std::string& name,
                                 const core::RobotModel& model) {
  const core::YamlDocument doc = core::YamlDocument::Parse(text, name);
  const YamlValue root = doc.Root();
  const YamlMap map = root.Map({"format", "description", "robot", "supply", "board", "joints"});
  RealArmParams p;
  p.source = name;
  const YamlValue format = map.Get("format", kFormat);
  if (format.String() != kFormat) {
    format.Fail("format '" + format.String() + "': allowed " + kFormat);
  }
  p.description = map.StringOr("description", "");
  p.robot = map.String("robot");
  if (p.robot != model.name) {
    map.Get("robot", "")
        .Fail("robot '" + p.robot + "': this file is for another arm; the model is '" + model.name +
              "'");
  }
  const YamlMap supply = map.Get("supply", "a mapping").Map({"voltage_v", "resistance_ohm"});
  p.supply_voltage_v = supply.Number("voltage_v", Rule(range::kSupplyVoltage, 1, "V"));
  p.supply_resistance_ohm =
      supply.Number("resistance_ohm", Rule(range::kSupplyResistance, 1, "ohm"));
  const YamlMap board =
      map.Get("board", "a mapping").Map({"command_latency_ms", "encoder_quantum_counts"});
  p.command_latency_s =
      board.Number("command_latency_ms", Rule(range::kCommandLatency, 1e3, "ms")) / 1e3;
  p.encoder_quantum_counts =
      static_cast<int>(board.Get("encoder_quantum_counts", "a whole number 1..64")
                           .Integer(static_cast<int64_t>(range::kEncoderQuantum.min),
                                    static_cast<int64_t>(range::kEncoderQuantum.max)));
  const YamlValue joints = map.Get("joints", "one entry per model joint");
  const std::vector<YamlValue> list = joints.Sequence();
  if (list.size() != model.joints.size()) {
    joints.Fail(std::to_string(list.size()) + " joints: allowed exactly " +
                std::to_string(model.joints.size()) + " (one per joint of " + model.name + ")");
  }
  for (size_t j = 0; j < list.size(); ++j) {
    p.joints.push_back(ReadJoint(list[j], model.joints[j], model.servo_tick_s));
  }
  return p;
}

RealArmParams LoadRealArmParams(const std::string& file, const core::RobotModel& model) {
  return ParseRealArmParams(core::ReadTextFile(file), file, model);
}

std::string FormatRealArmParams(const RealArmParams& p, const std::string& header) {
  std::ostringstream out;
  std::istringstream lines(header);
  for (std::string line; std::getline(lines, line);) out << "# " << line << "\n";
  out << "format: " << kFormat << "\n";
  if (!p.description.empty()) out << "description: \"" << p.description << "\"\n";
  out << "robot: " << p.robot << "\n"
      << "supply: {voltage_v: " << Num(p.supply_voltage_v)
      << ", resistance_ohm: " << Num(p.supply_resistance_ohm) << "}\n"
      << "board: {command_latency_ms: " << Num(p.command_latency_s * 1e3)
      << ", encoder_quantum_counts: " << p.encoder_quantum_counts << "}\n"
      << "joints:\n";
  for (const JointEffects& e : p.joints) {
    out << "  - motor: {resistance_ohm: " << Num(e.motor.resistance_ohm)
        << ", inductance_mh: " << Num(e.motor.inductance_h * 1e3)
        << ", torque_constant_nm_a: " << Num(e.motor.torque_constant_nm_per_a)
        << ", current_limit_a: " << Num(e.motor.current_limit_a) << "}\n"
        << "    armature_kg_m2: " << Num(e.armature_kg_m2) << "\n"
        << "    transmission: {backlash_deg: " << Num(e.backlash_rad / kDeg)
        << ", stiffness_nm_rad: " << Num(e.stiffness_nm_per_rad)
        << ", damping_nm_s_rad: " << Num(e.damping_nm_s_per_rad) << "}\n"
        << "    friction: {static_nm: [" << Num(e.static_nm[0]) << ", " << Num(e.static_nm[1])
        << "], coulomb_nm: [" << Num(e.coulomb_nm[0]) << ", " << Num(e.coulomb_nm[1])
        << "], viscous_nm_s_rad: " << Num(e.viscous_nm_s_per_rad)
        << ", stribeck_deg_s: " << Num(e.stribeck_rad_s / kDeg) << "}\n";
  }
  return out.str();
}

}  // namespace sirupp::hardware
