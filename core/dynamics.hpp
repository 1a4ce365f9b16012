#pragma once
// Rigid-body dynamics of any serial DH arm (standard or modified convention, revolute or prismatic
// joints): the joint efforts of
//
//   tau = M(q) qdd + C(q, qd) qd + G(q)
//
// from the model's link masses, centres of mass and inertia tensors (about the centre of mass, in
// link-frame axes: the same numbers sirupp-sim gives ODE), its gravity vector and base pose. Pure
// functions of (model, q, qd, qdd); SI units (rad, rad/s, rad/s^2, N*m; m, m/s, m/s^2, N).
//
// Method: recursive Newton-Euler for InverseDynamics, BiasEffort and GravityEffort, and the
// composite-rigid-body algorithm for MassMatrix, both with spatial vectors expressed in world
// coordinates, so one code path serves both DH conventions. The two algorithms share only the
// forward kinematics, which lets the tests check one against the other.
//
// Armature (joint.armature, the motor's reflected inertia G^2 * J_motor) is the rotor's own spin:
// it adds armature_i * qdd_i to joint i's effort and armature_i to M(i, i), and nothing else (as
// MuJoCo models it). sirupp-sim instead adds it to the child link's inertia about the joint axis
// (docs/physics.md); the two agree for joints whose parents do not turn about the same axis (PUMA
// joints 1-3) and differ slightly on wrists and planar arms. ODE leaves prismatic armature out;
// here it is a plain mass on the diagonal.

#include <Eigen/Core>

#include "core/kinematics.hpp"
#include "core/robot_model.hpp"

namespace sirupp::core {

// A model prepared for repeated evaluation (per-tick loops): the kinematic chain and each link's
// mass properties, copied once. Every q, qd, qdd must have num_joints() entries.
class Dynamics {
 public:
  explicit Dynamics(const RobotModel& model);

  int num_joints() const { return chain_.num_joints(); }

  // The efforts that give the arm acceleration qdd at position q and velocity qd, gravity and
  // armature included.
  JointVector InverseDynamics(const JointVector& q, const JointVector& qd,
                              const JointVector& qdd) const;
  // The efforts that hold the arm still at q against gravity: G(q).
  JointVector GravityEffort(const JointVector& q) const;
  // Coriolis, centrifugal and gravity efforts: C(q, qd) qd + G(q) = InverseDynamics(q, qd, 0).
  JointVector BiasEffort(const JointVector& q, const JointVector& qd) const;
  // The joint-space mass matrix M(q), armature on the diagonal; symmetric positive definite.
  Eigen::MatrixXd MassMatrix(const JointVector& q) const;

 private:
  struct Body {
    double mass_kg;
    Eigen::Vector3d com_m;          // in the link's DH frame
    Eigen::Matrix3d inertia_kg_m2;  // about the centre of mass, link-frame axes
  };

  KinematicChain chain_;
  DhConvention convention_;
  Eigen::Vector3d gravity_;
  std::vector<Body> bodies_;      // bodies_[i] is link i + 1, moved by joints 0..i
  std::vector<bool> revolute_;    // per joint
  std::vector<double> armature_;  // per joint
};

// One-off versions of the Dynamics methods (each builds a temporary Dynamics).
JointVector InverseDynamics(const RobotModel& model, const JointVector& q, const JointVector& qd,
                            const JointVector& qdd);
JointVector GravityEffort(const RobotModel& model, const JointVector& q);
JointVector BiasEffort(const RobotModel& model, const JointVector& q, const JointVector& qd);
Eigen::MatrixXd MassMatrix(const RobotModel& model, const JointVector& q);

}  // namespace sirupp::core
