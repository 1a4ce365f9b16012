#include "class/submissions.hpp"

#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>

#include <algorithm>
#include <chrono>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>

#include "class/rig.hpp"
#include "class/store_files.hpp"
#include "core/printable.hpp"
#include "grade/grade.hpp"
#include "grade/report.hpp"
#include "proc/child.hpp"
#include "runtime/data_path.hpp"
#include "sandbox/sandbox.hpp"

namespace sirupp::classroom {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;
using Clock = std::chrono::steady_clock;

const char* const kStates[] = {"graded", "build failed", "grade failed", "ready"};

bool IsFinal(const std::string& state) {
  return std::find(std::begin(kStates), std::end(kStates), state) != std::end(kStates);
}

panel::Response JsonResponse(int status, const Json& body) {
  return panel::Response{status, "application/json", body.dump()};
}

std::string Extension(const std::string& language) { return language == "cpp" ? ".cpp" : ".py"; }

// "the controller could not be loaded: X" on the first task is a submission that does not load,
// as `sirupp grade --batch` words it in the class table.
std::string LoadProblem(const grade::ControllerResult& result) {
  const std::string prefix = "the controller could not be loaded: ";
  if (result.tasks.empty() || result.tasks.front().ended.rfind(prefix, 0) != 0) return "";
  return "does not load: " + result.tasks.front().ended.substr(prefix.size());
}

// results.json back into what the class table needs (task names, passed, why ended).
grade::ControllerResult ResultFromJson(const Json& results) {
  grade::ControllerResult result;
  result.label = results.value("controller", "");
  for (const Json& task : results.value("tasks", Json::array())) {
    grade::TaskResult t;
    t.task = task.value("name", "");
    const Json controller = task.value("controller", Json::object());
    t.passed = controller.value("status", "") == "passed";
    if (controller.value("status", "") == "ended") t.ended = controller.value("reason", "ended");
    result.tasks.push_back(t);
  }
  return result;
}

}  // namespace

Json CompilerErrorsJson(const std::vector<grade::CompilerError>& errors) {
  Json out = Json::array();
  for (const grade::CompilerError& error : errors) {
    out.push_back(Json{{"file", error.file},
                       {"line", error.line},
                       {"column", error.column},
                       {"message", error.message}});
  }
  return out;
}

std::optional<panel::Response> CheckSubmissionBody(const std::string& body, int max_source_kb,
                                                   std::string* language, std::string* source) {
  const Json parsed = Json::parse(body, nullptr, false);
  if (parsed.is_discarded() || !parsed.is_object()) {
    return panel::ErrorResponse(
        400,
        "body: expected a JSON object {\"language\": \"cpp\" or \"python\", \"source\": TEXT}");
  }
  for (const auto& [key, value] : parsed.items()) {
    if (key != "language" && key != "source") {
      return panel::ErrorResponse(
          400, "unknown field '" + core::Printable(key, 40) + "'; allowed: language, source");
    }
  }
  const auto lang = parsed.find("language");
  if (lang == parsed.end() || !lang->is_string() || (*lang != "cpp" && *lang != "python")) {
    return panel::ErrorResponse(
        400, "language: " +
                 (lang == parsed.end() ? std::string("missing")
                                       : "'" + core::Printable(lang->dump(), 40) + "'") +
                 "; allowed: \"cpp\" (one C++ file against include/sirupp/controller.h) or "
                 "\"python\" (one Python file with a class Controller)");
  }
  const auto text = parsed.find("source");
  if (text == parsed.end() || !text->is_string()) {
    return panel::ErrorResponse(400, "source: expected the controller's text as a JSON string");
  }
  const std::string& value = text->get_ref<const std::string&>();
  if (value.find_first_not_of(" \t\r\n") == std::string::npos) {
    return panel::ErrorResponse(400, "source: empty; allowed: the controller's text");
  }
  if (value.size() > static_cast<size_t>(max_source_kb) * 1024) {
    return panel::ErrorResponse(413, "source: " + std::to_string((value.size() + 1023) / 1024) +
                                         " KB; allowed: at most " + std::to_string(max_source_kb) +
                                         " KB (one file)");
  }
  if (value.find('\0') != std::string::npos) {
    return panel::ErrorResponse(400, "source: holds a NUL byte; allowed: text");
  }
  *language = lang->get<std::string>();
  *source = value;
  return std::nullopt;
}

