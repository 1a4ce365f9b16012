#include "tools/export_commands.hpp"

#include <fstream>
#include <ostream>
#include <stdexcept>

#include "core/errors.hpp"
#include "core/model_export.hpp"
#include "core/model_loader.hpp"
#include "runtime/data_path.hpp"
#include "tools/cli.hpp"

namespace sirupp::tools {

const char* const kModelExportUsage =
    "usage: sirupp model export (--urdf FILE | --mjcf FILE)... MODEL.yaml\n"
    "  Writes the robot model as URDF (ROS, MoveIt, Drake, PyBullet) and/or MJCF (MuJoCo): links\n"
    "  with mass, centre of mass and inertia; joints with limits, effort, velocity, friction and\n"
    "  armature; visual and collision shapes; base and tool poses. FILE '-' writes to standard\n"
    "  output. Frames and what each format cannot hold: docs/export.md.\n"
    "  Exit code 0 when written, 1 when a file cannot be written, 2 for bad arguments or a bad\n"
    "  model.\n";

namespace {

void Write(const std::string& path, const std::string& text, std::ostream& out) {
  if (path == "-") {
    out << text;
    return;
  }
  std::ofstream file(path, std::ios::binary | std::ios::trunc);
  file << text;
  file.close();
  if (!file) throw std::runtime_error("model export: cannot write '" + path + "'");
}

}  // namespace

int RunModelExport(const std::vector<std::string>& args, std::ostream& out) {
  std::string urdf, mjcf, model_file;
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string& arg = args[i];
    if (arg == "--urdf" || arg == "--mjcf") {
      std::string& target = arg == "--urdf" ? urdf : mjcf;
      if (i + 1 >= args.size()) throw core::UsageError("model export: " + arg + " needs a FILE");
      if (!target.empty()) throw core::UsageError("model export: " + arg + " given twice");
      target = args[++i];
      if (target.empty()) throw core::UsageError("model export: " + arg + " needs a FILE");
    } else if (arg.size() > 1 && arg[0] == '-' && arg[1] == '-') {
      throw core::UsageError("model export: unknown option '" + arg + "'; allowed: --urdf, --mjcf");
    } else if (model_file.empty()) {
      model_file = arg;
    } else {
      throw core::UsageError("model export: expected one MODEL.yaml, got '" + model_file +
                             "' and '" + arg + "'");
    }
  }
  if (model_file.empty()) throw core::UsageError("model export: missing MODEL.yaml");
  if (urdf.empty() && mjcf.empty()) {
    throw core::UsageError("model export: nothing to write: give --urdf FILE and/or --mjcf FILE");
  }
  if (urdf == "-" && mjcf == "-") {
    throw core::UsageError("model export: only one of --urdf and --mjcf can write to '-'");
  }
  const core::RobotModel model = core::LoadRobotModel(runtime::ResolveDataPath(model_file));
  if (!urdf.empty()) Write(urdf, core::ExportUrdf(model), out);
  if (!mjcf.empty()) Write(mjcf, core::ExportMjcf(model), out);
  return 0;
}

}  // namespace sirupp::tools
