// Example 1: load a robot model, send it on the bus as sirupp-sim does, and receive it as any other
// process would. In-process (memq://), so it runs anywhere; with a udpm:// URL the same code
// crosses PCs.
//
//   build/bin/example_01_model_on_the_bus [config/robots/puma260.yaml]
#include <iostream>
#include <sirupp/robot_model_t.hpp>

#include "core/bus.hpp"
#include "core/channels.hpp"
#include "core/model_loader.hpp"
#include "core/model_report.hpp"
#include "core/translate.hpp"

int main(int argc, char** argv) {
  using namespace sirupp::core;
  const std::string file = argc > 1 ? argv[1] : "config/robots/puma260.yaml";
  const RobotModel model = LoadRobotModel(file);  // throws ConfigError with file:line:col

  Bus bus("memq://");
  const Channels channels;
  Latest<sirupp::robot_model_t> latest(bus, channels.robot_model);

  bus.Publish(channels.robot_model, ToMessage(model, /*utime=*/0, /*seq=*/0));
  bus.HandleAvailable();

  // What a receiver does: rebuild the model and refuse it if anything is off.
  const RobotModel received = RobotModelFromMessage(latest.Get(), channels.robot_model);
  std::cout << "received on " << channels.robot_model << ": " << ModelSummary(received) << "\n";
  return received.source_hash == model.source_hash ? 0 : 1;
}
