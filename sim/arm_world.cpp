#include "sim/arm_world.hpp"

#include <ode/ode.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <limits>
#include <mutex>
#include <sirupp/arm_state_t.hpp>
#include <stdexcept>

#include "core/errors.hpp"
#include "core/kinematics.hpp"
#include "planning/narrow_phase.hpp"

namespace sirupp::sim {
namespace {

using core::FormatNumber;

constexpr double kPi = 3.14159265358979323846;
// A hinge is re-zeroed once its ODE angle passes this, so that ODE's angle (which wraps at +-pi)
// never wraps and stops within pi of the joint can always be expressed in ODE's range.
constexpr double kRezeroAngle = kPi / 2;
// The brake of kHold holds up to this multiple of the joint's effort limit.
constexpr double kBrakeEffortFactor = 10.0;
constexpr int kMaxContactsPerPair = 8;
// Steps every joint must stay held, under one command, before the arm is at rest.
constexpr int kRestSteps = 32;

void OdeMessage(int errnum, const char* msg, va_list ap) {
  std::fprintf(stderr, "sirupp-sim: ODE message %d: ", errnum);
  std::vfprintf(stderr, msg, ap);
  std::fputc('\n', stderr);
}

// ODE's global state: initialised once per process, on first use, and never torn down (worlds may
// be created and destroyed at any time).
void EnsureOdeInitialised() {
  static std::once_flag once;
  std::call_once(once, [] { dSetMessageHandler(&OdeMessage); });
  planning::EnsureOdeReady();  // ODE itself, and this thread's collision data
}

void ToOde(const Eigen::Matrix3d& r, dMatrix3 out) {
  for (int row = 0; row < 3; ++row) {
    for (int col = 0; col < 3; ++col) out[row * 4 + col] = r(row, col);
    out[row * 4 + 3] = 0;
  }
}

Eigen::Matrix3d FromOde(const dReal* r) {
  Eigen::Matrix3d out;
  for (int row = 0; row < 3; ++row) {
    for (int col = 0; col < 3; ++col) out(row, col) = r[row * 4 + col];
  }
  return out;
}

void ToOdeQuaternion(const Eigen::Quaterniond& q, dQuaternion out) {
  out[0] = q.w();
  out[1] = q.x();
  out[2] = q.y();
  out[3] = q.z();
}

Eigen::Vector3d FromOdeVector(const dReal* v) { return {v[0], v[1], v[2]}; }

double WrapToPi(double angle) {
  angle = std::fmod(angle + kPi, 2 * kPi);
  if (angle < 0) angle += 2 * kPi;
  return angle - kPi;
}

bool PositiveDefinite(const Eigen::Matrix3d& inertia) {
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(inertia);
  return solver.info() == Eigen::Success && solver.eigenvalues().minCoeff() > 0;
}

// Surface properties carried by each geom (dGeomSetData).
struct Material {
  double friction = 1.0;
  double restitution = 0.0;
  bool arm = false;  // the arm's links: neutral, the other surface decides
};

// Everything the sim keeps per joint between steps.
struct JointSim {
  dJointID id = nullptr;
  bool revolute = true;
  // Model constants (SI).
  double position_min = 0, position_max = 0, effort_max = 0;
  double static_effort = 0, coulomb_positive = 0, coulomb_negative = 0, viscous = 0;
  double stribeck_velocity = 1;
  bool has_friction = false;
  // State.
  double q = 0;       // unwrapped joint position, DH convention
  double qd = 0;      // joint speed
  double raw = 0;     // ODE's reading (hinge angle or slider position) at the last update
  double offset = 0;  // q = offset + ODE reading accumulated since the last re-zero
  bool stuck = true;
  double q_stick = 0;
  double effort = 0;  // actuator effort applied in the last step
  bool braked = false;
  bool friction_row = false;       // the last step had a friction (or brake) row
  bool explicit_friction = false;  // the last step applied sliding friction as a plain torque
  double qd_before = 0;            // speed at the start of the step
  bool at_lower = false, at_upper = false;
  // Stop parameters last given to ODE (in ODE's coordinates), to avoid redundant calls.
  double lo_stop = -dInfinity, hi_stop = dInfinity;
};

}  // namespace

struct ArmWorld::Impl {
  core::RobotModel model;
  core::KinematicChain chain;
  WorldOptions options;
  double step_s = 0;
  int64_t tick = 0;

  dWorldID world = nullptr;
  dSpaceID arm_space = nullptr;
  // Static objects never move and are never tested against each other: they sit in a quadtree
  // (made once their extent is known) that the arm's and the free objects' geoms are tested
  // against. Free objects have a space of their own.
  dSpaceID static_space = nullptr;
  dSpaceID free_space = nullptr;
  int static_count = 0;
  int free_count = 0;
  dJointGroupID contact_group = nullptr;

  std::vector<dBodyID> bodies;  // bodies[i - 1] is link i
  std::vector<JointSim> joints;
  std::vector<std::string> omissions;

  struct Object {
    std::string name;
    dBodyID body = nullptr;  // null for static objects
    dGeomID geom = nullptr;
    core::Pose start;
  };
  std::vector<Object> objects;
  core::Environment built_environment;  // what the objects were built from
  std::vector<std::unique_ptr<Material>> materials;
  int last_rows = 0;
  int contact_rows = 0;
  int arm_contacts = 0;  // contacts of the arm with objects in the last step
  std::vector<Eigen::Vector3d> scratch_points, scratch_axes;
  std::vector<char> scratch_force_row;
  // Position, orientation and velocities of every moving body, to undo a step.
  struct BodyState {
    dBodyID body;
    dReal position[3], quaternion[4], linear[3], angular[3];
  };
  std::vector<BodyState> saved_bodies;
  int64_t redone_steps = 0;
  // Rest (WorldOptions::rest). After a teleport to zero speeds the arm is at rest for any hold
  // command (the brake keeps it where it is); after settling, for the command it settled under.
  bool at_rest = false;
  bool rest_any_hold = false;
  core::CommandMode rest_mode = core::CommandMode::kHold;
  std::vector<double> rest_effort;
  int quiet_steps = 0;
  core::CommandMode previous_mode = core::CommandMode::kHold;
  std::vector<double> previous_effort;
  bool have_previous = false;
  int64_t rest_ticks = 0;

