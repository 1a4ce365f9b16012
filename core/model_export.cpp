#include "core/model_export.hpp"

#include <tinyxml2.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <set>
#include <vector>

#include "core/errors.hpp"
#include "core/kinematics.hpp"

namespace sirupp::core {

namespace {

// The shortest text that reads back as the same double, so other tools see exactly our numbers.
std::string Num(double value) { return value == 0 ? "0" : FormatNumber(value); }  // no "-0"

std::string Vec(const Eigen::Vector3d& v) {
  return Num(v.x()) + " " + Num(v.y()) + " " + Num(v.z());
}

// A coordinate of a composed pose: rounding noise below 1e-14 (m, rad or quaternion units) is
// written as 0, so that "2.3e-18" does not hide an exact zero.
double Clean(double value) { return std::abs(value) < 1e-14 ? 0.0 : value; }

std::string Position(const Eigen::Vector3d& v) { return Vec(v.unaryExpr(&Clean)); }

std::string Rpy(const Eigen::Matrix3d& rotation) { return Position(RollPitchYaw(rotation)); }

std::string Quat(const Eigen::Matrix3d& rotation) {
  Eigen::Quaterniond q(rotation);
  if (q.w() < 0) q.coeffs() *= -1;  // one of the two equal quaternions, w >= 0
  return Num(Clean(q.w())) + " " + Num(Clean(q.x())) + " " + Num(Clean(q.y())) + " " +
         Num(Clean(q.z()));
}

// A colour component (stored as float): the shortest text that reads back as the same float.
std::string Component(float value) {
  char text[32];
  for (int digits = 3; digits <= 9; ++digits) {
    std::snprintf(text, sizeof text, "%.*g", digits, static_cast<double>(value));
    if (std::strtof(text, nullptr) == value) break;
  }
  return text;
}

std::string Rgba(const Shape& shape) {
  return Component(shape.rgba[0]) + " " + Component(shape.rgba[1]) + " " +
         Component(shape.rgba[2]) + " " + Component(shape.rgba[3]);
}

// XML comments may not contain "--".
std::string CommentText(std::string text) {
  for (size_t at = text.find("--"); at != std::string::npos; at = text.find("--", at)) {
    text.replace(at, 2, "- -");
  }
  return " " + text + " ";
}

Eigen::Isometry3d Translation(const Eigen::Vector3d& offset) {
  Eigen::Isometry3d transform = Eigen::Isometry3d::Identity();
  transform.translation() = offset;
  return transform;
}

// An element with attributes, written on one line when it has no children.
class Writer {
 public:
  Writer() : printer_(nullptr, false) { printer_.PushHeader(false, true); }

  void Open(const char* name) { printer_.OpenElement(name); }
  void Attr(const char* name, const std::string& value) {
    printer_.PushAttribute(name, value.c_str());
  }
  void Close() { printer_.CloseElement(); }
  void Comment(const std::string& text) { printer_.PushComment(CommentText(text).c_str()); }
  // <name a1="v1" a2="v2" .../>
  void Leaf(const char* name, std::initializer_list<std::pair<const char*, std::string>> attrs) {
    Open(name);
    for (const auto& [key, value] : attrs) Attr(key, value);
    Close();
  }
  // <name>text</name>
  void TextLeaf(const char* name, const std::string& text) {
    Open(name);
    printer_.PushText(text.c_str());
    Close();
  }
  std::string Text() const { return printer_.CStr(); }