// --- the store
// ------------------------------------------------------------------------------------

SubmissionStore::SubmissionStore(std::string data_dir) : data_dir_(std::move(data_dir)) {}

std::string SubmissionStore::Folder(const std::string& student) const {
  return data_dir_ + "/students/" + student + "/submissions";
}

std::string SubmissionStore::Folder(const std::string& student, int id) const {
  return Folder(student) + "/" + std::to_string(id);
}

std::string SubmissionStore::SourceFile(const std::string& student, int id) const {
  const Json meta = Read(student, id);
  const std::string language = meta.is_object() ? meta.value("language", "cpp") : "cpp";
  return Folder(student, id) + "/src/controller" + Extension(language);
}

int SubmissionStore::Create(const std::string& student, const std::string& language,
                            const std::string& source) const {
  const std::vector<int> ids = Ids(student);
  const int id = ids.empty() ? 1 : ids.back() + 1;
  const std::string folder = Folder(student, id);
  fs::create_directories(folder + "/src");
  // As root the sandbox runs the code as a uid of its own, which must read the source.
  for (const std::string& dir : {Folder(student), folder, folder + "/src"}) {
    ::chmod(dir.c_str(), 0755);
  }
  WriteAtomically(folder + "/src/controller" + Extension(language), source);
  Write(student, id,
        Json{{"id", id},
             {"language", language},
             {"submitted_at", WallClock()},
             {"bytes", source.size()},
             {"state", "new"}});
  return id;
}

std::vector<int> SubmissionStore::Ids(const std::string& student) const {
  std::vector<int> ids;
  std::error_code error;
  for (fs::directory_iterator it(Folder(student), error), end; !error && it != end;
       it.increment(error)) {
    const std::string name = it->path().filename().string();
    if (!name.empty() && name.size() < 9 &&
        std::all_of(name.begin(), name.end(), [](char c) { return c >= '0' && c <= '9'; }) &&
        fs::is_regular_file(it->path() / "submission.json")) {
      ids.push_back(std::stoi(name));
    }
  }
  std::sort(ids.begin(), ids.end());
  return ids;
}

Json SubmissionStore::Read(const std::string& student, int id) const {
  const std::string file = Folder(student, id) + "/submission.json";
  if (!fs::is_regular_file(file)) return nullptr;
  const Json meta = Json::parse(ReadAll(file), nullptr, false);
  return meta.is_discarded() ? Json(nullptr) : meta;
}

void SubmissionStore::Write(const std::string& student, int id, const Json& meta) const {
  WriteAtomically(Folder(student, id) + "/submission.json", meta.dump(2) + "\n");
}

std::optional<int> SubmissionStore::Running(const std::string& student) const {
  const std::string text = ReadAll(Folder(student) + "/running");
  const std::vector<int> ids = Ids(student);
  try {
    const int id = std::stoi(text);
    if (std::find(ids.begin(), ids.end(), id) != ids.end()) return id;
  } catch (const std::exception&) {
  }
  return std::nullopt;
}

void SubmissionStore::SetRunning(const std::string& student, std::optional<int> id) const {
  fs::create_directories(Folder(student));
  if (id) {
    WriteAtomically(Folder(student) + "/running", std::to_string(*id) + "\n");
  } else {
    fs::remove(Folder(student) + "/running");
  }
}

std::optional<int> SubmissionStore::Counted(const std::string& student) const {
  const std::vector<int> ids = Ids(student);
  for (auto it = ids.rbegin(); it != ids.rend(); ++it) {
    const Json meta = Read(student, *it);
    if (meta.is_object() && IsFinal(meta.value("state", ""))) return *it;
  }
  return std::nullopt;
}

// --- the service
// ----------------------------------------------------------------------------------

