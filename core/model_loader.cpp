#include "core/model_loader.hpp"

#include <cmath>

#include "core/mass_properties.hpp"
#include "core/printable.hpp"
#include "core/yaml_reader.hpp"

namespace sirupp::core {

namespace {

// The units a file declares and the rules derived from them.
struct FileUnits {
  std::string length_name;
  double length_m = 1;
  std::string angle_name;
  double angle_rad = 1;

  double Length(double value) const { return value * length_m; }
  double Angle(double value) const { return value * angle_rad; }
};

FileUnits ReadUnits(const YamlMap& root) {
  const YamlMap units =
      root.Get("units", "a mapping with length and angle").Map({"length", "angle"});
  FileUnits result;
  result.length_name =
      units.Get("length", "one of: m, cm, mm, inch").Choice({"m", "cm", "mm", "inch"});
  result.length_m = result.length_name == "inch" ? 0.0254
                    : result.length_name == "cm" ? 0.01
                    : result.length_name == "mm" ? 0.001
                                                 : 1.0;
  result.angle_name = units.Get("angle", "one of: deg, rad").Choice({"deg", "rad"});
  result.angle_rad = result.angle_name == "deg" ? M_PI / 180.0 : 1.0;
  return result;
}

Eigen::Vector3d ReadPoint(const YamlValue& value, const FileUnits& units) {
  const std::vector<double> xyz = value.Numbers(3, AnyNumber(units.length_name));
  return Eigen::Vector3d(xyz[0], xyz[1], xyz[2]) * units.length_m;
}

Eigen::Quaterniond ReadRpy(const YamlValue& value, const FileUnits& units) {
  const std::vector<double> rpy = value.Numbers(3, AnyNumber(units.angle_name));
  return QuaternionFromRpy(units.Angle(rpy[0]), units.Angle(rpy[1]), units.Angle(rpy[2]));
}

Pose ReadPose(const YamlMap& parent, const std::string& key, const FileUnits& units) {
  Pose pose;
  const std::optional<YamlValue> value = parent.Find(key);
  if (!value) return pose;
  const YamlMap map = value->Map({"position", "rpy"});
  if (auto position = map.Find("position")) pose.position_m = ReadPoint(*position, units);
  if (auto rpy = map.Find("rpy")) pose.orientation = ReadRpy(*rpy, units);
  return pose;
}

std::array<float, 4> ReadColor(const YamlValue& value) {
  const std::vector<YamlValue> items = value.Sequence(3, 4);
  std::array<float, 4> rgba{{0, 0, 0, 1}};
  for (size_t i = 0; i < items.size(); ++i) {
    rgba[i] = static_cast<float>(items[i].Number(NumberInRange(0, 1, "colour component")));
  }
  return rgba;
}

// A cylinder or capsule given by the centres of its two end faces (or cap centres).
void PlaceBetween(const YamlMap& map, const FileUnits& units, Shape& shape) {
  const YamlValue from_value =
      map.Get("from", "the centre of one end, [x, y, z] in " + units.length_name);
  const YamlValue to_value =
      map.Get("to", "the centre of the other end, [x, y, z] in " + units.length_name);
  const Eigen::Vector3d from = ReadPoint(from_value, units);
  const Eigen::Vector3d to = ReadPoint(to_value, units);
  const Eigen::Vector3d axis = to - from;
  if (axis.norm() <= 0) {
    to_value.Fail("is the same point as 'from'; expected a " +
                  std::string(ShapeTypeName(shape.type)) + " of length > 0");
  }
  shape.pose.position_m = (from + to) / 2;
  shape.pose.orientation = Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitZ(), axis);
  shape.size_m.y() = axis.norm();
}

Shape ReadShape(const YamlValue& value, const FileUnits& units) {
  const YamlMap any = value.Map({"type", "size", "center", "rpy", "radius", "from", "to", "color"});
  const std::string type = any.Get("type", "one of: box, cylinder, sphere, capsule")
                               .Choice({"box", "cylinder", "sphere", "capsule"});
  const NumberRule dimension = PositiveNumber(units.length_name);
  Shape shape;
  if (type == "box") {
    const YamlMap map = value.Map({"type", "size", "center", "rpy", "color"});
    shape.type = ShapeType::kBox;
    const std::vector<double> size =
        map.Get("size", "[x, y, z] edge lengths in " + units.length_name).Numbers(3, dimension);
    shape.size_m = Eigen::Vector3d(size[0], size[1], size[2]) * units.length_m;
    if (auto center = map.Find("center")) shape.pose.position_m = ReadPoint(*center, units);
    if (auto rpy = map.Find("rpy")) shape.pose.orientation = ReadRpy(*rpy, units);
  } else if (type == "sphere") {
    const YamlMap map = value.Map({"type", "radius", "center", "color"});
    shape.type = ShapeType::kSphere;
    shape.size_m.x() = units.Length(map.Number("radius", dimension));
    if (auto center = map.Find("center")) shape.pose.position_m = ReadPoint(*center, units);
  } else {
    const YamlMap map = value.Map({"type", "radius", "from", "to", "color"});
    shape.type = type == "cylinder" ? ShapeType::kCylinder : ShapeType::kCapsule;
    shape.size_m.x() = units.Length(map.Number("radius", dimension));
    PlaceBetween(map, units, shape);
  }
  if (auto color = any.Find("color")) shape.rgba = ReadColor(*color);
  return shape;
}

Link ReadLink(const YamlValue& value, bool is_base, const FileUnits& units) {
  const YamlMap map = value.Map({"name", "mass_kg", "com", "inertia_kg_m2", "shapes"});
  Link link;
  link.name = map.String("name");
  link.mass_kg = is_base ? map.NumberOr("mass_kg", 0, NonNegativeNumber("kg"))
                         : map.Number("mass_kg", PositiveNumber("kg"));
  if (auto shapes = map.Find("shapes")) {
    for (const YamlValue& shape : shapes->Sequence())
      link.shapes.push_back(ReadShape(shape, units));
  }
  const std::optional<YamlValue> com = map.Find("com");
  const std::optional<YamlValue> inertia = map.Find("inertia_kg_m2");
  if (com.has_value() != inertia.has_value()) {
    (com ? *com : *inertia)
        .Fail("is given without " + std::string(com ? "inertia_kg_m2" : "com") +
              "; give both, or neither to derive them from the shapes");
  }
  if (com) {
    link.com_m = ReadPoint(*com, units);
    const YamlMap tensor = inertia->Map({"ixx", "iyy", "izz", "ixy", "ixz", "iyz"});
    const NumberRule moment = PositiveNumber("kg*m^2");
    const NumberRule product = AnyNumber("kg*m^2");
    const double ixx = tensor.Number("ixx", moment);
    const double iyy = tensor.Number("iyy", moment);
    const double izz = tensor.Number("izz", moment);
    const double ixy = tensor.NumberOr("ixy", 0, product);
    const double ixz = tensor.NumberOr("ixz", 0, product);
    const double iyz = tensor.NumberOr("iyz", 0, product);
    link.inertia_kg_m2 << ixx, ixy, ixz, ixy, iyy, iyz, ixz, iyz, izz;
  } else if (!is_base) {
    double volume = 0;
    for (const Shape& shape : link.shapes) volume += ShapeVolume(shape);
    if (volume <= 0) {
      map.self().Fail(
          "has no com and inertia_kg_m2 and no shapes to derive them from; give one or the other");
    }
    const MassProperties derived = DeriveMassProperties(link.shapes, link.mass_kg);
    link.com_m = derived.com_m;
    link.inertia_kg_m2 = derived.inertia_kg_m2;
    link.inertia_derived = true;
  }
  return link;
}

Friction ReadFriction(const YamlValue& value, bool revolute, const std::string& speed_unit,
                      double speed_scale) {
  const std::string effort_unit = revolute ? "N*m" : "N";
  const YamlMap map = value.Map({"static", "coulomb", "viscous", "stribeck_velocity"});
  const NumberRule effort = NonNegativeNumber(effort_unit);
  Friction friction;
  friction.static_effort = map.Number("static", effort);
  const YamlValue coulomb =
      map.Get("coulomb", "a level, or [positive, negative] levels in " + effort_unit);
  if (coulomb.node().IsSequence()) {
    const std::vector<double> levels = coulomb.Numbers(2, effort);
    friction.coulomb_positive = levels[0];
    friction.coulomb_negative = levels[1];
  } else {
    friction.coulomb_positive = friction.coulomb_negative = coulomb.Number(effort);
  }
  friction.viscous = map.Number("viscous", NonNegativeNumber(revolute ? "N*m*s/rad" : "N*s/m"));
  friction.stribeck_velocity =
      map.NumberOr("stribeck_velocity", 0.01 / speed_scale, PositiveNumber(speed_unit)) *
      speed_scale;
  return friction;
}

ServoParams ReadServo(const YamlValue& value, const std::string& speed_unit, double speed_scale) {
  const YamlMap map =
      value.Map({"encoder_counts_per_rev", "gear_ratio", "motor_torque_max_nm", "default_velocity",
                 "default_acceleration", "kp", "kd", "ki", "integration_limit", "output_limit",
                 "current_limit", "error_limit", "servo_rate_divisor", "deadband"});
  ServoParams servo;
  servo.encoder_counts_per_rev =
      map.Number("encoder_counts_per_rev", PositiveNumber("counts per motor revolution"));
  const YamlValue gear = map.Get("gear_ratio", "motor revolutions per joint revolution, non-zero");
  servo.gear_ratio = gear.Number(AnyNumber("motor revolutions per joint revolution"));
  if (servo.gear_ratio == 0) gear.Fail("0 is not allowed; expected a non-zero gear ratio");
  servo.motor_torque_max_nm = map.Number("motor_torque_max_nm", PositiveNumber("N*m"));
  servo.default_velocity = map.Number("default_velocity", PositiveNumber(speed_unit)) * speed_scale;
  servo.default_acceleration =
      map.Number("default_acceleration", PositiveNumber(speed_unit + "^2")) * speed_scale;
  auto chip = [&](const char* key, int64_t min, int64_t max, double fallback) {
    const std::optional<YamlValue> field = map.Find(key);
    if (!field) return fallback;
    return static_cast<double>(field->Integer(min, max));
  };
  auto chip_required = [&](const char* key, int64_t min, int64_t max) {
    return static_cast<double>(
        map.Get(key, "an integer in [" + std::to_string(min) + ", " + std::to_string(max) + "]")
            .Integer(min, max));
  };
  servo.kp = chip_required("kp", 0, 32767);
  servo.kd = chip_required("kd", 0, 32767);
  servo.ki = chip_required("ki", 0, 32767);
  servo.integration_limit = chip("integration_limit", 0, 32767, 0);
  servo.output_limit = chip("output_limit", 0, 255, 255);
  servo.current_limit = chip("current_limit", 0, 255, 0);
  servo.error_limit = chip("error_limit", 0, 32767, 4000);
  servo.servo_rate_divisor = chip("servo_rate_divisor", 1, 255, 1);
  servo.deadband = chip("deadband", 0, 255, 0);
  return servo;
}

Joint ReadJoint(const YamlValue& value, const DhRow& dh, const FileUnits& units) {
  const YamlMap map = value.Map({"name", "type", "limits", "max_velocity", "max_effort", "armature",
                                 "home", "friction", "servo"});
  Joint joint;
  joint.name = map.String("name");
  joint.dh = dh;
  if (auto type = map.Find("type")) {
    joint.type = type->Choice({"revolute", "prismatic"}) == "revolute" ? JointType::kRevolute
                                                                       : JointType::kPrismatic;
  }
  const bool revolute = joint.type == JointType::kRevolute;
  const std::string position_unit = revolute ? units.angle_name : units.length_name;
  const double scale = revolute ? units.angle_rad : units.length_m;
  const std::string speed_unit = position_unit + "/s";
  const std::string effort_unit = revolute ? "N*m" : "N";

  const std::vector<double> limits =
      map.Get("limits", "[min, max] in " + position_unit).Numbers(2, AnyNumber(position_unit));
  joint.position_min = limits[0] * scale;
  joint.position_max = limits[1] * scale;
  joint.velocity_max = map.Number("max_velocity", PositiveNumber(speed_unit)) * scale;
  joint.effort_max = map.Number("max_effort", PositiveNumber(effort_unit));
  joint.armature = map.NumberOr("armature", 0, NonNegativeNumber(revolute ? "kg*m^2" : "kg"));
  joint.home = map.NumberOr("home", 0, AnyNumber(position_unit)) * scale;
  joint.friction = ReadFriction(map.Get("friction", "a mapping: static, coulomb, viscous"),
                                revolute, speed_unit, scale);
  joint.servo =
      ReadServo(map.Get("servo", "the joint's PIC-SERVO drive, a mapping"), speed_unit, scale);
  return joint;
}

DhRow ReadDhRow(const YamlValue& value, const FileUnits& units) {
  const YamlMap map = value.Map({"a", "alpha", "d", "theta"});
  DhRow row;
  row.a_m = units.Length(map.Number("a", AnyNumber(units.length_name)));
  row.alpha_rad = units.Angle(map.Number("alpha", AnyNumber(units.angle_name)));
  row.d_m = units.Length(map.Number("d", AnyNumber(units.length_name)));
  row.theta_rad = units.Angle(map.NumberOr("theta", 0, AnyNumber(units.angle_name)));
  return row;
}

}  // namespace

