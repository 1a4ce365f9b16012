#include "core/model_report.hpp"

#include <cmath>
#include <cstdarg>
#include <cstdio>

#include "core/mass_properties.hpp"

namespace sirupp::core {

namespace {

__attribute__((format(printf, 2, 3))) void Append(std::string& out, const char* format, ...) {
  char buffer[512];
  va_list args;
  va_start(args, format);
  std::vsnprintf(buffer, sizeof buffer, format, args);
  va_end(args);
  out += buffer;
}

double ToDeg(double rad) { return rad * 180.0 / M_PI; }

double MovingMass(const RobotModel& model) {
  double mass = 0;
  for (size_t i = 1; i < model.links.size(); ++i) mass += model.links[i].mass_kg;
  return mass;
}

}  // namespace

std::string ModelSummary(const RobotModel& model) {
  std::string out;
  Append(out, "%s: %d joints, %s DH, moving mass %.3f kg, file %s (units %s, %s), hash %s",
         model.name.c_str(), model.num_joints(), DhConventionName(model.dh_convention),
         MovingMass(model), model.source_file.c_str(), model.file_length_unit.c_str(),
         model.file_angle_unit.c_str(), model.source_hash.c_str());
  return out;
}

std::string ModelReport(const RobotModel& model) {
  const double unit = model.file_length_unit_m;
  const char* lu = model.file_length_unit.c_str();
  std::string out;
  Append(out, "Robot model %s\n", model.name.c_str());
  if (!model.description.empty()) Append(out, "  %s\n", model.description.c_str());
  out += "  " + ModelSummary(model) + "\n";
  Append(out, "  servo tick %.6g s (%.6g Hz), gravity [%g %g %g] m/s^2\n", model.servo_tick_s,
         1.0 / model.servo_tick_s, model.gravity_m_s2.x(), model.gravity_m_s2.y(),
         model.gravity_m_s2.z());
  const Eigen::Vector3d base_rpy = model.base.orientation.toRotationMatrix().eulerAngles(2, 1, 0);
  Append(out, "  base at [%g %g %g] m, yaw-pitch-roll [%g %g %g] deg\n", model.base.position_m.x(),
         model.base.position_m.y(), model.base.position_m.z(), ToDeg(base_rpy[0]),
         ToDeg(base_rpy[1]), ToDeg(base_rpy[2]));
  Append(out, "  tool at [%g %g %g] m in the last DH frame\n", model.tool.position_m.x(),
         model.tool.position_m.y(), model.tool.position_m.z());

  Append(out, "\nDH table (%s convention)\n", DhConventionName(model.dh_convention));
  Append(out, "  %-2s %-10s %-9s | %9s %9s %9s %9s | %9s %9s %9s %9s\n", "i", "joint", "type",
         "alpha deg", "a m", "d m", "theta deg", "alpha", "a", "d", "theta");
  Append(out, "  %-2s %-10s %-9s | %39s | %9s %9s %9s %9s\n", "", "", "", "(SI)",
         model.file_angle_unit.c_str(), lu, lu, model.file_angle_unit.c_str());
  const bool deg = model.file_angle_unit == "deg";
  for (size_t i = 0; i < model.joints.size(); ++i) {
    const Joint& j = model.joints[i];
    const double fa = deg ? ToDeg(j.dh.alpha_rad) : j.dh.alpha_rad;
    const double ft = deg ? ToDeg(j.dh.theta_rad) : j.dh.theta_rad;
    Append(out, "  %-2zu %-10s %-9s | %9.3f %9.5f %9.5f %9.3f | %9.4g %9.4g %9.4g %9.4g\n", i + 1,
           j.name.c_str(), JointTypeName(j.type), ToDeg(j.dh.alpha_rad), j.dh.a_m, j.dh.d_m,
           ToDeg(j.dh.theta_rad), fa, j.dh.a_m / unit, j.dh.d_m / unit, ft);
  }

  out += "\nJoints (limits and speeds in deg or m; friction at the joint)\n";
  Append(out, "  %-2s %-10s %19s %9s %9s %9s | %8s %15s %9s | %9s %8s %5s %5s %5s\n", "i", "joint",
         "limits", "vmax/s", "effort", "armature", "static", "coulomb +/-", "viscous", "gear",
         "counts", "Kp", "Kd", "Ki");
  for (size_t i = 0; i < model.joints.size(); ++i) {
    const Joint& j = model.joints[i];
    const double k = j.type == JointType::kRevolute ? 180.0 / M_PI : 1.0;
    Append(out,
           "  %-2zu %-10s [%8.2f %8.2f] %9.2f %9.3g %9.3g | %8.3g %7.3g/%-7.3g %9.3g | %9.4g %8.0f "
           "%5.0f %5.0f %5.0f\n",
           i + 1, j.name.c_str(), j.position_min * k, j.position_max * k, j.velocity_max * k,
           j.effort_max, j.armature, j.friction.static_effort, j.friction.coulomb_positive,
           j.friction.coulomb_negative, j.friction.viscous, j.servo.gear_ratio,
           j.servo.encoder_counts_per_rev, j.servo.kp, j.servo.kd, j.servo.ki);
  }

  out += "\nLinks (centre of mass in the link's DH frame; inertia about it, kg*m^2)\n";
  for (size_t i = 0; i < model.links.size(); ++i) {
    const Link& l = model.links[i];
    const Eigen::Matrix3d& I = l.inertia_kg_m2;
    Append(out, "  %-2zu %-10s mass %6.3f kg  com [%8.4f %8.4f %8.4f] m = [%7.3f %7.3f %7.3f] %s\n",
           i, l.name.c_str(), l.mass_kg, l.com_m.x(), l.com_m.y(), l.com_m.z(), l.com_m.x() / unit,
           l.com_m.y() / unit, l.com_m.z() / unit, lu);
    if (i > 0) {
      Append(out, "     inertia %s: Ixx %.4g Iyy %.4g Izz %.4g Ixy %.3g Ixz %.3g Iyz %.3g\n",
             l.inertia_derived ? "(derived from shapes)" : "(given)", I(0, 0), I(1, 1), I(2, 2),
             I(0, 1), I(0, 2), I(1, 2));
    }
    for (const Shape& s : l.shapes) {
      Append(out, "     %-8s at [%7.4f %7.4f %7.4f] m  size [%.4g %.4g %.4g] m  volume %.3g m^3\n",
             ShapeTypeName(s.type), s.pose.position_m.x(), s.pose.position_m.y(),
             s.pose.position_m.z(), s.size_m.x(), s.size_m.y(), s.size_m.z(), ShapeVolume(s));
    }
  }

  if (!model.named_poses.empty()) out += "\nNamed poses (deg or m)\n";
  for (const NamedPose& pose : model.named_poses) {
    Append(out, "  %-10s", pose.name.c_str());
    for (size_t j = 0; j < pose.position.size(); ++j) {
      const double k = model.joints[j].type == JointType::kRevolute ? 180.0 / M_PI : 1.0;
      Append(out, " %8.2f", pose.position[j] * k);
    }
    out += "\n";
  }
  return out;
}

}  // namespace sirupp::core
