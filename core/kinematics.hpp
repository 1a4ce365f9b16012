#pragma once
// Forward kinematics, the geometric Jacobian and manipulability of any serial DH arm (standard or
// modified convention, revolute or prismatic joints). Pure functions of (model, joint positions).
//
// Frames: frames[0] is DH frame 0 in the world (the model's base pose); frames[i] is DH frame i;
// the tool frame is frames[n] * model.tool. Positions in metres, angles in radians.

#include <Eigen/Geometry>
#include <vector>

#include "core/robot_model.hpp"

namespace sirupp::core {

using JointVector = Eigen::VectorXd;
using Jacobian = Eigen::Matrix<double, 6, Eigen::Dynamic>;

// One joint's constant DH terms, with cos and sin of the twist computed once.
struct DhLink {
  double a, d, theta, cos_alpha, sin_alpha;
  bool revolute;

  static DhLink From(const Joint& joint);
};

// Multiplies the pose (r, p) of frame i-1 by the DH transform of `link` at position q, giving the
// pose of frame i; column by column, without forming a 4x4 matrix.
void ApplyDh(DhConvention convention, const DhLink& link, double q, Eigen::Matrix3d& r,
             Eigen::Vector3d& p);

// The transform from DH frame i-1 to frame i for joint `joint` at position q.
Eigen::Isometry3d DhTransform(DhConvention convention, const Joint& joint, double q);

struct ForwardResult {
  std::vector<Eigen::Isometry3d> frames;  // world poses of DH frames 0..n
  Eigen::Isometry3d tool;                 // world pose of the tool point
};

// The kinematic part of a model prepared for repeated evaluation: each joint's constant DH terms
// (including cos and sin of the twist) computed once. Build one per model and reuse it in loops;
// the free functions below build a temporary one per call.
class KinematicChain {
 public:
  explicit KinematicChain(const RobotModel& model);

  int num_joints() const { return static_cast<int>(links_.size()); }
  Eigen::Isometry3d ToolPose(const JointVector& q) const;
  ForwardResult Forward(const JointVector& q) const;
  Jacobian GeometricJacobian(const JointVector& q) const;

 private:
  std::vector<DhLink> links_;
  DhConvention convention_;
  Eigen::Isometry3d base_;
  Eigen::Isometry3d tool_;
};

// Every link frame and the tool. `q` must have model.num_joints() entries.
ForwardResult ForwardKinematics(const RobotModel& model, const JointVector& q);
// Only the tool's world pose.
Eigen::Isometry3d ToolPose(const RobotModel& model, const JointVector& q);

// Geometric Jacobian of the tool point in the world frame: rows 0-2 linear velocity (m/s), rows 3-5
// angular velocity (rad/s); column i is joint i's contribution per unit joint speed.
Jacobian GeometricJacobian(const RobotModel& model, const JointVector& q);

// Yoshikawa's measure sqrt(det(J J^T)) (for fewer than 6 joints, sqrt(det(J^T J))). 0 at a
// singularity; it has units, so compare it only between poses of one arm.
double Manipulability(const Jacobian& jacobian);

// Pose difference used by IK and by tests: position error (m) and rotation angle (rad) between two
// poses.
struct PoseError {
  double position_m = 0;
  double rotation_rad = 0;
};
PoseError ComparePoses(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b);

// Roll, pitch, yaw (rad) of a rotation, R = Rz(yaw) Ry(pitch) Rx(roll), pitch in [-pi/2, pi/2].
Eigen::Vector3d RollPitchYaw(const Eigen::Matrix3d& rotation);

// Joint positions from a std::vector (convenience for messages and named poses).
JointVector ToJointVector(const std::vector<double>& values);

}  // namespace sirupp::core
