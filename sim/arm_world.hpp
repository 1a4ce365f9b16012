#pragma once
// The virtual robot in ODE: one rigid body per link, one hinge (or slider) per joint, joint
// friction with exact sticking, joint and torque limits, optional rotor inertia, and the
// environment's objects with contacts. No LCM here: SimNode (sim_node.hpp) feeds it commands and
// publishes its state; tests and benchmarks drive it directly. The physics are described in
// docs/physics.md.
//
// Frames and conventions: every body sits at its link's centre of mass with the axes of the link's
// DH frame (so the model's inertia tensor applies unchanged). Joint positions are reported in the
// model's DH convention, unwrapped (a revolute joint may read beyond +-pi), and every position
// limit is enforced whatever its range.
//
// Not thread-safe: one ArmWorld is used by one thread at a time. Several worlds may exist at once.

#include <Eigen/Geometry>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/arm_state.hpp"
#include "core/environment.hpp"
#include "core/robot_model.hpp"

namespace sirupp::sim {

struct WorldOptions {
  double step_s = 0;     // physics step; 0 = the model's servo tick (PIC-SERVO SC: 0.512 ms)
  bool friction = true;  // joint friction from the model (static, Coulomb, viscous)
  bool armature = true;  // the model's rotor inertia, added to each joint's child link
  bool contacts = true;  // contacts between the arm and the environment's objects
  double erp = 0.2;      // ODE error reduction for joints and limits (0..1)
  double cfm = 1e-10;    // ODE constraint force mixing (softness), >= 0
  // A joint whose speed ends a step below this counts as stuck (static friction holds it).
  double stick_speed = 1e-6;  // rad/s or m/s
  // Keep every joint's friction row even while it slides (slower; the default gives the same
  // motion with fewer constraint rows, see docs/physics.md). For tests and comparisons.
  bool always_friction_rows = false;
  // Rest: once every joint has been held (stuck in static friction, or braked) below stick_speed
  // for kRestSteps steps under one unchanged command, the arm is kept exactly still, without
  // stepping, until the command changes or the arm is teleported. Without it a held arm trembles
  // in the last bits of its state, so a move's result would depend on the tick it started at
  // (docs/physics.md, "Rest"). Never with free environment objects.
  bool rest = true;
};

// The world pose of one environment object (free objects move; static ones never do).
struct ObjectPose {
  std::string name;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
};

class ArmWorld {
 public:
  // Builds the arm at the model's home positions (all joints at rest) and the environment's objects
  // at their poses. Throws std::invalid_argument naming the bad value if the model cannot be
  // simulated (it is expected to have passed core::FindModelProblem) or an option is out of range.
  ArmWorld(const core::RobotModel& model, const core::Environment& environment,
           const WorldOptions& options = {});
  ~ArmWorld();
  ArmWorld(const ArmWorld&) = delete;
  ArmWorld& operator=(const ArmWorld&) = delete;

  const core::RobotModel& model() const;
  double step_s() const;
  int64_t tick() const;
  double time_s() const;

  // Teleports the arm: joint positions (within limits) and velocities (empty = at rest). Friction
  // starts stuck for joints at rest. Time goes on; free objects stay where they are unless
  // `reset_objects`, which puts them back at their start poses, at rest. Throws
  // std::invalid_argument naming the joint, the bad value and the allowed range.
  void SetJointState(const std::vector<double>& position, const std::vector<double>& velocity = {},
                     bool reset_objects = false);

  // Replaces the environment's objects with `environment`'s, between two steps: the arm, its
  // joints, time and friction state are untouched. Throws std::invalid_argument naming the object
  // and the link when a new object would overlap the arm where it stands (deeper than 1 mm); the
  // old objects are then put back as they were built (free objects at their start poses).
  void ReplaceEnvironment(const core::Environment& environment);

  // Rebuilds the arm from `model` between two steps, with the same options and environment, at
  // the joints' present positions and speeds; time goes on, and the free objects keep their
  // present poses and velocities. Throws std::invalid_argument, the world unchanged, when `model`
  // has another number of joints or servo tick, cannot be simulated, a joint stands outside its new
  // limits (naming the joint, its position and the limits) or an object would overlap the new arm.
  void ReplaceModel(const core::RobotModel& model);

  // Advances one step under `command`: efforts (clamped to each joint's effort_max) in
  // kEffort mode, every joint braked still in kHold, no actuator effort in kLimp. Throws
  // std::invalid_argument if the command's joint count is wrong or an effort is not finite; the
  // world is then unchanged. Throws std::runtime_error naming the joint if the integration blew up
  // (a non-finite position or speed); the world is then unusable.
  void Step(const core::ArmCommand& command);

  // The state after the last step (or teleport): utime = tick * step, source kSim, effort = the
  // actuator effort applied in the last step after limits, flags = arm_state_t::FLAG_* bits.
  core::ArmState State() const;

  // World pose of link i's body (1..n): position of its centre of mass, axes of its DH frame.
  Eigen::Isometry3d LinkBodyPose(int link) const;
  // World linear velocity of link i's centre of mass and its angular velocity.
  Eigen::Vector3d LinkLinearVelocity(int link) const;
  Eigen::Vector3d LinkAngularVelocity(int link) const;
  // Current poses of the environment's objects, in file order.
  std::vector<ObjectPose> ObjectPoses() const;
  // Names of model features this engine cannot represent and leaves out (e.g. armature on a
  // prismatic joint); empty when everything is simulated.
  const std::vector<std::string>& Omissions() const;
  // True while the arm is at rest (see WorldOptions::rest); State() then flags every joint
  // FLAG_AT_REST. Ticks spent at rest so far.
  bool AtRest() const;
  int64_t RestTicks() const;
  // Constraint rows ODE solved in the last step (hinge rows + friction, limit and contact rows);
  // the step's cost grows with the cube of this count.
  int LastStepRows() const;
  // Contacts between the arm and the environment's objects that the last step created (0 when
  // the arm touches nothing). They come from the same primitive tests as the planner's collision
  // model (planning/narrow_phase.hpp).
  int LastStepArmContacts() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace sirupp::sim
