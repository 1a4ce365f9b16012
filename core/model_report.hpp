#pragma once
// Human-readable text of a robot model, for `sirupp model show` and the demo: the DH table and
// joint data in SI and in the file's own units, then link masses, centres of mass, inertias and
// shapes.

#include <string>

#include "core/robot_model.hpp"

namespace sirupp::core {

std::string ModelReport(const RobotModel& model);
// One line: name, joint count, convention, total moving mass, source hash.
std::string ModelSummary(const RobotModel& model);

}  // namespace sirupp::core
