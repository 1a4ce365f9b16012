// The URDF and MJCF export (core/model_export.hpp). The URDF is read back with TinyXML-2 and its
// chain composed the way URDF defines it (child = parent * origin * motion about the axis), which
// must give our forward kinematics, link contents and tool exactly. The MJCF is checked by MuJoCo
// itself in test_model_export_mujoco.cpp.
#include <gtest/gtest.h>
#include <tinyxml2.h>

#include <cmath>
#include <map>
#include <random>
#include <sstream>

#include "core/kinematics.hpp"
#include "core/model_export.hpp"
#include "core/model_loader.hpp"

namespace sirupp::core {
namespace {

const char* const kModels[] = {"config/robots/puma260.yaml", "config/robots/planar3.yaml",
                               "config/robots/stanford.yaml"};

Eigen::Vector3d Triple(const char* text) {
  std::istringstream in(text ? text : "");
  Eigen::Vector3d v;
  in >> v.x() >> v.y() >> v.z();
  EXPECT_TRUE(in && text) << "not three numbers: " << (text ? text : "(none)");
  return v;
}

Eigen::Isometry3d Origin(const tinyxml2::XMLElement* parent) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  const tinyxml2::XMLElement* origin = parent->FirstChildElement("origin");
  if (origin == nullptr) return pose;
  const Eigen::Vector3d rpy = Triple(origin->Attribute("rpy"));
  pose.linear() = QuaternionFromRpy(rpy.x(), rpy.y(), rpy.z()).toRotationMatrix();
  pose.translation() = Triple(origin->Attribute("xyz"));
  return pose;
}

struct UrdfJoint {
  std::string name, type, parent, child;
  Eigen::Isometry3d origin;
  Eigen::Vector3d axis = Eigen::Vector3d::UnitX();  // URDF's default
  const tinyxml2::XMLElement* element = nullptr;
};

// The URDF read back: joints by child link, and link poses for joint positions q (in joint order).
class Urdf {
 public:
  explicit Urdf(const std::string& text) {
    EXPECT_EQ(doc_.Parse(text.c_str()), tinyxml2::XML_SUCCESS) << doc_.ErrorStr();
    const tinyxml2::XMLElement* robot = doc_.FirstChildElement("robot");
    EXPECT_NE(robot, nullptr);
    for (auto* e = robot->FirstChildElement("link"); e; e = e->NextSiblingElement("link")) {
      links_[e->Attribute("name")] = e;
    }
    for (auto* e = robot->FirstChildElement("joint"); e; e = e->NextSiblingElement("joint")) {
      UrdfJoint joint;
      joint.element = e;
      joint.name = e->Attribute("name");
      joint.type = e->Attribute("type");
      joint.parent = e->FirstChildElement("parent")->Attribute("link");
      joint.child = e->FirstChildElement("child")->Attribute("link");
      joint.origin = Origin(e);
      if (auto* axis = e->FirstChildElement("axis")) joint.axis = Triple(axis->Attribute("xyz"));
      by_child_[joint.child] = joint;
      if (joint.type != "fixed") movable_.push_back(joint.name);
    }
  }

  const std::vector<std::string>& movable() const { return movable_; }
  const tinyxml2::XMLElement* link(const std::string& name) const { return links_.at(name); }
  const UrdfJoint& joint_to(const std::string& child) const { return by_child_.at(child); }

  // World pose of `link` with joint positions q (one per movable joint, in file order).
  Eigen::Isometry3d Pose(const std::string& link, const JointVector& q) const {
    const auto found = by_child_.find(link);
    if (found == by_child_.end()) return Eigen::Isometry3d::Identity();  // the root
    const UrdfJoint& joint = found->second;
    Eigen::Isometry3d motion = Eigen::Isometry3d::Identity();
    for (size_t i = 0; i < movable_.size(); ++i) {
      if (movable_[i] != joint.name) continue;
      const double value = q[static_cast<Eigen::Index>(i)];
      if (joint.type == "prismatic") {
        motion.translation() = joint.axis.normalized() * value;
      } else {
        motion.linear() = Eigen::AngleAxisd(value, joint.axis.normalized()).toRotationMatrix();
      }
    }
    return Pose(joint.parent, q) * joint.origin * motion;
  }

