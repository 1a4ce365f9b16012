#pragma once
// A robot model written as URDF or MJCF, for other tools (ROS, MoveIt, Drake, PyBullet, MuJoCo):
// links with mass, centre of mass and inertia; joints with limits, effort, velocity, friction and
// armature; visual and collision shapes; the base and tool poses. Pure functions of the model.
// What goes where, and what cannot be said in each format: docs/export.md.
//
// Frames. MJCF: body i is DH frame i, so inertials and geoms keep the model's numbers; each joint
// is placed on its DH axis (z of frame i-1 in standard DH, z of frame i in modified DH). URDF
// rotates (or slides) a child link about an axis through the child link's own origin, which DH
// frame i is not in standard DH when a_i != 0. URDF link i is therefore the frame joint i moves:
// DH frame i itself in modified DH; in standard DH, DH frame i-1 turned by theta_i and moved by
// d_i along z_(i-1), with DH frame i = URDF link i * Tx(a_i) Rx(alpha_i) (UrdfLinkToDhFrame).
// Either way the exported chain gives exactly our forward kinematics at every q.

#include <Eigen/Geometry>
#include <string>

#include "core/robot_model.hpp"

namespace sirupp::core {

struct MjcfOptions {
  double timestep_s = 0;       // <option timestep>; 0 = the model's servo tick
  bool joint_friction = true;  // damping (viscous) and frictionloss (Coulomb); false: neither
  bool armature = true;        // joint armature (rotor inertia)
  bool geoms = true;           // the links' shapes as geoms (drawn, and colliding with the world)
  bool contacts = true;        // false: <flag contact="disable"/>
  bool actuators = true;       // one motor per joint, ctrlrange = +-max effort
};

// URDF 1.0 text; root link "world", one fixed joint to the base at the model's base pose, a fixed
// "tool" link at the tool pose; armature as Drake's <drake:rotor_inertia> and <drake:gear_ratio>
// in a <transmission> (reflected inertia = rotor inertia * gear ratio^2).
std::string ExportUrdf(const RobotModel& model);

// MJCF text for MuJoCo 2.2 or later; one motor per joint (ctrlrange = +-max effort) and a site
// "tool" at the tool pose.
std::string ExportMjcf(const RobotModel& model, const MjcfOptions& options = {});

// The pose of DH frame `link` (0..n) in URDF link `link`'s frame: identity for modified DH and
// for the base, Tx(a) Rx(alpha) of that joint for standard DH.
Eigen::Isometry3d UrdfLinkToDhFrame(const RobotModel& model, int link);

// Names used in the exported files for the model's links and joints, made unique and kept clear of
// the names the export adds ("world", "tool"): links()[i] for link i (0 = base), then the tool.
struct ExportNames {
  std::vector<std::string> links;   // one per model link, then the tool link / site
  std::vector<std::string> joints;  // one per model joint
  std::string world = "world";
};
ExportNames MakeExportNames(const RobotModel& model);

}  // namespace sirupp::core
