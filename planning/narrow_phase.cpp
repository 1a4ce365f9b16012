#include "planning/narrow_phase.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <mutex>
#include <stdexcept>
#include <vector>

namespace sirupp::planning {
namespace {

using Eigen::Vector3d;

constexpr double kTouchTolerance = 1e-9;  // m: closer than this counts as touching
constexpr int kMaxIterations = 64;

Eigen::Matrix3d RotationOf(const dReal* r) {
  Eigen::Matrix3d out;
  for (int row = 0; row < 3; ++row) {
    for (int col = 0; col < 3; ++col) out(row, col) = r[row * 4 + col];
  }
  return out;
}

// The point of a simplex (1 to 4 points of the Minkowski difference) closest to the origin; the
// simplex is reduced to the points that span it. Returns false when the origin is inside a
// tetrahedron (overlap).
struct Simplex {
  std::array<Vector3d, 4> p;
  int size = 0;
};

Vector3d ClosestOnSegment(Simplex& s) {
  const Vector3d& a = s.p[0];
  const Vector3d& b = s.p[1];
  const Vector3d ab = b - a;
  const double t = -a.dot(ab);
  const double len2 = ab.squaredNorm();
  if (t <= 0 || len2 <= 0) {
    s.size = 1;
    return a;
  }
  if (t >= len2) {
    s.p[0] = b;
    s.size = 1;
    return b;
  }
  return a + ab * (t / len2);
}

// Ericson, Real-Time Collision Detection, 5.1.5 (the closest point of a triangle), with the
// region's vertices kept.
Vector3d ClosestOnTriangle(const Vector3d& a, const Vector3d& b, const Vector3d& c, Simplex& out) {
  const Vector3d ab = b - a, ac = c - a, ap = -a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) {
    out.p[0] = a;
    out.size = 1;
    return a;
  }
  const Vector3d bp = -b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) {
    out.p[0] = b;
    out.size = 1;
    return b;
  }
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) {
    const double v = d1 / (d1 - d3);
    out.p[0] = a;
    out.p[1] = b;
    out.size = 2;
    return a + v * ab;
  }
  const Vector3d cp = -c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) {
    out.p[0] = c;
    out.size = 1;
    return c;
  }
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) {
    const double w = d2 / (d2 - d6);
    out.p[0] = a;
    out.p[1] = c;
    out.size = 2;
    return a + w * ac;
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
    const double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    out.p[0] = b;
    out.p[1] = c;
    out.size = 2;
    return b + w * (c - b);
  }
  const double sum = va + vb + vc;
  if (!(std::abs(sum) > 0)) {  // degenerate triangle: its longest edge
    Simplex edge;
    edge.p[0] = a;
    edge.p[1] = b;
    edge.size = 2;
    const Vector3d on_ab = ClosestOnSegment(edge);
    out = edge;
    Simplex other;
    other.p[0] = a;
    other.p[1] = c;
    other.size = 2;
    const Vector3d on_ac = ClosestOnSegment(other);
    if (on_ac.squaredNorm() < on_ab.squaredNorm()) {
      out = other;
      return on_ac;
    }
    return on_ab;
  }
  const double denom = 1.0 / sum;
  out.p[0] = a;
  out.p[1] = b;
  out.p[2] = c;
  out.size = 3;
  return a + ab * (vb * denom) + ac * (vc * denom);
}