  Impl(const core::RobotModel& robot, const core::Environment& environment,
       const WorldOptions& opts)
      : model(robot), chain(robot), options(opts) {
    EnsureOdeInitialised();
    step_s = options.step_s > 0 ? options.step_s : model.servo_tick_s;
    CheckInputs();
    world = dWorldCreate();
    dWorldSetGravity(world, model.gravity_m_s2.x(), model.gravity_m_s2.y(), model.gravity_m_s2.z());
    dWorldSetERP(world, options.erp);
    dWorldSetCFM(world, options.cfm);
    dWorldSetAutoDisableFlag(world, 0);
    dWorldSetContactSurfaceLayer(world, 0.0005);
    dWorldSetContactMaxCorrectingVel(world, 1.0);
    arm_space = dSimpleSpaceCreate(nullptr);
    free_space = dSimpleSpaceCreate(nullptr);
    contact_group = dJointGroupCreate(0);
    BuildArm();
    BuildEnvironment(environment);
    built_environment = environment;
    StartRest(true);
  }

  bool RestAllowed() const { return options.rest && free_count == 0; }

  // At rest from now on: for any hold command (after a teleport to zero speeds) or for the
  // previous command (after settling). The state stays the last step's, speeds (below
  // stick_speed) included, so that a law answering it keeps answering the same.
  void StartRest(bool any_hold) {
    quiet_steps = 0;
    at_rest = RestAllowed();
    if (!at_rest) return;
    rest_any_hold = any_hold;
    rest_mode = previous_mode;
    rest_effort = previous_effort;
  }

  static bool SameCommand(core::CommandMode mode_a, const std::vector<double>& effort_a,
                          const core::ArmCommand& b) {
    return mode_a == b.mode && (b.mode != core::CommandMode::kEffort || effort_a == b.effort);
  }

  bool KeepsRest(const core::ArmCommand& command) const {
    return at_rest && ((rest_any_hold && command.mode == core::CommandMode::kHold) ||
                       SameCommand(rest_mode, rest_effort, command));
  }

  // After a step: counts the steps every joint stayed held under the same command.
  void NoteRest(const core::ArmCommand& command) {
    bool held =
        RestAllowed() && have_previous && SameCommand(previous_mode, previous_effort, command);
    for (const JointSim& sim : joints) {
      held = held && std::abs(sim.qd) <= options.stick_speed &&
             (sim.braked || (sim.has_friction && sim.friction_row && sim.stuck));
    }
    quiet_steps = held ? quiet_steps + 1 : 0;
    previous_mode = command.mode;
    previous_effort =
        command.mode == core::CommandMode::kEffort ? command.effort : std::vector<double>{};
    have_previous = true;
    if (quiet_steps >= kRestSteps) StartRest(false);
  }

  ~Impl() {
    if (contact_group != nullptr) dJointGroupDestroy(contact_group);
    if (arm_space != nullptr) dSpaceDestroy(arm_space);  // destroys its geoms
    if (static_space != nullptr) dSpaceDestroy(static_space);
    if (free_space != nullptr) dSpaceDestroy(free_space);
    if (world != nullptr) dWorldDestroy(world);  // destroys bodies and joints
  }

  void CheckInputs() const {
    auto bad = [](const std::string& what) { throw std::invalid_argument(what); };
    if (!(step_s > 0 && step_s <= 0.01)) {
      bad("step " + FormatNumber(step_s) + " s: allowed 0 < step <= 0.01 s");
    }
    if (!(options.erp > 0 && options.erp <= 1)) {
      bad("erp " + FormatNumber(options.erp) + ": allowed 0 < erp <= 1");
    }
    if (!(options.cfm >= 0 && std::isfinite(options.cfm))) {
      bad("cfm " + FormatNumber(options.cfm) + ": allowed a finite value >= 0");
    }
    if (!(options.stick_speed > 0 && std::isfinite(options.stick_speed))) {
      bad("stick_speed " + FormatNumber(options.stick_speed) + ": allowed a finite value > 0");
    }
    if (model.num_joints() < 1 || model.links.size() != model.joints.size() + 1) {
      bad("model " + model.name +
          ": needs at least one joint and one link per joint plus the base");
    }
    for (int i = 1; i <= model.num_joints(); ++i) {
      const core::Link& link = model.links[static_cast<size_t>(i)];
      if (!(link.mass_kg > 0) || !PositiveDefinite(link.inertia_kg_m2)) {
        bad("links[" + std::to_string(i) + "] (" + link.name + "): mass " +
            FormatNumber(link.mass_kg) +
            " kg and its inertia must be positive for a simulated body");
      }
    }
  }

  // Joint i's axis (unit vector) and a point on it, in the world, from the DH frames at q.
  void JointAxis(const core::ForwardResult& fk, int i, Eigen::Vector3d& point,
                 Eigen::Vector3d& axis) const {
    const Eigen::Isometry3d& frame = model.dh_convention == core::DhConvention::kStandard
                                         ? fk.frames[static_cast<size_t>(i - 1)]
                                         : fk.frames[static_cast<size_t>(i)];
    point = frame.translation();
    axis = frame.linear().col(2);
  }

