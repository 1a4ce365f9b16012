#include "tools/cli.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <iostream>
#include <map>
#include <ostream>
#include <sirupp/arm_state_t.hpp>

#include "core/errors.hpp"
#include "core/model_loader.hpp"
#include "core/model_report.hpp"
#include "runtime/app_format.hpp"
#include "runtime/args.hpp"
#include "runtime/data_path.hpp"
#include "tools/class_commands.hpp"
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
#include "tools/turns_commands.hpp"
#include "tools/view_commands.hpp"

namespace sirupp::tools {

namespace {

constexpr int kExitOk = 0;
constexpr int kExitAbout = 2;

using Args = std::vector<std::string>;
using Run = std::function<int(const Args&)>;

const char* const kAbout =
    "The command line of SIRUPP-LCM. `sirupp COMMAND --help` shows a command's flags.";

const char* const kFooter =
    "Processes (each with --help): sirupp-sim (ODE physics), sirupp-control (sequencer and "
    "virtual PIC-SERVOs), sirupp-hardware (bridge to the real arm), sirupp-picservo-emu "
    "(emulated real arm), sirupp-logger (data files), sirupp-viewer (off-screen images), "
    "sirupp-panel (browser panel).\n"
    "Files: config/robots/*.yaml (docs/model-format.md), config/environments/*.xml "
    "(docs/environment-format.md), config/plans/*.plan (docs/plan-format.md). Joint values on "
    "every command line: docs/command-line.md.\n"
    "Exit codes: 0 success, 1 failure while running, 2 bad arguments or bad input.";

int ModelCheck(const Args& args, std::ostream& out) {
  const runtime::Args parsed(
      args, "model check", {runtime::Flag("files", "robot model files").Positional("FILE", -1)},
      "Validates robot model files (docs/model-format.md): one line per file; exit 2 on the "
      "first bad one, naming file:line.");
  for (const std::string& file : parsed.Values("files", -1)) {
    const core::RobotModel model = core::LoadRobotModel(file);
    out << file << ": ok: " << core::ModelSummary(model) << "\n";
  }
  return kExitOk;
}

int ModelShow(const Args& args, std::ostream& out) {
  const runtime::Args parsed(args, "model show",
                             {runtime::Flag("file", "robot model file").Positional("FILE", 1)},
                             "Prints the DH table and link data, in SI and in the file's units.");
  out << core::ModelReport(core::LoadRobotModel(parsed.String("file")));
  return kExitOk;
}

// A command of the tree: the word(s), one summary line, and the function given the arguments
// after the word(s). The function parses them with runtime::Args, which answers --help.
struct Command {
  std::string group;  // "" for a top-level command
  std::string name;
  std::string summary;
  Run run;
};

std::vector<Command> Commands(std::ostream& out, std::ostream& err) {
  const auto with = [](const std::string& word, Run run) {
    return [word, run](const Args& rest) {
      Args args{word};
      args.insert(args.end(), rest.begin(), rest.end());
      return run(args);
    };
  };
  const Run move = [&out](const Args& a) { return RunMove(a, out); };
  const Run plan = [&out](const Args& a) { return RunPlan(a, out); };
  const Run hardware = [&out](const Args& a) { return RunHardware(a, out); };
  const Run env = [&out, &err](const Args& a) { return RunEnv(a, out, err); };
  std::vector<Command> commands = {
      {"", "demo", "the main job: the paper's experiment headless, Table II report, images",
       [&](const Args& a) { return RunDemo(a, out, err); }},
      {"", "launch", "run a lab layout's processes (config/labs/*.yaml), live table",
       [&](const Args& a) { return RunLaunch(a, out, err); }},
      {"turns", "serve", "share the one real arm among rigs by turns (queue on stdin)",
       [&](const Args& a) {
         Args args{"serve"};
         args.insert(args.end(), a.begin(), a.end());
         return RunTurns(args, std::cin, out, err);
       }},
      {"", "spy", "lcm-spy with our types: every channel decodes by name",
       [&](const Args& a) { return RunSpy(a, out, err); }},
      {"model", "check", "validate robot model files",
       [&](const Args& a) { return ModelCheck(a, out); }},
      {"model", "show", "the DH table and link data, in SI and the file's units",
       [&](const Args& a) { return ModelShow(a, out); }},
      {"model", "export", "the model as URDF or MJCF for other tools",
       [&](const Args& a) { return RunModelExport(a, out); }},
      {"", "fk", "tool pose for joint positions", [&](const Args& a) { return RunFk(a, out); }},
      {"", "ik", "joint solutions for a tool pose", [&](const Args& a) { return RunIk(a, out); }},
      {"env", "check", "validate environment files", with("check", env)},
      {"env", "show", "list an environment's objects", with("show", env)},
      {"", "reset", "teleport the simulated arm", [&](const Args& a) { return RunReset(a, out); }},
      {"move", "joints", "a joint target for sirupp-control", with("joints", move)},
      {"move", "pose", "a tool target, through IK", with("pose", move)},
      {"plan", "check", "validate movement plans, naming file:line", with("check", plan)},
      {"plan", "make", "a collision-free plan around an environment (OMPL)", with("make", plan)},
      {"plan", "run", "run a plan in sirupp-control", with("run", plan)},
      {"plan", "pause", "pause the running plan", with("pause", plan)},
      {"plan", "resume", "resume the paused plan", with("resume", plan)},
      {"plan", "abort", "abort the plan (the arm holds)", with("abort", plan)},
      {"plan", "manual", "manual mode: the operator steps the plan", with("manual", plan)},
      {"plan", "automatic", "automatic mode: the plan runs on", with("automatic", plan)},
      {"", "gains", "the live servo gains: show, or change",
       [&](const Args& a) { return RunGains(a, out); }},
      {"", "clear-fault", "clear sirupp-control's latched fault (servos on, arm held)",
       with("clear-fault", plan)},
      {"", "status", "what the controller, the arm and every process report",
       [&](const Args& a) { return RunStatus(a, out); }},
      {"", "estop", "emergency stop: real motors off, plans aborted",
       [&](const Args& a) { return RunEstop(a, out); }},
      {"", "report", "Table II report, CSV and plots of data files or LCM logs",
       [&](const Args& a) { return RunReport(a, out, err); }},
      {"", "grade", "score a controller beside the PIC-SERVO baseline",
       [&](const Args& a) { return RunGrade(a, out, err); }},
      {"controller", "build", "build a controller library from C++ source (sandboxed)",
       [&](const Args& a) { return RunControllerBuild(a, out, err); }},
      {"", "fit-emulator", "fit the emulated real arm's effects to the paper's Table II",
       [&](const Args& a) { return RunFitEmulator(a, out, err); }},
      {"", "identify", "fit a model's friction and armature to real data",
       [&](const Args& a) { return RunIdentify(a, out, err); }},
      {"", "replay", "play an lcm-logger file back onto the bus, original timing",
       [&](const Args& a) { return RunReplay(a, out); }},
      {"class", "serve", "serve a class: a private rig per student, the teacher's page",
       [&](const Args& a) { return RunClassServe(a, out, err); }},
      {"class", "tokens", "issue the class's missing tokens, or --reissue one",
       [&](const Args& a) { return RunClassTokens(a, out); }},
      {"class", "check", "validate a class file",
       [&](const Args& a) { return RunClassCheck(a, out); }},
      {"class", "notebooks", "run the class's notebooks hub (JupyterHub, docs/notebooks.md)",
       [&](const Args& a) { return RunClassNotebooks(a, out); }},
      {"", "panel", "the lab panel in the browser (sirupp-panel)",
       [&](const Args& a) { return RunPanel(a, err); }},
      {"", "view", "show sirupp-viewer's images in a window (needs a display)",
       [&](const Args& a) { return RunView(a, out, err); }},
  };
  for (const std::string& verb : HardwareVerbs()) {
    commands.push_back({"hardware", verb, HardwareVerbSummary(verb), with(verb, hardware)});
  }
  return commands;
}

const std::map<std::string, std::string> kGroups = {
    {"model", "robot model files: check, show, export"},
    {"env", "environment files: check, show"},
    {"class", "a class on one server: serve, tokens, check (docs/class.md)"},
    {"move", "a joint or tool target for sirupp-control"},
    {"plan", "movement plans: check, make, run, pause, resume, abort, modes"},
    {"hardware", "the bridge to the real arm (or sirupp-picservo-emu)"},
    {"turns", "the one real arm shared by several rigs, by turns: serve"},
    {"controller", "student controllers: build"}};

// The help of `level` itself (CLI::App::help() gives a parsed subcommand's instead).
std::string HelpOf(const CLI::App& level) {
  const std::string name =
      level.get_parent() == nullptr ? level.get_name() : "sirupp " + level.get_name();
  return level.get_formatter()->make_help(&level, name, CLI::AppFormatMode::Normal);
}

}  // namespace

namespace {

// The command levels under `sirupp`: the groups (move, plan, ...), `help`, and the command the
// parse chose with its level (set by the leaves' callbacks).
struct CommandTree {
  std::map<std::string, CLI::App*> groups;
  CLI::App* help = nullptr;
  const Run* chosen = nullptr;
  CLI::App* chosen_app = nullptr;
};

// One leaf per command, under its group (made on its first command) or under `app`.
void AddCommands(CLI::App& app, const std::vector<Command>& commands, CommandTree& tree) {
  for (const Command& command : commands) {
    CLI::App* parent = &app;
    if (!command.group.empty()) {
      CLI::App*& group = tree.groups[command.group];
      if (group == nullptr) {
        group = app.add_subcommand(command.group, kGroups.at(command.group));
        group->require_subcommand(1);
        group->formatter(app.get_formatter());
        group->set_help_flag("-h,--help", "print this help and exit");
        group->footer("");
        group->group("Commands");
        group->allow_extras();
      }
      parent = group;
    }
    CLI::App* leaf = parent->add_subcommand(command.name, command.summary);
    leaf->group("Commands");
    // The leaf's flags are its own (runtime::Args in its function), --help included.
    leaf->prefix_command();
    leaf->set_help_flag();
    leaf->set_version_flag();
    leaf->callback([&tree, &command, leaf] {
      tree.chosen = &command.run;
      tree.chosen_app = leaf;
    });
  }
}

// A group given without a known subcommand: core::UsageError naming the group, what was given
// and what is allowed.
void ThrowIfGroupIncomplete(const std::map<std::string, CLI::App*>& groups) {
  for (const auto& [name, group] : groups) {
    if (!group->parsed()) continue;
    std::string allowed;
    for (const CLI::App* sub : group->get_subcommands({})) {
      allowed += (allowed.empty() ? "" : ", ") + sub->get_name();
    }
    const std::vector<std::string> extra = group->remaining();
    throw core::UsageError(
        name + ": " +
        (extra.empty() ? "expected a subcommand" : "unknown subcommand '" + extra.front() + "'") +
        "; allowed: " + allowed);
  }
}

}  // namespace

int RunCli(const Args& args, std::ostream& out, std::ostream& err) {
  CLI::App app(kAbout, "sirupp");
  runtime::ConfigureApp(app, std::string("sirupp ") + runtime::Version());
  app.footer(kFooter);
  app.require_subcommand(1);
  const std::vector<Command> commands = Commands(out, err);
  CommandTree tree;
  tree.help = app.add_subcommand("help", "this text");
  tree.help->group("Commands");
  AddCommands(app, commands, tree);
  const std::map<std::string, CLI::App*>& groups = tree.groups;
  CLI::App* help = tree.help;
  try {
    if (args.empty()) {
      err << HelpOf(app);
      return kExitAbout;
    }
    const auto& subcommands = app.get_subcommands({});
    if (args[0].rfind("-", 0) != 0 &&
        std::none_of(subcommands.begin(), subcommands.end(),
                     [&args](const CLI::App* sub) { return sub->get_name() == args[0]; })) {
      throw core::UsageError("unknown command '" + args[0] + "'; run 'sirupp help'");
    }
    try {
      std::vector<std::string> reversed(args.rbegin(), args.rend());
      app.parse(reversed);
    } catch (const CLI::CallForHelp&) {
      // The help of the level asked for: `sirupp --help`, `sirupp move --help`.
      const CLI::App* level = &app;
      for (const auto& [name, group] : groups) {
        if (group->parsed()) level = group;
      }
      out << HelpOf(*level);
      return kExitOk;
    } catch (const CLI::CallForVersion&) {
      out << "sirupp " << runtime::Version() << "\n";
      return kExitOk;
    } catch (const CLI::RequiredError& error) {
      if (help->parsed()) return out << HelpOf(app), kExitOk;
      ThrowIfGroupIncomplete(groups);
      throw core::UsageError(error.what());
    } catch (const CLI::ParseError& error) {
      throw core::UsageError(error.what());
    }
    if (help->parsed()) return out << HelpOf(app), kExitOk;
    if (tree.chosen == nullptr) throw core::UsageError("expected a command; run 'sirupp help'");
    return (*tree.chosen)(tree.chosen_app->remaining());
  } catch (const runtime::HelpRequested& help_text) {
    out << help_text.text;
    return kExitOk;
  } catch (const core::UsageError& error) {
    err << "sirupp: " << error.what() << "\n";
    return kExitAbout;
  } catch (const core::ConfigError& error) {
    err << "error: " << error.what() << "\n";
    return kExitAbout;
  }
}

}  // namespace sirupp::tools
