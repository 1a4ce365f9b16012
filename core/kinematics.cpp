#include "core/kinematics.hpp"

#include <Eigen/SVD>
#include <cmath>

namespace sirupp::core {

Eigen::Isometry3d DhTransform(DhConvention convention, const Joint& joint, double q) {
  Eigen::Matrix3d r = Eigen::Matrix3d::Identity();
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  ApplyDh(convention, DhLink::From(joint), q, r, p);
  Eigen::Isometry3d transform = Eigen::Isometry3d::Identity();
  transform.linear() = r;
  transform.translation() = p;
  return transform;
}

KinematicChain::KinematicChain(const RobotModel& model)
    : convention_(model.dh_convention),
      base_(model.base.ToIsometry()),
      tool_(model.tool.ToIsometry()) {
  for (const Joint& joint : model.joints) links_.push_back(DhLink::From(joint));
}

DhLink DhLink::From(const Joint& joint) {
  return DhLink{joint.dh.a_m,
                joint.dh.d_m,
                joint.dh.theta_rad,
                std::cos(joint.dh.alpha_rad),
                std::sin(joint.dh.alpha_rad),
                joint.type == JointType::kRevolute};
}

void ApplyDh(DhConvention convention, const DhLink& link, double q, Eigen::Matrix3d& r,
             Eigen::Vector3d& p) {
  const double theta = link.theta + (link.revolute ? q : 0.0);
  const double d = link.d + (link.revolute ? 0.0 : q);
  const double ct = std::cos(theta), st = std::sin(theta);
  const double ca = link.cos_alpha, sa = link.sin_alpha;
  const Eigen::Vector3d x = r.col(0), y = r.col(1), z = r.col(2);
  if (convention == DhConvention::kStandard) {
    // Rz(theta) Tz(d) Tx(a) Rx(alpha)
    const Eigen::Vector3d new_x = ct * x + st * y;
    const Eigen::Vector3d across = -st * x + ct * y;
    p += link.a * new_x + d * z;
    r.col(0) = new_x;
    r.col(1) = ca * across + sa * z;
    r.col(2) = -sa * across + ca * z;
  } else {
    // Rx(alpha) Tx(a) Rz(theta) Tz(d)
    const Eigen::Vector3d u = ca * y + sa * z;
    const Eigen::Vector3d v = -sa * y + ca * z;
    p += link.a * x + d * v;
    r.col(0) = ct * x + st * u;
    r.col(1) = -st * x + ct * u;
    r.col(2) = v;
  }
}

Eigen::Isometry3d KinematicChain::ToolPose(const JointVector& q) const {
  Eigen::Matrix3d r = base_.linear();
  Eigen::Vector3d p = base_.translation();
  for (size_t i = 0; i < links_.size(); ++i)
    ApplyDh(convention_, links_[i], q[static_cast<Eigen::Index>(i)], r, p);
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = r * tool_.linear();
  pose.translation() = p + r * tool_.translation();
  return pose;
}

ForwardResult KinematicChain::Forward(const JointVector& q) const {
  ForwardResult result;
  result.frames.reserve(links_.size() + 1);
  result.frames.push_back(base_);
  Eigen::Matrix3d r = base_.linear();
  Eigen::Vector3d p = base_.translation();
  for (size_t i = 0; i < links_.size(); ++i) {
    ApplyDh(convention_, links_[i], q[static_cast<Eigen::Index>(i)], r, p);
    Eigen::Isometry3d frame = Eigen::Isometry3d::Identity();
    frame.linear() = r;
    frame.translation() = p;
    result.frames.push_back(frame);
  }
  result.tool = result.frames.back() * tool_;
  return result;
}

Jacobian KinematicChain::GeometricJacobian(const JointVector& q) const {
  const int n = num_joints();
  // Joint i turns about z of frame i (standard DH, frames counted from 0) or of frame i+1
  // (modified).
  Eigen::Matrix<double, 3, Eigen::Dynamic> axes(3, n), origins(3, n);
  Eigen::Matrix3d r = base_.linear();
  Eigen::Vector3d p = base_.translation();
  for (int i = 0; i < n; ++i) {
    if (convention_ == DhConvention::kStandard) {
      axes.col(i) = r.col(2);
      origins.col(i) = p;
    }
    ApplyDh(convention_, links_[static_cast<size_t>(i)], q[i], r, p);
    if (convention_ == DhConvention::kModified) {
      axes.col(i) = r.col(2);
      origins.col(i) = p;
    }
  }
  const Eigen::Vector3d tip = p + r * tool_.translation();
  Jacobian jacobian(6, n);
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d z = axes.col(i);
    if (links_[static_cast<size_t>(i)].revolute) {
      jacobian.col(i) << z.cross(tip - origins.col(i)), z;
    } else {
      jacobian.col(i) << z, Eigen::Vector3d::Zero();
    }
  }
  return jacobian;
}

ForwardResult ForwardKinematics(const RobotModel& model, const JointVector& q) {
  return KinematicChain(model).Forward(q);
}

Eigen::Isometry3d ToolPose(const RobotModel& model, const JointVector& q) {
  return KinematicChain(model).ToolPose(q);
}

Jacobian GeometricJacobian(const RobotModel& model, const JointVector& q) {
  return KinematicChain(model).GeometricJacobian(q);
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
