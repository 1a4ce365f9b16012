#include "class/notebook_submissions.hpp"

#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>

#include <algorithm>
#include <chrono>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "class/gradebook.hpp"
#include "class/store_files.hpp"
#include "core/errors.hpp"
#include "core/printable.hpp"

namespace sirupp::classroom {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;
using Clock = std::chrono::steady_clock;

constexpr const char* kFromNotebooks = "from-notebooks";

panel::Response JsonAnswer(int status, const Json& body) {
  return panel::Response{status, "application/json",
                         body.dump(-1, ' ', false, Json::error_handler_t::replace)};
}

bool IsFinal(const std::string& state) { return state == "graded" || state == "grade failed"; }

// "12" -> 12; anything else (a sign, letters, too long) -> -1.
int IdOf(const std::string& text) {
  if (text.empty() || text.size() > 6) return -1;
  for (const char c : text) {
    if (c < '0' || c > '9') return -1;
  }
  return std::stoi(text);
}

std::string Names(const std::vector<NotebookAssignment>& assignments) {
  std::string names;
  for (const NotebookAssignment& a : assignments) names += (names.empty() ? "" : ", ") + a.name;
  return names.empty() ? "none" : names;
}

}  // namespace

std::optional<panel::Response> CheckNotebookBody(const std::string& body, size_t max_kb) {
  if (body.size() > max_kb * 1024) {
    return panel::ErrorResponse(413, "the notebook is " + std::to_string(body.size() / 1024) +
                                         " KiB; allowed: at most " + std::to_string(max_kb) +
                                         " KiB (clear its outputs: Cell > All Output > Clear)");
  }
  if (body.empty()) {
    return panel::ErrorResponse(400, "the body is empty; send the notebook (.ipynb) itself");
  }
  const Json json = Json::parse(body, nullptr, false);
  if (json.is_discarded() || !json.is_object()) {
    return panel::ErrorResponse(400,
                                "not a notebook: the body is not a JSON object; send the .ipynb "
                                "file as it is saved by Jupyter");
  }
  const auto cells = json.find("cells");
  const auto format = json.find("nbformat");
  if (cells == json.end() || !cells->is_array()) {
    return panel::ErrorResponse(400, "not a notebook: no \"cells\" list");
  }
  if (format == json.end() || !format->is_number_integer() || format->get<int>() < 4) {
    return panel::ErrorResponse(
        400,
        "not a notebook: \"nbformat\" must be 4 (Jupyter's format since "
        "2015); this one is " +
            (format == json.end() ? std::string("missing") : core::Printable(format->dump(), 20)));
  }
  return std::nullopt;
}

std::string StudentNotebookFile(const ClassConfig& config, const std::string& student,
                                const NotebookAssignment& assignment) {
  const fs::path notebook = fs::path(assignment.notebook).lexically_normal();
  fs::path relative = notebook.filename();
  if (config.notebooks && !config.notebooks->folder.empty()) {
    const fs::path under =
        notebook.lexically_relative(fs::path(config.notebooks->folder).lexically_normal());
    if (!under.empty() && *under.begin() != "..") relative = under;
  }
  return (fs::path(config.data_dir) / "students" / student / "notebooks" / relative).string();
}

NotebookSubmissionService::NotebookSubmissionService(const ClassConfig& config,
                                                     NotebookSubmissionOptions options,
                                                     proc::Launcher& launcher,
                                                     std::function<void(const std::string&)> log)
    : config_(config), options_(std::move(options)), launcher_(launcher), log_(std::move(log)) {
  if (config_.notebooks) {
    for (const NotebookAssignment& a : config_.notebooks->assignments) {
      Assignment assignment;
      assignment.config = a;
      assignment.tests = grade::ReadNotebookTests(a.tests);
      const std::string exposed = grade::HiddenTestsExposed(a.tests, options_.bin_dir);
      if (!exposed.empty()) throw std::runtime_error(a.name + ": tests: " + exposed);
      for (const grade::NotebookTest& test : assignment.tests) assignment.max_points += test.points;
      assignments_.push_back(assignment);
    }
  }
  // What a previous server left queued or grading is graded (again).
  for (const std::string& student : config_.students) {
    for (const Assignment& assignment : assignments_) {
      for (const int id : Ids(student, assignment.config.name)) {
        const Json meta = Read(student, assignment.config.name, id);
        const std::string state = meta.is_object() ? meta.value("state", "") : "";
        if (state == "queued" || state == "grading") {
          queue_.emplace_back(student, assignment.config.name, id);
        }
      }
    }
  }
  if (!queue_.empty()) {
    log_("notebook assignments: " + std::to_string(queue_.size()) +
         " submission(s) left queued or grading by the last server, graded now");
  }
  worker_ = std::thread([this] { Worker(); });
}