  void BuildArm() {
    const int n = model.num_joints();
    core::JointVector q0(n);
    for (int j = 0; j < n; ++j) q0[j] = model.joints[static_cast<size_t>(j)].home;
    const core::ForwardResult fk = chain.Forward(q0);

    // Base shapes: fixed geoms in the arm's space (nothing to collide with among the arm itself).
    AddArmGeoms(nullptr, model.links[0], fk.frames[0]);

    for (int i = 1; i <= n; ++i) {
      const core::Link& link = model.links[static_cast<size_t>(i)];
      const core::Joint& joint = model.joints[static_cast<size_t>(i - 1)];
      Eigen::Vector3d point, axis;
      JointAxis(fk, i, point, axis);
      Eigen::Matrix3d inertia = link.inertia_kg_m2;
      if (options.armature && joint.armature > 0) {
        if (joint.type == core::JointType::kRevolute) {
          // Rotor inertia about the joint axis, added to the child link (docs/physics.md).
          const Eigen::Vector3d axis_body =
              fk.frames[static_cast<size_t>(i)].linear().transpose() * axis;
          inertia += joint.armature * axis_body * axis_body.transpose();
        } else {
          omissions.push_back("joints[" + std::to_string(i - 1) + "] (" + joint.name +
                              "): armature " + FormatNumber(joint.armature) +
                              " kg on a prismatic joint is not simulated");
        }
      }
      dBodyID body = dBodyCreate(world);
      dMass mass;
      dMassSetParameters(&mass, link.mass_kg, 0, 0, 0, inertia(0, 0), inertia(1, 1), inertia(2, 2),
                         inertia(0, 1), inertia(0, 2), inertia(1, 2));
      dBodySetMass(body, &mass);
      dBodySetGyroscopicMode(body, 1);
      bodies.push_back(body);
      PlaceBody(i, fk.frames[static_cast<size_t>(i)]);
      AddArmGeoms(body, link, fk.frames[static_cast<size_t>(i)]);

      JointSim sim;
      sim.revolute = joint.type == core::JointType::kRevolute;
      sim.position_min = joint.position_min;
      sim.position_max = joint.position_max;
      sim.effort_max = joint.effort_max;
      if (options.friction) {
        sim.static_effort = joint.friction.static_effort;
        sim.coulomb_positive = joint.friction.coulomb_positive;
        sim.coulomb_negative = joint.friction.coulomb_negative;
        sim.viscous = joint.friction.viscous;
        sim.stribeck_velocity = joint.friction.stribeck_velocity;
      }
      sim.has_friction =
          sim.static_effort > 0 || sim.coulomb_positive > 0 || sim.coulomb_negative > 0;
      sim.q = q0[i - 1];
      sim.q_stick = sim.q;
      dBodyID parent = i > 1 ? bodies[static_cast<size_t>(i - 2)] : nullptr;
      sim.id =
          sim.revolute ? dJointCreateHinge(world, nullptr) : dJointCreateSlider(world, nullptr);
      dJointAttach(sim.id, body, parent);
      joints.push_back(sim);
      AttachJointFrame(i - 1, point, axis);
    }
  }

  // Sets joint j's anchor and axis at the current pose; ODE's reading restarts from zero there.
  void AttachJointFrame(int j, const Eigen::Vector3d& point, const Eigen::Vector3d& axis) {
    JointSim& sim = joints[static_cast<size_t>(j)];
    if (sim.revolute) {
      dJointSetHingeAnchor(sim.id, point.x(), point.y(), point.z());
      dJointSetHingeAxis(sim.id, axis.x(), axis.y(), axis.z());
    } else {
      dJointSetSliderAxis(sim.id, axis.x(), axis.y(), axis.z());
    }
    sim.offset = sim.q;
    sim.raw = 0;
    sim.lo_stop = -dInfinity;
    sim.hi_stop = dInfinity;
    SetParam(sim, dParamLoStop, -dInfinity);
    SetParam(sim, dParamHiStop, dInfinity);
  }

  static void SetParam(const JointSim& sim, int parameter, double value) {
    if (sim.revolute) {
      dJointSetHingeParam(sim.id, parameter, value);
    } else {
      dJointSetSliderParam(sim.id, parameter, value);
    }
  }

  void PlaceBody(int i, const Eigen::Isometry3d& frame) {
    const core::Link& link = model.links[static_cast<size_t>(i)];
    const Eigen::Vector3d com = frame * link.com_m;
    dBodyID body = bodies[static_cast<size_t>(i - 1)];
    dBodySetPosition(body, com.x(), com.y(), com.z());
    dMatrix3 rotation;
    ToOde(frame.linear(), rotation);
    dBodySetRotation(body, rotation);
  }

  dGeomID CreateGeom(dSpaceID space, const core::Shape& shape) {
    switch (shape.type) {
      case core::ShapeType::kBox:
        return dCreateBox(space, shape.size_m.x(), shape.size_m.y(), shape.size_m.z());
      case core::ShapeType::kCylinder:
        return dCreateCylinder(space, shape.size_m.x(), shape.size_m.y());
      case core::ShapeType::kCapsule:
        return dCreateCapsule(space, shape.size_m.x(), shape.size_m.y());
      case core::ShapeType::kSphere:
        return dCreateSphere(space, shape.size_m.x());
    }
    throw std::logic_error("unknown shape type");
  }

  Material* NewMaterial(double friction, double restitution, bool arm = false) {
    materials.push_back(std::make_unique<Material>(Material{friction, restitution, arm}));
    return materials.back().get();
  }

  // The link's shapes as geoms riding on its body (or fixed, for the base).
  void AddArmGeoms(dBodyID body, const core::Link& link, const Eigen::Isometry3d& frame) {
    Material* material = NewMaterial(1.0, 0.0, /*arm=*/true);
    for (const core::Shape& shape : link.shapes) {
      dGeomID geom = CreateGeom(arm_space, shape);
      dGeomSetData(geom, material);
      dQuaternion rotation;
      if (body != nullptr) {
        dGeomSetBody(geom, body);
        const Eigen::Vector3d offset =
            shape.pose.position_m - link.com_m;  // body axes = frame axes
        dGeomSetOffsetPosition(geom, offset.x(), offset.y(), offset.z());
        ToOdeQuaternion(shape.pose.orientation, rotation);
        dGeomSetOffsetQuaternion(geom, rotation);
      } else {
        const Eigen::Isometry3d pose = frame * shape.pose.ToIsometry();
        dGeomSetPosition(geom, pose.translation().x(), pose.translation().y(),
                         pose.translation().z());
        ToOdeQuaternion(Eigen::Quaterniond(pose.linear()), rotation);
        dGeomSetQuaternion(geom, rotation);
      }
    }
  }

