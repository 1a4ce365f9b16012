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

const char* const kModelExportAbout =
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
  const runtime::Args parsed(
      args, "model export",
      {runtime::Flag("model", "the robot model file").Positional("MODEL.yaml"),
       runtime::Flag("urdf", "write URDF to FILE ('-': stdout)").Takes("FILE"),
       runtime::Flag("mjcf", "write MJCF to FILE ('-': stdout)").Takes("FILE")},
      kModelExportAbout);
  const std::string urdf = parsed.Has("urdf") ? parsed.String("urdf") : "";
  const std::string mjcf = parsed.Has("mjcf") ? parsed.String("mjcf") : "";
  const std::string model_file = parsed.String("model");
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
