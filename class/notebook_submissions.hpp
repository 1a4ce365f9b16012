#pragma once
// Notebook assignments on the class server (docs/notebook-assignments.md): a student submits a
// notebook for one of the class file's notebooks.assignments, as the page's upload or as the copy
// in their notebooks folder (where the notebook hub keeps it: DATA/students/NAME/notebooks/, the
// assignment's path under notebooks.folder); the server grades it in the background with that
// assignment's hidden tests (`sirupp grade notebook` as a child at a lower priority than the
// rigs, one at a time: grade/notebook_assignment.hpp, in the sandbox), and the scores appear on
// the student's and the teacher's pages. The teacher exports every grade as one CSV.
//
// Writes, per student and assignment, DATA/students/NAME/assignments/ASSIGNMENT/N/:
//   submission.ipynb   the notebook as sent (mode 644)
//   submission.json    what the pages show: source, time, state, problem, the result
//   grade/             `sirupp grade notebook`'s folder: result.json, grade.log, scratch/
// States: queued -> grading -> graded | "grade failed" (final). The latest submission in a final
// state is the one counted. A server stopped or killed while grading grades the submission again
// at its next start (queued and grading ones are queued again).
//
// The hidden tests stay the teacher's: the pages get each test's name, points, pass or fail and
// the failing assert's message, never the file.

#include <condition_variable>
#include <deque>
#include <functional>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <thread>
#include <tuple>
#include <vector>

#include "class/class_config.hpp"
#include "grade/notebook_assignment.hpp"
#include "panel/panel_api.hpp"
#include "proc/child.hpp"

namespace sirupp::classroom {

struct NotebookSubmissionOptions {
  std::string bin_dir;  // sirupp (for `sirupp grade notebook`)
  int grade_nice = 10;  // above the rigs' rig_nice
  // Largest notebook accepted (the server's request limit is 1 MiB).
  size_t max_notebook_kb = 900;
};

// A POST body checked as a notebook: nullopt when it is one (a JSON object with a "cells" list
// and an integer "nbformat" of 4 or more), else 400 or 413 naming what is wrong and what is
// allowed.
std::optional<panel::Response> CheckNotebookBody(const std::string& body, size_t max_kb);

// The notebook's copy the hub keeps for `student`: DATA/students/NAME/notebooks/ + the
// assignment's notebook relative to notebooks.folder (its file name when it is elsewhere).
std::string StudentNotebookFile(const ClassConfig& config, const std::string& student,
                                const NotebookAssignment& assignment);

class NotebookSubmissionService {
 public:
  // Reads each assignment's hidden tests (names and points; throws std::runtime_error "FILE:LINE:
  // ..." for a bad tests file, and for one a student's sandbox could read:
  // grade::HiddenTestsExposed), queues what a previous server left queued or grading, and starts
  // the worker.
  NotebookSubmissionService(const ClassConfig& config, NotebookSubmissionOptions options,
                            proc::Launcher& launcher, std::function<void(const std::string&)> log);
  ~NotebookSubmissionService();
  NotebookSubmissionService(const NotebookSubmissionService&) = delete;
  NotebookSubmissionService& operator=(const NotebookSubmissionService&) = delete;
  // Ends the worker (a grade in progress is killed and graded again at the next start).
  void Stop();

  // /s/NAME/class/assignments...: nullopt when `rest` is not one of these. `owner`: NAME's own
  // token (the teacher's view only reads).
  //   GET  class/assignments                     every assignment, its tests, NAME's submissions
  //   POST class/assignments/A                   body: the notebook (.ipynb) -> 202 queued
  //   POST class/assignments/A/from-notebooks    NAME's copy in the notebooks folder -> 202
  //   GET  class/assignments/A/N                 one submission with its result and output
  std::optional<panel::Response> StudentRoute(const std::string& student, bool owner,
                                              const std::string& method, const std::string& rest,
                                              const std::string& body);
  // /teacher/api/notebook-grades (JSON) and /teacher/grades.csv (every student, the controller
  // grade and each assignment: GradebookCsv); nullopt else. `controller_score`: a student's
  // counted controller grade (percent), none when not graded.
  std::optional<panel::Response> TeacherRoute(
      const std::string& rest,
      const std::function<std::optional<double>(const std::string&)>& controller_score);

  nlohmann::json GradesJson() const;
  // Tests: waits until nothing is queued or grading (false after `timeout_s`).
  bool WaitIdle(double timeout_s);

 private:
  struct Assignment {
    NotebookAssignment config;
    std::vector<grade::NotebookTest> tests;
    double max_points = 0;
  };
  const Assignment* Find(const std::string& name) const;
  std::string Folder(const std::string& student, const std::string& assignment) const;
  std::string Folder(const std::string& student, const std::string& assignment, int id) const;
  std::vector<int> Ids(const std::string& student, const std::string& assignment) const;
  nlohmann::json Read(const std::string& student, const std::string& assignment, int id) const;
  void Write(const std::string& student, const std::string& assignment, int id,
             const nlohmann::json& meta) const;
  std::optional<int> Counted(const std::string& student, const std::string& assignment) const;
  panel::Response Submit(const std::string& student, const Assignment& assignment,
                         const std::string& notebook, const std::string& source);
  nlohmann::json Summary(const nlohmann::json& meta) const;  // without the output
  nlohmann::json AssignmentsJson(const std::string& student) const;
  void Worker();
  void Grade(const std::string& student, const std::string& assignment, int id);

  ClassConfig config_;
  NotebookSubmissionOptions options_;
  proc::Launcher& launcher_;
  std::function<void(const std::string&)> log_;
  std::vector<Assignment> assignments_;
  mutable std::mutex mutex_;  // the metadata files, queue_, busy_, stop_, grading_group_
  std::condition_variable wake_;
  std::deque<std::tuple<std::string, std::string, int>> queue_;  // student, assignment, id
  int busy_ = 0;
  bool stop_ = false;
  pid_t grading_group_ = 0;
  std::thread worker_;
};

}  // namespace sirupp::classroom
