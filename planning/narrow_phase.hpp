#pragma once
// The primitive tests under CollisionModel and the sim's contacts: box, cylinder, capsule and
// sphere, pairwise. ODE's dCollide answers every pair but one: ODE 0.16's cylinder-box test misses
// overlaps when the cylinder passes through a thin box (research: 1432 of 20 000 random poses
// against a 2 cm plate, as deep as half the plate). That pair is answered here by an exact convex
// test (GJK on the shapes' support functions) and, when ODE finds no contact where the shapes do
// overlap, one contact of this library's own (the direction of least overlap among the boxes' and
// the cylinder's axes and their cross products: an upper bound of the depth).

#include <ode/ode.h>

#include <Eigen/Geometry>
#include <vector>

#include "core/geometry.hpp"

namespace sirupp::planning {

// A convex primitive placed in the world, with `margin` added: box half sizes + margin,
// cylinder/capsule radius + margin and half length + margin, sphere radius + margin.
struct Solid {
  core::ShapeType type = core::ShapeType::kBox;
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  Eigen::Vector3d half =
      Eigen::Vector3d::Zero();  // box: half sizes; cyl/capsule: (r, r, L/2); sphere: (r, r, r)
  static Solid From(const core::Shape& shape, const Eigen::Isometry3d& world_pose,
                    double margin = 0);
  static Solid FromGeom(dGeomID geom);  // an ODE box, cylinder, capsule or sphere geom
  // The point of the solid farthest along `direction` (any length, nonzero).
  Eigen::Vector3d Support(const Eigen::Vector3d& direction) const;
  // True when `point` lies inside (for tests).
  bool Contains(const Eigen::Vector3d& point) const;
};

// Whether two convex solids overlap (touching counts), by GJK. Exact up to 1e-9 m.
bool SolidsOverlap(const Solid& a, const Solid& b);

// Penetration estimate of two overlapping solids: depth (m, >= 0), the direction n to move `a` by
// depth to separate it from `b` (unit), and a point between the two. Upper bound of the true depth.
struct Penetration {
  double depth_m = 0;
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
};
Penetration EstimatePenetration(const Solid& a, const Solid& b);

// True for the pair that ODE's test cannot be trusted with (box and cylinder, either order).
bool NeedsOwnTest(int ode_class_a, int ode_class_b);

// dCollide with the box-cylinder pair made exact: ODE's contacts, or (when ODE finds none but the
// shapes overlap) one contact of ours with ODE's conventions (normal pushes `a` out of `b`, g1 = a,
// g2 = b). Same arguments and return as dCollide (max_contacts >= 1).
int CollideGeoms(dGeomID a, dGeomID b, int max_contacts, dContactGeom* contacts, int stride);

// Boolean only (no contact points): dCollide with one contact, or SolidsOverlap for the
// box-cylinder pair. What CollisionModel::IsFree uses.
bool GeomsOverlap(dGeomID a, dGeomID b);

// An empty ODE quad-tree space around the geoms' bounding boxes (1 cm margin), deep enough for
// about one smallest block per two geoms (at most 4^7): for static objects, which never move. The
// caller adds the geoms.
dSpaceID QuadTreeSpaceAround(const std::vector<dGeomID>& geoms);

// ODE's global state, once per process, and the calling thread's collision data (ODE needs it per
// thread). Every user of ODE collision calls it first; the sim's initialisation is the same.
void EnsureOdeReady();

}  // namespace sirupp::planning