SubmissionService::SubmissionService(const ClassConfig& config, SubmissionOptions options,
                                     RigSpawnerFactory& spawners,
                                     std::function<void(const std::string&)> log)
    : config_(config), options_(std::move(options)), log_(std::move(log)), store_(config.data_dir) {
  Start(spawners);
}

SubmissionService::SubmissionService(const ClassConfig& config, SubmissionOptions options,
                                     ProcessLauncher& launcher,
                                     std::function<void(const std::string&)> log)
    : config_(config), options_(std::move(options)), log_(std::move(log)), store_(config.data_dir) {
  own_spawners_ =
      MakeRigSpawnerFactory(config_, RigSpawnerOptions{options_.bin_dir, log_}, launcher);
  Start(*own_spawners_);
}

void SubmissionService::Start(RigSpawnerFactory& spawners) {
  if (!config_.grading_suite.empty()) {
    suite_ = grade::LoadSuite(config_.grading_suite, &runtime::ResolveDataPath);
  }
  GradeHooks hooks;
  hooks.log = log_;
  hooks.save = [this](const std::string& student, int id, const Json& record) {
    SaveGradingJob(student, id, record);
  };
  hooks.clear = [this](const std::string& student, int id) { ClearGradingJob(student, id); };
  place_ = spawners.MakeGradePlace(
      LocalGradeOptions{options_.grade_nice, options_.grade_time_limit_s}, std::move(hooks));
  // What a stopped server left queued or half graded is graded again.
  for (const std::string& student : config_.students) {
    for (const int id : store_.Ids(student)) {
      const Json meta = store_.Read(student, id);
      const std::string state = meta.is_object() ? meta.value("state", "") : "";
      if (state == "queued" || state == "grading") queue_.emplace_back(student, id);
      // A grading run the last server left (killed while it ran): taken back when the place can,
      // never started again while it may still run.
      if (state == "grading" && meta.contains("grading_job")) {
        if (std::optional<Json> run = place_->TakeBack(meta["grading_job"])) {
          resume_[{student, id}] = *run;
        }
      }
    }
  }
  const int workers = std::max(1, place_->Slots());
  for (int i = 0; i < workers; ++i) workers_.emplace_back([this] { Worker(); });
}

SubmissionService::~SubmissionService() { Stop(); }

void SubmissionService::Stop() {
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  if (place_) place_->Stop();
  wake_.notify_all();
  for (std::thread& worker : workers_) {
    if (worker.joinable()) worker.join();
  }
}

panel::Response SubmissionService::Submit(const std::string& student, const std::string& language,
                                          const std::string& source) {
  const sandbox::Probe& probe = sandbox::ProbeMachine();
  if (!probe.usable) {
    return panel::ErrorResponse(503,
                                "submissions are not accepted on this server: the sandbox "
                                "students' code must run in cannot be had here: " +
                                    probe.problem);
  }
  int id = 0;
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    id = store_.Create(student, language, source);
  }
  Json meta = store_.Read(student, id);
  if (language == "cpp") {
    meta["state"] = "building";
    {
      const std::lock_guard<std::mutex> lock(mutex_);
      store_.Write(student, id, meta);
    }
    grade::BuildOptions build;
    build.include_dir = options_.include_dir;
    build.time_limit_s = options_.build_time_limit_s;
    grade::BuildResult built;
    try {
      const std::lock_guard<std::mutex> one_at_a_time(build_mutex_);
      built = grade::BuildController({store_.SourceFile(student, id)},
                                     store_.Folder(student, id) + "/build", "controller", build);
    } catch (const std::exception& e) {
      built.problem = std::string("cannot be built here: ") + e.what();
    }
    meta["build_seconds"] = built.seconds;
    meta["errors"] = CompilerErrorsJson(built.errors);
    if (!built.built) {
      meta["state"] = "build failed";
      meta["problem"] = built.problem;
      const std::lock_guard<std::mutex> lock(mutex_);
      store_.Write(student, id, meta);
      log_(student + ": submission " + std::to_string(id) + " " + built.problem);
      return JsonResponse(200, Public(student, id));
    }
  }
  Json answer;
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    meta["state"] = suite_ ? "queued" : "ready";
    store_.Write(student, id, meta);
    if (suite_) queue_.emplace_back(student, id);
    // The answer is the submission as it was taken (queued), not whatever an idle grading worker
    // made of it by the time the answer is read.
    answer = Public(student, id);
  }
  wake_.notify_all();
  log_(student + ": submission " + std::to_string(id) + " (" + language + ") " +
       (suite_ ? "queued for grading" : "ready"));
  return JsonResponse(200, answer);
}

