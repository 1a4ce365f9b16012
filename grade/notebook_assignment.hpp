#pragma once
// Notebook assignments (docs/notebook-assignments.md): a student's Jupyter notebook graded with
// the teacher's hidden tests. GradeNotebook
//   1. copies the notebook into a scratch folder (WORK/scratch/, the only folder the code may
//      write; a notebook that deletes files deletes its own copy);
//   2. runs python/sirupp/notebook_grade_host.py under Debian's python3 in the sandbox
//      (sandbox/: no network but Unix sockets, /usr and this build's module read-only, the
//      scratch folder read-write, RLIMIT_AS memory_mb, CPU time, processes, file size), with the
//      hidden tests on its standard input (they are never a file inside the sandbox): every cell
//      in a fresh python3 kernel (nbclient), errors and all, then each test_* of the tests in the
//      same kernel;
//   3. reads the one JSON line the host writes, or says why there is none (the time limit, a
//      crash, the memory limit), and gives every hidden test its score.
// The names and points of the hidden tests come from the tests' own text (`@points(N)` above
// `def test_NAME`), so a notebook that never reaches them still gets each one at 0 with the
// reason. Nothing a notebook does (raise, loop, print megabytes, delete files, open a socket)
// makes this throw: the result says what happened.

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace sirupp::grade {

inline constexpr const char* kNotebookResultFormat = "sirupp-notebook-result-1";

struct NotebookTest {
  std::string name;
  double points = 1;  // the test's worth (`@points(N)`)
};

struct NotebookTestResult {
  std::string name;
  double max_points = 1;
  double points = 0;  // max_points when passed, else 0
  bool passed = false;
  std::string message;  // why it failed ("" when passed)
};

struct NotebookCellError {
  int cell = 0;  // code cell, from 1
  std::string error;
};

struct NotebookResult {
  std::vector<NotebookTestResult> tests;  // the hidden tests, in their file's order
  int cells = 0;                          // code cells in the notebook
  std::vector<NotebookCellError> cell_errors;
  std::string problem;  // "" or why the hidden tests did not all run (time, memory, a crash)
  std::string output;   // the notebook's output as text, cut at the limit
  double score() const;
  double max_score() const;
};

struct NotebookGradeOptions {
  std::string bin_dir;   // ../python holds this build's module and the host
  std::string work_dir;  // WORK/scratch/ (the copy, run there), WORK/grade.log
  double timeout_s = 120;
  int memory_mb = 2048;
  bool sandbox = true;  // false: unconfined (the teacher's own notebooks only)
  size_t output_limit_bytes = 64 * 1024;
  size_t max_notebook_bytes = 8 * 1024 * 1024;  // larger: refused unrun
};

// The hidden tests of a tests file: each `def test_NAME` at the top level, its points from a
// `@points(N)` line above it (default 1). Throws std::runtime_error "FILE:LINE: ..." for a file
// that cannot be read or has no test, or points that are not a number > 0.
std::vector<NotebookTest> ReadNotebookTests(const std::string& tests_file);

// "" when no sandbox of a student can read `tests_file`; else why it can, naming the place: it is
// under /usr (every sandbox, the graders' and the notebook servers', has /usr read-only: an
// installed package's config/ is there) or under `bin_dir`'s ../python or the robot models, which
// the grader's sandbox also shows.
std::string HiddenTestsExposed(const std::string& tests_file, const std::string& bin_dir);

// Grades `notebook` with `tests_file` (see the top). Throws std::runtime_error only for the
// grader's own problems (a tests file that cannot be read, a work folder that cannot be made);
// the sandbox missing on this machine is the result's problem.
NotebookResult GradeNotebook(const std::string& notebook, const std::string& tests_file,
                             const NotebookGradeOptions& options);

// The result as JSON ({format, score, max_score, tests, cells, cell_errors, problem, output})
// and back (throws std::runtime_error naming the field for another format).
nlohmann::ordered_json NotebookResultJson(const NotebookResult& result);
NotebookResult NotebookResultFromJson(const nlohmann::json& json);

// The table a teacher reads in a terminal: one line per test, the total, the problem.
std::string NotebookResultTable(const NotebookResult& result);

}  // namespace sirupp::grade