// False when the origin lies inside the tetrahedron.
bool ClosestOnTetrahedron(Simplex& s, Vector3d& closest) {
  const std::array<std::array<int, 4>, 4> faces{
      {{0, 1, 2, 3}, {0, 1, 3, 2}, {0, 2, 3, 1}, {1, 2, 3, 0}}};
  bool outside_any = false;
  double best = std::numeric_limits<double>::infinity();
  Simplex best_simplex;
  for (const auto& f : faces) {
    const Vector3d& a = s.p[static_cast<size_t>(f[0])];
    const Vector3d& b = s.p[static_cast<size_t>(f[1])];
    const Vector3d& c = s.p[static_cast<size_t>(f[2])];
    const Vector3d& d = s.p[static_cast<size_t>(f[3])];
    const Vector3d n = (b - a).cross(c - a);
    const double side_origin = -a.dot(n);
    const double side_d = (d - a).dot(n);
    // The origin is outside this face when it lies on the other side from d (or d is on the
    // plane: a flat tetrahedron, where every face is tried).
    if (side_origin * side_d > 0 && std::abs(side_d) > 1e-18) continue;
    outside_any = true;
    Simplex face;
    const Vector3d point = ClosestOnTriangle(a, b, c, face);
    const double dist2 = point.squaredNorm();
    if (dist2 < best) {
      best = dist2;
      best_simplex = face;
      closest = point;
    }
  }
  if (!outside_any) return false;
  s = best_simplex;
  return true;
}

double SupportValue(const Solid& solid, const Vector3d& direction) {
  return solid.Support(direction).dot(direction);
}

}  // namespace

Solid Solid::From(const core::Shape& shape, const Eigen::Isometry3d& world_pose, double margin) {
  Solid solid;
  solid.type = shape.type;
  solid.rotation = world_pose.linear();
  solid.centre = world_pose.translation();
  const Vector3d& size = shape.size_m;
  switch (shape.type) {
    case core::ShapeType::kBox:
      solid.half = size / 2 + Vector3d::Constant(margin);
      break;
    case core::ShapeType::kCylinder:
      solid.half = {size.x() + margin, size.x() + margin, size.y() / 2 + margin};
      break;
    case core::ShapeType::kCapsule:
      solid.half = {size.x() + margin, size.x() + margin, size.y() / 2};
      break;
    case core::ShapeType::kSphere:
      solid.half = Vector3d::Constant(size.x() + margin);
      break;
  }
  return solid;
}

Solid Solid::FromGeom(dGeomID geom) {
  Solid solid;
  solid.rotation = RotationOf(dGeomGetRotation(geom));
  const dReal* p = dGeomGetPosition(geom);
  solid.centre = {p[0], p[1], p[2]};
  switch (dGeomGetClass(geom)) {
    case dBoxClass: {
      dVector3 lengths;
      dGeomBoxGetLengths(geom, lengths);
      solid.type = core::ShapeType::kBox;
      solid.half = {lengths[0] / 2, lengths[1] / 2, lengths[2] / 2};
      break;
    }
    case dCylinderClass: {
      dReal radius = 0, length = 0;
      dGeomCylinderGetParams(geom, &radius, &length);
      solid.type = core::ShapeType::kCylinder;
      solid.half = {radius, radius, length / 2};
      break;
    }
    case dCapsuleClass: {
      dReal radius = 0, length = 0;
      dGeomCapsuleGetParams(geom, &radius, &length);
      solid.type = core::ShapeType::kCapsule;
      solid.half = {radius, radius, length / 2};
      break;
    }
    case dSphereClass: {
      const dReal radius = dGeomSphereGetRadius(geom);
      solid.type = core::ShapeType::kSphere;
      solid.half = Vector3d::Constant(radius);
      break;
    }
    default:
      throw std::invalid_argument("narrow phase: ODE geom class " +
                                  std::to_string(dGeomGetClass(geom)) +
                                  " is not a box, cylinder, capsule or sphere");
  }
  return solid;
}