void SubmissionService::Worker() {
  std::unique_lock<std::mutex> lock(mutex_);
  while (true) {
    wake_.wait(lock, [this] { return stop_ || !queue_.empty(); });
    if (stop_) return;
    const auto [student, id] = queue_.front();
    queue_.pop_front();
    ++busy_;
    lock.unlock();
    try {
      Grade(student, id);
    } catch (const std::exception& e) {
      const std::lock_guard<std::mutex> relock(mutex_);
      Json meta = store_.Read(student, id);
      if (meta.is_object() && !stop_) {
        meta["state"] = "grade failed";
        meta["problem"] = e.what();
        store_.Write(student, id, meta);
      }
    }
    lock.lock();
    --busy_;
    wake_.notify_all();
  }
}

// `sirupp grade SOURCE --suite SUITE --out N/grade --no-baseline`: the command a teacher types,
// so the page's scores are the command line's; niced below the rigs, its own process group.
void SubmissionService::Grade(const std::string& student, int id) {
  const std::string folder = store_.Folder(student, id);
  Json meta;
  std::optional<Json> resume;
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    meta = store_.Read(student, id);
    if (!meta.is_object()) return;
    const auto saved = resume_.find({student, id});
    if (saved != resume_.end()) {
      resume = saved->second;
      resume_.erase(saved);
    }
    meta["state"] = "grading";
    meta.erase("grade");
    store_.Write(student, id, meta);
  }
  const std::string out = folder + "/grade";
  if (!resume) {  // a job taken back writes where it was writing
    fs::remove_all(out);
    fs::create_directories(out);
  }
  const std::vector<std::string> argv = {options_.bin_dir + "/sirupp",
                                         "grade",
                                         store_.SourceFile(student, id),
                                         "--suite",
                                         config_.grading_suite,
                                         "--out",
                                         out,
                                         "--no-baseline",
                                         "-j",
                                         std::to_string(options_.grade_jobs)};
  const auto start = Clock::now();
  const std::string log_file = folder + "/grade.log";
  if (!resume) fs::remove(log_file);
  log_(student + ": grading submission " + std::to_string(id));
  const GradeRun run = place_->Grade(GradeTask{student, id, argv, log_file, resume});
  const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
  const std::lock_guard<std::mutex> lock(mutex_);
  if (stop_ || run.stopped) return;  // killed by Stop(): stays "grading", graded again next start
  meta = store_.Read(student, id);
  meta.erase("grading_job");
  meta["grade_seconds"] = seconds;
  const Json results = Json::parse(ReadAll(out + "/results.json"), nullptr, false);
  std::string summary;
  {
    std::istringstream lines(ReadAll(log_file));
    for (std::string line; std::getline(lines, line);) {
      if (!line.empty()) summary = line;
    }
  }
  if (!run.ok || results.is_discarded()) {
    meta["state"] = "grade failed";
    meta["problem"] = !run.problem.empty() ? run.problem : "sirupp grade: " + summary;
    store_.Write(student, id, meta);
    log_(student + ": submission " + std::to_string(id) +
         " not graded: " + meta["problem"].get<std::string>());
    return;
  }
  const grade::ControllerResult result = ResultFromJson(results);
  Json tasks = Json::array();
  std::vector<std::string> safety_failed;
  for (const Json& task : results["tasks"]) {
    const Json controller = task.value("controller", Json::object());
    const std::string name = task.value("name", "");
    const std::string state = controller.value("status", "");
    Json row{{"name", name}, {"status", state}};
    if (controller.contains("reason")) row["reason"] = controller["reason"];
    if (controller.contains("failed_checks")) row["failed_checks"] = controller["failed_checks"];
    tasks.push_back(row);
    if (std::find(config_.safety_tasks.begin(), config_.safety_tasks.end(), name) !=
            config_.safety_tasks.end() &&
        state != "passed") {
      std::string why = state;
      if (controller.contains("reason")) why += ": " + controller["reason"].get<std::string>();
      safety_failed.push_back(name + " (" + why + ")");
    }
  }
  meta["state"] = "graded";
  meta["grade"] = Json{{"suite", results["suite"]["name"]},
                       {"score", results["score"]},
                       {"passed", results["passed"]},
                       {"tasks_total", results["tasks_total"]},
                       {"failed_tasks", result.FailedTasks()},
                       {"problem", LoadProblem(result)},
                       {"tasks", tasks},
                       {"safety_passed", safety_failed.empty()},
                       {"safety_failed", safety_failed},
                       {"summary", summary}};
  store_.Write(student, id, meta);
  log_(student + ": submission " + std::to_string(id) + " graded in " +
       std::to_string(static_cast<int>(seconds)) + " s: " + summary);
}

