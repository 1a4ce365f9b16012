#include "core/mass_properties.hpp"

#include <Eigen/Eigenvalues>
#include <cmath>

#include "core/errors.hpp"

namespace sirupp::core {

const char* ShapeTypeName(ShapeType type) {
  switch (type) {
    case ShapeType::kBox:
      return "box";
    case ShapeType::kCylinder:
      return "cylinder";
    case ShapeType::kSphere:
      return "sphere";
    case ShapeType::kCapsule:
      return "capsule";
  }
  return "?";
}

double ShapeVolume(const Shape& shape) {
  const Eigen::Vector3d& s = shape.size_m;
  switch (shape.type) {
    case ShapeType::kBox:
      return s.x() * s.y() * s.z();
    case ShapeType::kCylinder:
      return M_PI * s.x() * s.x() * s.y();
    case ShapeType::kSphere:
      return 4.0 / 3.0 * M_PI * std::pow(s.x(), 3);
    case ShapeType::kCapsule:
      return M_PI * s.x() * s.x() * s.y() + 4.0 / 3.0 * M_PI * std::pow(s.x(), 3);
  }
  return 0;
}

namespace {

// Principal inertia of a solid shape about its centre, in the shape's own axes.
Eigen::Vector3d PrincipalInertia(const Shape& shape, double mass) {
  const Eigen::Vector3d& s = shape.size_m;
  switch (shape.type) {
    case ShapeType::kBox:
      return mass / 12.0 *
             Eigen::Vector3d(s.y() * s.y() + s.z() * s.z(), s.x() * s.x() + s.z() * s.z(),
                             s.x() * s.x() + s.y() * s.y());
    case ShapeType::kCylinder: {
      const double r2 = s.x() * s.x();
      const double across = mass * (3 * r2 + s.y() * s.y()) / 12.0;
      return {across, across, mass * r2 / 2.0};
    }
    case ShapeType::kSphere: {
      const double moment = 0.4 * mass * s.x() * s.x();
      return {moment, moment, moment};
    }
    case ShapeType::kCapsule: {
      // Cylinder of length h plus two hemispherical caps whose centres sit at the cylinder's ends.
      const double r = s.x();
      const double h = s.y();
      const double cylinder_volume = M_PI * r * r * h;
      const double caps_volume = 4.0 / 3.0 * M_PI * r * r * r;
      const double cylinder_mass = mass * cylinder_volume / (cylinder_volume + caps_volume);
      const double caps_mass = mass - cylinder_mass;
      const double axial = cylinder_mass * r * r / 2.0 + caps_mass * 0.4 * r * r;
      const double across = cylinder_mass * (r * r / 4.0 + h * h / 12.0) +
                            caps_mass * (0.4 * r * r + 0.375 * r * h + 0.25 * h * h);
      return {across, across, axial};
    }
  }
  return Eigen::Vector3d::Zero();
}

}  // namespace

MassProperties SolidShapeMassProperties(const Shape& shape, double mass_kg) {
  MassProperties result;
  result.mass_kg = mass_kg;
  result.com_m = shape.pose.position_m;
  const Eigen::Matrix3d rotation = shape.pose.orientation.toRotationMatrix();
  result.inertia_kg_m2 =
      rotation * PrincipalInertia(shape, mass_kg).asDiagonal() * rotation.transpose();
  return result;
}

MassProperties DeriveMassProperties(const std::vector<Shape>& shapes, double mass_kg) {
  double total_volume = 0;
  for (const Shape& shape : shapes) total_volume += ShapeVolume(shape);
  MassProperties result;
  result.mass_kg = mass_kg;
  if (total_volume <= 0) return result;

  std::vector<MassProperties> parts;
  for (const Shape& shape : shapes) {
    parts.push_back(SolidShapeMassProperties(shape, mass_kg * ShapeVolume(shape) / total_volume));
    result.com_m += parts.back().mass_kg * parts.back().com_m;
  }
  result.com_m /= mass_kg;
  for (const MassProperties& part : parts) {
    // Parallel-axis theorem: move each part's inertia from its own centre to the link's.
    const Eigen::Vector3d d = part.com_m - result.com_m;
    result.inertia_kg_m2 +=
        part.inertia_kg_m2 +
        part.mass_kg * (d.squaredNorm() * Eigen::Matrix3d::Identity() - d * d.transpose());
  }
  return result;
}

std::optional<std::string> InertiaProblem(const Eigen::Matrix3d& inertia) {
  if (!inertia.allFinite()) return std::string("has a non-finite element");
  const double scale = inertia.cwiseAbs().maxCoeff();
  if ((inertia - inertia.transpose()).cwiseAbs().maxCoeff() > 1e-12 * scale) {
    return std::string("is not symmetric");
  }
  const Eigen::Vector3d moments =
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(inertia).eigenvalues();
  if (moments.minCoeff() <= 0) {
    return "is not positive definite (principal moments " + FormatApprox(moments[0]) + ", " +
           FormatApprox(moments[1]) + ", " + FormatApprox(moments[2]) + " kg*m^2; all must be > 0)";
  }
  // Sorted ascending, so the only inequality that can fail is m0 + m1 >= m2.
  const double tolerance = 1e-9 * moments[2];
  if (moments[0] + moments[1] < moments[2] - tolerance) {
    return "breaks the triangle inequality: principal moments " + FormatApprox(moments[0]) + " + " +
           FormatApprox(moments[1]) + " < " + FormatApprox(moments[2]) +
           " kg*m^2; a real body has each principal moment <= the sum of the other two";
  }
  return std::nullopt;
}

}  // namespace sirupp::core