RobotModel ParseRobotModel(const std::string& text, const std::string& name) {
  const YamlDocument document = YamlDocument::Parse(text, name);
  const YamlMap root = document.Root().Map({"format", "name", "description", "units",
                                            "dh_convention", "servo_tick_s", "gravity_m_s2", "base",
                                            "tool", "dh", "joints", "links", "named_poses"});
  root.Get("format", std::string("the format tag ") + kRobotFormat).Choice({kRobotFormat});

  RobotModel model;
  model.name = root.String("name");
  model.description = root.StringOr("description", "");
  model.source_file = name;
  model.source_hash = Fnv1aHex(text);
  const FileUnits units = ReadUnits(root);
  model.file_length_unit = units.length_name;
  model.file_length_unit_m = units.length_m;
  model.file_angle_unit = units.angle_name;
  model.dh_convention =
      root.Get("dh_convention", "one of: standard, modified").Choice({"standard", "modified"}) ==
              "standard"
          ? DhConvention::kStandard
          : DhConvention::kModified;
  model.servo_tick_s = root.NumberOr("servo_tick_s", 0.000512, PositiveNumber("s"));
  if (auto gravity = root.Find("gravity_m_s2")) {
    const std::vector<double> g = gravity->Numbers(3, AnyNumber("m/s^2"));
    model.gravity_m_s2 = Eigen::Vector3d(g[0], g[1], g[2]);
  }
  model.base = ReadPose(root, "base", units);
  model.tool = ReadPose(root, "tool", units);

  const YamlValue dh_value =
      root.Get("dh", "a list of DH rows {a, alpha, d, theta}, one per joint");
  std::vector<DhRow> rows;
  for (const YamlValue& row : dh_value.Sequence(1, 64)) rows.push_back(ReadDhRow(row, units));
  const std::vector<YamlValue> joint_values =
      root.Get("joints", "a list of joints, one per DH row").Sequence(1, 64);
  if (joint_values.size() != rows.size()) {
    dh_value.Fail(std::to_string(rows.size()) + " rows for " + std::to_string(joint_values.size()) +
                  " joints; expected one DH row per joint");
  }
  for (size_t i = 0; i < joint_values.size(); ++i) {
    model.joints.push_back(ReadJoint(joint_values[i], rows[i], units));
  }

  const std::vector<YamlValue> link_values =
      root.Get("links", "a list: the base, then one link per joint").Sequence(1, 65);
  for (size_t i = 0; i < link_values.size(); ++i) {
    model.links.push_back(ReadLink(link_values[i], i == 0, units));
  }

  if (auto poses = root.Find("named_poses")) {
    for (const auto& [pose_name, pose_value] : poses->Entries()) {
      NamedPose pose;
      pose.name = pose_name;
      const std::vector<YamlValue> items = pose_value.Sequence();
      for (size_t j = 0; j < items.size(); ++j) {
        const bool revolute =
            j >= model.joints.size() || model.joints[j].type == JointType::kRevolute;
        const double value =
            items[j].Number(AnyNumber(revolute ? units.angle_name : units.length_name));
        pose.position.push_back(value * (revolute ? units.angle_rad : units.length_m));
      }
      model.named_poses.push_back(pose);
    }
  }

  if (const std::optional<ModelProblem> problem = FindModelProblem(model)) {
    throw ConfigError(document.LocationOf(problem->path), Printable(problem->path, 256),
                      Printable(problem->problem));
  }
  return model;
}

RobotModel LoadRobotModel(const std::string& file) {
  return ParseRobotModel(ReadTextFile(file), file);
}

}  // namespace sirupp::core
