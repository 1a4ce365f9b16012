#pragma once
// A SIRUPP robot model as a MuJoCo 2.2 model, the peer of the physics benchmark. MuJoCo is never a
// dependency of the project: this file is compiled only when CMake finds MuJoCo (it then defines
// SIRUPP_HAVE_MUJOCO for the targets that link sirupp_bench_mujoco).
//
// The MJCF is `sirupp model export --mjcf` (core/model_export.hpp) without geoms, contacts or
// actuators: one nested body per link whose frame is the link's DH frame (the base, DH frame 0, at
// model.base). MuJoCo joint j is SIRUPP joint j, and its qpos is the SIRUPP joint variable q_j (the
// model is built at q = 0). Efforts are applied as generalized forces (qfrc_applied).

#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "core/robot_model.hpp"

struct mjModel_;
struct mjData_;

namespace sirupp::bench {

// MJCF text of `model`: Euler integrator with time step `step_s`, the model's gravity, contacts
// off, joint limits, armature and viscous damping; with `with_friction` also each joint's dry
// friction as MuJoCo's frictionloss (the mean Coulomb level; docs/export.md says what that leaves
// out).
std::string MujocoXmlFromModel(const core::RobotModel& model, double step_s, bool with_friction);

class MujocoArm {
 public:
  // Builds and compiles the MJCF of `model` in memory; throws std::runtime_error with MuJoCo's
  // message when MuJoCo rejects it. Starts at q = 0, at rest, time 0.
  MujocoArm(const core::RobotModel& model, double step_s, bool with_friction);
  ~MujocoArm();
  MujocoArm(const MujocoArm&) = delete;
  MujocoArm& operator=(const MujocoArm&) = delete;

  int num_joints() const { return static_cast<int>(joint_ids_.size()); }

  // Puts the arm at positions q (rad or m, one per joint), at rest, and updates every derived
  // quantity (poses, mass matrix, forces); time is kept.
  void SetPositions(const std::vector<double>& q);
  // One mj_step with `effort` (N*m or N, one per joint) applied at the joints.
  void Step(const std::vector<double>& effort);

  std::vector<double> Positions() const;
  std::vector<double> Velocities() const;
  // World pose of link `link`'s centre-of-mass frame (0 = base): the DH frame's rotation, placed
  // at the link's centre of mass. Valid after SetPositions (after Step it is the pose at the
  // start of that step, as MuJoCo computes kinematics before integrating).
  Eigen::Isometry3d BodyComPose(int link) const;
  double time() const;

  // The MuJoCo objects, for checks that call MuJoCo directly (mj_inverse, energy, options).
  const mjModel_* model() const { return model_; }
  mjModel_* mutable_model() { return model_; }
  mjData_* data() const { return data_; }
  int BodyId(int link) const { return body_ids_[static_cast<size_t>(link)]; }
  int JointId(int joint) const { return joint_ids_[static_cast<size_t>(joint)]; }
  int DofIndex(int joint) const { return dof_indices_[static_cast<size_t>(joint)]; }
  int QposIndex(int joint) const { return qpos_indices_[static_cast<size_t>(joint)]; }

 private:
  mjModel_* model_ = nullptr;
  mjData_* data_ = nullptr;
  std::vector<int> body_ids_;      // per link 0..n
  std::vector<int> joint_ids_;     // per joint
  std::vector<int> dof_indices_;   // per joint, into qvel / qfrc_*
  std::vector<int> qpos_indices_;  // per joint, into qpos
};

// mj_step calls per wall-clock second (std::chrono::steady_clock) while the arm follows the
// reference motion of bench/reference_motion.hpp for `seconds_to_run` of wall time, starting at
// rest at the reference's start positions. Model building is not timed; the controller is (it is
// the same for every engine).
double MujocoStepsPerSecond(const core::RobotModel& model, double step_s, bool with_friction,
                            double seconds_to_run);

// MuJoCo's version string (e.g. "2.2.2").
std::string MujocoVersion();

}  // namespace sirupp::bench
