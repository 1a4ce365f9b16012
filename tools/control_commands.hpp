#pragma once
// The command line of sirupp-control: `sirupp move joints|pose`, `sirupp plan
// check|run|pause|resume|abort|manual|automatic`, `sirupp gains`, `sirupp status`.
//
// Everything that can be checked here is checked before anything is sent (limits, IK, the whole
// plan, gain ranges): bad input exits 2 and nothing moves. After sending, the command watches
// CONTROLLER_STATUS for the controller's answer: refused (exit 1, its reason printed), accepted
// (exit 0), or no controller heard (exit 1). With --wait it follows the move or plan to its end.

#include <iosfwd>
#include <string>
#include <vector>

namespace sirupp::tools {

extern const char* const kMoveUsage;
extern const char* const kPlanUsage;
extern const char* const kGainsUsage;
extern const char* const kStatusUsage;

int RunMove(const std::vector<std::string>& args, std::ostream& out);
int RunPlan(const std::vector<std::string>& args, std::ostream& out);
int RunGains(const std::vector<std::string>& args, std::ostream& out);
int RunStatus(const std::vector<std::string>& args, std::ostream& out);

}  // namespace sirupp::tools