  // Removes every environment object (geoms, bodies, their materials and spaces).
  void ClearEnvironment() {
    dJointGroupEmpty(contact_group);
    for (const Object& object : objects) {
      if (object.body != nullptr) dBodyDestroy(object.body);
    }
    if (static_space != nullptr) dSpaceDestroy(static_space);  // destroys its geoms
    static_space = nullptr;
    dSpaceDestroy(free_space);
    free_space = dSimpleSpaceCreate(nullptr);
    objects.clear();
    saved_bodies.clear();
    static_count = 0;
    free_count = 0;
    materials.erase(std::remove_if(materials.begin(), materials.end(),
                                   [](const std::unique_ptr<Material>& m) { return !m->arm; }),
                    materials.end());
  }

  // The first object overlapping one of the arm's moving links by more than 1 mm, as
  // "object 'NAME' overlaps link I" (empty when none does).
  std::string FindOverlap() {
    struct Probe {
      Impl* self;
      std::string found;
    } probe{this, {}};
    const auto callback = [](void* data, dGeomID a, dGeomID b) {
      auto* p = static_cast<Probe*>(data);
      if (!p->found.empty()) return;
      if (dGeomGetBody(a) == nullptr && dGeomGetBody(b) == nullptr) return;
      dContactGeom contacts[kMaxContactsPerPair];
      const int count =
          planning::CollideGeoms(a, b, kMaxContactsPerPair, contacts, sizeof(dContactGeom));
      for (int k = 0; k < count; ++k) {
        if (contacts[k].depth <= 0.001) continue;
        for (const Object& object : p->self->objects) {
          if (object.geom != a && object.geom != b) continue;
          const dGeomID arm_geom = object.geom == a ? b : a;
          const dBodyID body = dGeomGetBody(arm_geom);
          const auto& links = p->self->bodies;
          const auto it = std::find(links.begin(), links.end(), body);
          p->found = "object '" + object.name + "' overlaps " +
                     (it == links.end() ? std::string("the base")
                                        : "link " + std::to_string(it - links.begin() + 1)) +
                     " by " + FormatNumber(std::round(contacts[k].depth * 1e4) / 10) + " mm";
          return;
        }
      }
    };
    const auto arm = reinterpret_cast<dGeomID>(arm_space);
    if (static_space != nullptr) {
      dSpaceCollide2(arm, reinterpret_cast<dGeomID>(static_space), &probe, callback);
    }
    if (probe.found.empty() && free_count > 0) {
      dSpaceCollide2(arm, reinterpret_cast<dGeomID>(free_space), &probe, callback);
    }
    return probe.found;
  }

  void BuildEnvironment(const core::Environment& environment) {
    std::vector<dGeomID> static_geoms;
    for (const core::EnvironmentObject& object : environment.objects) {
      Object sim_object;
      sim_object.name = object.name;
      sim_object.start = object.shape.pose;
      sim_object.geom = CreateGeom(object.is_static ? nullptr : free_space, object.shape);
      dGeomSetData(sim_object.geom, NewMaterial(object.friction, object.restitution));
      if (!object.is_static) {
        ++free_count;
        sim_object.body = dBodyCreate(world);
        dMass mass;
        const Eigen::Vector3d& size = object.shape.size_m;
        switch (object.shape.type) {
          case core::ShapeType::kBox:
            dMassSetBoxTotal(&mass, object.mass_kg, size.x(), size.y(), size.z());
            break;
          case core::ShapeType::kCylinder:
            dMassSetCylinderTotal(&mass, object.mass_kg, 3, size.x(), size.y());
            break;
          case core::ShapeType::kCapsule:
            dMassSetCapsuleTotal(&mass, object.mass_kg, 3, size.x(), size.y());
            break;
          case core::ShapeType::kSphere:
            dMassSetSphereTotal(&mass, object.mass_kg, size.x());
            break;
        }
        dBodySetMass(sim_object.body, &mass);
        dGeomSetBody(sim_object.geom, sim_object.body);
      } else {
        static_geoms.push_back(sim_object.geom);
      }
      objects.push_back(sim_object);
      PlaceObject(objects.back());
    }
    BuildStaticSpace(static_geoms);
  }

  // A quadtree over the horizontal extent of the static geoms (z is up), deep enough that its
  // smallest blocks hold a few geoms each; geoms straddling a block's edge stay in its parent.
  void BuildStaticSpace(const std::vector<dGeomID>& geoms) {
    static_count = static_cast<int>(geoms.size());
    if (geoms.empty()) return;
    static_space = planning::QuadTreeSpaceAround(geoms);
    for (dGeomID geom : geoms) dSpaceAdd(static_space, geom);
  }

  static void PlaceObject(Object& object) {
    const Eigen::Vector3d& p = object.start.position_m;
    dQuaternion rotation;
    ToOdeQuaternion(object.start.orientation, rotation);
    if (object.body != nullptr) {
      dBodySetPosition(object.body, p.x(), p.y(), p.z());
      dBodySetQuaternion(object.body, rotation);
      dBodySetLinearVel(object.body, 0, 0, 0);
      dBodySetAngularVel(object.body, 0, 0, 0);
    } else {
      dGeomSetPosition(object.geom, p.x(), p.y(), p.z());
      dGeomSetQuaternion(object.geom, rotation);
    }
  }