void SubmissionService::SaveGradingJob(const std::string& student, int id, const Json& record) {
  const std::lock_guard<std::mutex> lock(mutex_);
  Json meta = store_.Read(student, id);
  if (!meta.is_object()) return;
  meta["grading_job"] = record;
  store_.Write(student, id, meta);
}

void SubmissionService::ClearGradingJob(const std::string& student, int id) {
  const std::lock_guard<std::mutex> lock(mutex_);
  Json meta = store_.Read(student, id);
  if (!meta.is_object() || !meta.contains("grading_job")) return;
  meta.erase("grading_job");
  store_.Write(student, id, meta);
}

bool SubmissionService::WaitIdle(double timeout_s) {
  std::unique_lock<std::mutex> lock(mutex_);
  return wake_.wait_for(lock, std::chrono::duration<double>(timeout_s),
                        [this] { return queue_.empty() && busy_ == 0; });
}

Json SubmissionService::Public(const std::string& student, int id) const {
  Json meta = store_.Read(student, id);
  if (!meta.is_object()) return nullptr;
  const std::string base = "class/submissions/" + std::to_string(id) + "/";
  meta["source_url"] = base + "source";
  if (meta.value("state", "") == "graded") meta["report_url"] = base + "report.md";
  return meta;
}

Json SubmissionService::ListJson(const std::string& student) const {
  const std::lock_guard<std::mutex> lock(mutex_);
  Json list = Json::array();
  const std::vector<int> ids = store_.Ids(student);
  for (auto it = ids.rbegin(); it != ids.rend(); ++it) list.push_back(Public(student, *it));
  const std::optional<int> running = store_.Running(student);
  const std::optional<int> counted = store_.Counted(student);
  Json grading = nullptr;
  if (suite_) {
    grading = Json{{"suite", suite_->name},
                   {"tasks", suite_->tasks.size()},
                   {"safety_tasks", config_.safety_tasks}};
  }
  return Json{{"running", running ? Json(*running) : Json(nullptr)},
              {"counted", counted ? Json(*counted) : Json(nullptr)},
              {"grading", grading},
              {"max_source_kb", config_.max_source_kb},
              {"queue", queue_.size()},
              {"submissions", list}};
}