NotebookSubmissionService::~NotebookSubmissionService() { Stop(); }

void NotebookSubmissionService::Stop() {
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
    if (grading_group_ > 0) ::kill(-grading_group_, SIGKILL);
  }
  wake_.notify_all();
  if (worker_.joinable()) worker_.join();
}

const NotebookSubmissionService::Assignment* NotebookSubmissionService::Find(
    const std::string& name) const {
  for (const Assignment& assignment : assignments_) {
    if (assignment.config.name == name) return &assignment;
  }
  return nullptr;
}

std::string NotebookSubmissionService::Folder(const std::string& student,
                                              const std::string& assignment) const {
  return config_.data_dir + "/students/" + student + "/assignments/" + assignment;
}

std::string NotebookSubmissionService::Folder(const std::string& student,
                                              const std::string& assignment, int id) const {
  return Folder(student, assignment) + "/" + std::to_string(id);
}

std::vector<int> NotebookSubmissionService::Ids(const std::string& student,
                                                const std::string& assignment) const {
  std::vector<int> ids;
  std::error_code error;
  for (fs::directory_iterator it(Folder(student, assignment), error), end; !error && it != end;
       it.increment(error)) {
    const int id = IdOf(it->path().filename().string());
    if (id > 0 && fs::is_regular_file(it->path() / "submission.json")) ids.push_back(id);
  }
  std::sort(ids.begin(), ids.end());
  return ids;
}

Json NotebookSubmissionService::Read(const std::string& student, const std::string& assignment,
                                     int id) const {
  const Json meta =
      Json::parse(ReadAll(Folder(student, assignment, id) + "/submission.json"), nullptr, false);
  return meta.is_object() ? meta : Json();
}

void NotebookSubmissionService::Write(const std::string& student, const std::string& assignment,
                                      int id, const Json& meta) const {
  // Invalid UTF-8 (a log's tail in a problem) is replaced, never a throw.
  WriteAtomically(Folder(student, assignment, id) + "/submission.json",
                  meta.dump(1, ' ', false, Json::error_handler_t::replace));
}

std::optional<int> NotebookSubmissionService::Counted(const std::string& student,
                                                      const std::string& assignment) const {
  const std::vector<int> ids = Ids(student, assignment);
  for (auto it = ids.rbegin(); it != ids.rend(); ++it) {
    const Json meta = Read(student, assignment, *it);
    if (meta.is_object() && IsFinal(meta.value("state", ""))) return *it;
  }
  return std::nullopt;
}

Json NotebookSubmissionService::Summary(const Json& meta) const {
  Json summary = meta;
  if (summary.contains("result") && summary["result"].is_object()) {
    summary["result"].erase("output");
  }
  return summary;
}

Json NotebookSubmissionService::AssignmentsJson(const std::string& student) const {
  Json list = Json::array();
  for (const Assignment& assignment : assignments_) {
    const std::string& name = assignment.config.name;
    Json tests = Json::array();
    for (const grade::NotebookTest& test : assignment.tests) {
      tests.push_back({{"name", test.name}, {"points", test.points}});
    }
    Json submissions = Json::array();
    const std::vector<int> ids = Ids(student, name);
    for (auto it = ids.rbegin(); it != ids.rend(); ++it) {
      const Json meta = Read(student, name, *it);
      if (meta.is_object()) submissions.push_back(Summary(meta));
    }
    const std::optional<int> counted = Counted(student, name);
    Json latest;  // the newest submission in full (its output too)
    if (!ids.empty()) latest = Read(student, name, ids.back());
    const std::string copy = StudentNotebookFile(config_, student, assignment.config);
    list.push_back({{"name", name},
                    {"notebook", fs::path(assignment.config.notebook).filename().string()},
                    {"timeout_s", assignment.config.timeout_s},
                    {"max_points", assignment.max_points},
                    {"tests", tests},
                    {"in_notebooks_folder", fs::is_regular_file(copy)},
                    {"counted", counted ? Json(*counted) : Json(nullptr)},
                    {"latest", latest},
                    {"submissions", submissions}});
  }
  return Json{{"student", student}, {"assignments", list}};
}

