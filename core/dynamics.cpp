#include "core/dynamics.hpp"

#include <vector>

namespace sirupp::core {
namespace {

// Spatial vectors in world coordinates (Featherstone's notation, angular part first). A motion
// (w, v) is a body's angular velocity w and the velocity v of the body-fixed point that is at the
// world origin at this instant; a force (n, f) is a moment n about the world origin and a force f.
struct Motion {
  Eigen::Vector3d angular = Eigen::Vector3d::Zero();
  Eigen::Vector3d linear = Eigen::Vector3d::Zero();
};
using Force = Motion;  // same storage: moment about the origin, then force

double Dot(const Motion& m, const Force& f) {
  return m.angular.dot(f.angular) + m.linear.dot(f.linear);
}

// The motion of joint j per unit joint speed (its world-frame joint axis): a revolute joint about
// unit axis z through point o turns the body at z and moves the point at the origin at o x z; a
// prismatic joint slides the whole body along z.
Motion JointAxis(const Eigen::Isometry3d& axis_frame, bool revolute) {
  const Eigen::Vector3d z = axis_frame.linear().col(2);
  Motion s;
  if (revolute) {
    s.angular = z;
    s.linear = axis_frame.translation().cross(z);
  } else {
    s.linear = z;
  }
  return s;
}

// A rigid body's spatial inertia at its present world pose, applied to motions.
struct WorldInertia {
  double mass;
  Eigen::Vector3d com;      // world position of the centre of mass
  Eigen::Matrix3d central;  // inertia about the centre of mass, world axes

  // The spatial momentum (or, applied to an acceleration, the rate of change of momentum) of the
  // body moving at m: linear p = mass * (velocity of the centre of mass), moment L about the
  // origin = central * w + com x p.
  Force Times(const Motion& m) const {
    Force h;
    h.linear = mass * (m.linear + m.angular.cross(com));
    h.angular = central * m.angular + com.cross(h.linear);
    return h;
  }

