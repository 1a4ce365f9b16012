#pragma once
// The command line of sirupp-hardware: `sirupp hardware connect|calibrate|arm|disarm|link|unlink|
// home|clear-faults|status` and `sirupp estop [--release]`. A command is sent on HARDWARE_COMMAND,
// then HARDWARE_STATUS is watched for the bridge's answer: the state it leads to (exit 0), a
// refusal with its reason (exit 1), or no bridge heard (exit 1).

#include <iosfwd>
#include <string>
#include <vector>

namespace sirupp::tools {

extern const char* const kHardwareUsage;
extern const char* const kEstopUsage;

int RunHardware(const std::vector<std::string>& args, std::ostream& out);
int RunEstop(const std::vector<std::string>& args, std::ostream& out);

}  // namespace sirupp::tools