std::optional<panel::Response> NotebookSubmissionService::StudentRoute(const std::string& student,
                                                                       bool owner,
                                                                       const std::string& method,
                                                                       const std::string& rest,
                                                                       const std::string& body) {
  const std::string prefix = "class/assignments";
  if (rest != prefix && rest.rfind(prefix + "/", 0) != 0) return std::nullopt;
  if (rest == prefix) {
    if (method != "GET") return panel::ErrorResponse(405, "class/assignments: allowed: GET");
    const std::lock_guard<std::mutex> lock(mutex_);
    return JsonAnswer(200, AssignmentsJson(student));
  }
  std::string tail = rest.substr(prefix.size() + 1);
  const size_t slash = tail.find('/');
  const std::string name = tail.substr(0, slash);
  const std::string more = slash == std::string::npos ? "" : tail.substr(slash + 1);
  const Assignment* assignment = Find(name);
  if (assignment == nullptr) {
    return panel::ErrorResponse(404,
                                "no assignment '" + core::Printable(name, 40) +
                                    "' in this class; its notebook assignments: " +
                                    Names(config_.notebooks ? config_.notebooks->assignments
                                                            : std::vector<NotebookAssignment>{}));
  }
  if (method == "POST") {
    if (!owner) {
      return panel::ErrorResponse(403, "only " + student + " submits " + student +
                                           "'s notebooks (the teacher's view only reads)");
    }
    if (more.empty()) {
      if (auto refusal = CheckNotebookBody(body, options_.max_notebook_kb)) return refusal;
      return Submit(student, *assignment, body, "upload");
    }
    if (more == kFromNotebooks) {
      const std::string copy = StudentNotebookFile(config_, student, assignment->config);
      std::error_code error;
      if (!fs::is_regular_file(copy, error)) {
        return panel::ErrorResponse(
            404, "no " + fs::path(copy).filename().string() + " in your notebooks folder (" +
                     fs::path(copy).parent_path().string() +
                     "); open the notebook server once, or upload the file");
      }
      if (fs::file_size(copy, error) > options_.max_notebook_kb * 1024) {
        return panel::ErrorResponse(413, "your " + fs::path(copy).filename().string() +
                                             " is larger than " +
                                             std::to_string(options_.max_notebook_kb) +
                                             " KiB (clear its outputs and save it)");
      }
      const std::string text = ReadAll(copy);
      if (auto refusal = CheckNotebookBody(text, options_.max_notebook_kb)) return refusal;
      return Submit(student, *assignment, text, "notebooks folder");
    }
    return panel::ErrorResponse(404, "POST class/assignments/" + name + "/" +
                                         core::Printable(more, 40) +
                                         ": allowed: the notebook as the body of POST "
                                         "class/assignments/" +
                                         name + ", or POST .../" + kFromNotebooks);
  }
  if (method != "GET") {
    return panel::ErrorResponse(405, "class/assignments/" + name + ": allowed: GET, POST");
  }
  const int id = IdOf(more);
  if (id <= 0) {
    return panel::ErrorResponse(404, "class/assignments/" + name + "/" + core::Printable(more, 40) +
                                         ": allowed: a submission's number");
  }
  const std::lock_guard<std::mutex> lock(mutex_);
  const Json meta = Read(student, name, id);
  if (!meta.is_object()) {
    return panel::ErrorResponse(
        404, student + " has no submission " + std::to_string(id) + " of " + name);
  }
  return JsonAnswer(200, meta);
}