std::optional<panel::Response> SubmissionService::StudentRoute(
    const std::string& student, bool owner, const std::string& method, const std::string& rest,
    const std::string& body, const std::function<std::string()>& restart_rig) {
  const bool ours = rest == "class/run" || rest == "class/submissions" ||
                    rest.rfind("class/submissions/", 0) == 0;
  if (!ours) return std::nullopt;
  if (method != "GET" && !owner) {
    return panel::ErrorResponse(403, "only " + student +
                                         " submits and runs controllers on this rig (the "
                                         "teacher's view is read-only)");
  }
  if (rest == "class/run") {
    if (method != "POST") return panel::ErrorResponse(405, "class/run: allowed: POST");
    return Run(student, body, restart_rig);
  }
  if (rest == "class/submissions") {
    if (method == "GET") {
      Json list = ListJson(student);
      const std::optional<std::string> refusal = RealArmRefusal(student);
      list["real_arm"] = refusal ? Json(*refusal) : Json(nullptr);
      return JsonResponse(200, list);
    }
    if (method != "POST") return panel::ErrorResponse(405, "class/submissions: allowed: GET, POST");
    std::string language;
    std::string source;
    if (auto refusal = CheckSubmissionBody(body, config_.max_source_kb, &language, &source)) {
      return refusal;
    }
    return Submit(student, language, source);
  }
  if (method != "GET") return panel::ErrorResponse(405, rest + ": allowed: GET");
  // class/submissions/N/(source|report.md|plots/TASK.png)
  static const std::regex kFile(
      R"(class/submissions/([0-9]{1,8})/(source|report\.md|plots/([A-Za-z0-9_.-]{1,80})\.png))");
  std::smatch match;
  if (!std::regex_match(rest, match, kFile)) {
    return panel::ErrorResponse(404, "no such file: " + core::Printable(rest, 100) +
                                         "; allowed: class/submissions/N/source, report.md, "
                                         "plots/TASK.png");
  }
  const int id = std::stoi(match[1].str());
  std::string file;
  std::string type = "text/plain; charset=utf-8";
  if (match[2] == "source") {
    file = store_.SourceFile(student, id);
  } else if (match[2] == "report.md") {
    file = store_.Folder(student, id) + "/grade/report.md";
  } else {
    file = store_.Folder(student, id) + "/grade/plots/" + match[3].str() + ".png";
    type = "image/png";
  }
  if (!fs::is_regular_file(file)) {
    return panel::ErrorResponse(
        404, "submission " + std::to_string(id) + " has no " + match[2].str() + " (yet)");
  }
  return panel::Response{200, type, ReadAll(file)};
}

panel::Response SubmissionService::Run(const std::string& student, const std::string& body,
                                       const std::function<std::string()>& restart_rig) {
  const Json parsed = Json::parse(body.empty() ? "{}" : body, nullptr, false);
  if (parsed.is_discarded() || !parsed.is_object() || !parsed.contains("id")) {
    return panel::ErrorResponse(
        400,
        "body: expected {\"id\": N} (a submission of yours) or {\"id\": null} (the "
        "built-in PIC-SERVO law)");
  }
  const Json& value = parsed["id"];
  std::optional<int> id;
  if (!value.is_null()) {
    if (!value.is_number_integer()) {
      return panel::ErrorResponse(400, "id: '" + core::Printable(value.dump(), 40) +
                                           "'; allowed: a submission's number or null");
    }
    const Json meta = [&] {
      const std::lock_guard<std::mutex> lock(mutex_);
      return store_.Read(student, value.get<int>());
    }();
    if (!meta.is_object()) {
      return panel::ErrorResponse(404, "id: you have no submission " + value.dump());
    }
    const std::string state = meta.value("state", "");
    if (state == "build failed" || state == "building" || state == "new") {
      return panel::ErrorResponse(409, "id: submission " + value.dump() + " is not built (" +
                                           state + "); allowed: a submission that built");
    }
    id = value.get<int>();
  }
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    store_.SetRunning(student, id);
  }
  log_(student + ": rig restarted with " +
       (id ? "submission " + std::to_string(*id) : std::string("the built-in law")));
  const std::string problem = restart_rig();
  return JsonResponse(200,
                      Json{{"running", id ? Json(*id) : Json(nullptr)}, {"rig_problem", problem}});
}

std::string SubmissionService::RigController(const std::string& student) const {
  const std::lock_guard<std::mutex> lock(mutex_);
  const std::optional<int> id = store_.Running(student);
  if (!id) return "";
  const Json meta = store_.Read(student, *id);
  if (!meta.is_object()) return "";
  if (meta.value("language", "") == "python") return store_.SourceFile(student, *id);
  return store_.Folder(student, *id) + "/build/controller.so";
}