  // Puts every link's body where forward kinematics puts it at q, moving as the joint speeds qd
  // make it move; optionally returns each joint's axis point and direction.
  void PlaceArm(const core::JointVector& q, const core::JointVector& qd,
                std::vector<Eigen::Vector3d>* points_out = nullptr,
                std::vector<Eigen::Vector3d>* axes_out = nullptr) {
    const int n = model.num_joints();
    const core::ForwardResult fk = chain.Forward(q);
    std::vector<Eigen::Vector3d>& points = scratch_points;
    std::vector<Eigen::Vector3d>& axes = scratch_axes;
    points.resize(static_cast<size_t>(n));
    axes.resize(static_cast<size_t>(n));
    for (int i = 1; i <= n; ++i) {
      JointAxis(fk, i, points[static_cast<size_t>(i - 1)], axes[static_cast<size_t>(i - 1)]);
    }
    Eigen::Vector3d omega = Eigen::Vector3d::Zero();
    for (int i = 1; i <= n; ++i) {
      PlaceBody(i, fk.frames[static_cast<size_t>(i)]);
      const Eigen::Vector3d com =
          fk.frames[static_cast<size_t>(i)] * model.links[static_cast<size_t>(i)].com_m;
      const Eigen::Vector3d& z = axes[static_cast<size_t>(i - 1)];
      if (model.joints[static_cast<size_t>(i - 1)].type == core::JointType::kRevolute) {
        omega += z * qd[i - 1];
      }
      // Velocity of this link's centre: every joint up to i contributes.
      Eigen::Vector3d v = Eigen::Vector3d::Zero();
      for (int k = 1; k <= i; ++k) {
        const Eigen::Vector3d& zk = axes[static_cast<size_t>(k - 1)];
        if (model.joints[static_cast<size_t>(k - 1)].type == core::JointType::kRevolute) {
          v += zk.cross(com - points[static_cast<size_t>(k - 1)]) * qd[k - 1];
        } else {
          v += zk * qd[k - 1];
        }
      }
      dBodyID body = bodies[static_cast<size_t>(i - 1)];
      dBodySetLinearVel(body, v.x(), v.y(), v.z());
      dBodySetAngularVel(body, omega.x(), omega.y(), omega.z());
    }
    if (points_out != nullptr) *points_out = points;
    if (axes_out != nullptr) *axes_out = axes;
  }

  void Teleport(const std::vector<double>& position, const std::vector<double>& velocity,
                bool reset_objects) {
    const int n = model.num_joints();
    auto joint_label = [&](int j) {
      return "joints[" + std::to_string(j) + "] (" + model.joints[static_cast<size_t>(j)].name +
             ")";
    };
    if (static_cast<int>(position.size()) != n) {
      throw std::invalid_argument("position has " + std::to_string(position.size()) +
                                  " values; the model has " + std::to_string(n) + " joints");
    }
    if (!velocity.empty() && static_cast<int>(velocity.size()) != n) {
      throw std::invalid_argument("velocity has " + std::to_string(velocity.size()) +
                                  " values; give none or " + std::to_string(n));
    }
    for (int j = 0; j < n; ++j) {
      const core::Joint& joint = model.joints[static_cast<size_t>(j)];
      const double q = position[static_cast<size_t>(j)];
      if (!std::isfinite(q) || q < joint.position_min || q > joint.position_max) {
        throw std::invalid_argument(joint_label(j) + ": position " + FormatNumber(q) +
                                    " is outside the limits [" + FormatNumber(joint.position_min) +
                                    ", " + FormatNumber(joint.position_max) + "]");
      }
      if (!velocity.empty() && !std::isfinite(velocity[static_cast<size_t>(j)])) {
        throw std::invalid_argument(joint_label(j) + ": velocity " +
                                    FormatNumber(velocity[static_cast<size_t>(j)]) +
                                    " is not a finite number");
      }
    }
    std::vector<Eigen::Vector3d> points, axes;
    PlaceArm(core::ToJointVector(position),
             velocity.empty() ? core::JointVector::Zero(n) : core::ToJointVector(velocity), &points,
             &axes);
    for (int j = 0; j < n; ++j) {
      JointSim& sim = joints[static_cast<size_t>(j)];
      sim.q = position[static_cast<size_t>(j)];
      sim.qd = velocity.empty() ? 0.0 : velocity[static_cast<size_t>(j)];
      sim.stuck = sim.qd == 0;
      sim.q_stick = sim.q;
      sim.effort = 0;
      sim.braked = false;
      AttachJointFrame(j, points[static_cast<size_t>(j)], axes[static_cast<size_t>(j)]);
      UpdateLimitFlags(sim);
    }
    if (reset_objects) {
      for (Object& object : objects) {
        if (object.body != nullptr) PlaceObject(object);  // static objects never moved
      }
    }
    have_previous = false;
    const bool still =
        std::all_of(joints.begin(), joints.end(), [](const JointSim& sim) { return sim.qd == 0; });
    if (still) {
      StartRest(true);
    } else {
      at_rest = false;
      quiet_steps = 0;
    }
  }

  static void UpdateLimitFlags(JointSim& sim) {
    constexpr double kAtLimit = 1e-4;  // rad or m
    sim.at_lower = sim.q <= sim.position_min + kAtLimit;
    sim.at_upper = sim.q >= sim.position_max - kAtLimit;
  }

  double SlidingFriction(const JointSim& sim, double speed) const {
    const double coulomb = speed >= 0 ? sim.coulomb_positive : sim.coulomb_negative;
    const double ratio = std::abs(speed) / sim.stribeck_velocity;
    return coulomb + (sim.static_effort - coulomb) * std::exp(-ratio * ratio);
  }

  void AddJointEffort(const JointSim& sim, double effort) {
    if (sim.revolute) {
      dJointAddHingeTorque(sim.id, effort);
    } else {
      dJointAddSliderForce(sim.id, effort);
    }
  }

