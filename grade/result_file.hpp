#pragma once
// One controller's grade written whole, so that a grade run elsewhere (each submission of
// `sirupp grade --batch DIR --cluster FILE` is one cluster job, docs/cluster.md) gives the batch
// the same ControllerResult a local run gives, and so the same reports, byte for byte: every
// task's record (time, position, reference, goal, effort per tick) as the doubles themselves,
// why a task ended, and the submission's problem (a build that failed). The figures are not
// written: reading computes them from the records with the suite's thresholds, as RunControllers
// does.
//
// The file is binary, little-endian as the machine writes it (the nodes and the front are one
// architecture): "SIRUPP-GRADE-RESULT 1\n", then the fields in order, strings and lists with
// their length first.

#include <string>

#include "core/robot_model.hpp"
#include "grade/grade.hpp"
#include "grade/suite.hpp"

namespace sirupp::grade {

// Writes `result` (and `problem`: why the submission could not be graded, "" when it was) to
// `file`, through a temporary file renamed into place. Throws std::runtime_error naming the file.
void WriteResultFile(const std::string& file, const ControllerResult& result,
                     const std::string& problem);

struct ReadResult {
  ControllerResult result;
  std::string problem;
};

// Reads a file WriteResultFile wrote for `suite` (its tasks, in order) and computes each task's
// figures. Throws std::runtime_error naming the file when it is missing, cut short, not one of
// these files, or written for other tasks.
ReadResult ReadResultFile(const std::string& file, const Suite& suite,
                          const core::RobotModel& model);

}  // namespace sirupp::grade