std::optional<std::string> SubmissionService::RealArmRefusal(const std::string& student) const {
  const std::lock_guard<std::mutex> lock(mutex_);
  const std::optional<int> id = store_.Running(student);
  if (!id) return std::nullopt;  // the built-in PIC-SERVO law
  const std::string which = "your controller (submission " + std::to_string(*id) + ")";
  if (!suite_) {
    return which +
           " cannot run on the real arm: the class has no grading suite to check it in "
           "simulation (the teacher sets grading: in the class file); switch back to "
           "the built-in law";
  }
  const Json meta = store_.Read(student, *id);
  const std::string state = meta.is_object() ? meta.value("state", "") : "";
  if (state != "graded") {
    return which + " has not been graded yet (" + state +
           "); it may run on the real arm once it passed the safety tasks in simulation";
  }
  const Json grade = meta.value("grade", Json::object());
  if (grade.value("safety_passed", false)) return std::nullopt;
  std::string failed;
  for (const Json& task : grade.value("safety_failed", Json::array())) {
    failed += (failed.empty() ? "" : "; ") + task.get<std::string>();
  }
  return which + " failed the class's safety tasks in simulation: " + failed;
}

Json SubmissionService::GradesJson() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  Json rows = Json::array();
  for (const std::string& student : config_.students) {
    Json row{{"student", student}, {"submissions", store_.Ids(student).size()}};
    const std::optional<int> running = store_.Running(student);
    row["running"] = running ? Json(*running) : Json(nullptr);
    if (const std::optional<int> counted = store_.Counted(student)) {
      const Json meta = store_.Read(student, *counted);
      row["counted"] = *counted;
      row["language"] = meta.value("language", "");
      row["submitted_at"] = meta.value("submitted_at", "");
      row["state"] = meta.value("state", "");
      row["problem"] = meta.value("problem", "");
      if (meta.contains("grade")) row["grade"] = meta["grade"];
    }
    const std::vector<int> ids = store_.Ids(student);
    if (!ids.empty()) {
      const Json latest = store_.Read(student, ids.back());
      row["latest"] = Json{{"id", ids.back()}, {"state", latest.value("state", "")}};
    }
    rows.push_back(row);
  }
  return Json{{"suite", suite_ ? Json(suite_->name) : Json(nullptr)},
              {"safety_tasks", config_.safety_tasks},
              {"rows", rows}};
}

std::string SubmissionService::ClassTable(const std::string& format) {
  if (!suite_) return "";
  std::vector<grade::Submission> rows;
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    for (const std::string& student : config_.students) {
      grade::Submission row;
      row.name = student;
      const std::optional<int> counted = store_.Counted(student);
      if (!counted) {
        row.problem = "no submission graded yet";
        rows.push_back(row);
        continue;
      }
      const Json meta = store_.Read(student, *counted);
      const std::string state = meta.value("state", "");
      if (state == "graded") {
        const Json results = Json::parse(
            ReadAll(store_.Folder(student, *counted) + "/grade/results.json"), nullptr, false);
        if (!results.is_discarded()) {
          row.result = ResultFromJson(results);
          row.problem = LoadProblem(row.result);
        } else {
          row.problem = "its results.json cannot be read";
        }
      } else {
        row.problem = meta.value("problem", state);
      }
      rows.push_back(row);
    }
  }
  const std::lock_guard<std::mutex> lock(table_mutex_);
  const std::string dir = config_.data_dir + "/class-table";
  grade::WriteClassTable(dir, *suite_, rows, nullptr);
  return ReadAll(dir + (format == "csv" ? "/class.csv" : "/class.md"));
}

std::optional<panel::Response> SubmissionService::TeacherRoute(const std::string& rest) {
  if (rest == "api/grades") return JsonResponse(200, GradesJson());
  if (rest != "api/class.csv" && rest != "api/class.md") return std::nullopt;
  if (!suite_) {
    return panel::ErrorResponse(404,
                                "the class has no grading suite (grading: suite: in the "
                                "class file), so no class table");
  }
  const bool csv = rest == "api/class.csv";
  panel::Response response{200, csv ? "text/csv; charset=utf-8" : "text/markdown; charset=utf-8",
                           ClassTable(csv ? "csv" : "md")};
  return response;
}

}  // namespace sirupp::classroom