panel::Response NotebookSubmissionService::Submit(const std::string& student,
                                                  const Assignment& assignment,
                                                  const std::string& notebook,
                                                  const std::string& source) {
  const std::string& name = assignment.config.name;
  int id = 0;
  Json meta;
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    const std::vector<int> ids = Ids(student, name);
    id = ids.empty() ? 1 : ids.back() + 1;
    const std::string folder = Folder(student, name, id);
    fs::create_directories(folder);
    WriteAtomically(folder + "/submission.ipynb", notebook);
    meta = Json{{"id", id},
                {"assignment", name},
                {"source", source},
                {"submitted_at", WallClock()},
                {"bytes", notebook.size()},
                {"state", "queued"},
                {"problem", ""}};
    Write(student, name, id, meta);
    queue_.emplace_back(student, name, id);
  }
  wake_.notify_all();
  log_(student + ": notebook " + name + " submission " + std::to_string(id) + " (" + source +
       ") queued");
  return JsonAnswer(202, meta);
}

void NotebookSubmissionService::Worker() {
  std::unique_lock<std::mutex> lock(mutex_);
  while (true) {
    wake_.wait(lock, [this] { return stop_ || !queue_.empty(); });
    if (stop_) return;
    const auto [student, assignment, id] = queue_.front();
    queue_.pop_front();
    ++busy_;
    lock.unlock();
    try {
      Grade(student, assignment, id);
    } catch (const std::exception& error) {
      const std::lock_guard<std::mutex> relock(mutex_);
      Json meta = Read(student, assignment, id);
      if (meta.is_object() && !stop_) {
        meta["state"] = "grade failed";
        meta["problem"] = error.what();
        Write(student, assignment, id, meta);
      }
    }
    lock.lock();
    --busy_;
    wake_.notify_all();
  }
}

// `sirupp grade notebook N/submission.ipynb --tests HIDDEN --out N/grade --json`: the command a
// teacher types, niced below the rigs, its own process group, killed well after the
// assignment's own time limit.
void NotebookSubmissionService::Grade(const std::string& student, const std::string& name, int id) {
  const Assignment* assignment = Find(name);
  if (assignment == nullptr) return;
  const std::string folder = Folder(student, name, id);
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    Json meta = Read(student, name, id);
    if (!meta.is_object()) return;
    meta["state"] = "grading";
    meta.erase("result");
    Write(student, name, id, meta);
  }
  const std::string out = folder + "/grade";
  std::error_code ignored;
  fs::remove_all(out, ignored);
  fs::create_directories(out);
  proc::ProcessSpec spec;
  spec.argv = {options_.bin_dir + "/sirupp",
               "grade",
               "notebook",
               folder + "/submission.ipynb",
               "--tests",
               assignment->config.tests,
               "--out",
               out,
               "--timeout",
               core::FormatNumber(assignment->config.timeout_s),
               "--memory",
               std::to_string(assignment->config.memory_mb),
               "--json"};
  spec.log_path = folder + "/grade.log";
  spec.limits.nice = options_.grade_nice;
  spec.death_signal = SIGTERM;
  fs::remove(spec.log_path, ignored);
  log_(student + ": grading notebook " + name + " submission " + std::to_string(id));
  const auto start = Clock::now();
  proc::Child grader;
  grader.Start(spec, 0, &launcher_);
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    grading_group_ = grader.pid();
    if (stop_) ::kill(-grader.pid(), SIGKILL);
  }
  const double limit_s = assignment->config.timeout_s + 60;
  bool timed_out = false;
  while (grader.Running()) {
    if (!timed_out && std::chrono::duration<double>(Clock::now() - start).count() > limit_s) {
      ::kill(-grader.pid(), SIGKILL);
      timed_out = true;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  proc::KillGroup(grader.group());
  const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
  const std::lock_guard<std::mutex> lock(mutex_);
  grading_group_ = 0;
  if (stop_) return;  // killed by Stop(): stays "grading", graded again at the next start
  Json meta = Read(student, name, id);
  if (!meta.is_object()) return;
  meta["grade_seconds"] = seconds;
  const Json result = Json::parse(ReadAll(out + "/result.json"), nullptr, false);
  if (timed_out || !grader.EndedCleanly() || !result.is_object()) {
    meta["state"] = "grade failed";
    meta["problem"] =
        timed_out ? "grading took longer than " + std::to_string(static_cast<int>(limit_s)) +
                        " s and was stopped"
                  : "sirupp grade notebook ended (" + grader.HowEnded() + "): " + grader.LogTail(2);
    Write(student, name, id, meta);
    log_(student + ": notebook " + name + " submission " + std::to_string(id) +
         " not graded: " + meta["problem"].get<std::string>());
    return;
  }
  // What the pages get: the scores, the cells that raised, why the tests did not run, the
  // output (the hidden tests' text is never in it).
  meta["state"] = "graded";
  meta["problem"] = result.value("problem", "");
  meta["result"] = result;
  Write(student, name, id, meta);
  log_(student + ": notebook " + name + " submission " + std::to_string(id) +
       " graded: " + core::FormatNumber(result.value("score", 0.0)) + " of " +
       core::FormatNumber(result.value("max_score", 0.0)));
}

Json NotebookSubmissionService::GradesJson() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  Json assignments = Json::array();
  for (const Assignment& assignment : assignments_) {
    assignments.push_back(
        {{"name", assignment.config.name}, {"max_points", assignment.max_points}});
  }
  Json rows = Json::array();
  for (const std::string& student : config_.students) {
    Json row{{"student", student}, {"assignments", Json::object()}};
    for (const Assignment& assignment : assignments_) {
      const std::string& name = assignment.config.name;
      const std::vector<int> ids = Ids(student, name);
      Json cell{{"submissions", ids.size()}};
      if (const std::optional<int> counted = Counted(student, name)) {
        const Json meta = Read(student, name, *counted);
        cell["counted"] = *counted;
        cell["state"] = meta.value("state", "");
        cell["submitted_at"] = meta.value("submitted_at", "");
        cell["problem"] = meta.value("problem", "");
        if (meta.contains("result") && meta["result"].is_object()) {
          const Json& result = meta["result"];
          cell["score"] = result.value("score", 0.0);
          cell["max_score"] = result.value("max_score", 0.0);
          Json tests = Json::array();
          for (const Json& test : result.value("tests", Json::array())) {
            tests.push_back({{"name", test.value("name", "")},
                             {"points", test.value("points", 0.0)},
                             {"max_points", test.value("max_points", 0.0)},
                             {"passed", test.value("passed", false)},
                             {"message", test.value("message", "")}});
          }
          cell["tests"] = tests;
        }
      }
      if (!ids.empty()) {
        const Json latest = Read(student, name, ids.back());
        cell["latest"] = {{"id", ids.back()}, {"state", latest.value("state", "")}};
      }
      row["assignments"][name] = cell;
    }
    rows.push_back(row);
  }
  return Json{{"assignments", assignments}, {"rows", rows}};
}

