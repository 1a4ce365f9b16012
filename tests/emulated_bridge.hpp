#pragma once
// The bridge to the real arm (hardware::BridgeNode) on the emulated PIC-SERVO boards, on a bus the
// test gives: connected and calibrated, servos off at the "ready" pose, with a start guard of 0
// and reply margins for a loaded machine, used by the class server's turns tests
// (tests/test_class_turns.cpp, on a udpm bus). The line is a Unix socket in a folder of its own,
// as in the demo and the layouts: polling a pty waits for the kernel's tty worker, and with one
// busy loop per core the emulator's thread sat in that wait for seconds (its emulated time
// slipped up to 8 s and the bridge faulted "no reply").

#include <stdlib.h>
#include <unistd.h>

#include <memory>
#include <stdexcept>
#include <string>

#include "core/bus.hpp"
#include "core/robot_model.hpp"
#include "hardware/arm_link.hpp"
#include "hardware/bridge_node.hpp"
#include "hardware/emulator.hpp"
#include "hardware/serial_port.hpp"

namespace sirupp::testing {

struct EmulatedBridge {
  EmulatedBridge(core::Bus& bus, const core::RobotModel& model)
      : settings(hardware::DefaultBridgeSettings(model)), folder(MakeFolder()) {
    constexpr double kDeg = 3.14159265358979323846 / 180;
    hardware::EmulatorOptions eo;
    eo.model = model;
    eo.socket = folder + "/line";
    eo.start_positions = {0, -90 * kDeg, 90 * kDeg, 0, 45 * kDeg, 0};  // ready, servos off
    settings.calibration_pose = "ready";
    settings.start_guard_s = 0;
    settings.reply_margin_ms = 500;  // a loaded machine may starve the emulator's thread
    settings.retries = 4;
    emulator = std::make_unique<hardware::Emulator>(eo);
    emulator->Start();
    port = std::make_unique<hardware::SerialPort>(emulator->device(), hardware::nmc::kPowerUpBaud);
    link = std::make_unique<hardware::ArmLink>(model, settings, *port);
    bridge = std::make_unique<hardware::BridgeNode>(bus, model, *link, settings);
    bridge->Connect();
    bridge->Calibrate();
  }
  ~EmulatedBridge() {
    bridge.reset();
    link.reset();
    port.reset();
    emulator->Stop();
    emulator.reset();
    ::unlink((folder + "/line").c_str());
    ::rmdir(folder.c_str());
  }
  EmulatedBridge(const EmulatedBridge&) = delete;
  EmulatedBridge& operator=(const EmulatedBridge&) = delete;

  static std::string MakeFolder() {
    char path[] = "/tmp/sirupp-emulated-bridge.XXXXXX";
    if (::mkdtemp(path) == nullptr)
      throw std::runtime_error("mkdtemp failed for the emulator's line");
    return path;
  }

  hardware::BridgeSettings settings;
  std::string folder;
  std::unique_ptr<hardware::Emulator> emulator;
  std::unique_ptr<hardware::SerialPort> port;
  std::unique_ptr<hardware::ArmLink> link;
  std::unique_ptr<hardware::BridgeNode> bridge;
};

}  // namespace sirupp::testing
