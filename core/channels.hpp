#pragma once
// The LCM channel names of SIRUPP in one place, and the table of who publishes what at which rate
// (the same content as docs/channels.md; tests/test_channels.cpp keeps the two in agreement).
//
// Two ways to run several rigs on one network, use one of them, not both:
//  - give the rig prefix to Bus (core/bus.hpp) and use the default Channels: the Bus prepends it;
//  - or build Channels::WithPrefix(prefix) for code that talks to LCM without a Bus (lcm-logger
//    channel filters, scripts, listings of full names).

#include <cstddef>
#include <sirupp/arm_command_t.hpp>
#include <sirupp/arm_state_t.hpp>
#include <sirupp/arm_ticks_t.hpp>
#include <sirupp/board_status_t.hpp>
#include <sirupp/command_reply_t.hpp>
#include <sirupp/controller_status_t.hpp>
#include <sirupp/environment_t.hpp>
#include <sirupp/estop_t.hpp>
#include <sirupp/hardware_command_t.hpp>
#include <sirupp/hardware_status_t.hpp>
#include <sirupp/heartbeat_t.hpp>
#include <sirupp/image_t.hpp>
#include <sirupp/joint_target_t.hpp>
#include <sirupp/logger_command_t.hpp>
#include <sirupp/logger_pass_t.hpp>
#include <sirupp/plan_command_t.hpp>
#include <sirupp/pose_target_t.hpp>
#include <sirupp/robot_model_t.hpp>
#include <sirupp/servo_gains_t.hpp>
#include <sirupp/servo_move_t.hpp>
#include <sirupp/servo_setpoint_t.hpp>
#include <sirupp/sim_command_t.hpp>
#include <sirupp/sim_reset_t.hpp>
#include <sirupp/sim_status_t.hpp>
#include <sirupp/viewer_camera_t.hpp>
#include <string>
#include <vector>

#include "core/channel.hpp"

namespace sirupp::core {

// LCM_MAX_CHANNEL_NAME_LENGTH in lcm.h. udpm:// refuses longer names at publish time (a failure
// deep inside a running process); memq:// accepts them, so the bus and the channel names check it
// themselves, and a test on memq fails the way the lab would.
inline constexpr std::size_t kMaxChannelNameLength = 63;

// One typed channel per name (core/channel.hpp), defaults as on the wire without prefix. Names are
// settable so that a lab layout can rename a channel without touching code; types are not.
struct Channels {
  Channel<sirupp::robot_model_t> robot_model{"ROBOT_MODEL"};
  Channel<sirupp::environment_t> environment{"ENVIRONMENT"};
  Channel<sirupp::arm_state_t> sim_arm_state{"SIM_ARM_STATE"};
  Channel<sirupp::arm_ticks_t> sim_arm_ticks{"SIM_ARM_TICKS"};
  Channel<sirupp::arm_command_t> sim_arm_command{"SIM_ARM_COMMAND"};
  Channel<sirupp::sim_reset_t> sim_reset{"SIM_RESET"};
  Channel<sirupp::sim_status_t> sim_status{"SIM_STATUS"};
  Channel<sirupp::sim_command_t> sim_command{"SIM_COMMAND"};
  Channel<sirupp::command_reply_t> sim_reply{"SIM_REPLY"};
  Channel<sirupp::board_status_t> sim_board_status{"SIM_BOARD_STATUS"};
  Channel<sirupp::servo_move_t> sim_board_command{"SIM_BOARD_COMMAND"};
  Channel<sirupp::servo_move_t> arm_move{"ARM_MOVE"};
  Channel<sirupp::servo_setpoint_t> arm_setpoint{"ARM_SETPOINT"};
  Channel<sirupp::servo_gains_t> arm_gains{"ARM_GAINS"};
  Channel<sirupp::servo_gains_t> controller_gains{"CONTROLLER_GAINS"};
  Channel<sirupp::joint_target_t> arm_target{"ARM_TARGET"};
  Channel<sirupp::pose_target_t> arm_pose_target{"ARM_POSE_TARGET"};
  Channel<sirupp::plan_command_t> arm_plan{"ARM_PLAN"};
  Channel<sirupp::controller_status_t> controller_status{"CONTROLLER_STATUS"};
  Channel<sirupp::command_reply_t> controller_reply{"CONTROLLER_REPLY"};
  Channel<sirupp::arm_state_t> real_arm_state{"REAL_ARM_STATE"};
  Channel<sirupp::servo_setpoint_t> real_arm_setpoint{"REAL_ARM_SETPOINT"};
  Channel<sirupp::servo_gains_t> real_arm_gains{"REAL_ARM_GAINS"};
  Channel<sirupp::hardware_status_t> hardware_status{"HARDWARE_STATUS"};
  Channel<sirupp::hardware_command_t> hardware_command{"HARDWARE_COMMAND"};
  Channel<sirupp::command_reply_t> hardware_reply{"HARDWARE_REPLY"};
  Channel<sirupp::logger_command_t> logger_command{"LOGGER_COMMAND"};
  Channel<sirupp::command_reply_t> logger_reply{"LOGGER_REPLY"};
  Channel<sirupp::logger_pass_t> logger_pass{"LOGGER_PASS"};
  Channel<sirupp::estop_t> estop{"ESTOP"};
  Channel<sirupp::heartbeat_t> heartbeat{"HEARTBEAT"};
  Channel<sirupp::image_t> viewer_image{"VIEWER_IMAGE"};
  Channel<sirupp::viewer_camera_t> viewer_camera{"VIEWER_CAMERA"};

