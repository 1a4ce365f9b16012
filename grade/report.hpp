#pragma once
// The outputs of a grade (docs/grading.md, "Reading a report"):
//  - results.json: every task's figures for the controller and the baseline; no times, paths or
//    process ids, so the same controller gives the same bytes (its FNV-1a hash is in the report);
//  - report.md: the score, then a table per task with the baseline beside the controller, the
//    failed checks or why the task ended, and the plot of the worst joint;
//  - plots/TASK.png: that joint's position, reference and the baseline's position over time;
//  - one summary line.
// For a class (--batch): class.csv and class.md, one row per submission.

#include <string>
#include <vector>

#include "grade/grade.hpp"

namespace sirupp::grade {

// results.json's text (2-space indented, ends with a newline). `baseline` may be null.
std::string ResultsJson(const Suite& suite, const core::RobotModel& model,
                        const ControllerResult& student, const ControllerResult* baseline);

// Writes results.json, report.md and plots/ into `out_dir`; returns the results hash.
std::string WriteReport(const std::string& out_dir, const Suite& suite,
                        const core::RobotModel& model, const ControllerResult& student,
                        const ControllerResult* baseline);

// "grade: NAME on SUITE: 11/13 tasks passed, score 84.6 (baseline 13/13, 100); results fnv1a HASH"
std::string SummaryLine(const Suite& suite, const ControllerResult& student,
                        const ControllerResult* baseline, const std::string& hash);

struct Submission {
  std::string name;     // the sub-folder
  std::string problem;  // why it could not be graded ("" when graded)
  ControllerResult result;
};

// Writes class.csv and class.md into `out_dir`.
void WriteClassTable(const std::string& out_dir, const Suite& suite,
                     const std::vector<Submission>& submissions, const ControllerResult* baseline);

}  // namespace sirupp::grade
