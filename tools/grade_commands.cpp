#include "tools/grade_commands.hpp"

#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <optional>
#include <ostream>

#include "core/errors.hpp"
#include "core/model_loader.hpp"
#include "grade/build_controller.hpp"
#include "grade/grade.hpp"
#include "grade/notebook_assignment.hpp"
#include "grade/planning_assignment.hpp"
#include "grade/report.hpp"
#include "grade/result_file.hpp"
#include "grade/submission.hpp"
#include "runtime/args.hpp"
#include "runtime/data_path.hpp"
#include "sandbox/sandbox.hpp"
#include "tools/cli.hpp"
#include "tools/grade_cluster.hpp"

namespace sirupp::tools {
namespace fs = std::filesystem;

const char* const kGradeAbout =
    "Three forms: LIB.so (a controller library) or FILE.cpp (its one source, built first with\n"
    "fixed flags, as `sirupp controller build` does), -- COMMAND ... (a process controller), or\n"
    "--batch DIR (a class).\n"
    "Runs every task of the suite (config/grading/basic.yaml, advanced.yaml) for a student's\n"
    "controller and for the baseline (the PIC-SERVO PID with the model's gains), each task in\n"
    "lockstep on a private bus with the controller in its own process, N tasks at a time.\n"
    "A library (built against include/sirupp/controller.h) runs in sirupp-control; a process\n"
    "controller (after --) gets the placeholders {url} {name} {goal_deg} {start_deg}\n"
    "{duration_s}. A crash, a hang (per-tick and per-task limits), a NaN effort or no answer\n"
    "ends that task with the reason; the grade goes on.\n"
    "Writes DIR/report.md, DIR/results.json, DIR/plots/*.png (default DIR: grade-out) and prints\n"
    "one summary line. --batch: one controller per sub-folder (a 'command' file, a *.so or\n"
    "*.cpp sources), DIR/class.csv and DIR/class.md. Exit 0 once graded (whatever the score),\n"
    "2 for bad options, a bad suite or a FILE.cpp that does not build (its errors, file:line).\n"
    "Libraries are built and run in the sandbox (docs/sandbox.md): no network, their own folder\n"
    "read-only, CPU, memory, process and file-size limits; where this machine cannot give it,\n"
    "grading a library is refused with the reason. --no-sandbox: unconfined (your own code\n"
    "only). Process controllers (-- COMMAND) use the network and run unconfined.\n"
    "--batch DIR --cluster FILE: each submission graded as one Slurm job (and the baseline as\n"
    "one more) with FILE's cluster: key (a class file, or a file with that one key): its\n"
    "grading time, CPUs and memory, grading.jobs at once, -j tasks at a time in each job; the\n"
    "same reports; DIR, OUT, the suite and the programs at the same paths on the nodes\n"
    "(docs/cluster.md). Exit 1 when the baseline could not be graded or on SIGINT/SIGTERM\n"
    "(every job cancelled).\n"
    "A planning suite (format sirupp-grade-planning-1, config/grading/planning.yaml) grades\n"
    "FILE.py with plan(start, goal, scene) -> path, or a C++ planner (FILE.cpp, built first,\n"
    "or FILE.so) exporting sirupp_plan (include/sirupp/student_planner.h): run in the sandbox\n"
    "per query, the path checked at the suite's finer resolution, then run on a rig with the\n"
    "environment, beside OMPL's reference.\n"
    "sirupp grade notebook NOTEBOOK.ipynb --tests HIDDEN.py: a notebook assignment: every cell\n"
    "run in a fresh python3 kernel in the sandbox, then the teacher's hidden tests (test_*\n"
    "functions, @points(N)) in the same kernel; a table of the tests' scores (--json: the\n"
    "result as JSON), OUT/result.json (docs/notebook-assignments.md).\n"
    "docs/grading.md.\n";

const char* const kGradeNotebookAbout =
    "Grades a notebook assignment (docs/notebook-assignments.md): copies NOTEBOOK.ipynb into\n"
    "OUT/scratch/, runs every code cell in a fresh python3 kernel (nbclient) in the sandbox (no\n"
    "network, /usr and the module read-only, only the copy's folder writable, --memory MB per\n"
    "process, --timeout S for the whole run), errors and all, then the hidden tests of HIDDEN.py\n"
    "in the same kernel: each top-level test_* function (its points from @points(N) above it,\n"
    "default 1) passes when it returns. The hidden tests reach the sandbox on stdin only.\n"
    "Prints one line per test (points, pass or the failing assert's message), the total, the\n"
    "cells that raised and why the tests did not all run (a cell past the time limit, the\n"
    "memory limit); --json prints the result as JSON instead. Writes OUT/result.json (default\n"
    "OUT: grade-out). Exit 0 once graded (whatever the score), 2 for bad options or a bad\n"
    "tests file.\n";

const char* const kControllerBuildAbout =
    "Builds a controller library from one C++ file (or a few) written against\n"
    "include/sirupp/controller.h, with the fixed flags sirupp grade and the class server use\n"
    "(g++ -std=c++17 -O2 -fPIC -shared -Wl,-z,defs), a time limit (--time-limit S, default 60)\n"
    "and in the sandbox (docs/sandbox.md; --no-sandbox: unconfined).\n"
    "Writes OUT/NAME.so and OUT/NAME.build.log (NAME: the first file's name without .cpp).\n"
    "Prints the library's path, or each compiler error as FILE:LINE:COLUMN: error: TEXT and\n"
    "exits 1. Exit 2: bad options.\n"
    "docs/student-controllers.md.\n";

namespace {

std::string BinDir() {
  if (const char* dir = std::getenv("SIRUPP_BIN_DIR"); dir != nullptr && *dir != '\0') return dir;
  return fs::read_symlink("/proc/self/exe").parent_path().string();
}

std::string Resolve(const std::string& path) { return runtime::ResolveDataPath(path); }

std::string LoadProblem(const grade::ControllerResult& result) {
  const std::string prefix = "the controller could not be loaded: ";
  if (result.tasks.empty() || result.tasks.front().ended.rfind(prefix, 0) != 0) return "";
  return "does not load: " + result.tasks.front().ended.substr(prefix.size());
}

// The folder holding sirupp/controller.h: the source tree's include/ from a build tree, the data
// folder's when installed (runtime/data_path.hpp).
std::string IncludeDir() {
  return fs::path(runtime::ResolveDataPath("include/sirupp/controller.h"))
      .parent_path()
      .parent_path()
      .string();
}

std::string Seconds(double seconds) {
  char text[32];
  std::snprintf(text, sizeof text, "%.1f", seconds);
  return text;
}

bool EndsWith(const std::string& text, const std::string& end) {
  return text.size() >= end.size() && text.compare(text.size() - end.size(), end.size(), end) == 0;
}

// FILE.cpp built into OUT/build/NAME/NAME.so; throws UsageError listing the compiler's errors.
std::string BuildSource(const std::string& source, const std::string& out_dir, bool sandbox,
                        std::ostream& err) {
  grade::BuildOptions options;
  options.include_dir = IncludeDir();
  options.sandbox = sandbox;
  const std::string name = fs::path(source).stem().string();
  grade::BuildResult built;
  try {
    built = grade::BuildController({source}, (fs::absolute(out_dir) / "build" / name).string(),
                                   name, options);
  } catch (const std::runtime_error& error) {
    throw core::UsageError("grade: " + source + ": cannot be built: " + error.what());
  }
  if (!built.built) {
    for (const grade::CompilerError& error : built.errors) err << error.ToString() << "\n";
    throw core::UsageError("grade: " + source + " " + built.problem + "; not graded (the whole " +
                           "output: " + built.log_file + ")");
  }
  err << "grade: built " << built.library << " in " << Seconds(built.seconds) << " s\n";
  return built.library;
}

// The one controller graded: LIB.so with its constructor's arguments, or -- COMMAND ...
grade::ControllerSpec SingleController(const std::string& library, const std::string& library_args,
                                       const std::vector<std::string>& command, bool sandbox) {
  grade::ControllerSpec spec;
  spec.sandbox = sandbox;
  if (!library.empty()) {
    spec.kind = grade::ControllerSpec::Kind::kLibrary;
    spec.library = fs::absolute(library).string();
    spec.args = library_args;
    spec.label = fs::path(library).filename().string();
  } else {
    spec.kind = grade::ControllerSpec::Kind::kProcess;
    spec.command = command;
    spec.label = fs::path(command.front()).filename().string();
  }
  return spec;
}

// --batch DIR: one submission per sub-folder, by name; those whose controller is found (built
// under OUT/build) are added to `controllers`, graded[i] naming submission i's (-1: none).
void AddBatch(const std::string& batch, const std::string& out_dir, bool sandbox,
              std::vector<grade::ControllerSpec>& controllers,
              std::vector<grade::Submission>& submissions, std::vector<size_t>& graded) {
  std::vector<fs::path> folders;
  for (const fs::directory_entry& entry : fs::directory_iterator(batch)) {
    if (entry.is_directory()) folders.push_back(entry.path());
  }
  std::sort(folders.begin(), folders.end());
  for (const fs::path& folder : folders) {
    grade::Submission submission;
    submission.name = folder.filename().string();
    const grade::FoundController found = grade::FindSubmission(
        folder.string(), IncludeDir(), (fs::absolute(out_dir) / "build").string(), sandbox);
    submission.problem = found.problem;
    if (found.problem.empty()) {
      graded.push_back(controllers.size());
      controllers.push_back(found.spec);
    } else {
      graded.push_back(static_cast<size_t>(-1));
    }
    submissions.push_back(submission);
  }
}

// The batch's reports: one per graded submission (OUT/NAME), then the class table.
void ReportBatch(const std::string& out_dir, const grade::Suite& suite,
                 const core::RobotModel& model, const std::vector<grade::ControllerResult>& results,
                 const grade::ControllerResult* base, const std::vector<size_t>& graded,
                 std::vector<grade::Submission>& submissions, std::ostream& out,
                 std::ostream& err) {
  for (size_t i = 0; i < submissions.size(); ++i) {
    if (graded[i] == static_cast<size_t>(-1)) continue;
    grade::Submission& submission = submissions[i];
    submission.result = results[graded[i]];
    submission.problem = LoadProblem(submission.result);
    const std::string hash =
        grade::WriteReport(out_dir + "/" + submission.name, suite, model, submission.result, base);
    out << grade::SummaryLine(suite, submission.result, base, hash) << "\n";
  }
  grade::WriteClassTable(out_dir, suite, submissions, base);
  for (const grade::Submission& submission : submissions) {
    if (!submission.problem.empty())
      err << "grade: " << submission.name << ": " << submission.problem << "\n";
  }
  out << "grade: class table " << out_dir << "/class.csv and class.md (" << submissions.size()
      << " submissions)\n";
}

// What one job of `--batch DIR --cluster FILE` runs on its node (tools/grade_cluster.hpp): the
// submission's folder found and built as a local batch does (into OUT/build/NAME), or the
// baseline, graded; the whole result written to `result_file` for the batch's reports.
int RunClusterPart(const std::string& part, const std::string& result_file,
                   const std::string& out_dir, bool sandbox, const grade::Suite& suite,
                   const core::RobotModel& model, grade::GradeOptions options, std::ostream& out) {
  options.work_dir = (fs::absolute(result_file).parent_path() / "logs").string();
  grade::ControllerSpec spec;
  if (part == "baseline") {
    spec.kind = grade::ControllerSpec::Kind::kBaseline;
    spec.label = grade::kBaselineLabel;
  } else {
    const grade::FoundController found = grade::FindSubmission(
        part, IncludeDir(), (fs::absolute(out_dir) / "build").string(), sandbox);
    if (!found.problem.empty()) {
      grade::WriteResultFile(result_file, grade::ControllerResult{}, found.problem);
      out << "grade: " << part << ": " << found.problem << "\n";
      return 0;
    }
    spec = found.spec;
  }
  const std::vector<grade::ControllerResult> results =
      grade::RunControllers(suite, model, {spec}, options);
  grade::WriteResultFile(result_file, results.front(), "");
  out << "grade: " << spec.label << " on " << suite.name << ": " << results.front().passed() << "/"
      << results.front().tasks.size() << " tasks passed; result " << result_file << "\n";
  return 0;
}

// --cluster FILE, --cluster-part P and --cluster-result R: each only where it means something.
void CheckClusterFlags(const std::string& cluster_file, const std::string& batch,
                       const std::string& part, const std::string& part_result) {
  if (!cluster_file.empty() && batch.empty()) {
    throw core::UsageError("grade: --cluster " + cluster_file +
                           ": allowed with --batch DIR only (one controller is one grade here)");
  }
  if (part.empty() != part_result.empty()) {
    throw core::UsageError(
        "grade: --cluster-part and --cluster-result go together (what a --cluster job runs)");
  }
  if (!part.empty() && part != "baseline" && !fs::is_directory(part)) {
    throw core::UsageError("grade: --cluster-part '" + part +
                           "': allowed a submission's folder or the word baseline");
  }
}

// --batch DIR --cluster FILE: the jobs (tools/grade_cluster.hpp), then the batch's reports as a
// local batch writes them. 1 when stopped or when the baseline gave no result.
int GradeBatchAsJobs(const ClusterBatch& batch, const std::string& out_dir,
                     const grade::Suite& suite, const core::RobotModel& model, std::ostream& out,
                     std::ostream& err) {
  const ClusterBatchResult graded = GradeBatchOnCluster(batch, suite, model, err);
  if (graded.stopped) return 1;
  const grade::ControllerResult* base = graded.has_baseline ? &graded.results.back() : nullptr;
  std::vector<grade::Submission> submissions = graded.submissions;
  ReportBatch(out_dir, suite, model, graded.results, base, graded.graded, submissions, out, err);
  if (!graded.baseline_problem.empty()) {
    err << "grade: the baseline was not graded (" << graded.baseline_problem
        << "); the reports have no baseline\n";
    return 1;
  }
  return 0;
}

}  // namespace

namespace {
int RunGradeNotebook(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  const runtime::Args parsed(
      args, "grade notebook",
      {runtime::Flag("notebook", "the student's notebook").Positional("NOTEBOOK.ipynb", 0),
       runtime::Flag("tests", "the teacher's hidden tests").Takes("HIDDEN.py"),
       runtime::Flag("out", "result folder (default grade-out)").Takes("DIR"),
       runtime::Flag("timeout", "seconds the whole run may take (default 120)")
           .Takes("S")
           .Above(0, 3600),
       runtime::Flag("memory", "MB of address space per process (default 2048)")
           .Takes("MB")
           .Integer(256, 65536),
       runtime::Flag("json", "print the result as JSON").Switch(),
       runtime::Flag("no-sandbox", "run unconfined (your own notebooks only)").Switch()},
      kGradeNotebookAbout);
  if (!parsed.Has("notebook")) throw core::UsageError("grade notebook: missing NOTEBOOK.ipynb");
  if (!parsed.Has("tests")) throw core::UsageError("grade notebook: missing --tests HIDDEN.py");
  const std::vector<std::string> notebooks = parsed.Values("notebook", -1);
  if (notebooks.size() > 1) {
    throw core::UsageError("grade notebook: more than one notebook ('" + notebooks[0] + "', '" +
                           notebooks[1] + "'); allowed: one");
  }
  const std::string notebook = notebooks.front();
  const std::string tests = parsed.String("tests");
  if (!fs::is_regular_file(notebook)) {
    throw core::UsageError("grade notebook: '" + notebook + "' is not a file");
  }
  if (!fs::is_regular_file(tests)) {
    throw core::UsageError("grade notebook: --tests '" + tests + "' is not a file");
  }
  grade::NotebookGradeOptions options;
  options.bin_dir = BinDir();
  options.work_dir = parsed.Has("out") ? parsed.String("out") : "grade-out";
  options.timeout_s = parsed.Number("timeout", options.timeout_s);
  options.memory_mb = static_cast<int>(parsed.Integer("memory", options.memory_mb));
  options.sandbox = !parsed.Switch("no-sandbox");
  try {
    grade::ReadNotebookTests(tests);
  } catch (const std::runtime_error& error) {
    throw core::UsageError(std::string("grade notebook: ") + error.what());
  }
  const std::string exposed = grade::HiddenTestsExposed(tests, options.bin_dir);
  if (!exposed.empty()) err << "grade notebook: warning: " << exposed << "\n";
  fs::create_directories(options.work_dir);
  const grade::NotebookResult result = grade::GradeNotebook(notebook, tests, options);
  // Invalid UTF-8 (a log's tail in a problem) replaced, never a throw.
  const std::string json = grade::NotebookResultJson(result).dump(
      2, ' ', false, nlohmann::json::error_handler_t::replace);
  {
    std::ofstream file(fs::path(options.work_dir) / "result.json");
    file << json << "\n";
  }
  if (parsed.Switch("json")) {
    out << json << "\n";
  } else {
    out << notebook << "\n" << grade::NotebookResultTable(result);
  }
  return 0;
}
}  // namespace

int RunGrade(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  if (!args.empty() && args.front() == "notebook") {
    return RunGradeNotebook(std::vector<std::string>(args.begin() + 1, args.end()), out, err);
  }
  // Everything after "--" is the process controller's command line, not ours.
  const auto dash = std::find(args.begin(), args.end(), std::string("--"));
  const std::vector<std::string> command(dash == args.end() ? dash : dash + 1, args.end());
  if (dash != args.end() && command.empty()) throw core::UsageError("grade: -- needs a COMMAND");
  const runtime::Args parsed(
      std::vector<std::string>(args.begin(), dash), "grade",
      {runtime::Flag("library", "a controller library").Positional("LIB.so", 0),
       runtime::Flag("suite", "the grading suite").Takes("FILE"),
       runtime::Flag("args", "arguments for the library's constructor").Takes("TEXT"),
       runtime::Flag("out", "report folder (default grade-out)").Takes("DIR"),
       runtime::Flag("batch", "one controller per sub-folder").Takes("DIR"),
       runtime::Flag("no-baseline", "do not grade the baseline").Switch(),
       runtime::Flag("jobs", "tasks at a time").Short('j').Takes("N").Integer(1, 64),
       runtime::Flag("no-sandbox", "build and run libraries unconfined").Switch(),
       runtime::Flag("cluster", "--batch: each submission one Slurm job (a class file)")
           .Takes("FILE"),
       runtime::Flag("cluster-part", "what one --cluster job grades (written by --cluster)")
           .Takes("FOLDER|baseline"),
       runtime::Flag("cluster-result", "where that job writes its result").Takes("FILE")},
      kGradeAbout);
  const std::vector<std::string> libraries =
      parsed.Has("library") ? parsed.Values("library", -1) : std::vector<std::string>{};
  if (libraries.size() > 1) {
    throw core::UsageError("grade: more than one controller ('" + libraries[0] + "', '" +
                           libraries[1] + "')");
  }
  const std::string library = libraries.empty() ? "" : libraries[0];
  const std::string suite_file = parsed.Has("suite") ? parsed.String("suite") : "";
  const std::string out_dir = parsed.Has("out") ? parsed.String("out") : "grade-out";
  const std::string batch = parsed.Has("batch") ? parsed.String("batch") : "";
  const std::string library_args = parsed.Has("args") ? parsed.String("args") : "";
  const int jobs = static_cast<int>(parsed.Integer("jobs", 1));
  const bool baseline = !parsed.Switch("no-baseline");
  const bool sandbox = !parsed.Switch("no-sandbox");
  const std::string cluster_file = parsed.Has("cluster") ? parsed.String("cluster") : "";
  const std::string part = parsed.Has("cluster-part") ? parsed.String("cluster-part") : "";
  const std::string part_result =
      parsed.Has("cluster-result") ? parsed.String("cluster-result") : "";
  if (suite_file.empty()) throw core::UsageError("grade: missing --suite FILE");
  const int given = (library.empty() ? 0 : 1) + (command.empty() ? 0 : 1) +
                    (batch.empty() ? 0 : 1) + (part.empty() ? 0 : 1);
  if (given != 1) {
    throw core::UsageError("grade: give one controller: LIB.so, -- COMMAND ..., or --batch DIR");
  }
  CheckClusterFlags(cluster_file, batch, part, part_result);
  const std::optional<cluster::ClusterConfig> on_cluster =
      cluster_file.empty() ? std::nullopt
                           : std::optional<cluster::ClusterConfig>(ReadGradeCluster(cluster_file));
  if (!library.empty() && !fs::is_regular_file(library)) {
    throw core::UsageError("grade: controller library '" + library + "' is not a file");
  }
  if (!library.empty() && !EndsWith(library, ".so") && !EndsWith(library, ".cpp") &&
      !EndsWith(library, ".py")) {
    throw core::UsageError("grade: controller '" + library +
                           "': allowed a library (.so), its C++ source (.cpp) or a controller "
                           "written in Python (.py)");
  }
  if (!batch.empty() && !fs::is_directory(batch)) {
    throw core::UsageError("grade: --batch '" + batch + "' is not a folder");
  }
  // Libraries (and sources) are someone else's code: without the sandbox they are refused here,
  // with the reason, rather than run unconfined (a process controller runs unconfined anyway).
  // With --cluster, the jobs check it on their nodes.
  if (sandbox && command.empty() && !on_cluster && !sandbox::ProbeMachine().usable) {
    throw core::UsageError(
        "grade: the sandbox cannot be had on this machine: " + sandbox::ProbeMachine().problem +
        " (docs/sandbox.md; --no-sandbox grades unconfined, for your own code)");
  }
  if (grade::SuiteFormat(Resolve(suite_file)) == grade::kPlanningSuiteFormat) {
    if (library.empty() || !batch.empty() || !command.empty() || !part.empty()) {
      throw core::UsageError("grade: " + suite_file +
                             " is a planning suite: give one FILE.py with plan(start, goal, "
                             "scene), or FILE.cpp / FILE.so exporting sirupp_plan "
                             "(docs/grading.md, Planning assignments)");
    }
    const grade::PlanningSuite planning_suite =
        grade::LoadPlanningSuite(Resolve(suite_file), &Resolve);
    const core::RobotModel planning_model = core::LoadRobotModel(planning_suite.model_file);
    grade::PlanningGradeOptions planning_options;
    planning_options.bin_dir = BinDir();
    planning_options.work_dir = (fs::absolute(out_dir) / "logs").string();
    planning_options.sandbox = sandbox;
    planning_options.label = fs::path(library).filename().string();
    // A C++ planner's source is built as a controller's is (the same flags, in the sandbox);
    // include/sirupp/ holds both headers.
    const std::string planner =
        EndsWith(library, ".cpp") ? BuildSource(library, out_dir, sandbox, err) : library;
    const grade::PlanningResult result =
        grade::GradePlanning(planning_suite, planning_model, planner, planning_options);
    const std::string hash =
        grade::WritePlanningReport(out_dir, planning_suite, planning_model, result);
    out << grade::PlanningSummaryLine(planning_suite, result, hash) << "\n";
    return 0;
  }
  const grade::Suite suite = grade::LoadSuite(Resolve(suite_file), &Resolve);
  const core::RobotModel model = core::LoadRobotModel(suite.model_file);
  grade::GradeOptions options;
  options.jobs = jobs;
  options.bin_dir = BinDir();
  options.work_dir = (fs::absolute(out_dir) / "logs").string();
  if (!part.empty())
    return RunClusterPart(part, part_result, out_dir, sandbox, suite, model, options, out);
  if (on_cluster) {
    ClusterBatch jobs_batch;
    jobs_batch.cluster = *on_cluster;
    jobs_batch.bin_dir = options.bin_dir;
    jobs_batch.batch_dir = fs::absolute(batch).string();
    jobs_batch.out_dir = fs::absolute(out_dir).string();
    jobs_batch.suite_file = fs::absolute(Resolve(suite_file)).string();
    jobs_batch.jobs = jobs;
    jobs_batch.sandbox = sandbox;
    jobs_batch.baseline = baseline;
    return GradeBatchAsJobs(jobs_batch, out_dir, suite, model, out, err);
  }

  std::vector<grade::ControllerSpec> controllers;
  std::vector<grade::Submission> submissions;
  std::vector<size_t> graded;  // submissions[i] -> controllers index
  if (batch.empty()) {
    const std::string built =
        EndsWith(library, ".cpp") ? BuildSource(library, out_dir, sandbox, err) : library;
    controllers.push_back(SingleController(built, library_args, command, sandbox));
  } else {
    AddBatch(batch, out_dir, sandbox, controllers, submissions, graded);
  }
  if (baseline) {
    grade::ControllerSpec spec;
    spec.kind = grade::ControllerSpec::Kind::kBaseline;
    spec.label = grade::kBaselineLabel;
    controllers.push_back(spec);
  }
  std::vector<grade::ControllerResult> results =
      grade::RunControllers(suite, model, controllers, options);
  const grade::ControllerResult* base = baseline ? &results.back() : nullptr;
  if (batch.empty()) {
    const std::string hash = grade::WriteReport(out_dir, suite, model, results.front(), base);
    out << grade::SummaryLine(suite, results.front(), base, hash) << "\n";
    return 0;
  }
  ReportBatch(out_dir, suite, model, results, base, graded, submissions, out, err);
  return 0;
}

int RunControllerBuild(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  const runtime::Args parsed(
      args, "controller build",
      {runtime::Flag("source", "C++ sources").Positional("FILE.cpp", -1),
       runtime::Flag("out", "output folder").Takes("DIR"),
       runtime::Flag("time-limit", "seconds the build may take").Takes("S").Above(0, 3600),
       runtime::Flag("no-sandbox", "build unconfined").Switch()},
      kControllerBuildAbout);
  if (!parsed.Has("source")) throw core::UsageError("controller build: missing FILE.cpp");
  if (!parsed.Has("out")) throw core::UsageError("controller build: missing --out DIR");
  const std::vector<std::string> sources = parsed.Values("source", -1);
  const fs::path folder = fs::absolute(sources.front()).parent_path();
  for (const std::string& source : sources) {
    if (!EndsWith(source, ".cpp") || !fs::is_regular_file(source)) {
      throw core::UsageError("controller build: '" + source + "': allowed an existing .cpp file");
    }
    if (fs::absolute(source).parent_path() != folder) {
      throw core::UsageError("controller build: '" + source +
                             "': allowed sources in one folder (that of '" + sources.front() +
                             "')");
    }
  }
  grade::BuildOptions options;
  options.include_dir = IncludeDir();
  options.time_limit_s = parsed.Number("time-limit", options.time_limit_s);
  options.sandbox = !parsed.Switch("no-sandbox");
  grade::BuildResult built;
  try {
    built = grade::BuildController(sources, parsed.String("out"),
                                   fs::path(sources.front()).stem().string(), options);
  } catch (const std::runtime_error& error) {
    throw core::UsageError(
        std::string("controller build: ") + error.what() +
        (options.sandbox ? " (docs/sandbox.md; --no-sandbox builds unconfined)" : ""));
  }
  if (!built.built) {
    for (const grade::CompilerError& error : built.errors) out << error.ToString() << "\n";
    err << "controller build: " << sources.front() << " " << built.problem << " (the whole "
        << "output: " << built.log_file << ")\n";
    return 1;
  }
  out << built.library << "\n";
  err << "controller build: built in " << Seconds(built.seconds) << " s"
      << (options.sandbox ? " in the sandbox" : " (no sandbox)") << "\n";
  return 0;
}

}  // namespace sirupp::tools
