#include "core/channels.hpp"

#include <algorithm>
#include <iterator>
#include <stdexcept>

namespace sirupp::core {

namespace {

bool IsPrefixCharacter(char c) {
  return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_';
}

std::size_t LongestDefaultName() {
  std::size_t longest = 0;
  for (const ChannelInfo& info : ChannelTable()) longest = std::max(longest, info.name.size());
  return longest;
}

}  // namespace

Channels Channels::WithPrefix(const std::string& prefix) {
  ValidateChannelPrefix(prefix);
  Channels channels;
  for (ChannelName* channel : channels.Each()) channel->SetName(prefix + channel->name());
  return channels;
}

std::vector<ChannelName*> Channels::Each() {
  return {&robot_model,       &environment,       &sim_arm_state,
          &sim_arm_ticks,     &sim_arm_command,   &sim_reset,
          &sim_status,        &sim_command,       &sim_reply,
          &sim_board_status,  &sim_board_command, &arm_move,
          &arm_setpoint,      &arm_gains,         &controller_gains,
          &arm_target,        &arm_pose_target,   &arm_plan,
          &controller_status, &controller_reply,  &real_arm_state,
          &real_arm_setpoint, &real_arm_gains,    &hardware_status,
          &hardware_command,  &hardware_reply,    &logger_command,
          &logger_reply,      &logger_pass,       &estop,
          &heartbeat,         &viewer_image,      &viewer_camera};
}

std::vector<const ChannelName*> Channels::Each() const {
  std::vector<ChannelName*> channels = const_cast<Channels*>(this)->Each();
  return {channels.begin(), channels.end()};
}

std::vector<std::string> Channels::All() const {
  std::vector<std::string> names;
  for (const ChannelName* channel : Each()) names.push_back(channel->name());
  return names;
}

std::vector<std::string> Channels::PerTick() const {
  return {sim_arm_state.name(),  sim_arm_command.name(),   arm_setpoint.name(),
          real_arm_state.name(), real_arm_setpoint.name(), sim_arm_ticks.name()};
}

std::vector<std::string> Channels::Exchange() const {
  return {sim_board_status.name(), sim_board_command.name(), controller_gains.name()};
}

void ValidateChannelPrefix(const std::string& prefix) {
  const std::size_t max_length = kMaxChannelNameLength - LongestDefaultName();
  const auto bad = std::find_if_not(prefix.begin(), prefix.end(), IsPrefixCharacter);
  if (bad != prefix.end()) {
    throw std::invalid_argument("channel prefix \"" + prefix + "\" has the character '" +
                                std::string(1, *bad) +
                                "': allowed are letters, digits and '_' (e.g. \"RIG3_\"), or an "
                                "empty prefix");
  }
  if (prefix.size() > max_length) {
    throw std::invalid_argument(
        "channel prefix \"" + prefix + "\" is " + std::to_string(prefix.size()) +
        " characters long: at most " + std::to_string(max_length) +
        " are allowed, so that every channel name fits LCM's 63 characters");
  }
}

namespace {

// The part of a table row that is prose: who sends and reads a channel, how often, what it carries.
// Name and type come from Channels.
// Plain text, so the table below is constant-initialised and safe to read at any time.
struct ChannelProse {
  const char* name;
  const char* publisher;
  const char* subscribers;
  const char* rate;
  const char* carries;
};

// Keep in step with docs/channels.md (tests/test_channels.cpp compares them row by row).
constexpr ChannelProse kProse[] = {
    {"ROBOT_MODEL", "sirupp-sim", "sirupp-control, sirupp-hardware, sirupp-logger, sirupp-viewer",
     "1 Hz, at start-up and at once after a model load (`SIM_COMMAND`)",
     "the robot model as the physics loaded it: DH rows, links, mass properties, limits, "
     "friction, servo parameters"},
    {"ENVIRONMENT", "sirupp-sim", "sirupp-control (a plan is checked against it), sirupp-viewer",
     "1 Hz", "the objects around the robot: shape, pose, size, colour, static or dynamic"},
    {"SIM_ARM_STATE", "sirupp-sim",
     "sirupp-control (running the boards itself), sirupp-logger, sirupp-viewer",
     "every physics tick (1953.125 Hz by default)",
     "virtual arm: tick, joint positions, velocities, applied efforts, limit and brake flags"},
    {"SIM_ARM_TICKS", "sirupp-sim",
     "sirupp-control (running the boards itself), sirupp-logger, sirupp-viewer (every reader of "
     "SIM_ARM_STATE or ARM_SETPOINT: the Bus hands each tick to it)",
     "every exchange tick (16 ticks, 122 Hz) while the sim's boards drive the arm, in place of "
     "SIM_ARM_STATE and ARM_SETPOINT",
     "several ticks' SIM_ARM_STATE and ARM_SETPOINT messages, in order, each with the wall time it "
     "was made"},
    {"SIM_ARM_COMMAND", "sirupp-control (or a student's controller)", "sirupp-sim",
     "one per SIM_ARM_STATE (sirupp-control with the sim's boards: one per SIM_BOARD_STATUS)",
     "joint efforts for the tick it answers, or hold / limp, or MODE_BOARDS: the sim's boards "
     "drive the arm until the next exchange tick"},
    {"SIM_RESET", "sirupp CLI, lesson scripts, tests", "sirupp-sim", "on demand",
     "teleport: joint positions (and speeds) set at once, objects optionally reset"},
    {"SIM_STATUS", "sirupp-sim", "sirupp CLI, bench_system, student controllers",
     "1 Hz, on a participant's change and on a new refusal",
     "run id, timing mode, real-time factor, slipped time, e-stop, each participant's answer "
     "time and state, refused commands per sender with the reason"},
    {"SIM_COMMAND", "sirupp-panel (client library)", "sirupp-sim", "on demand",
     "load an environment (the XML text) or a robot model (the YAML text, after `ARM_PLAN` "
     "`COMMAND_LOAD_MODEL` to sirupp-control) into the running sim between two ticks, the arm "
     "untouched"},
    {"SIM_REPLY", "sirupp-sim", "sirupp-panel (client library)", "one per SIM_COMMAND",
     "the answer to one command: its channel, utime and seq, accepted or refused and why"},
    {"SIM_BOARD_STATUS", "sirupp-sim", "sirupp-control",
     "every exchange tick (every 16 ticks by default, `sirupp-sim --exchange-ticks`)",
     "the virtual PIC-SERVO boards beside the physics: the arm's state and the boards' set-points "
     "and status at the tick sirupp-control answers, the last board command applied"},
    {"SIM_BOARD_COMMAND", "sirupp-control", "sirupp-sim", "one per move, stop and servo-on",
     "a command for the virtual boards (the same servo_move_t as ARM_MOVE, also servo on and "
     "motor off): applied at the tick of the sender's next answer"},
    {"ARM_MOVE", "sirupp-control", "sirupp-hardware", "one per move",
     "per-joint goal, maximum velocity and acceleration: the PIC-SERVO LOAD_TRAJ analogue"},
    {"ARM_SETPOINT", "sirupp-sim (its boards) or sirupp-control (running them itself)",
     "sirupp-logger, sirupp-viewer", "every servo tick",
     "profiled set-point position and velocity, goal, position error, effort, move-done per "
     "joint"},
    {"ARM_GAINS", "sirupp CLI or user", "sirupp-control, sirupp-hardware, sirupp-logger",
     "on change", "Kp, Kd, Ki, integration, output and error limits per joint, in chip units"},
    {"CONTROLLER_GAINS", "sirupp-control", "sirupp-sim, sirupp CLI, sirupp-logger",
     "1 Hz and on change",
     "the gains the virtual servos run with now, in chip units (sirupp-sim's boards take them at "
     "the tick of sirupp-control's next answer)"},
    {"ARM_TARGET", "sirupp CLI or user", "sirupp-control", "on demand",
     "a joint-space target with per-joint speed and acceleration"},
    {"ARM_POSE_TARGET", "sirupp CLI", "sirupp-control", "on demand",
     "an end-effector pose and the wanted IK configuration (shoulder, elbow, wrist)"},
    {"ARM_PLAN", "sirupp CLI", "sirupp-control", "on demand",
     "plan text and run / pause / resume / abort, manual or automatic mode, clear fault; load "
     "model: the model text the sim is about to load (docs/panel.md)"},
    {"CONTROLLER_STATUS", "sirupp-control",
     "sirupp CLI, sirupp-logger, sirupp-viewer, sirupp-hardware", "10 Hz and on change",
     "mode, state, present move and plan step, last error"},
    {"CONTROLLER_REPLY", "sirupp-control", "sirupp CLI, sirupp demo, sirupp-panel, sirupp grade",
     "one per ARM_TARGET, ARM_POSE_TARGET, ARM_PLAN and ARM_GAINS",
     "the answer to one command: its channel, utime and seq, accepted or refused and why, the "
     "move it started"},
    {"REAL_ARM_STATE", "sirupp-hardware", "sirupp-logger, sirupp-viewer",
     "every status poll (about 100-500 Hz)",
     "real arm: joint positions and velocities from the encoders, estimated efforts"},
    {"REAL_ARM_SETPOINT", "sirupp-hardware", "lcm-spy", "with every REAL_ARM_STATE",
     "the real chips' own command positions (position + position error), goals, status"},
    {"REAL_ARM_GAINS", "sirupp-hardware", "sirupp CLI, sirupp-logger", "1 Hz and on change",
     "the gains loaded into the real boards (SET_GAIN), in chip units"},
    {"HARDWARE_STATUS", "sirupp-hardware", "sirupp-control, sirupp CLI, sirupp demo",
     "10 Hz and on change",
     "bridge state (connected, armed, linked, fault), module status, serial errors"},
    {"HARDWARE_COMMAND", "sirupp CLI", "sirupp-hardware", "on demand",
     "connect, calibrate, arm, disarm, link, unlink, home, clear faults"},
    {"HARDWARE_REPLY", "sirupp-hardware", "sirupp-control, sirupp CLI, sirupp-panel",
     "one per HARDWARE_COMMAND, ARM_MOVE and ARM_GAINS",
     "the answer to one command: its channel, utime and seq, accepted or refused and why"},
    {"LOGGER_COMMAND", "sirupp-panel (client library)", "sirupp-logger", "on demand",
     "start recording a named run, or stop the present one"},
    {"LOGGER_REPLY", "sirupp-logger", "sirupp-panel (client library)", "one per LOGGER_COMMAND",
     "the answer to one command: its channel, utime and seq, accepted or refused and why"},
    {"LOGGER_PASS", "sirupp-logger (into its raw log only, never on the bus)",
     "none on the bus (sirupp-logger --from-log reads the raw log)",
     "one per writer pass (every 25 ms while messages come)",
     "when the writer took its messages and how many so far, and the logger's settings (row "
     "clock, --max-age, --idle, --split, --velocities, --efforts, --note, model file, prefix): "
     "--from-log replays the live rows with them"},
    {"ESTOP", "any process", "sirupp-sim, sirupp-control, sirupp-hardware", "on demand",
     "emergency stop engaged or released, by whom and why"},
    {"HEARTBEAT", "every process", "sirupp launch, sirupp CLI", "1 Hz (10 Hz while starting)",
     "process name, host, pid, state and per-channel traffic counters"},
    {"VIEWER_IMAGE", "sirupp-viewer", "sirupp view, lcm-spy", "chosen rate (e.g. 10-30 Hz)",
     "rendered frames (JPEG or raw pixels) in the bot_core.image_t layout"},
    {"VIEWER_CAMERA", "sirupp view, lesson scripts or user", "sirupp-viewer", "on demand",
     "camera azimuth, elevation, distance and target; DH frames and ghost on or off; a PNG "
     "snapshot"},
};

// The rows: name and type from Channels, the rest from kProse, checked to be in the same order.
std::vector<ChannelInfo> BuildTable() {
  const Channels channels;
  const std::vector<const ChannelName*> typed = channels.Each();
  if (typed.size() != std::size(kProse))
    throw std::logic_error("channel table: rows do not match Channels");
  std::vector<ChannelInfo> table;
  for (std::size_t i = 0; i < typed.size(); ++i) {
    const ChannelProse& row = kProse[i];
    if (typed[i]->name() != row.name) {
      throw std::logic_error("channel table: row " + std::to_string(i) + " is " + row.name +
                             ", Channels has " + typed[i]->name());
    }
    table.push_back(ChannelInfo{typed[i]->name(), typed[i]->lcm_type(), row.publisher,
                                row.subscribers, row.rate, row.carries});
  }
  return table;
}

}  // namespace

const std::vector<ChannelInfo>& ChannelTable() {
  static const std::vector<ChannelInfo> table = BuildTable();
  return table;
}

}  // namespace sirupp::core
