#pragma once
// Students' controllers from the browser (docs/student-controllers.md): a student submits one C++
// file (against include/sirupp/controller.h) or one Python file on their page; the class server
// builds it (grade/build_controller.hpp: fixed flags, a time limit, in the sandbox), runs it on
// the student's own rig in place of the PIC-SERVO law (sirupp-control --controller, its host in
// the sandbox), and grades it in the background with the class's suite (`sirupp grade` as a child
// process at a lower priority than the rigs, one at a time). The teacher gets the class table.
//
// Reads: the class file's grading: key (suite, safety_tasks, max_source_kb), the sources sent.
// Writes, per student, DATA/students/NAME/submissions/:
//   N/src/controller.cpp|.py   the source as sent (mode 644: the sandbox's uid reads it as root)
//   N/build/                   the library and the compiler's whole output (C++)
//   N/grade/                   `sirupp grade`'s output: report.md, results.json, plots/, logs/
//   N/submission.json          what the pages show: language, time, state, errors, the grade
//   running                    the number of the submission the rig runs (absent: built-in law)
// and DATA/class-table/class.csv|.md (the teacher's table, the format of `sirupp grade --batch`).
//
// States of a submission: building -> "build failed" (final) | queued -> grading -> graded |
// "grade failed" (final); "ready" (final) when the class has no suite. The latest submission in a
// final state is the one counted.

#include <sys/types.h>

#include <condition_variable>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "class/class_config.hpp"
#include "class/grade_place.hpp"
#include "class/rig_spawner.hpp"
#include "grade/build_controller.hpp"
#include "grade/suite.hpp"
#include "panel/panel_api.hpp"
#include "proc/child.hpp"

namespace sirupp::classroom {

using ProcessLauncher = proc::Launcher;  // as in class/rig.hpp

// The compiler's errors as the page gets them: [{file, line, column, message}, ...].
nlohmann::json CompilerErrorsJson(const std::vector<grade::CompilerError>& errors);

// A POST body {"language": "cpp"|"python", "source": TEXT} checked. On success fills `language`
// and `source` and returns nullopt; else the refusal: 400 (not JSON, a missing or wrong field,
// an empty source, a NUL byte) or 413 (larger than max_source_kb), naming the field and what is
// allowed.
std::optional<panel::Response> CheckSubmissionBody(const std::string& body, int max_source_kb,
                                                   std::string* language, std::string* source);

// The submissions' files (no threads, no processes).
class SubmissionStore {
 public:
  explicit SubmissionStore(std::string data_dir);
  std::string Folder(const std::string& student) const;  // DATA/students/NAME/submissions
  std::string Folder(const std::string& student, int id) const;
  std::string SourceFile(const std::string& student, int id) const;  // from the stored language
  // A new submission (the next number), its source written; state "new".
  int Create(const std::string& student, const std::string& language,
             const std::string& source) const;
  std::vector<int> Ids(const std::string& student) const;         // ascending
  nlohmann::json Read(const std::string& student, int id) const;  // null when there is none
  void Write(const std::string& student, int id, const nlohmann::json& meta) const;
  std::optional<int> Running(const std::string& student) const;
  void SetRunning(const std::string& student, std::optional<int> id) const;
  // The latest submission in a final state (graded, build failed, grade failed, ready).
  std::optional<int> Counted(const std::string& student) const;

 private:
  std::string data_dir_;
};

struct SubmissionOptions {
  std::string bin_dir;      // sirupp (for `sirupp grade`)
  std::string include_dir;  // holds sirupp/controller.h
  int grade_nice = 10;      // above the rigs' rig_nice
  int grade_jobs = 1;
  double build_time_limit_s = 30;
  double grade_time_limit_s = 1800;  // the whole grade; the suite's own per-task limits come first
};

class SubmissionService {
 public:
  // Starts the grading workers (as many as the class's grading place runs at once: its spawner
  // factory's MakeGradePlace, made by `spawners`, which must outlive the service); queued or
  // interrupted submissions found in the folders are graded again (a grading job a previous
  // server left is taken back). `log`: one line per submission, build and grade.
  SubmissionService(const ClassConfig& config, SubmissionOptions options,
                    RigSpawnerFactory& spawners, std::function<void(const std::string&)> log);
  // The same with the class file's own factory (MakeRigSpawnerFactory), owned by the service.
  SubmissionService(const ClassConfig& config, SubmissionOptions options, ProcessLauncher& launcher,
                    std::function<void(const std::string&)> log);
  ~SubmissionService();
  SubmissionService(const SubmissionService&) = delete;
  SubmissionService& operator=(const SubmissionService&) = delete;
  // Ends the worker (and kills a grade in progress; its submission is graded again next start).
  void Stop();

