#include "tools/environment_commands.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ostream>

#include "core/environment.hpp"
#include "core/errors.hpp"
#include "core/kinematics.hpp"
#include "runtime/args.hpp"

namespace sirupp::tools {

const char* const kEnvAbout =
    "  Environment files (config/environments/*.xml) list the objects around the robot: boxes,\n"
    "  cylinders, spheres and capsules, static or free, in the world frame (z up).\n"
    "  check: one line per file, 'FILE: ok: ...' or 'error: FILE:LINE: path: problem'.\n"
    "  show:  every object's shape, size, pose, static or mass, friction and restitution, in SI\n"
    "         units (m, kg) with roll-pitch-yaw in degrees (R = Rz(yaw) Ry(pitch) Rx(roll)).\n"
    "  Exit code 0 when every file is valid, 2 when one is not or the arguments are bad.\n"
    "  Format: docs/environment-format.md.\n";

namespace {

constexpr int kEnvExitOk = 0;
constexpr int kExitBadFile = 2;  // bad input, as `sirupp model check`

std::string FixedWidth(double value, int decimals, int width = 0) {
  // "-0.0000" reads as a sign that is not there.
  if (std::abs(value) < 0.5 * std::pow(10.0, -decimals)) value = 0;
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%*.*f", width, decimals, value);
  return buffer;
}

std::string Padded(const std::string& text, size_t width) {
  return text.size() >= width ? text : text + std::string(width - text.size(), ' ');
}

std::string Triple(const Eigen::Vector3d& v, int decimals, int width) {
  return "[" + FixedWidth(v.x(), decimals, width) + " " + FixedWidth(v.y(), decimals, width) + " " +
         FixedWidth(v.z(), decimals, width) + "]";
}

std::string SizeText(const core::Shape& shape) {
  const Eigen::Vector3d& s = shape.size_m;
  switch (shape.type) {
    case core::ShapeType::kBox:
      return FixedWidth(s.x(), 4) + " x " + FixedWidth(s.y(), 4) + " x " + FixedWidth(s.z(), 4);
    case core::ShapeType::kSphere:
      return "radius " + FixedWidth(s.x(), 4);
    case core::ShapeType::kCylinder:
    case core::ShapeType::kCapsule:
      break;
  }
  return "radius " + FixedWidth(s.x(), 4) + " length " + FixedWidth(s.y(), 4);
}

// "8 objects (5 static, 3 free)".
std::string CountText(const core::Environment& environment) {
  const auto free_count = static_cast<size_t>(
      std::count_if(environment.objects.begin(), environment.objects.end(),
                    [](const core::EnvironmentObject& object) { return !object.is_static; }));
  const size_t count = environment.objects.size();
  return std::to_string(count) + (count == 1 ? " object" : " objects") + " (" +
         std::to_string(count - free_count) + " static, " + std::to_string(free_count) + " free)";
}

std::string Summary(const core::Environment& environment) {
  return "environment \"" + environment.name + "\", " + CountText(environment);
}

std::string Report(const core::Environment& environment) {
  std::string text = "Environment \"" + environment.name + "\" from " + environment.source_file +
                     ": " + CountText(environment) + "\n";
  if (environment.objects.empty()) return text + "No objects: the robot stands alone.\n";
  text +=
      "World frame, z up. Sizes and positions (shape centres) in metres, roll-pitch-yaw in "
      "degrees.\n\n";
  size_t name_width = 4;
  for (const core::EnvironmentObject& object : environment.objects) {
    name_width = std::max(name_width, object.name.size());
  }
  const size_t size_width = 30;
  const size_t position_width = 27;
  const size_t rpy_width = 25;
  const size_t body_width = 16;
  text += "  " + Padded("name", name_width) + "  " + Padded("shape", 10) +
          Padded("size (m)", size_width) + Padded("position (m)", position_width) +
          Padded("rpy (deg)", rpy_width) + Padded("body", body_width) + "friction  restitution\n";
  for (const core::EnvironmentObject& object : environment.objects) {
    const core::Shape& shape = object.shape;
    const Eigen::Vector3d rpy_deg =
        core::RollPitchYaw(shape.pose.orientation.toRotationMatrix()) * 180.0 / M_PI;
    const std::string body =
        object.is_static ? std::string("static") : "free " + FixedWidth(object.mass_kg, 3) + " kg";
    text += "  " + Padded(object.name, name_width) + "  " + Padded(ShapeTypeName(shape.type), 10) +
            Padded(SizeText(shape), size_width) +
            Padded(Triple(shape.pose.position_m, 4, 7), position_width) +
            Padded(Triple(rpy_deg, 1, 6), rpy_width) + Padded(body, body_width) +
            Padded(core::FormatNumber(object.friction), 10) +
            core::FormatNumber(object.restitution) + "\n";
  }
  return text;
}

int Check(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  const runtime::Args parsed(args, "env check",
                             {runtime::Flag("files", "environment files").Positional("FILE", -1)},
                             kEnvAbout);
  int status = kEnvExitOk;
  for (const std::string& file : parsed.Values("files", -1)) {
    try {
      const core::Environment environment = core::LoadEnvironment(file);
      out << file << ": ok: " << Summary(environment) << "\n";
    } catch (const core::ConfigError& error) {
      err << "error: " << error.what() << "\n";
      status = kExitBadFile;
    }
  }
  return status;
}

int Show(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  const runtime::Args parsed(
      args, "env show", {runtime::Flag("file", "environment file").Positional("FILE")}, kEnvAbout);
  try {
    const core::Environment environment = core::LoadEnvironment(parsed.String("file"));
    out << Report(environment);
  } catch (const core::ConfigError& error) {
    err << "error: " << error.what() << "\n";
    return kExitBadFile;
  }
  return kEnvExitOk;
}

}  // namespace

int RunEnv(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  const std::vector<std::string> files(args.begin() + 1, args.end());
  if (args[0] == "check") return Check(files, out, err);
  if (args[0] == "show") return Show(files, out, err);
  throw core::UsageError("env: unknown subcommand '" + args[0] + "'; allowed: check, show");
}

}  // namespace sirupp::tools
