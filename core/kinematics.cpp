#include "core/kinematics.hpp"

#include <Eigen/SVD>
#include <cmath>

namespace sirupp::core {

Eigen::Isometry3d DhTransform(DhConvention convention, const Joint& joint, double q) {
  const bool revolute = joint.type == JointType::kRevolute;
  const double theta = joint.dh.theta_rad + (revolute ? q : 0.0);
  const double d = joint.dh.d_m + (revolute ? 0.0 : q);
  const double ct = std::cos(theta), st = std::sin(theta);
  const double ca = std::cos(joint.dh.alpha_rad), sa = std::sin(joint.dh.alpha_rad);
  const double a = joint.dh.a_m;
  Eigen::Matrix4d m;
  if (convention == DhConvention::kStandard) {
    // Rz(theta) Tz(d) Tx(a) Rx(alpha)
    m << ct, -st * ca, st * sa, a * ct,  //
        st, ct * ca, -ct * sa, a * st,   //
        0, sa, ca, d,                    //
        0, 0, 0, 1;
  } else {
    // Rx(alpha) Tx(a) Rz(theta) Tz(d)
    m << ct, -st, 0, a,                  //
        st * ca, ct * ca, -sa, -sa * d,  //
        st * sa, ct * sa, ca, ca * d,    //
        0, 0, 0, 1;
  }
  Eigen::Isometry3d transform;
  transform.matrix() = m;
  return transform;
}

ForwardResult ForwardKinematics(const RobotModel& model, const JointVector& q) {
  ForwardResult result;
  result.frames.reserve(model.joints.size() + 1);
  result.frames.push_back(model.base.ToIsometry());
  for (size_t i = 0; i < model.joints.size(); ++i) {
    result.frames.push_back(result.frames.back() * DhTransform(model.dh_convention, model.joints[i],
                                                               q[static_cast<Eigen::Index>(i)]));
  }
  result.tool = result.frames.back() * model.tool.ToIsometry();
  return result;
}

Eigen::Isometry3d ToolPose(const RobotModel& model, const JointVector& q) {
  Eigen::Isometry3d pose = model.base.ToIsometry();
  for (size_t i = 0; i < model.joints.size(); ++i) {
    pose =
        pose * DhTransform(model.dh_convention, model.joints[i], q[static_cast<Eigen::Index>(i)]);
  }
  return pose * model.tool.ToIsometry();
}

Jacobian GeometricJacobian(const RobotModel& model, const JointVector& q) {
  const ForwardResult fk = ForwardKinematics(model, q);
  const Eigen::Vector3d tip = fk.tool.translation();
  Jacobian jacobian(6, model.num_joints());
  for (int i = 0; i < model.num_joints(); ++i) {
    // Standard DH: joint i+1 moves about z of frame i; modified DH: about z of frame i+1.
    const Eigen::Isometry3d& axis_frame =
        fk.frames[static_cast<size_t>(model.dh_convention == DhConvention::kStandard ? i : i + 1)];
    const Eigen::Vector3d z = axis_frame.linear().col(2);
    if (model.joints[static_cast<size_t>(i)].type == JointType::kRevolute) {
      jacobian.col(i) << z.cross(tip - axis_frame.translation()), z;
    } else {
      jacobian.col(i) << z, Eigen::Vector3d::Zero();
    }
  }
  return jacobian;
}

double Manipulability(const Jacobian& jacobian) {
  const Eigen::MatrixXd gram = jacobian.cols() >= 6
                                   ? Eigen::MatrixXd(jacobian * jacobian.transpose())
                                   : Eigen::MatrixXd(jacobian.transpose() * jacobian);
  return std::sqrt(std::max(0.0, gram.determinant()));
}

PoseError ComparePoses(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  PoseError error;
  error.position_m = (a.translation() - b.translation()).norm();
  error.rotation_rad = Eigen::AngleAxisd(a.linear().transpose() * b.linear()).angle();
  return error;
}

Eigen::Vector3d RollPitchYaw(const Eigen::Matrix3d& r) {
  const double pitch = std::atan2(-r(2, 0), std::hypot(r(0, 0), r(1, 0)));
  double roll, yaw;
  if (std::hypot(r(0, 0), r(1, 0)) < 1e-12) {
    // Gimbal lock: only roll - yaw (or roll + yaw) is defined; report yaw = 0.
    yaw = 0;
    roll = pitch > 0 ? std::atan2(r(0, 1), r(1, 1)) : -std::atan2(r(0, 1), r(1, 1));
  } else {
    roll = std::atan2(r(2, 1), r(2, 2));
    yaw = std::atan2(r(1, 0), r(0, 0));
  }
  return {roll, pitch, yaw};
}

JointVector ToJointVector(const std::vector<double>& values) {
  return Eigen::Map<const JointVector>(values.data(), static_cast<Eigen::Index>(values.size()));
}

}  // namespace sirupp::core