  // Stores, builds (C++: in this thread, one build at a time) and queues for grading. Returns the
  // submission as the page shows it (state "build failed" with its errors, or queued/ready), or
  // a refusal (the sandbox cannot be had on this machine: 503).
  panel::Response Submit(const std::string& student, const std::string& language,
                         const std::string& source);

  // /s/NAME/class/submissions..., /s/NAME/class/run: nullopt when `rest` is not one of these.
  // `owner`: NAME's own token (the teacher's view only reads). `restart_rig` restarts NAME's rig
  // with RigController(NAME) and returns "" or why it failed.
  std::optional<panel::Response> StudentRoute(const std::string& student, bool owner,
                                              const std::string& method, const std::string& rest,
                                              const std::string& body,
                                              const std::function<std::string()>& restart_rig);
  // /teacher/api/grades (JSON), /teacher/api/class.csv, /teacher/api/class.md; nullopt else.
  std::optional<panel::Response> TeacherRoute(const std::string& rest);

  // The file sirupp-control loads on NAME's rig (RigSpec::controller): the library of the running
  // C++ submission, the running .py, or "" for the built-in PIC-SERVO law.
  std::string RigController(const std::string& student) const;

  // The real arm's gate (the turn queue asks before linking NAME's rig to the arm): nullopt when
  // NAME's rig runs the built-in law, or a submission graded with every safety task of the
  // class (grading.safety_tasks) passed in simulation; else the reason it is refused, e.g.
  // "your controller (submission 3) failed the class's safety tasks in simulation: set1 (...)",
  // "... has not been graded yet (grading)", "the class has no grading suite ...".
  std::optional<std::string> RealArmRefusal(const std::string& student) const;

  // The class table: one row per student, the counted submission (format of --batch).
  std::string ClassTable(const std::string& format);  // "csv" or "md"
  nlohmann::json GradesJson() const;

  // Tests: waits until no submission is queued or grading (false after `timeout_s`).
  bool WaitIdle(double timeout_s);
  const SubmissionStore& store() const { return store_; }

 private:
  void Start(RigSpawnerFactory& spawners);
  void Worker();
  void Grade(const std::string& student, int id);
  // The grading place's record of the run grading `student`'s submission `id` now, in its
  // meta.json "grading_job" (so a server killed while it runs finds it again instead of grading
  // twice); Clear when it ended or was cancelled.
  void SaveGradingJob(const std::string& student, int id, const nlohmann::json& record);
  void ClearGradingJob(const std::string& student, int id);
  nlohmann::json Public(const std::string& student, int id) const;
  nlohmann::json ListJson(const std::string& student) const;
  panel::Response Run(const std::string& student, const std::string& body,
                      const std::function<std::string()>& restart_rig);

  ClassConfig config_;
  SubmissionOptions options_;
  std::unique_ptr<RigSpawnerFactory> own_spawners_;  // when made by the service
  std::function<void(const std::string&)> log_;
  SubmissionStore store_;
  std::optional<grade::Suite> suite_;
  mutable std::mutex mutex_;  // the metadata files, queue_, busy_, stop_
  std::mutex build_mutex_;    // one compiler at a time
  std::mutex table_mutex_;
  std::condition_variable wake_;
  std::deque<std::pair<std::string, int>> queue_;
  int busy_ = 0;  // grades in progress
  bool stop_ = false;
  // Where the grades run (the class's spawner factory decides: this server's child, or a Slurm
  // job); what runs is stopped by Stop().
  std::unique_ptr<GradePlace> place_;
  // Grading runs found in the submissions at the start (the place's TakeBack of their record),
  // taken back by the worker that takes the submission from the queue (under mutex_).
  std::map<std::pair<std::string, int>, nlohmann::json> resume_;
  std::vector<std::thread> workers_;
};

}  // namespace sirupp::classroom