 private:
  tinyxml2::XMLPrinter printer_;
};

std::string Provenance(const RobotModel& model) {
  std::string text = "exported by 'sirupp model export' from robot model '" + model.name + "'";
  if (!model.source_file.empty())
    text += " (" + model.source_file + ", FNV-1a " + model.source_hash + ")";
  return text + "; SI units (m, rad, kg, N*m); format notes: docs/export.md";
}

// ---- URDF ----------------------------------------------------------------------------------

void UrdfOrigin(Writer& xml, const Eigen::Isometry3d& pose) {
  xml.Leaf("origin", {{"xyz", Position(pose.translation())}, {"rpy", Rpy(pose.linear())}});
}

// One URDF geometry element for a shape whose centre frame is `pose` in the link frame; a capsule
// has no URDF element and becomes a cylinder and two spheres (same solid).
struct UrdfPiece {
  Eigen::Isometry3d pose;
  std::string element;  // box, cylinder, sphere
  std::vector<std::pair<const char*, std::string>> attrs;
};

std::vector<UrdfPiece> UrdfPieces(const Shape& shape, const Eigen::Isometry3d& pose) {
  const Eigen::Vector3d& s = shape.size_m;
  switch (shape.type) {
    case ShapeType::kBox:
      return {{pose, "box", {{"size", Vec(s)}}}};
    case ShapeType::kCylinder:
      return {{pose, "cylinder", {{"radius", Num(s.x())}, {"length", Num(s.y())}}}};
    case ShapeType::kSphere:
      return {{pose, "sphere", {{"radius", Num(s.x())}}}};
    case ShapeType::kCapsule: {
      const Eigen::Vector3d half(0, 0, s.y() / 2);
      return {{pose, "cylinder", {{"radius", Num(s.x())}, {"length", Num(s.y())}}},
              {pose * Translation(half), "sphere", {{"radius", Num(s.x())}}},
              {pose * Translation(-half), "sphere", {{"radius", Num(s.x())}}}};
    }
  }
  return {};
}

void UrdfLink(Writer& xml, const RobotModel& model, int index, const std::string& name) {
  const Link& link = model.links[static_cast<size_t>(index)];
  const Eigen::Isometry3d to_dh = UrdfLinkToDhFrame(model, index);
  xml.Open("link");
  xml.Attr("name", name);
  if (link.mass_kg > 0) {
    // The inertia is about the centre of mass in the DH frame's axes: the inertial frame is the
    // DH frame's axes at the centre of mass, so the tensor is written unchanged.
    const Eigen::Matrix3d& i = link.inertia_kg_m2;
    Eigen::Isometry3d inertial = to_dh * Translation(link.com_m);
    xml.Open("inertial");
    UrdfOrigin(xml, inertial);
    xml.Leaf("mass", {{"value", Num(link.mass_kg)}});
    xml.Leaf("inertia", {{"ixx", Num(i(0, 0))},
                         {"ixy", Num(i(0, 1))},
                         {"ixz", Num(i(0, 2))},
                         {"iyy", Num(i(1, 1))},
                         {"iyz", Num(i(1, 2))},
                         {"izz", Num(i(2, 2))}});
    xml.Close();
  }
  int count = 0;
  for (const Shape& shape : link.shapes) {
    for (const UrdfPiece& piece : UrdfPieces(shape, to_dh * shape.pose.ToIsometry())) {
      const std::string piece_name = name + "_" + std::to_string(count++);
      for (const char* kind : {"visual", "collision"}) {
        xml.Open(kind);
        xml.Attr("name", piece_name);
        UrdfOrigin(xml, piece.pose);
        xml.Open("geometry");
        xml.Open(piece.element.c_str());
        for (const auto& [key, value] : piece.attrs) xml.Attr(key, value);
        xml.Close();
        xml.Close();
        if (kind[0] == 'v') {
          xml.Open("material");
          xml.Attr("name", piece_name);
          xml.Leaf("color", {{"rgba", Rgba(shape)}});
          xml.Close();
        }
        xml.Close();
      }
    }
  }
  xml.Close();
}

void UrdfFixedJoint(Writer& xml, const std::string& name, const std::string& parent,
                    const std::string& child, const Eigen::Isometry3d& origin) {
  xml.Open("joint");
  xml.Attr("name", name);
  xml.Attr("type", "fixed");
  xml.Leaf("parent", {{"link", parent}});
  xml.Leaf("child", {{"link", child}});
  UrdfOrigin(xml, origin);
  xml.Close();
}

// ---- MJCF ----------------------------------------------------------------------------------

void MjcfInertial(Writer& xml, const Link& link) {
  const Eigen::Matrix3d& i = link.inertia_kg_m2;
  // MuJoCo's fullinertia order is M(1,1) M(2,2) M(3,3) M(1,2) M(1,3) M(2,3), about the centre of
  // mass in the body's axes (here the DH frame's).
  xml.Leaf("inertial",
           {{"pos", Vec(link.com_m)},
            {"mass", Num(link.mass_kg)},
            {"fullinertia", Num(i(0, 0)) + " " + Num(i(1, 1)) + " " + Num(i(2, 2)) + " " +
                                Num(i(0, 1)) + " " + Num(i(0, 2)) + " " + Num(i(1, 2))}});
}

void MjcfGeoms(Writer& xml, const Link& link, const std::string& body_name) {
  int count = 0;
  for (const Shape& shape : link.shapes) {
    const Eigen::Isometry3d pose = shape.pose.ToIsometry();
    const Eigen::Vector3d& s = shape.size_m;
    std::string type, size;
    switch (shape.type) {
      case ShapeType::kBox:
        type = "box", size = Vec(s / 2);  // half edges
        break;
      case ShapeType::kCylinder:
        type = "cylinder", size = Num(s.x()) + " " + Num(s.y() / 2);  // radius, half length
        break;
      case ShapeType::kCapsule:
        type = "capsule", size = Num(s.x()) + " " + Num(s.y() / 2);
        break;
      case ShapeType::kSphere:
        type = "sphere", size = Num(s.x());
        break;
    }
    // contype 1, conaffinity 0: the arm's geoms touch the world's (default 1/1) but never each
    // other, like sirupp-sim, where adjacent links overlap at their joints.
    xml.Leaf("geom", {{"name", body_name + "_" + std::to_string(count++)},
                      {"type", type},
                      {"size", size},
                      {"pos", Position(pose.translation())},
                      {"quat", Quat(pose.linear())},
                      {"rgba", Rgba(shape)},
                      {"contype", "1"},
                      {"conaffinity", "0"}});
  }
}

std::string UniqueName(const std::string& wanted, const std::set<std::string>& taken) {
  std::string name = wanted;
  while (taken.count(name)) name += "_";
  return name;
}

}  // namespace

Eigen::Isometry3d UrdfLinkToDhFrame(const RobotModel& model, int link) {
  if (link <= 0 || model.dh_convention == DhConvention::kModified) {
    return Eigen::Isometry3d::Identity();
  }
  const DhRow& dh = model.joints[static_cast<size_t>(link - 1)].dh;
  return Translation(Eigen::Vector3d(dh.a_m, 0, 0)) *
         Eigen::AngleAxisd(dh.alpha_rad, Eigen::Vector3d::UnitX());
}

ExportNames MakeExportNames(const RobotModel& model) {
  ExportNames names;
  std::set<std::string> link_names;
  for (const Link& link : model.links) link_names.insert(link.name);
  // "world" is MuJoCo's world body and the URDF root; a link of that name is renamed.
  for (const Link& link : model.links) {
    names.links.push_back(link.name == "world" ? UniqueName("world_link", link_names) : link.name);
  }
  std::set<std::string> taken(names.links.begin(), names.links.end());
  taken.insert("world");
  names.links.push_back(UniqueName("tool", taken));
  for (const Joint& joint : model.joints) names.joints.push_back(joint.name);
  return names;
}

std::string ExportUrdf(const RobotModel& model) {
  const ExportNames names = MakeExportNames(model);
  const int n = model.num_joints();
  std::set<std::string> joint_names(names.joints.begin(), names.joints.end());
  Writer xml;
  xml.Comment(Provenance(model));
  xml.Comment(std::string("URDF link i is the frame joint i moves; ") +
              (model.dh_convention == DhConvention::kStandard
                   ? "standard DH: DH frame i = link i * Tx(a_i) Rx(alpha_i)"
                   : "modified DH: link i is DH frame i") +
              "; joint positions are the model's q (theta = q + offset, or d = q + offset)");
  xml.Open("robot");
  xml.Attr("name", model.name);
  xml.Attr("xmlns:drake", "http://drake.mit.edu");

  xml.Open("link");
  xml.Attr("name", names.world);
  xml.Close();
  UrdfFixedJoint(xml, UniqueName("world_to_" + names.links[0], joint_names), names.world,
                 names.links[0], model.base.ToIsometry());
  UrdfLink(xml, model, 0, names.links[0]);

  for (int k = 1; k <= n; ++k) {
    const Joint& joint = model.joints[static_cast<size_t>(k - 1)];
    // URDF link k-1 -> URDF link k at q = 0:
    // (URDF link k-1 -> DH frame k-1) * A_k(0) * (DH frame k -> URDF link k).
    const Eigen::Isometry3d origin = UrdfLinkToDhFrame(model, k - 1) *
                                     DhTransform(model.dh_convention, joint, 0.0) *
                                     UrdfLinkToDhFrame(model, k).inverse();
    const bool revolute = joint.type == JointType::kRevolute;
    xml.Open("joint");
    xml.Attr("name", names.joints[static_cast<size_t>(k - 1)]);
    xml.Attr("type", revolute ? "revolute" : "prismatic");
    xml.Leaf("parent", {{"link", names.links[static_cast<size_t>(k - 1)]}});
    xml.Leaf("child", {{"link", names.links[static_cast<size_t>(k)]}});
    UrdfOrigin(xml, origin);
    xml.Leaf("axis", {{"xyz", "0 0 1"}});
    xml.Leaf("limit", {{"lower", Num(joint.position_min)},
                       {"upper", Num(joint.position_max)},
                       {"effort", Num(joint.effort_max)},
                       {"velocity", Num(joint.velocity_max)}});
    // URDF's friction is the joint's static friction; damping its viscous coefficient.
    xml.Leaf("dynamics", {{"damping", Num(joint.friction.viscous)},
                          {"friction", Num(joint.friction.static_effort)}});
    xml.Close();
    UrdfLink(xml, model, k, names.links[static_cast<size_t>(k)]);
  }
  UrdfFixedJoint(xml, UniqueName(names.links.back() + "_joint", joint_names),
                 names.links[static_cast<size_t>(n)], names.links.back(),
                 UrdfLinkToDhFrame(model, n) * model.tool.ToIsometry());
  xml.Open("link");
  xml.Attr("name", names.links.back());
  xml.Close();

  // The drive of each joint: gear ratio and armature (reflected rotor inertia G^2 * J_rotor).
  for (int k = 1; k <= n; ++k) {
    const Joint& joint = model.joints[static_cast<size_t>(k - 1)];
    const std::string& joint_name = names.joints[static_cast<size_t>(k - 1)];
    const double gear = std::abs(joint.servo.gear_ratio);
    xml.Open("transmission");
    xml.Attr("name", joint_name + "_transmission");
    xml.TextLeaf("type", "transmission_interface/SimpleTransmission");
    xml.Open("joint");
    xml.Attr("name", joint_name);
    xml.TextLeaf("hardwareInterface", "hardware_interface/EffortJointInterface");
    xml.Close();
    xml.Open("actuator");
    xml.Attr("name", joint_name + "_motor");
    xml.TextLeaf("mechanicalReduction", Num(joint.servo.gear_ratio));
    xml.Leaf("drake:gear_ratio", {{"value", Num(gear)}});
    xml.Leaf("drake:rotor_inertia", {{"value", Num(joint.armature / (gear * gear))}});
    xml.Close();
    xml.Close();
  }
  xml.Close();
  return xml.Text();
}

namespace {

// <compiler>, <option> (time step, gravity, contacts) and the joint speed limits as <custom>.
void MjcfSettings(Writer& xml, const RobotModel& model, const MjcfOptions& options,
                  const ExportNames& names) {
  const double step = options.timestep_s > 0 ? options.timestep_s : model.servo_tick_s;
  // Inertia comes only from the <inertial> elements, never balanced or derived from geoms;
  // fusestatic off keeps the fixed base as its own body.
  xml.Leaf("compiler", {{"angle", "radian"},
                        {"balanceinertia", "false"},
                        {"inertiafromgeom", "false"},
                        {"fusestatic", "false"}});
  xml.Open("option");
  xml.Attr("timestep", Num(step));
  xml.Attr("gravity", Vec(model.gravity_m_s2));
  xml.Attr("integrator", "Euler");
  if (!options.contacts) xml.Leaf("flag", {{"contact", "disable"}});
  xml.Close();

  // Joint speed limits have no MJCF attribute; they travel as custom numerics.
  xml.Open("custom");
  for (size_t j = 0; j < model.joints.size(); ++j) {
    xml.Leaf("numeric", {{"name", names.joints[j] + "_max_velocity"},
                         {"data", Num(model.joints[j].velocity_max)}});
  }
  xml.Close();
}

// Opens the body of link j + 1 (DH frame j + 1 relative to DH frame j at q = 0) with its joint,
// inertia and geoms; the caller closes it after the bodies nested in it.
void MjcfOpenJointBody(Writer& xml, const RobotModel& model, const MjcfOptions& options,
                       const ExportNames& names, size_t j) {
  const Joint& joint = model.joints[j];
  const Link& link = model.links[j + 1];
  const Eigen::Isometry3d step_pose = DhTransform(model.dh_convention, joint, 0.0);
  const Eigen::Matrix3d& r = step_pose.linear();
  // The joint line in body coordinates. Standard DH: z of the parent frame through its origin,
  // axis = R^T z, anchor = -R^T p. Modified DH: z of the body's own frame through its origin.
  // Turning (or sliding) the body about that line by q gives the DH transform at q, since
  // Rz(q) and Tz(q) commute with Rz(theta) Tz(d).
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();
  Eigen::Vector3d anchor = Eigen::Vector3d::Zero();
  if (model.dh_convention == DhConvention::kStandard) {
    axis = r.transpose() * Eigen::Vector3d::UnitZ();
    anchor = -(r.transpose() * step_pose.translation());
  }
  const bool revolute = joint.type == JointType::kRevolute;
  xml.Open("body");
  xml.Attr("name", names.links[j + 1]);
  xml.Attr("pos", Position(step_pose.translation()));
  xml.Attr("quat", Quat(r));
  xml.Open("joint");
  xml.Attr("name", names.joints[j]);
  xml.Attr("type", revolute ? "hinge" : "slide");
  xml.Attr("pos", Position(anchor));
  xml.Attr("axis", Position(axis));
  xml.Attr("ref", "0");
  xml.Attr("limited", "true");
  xml.Attr("range", Num(joint.position_min) + " " + Num(joint.position_max));
  xml.Attr("armature", Num(options.armature ? joint.armature : 0.0));
  const Friction& f = joint.friction;
  xml.Attr("damping", Num(options.joint_friction ? f.viscous : 0.0));
  xml.Attr("frictionloss",
           Num(options.joint_friction ? (f.coulomb_positive + f.coulomb_negative) / 2 : 0.0));
  xml.Close();
  MjcfInertial(xml, link);
  if (options.geoms) MjcfGeoms(xml, link, names.links[j + 1]);
}

// <worldbody>: the base welded to the world, then one nested body per joint, the tool as a site.
void MjcfWorldBody(Writer& xml, const RobotModel& model, const MjcfOptions& options,
                   const ExportNames& names) {
  xml.Open("worldbody");
  const Eigen::Isometry3d base = model.base.ToIsometry();
  xml.Open("body");
  xml.Attr("name", names.links[0]);
  xml.Attr("pos", Position(base.translation()));
  xml.Attr("quat", Quat(base.linear()));
  // The base is welded to the world, so its mass changes nothing; kept for completeness.
  if (model.links[0].mass_kg > 0) MjcfInertial(xml, model.links[0]);
  if (options.geoms) MjcfGeoms(xml, model.links[0], names.links[0]);
  for (size_t j = 0; j < model.joints.size(); ++j) MjcfOpenJointBody(xml, model, options, names, j);
  xml.Leaf("site", {{"name", names.links.back()},
                    {"pos", Position(model.tool.position_m)},
                    {"quat", Quat(model.tool.orientation.toRotationMatrix())}});
  for (size_t j = 0; j <= model.joints.size(); ++j) xml.Close();
  xml.Close();  // worldbody
}

// One torque (or force) motor per joint, limited to the joint's effort.
void MjcfActuators(Writer& xml, const RobotModel& model, const ExportNames& names) {
  xml.Open("actuator");
  for (size_t j = 0; j < model.joints.size(); ++j) {
    const double limit = model.joints[j].effort_max;
    xml.Leaf("motor", {{"name", names.joints[j] + "_motor"},
                       {"joint", names.joints[j]},
                       {"gear", "1"},
                       {"ctrllimited", "true"},
                       {"ctrlrange", Num(-limit) + " " + Num(limit)}});
  }
  xml.Close();
}

}  // namespace

std::string ExportMjcf(const RobotModel& model, const MjcfOptions& options) {
  const ExportNames names = MakeExportNames(model);
  Writer xml;
  xml.Comment(Provenance(model));
  xml.Comment(
      "body i is DH frame i; joint qpos is the model's q (built at q = 0); frictionloss is the "
      "mean Coulomb level: static break-away, direction asymmetry and Stribeck decay have no "
      "MuJoCo counterpart");
  xml.Open("mujoco");
  xml.Attr("model", model.name);
  MjcfSettings(xml, model, options, names);
  MjcfWorldBody(xml, model, options, names);
  if (options.actuators) MjcfActuators(xml, model, names);
  xml.Close();  // mujoco
  return xml.Text();
}

}  // namespace sirupp::core
