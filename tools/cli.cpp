#include "tools/cli.hpp"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <map>
#include <ostream>
#include <sirupp/arm_state_t.hpp>

#include "core/errors.hpp"
#include "core/model_loader.hpp"
#include "core/model_report.hpp"
#include "tools/control_commands.hpp"
#include "tools/demo_commands.hpp"
#include "tools/environment_commands.hpp"
#include "tools/export_commands.hpp"
#include "tools/grade_commands.hpp"
#include "tools/hardware_commands.hpp"
#include "tools/kinematics_commands.hpp"
#include "tools/lab_commands.hpp"
#include "tools/launch_commands.hpp"
#include "tools/panel_commands.hpp"
#include "tools/replay_commands.hpp"
#include "tools/report_commands.hpp"
#include "tools/sim_commands.hpp"
#include "tools/spy_commands.hpp"
#include "tools/view_commands.hpp"

namespace sirupp::tools {

namespace {

constexpr int kExitOk = 0;
constexpr int kExitUsage = 2;
constexpr const char* kDefaultModel = "config/robots/puma260.yaml";

const char* const kUsage =
    "usage: sirupp <command> [arguments]\n"
    "\n"
    "commands:\n"
    "  demo [--out DIR] [--sets N..]  the main job: the paper's experiment headless (sim, "
    "control,\n"
    "                             emulated real arm, logger, viewer; Table II report, images)\n"
    "  launch LAYOUT [--host NAME]  run a lab layout's processes (config/labs/*.yaml), live table\n"
    "  spy [--lcm-url URL]        lcm-spy with our types: every channel decodes by name\n"
    "  model check FILE...        validate robot model files; exit 2 on the first bad one\n"
    "  model show FILE            print the DH table and link data, in SI and the file's units\n"
    "  model export --urdf F | --mjcf F MODEL   the model as URDF or MJCF for other tools\n"
    "  fk --model FILE --deg Q..  tool pose for joint positions (see sirupp fk --help)\n"
    "  ik --model FILE --pose X Y Z ROLL PITCH YAW   joint solutions (see sirupp ik --help)\n"
    "  env check FILE...          validate environment files (objects around the robot); exit 2 on "
    "a bad one\n"
    "  env show FILE              list an environment's objects: shape, size, pose, static or "
    "mass\n"
    "  reset (--pose NAME | --deg Q..)  teleport the simulated arm (see sirupp reset --help)\n"
    "  move joints (--pose NAME | --deg Q..) [--wait]  a joint target for sirupp-control\n"
    "  move pose --pose X Y Z R P Y [--config C]    a tool target, through IK\n"
    "  plan check FILE...         validate movement plans; exit 2 naming file:line\n"
    "  plan run FILE [--wait]     run a plan in sirupp-control (also pause, resume, abort,\n"
    "                             manual, automatic)\n"
    "  gains [--joint N] [--kp V] [--kd V] ...   the live servo gains: show, or change\n"
    "  clear-fault                clear sirupp-control's latched fault (servos on, arm held)\n"
    "  status                     what the controller, the arm and every process report\n"
    "  hardware connect|calibrate|arm|disarm|link|unlink|home|clear-faults|status\n"
    "                             the bridge to the real arm (or sirupp-picservo-emu)\n"
    "  estop [--release]          emergency stop: real motors off, plans aborted\n"
    "  report FILE|DIR...         Table II report, CSV and plots of logger data files or LCM logs\n"
    "  grade LIB.so --suite FILE  score a controller beside the PIC-SERVO baseline (--batch DIR)\n"
    "  fit-emulator [--evaluate]  the paper's sets in one process, both arms; fit the emulated\n"
    "                             real arm's effects to the paper's Table II\n"
    "  identify DATA... --model M --out M2   fit a model's friction and armature to real data\n"
    "  replay LOG [--speed X]     play an lcm-logger file back onto the bus, original timing\n"
    "  panel [--listen ADDR]      the lab panel in the browser (sirupp-panel); prints its address\n"
    "  view [--channel NAME]      show sirupp-viewer's images in a window (needs a display)\n"
    "  help                       this text\n"
    "\n"
    "Model files: config/robots/*.yaml, format in docs/model-format.md.\n"
    "Environment files: config/environments/*.xml, format in docs/environment-format.md.\n"
    "Plan files: config/plans/*.plan, format in docs/plan-format.md.\n"
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

// The arm in ODE: released limp from its home pose, one second with joint friction.
}  // namespace

int RunCli(const Args& args, std::ostream& out, std::ostream& err) {
  try {
    if (args.empty() || args[0] == "help" || args[0] == "--help" || args[0] == "-h") {
      (args.empty() ? err : out) << kUsage;
      return args.empty() ? kExitUsage : kExitOk;
    }
    const std::string& command = args[0];
    const Args rest(args.begin() + 1, args.end());
    const bool wants_help = !rest.empty() && (rest[0] == "--help" || rest[0] == "-h");
    if (command == "demo") {
      if (wants_help) return out << kDemoUsage, kExitOk;
      return RunDemo(rest, out, err);
    }
    if (command == "launch") {
      if (wants_help) return out << kLaunchUsage, kExitOk;
      return RunLaunch(rest, out, err);
    }
    if (command == "spy") {
      if (wants_help) return out << kSpyUsage, kExitOk;
      return RunSpy(rest, out, err);
    }
    if (command == "fk") {
      if (wants_help) return out << kFkUsage, kExitOk;
      return RunFk(rest, out);
    }
    if (command == "ik") {
      if (wants_help) return out << kIkUsage, kExitOk;
      return RunIk(rest, out);
    }
    if (command == "move") {
      if (wants_help) return out << kMoveUsage, kExitOk;
      return RunMove(rest, out);
    }
    if (command == "plan") {
      if (wants_help) return out << kPlanUsage, kExitOk;
      return RunPlan(rest, out);
    }
    if (command == "clear-fault") {
      if (wants_help) return out << kPlanUsage, kExitOk;
      Args plan_args{"clear-fault"};
      plan_args.insert(plan_args.end(), rest.begin(), rest.end());
      return RunPlan(plan_args, out);
    }
    if (command == "gains") {
      if (wants_help) return out << kGainsUsage, kExitOk;
      return RunGains(rest, out);
    }
    if (command == "hardware") {
      if (wants_help) return out << kHardwareUsage, kExitOk;
      return RunHardware(rest, out);
    }
    if (command == "estop") {
      if (wants_help) return out << kEstopUsage, kExitOk;
      return RunEstop(rest, out);
    }
    if (command == "status") {
      if (wants_help) return out << kStatusUsage, kExitOk;
      return RunStatus(rest, out);
    }
    if (command == "panel") {
      if (wants_help) return out << kPanelUsage, kExitOk;
      return RunPanel(rest, err);
    }
    if (command == "view") {
      if (wants_help) return out << kViewUsage, kExitOk;
      return RunView(rest, out, err);
    }
    if (command == "report") {
      if (wants_help) return out << kReportUsage, kExitOk;
      return RunReport(rest, out, err);
    }
    if (command == "grade") {
      if (wants_help) return out << kGradeUsage, kExitOk;
      return RunGrade(rest, out, err);
    }
    if (command == "fit-emulator") {
      if (wants_help) return out << kFitEmulatorUsage, kExitOk;
      return RunFitEmulator(rest, out, err);
    }
    if (command == "identify") {
      if (wants_help) return out << kIdentifyUsage, kExitOk;
      return RunIdentify(rest, out, err);
    }
    if (command == "replay") {
      if (wants_help) return out << kReplayUsage, kExitOk;
      return RunReplay(rest, out);
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
      if (rest.empty())
        throw core::UsageError("model: expected a subcommand: check, show or export");
      const Args files(rest.begin() + 1, rest.end());
      if (rest[0] == "check") return ModelCheck(files, out);
      if (rest[0] == "show") return ModelShow(files, out);
      if (rest[0] == "export") {
        if (!files.empty() && (files[0] == "--help" || files[0] == "-h")) {
          return out << kModelExportUsage, kExitOk;
        }
        return RunModelExport(files, out);
      }
      throw core::UsageError("model: unknown subcommand '" + rest[0] +
                             "'; allowed: check, show, export");
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
