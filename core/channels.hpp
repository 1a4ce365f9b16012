#pragma once
// The LCM channel names of SIRUPP in one place, and the table of who publishes what at which rate
// (the same content as docs/channels.md; tests/test_channels.cpp keeps the two in agreement).
//
// Two ways to run several rigs on one network, use one of them, not both:
//  - give the rig prefix to Bus (core/bus.hpp) and use the default Channels: the Bus prepends it;
//  - or build Channels::WithPrefix(prefix) for code that talks to LCM without a Bus (lcm-logger
//    channel filters, scripts, listings of full names).

#include <string>
#include <vector>

namespace sirupp::core {

// One std::string per channel, defaults as on the wire without prefix. Members are settable so that
// a lab layout can rename a channel without touching code.
struct Channels {
  std::string robot_model = "ROBOT_MODEL";
  std::string environment = "ENVIRONMENT";
  std::string sim_arm_state = "SIM_ARM_STATE";
  std::string sim_arm_command = "SIM_ARM_COMMAND";
  std::string sim_reset = "SIM_RESET";
  std::string sim_status = "SIM_STATUS";
  std::string sim_command = "SIM_COMMAND";
  std::string sim_reply = "SIM_REPLY";
  std::string arm_move = "ARM_MOVE";
  std::string arm_setpoint = "ARM_SETPOINT";
  std::string arm_gains = "ARM_GAINS";
  std::string controller_gains = "CONTROLLER_GAINS";
  std::string arm_target = "ARM_TARGET";
  std::string arm_pose_target = "ARM_POSE_TARGET";
  std::string arm_plan = "ARM_PLAN";
  std::string controller_status = "CONTROLLER_STATUS";
  std::string controller_reply = "CONTROLLER_REPLY";
  std::string real_arm_state = "REAL_ARM_STATE";
  std::string real_arm_setpoint = "REAL_ARM_SETPOINT";
  std::string real_arm_gains = "REAL_ARM_GAINS";
  std::string hardware_status = "HARDWARE_STATUS";
  std::string hardware_command = "HARDWARE_COMMAND";
  std::string hardware_reply = "HARDWARE_REPLY";
  std::string logger_command = "LOGGER_COMMAND";
  std::string logger_reply = "LOGGER_REPLY";
  std::string estop = "ESTOP";
  std::string heartbeat = "HEARTBEAT";
  std::string viewer_image = "VIEWER_IMAGE";
  std::string viewer_camera = "VIEWER_CAMERA";

  // The defaults with `prefix` in front of each. Throws std::invalid_argument if the prefix is not
  // allowed (see ValidateChannelPrefix).
  static Channels WithPrefix(const std::string& prefix);

  // Every name, in the order of ChannelTable().
  std::vector<std::string> All() const;
};

// Throws std::invalid_argument naming the bad value unless `prefix` is empty or made of letters,
// digits and '_', and short enough that every channel stays within LCM's 63-character names.
void ValidateChannelPrefix(const std::string& prefix);

// One row of the channel table. Plain text (no markup); docs/channels.md shows the same rows.
struct ChannelInfo {
  std::string name;         // default name, without prefix
  std::string lcm_type;     // fully qualified LCM type, e.g. "sirupp.arm_state_t"
  std::string publisher;    // process(es) that send it
  std::string subscribers;  // process(es) that listen
  std::string rate;         // how often it is sent
  std::string carries;      // what is in it, in a few words
};

// Every channel of the system, in a fixed order (the order of Channels' members).
const std::vector<ChannelInfo>& ChannelTable();

}  // namespace sirupp::core
