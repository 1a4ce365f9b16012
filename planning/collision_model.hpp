#pragma once
// One collision model of an arm in its world, for everything that asks "does the arm touch
// something here?": the planner, `sirupp plan check`, the panel, Python, grading and the sim's
// contacts (sim/arm_world.cpp creates its contacts through planning/narrow_phase.hpp, the same
// primitive tests). Reads a core::RobotModel (the links' shapes) and a core::Environment (its
// objects: static ones where the file puts them, free ones where SetObjectPose last put them);
// writes nothing. SI units, world frame.
//
// What is tested:
//   - every arm shape against every object (the arm's shapes grown by `padding_m`: boxes by the
//     padding on every side, cylinders and capsules in radius and at both ends, spheres in radius;
//     objects as they are);
//   - the arm against itself: every pair of links that are not adjacent (i, j >= i + 2), without
//     padding, except the pairs that overlap at the model's home pose, in every one of a fixed
//     sample of states (built into the links' housings) or in none of them (they cannot meet
//     within the joint limits): SelfPairs() lists what is checked, SkippedSelfPairs() the rest.
// Primitive pairs go to ODE's own tests, except box against cylinder, where ODE 0.16 misses a
// cylinder passing through a thin box: that pair uses this library's exact convex test
// (narrow_phase.hpp), so nothing the shapes overlap by is missed.
//
// Not thread-safe: one CollisionModel per thread (they may share nothing; build one per thread).

#include <Eigen/Geometry>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "core/environment.hpp"
#include "core/kinematics.hpp"
#include "core/robot_model.hpp"

namespace sirupp::planning {

using core::JointVector;

struct CollisionOptions {
  double padding_m = 0;        // added around the arm's shapes against objects, >= 0, <= 0.1
  bool self_collision = true;  // check non-adjacent link pairs (SelfPairs)
  // Random states (within the limits, a fixed seed) that decide which non-adjacent link pairs
  // are checked: a pair touching in every one is built into the housings, a pair touching in none
  // cannot meet within the limits (MoveIt's Setup Assistant rule: "never in collision"); both are
  // left out. 0 = check every non-adjacent pair not overlapping at home. 0 to 1 000 000.
  int self_pair_samples = 10000;
};

// What a contact is with.
enum class ContactKind {
  kStaticObject,  // a fixed object of the environment (a table): passing through it is an error
  kFreeObject,    // a free object (a block to push): touching it is allowed, and reported
  kSelf,          // two links of the arm
};
const char* ContactKindName(ContactKind kind);  // "static object", "free object", "self"

// Which contacts a check counts. Default: all of them.
struct CheckFilter {
  bool static_objects = true;
  bool free_objects = true;
  bool self = true;
  static CheckFilter StaticAndSelf() { return {true, false, true}; }
};

// One touching pair: an arm link's shape and an object's shape (or another link's shape).
struct Contact {
  ContactKind kind = ContactKind::kStaticObject;
  int link = 0;          // 0 = the base, 1..n = link i (model.links index)
  int shape = 0;         // index in model.links[link].shapes
  int other_link = -1;   // kSelf: the other link (> link), else -1
  int other_shape = -1;  // kSelf: its shape index, else -1
  int object = -1;       // kStaticObject / kFreeObject: index in environment.objects, else -1
  double depth_m = 0;    // how far the two overlap (the arm's padding included); >= 0
  Eigen::Vector3d point_m = Eigen::Vector3d::Zero();  // a world point where they overlap
};

// The result of checking a straight joint-space segment at a resolution.
struct EdgeCheck {
  bool free = true;
  double fraction = 1;  // where the first touching state lies (0..1); 1 when free
  JointVector state;    // that state (empty when free)
  std::optional<Contact> contact;
  int states_checked = 0;
};

class CollisionModel {
 public:
  // Throws std::invalid_argument naming the bad value (padding out of range, a model without one
  // link per joint plus the base).
  CollisionModel(const core::RobotModel& model, const core::Environment& environment,
                 const CollisionOptions& options = {});
  ~CollisionModel();
  CollisionModel(const CollisionModel&) = delete;
  CollisionModel& operator=(const CollisionModel&) = delete;
  CollisionModel(CollisionModel&&) noexcept;
  CollisionModel& operator=(CollisionModel&&) noexcept;

