#include "tools/cli.hpp"

#include <filesystem>
#include <functional>
#include <map>
#include <ostream>

#include "core/errors.hpp"
#include "core/model_loader.hpp"
#include "core/model_report.hpp"
#include "tools/environment_commands.hpp"
#include "tools/kinematics_commands.hpp"
#include "tools/sim_commands.hpp"

#ifndef SIRUPP_SOURCE_DIR
#define SIRUPP_SOURCE_DIR "."
#endif

namespace sirupp::tools {

namespace {

constexpr int kExitOk = 0;
constexpr int kExitUsage = 2;
constexpr const char* kDefaultModel = "config/robots/puma260.yaml";

const char* const kUsage =
    "usage: sirupp <command> [arguments]\n"
    "\n"
    "commands:\n"
    "  demo [--model FILE]        the main job: load the PUMA 260 model and print it\n"
    "  model check FILE...        validate robot model files; exit 2 on the first bad one\n"
    "  model show FILE            print the DH table and link data, in SI and the file's units\n"
    "  fk --model FILE --deg Q..  tool pose for joint positions (see sirupp fk --help)\n"
    "  ik --model FILE --pose X Y Z ROLL PITCH YAW   joint solutions (see sirupp ik --help)\n"
    "  env check FILE...          validate environment files (objects around the robot); exit 2 on "
    "a bad one\n"
    "  env show FILE              list an environment's objects: shape, size, pose, static or "
    "mass\n"
    "  reset (--pose NAME | --position Q..)  teleport the simulated arm (see sirupp reset --help)\n"
    "  help                       this text\n"
    "\n"
    "Model files: config/robots/*.yaml, format in docs/model-format.md.\n"
    "Environment files: config/environments/*.xml, format in docs/environment-format.md.\n"
    "Exit codes: 0 success, 1 failure while running, 2 bad arguments or bad input.\n";

using Args = std::vector<std::string>;

int ModelCheck(const Args& files, std::ostream& out) {
  if (files.empty()) throw core::UsageError("model check: missing FILE");
  for (const std::string& file : files) {
    const core::RobotModel model = core::LoadRobotModel(file);
    out << file << ": ok: " << core::ModelSummary(model) << "\n";
  }
  return kExitOk;
}

int ModelShow(const Args& files, std::ostream& out) {
  if (files.size() != 1) {
    throw core::UsageError("model show: expected exactly one FILE, got " +
                           std::to_string(files.size()));
  }
  out << core::ModelReport(core::LoadRobotModel(files[0]));
  return kExitOk;
}

int Demo(const Args& args, std::ostream& out) {
  std::string model_file = ResolveDataPath(kDefaultModel);
  for (size_t i = 0; i < args.size(); ++i) {
    if (args[i] == "--model" && i + 1 < args.size()) {
      model_file = args[++i];
    } else {
      throw core::UsageError("demo: unknown argument '" + args[i] + "'; allowed: --model FILE");
    }
  }
  out << "SIRUPP-LCM demo: loading " << model_file << "\n\n";
  out << core::ModelReport(core::LoadRobotModel(model_file));
  out << "\nThe model loaded and validated. (Physics, control, logging and rendering join the demo "
         "as their processes arrive.)\n";
  return kExitOk;
}

}  // namespace

std::string ResolveDataPath(const std::string& path) {
  namespace fs = std::filesystem;
  if (fs::exists(path) || fs::path(path).is_absolute()) return path;
  const fs::path in_source = fs::path(SIRUPP_SOURCE_DIR) / path;
  return fs::exists(in_source) ? in_source.string() : path;
}

int RunCli(const Args& args, std::ostream& out, std::ostream& err) {
  try {
    if (args.empty() || args[0] == "help" || args[0] == "--help" || args[0] == "-h") {
      (args.empty() ? err : out) << kUsage;
      return args.empty() ? kExitUsage : kExitOk;
    }
    const std::string& command = args[0];
    const Args rest(args.begin() + 1, args.end());
    if (command == "demo") return Demo(rest, out);
    const bool wants_help = !rest.empty() && (rest[0] == "--help" || rest[0] == "-h");
    if (command == "fk") {
      if (wants_help) return out << kFkUsage, kExitOk;
      return RunFk(rest, out);
    }
    if (command == "ik") {
      if (wants_help) return out << kIkUsage, kExitOk;
      return RunIk(rest, out);
    }
    if (command == "reset") {
      if (wants_help) return out << kResetUsage, kExitOk;
      return RunReset(rest, out);
    }
    if (command == "env") {
      if (wants_help) return out << kEnvUsage, kExitOk;
      return RunEnv(rest, out, err);
    }
    if (command == "model") {
      if (rest.empty()) throw core::UsageError("model: expected a subcommand: check or show");
      const Args files(rest.begin() + 1, rest.end());
      if (rest[0] == "check") return ModelCheck(files, out);
      if (rest[0] == "show") return ModelShow(files, out);
      throw core::UsageError("model: unknown subcommand '" + rest[0] + "'; allowed: check, show");
    }
    throw core::UsageError("unknown command '" + command + "'; run 'sirupp help'");
  } catch (const core::UsageError& error) {
    err << "sirupp: " << error.what() << "\n";
    return kExitUsage;
  } catch (const core::ConfigError& error) {
    err << "error: " << error.what() << "\n";
    return kExitUsage;
  }
}

}  // namespace sirupp::tools