 private:
  tinyxml2::XMLDocument doc_;
  std::map<std::string, const tinyxml2::XMLElement*> links_;
  std::map<std::string, UrdfJoint> by_child_;
  std::vector<std::string> movable_;
};

JointVector RandomWithinLimits(const RobotModel& model, std::mt19937& rng) {
  JointVector q(model.num_joints());
  for (int i = 0; i < model.num_joints(); ++i) {
    const Joint& joint = model.joints[static_cast<size_t>(i)];
    q[i] = std::uniform_real_distribution<double>(joint.position_min, joint.position_max)(rng);
  }
  return q;
}

void ExpectSamePose(const Eigen::Isometry3d& got, const Eigen::Isometry3d& want,
                    const std::string& what) {
  const PoseError error = ComparePoses(got, want);
  EXPECT_LT(error.position_m, 1e-12) << what;
  EXPECT_LT(error.rotation_rad, 1e-12) << what;
}

TEST(UrdfExport, ChainGivesOurForwardKinematics) {
  std::mt19937 rng(21);
  for (const char* file : kModels) {
    SCOPED_TRACE(file);
    const RobotModel model = LoadRobotModel(file);
    const ExportNames names = MakeExportNames(model);
    const Urdf urdf(ExportUrdf(model));
    ASSERT_EQ(urdf.movable().size(), model.joints.size());
    for (int trial = 0; trial < 20; ++trial) {
      const JointVector q =
          trial == 0 ? JointVector::Zero(model.num_joints()) : RandomWithinLimits(model, rng);
      const ForwardResult fk = ForwardKinematics(model, q);
      ExpectSamePose(urdf.Pose(names.links.back(), q), fk.tool, "tool");
      for (int k = 0; k <= model.num_joints(); ++k) {
        const std::string& name = names.links[static_cast<size_t>(k)];
        // DH frame k from the URDF link frame, as the header documents.
        ExpectSamePose(urdf.Pose(name, q) * UrdfLinkToDhFrame(model, k),
                       fk.frames[static_cast<size_t>(k)], "DH frame of " + name);
        const Link& link = model.links[static_cast<size_t>(k)];
        const tinyxml2::XMLElement* element = urdf.link(name);
        // The inertial frame: at the centre of mass, with the DH frame's axes (so the tensor is
        // the model's, unchanged).
        if (const auto* inertial = element->FirstChildElement("inertial")) {
          ExpectSamePose(urdf.Pose(name, q) * Origin(inertial),
                         fk.frames[static_cast<size_t>(k)] * Eigen::Translation3d(link.com_m),
                         "inertial of " + name);
        } else {
          EXPECT_EQ(link.mass_kg, 0) << name;
        }
        // The first shape's visual (capsules come first as their cylinder).
        if (!link.shapes.empty()) {
          ExpectSamePose(urdf.Pose(name, q) * Origin(element->FirstChildElement("visual")),
                         fk.frames[static_cast<size_t>(k)] * link.shapes[0].pose.ToIsometry(),
                         "first visual of " + name);
        }
      }
    }
  }
}

TEST(UrdfExport, JointsCarryLimitsDynamicsAndDrive) {
  const RobotModel model = LoadRobotModel("config/robots/stanford.yaml");
  const Urdf urdf(ExportUrdf(model));
  const ExportNames names = MakeExportNames(model);
  for (size_t j = 0; j < model.joints.size(); ++j) {
    const Joint& joint = model.joints[j];
    const UrdfJoint& exported = urdf.joint_to(names.links[j + 1]);
    SCOPED_TRACE(joint.name);
    EXPECT_EQ(exported.name, joint.name);
    EXPECT_EQ(exported.type, joint.type == JointType::kPrismatic ? "prismatic" : "revolute");
    const tinyxml2::XMLElement* limit = exported.element->FirstChildElement("limit");
    EXPECT_EQ(limit->DoubleAttribute("lower"), joint.position_min);
    EXPECT_EQ(limit->DoubleAttribute("upper"), joint.position_max);
    EXPECT_EQ(limit->DoubleAttribute("effort"), joint.effort_max);
    EXPECT_EQ(limit->DoubleAttribute("velocity"), joint.velocity_max);
    const tinyxml2::XMLElement* dynamics = exported.element->FirstChildElement("dynamics");
    EXPECT_EQ(dynamics->DoubleAttribute("damping"), joint.friction.viscous);
    EXPECT_EQ(dynamics->DoubleAttribute("friction"), joint.friction.static_effort);
  }
  // Armature as Drake's rotor inertia times gear ratio squared.
  const std::string text = ExportUrdf(model);
  tinyxml2::XMLDocument doc;
  ASSERT_EQ(doc.Parse(text.c_str()), tinyxml2::XML_SUCCESS);
  size_t j = 0;
  for (auto* t = doc.FirstChildElement("robot")->FirstChildElement("transmission"); t;
       t = t->NextSiblingElement("transmission"), ++j) {
    ASSERT_LT(j, model.joints.size());
    EXPECT_STREQ(t->FirstChildElement("joint")->Attribute("name"), model.joints[j].name.c_str());
    const tinyxml2::XMLElement* actuator = t->FirstChildElement("actuator");
    const double gear = actuator->FirstChildElement("drake:gear_ratio")->DoubleAttribute("value");
    const double rotor =
        actuator->FirstChildElement("drake:rotor_inertia")->DoubleAttribute("value");
    EXPECT_NEAR(rotor * gear * gear, model.joints[j].armature,
                1e-15 * (1 + model.joints[j].armature));
  }
  EXPECT_EQ(j, model.joints.size());
}

TEST(ModelExport, NamesAreEscapedAndKeptApartFromAddedOnes) {
  RobotModel model = LoadRobotModel("config/robots/planar3.yaml");
  model.name = "arm \"<&>\"\tone";
  model.links[1].name = "world";
  model.links[2].name = "tool";
  const ExportNames names = MakeExportNames(model);
  EXPECT_EQ(names.links[1], "world_link");
  EXPECT_EQ(names.links.back(), "tool_");
  for (const std::string& text : {ExportUrdf(model), ExportMjcf(model)}) {
    tinyxml2::XMLDocument doc;
    ASSERT_EQ(doc.Parse(text.c_str()), tinyxml2::XML_SUCCESS) << text;
    const tinyxml2::XMLElement* root = doc.RootElement();
    const char* name = root->Attribute(root->Attribute("name") ? "name" : "model");
    ASSERT_NE(name, nullptr);
    EXPECT_EQ(std::string(name), model.name);
  }
}

}  // namespace
}  // namespace sirupp::core
