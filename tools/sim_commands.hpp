#pragma once
// `sirupp reset` (teleport the simulated arm, sim_reset_t on SIM_RESET) and `sirupp move joints`
// (a joint target for sirupp-control on ARM_TARGET) from the command line.

#include <iosfwd>
#include <string>
#include <vector>

namespace sirupp::tools {

extern const char* const kResetUsage;
extern const char* const kMoveUsage;

// args: the words after "reset". Publishes one sim_reset_t and returns 0; bad arguments throw
// core::UsageError (exit 2), a bad model core::ConfigError (exit 2).
int RunReset(const std::vector<std::string>& args, std::ostream& out);

// `sirupp move joints`: one joint_target_t on ARM_TARGET for sirupp-control. Bad arguments and
// targets outside the limits throw core::UsageError (exit 2); nothing is sent then.
int RunMove(const std::vector<std::string>& args, std::ostream& out);

}  // namespace sirupp::tools
