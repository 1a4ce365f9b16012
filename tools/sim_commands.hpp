#pragma once
// `sirupp reset`: teleport the simulated arm (sim_reset_t on SIM_RESET) from the command line.

#include <iosfwd>
#include <string>
#include <vector>

namespace sirupp::tools {

extern const char* const kResetAbout;

// args: the words after "reset". Publishes one sim_reset_t and returns 0; bad arguments throw
// core::UsageError (exit 2), a bad model core::ConfigError (exit 2).
int RunReset(const std::vector<std::string>& args, std::ostream& out);

}  // namespace sirupp::tools