Vector3d Solid::Support(const Vector3d& direction) const {
  const Vector3d local = rotation.transpose() * direction;
  Vector3d out = Vector3d::Zero();
  switch (type) {
    case core::ShapeType::kBox:
      out = {local.x() >= 0 ? half.x() : -half.x(), local.y() >= 0 ? half.y() : -half.y(),
             local.z() >= 0 ? half.z() : -half.z()};
      break;
    case core::ShapeType::kCylinder: {
      const double radial = std::hypot(local.x(), local.y());
      out.z() = local.z() >= 0 ? half.z() : -half.z();
      if (radial > 0) {
        out.x() = half.x() * local.x() / radial;
        out.y() = half.x() * local.y() / radial;
      }
      break;
    }
    case core::ShapeType::kCapsule: {
      const double norm = local.norm();
      out.z() = local.z() >= 0 ? half.z() : -half.z();
      if (norm > 0) out += half.x() * local / norm;
      break;
    }
    case core::ShapeType::kSphere: {
      const double norm = local.norm();
      if (norm > 0) out = half.x() * local / norm;
      break;
    }
  }
  return centre + rotation * out;
}

bool Solid::Contains(const Vector3d& point) const {
  const Vector3d local = rotation.transpose() * (point - centre);
  switch (type) {
    case core::ShapeType::kBox:
      return std::abs(local.x()) <= half.x() && std::abs(local.y()) <= half.y() &&
             std::abs(local.z()) <= half.z();
    case core::ShapeType::kCylinder:
      return std::abs(local.z()) <= half.z() && std::hypot(local.x(), local.y()) <= half.x();
    case core::ShapeType::kCapsule: {
      const double z = std::clamp(local.z(), -half.z(), half.z());
      return (local - Vector3d(0, 0, z)).norm() <= half.x();
    }
    case core::ShapeType::kSphere:
      return local.norm() <= half.x();
  }
  return false;
}

bool SolidsOverlap(const Solid& a, const Solid& b) {
  auto support = [&](const Vector3d& d) -> Vector3d { return a.Support(d) - b.Support(-d); };
  Vector3d start = a.centre - b.centre;
  if (start.squaredNorm() < 1e-24) start = Vector3d::UnitX();
  Simplex s;
  s.p[0] = support(start);
  s.size = 1;
  Vector3d v = s.p[0];
  for (int iteration = 0; iteration < kMaxIterations; ++iteration) {
    const double v2 = v.squaredNorm();
    if (v2 <= kTouchTolerance * kTouchTolerance) return true;
    const Vector3d w = support(-v);
    // A separating plane: every point of the difference lies beyond it from the origin.
    if (v.dot(w) > kTouchTolerance * std::sqrt(v2)) return false;
    // No progress towards the origin: v is (within rounding) the closest point.
    if (v2 - v.dot(w) <= 1e-14 * v2) return std::sqrt(v2) <= kTouchTolerance;
    s.p[static_cast<size_t>(s.size++)] = w;
    switch (s.size) {
      case 2:
        v = ClosestOnSegment(s);
        break;
      case 3: {
        Simplex reduced;
        v = ClosestOnTriangle(s.p[0], s.p[1], s.p[2], reduced);
        s = reduced;
        break;
      }
      case 4:
        if (!ClosestOnTetrahedron(s, v)) return true;
        break;
      default:
        break;
    }
  }
  return v.norm() <= 1e-6;  // not converged: rounding at a touching contact
}

Penetration EstimatePenetration(const Solid& a, const Solid& b) {
  std::vector<Vector3d> directions;
  directions.reserve(20);
  auto add = [&](const Vector3d& d) {
    const double norm = d.norm();
    if (norm > 1e-9) directions.push_back(d / norm);
  };
  for (int i = 0; i < 3; ++i) add(a.rotation.col(i));
  for (int i = 0; i < 3; ++i) add(b.rotation.col(i));
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) add(a.rotation.col(i).cross(b.rotation.col(j)));
  }
  const Vector3d between = b.centre - a.centre;
  add(between);
  // Radial directions of round solids towards the other's centre.
  for (const Solid* round : {&a, &b}) {
    if (round->type == core::ShapeType::kBox) continue;
    const Vector3d axis = round->rotation.col(2);
    const Vector3d to_other = (round == &a ? b.centre : a.centre) - round->centre;
    add(to_other - axis * axis.dot(to_other));
  }
  Penetration best;
  best.depth_m = std::numeric_limits<double>::infinity();
  for (const Vector3d& d : directions) {
    // a below b along d: move a along -d; a above b: move a along +d.
    const double below = SupportValue(a, d) + SupportValue(b, -d);
    const double above = SupportValue(b, d) + SupportValue(a, -d);
    if (below < best.depth_m) {
      best.depth_m = below;
      best.normal = -d;
    }
    if (above < best.depth_m) {
      best.depth_m = above;
      best.normal = d;
    }
  }
  best.depth_m = std::max(0.0, best.depth_m);
  best.point = 0.5 * (a.Support(-best.normal) + b.Support(best.normal));
  return best;
}

