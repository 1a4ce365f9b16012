#pragma once
// The robot model: an immutable description of a serial arm built once from config/robots/*.yaml
// (or received as robot_model_t) and shared read-only by every component. SI units throughout:
// metres, radians, kilograms, seconds, N*m. Link i is rigidly attached to DH frame i; links[0] is
// the fixed base.

#include <optional>
#include <string>
#include <vector>

#include "core/geometry.hpp"

namespace sirupp::core {

enum class DhConvention {
  kStandard,  // distal (Paul): A_i = Rz(theta_i) Tz(d_i) Tx(a_i) Rx(alpha_i); joint i about z_(i-1)
  kModified,  // proximal (Craig): A_i = Rx(alpha_(i-1)) Tx(a_(i-1)) Rz(theta_i) Tz(d_i); joint i
              // about z_i
};
enum class JointType { kRevolute, kPrismatic };

const char* DhConventionName(DhConvention convention);
const char* JointTypeName(JointType type);

// One DH row. For a revolute joint theta = q + theta_rad; for a prismatic joint d = q + d_m.
struct DhRow {
  double a_m = 0;
  double alpha_rad = 0;
  double d_m = 0;
  double theta_rad = 0;
};

// Joint friction at the joint (link side). Units: N*m and rad for revolute, N and m for prismatic.
struct Friction {
  double static_effort = 0;         // break-away effort while sticking (>= both Coulomb levels)
  double coulomb_positive = 0;      // sliding friction magnitude while moving positive
  double coulomb_negative = 0;      // sliding friction magnitude while moving negative
  double viscous = 0;               // effort per unit speed
  double stribeck_velocity = 0.01;  // speed over which static decays to Coulomb (> 0)
};

// The PIC-SERVO SC drive of a joint. Gains are in the chip's integer units (docs/servo-units.md).
struct ServoParams {
  double encoder_counts_per_rev = 4000;  // counts per motor revolution, after quadrature
  double gear_ratio = 1;                 // motor revolutions per joint revolution (or per metre)
  double motor_torque_max_nm = 1;        // motor torque at full PWM
  double default_velocity = 0;           // rad/s (m/s) when a move gives none
  double default_acceleration = 0;       // rad/s^2 (m/s^2) when a move gives none
  double kp = 100;
  double kd = 1000;
  double ki = 0;
  double integration_limit = 0;
  double output_limit = 255;
  double current_limit = 0;
  double error_limit = 4000;
  double servo_rate_divisor = 1;
  double deadband = 0;
};

struct Joint {
  std::string name;
  JointType type = JointType::kRevolute;
  DhRow dh;
  double position_min = 0;  // rad or m; may lie beyond +-pi
  double position_max = 0;
  double velocity_max = 0;  // rad/s or m/s
  double effort_max = 0;    // N*m or N
  double armature = 0;      // reflected rotor inertia, kg*m^2 (kg for prismatic)
  double home = 0;          // rad or m
  Friction friction;
  ServoParams servo;
};

struct Link {
  std::string name;
  double mass_kg = 0;
  Eigen::Vector3d com_m = Eigen::Vector3d::Zero();          // in the link's DH frame
  Eigen::Matrix3d inertia_kg_m2 = Eigen::Matrix3d::Zero();  // about the COM, link-frame axes
  bool inertia_derived = false;  // true when com and inertia came from the shapes
  std::vector<Shape> shapes;     // poses in the link's DH frame
};

struct NamedPose {
  std::string name;
  std::vector<double> position;  // rad or m, one per joint
};

struct RobotModel {
  std::string name;
  std::string description;
  std::string source_file;
  std::string source_hash;             // FNV-1a 64 of the file's bytes, 16 hex digits
  std::string file_length_unit = "m";  // the file's own units, for display
  double file_length_unit_m = 1;
  std::string file_angle_unit = "rad";

  DhConvention dh_convention = DhConvention::kStandard;
  Pose base;  // DH frame 0 in the world
  Pose tool;  // tool point in the last DH frame
  Eigen::Vector3d gravity_m_s2{0, 0, -9.81};
  double servo_tick_s = 0.000512;

  std::vector<Joint> joints;
  std::vector<Link> links;  // joints.size() + 1 entries; links[0] is the base
  std::vector<NamedPose> named_poses;

  int num_joints() const { return static_cast<int>(joints.size()); }
  const NamedPose* FindNamedPose(const std::string& pose_name) const;
};

// The first reason `model` cannot describe a real arm, as a key path in the file's layout (e.g.
// "joints[2].limits", "links[3].inertia_kg_m2") and a problem text with values in the file's units;
// nullopt when the model is valid. Used on every load and on every received robot_model_t.
struct ModelProblem {
  std::string path;
  std::string problem;
};
std::optional<ModelProblem> FindModelProblem(const RobotModel& model);

// 64-bit FNV-1a hash of `bytes` as 16 lowercase hex digits (model and config fingerprints).
std::string Fnv1aHex(const std::string& bytes);

}  // namespace sirupp::core