  // The same as a 6x6 matrix acting on (w, v), for summing composite inertias.
  Eigen::Matrix<double, 6, 6> Matrix() const {
    Eigen::Matrix3d cx;
    cx << 0, -com.z(), com.y(), com.z(), 0, -com.x(), -com.y(), com.x(), 0;
    Eigen::Matrix<double, 6, 6> out;
    out.topLeftCorner<3, 3>() = central - mass * cx * cx;
    out.topRightCorner<3, 3>() = mass * cx;
    out.bottomLeftCorner<3, 3>() = -mass * cx;
    out.bottomRightCorner<3, 3>() = mass * Eigen::Matrix3d::Identity();
    return out;
  }
};

}  // namespace

Dynamics::Dynamics(const RobotModel& model)
    : chain_(model), convention_(model.dh_convention), gravity_(model.gravity_m_s2) {
  for (size_t j = 0; j < model.joints.size(); ++j) {
    const Link& link = model.links[j + 1];
    bodies_.push_back({link.mass_kg, link.com_m, link.inertia_kg_m2});
    revolute_.push_back(model.joints[j].type == JointType::kRevolute);
    armature_.push_back(model.joints[j].armature);
  }
}

// Recursive Newton-Euler.
JointVector Dynamics::InverseDynamics(const JointVector& q, const JointVector& qd,
                                      const JointVector& qdd) const {
  const int n = num_joints();
  const std::vector<Eigen::Isometry3d> frames = chain_.Forward(q).frames;
  // Standard DH: joint j turns about z of frame j; modified DH: about z of frame j + 1.
  const int axis_offset = convention_ == DhConvention::kStandard ? 0 : 1;

  // Outward pass: each body's velocity and acceleration, and the force that moves it. The base
  // accelerates upwards at -g, which puts gravity on every body without a separate term.
  std::vector<Force> body_force(static_cast<size_t>(n));
  std::vector<Motion> axes(static_cast<size_t>(n));
  Motion velocity;
  Motion acceleration;
  acceleration.linear = -gravity_;
  for (int j = 0; j < n; ++j) {
    const auto i = static_cast<size_t>(j);
    const Motion s = JointAxis(frames[i + static_cast<size_t>(axis_offset)], revolute_[i]);
    axes[i] = s;
    const Eigen::Vector3d joint_w = s.angular * qd[j];
    const Eigen::Vector3d joint_v = s.linear * qd[j];
    velocity.angular += joint_w;
    velocity.linear += joint_v;
    // d/dt of the world-frame axis times the joint speed: velocity x (s * qd).
    acceleration.angular += s.angular * qdd[j] + velocity.angular.cross(joint_w);
    acceleration.linear +=
        s.linear * qdd[j] + velocity.angular.cross(joint_v) + velocity.linear.cross(joint_w);

    const Body& body = bodies_[i];
    const Eigen::Isometry3d& frame = frames[i + 1];
    const WorldInertia inertia{body.mass_kg, frame * body.com_m,
                               frame.linear() * body.inertia_kg_m2 * frame.linear().transpose()};
    const Force momentum = inertia.Times(velocity);
    const Force rate = inertia.Times(acceleration);
    // f = I a + v x* (I v)
    body_force[i].angular = rate.angular + velocity.angular.cross(momentum.angular) +
                            velocity.linear.cross(momentum.linear);
    body_force[i].linear = rate.linear + velocity.angular.cross(momentum.linear);
  }

  // Inward pass: each joint carries the forces of every body beyond it.
  JointVector tau(n);
  Force carried;
  for (int j = n - 1; j >= 0; --j) {
    const auto i = static_cast<size_t>(j);
    carried.angular += body_force[i].angular;
    carried.linear += body_force[i].linear;
    tau[j] = Dot(axes[i], carried) + armature_[i] * qdd[j];
  }
  return tau;
}

JointVector Dynamics::GravityEffort(const JointVector& q) const {
  const JointVector zero = JointVector::Zero(num_joints());
  return InverseDynamics(q, zero, zero);
}

JointVector Dynamics::BiasEffort(const JointVector& q, const JointVector& qd) const {
  return InverseDynamics(q, qd, JointVector::Zero(num_joints()));
}

Eigen::MatrixXd Dynamics::MassMatrix(const JointVector& q) const {
  const int n = num_joints();
  const std::vector<Eigen::Isometry3d> frames = chain_.Forward(q).frames;
  const int axis_offset = convention_ == DhConvention::kStandard ? 0 : 1;
  std::vector<Eigen::Matrix<double, 6, 1>> axes(static_cast<size_t>(n));
  for (int j = 0; j < n; ++j) {
    const auto i = static_cast<size_t>(j);
    const Motion s = JointAxis(frames[i + static_cast<size_t>(axis_offset)], revolute_[i]);
    axes[i] << s.angular, s.linear;
  }
  // Composite rigid bodies, from the tip inwards: joint j moves the composite of bodies j..n-1,
  // so M(i, j) = s_i . (composite_j * s_j) for i <= j.
  Eigen::MatrixXd mass = Eigen::MatrixXd::Zero(n, n);
  Eigen::Matrix<double, 6, 6> composite = Eigen::Matrix<double, 6, 6>::Zero();
  for (int j = n - 1; j >= 0; --j) {
    const auto i = static_cast<size_t>(j);
    const Body& body = bodies_[i];
    const Eigen::Isometry3d& frame = frames[i + 1];
    composite += WorldInertia{body.mass_kg, frame * body.com_m,
                              frame.linear() * body.inertia_kg_m2 * frame.linear().transpose()}
                     .Matrix();
    const Eigen::Matrix<double, 6, 1> force = composite * axes[i];
    mass(j, j) = axes[i].dot(force) + armature_[i];
    for (int k = 0; k < j; ++k) {
      mass(k, j) = mass(j, k) = axes[static_cast<size_t>(k)].dot(force);
    }
  }
  return mass;
}

JointVector InverseDynamics(const RobotModel& model, const JointVector& q, const JointVector& qd,
                            const JointVector& qdd) {
  return Dynamics(model).InverseDynamics(q, qd, qdd);
}

JointVector GravityEffort(const RobotModel& model, const JointVector& q) {
  return Dynamics(model).GravityEffort(q);
}

JointVector BiasEffort(const RobotModel& model, const JointVector& q, const JointVector& qd) {
  return Dynamics(model).BiasEffort(q, qd);
}

Eigen::MatrixXd MassMatrix(const RobotModel& model, const JointVector& q) {
  return Dynamics(model).MassMatrix(q);
}

}  // namespace sirupp::core
