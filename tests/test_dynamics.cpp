// Rigid-body dynamics (core/dynamics.hpp) on the three shipped arms (standard and modified DH, a
// prismatic joint): Newton-Euler and composite-rigid-body results against references computed
// here another way (link Jacobians, a hand-derived planar formula, Christoffel symbols from finite
// differences of M), and against the ODE sim's measured acceleration.

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include "core/dynamics.hpp"
#include "core/kinematics.hpp"
#include "core/model_loader.hpp"
#include "sim/arm_world.hpp"

namespace sirupp::core {
namespace {

constexpr double kDeg = 3.14159265358979323846 / 180;

const std::vector<std::string>& ModelFiles() {
  static const std::vector<std::string> files = {
      "config/robots/puma260.yaml", "config/robots/planar3.yaml", "config/robots/stanford.yaml"};
  return files;
}

// Random positions inside each joint's limits, `margin` (a fraction of the range) away from both.
JointVector RandomPosition(const RobotModel& model, std::mt19937& random, double margin = 0) {
  JointVector q(model.num_joints());
  for (int j = 0; j < model.num_joints(); ++j) {
    const Joint& joint = model.joints[static_cast<size_t>(j)];
    const double span = joint.position_max - joint.position_min;
    q[j] = std::uniform_real_distribution<double>(joint.position_min + margin * span,
                                                  joint.position_max - margin * span)(random);
  }
  return q;
}

JointVector RandomVector(int n, double scale, std::mt19937& random) {
  JointVector v(n);
  for (int j = 0; j < n; ++j) v[j] = std::uniform_real_distribution<double>(-scale, scale)(random);
  return v;
}

// Linear and angular Jacobians of link l's centre of mass (columns: joints), from the world frames.
struct LinkJacobian {
  Eigen::MatrixXd linear, angular;
};
LinkJacobian JacobianOfLink(const RobotModel& model, const std::vector<Eigen::Isometry3d>& frames,
                            int l) {
  const int n = model.num_joints();
  const Eigen::Vector3d com =
      frames[static_cast<size_t>(l)] * model.links[static_cast<size_t>(l)].com_m;
  LinkJacobian jacobian{Eigen::MatrixXd::Zero(3, n), Eigen::MatrixXd::Zero(3, n)};
  for (int j = 0; j < l; ++j) {  // joints 0..l-1 move link l
    const size_t axis =
        static_cast<size_t>(model.dh_convention == DhConvention::kStandard ? j : j + 1);
    const Eigen::Vector3d z = frames[axis].linear().col(2);
    if (model.joints[static_cast<size_t>(j)].type == JointType::kRevolute) {
      jacobian.linear.col(j) = z.cross(com - frames[axis].translation());
      jacobian.angular.col(j) = z;
    } else {
      jacobian.linear.col(j) = z;
    }
  }
  return jacobian;
}

// Reference gravity effort: minus the sum over links of J_linear^T * m * g (virtual work).
JointVector JacobianGravity(const RobotModel& model, const JointVector& q) {
  const std::vector<Eigen::Isometry3d> frames = ForwardKinematics(model, q).frames;
  JointVector tau = JointVector::Zero(model.num_joints());
  for (int l = 1; l <= model.num_joints(); ++l) {
    tau -= JacobianOfLink(model, frames, l).linear.transpose() *
           (model.links[static_cast<size_t>(l)].mass_kg * model.gravity_m_s2);
  }
  return tau;
}

// Reference mass matrix: sum over links of m Jv^T Jv + Jw^T I_world Jw, armature on the diagonal.
Eigen::MatrixXd JacobianMassMatrix(const RobotModel& model, const JointVector& q) {
  const std::vector<Eigen::Isometry3d> frames = ForwardKinematics(model, q).frames;
  const int n = model.num_joints();
  Eigen::MatrixXd mass = Eigen::MatrixXd::Zero(n, n);
  for (int l = 1; l <= n; ++l) {
    const Link& link = model.links[static_cast<size_t>(l)];
    const Eigen::Matrix3d r = frames[static_cast<size_t>(l)].linear();
    const LinkJacobian jacobian = JacobianOfLink(model, frames, l);
    mass +=
        link.mass_kg * jacobian.linear.transpose() * jacobian.linear +
        jacobian.angular.transpose() * (r * link.inertia_kg_m2 * r.transpose()) * jacobian.angular;
  }
  for (int j = 0; j < n; ++j) mass(j, j) += model.joints[static_cast<size_t>(j)].armature;
  return mass;
}

TEST(Dynamics, GravityEffortEqualsTheJacobianTransposeSum) {
  std::mt19937 random(7);
  for (const std::string& file : ModelFiles()) {
    const RobotModel model = LoadRobotModel(file);
    const Dynamics dynamics(model);
    double worst = 0;
    for (int k = 0; k < 200; ++k) {
      const JointVector q = RandomPosition(model, random);
      worst = std::max(
          worst, (dynamics.GravityEffort(q) - JacobianGravity(model, q)).cwiseAbs().maxCoeff());
    }
    std::printf("%s: gravity effort vs Jacobian sum, worst difference %.2e\n", model.name.c_str(),
                worst);
    EXPECT_LT(worst, 1e-10) << file;
  }
}

TEST(Dynamics, GravityEffortOfThePlanarArmMatchesTheHandDerivedFormula) {
  // planar3: three parallel joints in the vertical plane x0-y0 (y0 up), links 0.30 and 0.25 m,
  // centres of mass 0.15, 0.125 and 0.08 m out along each link. With h = heights of the centres,
  // G = dV/dq for V = g * sum m_l h_l:
  //   G3 = g m3 0.08 cos(q1+q2+q3)
  //   G2 = g (m2 0.125 + m3 0.25) cos(q1+q2) + G3
  //   G1 = g (m1 0.15 + (m2 + m3) 0.30) cos(q1) + G2
  const RobotModel model = LoadRobotModel("config/robots/planar3.yaml");
  ASSERT_NEAR((model.links[1].com_m - Eigen::Vector3d(0.15, 0, 0)).norm(), 0, 1e-12);
  ASSERT_NEAR((model.links[2].com_m - Eigen::Vector3d(0.125, 0, 0)).norm(), 0, 1e-12);
  ASSERT_NEAR((model.links[3].com_m - Eigen::Vector3d(0.08, 0, 0)).norm(), 0, 1e-12);
  const double g = 9.81;
  const double m1 = model.links[1].mass_kg, m2 = model.links[2].mass_kg,
               m3 = model.links[3].mass_kg;
  std::mt19937 random(3);
  for (int k = 0; k < 50; ++k) {
    const JointVector q = RandomPosition(model, random);
    const double g3 = g * m3 * 0.08 * std::cos(q[0] + q[1] + q[2]);
    const double g2 = g * (m2 * 0.125 + m3 * 0.25) * std::cos(q[0] + q[1]) + g3;
    const double g1 = g * (m1 * 0.15 + (m2 + m3) * 0.30) * std::cos(q[0]) + g2;
    const JointVector tau = GravityEffort(model, q);
    EXPECT_NEAR(tau[0], g1, 1e-12);
    EXPECT_NEAR(tau[1], g2, 1e-12);
    EXPECT_NEAR(tau[2], g3, 1e-12);
  }
  // Straight out horizontally, the shoulder carries the whole arm's moment.
  EXPECT_NEAR(GravityEffort(model, JointVector::Zero(3))[0],
              g * (m1 * 0.15 + m2 * 0.425 + m3 * 0.63), 1e-12);
}

TEST(Dynamics, MassMatrixIsSymmetricPositiveDefiniteAndTheColumnsOfInverseDynamics) {
  std::mt19937 random(11);
  for (const std::string& file : ModelFiles()) {
    const RobotModel model = LoadRobotModel(file);
    const Dynamics dynamics(model);
    const int n = model.num_joints();
    double worst_columns = 0, worst_reference = 0, smallest_eigenvalue = 1e300;
    for (int k = 0; k < 100; ++k) {
      const JointVector q = RandomPosition(model, random);
      const JointVector qd = RandomVector(n, 2.0, random);
      const Eigen::MatrixXd mass = dynamics.MassMatrix(q);
      EXPECT_EQ(mass, mass.transpose()) << file;
      smallest_eigenvalue =
          std::min(smallest_eigenvalue,
                   Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(mass).eigenvalues().minCoeff());
      // Inverse dynamics is affine in qdd: tau(qdd = e_i) - tau(qdd = 0) is column i of M, at any
      // velocity.
      const JointVector bias = dynamics.BiasEffort(q, qd);
      for (int i = 0; i < n; ++i) {
        const JointVector column = dynamics.InverseDynamics(q, qd, JointVector::Unit(n, i)) - bias;
        worst_columns = std::max(worst_columns, (column - mass.col(i)).cwiseAbs().maxCoeff());
      }
      worst_reference =
          std::max(worst_reference, (mass - JacobianMassMatrix(model, q)).cwiseAbs().maxCoeff());
    }
    std::printf(
        "%s: mass matrix vs inverse-dynamics columns %.2e, vs Jacobian sum %.2e, smallest "
        "eigenvalue %.3e\n",
        model.name.c_str(), worst_columns, worst_reference, smallest_eigenvalue);
    EXPECT_GT(smallest_eigenvalue, 0) << file;
    EXPECT_LT(worst_columns, 1e-10) << file;
    EXPECT_LT(worst_reference, 1e-10) << file;
  }
}

TEST(Dynamics, CoriolisEffortMatchesChristoffelSymbolsOfTheMassMatrix) {
  // (C(q, qd) qd)_i = sum_jk (dM_ij/dq_k - 1/2 dM_jk/dq_i) qd_j qd_k, with the derivatives of M
  // taken by central differences (step 1e-6: truncation and rounding both near 1e-9).
  std::mt19937 random(5);
  for (const std::string& file : ModelFiles()) {
    const RobotModel model = LoadRobotModel(file);
    const Dynamics dynamics(model);
    const int n = model.num_joints();
    double worst = 0, scale = 0;
    for (int k = 0; k < 20; ++k) {
      const JointVector q = RandomPosition(model, random, 0.01);
      const JointVector qd = RandomVector(n, 2.0, random);
      std::vector<Eigen::MatrixXd> dmass;  // dM/dq_k
      const double h = 1e-6;
      for (int c = 0; c < n; ++c) {
        const JointVector dq = h * JointVector::Unit(n, c);
        dmass.push_back((dynamics.MassMatrix(q + dq) - dynamics.MassMatrix(q - dq)) / (2 * h));
      }
      JointVector expected = JointVector::Zero(n);
      for (int i = 0; i < n; ++i) {
        for (int j = 0; j < n; ++j) {
          for (int c = 0; c < n; ++c) {
            expected[i] +=
                (dmass[static_cast<size_t>(c)](i, j) - 0.5 * dmass[static_cast<size_t>(i)](j, c)) *
                qd[j] * qd[c];
          }
        }
      }
      const JointVector coriolis = dynamics.BiasEffort(q, qd) - dynamics.GravityEffort(q);
      worst = std::max(worst, (coriolis - expected).cwiseAbs().maxCoeff());
      scale = std::max(scale, expected.cwiseAbs().maxCoeff());
    }
    std::printf("%s: Coriolis vs Christoffel, worst difference %.2e (largest effort %.2e)\n",
                model.name.c_str(), worst, scale);
    EXPECT_LT(worst, 1e-6 * std::max(1.0, scale)) << file;
  }
}

TEST(Dynamics, TheOdeSimAcceleratesAsInverseDynamicsSays) {
  // From rest at random poses, tau = InverseDynamics(q, 0, qdd) applied for one step must give
  // acceleration qdd: (velocity after the step) / step. No friction; armature off in both (the sim
  // puts it on the child link, here it is on the diagonal, docs/physics.md). Stated tolerance:
  // 0.2 % of the largest |qdd| per pose (ODE's first-order step with gyroscopic terms and
  // constraint stabilisation; measured at most 3.2e-4, on the PUMA 260).
  std::mt19937 random(13);
  for (const std::string& file : ModelFiles()) {
    RobotModel model = LoadRobotModel(file);
    for (Joint& joint : model.joints) joint.armature = 0;
    sim::WorldOptions options;
    options.friction = false;
    options.armature = false;
    sim::ArmWorld world(model, Environment{}, options);
    const Dynamics dynamics(model);
    const int n = model.num_joints();
    double worst = 0;
    for (int k = 0; k < 20; ++k) {
      const JointVector q = RandomPosition(model, random, 0.05);
      // Small accelerations keep every effort inside the joints' limits (the sim clamps).
      const JointVector qdd = RandomVector(n, 2.0, random);
      const JointVector tau = dynamics.InverseDynamics(q, JointVector::Zero(n), qdd);
      for (int j = 0; j < n; ++j) {
        ASSERT_LT(std::abs(tau[j]), model.joints[static_cast<size_t>(j)].effort_max) << file;
      }
      world.SetJointState(std::vector<double>(q.data(), q.data() + n));
      ArmCommand command;
      command.mode = CommandMode::kEffort;
      command.effort.assign(tau.data(), tau.data() + n);
      world.Step(command);
      const JointVector measured = ToJointVector(world.State().velocity) / world.step_s();
      const double error = (measured - qdd).cwiseAbs().maxCoeff() / qdd.cwiseAbs().maxCoeff();
      worst = std::max(worst, error);
      EXPECT_LT(error, 0.002) << file << " pose " << k;
    }
    std::printf("%s: ODE acceleration vs commanded qdd, worst relative difference %.2e\n",
                model.name.c_str(), worst);
  }
}

TEST(Dynamics, ArmatureAddsToTheDiagonalOnly) {
  const RobotModel model = LoadRobotModel("config/robots/puma260.yaml");
  RobotModel bare = model;
  for (Joint& joint : bare.joints) joint.armature = 0;
  const JointVector q = ToJointVector({10 * kDeg, -30 * kDeg, 40 * kDeg, 0, 20 * kDeg, 0});
  Eigen::MatrixXd expected = MassMatrix(bare, q);
  for (int j = 0; j < 6; ++j) expected(j, j) += model.joints[static_cast<size_t>(j)].armature;
  EXPECT_LT((MassMatrix(model, q) - expected).cwiseAbs().maxCoeff(), 1e-15);
  // Gravity does not see it; inverse dynamics adds armature * qdd.
  EXPECT_EQ(GravityEffort(model, q), GravityEffort(bare, q));
  const JointVector qdd = ToJointVector({1, 2, 3, 4, 5, 6});
  const JointVector zero = JointVector::Zero(6);
  for (int j = 0; j < 6; ++j) {
    EXPECT_NEAR(InverseDynamics(model, q, zero, qdd)[j] - InverseDynamics(bare, q, zero, qdd)[j],
                model.joints[static_cast<size_t>(j)].armature * qdd[j], 1e-12);
  }
}

}  // namespace
}  // namespace sirupp::core
