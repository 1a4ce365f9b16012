#include "bench/mujoco_arm.hpp"

#include <mujoco/mujoco.h>

#include <chrono>
#include <cstddef>
#include <cstdio>
#include <cstring>
#include <memory>
#include <stdexcept>

#include "bench/reference_motion.hpp"
#include "core/model_export.hpp"

namespace sirupp::bench {

namespace {

// Frees a VFS and everything in it when it goes out of scope.
struct VfsDeleter {
  void operator()(mjVFS* vfs) const {
    mj_deleteVFS(vfs);
    delete vfs;
  }
};

}  // namespace

std::string MujocoXmlFromModel(const core::RobotModel& model, double step_s, bool with_friction) {
  core::MjcfOptions options;
  options.timestep_s = step_s;
  options.joint_friction = with_friction;
  options.geoms = false;
  options.contacts = false;
  options.actuators = false;
  return core::ExportMjcf(model, options);
}

MujocoArm::MujocoArm(const core::RobotModel& model, double step_s, bool with_friction) {
  const std::string xml = MujocoXmlFromModel(model, step_s, with_friction);
  // MuJoCo 2.2 reads an XML "file" from its virtual file system, so nothing touches the disk.
  const std::unique_ptr<mjVFS, VfsDeleter> vfs(new mjVFS);
  mj_defaultVFS(vfs.get());
  const char* file_name = "sirupp_arm.xml";
  if (mj_makeEmptyFileVFS(vfs.get(), file_name, static_cast<int>(xml.size())) != 0) {
    throw std::runtime_error("MuJoCo: cannot make a virtual file for the model XML");
  }
  const int file = mj_findFileVFS(vfs.get(), file_name);
  if (file < 0) throw std::runtime_error("MuJoCo: virtual model XML file not found");
  std::memcpy(vfs->filedata[file], xml.data(), xml.size());

  char error[1024] = "";
  model_ = mj_loadXML(file_name, vfs.get(), error, sizeof error);
  if (model_ == nullptr) {
    throw std::runtime_error(std::string("MuJoCo rejected the model of ") + model.name + ": " +
                             error);
  }
  data_ = mj_makeData(model_);
  if (data_ == nullptr) {
    mj_deleteModel(model_);
    throw std::runtime_error("MuJoCo: mj_makeData failed");
  }

  const int n = model.num_joints();
  const core::ExportNames names = core::MakeExportNames(model);
  for (int link = 0; link <= n; ++link) {
    const std::string& name = names.links[static_cast<size_t>(link)];
    body_ids_.push_back(mj_name2id(model_, mjOBJ_BODY, name.c_str()));
  }
  bool consistent = model_->njnt == n && model_->nv == n && model_->nq == n;
  for (int j = 0; consistent && j < n; ++j) {
    // Joints are numbered in tree order, so MuJoCo joint j belongs to body link j+1.
    consistent = body_ids_[static_cast<size_t>(j) + 1] >= 0 &&
                 model_->jnt_bodyid[j] == body_ids_[static_cast<size_t>(j) + 1];
    joint_ids_.push_back(j);
    dof_indices_.push_back(model_->jnt_dofadr[j]);
    qpos_indices_.push_back(model_->jnt_qposadr[j]);
  }
  if (!consistent || body_ids_[0] < 0) {
    mj_deleteData(data_);
    mj_deleteModel(model_);
    throw std::runtime_error("MuJoCo model of " + model.name +
                             " does not have one body per link and one joint per SIRUPP joint");
  }
  SetPositions(std::vector<double>(static_cast<size_t>(n), 0.0));
}

MujocoArm::~MujocoArm() {
  mj_deleteData(data_);
  mj_deleteModel(model_);
}

void MujocoArm::SetPositions(const std::vector<double>& q) {
  if (static_cast<int>(q.size()) != num_joints()) {
    throw std::invalid_argument("MujocoArm::SetPositions: wrong number of joint positions");
  }
  for (int j = 0; j < num_joints(); ++j) {
    data_->qpos[QposIndex(j)] = q[static_cast<size_t>(j)];
  }
  for (int k = 0; k < model_->nv; ++k) {
    data_->qvel[k] = 0;
    data_->qfrc_applied[k] = 0;
  }
  mj_forward(model_, data_);
}

void MujocoArm::Step(const std::vector<double>& effort) {
  if (static_cast<int>(effort.size()) != num_joints()) {
    throw std::invalid_argument("MujocoArm::Step: wrong number of joint efforts");
  }
  for (int j = 0; j < num_joints(); ++j) {
    data_->qfrc_applied[DofIndex(j)] = effort[static_cast<size_t>(j)];
  }
  mj_step(model_, data_);
}

std::vector<double> MujocoArm::Positions() const {
  std::vector<double> q(static_cast<size_t>(num_joints()));
  for (int j = 0; j < num_joints(); ++j) q[static_cast<size_t>(j)] = data_->qpos[QposIndex(j)];
  return q;
}

std::vector<double> MujocoArm::Velocities() const {
  std::vector<double> qd(static_cast<size_t>(num_joints()));
  for (int j = 0; j < num_joints(); ++j) qd[static_cast<size_t>(j)] = data_->qvel[DofIndex(j)];
  return qd;
}

Eigen::Isometry3d MujocoArm::BodyComPose(int link) const {
  const int body = BodyId(link);
  // xmat is the body (= DH) frame's rotation, row-major; xipos its centre of mass (ximat would
  // be the principal axes, which are not the DH axes).
  const mjtNum* m = data_->xmat + 9 * static_cast<ptrdiff_t>(body);
  const mjtNum* p = data_->xipos + 3 * static_cast<ptrdiff_t>(body);
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() << m[0], m[1], m[2], m[3], m[4], m[5], m[6], m[7], m[8];
  pose.translation() = Eigen::Vector3d(p[0], p[1], p[2]);
  return pose;
}

double MujocoArm::time() const { return data_->time; }

double MujocoStepsPerSecond(const core::RobotModel& model, double step_s, bool with_friction,
                            double seconds_to_run) {
  MujocoArm arm(model, step_s, with_friction);
  arm.SetPositions(ReferencePosition(model, 0.0));
  using Clock = std::chrono::steady_clock;
  const auto start = Clock::now();
  const auto stop = start + std::chrono::duration<double>(seconds_to_run);
  long long steps = 0;
  auto now = start;
  do {
    // The clock is read every 256 steps so that reading it costs nothing measurable.
    for (int k = 0; k < 256; ++k) {
      arm.Step(ReferenceEffort(model, arm.time(), arm.Positions(), arm.Velocities()));
    }
    steps += 256;
    now = Clock::now();
  } while (now < stop);
  return static_cast<double>(steps) / std::chrono::duration<double>(now - start).count();
}

std::string MujocoVersion() { return mj_versionString(); }

}  // namespace sirupp::bench
