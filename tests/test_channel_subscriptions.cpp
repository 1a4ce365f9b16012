// The channel table's subscriber column (core/channels.cpp, docs/channels.md) against the
// subscriptions each process's node really makes on its Bus: sirupp-sim, sirupp-control,
// sirupp-hardware (on the emulated boards), sirupp-logger and sirupp-viewer. A row that names a
// process which does not subscribe, or a subscription the table does not show, fails here.

#include <gtest/gtest.h>

#include <filesystem>
#include <memory>
#include <set>
#include <sstream>
#include <string>

#include "control/control_node.hpp"
#include "core/bus.hpp"
#include "core/channels.hpp"
#include "core/model_loader.hpp"
#include "hardware/arm_link.hpp"
#include "hardware/bridge_node.hpp"
#include "hardware/emulator.hpp"
#include "hardware/serial_port.hpp"
#include "logger/logger_node.hpp"
#include "logger/recorder.hpp"
#include "sim/arm_world.hpp"
#include "sim/sim_node.hpp"
#include "viewer/viewer_node.hpp"

namespace sirupp {
namespace {

const core::RobotModel& Puma() {
  static const core::RobotModel model = core::LoadRobotModel("config/robots/puma260.yaml");
  return model;
}

// The channels a bus subscribes to.
std::set<std::string> Subscribed(const core::Bus& bus) {
  std::set<std::string> names;
  for (const core::ChannelStats& stats : bus.Stats()) {
    if (!stats.publishing) names.insert(stats.channel);
  }
  return names;
}

// The channels whose table row lists `process` among its subscribers.
std::set<std::string> FromTable(const std::string& process) {
  std::set<std::string> names;
  for (const core::ChannelInfo& row : core::ChannelTable()) {
    std::istringstream list(row.subscribers);
    for (std::string who; std::getline(list, who, ',');) {
      who.erase(0, who.find_first_not_of(' '));
      if (who == process || who.rfind(process + " ", 0) == 0) names.insert(row.name);
    }
  }
  return names;
}

TEST(ChannelSubscriptions, SirupSimSubscribesWhatTheTableSays) {
  core::Bus bus("memq://");
  sim::ArmWorld world(Puma(), core::Environment{});
  sim::SimNode node(bus, world, core::Environment{}, sim::NodeOptions{});
  EXPECT_EQ(Subscribed(bus), FromTable("sirupp-sim"));
}

// The table's row for sirupp-control covers both places of the boards: in the sim it reads
// SIM_BOARD_STATUS, running them itself (a student's controller, --boards control) SIM_ARM_STATE
// (and SIM_ARM_TICKS, which the Bus follows for it).
TEST(ChannelSubscriptions, SirupControlSubscribesWhatTheTableSays) {
  for (const bool boards_in_sim : {false, true}) {
    SCOPED_TRACE(boards_in_sim ? "the boards in the sim" : "the boards in the controller");
    core::Bus bus("memq://");
    control::ControlOptions options;
    options.boards_in_sim = boards_in_sim;
    control::ControlNode node(bus, Puma(), options);
    std::set<std::string> expected = FromTable("sirupp-control");
    ASSERT_EQ(expected.erase(boards_in_sim ? "SIM_ARM_STATE" : "SIM_BOARD_STATUS"), 1u);
    // The ticks SIM_ARM_TICKS carries are SIM_ARM_STATE's: followed with it.
    if (boards_in_sim) {
      ASSERT_EQ(expected.erase("SIM_ARM_TICKS"), 1u);
    }
    EXPECT_EQ(Subscribed(bus), expected);
  }
}

TEST(ChannelSubscriptions, SirupHardwareSubscribesWhatTheTableSays) {
  hardware::EmulatorOptions eo;
  eo.model = Puma();
  hardware::Emulator emulator(eo);
  emulator.Start();
  {
    hardware::BridgeSettings settings = hardware::DefaultBridgeSettings(Puma());
    hardware::SerialPort port(emulator.device(), hardware::nmc::kPowerUpBaud);
    hardware::ArmLink link(Puma(), settings, port);
    core::Bus bus("memq://");
    hardware::BridgeNode node(bus, Puma(), link, settings);
    EXPECT_EQ(Subscribed(bus), FromTable("sirupp-hardware"));
  }
  emulator.Stop();
}

TEST(ChannelSubscriptions, SirupLoggerSubscribesWhatTheTableSays) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() /
                                    ("sirupp_subscriptions_" + std::to_string(::getpid()));
  {
    core::Bus bus("memq://");
    logger::LoggerOptions options;
    options.out_dir = dir.string();
    options.name = "t";
    logger::Recorder node(bus, Puma(), options);  // what sirupp-logger runs
    EXPECT_EQ(Subscribed(bus), FromTable("sirupp-logger"));
  }
  std::filesystem::remove_all(dir);
}

TEST(ChannelSubscriptions, SirupViewerSubscribesWhatTheTableSays) {
  core::Bus bus("memq://");
  viewer::ViewerOptions options;
  options.publish_images = false;
  viewer::ViewerNode node(bus, options);
  EXPECT_EQ(Subscribed(bus), FromTable("sirupp-viewer"));
}

}  // namespace
}  // namespace sirupp
