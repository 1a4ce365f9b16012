#pragma once
// The command line of sirupp-control: `sirupp move joints|pose`, `sirupp plan
// check|run|pause|resume|abort|manual|automatic`, `sirupp gains`, `sirupp status`.
//
// Everything that can be checked here is checked before anything is sent (limits, IK, the whole
// plan, gain ranges): bad input exits 2 and nothing moves. After sending, the command watches
// CONTROLLER_REPLY for the controller's answer to that request (client/client.hpp): refused (exit
// 1, its reason printed), accepted (exit 0), or no controller heard (exit 1). With --wait it
// follows the move or plan to its end.

#include <iosfwd>
#include <string>
#include <vector>

#include "client/client.hpp"
#include "core/robot_model.hpp"

namespace sirupp::tools {

extern const char* const kMoveAbout;
extern const char* const kPlanAbout;
extern const char* const kClearFaultAbout;
extern const char* const kGainsAbout;
extern const char* const kStatusAbout;

int RunMove(const std::vector<std::string>& args, std::ostream& out);
int RunPlan(const std::vector<std::string>& args, std::ostream& out);
int RunGains(const std::vector<std::string>& args, std::ostream& out);
int RunStatus(const std::vector<std::string>& args, std::ostream& out);

// `sirupp plan run FILE`: checks the plan from the arm's present goals (throws
// core::ConfigError naming file:line if bad), sends it and reports the controller's answer; with
// wait_s > 0 follows it to its end, printing each step. Returns 0 when it ran (to its end with
// wait_s), 1 otherwise. Used by `sirupp demo` too.
int RunPlanFile(client::Client& rig, const core::RobotModel& model, const std::string& file,
                double wait_s, std::ostream& out);

}  // namespace sirupp::tools
