#pragma once
// `sirupp plan make` (a collision-free movement plan around an environment, through OMPL) and the
// collision sweep of `sirupp plan check --env` (every move's set-points against the environment
// and the arm itself). Over planning/ (the collision model, the planners) and control/ (plans and
// their set-points). docs/planning.md.

#include <iosfwd>
#include <string>
#include <vector>

#include "control/plan.hpp"
#include "core/robot_model.hpp"
#include "runtime/args.hpp"

namespace sirupp::tools {

extern const char* const kPlanMakeAbout;

// `sirupp plan make ...`: 0 when a plan was written, 1 when no path was found (nothing written),
// 2 (core::UsageError, core::ConfigError) for bad input.
int PlanMake(const std::vector<std::string>& args, std::ostream& out);

// The flags `plan check` adds for its sweep: --env, --step, --padding, --from.
std::vector<runtime::Flag> SweepFlags();

// The sweep of one parsed plan (from `start`, SI) against the environment of --env: prints the
// first touch of a static object or the arm itself as "FILE:LINE: STATEMENT: ..." and each free
// object's first touch as a note; returns false when the plan touches a static object or itself.
bool SweepPlan(const runtime::Args& parsed, const core::RobotModel& model,
               const control::Plan& plan, const std::vector<double>& start, std::ostream& out);

// The start pose of `plan check`: --from (degrees, or a named pose), else the model's home.
std::vector<double> CheckStart(const runtime::Args& parsed, const core::RobotModel& model);

}  // namespace sirupp::tools
