// Stands in for sirupp-control in test_grade_runner: answers every SIM_ARM_STATE (as lockstep
// participant "sirupp-control", holding the arm) but never replies to a command, so the grader's
// plan is never taken. Takes sirupp-control's arguments and uses only --lcm-url.

#include <sirupp/arm_command_t.hpp>
#include <sirupp/arm_state_t.hpp>
#include <string>

#include "core/bus.hpp"
#include "core/channels.hpp"

int main(int argc, char** argv) {
  std::string url;
  for (int i = 1; i + 1 < argc; ++i) {
    if (std::string(argv[i]) == "--lcm-url") url = argv[i + 1];
  }
  sirupp::core::Bus bus(url);
  const sirupp::core::Channels channels;
  int64_t seq = 0;
  bus.Subscribe<sirupp::arm_state_t>(channels.sim_arm_state, [&](const sirupp::arm_state_t& state,
                                                                 const sirupp::core::ReceiveInfo&) {
    sirupp::arm_command_t command{};
    command.utime = state.utime;
    command.seq = seq++;
    command.tick = state.tick;
    command.sender = "sirupp-control";
    command.mode = sirupp::arm_command_t::MODE_HOLD;
    command.num_joints = state.num_joints;
    command.effort.assign(static_cast<size_t>(state.num_joints), 0.0);
    bus.Publish(channels.sim_arm_command, command);
  });
  for (;;) bus.Handle(100);
}
