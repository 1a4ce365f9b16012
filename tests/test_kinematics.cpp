#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "core/kinematics.hpp"
#include "core/model_loader.hpp"

namespace sirupp::core {
namespace {

constexpr double kInch = 0.0254;
constexpr double kDeg = M_PI / 180;

JointVector Deg(std::initializer_list<double> degrees) {
  JointVector q(static_cast<Eigen::Index>(degrees.size()));
  Eigen::Index i = 0;
  for (double d : degrees) q[i++] = d * kDeg;
  return q;
}

void ExpectPose(const Eigen::Isometry3d& pose, const Eigen::Vector3d& position_in,
                const Eigen::Matrix3d& rotation) {
  EXPECT_TRUE(pose.translation().isApprox(position_in * kInch, 1e-12))
      << "got " << (pose.translation() / kInch).transpose() << " in";
  EXPECT_TRUE(pose.linear().isApprox(rotation, 1e-12)) << pose.linear();
}

class PumaKinematics : public ::testing::Test {
 protected:
  RobotModel puma = LoadRobotModel("config/robots/puma260.yaml");
};

// Hand-worked from Table I (inches). At q = 0 frame 1 sits at height 13 with z1 along +y0; the
// upper arm runs 8 along x with the shoulder offset d2 = -3.2 along z1, the elbow offset d3 = -2.4,
// then the forearm d4 = 8 and the flange d6 = 2.2 straight up.
TEST_F(PumaKinematics, ZeroPose) {
  ExpectPose(ToolPose(puma, Deg({0, 0, 0, 0, 0, 0})), {8, -5.6, 23.2}, Eigen::Matrix3d::Identity());
}

TEST_F(PumaKinematics, WaistQuarterTurn) {
  // Everything turns 90 degrees about the vertical waist axis: (x, y) -> (-y, x).
  ExpectPose(ToolPose(puma, Deg({90, 0, 0, 0, 0, 0})), {5.6, 8, 23.2},
             Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix());
}

TEST_F(PumaKinematics, ShoulderQuarterTurn) {
  // Joint 2 turns about +y through (0, 0, 13): the tool at (8, -5.6, 10.2) relative to that point
  // goes to (10.2, -5.6, -8).
  ExpectPose(ToolPose(puma, Deg({0, 90, 0, 0, 0, 0})), {10.2, -5.6, 5},
             Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitY()).toRotationMatrix());
}

TEST_F(PumaKinematics, ElbowQuarterTurn) {
  // Joint 3 turns about +y through the elbow (8, -3.2, 13): the forearm and flange (10.2 up)
  // point along +x.
  ExpectPose(ToolPose(puma, Deg({0, 0, 90, 0, 0, 0})), {18.2, -5.6, 13},
             Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitY()).toRotationMatrix());
}

TEST_F(PumaKinematics, WristRollTurnsOnlyTheOrientation) {
  // Joint 4 turns about the vertical forearm; with joint 5 at 0 joint 6 is on the same axis.
  ExpectPose(ToolPose(puma, Deg({0, 0, 0, 30, 0, 15})), {8, -5.6, 23.2},
             Eigen::AngleAxisd(45 * kDeg, Eigen::Vector3d::UnitZ()).toRotationMatrix());
}

TEST_F(PumaKinematics, FramesEndAtTheTool) {
  const ForwardResult fk = ForwardKinematics(puma, Deg({10, 20, 30, 40, 50, 60}));
  ASSERT_EQ(fk.frames.size(), 7U);
  EXPECT_TRUE(fk.frames[0].isApprox(Eigen::Isometry3d::Identity()));
  EXPECT_TRUE(fk.tool.isApprox(fk.frames[6] * puma.tool.ToIsometry()));
  EXPECT_TRUE(fk.tool.isApprox(ToolPose(puma, Deg({10, 20, 30, 40, 50, 60}))));
}

// Finite-difference check of the geometric Jacobian: linear rows against the tool position's
// derivative, angular rows against the rotation's.
void ExpectJacobianMatchesFiniteDifferences(const RobotModel& model, const JointVector& q) {
  const Jacobian jac = GeometricJacobian(model, q);
  const double h = 1e-7;
  for (int i = 0; i < q.size(); ++i) {
    JointVector plus = q, minus = q;
    plus[i] += h;
    minus[i] -= h;
    const Eigen::Isometry3d a = ToolPose(model, plus), b = ToolPose(model, minus);
    const Eigen::Vector3d linear = (a.translation() - b.translation()) / (2 * h);
    const Eigen::AngleAxisd turn(a.linear() * b.linear().transpose());
    const Eigen::Vector3d angular = turn.angle() * turn.axis() / (2 * h);
    EXPECT_TRUE(jac.col(i).head<3>().isApprox(linear, 1e-6) ||
                (jac.col(i).head<3>() - linear).norm() < 1e-7)
        << "joint " << i << " linear " << jac.col(i).head<3>().transpose() << " vs "
        << linear.transpose();
    EXPECT_LT((jac.col(i).tail<3>() - angular).norm(), 1e-6) << "joint " << i;
  }
}

