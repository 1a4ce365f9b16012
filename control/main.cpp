// sirupp-control: the virtual PIC-SERVOs as an LCM process (first slice: joint targets). Thin main.

#include <iostream>

#include "control/control_node.hpp"
#include "core/bus.hpp"
#include "core/errors.hpp"
#include "core/model_loader.hpp"
#include "tools/args.hpp"
#include "tools/cli.hpp"
#include "tools/process_main.hpp"

namespace {

constexpr const char* kUsage =
    "usage: sirupp-control [--model FILE] [--name NAME] [--no-setpoints] [--lcm-url URL]\n"
    "                      [--prefix PREFIX]\n"
    "The virtual PIC-SERVOs: answers every SIM_ARM_STATE with joint efforts on SIM_ARM_COMMAND\n"
    "(as participant NAME, default sirupp-control), takes joint targets on ARM_TARGET (see\n"
    "`sirupp move`), publishes ARM_MOVE, ARM_SETPOINT, CONTROLLER_STATUS and HEARTBEAT.\n";

int Run(const std::vector<std::string>& argv) {
  const sirupp::tools::Args args(argv, "sirupp-control",
                                 {{"model", "robot model file"},
                                  {"name", "participant name"},
                                  {"no-setpoints", "do not publish ARM_SETPOINT"},
                                  {"lcm-url", "LCM URL"},
                                  {"prefix", "channel prefix of the rig"}});
  const sirupp::core::RobotModel model =
      sirupp::core::LoadRobotModel(sirupp::tools::ResolveDataPath(
          args.Has("model") ? args.String("model") : "config/robots/puma260.yaml"));
  sirupp::control::ControlOptions options;
  if (args.Has("name")) options.name = args.String("name");
  options.publish_setpoints = !args.Switch("no-setpoints");
  sirupp::core::Bus bus(args.Has("lcm-url") ? args.String("lcm-url") : "",
                        args.Has("prefix") ? args.String("prefix") : "");
  sirupp::control::ControlNode node(bus, model, options);
  std::cerr << "sirupp-control: " << model.name << ", participant '" << options.name << "', on "
            << bus.url() << "\n";
  sirupp::tools::ServiceUntilSignal([&node] {
    node.Service(50);
    return true;
  });
  std::cerr << "sirupp-control: stopped after answering " << node.states_answered() << " states, "
            << node.move_id() << " moves\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return sirupp::tools::ProcessMain(argc, argv, "sirupp-control", kUsage, Run);
}
