#pragma once
// Mass, centre of mass and inertia of solid shapes, and the physical validity test for inertia
// tensors. A link that gives only its mass gets its inertia from its shapes: the mass is spread
// over the shapes in proportion to their volumes (uniform density; overlaps count twice).

#include <optional>
#include <string>
#include <vector>

#include "core/geometry.hpp"

namespace sirupp::core {

struct MassProperties {
  double mass_kg = 0;
  Eigen::Vector3d com_m = Eigen::Vector3d::Zero();          // in the parent frame
  Eigen::Matrix3d inertia_kg_m2 = Eigen::Matrix3d::Zero();  // about com_m, parent-frame axes
};

// Volume of a shape, m^3.
double ShapeVolume(const Shape& shape);

// Solid shape of the given mass: centre of mass at the shape's centre, inertia in the parent frame.
MassProperties SolidShapeMassProperties(const Shape& shape, double mass_kg);

// Mass properties of a link of `mass_kg` made of `shapes` (uniform density). Requires a positive
// total volume.
MassProperties DeriveMassProperties(const std::vector<Shape>& shapes, double mass_kg);

// Why an inertia tensor cannot belong to a real body, or nullopt when it can: it must be symmetric,
// positive definite, and its principal moments must satisfy the triangle inequality
// (each <= the sum of the other two).
std::optional<std::string> InertiaProblem(const Eigen::Matrix3d& inertia_kg_m2);

}  // namespace sirupp::core