  // Before a step: position stops, the friction (or brake) row and the explicit efforts of joint j.
  // A sliding joint's kinetic friction is a plain torque (no constraint row) unless `force_row`;
  // Step() redoes the step with the row if the joint's speed would reach or cross zero.
  // Returns the number of constraint rows the joint adds beyond its 5 fixed ones.
  int PrepareJoint(JointSim& sim, core::CommandMode mode, double commanded, bool force_row) {
    // Stops in ODE's coordinates, when they lie within ODE's reach.
    const double reading_now = sim.q - sim.offset;
    double lo = sim.position_min - sim.q + reading_now;
    double hi = sim.position_max - sim.q + reading_now;
    if (sim.revolute) {
      if (lo < -kPi) lo = -dInfinity;
      if (hi > kPi) hi = dInfinity;
    }
    if (lo != sim.lo_stop || hi != sim.hi_stop) {
      // Widen first so that ODE never sees lo > hi in between.
      SetParam(sim, dParamLoStop, -dInfinity);
      SetParam(sim, dParamHiStop, hi);
      SetParam(sim, dParamLoStop, lo);
      sim.lo_stop = lo;
      sim.hi_stop = hi;
    }
    const bool at_stop = reading_now <= lo || reading_now >= hi;

    sim.braked = mode == core::CommandMode::kHold;
    sim.explicit_friction = false;
    sim.qd_before = sim.qd;
    sim.effort = mode == core::CommandMode::kEffort
                     ? std::clamp(commanded, -sim.effort_max, sim.effort_max)
                     : 0.0;
    double explicit_effort = sim.effort;
    double row_max = 0;  // FMax of the joint's motor row; 0 = no row
    double row_speed = 0;
    if (sim.braked) {
      row_max = kBrakeEffortFactor * sim.effort_max;
      row_speed = at_stop ? 0.0 : options.erp * (sim.q_stick - sim.q) / step_s;
    } else if (sim.has_friction) {
      if (sim.stuck) {
        row_max = sim.static_effort;
        row_speed = at_stop ? 0.0 : options.erp * (sim.q_stick - sim.q) / step_s;
      } else if (!force_row && !options.always_friction_rows && sim.qd != 0) {
        explicit_effort -= std::copysign(SlidingFriction(sim, sim.qd), sim.qd);
        sim.explicit_friction = true;
      } else {
        row_max = SlidingFriction(sim, sim.qd);
      }
    }
    explicit_effort -= sim.viscous * sim.qd;
    SetParam(sim, dParamFMax, row_max);
    SetParam(sim, dParamVel, row_speed);
    if (explicit_effort != 0) AddJointEffort(sim, explicit_effort);
    sim.friction_row = row_max > 0;
    return (row_max > 0 || at_stop) ? 1 : 0;
  }

  // After a step: the joint's unwrapped position and speed, and its friction state.
  void UpdateJoint(JointSim& sim) {
    const double reading =
        sim.revolute ? dJointGetHingeAngle(sim.id) : dJointGetSliderPosition(sim.id);
    sim.qd = sim.revolute ? dJointGetHingeAngleRate(sim.id) : dJointGetSliderPositionRate(sim.id);
    const double step = sim.revolute ? WrapToPi(reading - sim.raw) : reading - sim.raw;
    sim.raw = reading;
    sim.q += step;
    if (sim.revolute && std::abs(reading) > kRezeroAngle) {
      // Re-zero the hinge so that its angle stays far from ODE's wrap at +-pi.
      dVector3 axis;
      dJointGetHingeAxis(sim.id, axis);
      dJointSetHingeAxis(sim.id, axis[0], axis[1], axis[2]);
      sim.offset = sim.q;
      sim.raw = 0;
      sim.lo_stop = std::numeric_limits<double>::quiet_NaN();  // force new stops next step
    } else {
      sim.offset = sim.q - reading;
    }
    const bool still = std::abs(sim.qd) <= options.stick_speed;
    if (sim.braked || (sim.has_friction && sim.friction_row && still)) {
      if (!sim.stuck) sim.q_stick = sim.q;
      sim.stuck = true;
    } else {
      sim.stuck = false;
    }
    UpdateLimitFlags(sim);
  }

  // Contact generation (ODE near callback).
  static void NearCallback(void* data, dGeomID a, dGeomID b) {
    auto* self = static_cast<Impl*>(data);
    dBodyID body_a = dGeomGetBody(a);
    dBodyID body_b = dGeomGetBody(b);
    if (body_a == nullptr && body_b == nullptr) return;  // two fixed geoms
    dContact contacts[kMaxContactsPerPair];
    // The planner's primitive tests (planning/narrow_phase.hpp): ODE's, with the box-cylinder pair
    // made exact, so that the physics stops what the plan check finds.
    const int count =
        planning::CollideGeoms(a, b, kMaxContactsPerPair, &contacts[0].geom, sizeof(dContact));
    if (count == 0) return;
    const auto* material_a = static_cast<const Material*>(dGeomGetData(a));
    const auto* material_b = static_cast<const Material*>(dGeomGetData(b));
    // An object's own surface decides against the arm (whose material is neutral: friction 1);
    // between two objects the geometric mean of frictions and the larger restitution.
    const Material& surface_a = *material_a;
    const Material& surface_b = *material_b;
    double friction = std::sqrt(surface_a.friction * surface_b.friction);
    double restitution = std::max(surface_a.restitution, surface_b.restitution);
    if (surface_a.arm || surface_b.arm) {
      self->arm_contacts += count;
      const Material& object = surface_a.arm ? surface_b : surface_a;
      friction = object.friction;
      restitution = object.restitution;
    }
    for (int k = 0; k < count; ++k) {
      dContact& contact = contacts[k];
      contact.surface.mode = dContactApprox1 | dContactSoftCFM | dContactSoftERP;
      contact.surface.mu = friction;
      contact.surface.soft_cfm = 1e-6;
      contact.surface.soft_erp = 0.2;
      if (restitution > 0) {
        contact.surface.mode |= dContactBounce;
        contact.surface.bounce = restitution;
        contact.surface.bounce_vel = 0.05;
      }
      dJointID joint = dJointCreateContact(self->world, self->contact_group, &contact);
      dJointAttach(joint, body_a, body_b);
      self->contact_rows += friction > 0 ? 3 : 1;
    }
  }

