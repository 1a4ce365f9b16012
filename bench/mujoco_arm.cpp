#include "bench/mujoco_arm.hpp"

#include <mujoco/mujoco.h>

#include <chrono>
#include <cstddef>
#include <cstdio>
#include <cstring>
#include <memory>
#include <sstream>
#include <stdexcept>

#include "bench/reference_motion.hpp"
#include "core/kinematics.hpp"

namespace sirupp::bench {

namespace {

// Shortest text that reads back as the same double, so MuJoCo sees exactly our numbers.
std::string Num(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%.17g", value == 0 ? 0.0 : value);  // no "-0"
  return text;
}

std::string Vec(const Eigen::Vector3d& v) {
  return Num(v.x()) + " " + Num(v.y()) + " " + Num(v.z());
}

std::string Quat(const Eigen::Matrix3d& rotation) {
  const Eigen::Quaterniond q(rotation);
  return Num(q.w()) + " " + Num(q.x()) + " " + Num(q.y()) + " " + Num(q.z());
}

std::string Escape(const std::string& text) {
  std::string out;
  for (const char c : text) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      case '\'':
        out += "&apos;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

// <inertial> of a link: centre of mass and mass, and the full inertia about the centre of mass in
// the link's (= body's) axes. MuJoCo diagonalizes it itself; fullinertia keeps the off-diagonal
// terms. MuJoCo's order is Ixx Iyy Izz Ixy Ixz Iyz.
std::string Inertial(const core::Link& link) {
  const Eigen::Matrix3d& i = link.inertia_kg_m2;
  return "<inertial pos=\"" + Vec(link.com_m) + "\" mass=\"" + Num(link.mass_kg) +
         "\" fullinertia=\"" + Num(i(0, 0)) + " " + Num(i(1, 1)) + " " + Num(i(2, 2)) + " " +
         Num(i(0, 1)) + " " + Num(i(0, 2)) + " " + Num(i(1, 2)) + "\"/>";
}

std::string BodyName(size_t link) { return "link" + std::to_string(link); }

// Frees a VFS and everything in it when it goes out of scope.
struct VfsDeleter {
  void operator()(mjVFS* vfs) const {
    mj_deleteVFS(vfs);
    delete vfs;
  }
};

}  // namespace

std::string MujocoXmlFromModel(const core::RobotModel& model, double step_s, bool with_friction) {
  std::ostringstream xml;
  const std::string pad = "  ";
  xml << "<mujoco model=\"" << Escape(model.name) << "\">\n"
      << pad << "<!-- SIRUPP robot model " << Escape(model.source_file)
      << " for the physics benchmark; body linkI is DH frame I, joint qpos is the SIRUPP q. -->\n"
      // No geoms: inertia comes only from the <inertial> elements, never balanced or altered.
      // fusestatic off keeps the fixed base as its own body, so body ids follow the links.
      << pad
      << "<compiler angle=\"radian\" balanceinertia=\"false\" inertiafromgeom=\"false\" "
         "fusestatic=\"false\"/>\n"
      << pad << "<option timestep=\"" << Num(step_s) << "\" gravity=\"" << Vec(model.gravity_m_s2)
      << "\" integrator=\"Euler\">\n"
      << pad << pad << "<flag contact=\"disable\"/>\n"
      << pad << "</option>\n"
      << pad << "<worldbody>\n";

  std::string indent = pad + pad;
  const Eigen::Isometry3d base = model.base.ToIsometry();
  xml << indent << "<body name=\"" << BodyName(0) << "\" pos=\"" << Vec(base.translation())
      << "\" quat=\"" << Quat(base.linear()) << "\">\n";
  // The base is welded to the world, so its mass changes nothing; it is kept for completeness.
  if (model.links[0].mass_kg > 0) xml << indent << pad << Inertial(model.links[0]) << "\n";

  for (size_t j = 0; j < model.joints.size(); ++j) {
    const core::Joint& joint = model.joints[j];
    const core::Link& link = model.links[j + 1];
    indent += pad;
    // Body j+1 sits at DH frame j+1 relative to DH frame j, at the build pose q = 0.
    const Eigen::Isometry3d step = core::DhTransform(model.dh_convention, joint, 0.0);
    const Eigen::Matrix3d& r = step.linear();
    // The joint axis in body coordinates. Standard DH: joint j+1 moves about (or along) z of the
    // parent frame through its origin: axis = R^T z, anchor = -R^T p. Modified DH: about z of the
    // body's own frame through its origin. Turning the body about that line by q (or sliding it
    // by q) gives exactly the DH transform at q, since Rz and Tz commute with each other.
    Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();
    Eigen::Vector3d anchor = Eigen::Vector3d::Zero();
    if (model.dh_convention == core::DhConvention::kStandard) {
      axis = r.transpose() * Eigen::Vector3d::UnitZ();
      anchor = -(r.transpose() * step.translation());
    }
    const bool revolute = joint.type == core::JointType::kRevolute;
    xml << indent << "<body name=\"" << BodyName(j + 1) << "\" pos=\"" << Vec(step.translation())
        << "\" quat=\"" << Quat(r) << "\">\n";
    // ref = 0: the model is built at q = 0, so qpos is the SIRUPP joint variable q.
    xml << indent << pad << "<joint name=\"" << Escape(joint.name) << "\" type=\""
        << (revolute ? "hinge" : "slide") << "\" pos=\"" << Vec(anchor) << "\" axis=\"" << Vec(axis)
        << "\" ref=\"0\" limited=\"true\" range=\"" << Num(joint.position_min) << " "
        << Num(joint.position_max) << "\" armature=\"" << Num(joint.armature) << "\" damping=\""
        << Num(joint.friction.viscous) << "\"";
    // MuJoCo has one symmetric dry-friction level per joint (a frictionloss constraint): we give
    // it the positive-direction Coulomb level. The negative level, the static break-away effort
    // and the Stribeck decay of the SIRUPP friction model have no MuJoCo counterpart.
    if (with_friction) xml << " frictionloss=\"" << Num(joint.friction.coulomb_positive) << "\"";
    xml << "/>\n";
    xml << indent << pad << Inertial(link) << "\n";
  }
  for (size_t j = model.joints.size() + 1; j-- > 0;) {
    xml << pad << pad << std::string(2 * j, ' ') << "</body>\n";
  }
  xml << pad << "</worldbody>\n"
      << "</mujoco>\n";
  return xml.str();
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
  for (int link = 0; link <= n; ++link) {
    const int id = mj_name2id(model_, mjOBJ_BODY, BodyName(static_cast<size_t>(link)).c_str());
    body_ids_.push_back(id);
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