  // The defaults with `prefix` in front of each. Throws std::invalid_argument if the prefix is not
  // allowed (see ValidateChannelPrefix).
  static Channels WithPrefix(const std::string& prefix);

  // Every name, in the order of ChannelTable().
  std::vector<std::string> All() const;
  // The per-tick channels: one message every physics or servo tick, or every status poll of the
  // real arm (SIM_ARM_STATE, SIM_ARM_COMMAND, ARM_SETPOINT, REAL_ARM_STATE, REAL_ARM_SETPOINT), and
  // SIM_ARM_TICKS, which carries several of SIM_ARM_STATE's and ARM_SETPOINT's ticks at once.
  // On udpm:// a process's LCM socket drops those it does not subscribe (core/bus.hpp).
  std::vector<std::string> PerTick() const;
  // The channels of the exchange between sirupp-sim's virtual boards and sirupp-control
  // (SIM_BOARD_STATUS, SIM_BOARD_COMMAND, CONTROLLER_GAINS): not per tick, but read with the
  // per-tick one from the same socket (Bus::ReadDirectly), so a command and the answer after it
  // are taken in the order they were sent. LCM's socket drops them only when read so.
  std::vector<std::string> Exchange() const;
  // Every channel, name and type, in the order of ChannelTable().
  std::vector<const ChannelName*> Each() const;
  std::vector<ChannelName*> Each();
};

// Throws std::invalid_argument naming the bad value unless `prefix` is empty or made of letters,
// digits and '_', and short enough that every channel stays within LCM's 63-character names.
void ValidateChannelPrefix(const std::string& prefix);

// One row of the channel table. Plain text (no markup); docs/channels.md shows the same rows.
struct ChannelInfo {
  std::string name;         // default name, without prefix (from Channels)
  std::string lcm_type;     // fully qualified LCM type, e.g. "sirupp.arm_state_t" (from Channels)
  std::string publisher;    // process(es) that send it
  std::string subscribers;  // process(es) that listen
  std::string rate;         // how often it is sent
  std::string carries;      // what is in it, in a few words
};

// Every channel of the system, in a fixed order (the order of Channels' members).
const std::vector<ChannelInfo>& ChannelTable();

}  // namespace sirupp::core