  // Contacts of the arm with every object and of the free objects with everything; static objects
  // are never tested against each other (they cannot move), and the quadtree finds the few
  // static geoms near each moving one.
  void Collide() {
    const auto arm = reinterpret_cast<dGeomID>(arm_space);
    const auto free = reinterpret_cast<dGeomID>(free_space);
    const auto fixed = reinterpret_cast<dGeomID>(static_space);
    if (static_count > 0) dSpaceCollide2(arm, fixed, this, &NearCallback);
    if (free_count > 0) {
      dSpaceCollide2(arm, free, this, &NearCallback);
      dSpaceCollide(free_space, this, &NearCallback);
      if (static_count > 0) dSpaceCollide2(free, fixed, this, &NearCallback);
    }
  }

  void SaveBodies() {
    saved_bodies.clear();
    auto save = [this](dBodyID body) {
      BodyState state{};
      state.body = body;
      const dReal* p = dBodyGetPosition(body);
      const dReal* q = dBodyGetQuaternion(body);
      const dReal* v = dBodyGetLinearVel(body);
      const dReal* w = dBodyGetAngularVel(body);
      std::copy(p, p + 3, state.position);
      std::copy(q, q + 4, state.quaternion);
      std::copy(v, v + 3, state.linear);
      std::copy(w, w + 3, state.angular);
      saved_bodies.push_back(state);
    };
    for (dBodyID body : bodies) save(body);
    for (const Object& object : objects) {
      if (object.body != nullptr) save(object.body);
    }
  }

  void RestoreBodies() {
    for (const BodyState& state : saved_bodies) {
      dBodySetPosition(state.body, state.position[0], state.position[1], state.position[2]);
      dBodySetQuaternion(state.body, state.quaternion);
      dBodySetLinearVel(state.body, state.linear[0], state.linear[1], state.linear[2]);
      dBodySetAngularVel(state.body, state.angular[0], state.angular[1], state.angular[2]);
    }
  }

  void Step(const core::ArmCommand& command) {
    const int n = model.num_joints();
    if (static_cast<int>(command.effort.size()) != n &&
        command.mode == core::CommandMode::kEffort) {
      throw std::invalid_argument("command has " + std::to_string(command.effort.size()) +
                                  " efforts; the model has " + std::to_string(n) + " joints");
    }
    if (command.mode == core::CommandMode::kEffort) {
      for (int j = 0; j < n; ++j) {
        if (!std::isfinite(command.effort[static_cast<size_t>(j)])) {
          throw std::invalid_argument("effort[" + std::to_string(j) + "] " +
                                      FormatNumber(command.effort[static_cast<size_t>(j)]) +
                                      " is not a finite number");
        }
      }
    }
    if (KeepsRest(command)) {
      // Held still under the same command: nothing moves, so nothing is integrated.
      for (JointSim& sim : joints) sim.braked = command.mode == core::CommandMode::kHold;
      last_rows = 0;
      ++rest_ticks;
      ++tick;
      return;
    }
    at_rest = false;
    // Sliding joints take their kinetic friction as a plain torque, which saves the constraint
    // row; that is exact as long as the joint keeps sliding the same way through the step. If one
    // reached or crossed zero speed, the step is undone and redone with that joint's row, so the
    // LCP can stop it exactly (each pass adds rows, so this ends).
    std::vector<char>& force_row = scratch_force_row;
    force_row.assign(static_cast<size_t>(n), 0);
    int rows = 0;
    for (int pass = 0;; ++pass) {
      rows = 0;
      for (int j = 0; j < n; ++j) {
        const double commanded =
            command.mode == core::CommandMode::kEffort ? command.effort[static_cast<size_t>(j)] : 0;
        rows += 5 + PrepareJoint(joints[static_cast<size_t>(j)], command.mode, commanded,
                                 force_row[static_cast<size_t>(j)] != 0);
      }
      bool any_explicit = false;
      for (const JointSim& sim : joints) any_explicit = any_explicit || sim.explicit_friction;
      if (any_explicit) SaveBodies();
      contact_rows = 0;
      arm_contacts = 0;
      if (options.contacts && !objects.empty()) Collide();
      dWorldStep(world, step_s);
      dJointGroupEmpty(contact_group);
      bool redo = false;
      for (int j = 0; j < n; ++j) {
        const JointSim& sim = joints[static_cast<size_t>(j)];
        if (!sim.explicit_friction) continue;
        const double after =
            sim.revolute ? dJointGetHingeAngleRate(sim.id) : dJointGetSliderPositionRate(sim.id);
        if (after * sim.qd_before <= 0) {
          force_row[static_cast<size_t>(j)] = 1;
          redo = true;
        }
      }
      if (!redo) break;
      RestoreBodies();
      ++redone_steps;
    }
    for (int j = 0; j < n; ++j) {
      UpdateJoint(joints[static_cast<size_t>(j)]);
    }
    for (int j = 0; j < n; ++j) {
      const JointSim& sim = joints[static_cast<size_t>(j)];
      if (!std::isfinite(sim.q) || !std::isfinite(sim.qd)) {
        throw std::runtime_error("the simulation became unstable at tick " + std::to_string(tick) +
                                 ": joint " + std::to_string(j + 1) + " (" +
                                 model.joints[static_cast<size_t>(j)].name + ") position " +
                                 FormatNumber(sim.q) + ", speed " + FormatNumber(sim.qd) +
                                 "; try a smaller step or check the model's masses and inertias");
      }
    }
    last_rows = rows + contact_rows;
    ++tick;
    NoteRest(command);
  }

