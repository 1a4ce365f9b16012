#include <gtest/gtest.h>

#include <cmath>

#include "core/mass_properties.hpp"
#include "core/model_loader.hpp"
#include "core/yaml_reader.hpp"

namespace sirupp::core {
namespace {

constexpr double kInch = 0.0254;
constexpr double kDeg = M_PI / 180;

TEST(ModelLoader, Puma260MatchesTableOne) {
  const RobotModel model = LoadRobotModel("config/robots/puma260.yaml");
  ASSERT_EQ(model.num_joints(), 6);
  EXPECT_EQ(model.dh_convention, DhConvention::kStandard);
  // Table I: alpha (deg), a (in), d (in).
  const double alpha[6] = {-90, 0, 90, -90, 90, 0};
  const double a[6] = {0, 8, 0, 0, 0, 0};
  const double d[6] = {13, -3.2, -2.4, 8, 0, 2.2};
  for (int i = 0; i < 6; ++i) {
    SCOPED_TRACE(i);
    const DhRow& row = model.joints[static_cast<size_t>(i)].dh;
    EXPECT_NEAR(row.alpha_rad, alpha[i] * kDeg, 1e-15);
    EXPECT_NEAR(row.a_m, a[i] * kInch, 1e-15);
    EXPECT_NEAR(row.d_m, d[i] * kInch, 1e-15);
    EXPECT_EQ(row.theta_rad, 0);
  }
  EXPECT_EQ(model.file_length_unit, "inch");
  EXPECT_DOUBLE_EQ(model.servo_tick_s, 0.000512);
}

TEST(ModelLoader, Puma260MassesFollowThePaper) {
  const RobotModel model = LoadRobotModel("config/robots/puma260.yaml");
  ASSERT_EQ(model.links.size(), 7U);
  EXPECT_DOUBLE_EQ(model.links[1].mass_kg, 3.0);  // link 1 with link 0
  EXPECT_DOUBLE_EQ(model.links[2].mass_kg, 1.5);
  const double link3_and_wrist = model.links[3].mass_kg + model.links[4].mass_kg +
                                 model.links[5].mass_kg + model.links[6].mass_kg;
  EXPECT_NEAR(link3_and_wrist, 2.3, 1e-12);
  for (size_t i = 1; i < model.links.size(); ++i) {
    SCOPED_TRACE(model.links[i].name);
    EXPECT_FALSE(InertiaProblem(model.links[i].inertia_kg_m2));
    EXPECT_TRUE(model.links[i].inertia_derived);
  }
}

TEST(ModelLoader, Puma260ServoAndLimits) {
  const RobotModel model = LoadRobotModel("config/robots/puma260.yaml");
  for (const Joint& joint : model.joints) {
    SCOPED_TRACE(joint.name);
    EXPECT_EQ(joint.servo.kp, 100);
    EXPECT_EQ(joint.servo.kd, 1000);
    EXPECT_EQ(joint.servo.ki, 0);
    EXPECT_LT(joint.position_min, 0);
    EXPECT_GT(joint.position_max, 90 * kDeg);  // the paper's moves go from 0 to 90 degrees
  }
  // Merge keys: the shoulder inherits the big servo and overrides its gear ratio.
  EXPECT_DOUBLE_EQ(model.joints[1].servo.gear_ratio, 69.9733);
  EXPECT_DOUBLE_EQ(model.joints[1].servo.encoder_counts_per_rev, 1000);
  // The wrist inherits through two levels of merging.
  EXPECT_DOUBLE_EQ(model.joints[4].servo.encoder_counts_per_rev, 800);
  EXPECT_DOUBLE_EQ(model.joints[4].servo.kd, 1000);
  // The wrist roll's range goes past +-180 degrees (ODE's hinge stops cannot hold it).
  EXPECT_NEAR(model.joints[3].position_max, 310 * kDeg, 1e-12);
  EXPECT_NEAR(model.joints[0].friction.coulomb_negative, 0.75, 1e-15);
  EXPECT_NEAR(model.joints[0].servo.default_velocity, 45 * kDeg, 1e-15);
  const NamedPose* ready = model.FindNamedPose("ready");
  ASSERT_NE(ready, nullptr);
  EXPECT_NEAR(ready->position[1], -90 * kDeg, 1e-15);
}

TEST(ModelLoader, CylinderBetweenPointsIsPlacedAndSized) {
  const RobotModel model = LoadRobotModel("config/robots/puma260.yaml");
  // Forearm cylinder from z = -0.8 in to z = 6.5 in along z3.
  const Shape& forearm = model.links[3].shapes[0];
  EXPECT_EQ(forearm.type, ShapeType::kCylinder);
  EXPECT_NEAR(forearm.size_m.y(), 7.3 * kInch, 1e-12);
  EXPECT_NEAR(forearm.pose.position_m.z(), 2.85 * kInch, 1e-12);
  EXPECT_TRUE((forearm.pose.orientation * Eigen::Vector3d::UnitZ())
                  .isApprox(Eigen::Vector3d::UnitZ(), 1e-12));
}

TEST(ModelLoader, PlanarArmUsesModifiedDhAndGivenInertia) {
  const RobotModel model = LoadRobotModel("config/robots/planar3.yaml");
  EXPECT_EQ(model.num_joints(), 3);
  EXPECT_EQ(model.dh_convention, DhConvention::kModified);
  EXPECT_FALSE(model.links[3].inertia_derived);
  EXPECT_DOUBLE_EQ(model.links[3].inertia_kg_m2(1, 1), 0.0012);
  EXPECT_DOUBLE_EQ(model.links[3].com_m.x(), 0.08);
  EXPECT_NEAR(model.tool.position_m.x(), 0.15, 1e-15);
  // rpy [90, 0, 0]: the frame-0 y axis points up in the world.
  EXPECT_TRUE((model.base.orientation * Eigen::Vector3d::UnitY())
                  .isApprox(Eigen::Vector3d::UnitZ(), 1e-12));
}

TEST(ModelLoader, StanfordArmHasAPrismaticJoint) {
  const RobotModel model = LoadRobotModel("config/robots/stanford.yaml");
  ASSERT_EQ(model.num_joints(), 6);
  const Joint& boom = model.joints[2];
  EXPECT_EQ(boom.type, JointType::kPrismatic);
  EXPECT_DOUBLE_EQ(boom.position_min, 0.15);  // metres, not converted as an angle
  EXPECT_DOUBLE_EQ(boom.velocity_max, 0.3);
  EXPECT_DOUBLE_EQ(boom.home, 0.3);
  EXPECT_NEAR(boom.dh.theta_rad, -90 * kDeg, 1e-15);
  EXPECT_DOUBLE_EQ(model.FindNamedPose("reach")->position[2], 0.7);
}

TEST(ModelLoader, HashFollowsTheBytes) {
  const std::string text = ReadTextFile("tests/data/good_two_link.yaml");
  const RobotModel a = ParseRobotModel(text, "a.yaml");
  const RobotModel b = ParseRobotModel(text + "# a comment\n", "a.yaml");
  EXPECT_EQ(a.source_hash.size(), 16U);
  EXPECT_EQ(a.source_hash, ParseRobotModel(text, "b.yaml").source_hash);
  EXPECT_NE(a.source_hash, b.source_hash);
  EXPECT_EQ(Fnv1aHex(""), "cbf29ce484222325");
}

TEST(ModelLoader, UnitsConvert) {
  std::string text = ReadTextFile("tests/data/good_two_link.yaml");
  text.replace(text.find("length: m,"), 10, "length: mm,");
  text.replace(text.find("a: 0.3,"), 7, "a: 300,");
  text.replace(text.find("angle: deg"), 10, "angle: rad");
  text.replace(text.find("limits: [-90, 90]"), 17, "limits: [-1.5, 1.5]");
  text.replace(text.find("limits: [-90, 90]"), 17, "limits: [-1.5, 1.5]");
  text.replace(text.find("max_velocity: 90"), 16, "max_velocity: 1.5");
  text.replace(text.find("max_velocity: 90"), 16, "max_velocity: 1.5");
  text.replace(text.find("default_velocity: 45"), 20, "default_velocity: 1");
  text.replace(text.find("default_velocity: 45"), 20, "default_velocity: 1");
  // In mm, the shapes given in metres' numbers become tiny; the model stays valid.
  const RobotModel model = ParseRobotModel(text, "mm.yaml");
  EXPECT_DOUBLE_EQ(model.joints[0].dh.a_m, 0.3);
  EXPECT_DOUBLE_EQ(model.joints[0].position_max, 1.5);
  EXPECT_DOUBLE_EQ(model.joints[1].servo.default_velocity, 1.0);
}

}  // namespace
}  // namespace sirupp::core