  const core::RobotModel& model() const;
  const core::Environment& environment() const;  // objects at their file poses
  const CollisionOptions& options() const;
  int num_joints() const;

  // Moves a free object to where it is now (e.g. from the sim's ObjectPoses). Throws
  // std::invalid_argument for an unknown name or a static object.
  void SetObjectPose(const std::string& object_name, const Eigen::Isometry3d& pose);
  // The padding of the arm against objects (m, 0..0.1); throws std::invalid_argument otherwise.
  void SetPadding(double padding_m);

  // True when the arm at q touches nothing the filter counts. q: num_joints() entries (rad / m);
  // throws std::invalid_argument for another count or a non-finite value.
  bool IsFree(const JointVector& q, const CheckFilter& filter = {});
  // The first touching pair found (statics, then free objects, then self), or nullopt.
  std::optional<Contact> FirstContact(const JointVector& q, const CheckFilter& filter = {});
  // The kind of the first touching pair (the order of FirstContact), without its depth: cheaper.
  std::optional<ContactKind> FirstContactKind(const JointVector& q, const CheckFilter& filter = {});
  // Every touching shape pair, with its depth (the deepest point of the pair).
  std::vector<Contact> Contacts(const JointVector& q, const CheckFilter& filter = {});

  // The straight segment from `from` to `to`, checked at states no joint of which is more than
  // `step_rad` (rad, or m for prismatic joints) from the previous one, `from` and `to` included,
  // in order: the first touching state is reported. step_rad > 0.
  EdgeCheck CheckEdge(const JointVector& from, const JointVector& to, double step_rad,
                      const CheckFilter& filter = {});
  // The same states, in bisection order (finds a touching state sooner); `from` is not checked
  // (the planner's motion validator: OMPL has checked it already).
  bool EdgeFree(const JointVector& from, const JointVector& to, double step_rad,
                const CheckFilter& filter = {});

  // States checked since construction or the last ResetCounter (every IsFree, FirstContact,
  // Contacts and each state of an edge).
  uint64_t states_checked() const;
  void ResetCounter();

  // The link pairs checked for self-collision (first < second), and those left out with why
  // ("adjacent" is not listed; "overlap at home", "overlap in every sampled state").
  const std::vector<std::pair<int, int>>& SelfPairs() const;
  struct SkippedPair {
    int first = 0, second = 0;
    std::string why;
  };
  const std::vector<SkippedPair>& SkippedSelfPairs() const;

  // "link 3 (forearm) touches static object 'table_top' by 4.2 mm at (0.412, 0.003, 0.118) m";
  // self: "link 2 (upper_arm) touches link 5 (wrist_pitch) by ...".
  std::string Describe(const Contact& contact) const;
  // The name of a link ("link 3 (forearm)") or object ("static object 'table_top'").
  std::string LinkName(int link) const;
  std::string ObjectName(int object) const;

  // World poses of the arm's shapes at q (links[i].shapes order, links 0..n), unpadded: what the
  // checks above see (for drawing and tests).
  std::vector<std::vector<Eigen::Isometry3d>> ShapePoses(const JointVector& q) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// A C-space slice: joints `joint_a` and `joint_b` (0-based) on a grid over their limits, every
// other joint fixed at `q`'s value. cells[ib * values_a.size() + ia] is what the arm touches at
// (values_a[ia], values_b[ib]): 0 free, 1 a static object, 2 a free object (only), 3 itself
// (only). The first and last grid values are the joints' limits.
struct CSpaceSlice {
  int joint_a = 0, joint_b = 1;
  std::vector<double> values_a, values_b;  // rad (m for prismatic joints)
  std::vector<uint8_t> cells;
  double seconds = 0;  // time taken
  int free_count() const;
};
inline constexpr uint8_t kCellFree = 0, kCellStatic = 1, kCellFreeObject = 2, kCellSelf = 3;

// step_rad: the grid spacing (> 0, at most 1 rad; 1 degree = 0.01745). Throws
// std::invalid_argument naming a bad joint, step or q.
CSpaceSlice ComputeCSpaceSlice(CollisionModel& model, const JointVector& q, int joint_a,
                               int joint_b, double step_rad, const CheckFilter& filter = {});

}  // namespace sirupp::planning
