#include <gtest/gtest.h>

#include <cmath>

#include "core/mass_properties.hpp"

namespace sirupp::core {
namespace {

Shape Box(double x, double y, double z, Eigen::Vector3d center = Eigen::Vector3d::Zero()) {
  Shape shape;
  shape.type = ShapeType::kBox;
  shape.size_m = {x, y, z};
  shape.pose.position_m = center;
  return shape;
}

TEST(MassProperties, BoxMatchesTextbookFormula) {
  const MassProperties p = SolidShapeMassProperties(Box(0.2, 0.4, 0.6), 3.0);
  EXPECT_NEAR(p.inertia_kg_m2(0, 0), 3.0 / 12 * (0.16 + 0.36), 1e-15);
  EXPECT_NEAR(p.inertia_kg_m2(1, 1), 3.0 / 12 * (0.04 + 0.36), 1e-15);
  EXPECT_NEAR(p.inertia_kg_m2(2, 2), 3.0 / 12 * (0.04 + 0.16), 1e-15);
  EXPECT_NEAR(ShapeVolume(Box(0.2, 0.4, 0.6)), 0.048, 1e-15);
}

TEST(MassProperties, CylinderAndSphere) {
  Shape cylinder;
  cylinder.type = ShapeType::kCylinder;
  cylinder.size_m = {0.1, 0.5, 0};
  const MassProperties c = SolidShapeMassProperties(cylinder, 2.0);
  EXPECT_NEAR(c.inertia_kg_m2(2, 2), 0.5 * 2.0 * 0.01, 1e-15);
  EXPECT_NEAR(c.inertia_kg_m2(0, 0), 2.0 * (3 * 0.01 + 0.25) / 12, 1e-15);
  Shape sphere;
  sphere.type = ShapeType::kSphere;
  sphere.size_m = {0.2, 0, 0};
  EXPECT_NEAR(SolidShapeMassProperties(sphere, 5).inertia_kg_m2(1, 1), 0.4 * 5 * 0.04, 1e-15);
}

TEST(MassProperties, CapsuleOfZeroLengthIsASphere) {
  Shape capsule;
  capsule.type = ShapeType::kCapsule;
  capsule.size_m = {0.1, 0, 0};
  Shape sphere = capsule;
  sphere.type = ShapeType::kSphere;
  EXPECT_TRUE(
      SolidShapeMassProperties(capsule, 1)
          .inertia_kg_m2.isApprox(SolidShapeMassProperties(sphere, 1).inertia_kg_m2, 1e-12));
  EXPECT_NEAR(ShapeVolume(capsule), ShapeVolume(sphere), 1e-15);
}

TEST(MassProperties, CapsuleMatchesNumericIntegration) {
  // Independent check: integrate r^2 over the capsule on a grid (radius 0.1, straight part 0.3).
  Shape capsule;
  capsule.type = ShapeType::kCapsule;
  capsule.size_m = {0.1, 0.3, 0};
  const double r = 0.1;
  const double h = 0.3;
  const int n = 120;
  double volume = 0, ixx = 0, izz = 0;
  const double step_xy = 2 * r / n, step_z = (h + 2 * r) / n;
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) {
      for (int k = 0; k < n; ++k) {
        const double x = -r + (i + 0.5) * step_xy, y = -r + (j + 0.5) * step_xy;
        const double z = -(h / 2 + r) + (k + 0.5) * step_z;
        const double dz = std::max(0.0, std::abs(z) - h / 2);
        if (x * x + y * y + dz * dz > r * r) continue;
        const double dv = step_xy * step_xy * step_z;
        volume += dv;
        ixx += (y * y + z * z) * dv;
        izz += (x * x + y * y) * dv;
      }
    }
  }
  const double density = 1.0 / volume;
  const MassProperties p = SolidShapeMassProperties(capsule, 1.0);
  EXPECT_NEAR(ShapeVolume(capsule), volume, 0.01 * volume);
  EXPECT_NEAR(p.inertia_kg_m2(0, 0), ixx * density, 0.01 * ixx * density);
  EXPECT_NEAR(p.inertia_kg_m2(2, 2), izz * density, 0.01 * izz * density);
}

TEST(MassProperties, TwoHalvesMakeTheWholeBox) {
  // Two 0.1 m cubes side by side weigh and turn like one 0.2 x 0.1 x 0.1 box.
  const MassProperties halves =
      DeriveMassProperties({Box(0.1, 0.1, 0.1, {0.05, 0, 0}), Box(0.1, 0.1, 0.1, {0.15, 0, 0})}, 2);
  const MassProperties whole = SolidShapeMassProperties(Box(0.2, 0.1, 0.1, {0.1, 0, 0}), 2);
  EXPECT_TRUE(halves.com_m.isApprox(whole.com_m, 1e-12));
  EXPECT_TRUE(halves.inertia_kg_m2.isApprox(whole.inertia_kg_m2, 1e-12));
}

TEST(MassProperties, RotatedShapeRotatesItsInertia) {
  Shape box = Box(0.1, 0.2, 0.3);
  box.pose.orientation = QuaternionFromRpy(0, 0, M_PI / 2);  // x and y swap
  const MassProperties p = SolidShapeMassProperties(box, 1);
  const MassProperties q = SolidShapeMassProperties(Box(0.2, 0.1, 0.3), 1);
  EXPECT_TRUE(p.inertia_kg_m2.isApprox(q.inertia_kg_m2, 1e-12));
}

TEST(MassProperties, InertiaValidity) {
  EXPECT_FALSE(InertiaProblem(Eigen::Vector3d(1, 1, 1).asDiagonal()));
  EXPECT_FALSE(
      InertiaProblem(Eigen::Vector3d(1, 1, 2).asDiagonal()));  // thin plate: equality holds
  const auto triangle = InertiaProblem(Eigen::Vector3d(0.066, 0.086, 0.0125).asDiagonal());
  ASSERT_TRUE(triangle);
  EXPECT_NE(triangle->find("triangle inequality"), std::string::npos);
  EXPECT_TRUE(InertiaProblem(Eigen::Vector3d(1, 0, 1).asDiagonal()));
  Eigen::Matrix3d asymmetric = Eigen::Matrix3d::Identity();
  asymmetric(0, 1) = 0.1;
  EXPECT_EQ(*InertiaProblem(asymmetric), "is not symmetric");
}

}  // namespace
}  // namespace sirupp::core