std::optional<panel::Response> NotebookSubmissionService::TeacherRoute(
    const std::string& rest,
    const std::function<std::optional<double>(const std::string&)>& controller_score) {
  if (rest == "api/notebook-grades") return JsonAnswer(200, GradesJson());
  if (rest != "grades.csv") return std::nullopt;
  std::vector<GradebookColumn> columns;
  if (!config_.grading_suite.empty()) columns.push_back({"controller", 100});
  for (const Assignment& assignment : assignments_) {
    columns.push_back({assignment.config.name, assignment.max_points});
  }
  std::vector<GradebookRow> rows;
  for (const std::string& student : config_.students) {
    GradebookRow row;
    row.student = student;
    if (!config_.grading_suite.empty()) row.grades.push_back(controller_score(student));
    const std::lock_guard<std::mutex> lock(mutex_);
    for (const Assignment& assignment : assignments_) {
      std::optional<double> grade;
      if (const std::optional<int> counted = Counted(student, assignment.config.name)) {
        const Json meta = Read(student, assignment.config.name, *counted);
        // A submission the grader could not grade counts as none graded (an empty cell).
        if (meta.value("state", "") == "graded" && meta.contains("result") &&
            meta["result"].is_object()) {
          grade = meta["result"].value("score", 0.0);
        }
      }
      row.grades.push_back(grade);
    }
    rows.push_back(row);
  }
  panel::Response response{200, "text/csv; charset=utf-8", GradebookCsv(columns, rows)};
  return response;
}

bool NotebookSubmissionService::WaitIdle(double timeout_s) {
  std::unique_lock<std::mutex> lock(mutex_);
  return wake_.wait_for(lock, std::chrono::duration<double>(timeout_s),
                        [this] { return queue_.empty() && busy_ == 0; });
}

}  // namespace sirupp::classroom
