#pragma once
// The command line of sirupp-hardware: `sirupp hardware connect|calibrate|arm|disarm|link|unlink|
// home|clear-faults|status` and `sirupp estop [--release]`. A command is sent on HARDWARE_COMMAND,
// then HARDWARE_STATUS is watched for the bridge's answer: the state it leads to (exit 0), a
// refusal with its reason (exit 1), or no bridge heard (exit 1).

#include <iosfwd>
#include <string>
#include <vector>

namespace sirupp::tools {

extern const char* const kHardwareAbout;
extern const char* const kEstopAbout;

// The commands of `sirupp hardware` and one line on each.
std::vector<std::string> HardwareVerbs();
std::string HardwareVerbSummary(const std::string& verb);

int RunHardware(const std::vector<std::string>& args, std::ostream& out);
int RunEstop(const std::vector<std::string>& args, std::ostream& out);

}  // namespace sirupp::tools
