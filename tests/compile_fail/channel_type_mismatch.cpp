// Must NOT compile: an ESTOP message published on the arm-state channel. The test
// channel_type_mismatch_does_not_compile (tests/CMakeLists.txt) builds this file and passes only
// when the compiler stops at core/channel.hpp's "channel type mismatch".

#include "core/bus.hpp"
#include "core/channels.hpp"

int main() {
  sirupp::core::Bus bus("memq://");
  const sirupp::core::Channels channels;
  sirupp::estop_t estop{};
  bus.Publish(channels.sim_arm_state, estop);
  return 0;
}
