#pragma once
// Poses and solid shapes, SI units. Shared by robot links and environment objects.

#include <Eigen/Geometry>
#include <array>

namespace sirupp::core {

// A rigid transform: position in metres and a unit quaternion, both in the parent frame.
struct Pose {
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();

  Eigen::Isometry3d ToIsometry() const {
    Eigen::Isometry3d transform = Eigen::Isometry3d::Identity();
    transform.linear() = orientation.toRotationMatrix();
    transform.translation() = position_m;
    return transform;
  }
};

// Roll-pitch-yaw (rad) as used in config files: R = Rz(yaw) * Ry(pitch) * Rx(roll), i.e. rotate
// about the fixed x axis by roll, then fixed y by pitch, then fixed z by yaw.
inline Eigen::Quaterniond QuaternionFromRpy(double roll_rad, double pitch_rad, double yaw_rad) {
  return Eigen::Quaterniond(Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()) *
                            Eigen::AngleAxisd(pitch_rad, Eigen::Vector3d::UnitY()) *
                            Eigen::AngleAxisd(roll_rad, Eigen::Vector3d::UnitX()));
}

enum class ShapeType { kBox, kCylinder, kSphere, kCapsule };

const char* ShapeTypeName(ShapeType type);

// A solid primitive placed by `pose` (its centre) in its parent frame. Cylinder and capsule axes
// are the shape's local z. size_m: box = edge lengths x, y, z; cylinder = radius, length, 0;
// capsule = radius, straight length between the cap centres, 0; sphere = radius, 0, 0.
struct Shape {
  ShapeType type = ShapeType::kBox;
  Pose pose;
  Eigen::Vector3d size_m = Eigen::Vector3d::Zero();
  std::array<float, 4> rgba{{0.7F, 0.7F, 0.7F, 1.0F}};
};

}  // namespace sirupp::core