  core::ArmState State() const {
    core::ArmState state;
    state.tick = tick;
    state.utime = static_cast<int64_t>(std::llround(static_cast<double>(tick) * step_s * 1e6));
    state.source = core::StateSource::kSim;
    for (const JointSim& sim : joints) {
      state.position.push_back(sim.q);
      state.velocity.push_back(sim.qd);
      state.effort.push_back(sim.effort);
      int flags = 0;
      if (sim.at_lower) flags |= sirupp::arm_state_t::FLAG_AT_LOWER_LIMIT;
      if (sim.at_upper) flags |= sirupp::arm_state_t::FLAG_AT_UPPER_LIMIT;
      if (sim.braked) {
        flags |= sirupp::arm_state_t::FLAG_BRAKED;
      } else if (sim.stuck && sim.has_friction) {
        flags |= sirupp::arm_state_t::FLAG_STICKING;
      }
      if (at_rest) flags |= sirupp::arm_state_t::FLAG_AT_REST;
      state.flags.push_back(static_cast<int8_t>(flags));
    }
    return state;
  }
};

ArmWorld::ArmWorld(const core::RobotModel& model, const core::Environment& environment,
                   const WorldOptions& options)
    : impl_(std::make_unique<Impl>(model, environment, options)) {}

ArmWorld::~ArmWorld() = default;

const core::RobotModel& ArmWorld::model() const { return impl_->model; }
double ArmWorld::step_s() const { return impl_->step_s; }
int64_t ArmWorld::tick() const { return impl_->tick; }
double ArmWorld::time_s() const { return static_cast<double>(impl_->tick) * impl_->step_s; }

void ArmWorld::SetJointState(const std::vector<double>& position,
                             const std::vector<double>& velocity, bool reset_objects) {
  impl_->Teleport(position, velocity, reset_objects);
}

void ArmWorld::ReplaceEnvironment(const core::Environment& environment) {
  const core::Environment previous = impl_->built_environment;
  impl_->ClearEnvironment();
  impl_->BuildEnvironment(environment);
  const std::string overlap = impl_->FindOverlap();
  if (overlap.empty()) {
    impl_->built_environment = environment;
    if (!impl_->RestAllowed()) {  // free objects now: they may move and push the arm
      impl_->at_rest = false;
      impl_->quiet_steps = 0;
    }
    return;
  }
  impl_->ClearEnvironment();
  impl_->BuildEnvironment(previous);
  throw std::invalid_argument(overlap + " where the arm stands now");
}

void ArmWorld::ReplaceModel(const core::RobotModel& model) {
  const core::RobotModel& old = impl_->model;
  if (model.num_joints() != old.num_joints()) {
    throw std::invalid_argument("the new model has " + std::to_string(model.num_joints()) +
                                " joints; the running arm has " + std::to_string(old.num_joints()));
  }
  if (model.servo_tick_s != old.servo_tick_s) {
    throw std::invalid_argument("the new model's servo tick is " +
                                FormatNumber(model.servo_tick_s) + " s; the running arm's is " +
                                FormatNumber(old.servo_tick_s) + " s");
  }
  const core::ArmState state = impl_->State();
  auto rebuilt = std::make_unique<Impl>(model, impl_->built_environment, impl_->options);
  rebuilt->tick = impl_->tick;
  rebuilt->Teleport(state.position, state.velocity, false);  // throws outside the new limits
  // The free objects stay where they are, moving as they were (the environment is the same, so
  // the objects come in the same order).
  for (size_t i = 0; i < rebuilt->objects.size() && i < impl_->objects.size(); ++i) {
    const dBodyID from = impl_->objects[i].body;
    const dBodyID to = rebuilt->objects[i].body;
    if (from == nullptr || to == nullptr) continue;
    const dReal* position = dBodyGetPosition(from);
    dBodySetPosition(to, position[0], position[1], position[2]);
    dBodySetQuaternion(to, dBodyGetQuaternion(from));
    const dReal* linear = dBodyGetLinearVel(from);
    dBodySetLinearVel(to, linear[0], linear[1], linear[2]);
    const dReal* angular = dBodyGetAngularVel(from);
    dBodySetAngularVel(to, angular[0], angular[1], angular[2]);
  }
  const std::string overlap = rebuilt->FindOverlap();
  if (!overlap.empty()) throw std::invalid_argument(overlap + " where the arm stands now");
  impl_ = std::move(rebuilt);
}

void ArmWorld::Step(const core::ArmCommand& command) { impl_->Step(command); }

core::ArmState ArmWorld::State() const { return impl_->State(); }

Eigen::Isometry3d ArmWorld::LinkBodyPose(int link) const {
  if (link < 1 || link > impl_->model.num_joints()) {
    throw std::out_of_range("link " + std::to_string(link) + ": allowed 1.." +
                            std::to_string(impl_->model.num_joints()));
  }
  dBodyID body = impl_->bodies[static_cast<size_t>(link - 1)];
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = FromOde(dBodyGetRotation(body));
  pose.translation() = FromOdeVector(dBodyGetPosition(body));
  return pose;
}

Eigen::Vector3d ArmWorld::LinkLinearVelocity(int link) const {
  LinkBodyPose(link);  // range check
  return FromOdeVector(dBodyGetLinearVel(impl_->bodies[static_cast<size_t>(link - 1)]));
}

Eigen::Vector3d ArmWorld::LinkAngularVelocity(int link) const {
  LinkBodyPose(link);
  return FromOdeVector(dBodyGetAngularVel(impl_->bodies[static_cast<size_t>(link - 1)]));
}

std::vector<ObjectPose> ArmWorld::ObjectPoses() const {
  std::vector<ObjectPose> poses;
  for (const Impl::Object& object : impl_->objects) {
    ObjectPose pose;
    pose.name = object.name;
    pose.pose.linear() = FromOde(dGeomGetRotation(object.geom));
    pose.pose.translation() = FromOdeVector(dGeomGetPosition(object.geom));
    poses.push_back(pose);
  }
  return poses;
}

const std::vector<std::string>& ArmWorld::Omissions() const { return impl_->omissions; }

int ArmWorld::LastStepRows() const { return impl_->last_rows; }
int ArmWorld::LastStepArmContacts() const { return impl_->arm_contacts; }

bool ArmWorld::AtRest() const { return impl_->at_rest; }

int64_t ArmWorld::RestTicks() const { return impl_->rest_ticks; }

}  // namespace sirupp::sim
