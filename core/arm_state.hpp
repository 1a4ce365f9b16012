#pragma once
// Value structs for what flows every tick: the arm's joint state and the effort command answering
// it. Units: rad, rad/s, N*m (m, m/s, N for prismatic joints); utime in microseconds.

#include <cstdint>
#include <string>
#include <vector>

namespace sirupp::core {

enum class StateSource : int8_t { kSim = 0, kReal = 1, kEmulated = 2 };

struct ArmState {
  int64_t utime = 0;
  int64_t tick = 0;
  StateSource source = StateSource::kSim;
  std::vector<double> position;
  std::vector<double> velocity;
  std::vector<double> effort;
  std::vector<int8_t> flags;  // arm_state_t::FLAG_* bits per joint

  int num_joints() const { return static_cast<int>(position.size()); }
};

// arm_command_t::MODE_*. kBoards: the virtual boards in sirupp-sim drive the arm until the
// sender's next answer (sim/sim_node.hpp); the sim's own combined command is never kBoards.
enum class CommandMode : int8_t { kEffort = 0, kHold = 1, kLimp = 2, kBoards = 3 };

struct ArmCommand {
  int64_t utime = 0;
  int64_t tick = 0;
  std::string sender;
  CommandMode mode = CommandMode::kEffort;
  std::vector<double> effort;
};

}  // namespace sirupp::core
