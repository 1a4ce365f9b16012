// sirupp-control: the sequencer and the virtual PIC-SERVOs as an LCM process. Thin main.

#include <iostream>
#include <memory>
#include <string>

#include "control/control_node.hpp"
#include "control/isolated_law.hpp"
#include "control/plugin_controller.hpp"
#include "core/bus.hpp"
#include "core/errors.hpp"
#include "core/model_loader.hpp"
#include "runtime/args.hpp"
#include "runtime/data_path.hpp"
#include "runtime/process_main.hpp"

namespace {

using sirupp::runtime::Flag;

constexpr const char* kAbout =
    "The sequencer of the virtual PIC-SERVOs. --boards sim (default): the boards run in "
    "sirupp-sim\n"
    "beside the physics; this process answers SIM_BOARD_STATUS every exchange tick (MODE_BOARDS)\n"
    "and sends them moves on SIM_BOARD_COMMAND, as sirupp-hardware does with the real boards.\n"
    "--boards control (and always with --controller): it runs them here and answers every\n"
    "SIM_ARM_STATE with joint efforts on SIM_ARM_COMMAND. As participant NAME (default\n"
    "sirupp-control). Takes joint targets\n"
    "(ARM_TARGET), tool targets through IK (ARM_POSE_TARGET), movement plans and modes (ARM_PLAN)\n"
    "and gains (ARM_GAINS), see `sirupp move|plan|gains|status --help`; publishes ARM_MOVE,\n"
    "ARM_SETPOINT, CONTROLLER_STATUS and HEARTBEAT.\n"
    "--controller: a student's controller library (built against sirupp/controller.h) computes\n"
    "the efforts from the profiles' set-points instead of the PID; --controller-args is passed\n"
    "to its constructor. The library runs in a child process (sirupp-controller-host): a crash\n"
    "(any signal), an exception, a non-finite effort or a call that takes longer than\n"
    "--controller-tick-limit seconds (default 0.5, wall time) is a fault naming the library and\n"
    "the tick; the arm is braked and `sirupp clear-fault` starts the library afresh.\n"
    "A file ending in .py is a controller written in Python (update(state) -> efforts), run the\n"
    "same way by sirupp-python-controller-host (docs/python.md).\n"
    "--controller-in-process: load it into sirupp-control itself (for a debugger; a crash then\n"
    "ends sirupp-control; not for .py). See docs/student-controllers.md.\n"
    "The host process runs sandboxed (docs/sandbox.md): no network, only /usr and the library's\n"
    "folder to read, a private /tmp, CPU, memory, process and file-size limits; where this\n"
    "machine cannot give the sandbox, --controller is refused with the reason. --no-sandbox runs\n"
    "the library unconfined (your own code only).\n"
    "--rt-priority N: run under SCHED_FIFO at priority N (1..99; needs root or CAP_SYS_NICE),\n"
    "so the servo loop answers each state at once on a busy machine (docs/timing.md).\n"
    "--sim-timeout S: no SIM_ARM_STATE for S wall seconds (default 0.5) aborts a plan (sirupp\n"
    "grade gives more: another participant may hold the lockstep sim that long).\n"
    "--bridge-timeout S: no HARDWARE_STATUS for S wall seconds (default 0.6) while the bridge was\n"
    "linked = the real arm's half of the run is lost: named in last_error and the plan's result.\n"
    "Wall seconds in every timing mode, lockstep too: the bridge and its boards run on the wall\n"
    "clock (docs/hardware.md, \"A lost bridge is named\").\n";

// --controller LIB.so with its arguments, in its host process (or in this one with
// --controller-in-process). Loaded before joining the bus: a library that cannot be used stops
// the process here (exit 2, one line), before it answers any state, so nothing moves.
std::shared_ptr<sirupp::control::EffortLaw> LoadController(const sirupp::runtime::Args& args,
                                                           const sirupp::core::RobotModel& model) {
  std::string controller_args;
  if (args.Has("controller-args")) {
    for (const std::string& word : args.Values("controller-args", -1)) {
      controller_args += (controller_args.empty() ? "" : " ") + word;
    }
  }
  sirupp::control::IsolationOptions isolation;
  isolation.tick_limit_s = args.Number("controller-tick-limit", isolation.tick_limit_s);
  isolation.sandbox = !args.Switch("no-sandbox");
  const bool in_process = args.Switch("controller-in-process");
  std::shared_ptr<sirupp::control::EffortLaw> law;
  if (in_process &&
      sirupp::control::HostProgramName(args.String("controller")) != "sirupp-controller-host") {
    throw sirupp::core::UsageError("--controller-in-process: " + args.String("controller") +
                                   " is a Python controller; it runs only in its host process");
  }
  if (in_process) {
    law = std::make_shared<sirupp::control::PluginEffortLaw>(args.String("controller"),
                                                             controller_args, model);
  } else {
    law = std::make_shared<sirupp::control::IsolatedEffortLaw>(args.String("controller"),
                                                               controller_args, model, isolation);
  }
  std::cerr << "sirupp-control: controller " << law->name() << " ("
            << (controller_args.empty() ? "no arguments" : "'" + controller_args + "'")
            << ") in place of the PID, "
            << (in_process ? std::string("in this process")
                           : "in its host process (call limit " +
                                 sirupp::core::FormatNumber(isolation.tick_limit_s) + " s; " +
                                 (isolation.sandbox
                                      ? sirupp::sandbox::Describe(sirupp::sandbox::ProbeMachine(),
                                                                  isolation.sandbox_limits)
                                      : std::string("no sandbox (--no-sandbox)")) +
                                 ")")
            << "\n";
  return law;
}

int Run(const std::vector<std::string>& argv) {
  const sirupp::runtime::Args args(
      argv, "sirupp-control",
      {sirupp::runtime::ModelFlag(), Flag("name", "participant name").Takes("NAME"),
       Flag("no-setpoints", "do not publish ARM_SETPOINT").Switch(),
       Flag("boards", "where the virtual PIC-SERVO boards run")
           .Takes("WHERE")
           .OneOf({"sim", "control"}),
       Flag("lcm-url", "LCM URL").Takes("URL"),
       Flag("prefix", "channel prefix of the rig").Takes("PREFIX"),
       sirupp::runtime::RtPriorityFlag(),
       Flag("sim-timeout", "seconds without a sim state that abort a plan")
           .Takes("S")
           .Above(0, 3600),
       Flag("bridge-timeout", "seconds without a bridge status that lose the real arm")
           .Takes("S")
           .Above(0, 3600),
       Flag("controller", "controller library (.so) or Python file (.py)").Takes("LIB.so"),
       Flag("controller-args", "arguments for the controller library").Takes("TEXT", -1),
       Flag("controller-tick-limit", "seconds one controller call may take")
           .Takes("S")
           .Above(0, 60),
       Flag("controller-in-process", "load the library into this process").Switch(),
       Flag("no-sandbox", "run the controller's host unconfined").Switch()},
      kAbout);
  const int rt_priority = static_cast<int>(args.Integer("rt-priority", 0));
  const sirupp::core::RobotModel model =
      sirupp::core::LoadRobotModel(sirupp::runtime::ModelFileArg(args));
  sirupp::control::ControlOptions options;
  if (args.Has("name")) {
    options.name = args.String("name");
    // The name the sim waits for in lockstep (--participants); it refuses an empty one too.
    if (options.name.empty()) {
      throw sirupp::core::UsageError(
          "sirupp-control: --name '': allowed a non-empty participant name (as in sirupp-sim "
          "--participants)");
    }
  }
  options.publish_setpoints = !args.Switch("no-setpoints");
  options.boards_in_sim = !args.Has("boards") || args.String("boards") == "sim";
  options.sim_timeout_s = args.Number("sim-timeout", options.sim_timeout_s);
  options.bridge_timeout_s = args.Number("bridge-timeout", options.bridge_timeout_s);
  for (const char* flag :
       {"controller-args", "controller-tick-limit", "controller-in-process", "no-sandbox"}) {
    if (args.Has(flag) && !args.Has("controller")) {
      throw sirupp::core::UsageError(std::string("sirupp-control: --") + flag +
                                     " needs --controller LIB.so");
    }
  }
  if (args.Has("controller")) options.effort_law = LoadController(args, model);
  sirupp::core::Bus bus(args.Has("lcm-url") ? args.String("lcm-url") : "",
                        args.Has("prefix") ? args.String("prefix") : "");
  sirupp::control::ControlNode node(bus, model, options);
  std::cerr << "sirupp-control: " << model.name << ", participant '" << options.name << "', "
            << (node.sequencer().boards_remote()
                    ? "the boards in sirupp-sim"
                    : std::string("the boards here") +
                          (options.effort_law ? " (a student's controller)" : ""))
            << ", on " << bus.url() << "\n";
  sirupp::runtime::RequestRealtimePriority(rt_priority, "sirupp-control");
  sirupp::runtime::ServiceUntilSignal([&node] {
    node.Service(50);
    return node.start_refusal().empty();
  });
  if (!node.start_refusal().empty()) {
    // Another robot in the sim before this controller moved anything: nothing is driven.
    std::cerr << "sirupp-control: " << node.start_refusal() << "\n";
    return 2;
  }
  std::cerr << "sirupp-control: stopped after answering " << node.states_answered() << " states, "
            << node.move_id() << " moves\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return sirupp::runtime::ProcessMain(argc, argv, "sirupp-control", Run);
}
