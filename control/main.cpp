// sirupp-control: the virtual PIC-SERVOs as an LCM process (first slice: joint targets). Thin main.

#include <atomic>
#include <csignal>
#include <iostream>

#include "control/control_node.hpp"
#include "core/bus.hpp"
#include "core/errors.hpp"
#include "core/model_loader.hpp"
#include "tools/args.hpp"
#include "tools/cli.hpp"

namespace {

constexpr const char* kUsage =
    "usage: sirupp-control [--model FILE] [--name NAME] [--no-setpoints] [--lcm-url URL]\n"
    "                      [--prefix PREFIX]\n"
    "The virtual PIC-SERVOs: answers every SIM_ARM_STATE with joint efforts on SIM_ARM_COMMAND\n"
    "(as participant NAME, default sirupp-control), takes joint targets on ARM_TARGET (see\n"
    "`sirupp move`), publishes ARM_MOVE, ARM_SETPOINT, CONTROLLER_STATUS and HEARTBEAT.\n";

std::atomic<bool> g_stop{false};
extern "C" void OnSignal(int /*signal*/) { g_stop = true; }

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
  std::signal(SIGINT, OnSignal);
  std::signal(SIGTERM, OnSignal);
  while (!g_stop) {
    try {
      node.Service(50);
    } catch (const sirupp::core::BusError&) {
      if (g_stop) break;
      throw;
    }
  }
  std::cerr << "sirupp-control: stopped after answering " << node.states_answered() << " states, "
            << node.move_id() << " moves\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  const std::vector<std::string> args(argv + 1, argv + argc);
  for (const std::string& arg : args) {
    if (arg == "--help" || arg == "-h") {
      std::cout << kUsage;
      return 0;
    }
  }
  try {
    return Run(args);
  } catch (const sirupp::core::UsageError& error) {
    std::cerr << error.what() << "\n" << kUsage;
    return 2;
  } catch (const sirupp::core::ConfigError& error) {
    std::cerr << "sirupp-control: " << error.what() << "\n";
    return 2;
  } catch (const std::exception& error) {
    std::cerr << "sirupp-control: " << error.what() << "\n";
    return 1;
  }
}