bool NeedsOwnTest(int ode_class_a, int ode_class_b) {
  return (ode_class_a == dBoxClass && ode_class_b == dCylinderClass) ||
         (ode_class_a == dCylinderClass && ode_class_b == dBoxClass);
}

int CollideGeoms(dGeomID a, dGeomID b, int max_contacts, dContactGeom* contacts, int stride) {
  const int count = dCollide(a, b, max_contacts, contacts, stride);
  if (count > 0 || !NeedsOwnTest(dGeomGetClass(a), dGeomGetClass(b))) return count;
  const Solid solid_a = Solid::FromGeom(a);
  const Solid solid_b = Solid::FromGeom(b);
  if (!SolidsOverlap(solid_a, solid_b)) return 0;
  const Penetration pen = EstimatePenetration(solid_a, solid_b);
  dContactGeom& contact = contacts[0];
  for (int i = 0; i < 3; ++i) {
    contact.pos[i] = pen.point[i];
    contact.normal[i] = pen.normal[i];
  }
  contact.pos[3] = contact.normal[3] = 0;
  contact.depth = pen.depth_m;
  contact.g1 = a;
  contact.g2 = b;
  contact.side1 = contact.side2 = -1;
  return 1;
}

bool GeomsOverlap(dGeomID a, dGeomID b) {
  if (NeedsOwnTest(dGeomGetClass(a), dGeomGetClass(b))) {
    return SolidsOverlap(Solid::FromGeom(a), Solid::FromGeom(b));
  }
  dContactGeom contact;
  return dCollide(a, b, 1, &contact, sizeof(dContactGeom)) > 0;
}

void EnsureOdeReady() {
  static std::once_flag once;
  std::call_once(once, [] { dInitODE2(0); });
  thread_local bool thread_ready = false;
  if (!thread_ready) {
    dAllocateODEDataForThread(dAllocateMaskAll);
    thread_ready = true;
  }
}

dSpaceID QuadTreeSpaceAround(const std::vector<dGeomID>& geoms) {
  double low[3] = {dInfinity, dInfinity, dInfinity};
  double high[3] = {-dInfinity, -dInfinity, -dInfinity};
  for (dGeomID geom : geoms) {
    dReal box[6];
    dGeomGetAABB(geom, box);
    for (int axis = 0; axis < 3; ++axis) {
      low[axis] = std::min(low[axis], static_cast<double>(box[2 * axis]));
      high[axis] = std::max(high[axis], static_cast<double>(box[2 * axis + 1]));
    }
  }
  dVector3 centre, extents;
  for (int axis = 0; axis < 3; ++axis) {
    centre[axis] = 0.5 * (low[axis] + high[axis]);
    extents[axis] = 0.5 * (high[axis] - low[axis]) + 0.01;  // half sizes, with a margin
  }
  centre[3] = extents[3] = 0;
  int depth = 1;  // 4^depth smallest blocks: about one per two geoms, at most 4^7
  while (depth < 7 && std::pow(4.0, depth) * 2 < static_cast<double>(geoms.size())) ++depth;
  return dQuadTreeSpaceCreate(nullptr, centre, extents, depth);
}

}  // namespace sirupp::planning