TEST(Kinematics, JacobianMatchesFiniteDifferencesOnEveryShippedArm) {
  std::mt19937 random(7);
  for (const char* file : {"config/robots/puma260.yaml", "config/robots/planar3.yaml",
                           "config/robots/stanford.yaml"}) {
    SCOPED_TRACE(file);
    const RobotModel model = LoadRobotModel(file);
    for (int trial = 0; trial < 20; ++trial) {
      JointVector q(model.num_joints());
      for (int i = 0; i < q.size(); ++i) {
        const Joint& joint = model.joints[static_cast<size_t>(i)];
        q[i] =
            std::uniform_real_distribution<double>(joint.position_min, joint.position_max)(random);
      }
      ExpectJacobianMatchesFiniteDifferences(model, q);
    }
  }
}

TEST(Kinematics, ModifiedDhPlanarArm) {
  const RobotModel arm = LoadRobotModel("config/robots/planar3.yaml");
  // Base at height 0.5, rolled 90 degrees: frame-0 x is world x, frame-0 y is world up.
  EXPECT_TRUE(
      ToolPose(arm, Deg({0, 0, 0})).translation().isApprox(Eigen::Vector3d(0.7, 0, 0.5), 1e-12));
  EXPECT_TRUE(
      ToolPose(arm, Deg({90, 0, 0})).translation().isApprox(Eigen::Vector3d(0, 0, 1.2), 1e-12));
  EXPECT_TRUE(ToolPose(arm, Deg({0, 90, -90}))
                  .translation()
                  .isApprox(Eigen::Vector3d(0.45, 0, 0.75), 1e-12));
}

TEST(Kinematics, PrismaticJointMovesAlongItsAxis) {
  const RobotModel arm = LoadRobotModel("config/robots/stanford.yaml");
  JointVector q = JointVector::Zero(6);
  q[2] = 0.3;
  const Eigen::Vector3d a = ToolPose(arm, q).translation();
  q[2] = 0.5;
  const Eigen::Vector3d b = ToolPose(arm, q).translation();
  const Jacobian jac = GeometricJacobian(arm, q);
  EXPECT_TRUE(((b - a) / 0.2).isApprox(jac.col(2).head<3>(), 1e-12));
  EXPECT_TRUE(jac.col(2).tail<3>().isZero());
}

TEST_F(PumaKinematics, ManipulabilityVanishesAtTheWristSingularity) {
  EXPECT_LT(Manipulability(GeometricJacobian(puma, Deg({0, 0, 0, 0, 0, 0}))), 1e-12);
  EXPECT_GT(Manipulability(GeometricJacobian(puma, Deg({0, 30, 60, 0, 45, 0}))), 1e-6);
}

TEST(Kinematics, RollPitchYawRoundTrip) {
  for (const Eigen::Vector3d& rpy :
       {Eigen::Vector3d(0.1, 0.2, 0.3), Eigen::Vector3d(-2.5, 1.2, 3.0),
        Eigen::Vector3d(0.3, -0.7, -1.1)}) {
    const Eigen::Matrix3d r = QuaternionFromRpy(rpy.x(), rpy.y(), rpy.z()).toRotationMatrix();
    EXPECT_TRUE(RollPitchYaw(r).isApprox(rpy, 1e-12)) << RollPitchYaw(r).transpose();
    const Eigen::Vector3d back = RollPitchYaw(r);
    EXPECT_TRUE(
        QuaternionFromRpy(back.x(), back.y(), back.z()).toRotationMatrix().isApprox(r, 1e-12));
  }
  // Gimbal lock: the rotation is still reproduced.
  const Eigen::Matrix3d lock = QuaternionFromRpy(0.4, M_PI / 2, 0).toRotationMatrix();
  const Eigen::Vector3d back = RollPitchYaw(lock);
  EXPECT_TRUE(
      QuaternionFromRpy(back.x(), back.y(), back.z()).toRotationMatrix().isApprox(lock, 1e-9));
}

}  // namespace
}  // namespace sirupp::core
