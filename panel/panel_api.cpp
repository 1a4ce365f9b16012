#include "panel/panel_api.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>

#include "control/plan.hpp"
#include "core/environment.hpp"
#include "core/errors.hpp"
#include "core/geometry.hpp"
#include "core/inverse_kinematics.hpp"
#include "core/printable.hpp"
#include "core/units.hpp"
#include "logger/report.hpp"
#include "panel/model_edit.hpp"

namespace sirupp::panel {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
constexpr size_t kMaxFileBytes = 1024 * 1024;
constexpr uintmax_t kMaxDownloadBytes = uintmax_t{256} * 1024 * 1024;

Response JsonResponse(const Json& body, int status = 200) {
  // Text from files or messages may hold invalid UTF-8: replaced, never thrown on.
  return Response{status, "application/json",
                  body.dump(-1, ' ', false, Json::error_handler_t::replace)};
}

Response FromResult(const CommandResult& result) {
  Json body = result.detail;
  body["ok"] = result.ok;
  body[result.ok ? "message" : "error"] = result.message;
  return JsonResponse(body, result.status);
}

// A number field of the body, with the field named when missing or wrong.
double Number(const Json& body, const std::string& field, std::optional<double> fallback) {
  if (!body.contains(field)) {
    if (fallback) return *fallback;
    throw std::invalid_argument(field + ": missing");
  }
  if (!body[field].is_number()) throw std::invalid_argument(field + ": must be a number");
  return body[field].get<double>();
}

std::string Text(const Json& body, const std::string& field, const std::string& fallback = "") {
  if (!body.contains(field)) return fallback;
  if (!body[field].is_string()) throw std::invalid_argument(field + ": must be a string");
  return body[field].get<std::string>();
}

std::vector<double> Numbers(const Json& body, const std::string& field, size_t count) {
  if (!body.contains(field) || !body[field].is_array() || body[field].size() != count) {
    throw std::invalid_argument(field + ": expected an array of " + std::to_string(count) +
                                " numbers");
  }
  std::vector<double> values;
  for (const Json& value : body[field]) {
    if (!value.is_number()) throw std::invalid_argument(field + ": must hold numbers only");
    values.push_back(value.get<double>());
  }
  return values;
}

// True when `path` lies inside `dir` (both canonical).
bool Inside(const fs::path& path, const fs::path& dir) {
  const auto rel = path.lexically_relative(dir);
  return !rel.empty() && *rel.begin() != "..";
}

// The routes that change nothing (reads and checks): no token, no lock.
bool ChangesNothing(const std::string& path) {
  return path == "/api/ik" || path == "/api/plan/check" || path == "/api/plan/make" ||
         path == "/api/cspace" || path == "/api/environment/check" || path == "/api/model/check" ||
         path == "/api/lock" || path == "/api/unlock";
}

}  // namespace

Response ErrorResponse(int status, const std::string& message) {
  return JsonResponse(Json{{"ok", false}, {"error", message}}, status);
}

PanelApi::PanelApi(PanelHub& hub, ApiOptions options)
    : hub_(hub), options_(std::move(options)), commands_(hub) {}

std::string PanelApi::LockHolder() {
  const std::lock_guard<std::mutex> guard(lock_mutex_);
  if (lock_ && Clock::now() - lock_->seen > options_.lock_idle) lock_.reset();
  return lock_ ? lock_->name : "";
}

bool PanelApi::Holds(const std::string& client) {
  const std::lock_guard<std::mutex> guard(lock_mutex_);
  if (lock_ && Clock::now() - lock_->seen > options_.lock_idle) lock_.reset();
  return lock_ && lock_->client == client;
}

void PanelApi::Seen(const std::string& client) {
  const std::lock_guard<std::mutex> guard(lock_mutex_);
  if (lock_ && lock_->client == client) lock_->seen = Clock::now();
}

Response PanelApi::LockJson(const std::string& client) {
  const std::lock_guard<std::mutex> guard(lock_mutex_);
  if (lock_ && Clock::now() - lock_->seen > options_.lock_idle) lock_.reset();
  if (!lock_) return JsonResponse(Json{{"held", false}, {"mine", false}, {"holder", ""}});
  const double held_s = std::chrono::duration<double>(Clock::now() - lock_->since).count();
  return JsonResponse(Json{{"held", true},
                           {"mine", !client.empty() && lock_->client == client},
                           {"holder", lock_->name},
                           {"held_s", held_s}});
}

Response PanelApi::Handle(const Request& request) {
  try {
    if (!request.client.empty()) Seen(request.client);
    if (request.method == "GET") return Get(request);
    if (request.method != "POST") {
      return ErrorResponse(405, "method " + core::Printable(request.method, 20) +
                                    " is not allowed; allowed: GET, POST");
    }
    if (request.client.empty()) {
      return ErrorResponse(400,
                           "missing header X-Sirupp-Client (the page sends it; a request "
                           "without it could come from another site)");
    }
    if (request.client.size() > 64 || !core::IsPrintable(request.client)) {
      return ErrorResponse(400, "X-Sirupp-Client: at most 64 printable characters");
    }
    Json body = Json::object();
    if (!request.body.empty()) {
      body = Json::parse(request.body, nullptr, false);
      if (body.is_discarded() || !body.is_object()) {
        return ErrorResponse(400, "the request body is not a JSON object");
      }
    }
    const bool estop_engage =
        request.path == "/api/estop" && !(body.contains("engaged") && body["engaged"] == false);
    if (!ChangesNothing(request.path) || request.path == "/api/lock") {
      if (options_.require_token && request.token != options_.token) {
        return ErrorResponse(403, std::string(request.token.empty() ? "missing" : "wrong") +
                                      " token (X-Sirupp-Token): this panel listens beyond this "
                                      "computer; open the address sirupp-panel printed at start");
      }
    }
    if (!ChangesNothing(request.path) && !estop_engage && !Holds(request.client)) {
      const std::string holder = LockHolder();
      return ErrorResponse(409, holder.empty()
                                    ? "take control first (nobody holds it)"
                                    : "control is held by '" + core::Printable(holder) +
                                          "': take it over explicitly to command the arm");
    }
    return Post(request, body);
  } catch (const std::invalid_argument& error) {
    return ErrorResponse(400, error.what());
  } catch (const std::exception& error) {
    return ErrorResponse(500, error.what());
  }
}

Response PanelApi::Get(const Request& request) {
  const std::string& path = request.path;
  if (path == "/api/info") {
    return JsonResponse(Json{{"name", "sirupp-panel"},
                             {"lcm_url", hub_.url()},
                             {"token_required", options_.require_token},
                             {"model_version", hub_.model_version()}});
  }
  if (path == "/api/model") return JsonResponse(hub_.ModelJson());
  if (path == "/api/environment") return JsonResponse(hub_.EnvironmentJson());
  if (path == "/api/state") return JsonResponse(hub_.StateJson());
  if (path == "/api/gains") return JsonResponse(hub_.GainsJson());
  if (path == "/api/processes") return JsonResponse(hub_.ProcessesJson());
  if (path == "/api/lock") return LockJson(request.client);
  if (path == "/api/files") {
    const auto it = request.query.find("dir");
    return ListFiles(it == request.query.end() ? "" : it->second);
  }
  if (path == "/api/file" || path == "/api/download" || path == "/api/model/fields") {
    const auto it = request.query.find("path");
    if (path == "/api/model/fields") {
      return ModelFields(it == request.query.end() ? "" : it->second);
    }
    if (it == request.query.end()) return ErrorResponse(400, "missing ?path=");
    return path == "/api/file" ? ReadFile(it->second) : Download(it->second);
  }
  if (path == "/api/record") return RecordJson();
  return ErrorResponse(404, "no such page: " + core::Printable(path, 200));
}

Response PanelApi::Post(const Request& request, const Json& body) {
  const std::string& path = request.path;
  if (path == "/api/lock") return TakeLock(request, body);
  if (path == "/api/unlock") {
    const std::lock_guard<std::mutex> guard(lock_mutex_);
    if (lock_ && lock_->client == request.client) lock_.reset();
    return JsonResponse(Json{{"ok", true}});
  }
  if (path == "/api/ik") return SolveIk(body);
  if (path == "/api/environment/check") return CheckEnvironment(body);
  if (path == "/api/environment/load") {
    return FromResult(
        commands_.LoadEnvironment(Text(body, "name", "page.xml"), Text(body, "text")));
  }
  if (path == "/api/record/start") return FromResult(commands_.StartRecording(Text(body, "name")));
  if (path == "/api/record/stop") return FromResult(commands_.StopRecording());
  if (path == "/api/record/report") return RunReport(body);
  if (path == "/api/model/check") return ModelEdit(body, false);
  if (path == "/api/model/save") return ModelEdit(body, true);
  if (path == "/api/model/apply") {
    // A model file under config/robots, loaded into the running sim and controller.
    const std::string file = Text(body, "path");
    if (file.rfind("config/robots/", 0) != 0) {
      throw std::invalid_argument("path '" + core::Printable(file, 200) +
                                  "': allowed a model file under config/robots/");
    }
    const Response read = ReadFile(file);
    if (read.status != 200) return read;
    return FromResult(commands_.LoadModel(file, Json::parse(read.body)["text"].get<std::string>()));
  }
  if (path == "/api/plan/check") {
    return FromResult(commands_.CheckPlan(Text(body, "name", "page.plan"), Text(body, "text")));
  }
  if (path == "/api/plan/make") {
    RigCommands::PlanGoal goal;
    if (body.contains("joints") == body.contains("tool")) {
      throw std::invalid_argument(
          "goal: give joints (one per joint) or tool (x y z roll pitch yaw)");
    }
    const auto list = [&](const std::string& field) {
      if (!body[field].is_array() || body[field].size() > 32) {
        throw std::invalid_argument(field + ": expected an array of numbers");
      }
      std::vector<double> values;
      for (const Json& v : body[field]) {
        if (!v.is_number()) throw std::invalid_argument(field + ": expected an array of numbers");
        values.push_back(v.get<double>());
      }
      return values;
    };
    if (body.contains("joints")) goal.joints = list("joints");
    if (body.contains("tool")) goal.tool = list("tool");
    goal.config = Text(body, "config", "nearest");
    goal.planner = Text(body, "planner", "rrtconnect");
    const double seed = Number(body, "seed", 1.0);
    if (!(seed >= 0 && seed <= 4294967295.0) || seed != std::floor(seed)) {
      throw std::invalid_argument("seed: " + core::FormatNumber(seed) +
                                  ": allowed a whole number from 0 to 4294967295");
    }
    goal.seed = static_cast<uint32_t>(seed);
    return FromResult(commands_.MakePlan(goal));
  }
  if (path == "/api/cspace") {
    const double a = Number(body, "joint_a", std::nullopt);  // 1-based, as the page shows them
    const double b = Number(body, "joint_b", std::nullopt);
    for (const auto& [name, v] : {std::pair{"joint_a", a}, std::pair{"joint_b", b}}) {
      if (v != std::floor(v) || v < 1 || v > 32) {
        throw std::invalid_argument(std::string(name) + ": " + core::FormatNumber(v) +
                                    ": a joint number (1-based)");
      }
    }
    return FromResult(commands_.CSpace(static_cast<int>(a) - 1, static_cast<int>(b) - 1,
                                       Number(body, "step", 2.0)));
  }
  if (path == "/api/plan/run") {
    return FromResult(commands_.RunPlan(Text(body, "name", "page.plan"), Text(body, "text")));
  }
  if (path.rfind("/api/plan/", 0) == 0) return FromResult(commands_.PlanControl(path.substr(10)));
  if (path == "/api/move/joints") {
    if (!body.contains("targets") || !body["targets"].is_array()) {
      throw std::invalid_argument("targets: expected an array (number or null per joint)");
    }
    std::vector<std::optional<double>> targets;
    for (const Json& value : body["targets"]) {
      if (value.is_null()) {
        targets.emplace_back();
      } else if (value.is_number()) {
        targets.emplace_back(value.get<double>());
      } else {
        throw std::invalid_argument("targets: each entry must be a number or null");
      }
    }
    return FromResult(commands_.MoveJoints(targets, Number(body, "speed", 1.0)));
  }
  if (path == "/api/move/pose") {
    return FromResult(commands_.MovePose(Numbers(body, "pose", 6), Text(body, "config", "nearest"),
                                         Number(body, "speed", 1.0)));
  }
  if (path == "/api/gains") {
    const double joint = Number(body, "joint", 0.0);  // 1-based, 0 = all
    if (joint != static_cast<double>(static_cast<int>(joint))) {
      throw std::invalid_argument("joint: a whole number (1-based, 0 = every joint)");
    }
    if (!body.contains("values") || !body["values"].is_object()) {
      throw std::invalid_argument("values: expected an object such as {\"kp\": 120}");
    }
    std::vector<std::pair<std::string, double>> values;
    for (const auto& [field, value] : body["values"].items()) {
      if (!value.is_number()) throw std::invalid_argument("values." + field + ": must be a number");
      values.emplace_back(field, value.get<double>());
    }
    return FromResult(commands_.SetGains(static_cast<int>(joint) - 1, values));
  }
  if (path == "/api/estop") {
    const bool engaged = !(body.contains("engaged") && body["engaged"] == false);
    return FromResult(commands_.Estop(engaged, Text(body, "who"), Text(body, "reason")));
  }
  if (path.rfind("/api/hardware/", 0) == 0) {
    return FromResult(commands_.Hardware(path.substr(14)));
  }
  return ErrorResponse(404, "no such command: " + core::Printable(path, 200));
}

Response PanelApi::TakeLock(const Request& request, const Json& body) {
  const std::string name = Text(body, "name", "browser");
  if (name.empty() || name.size() > 40 || !core::IsPrintable(name)) {
    throw std::invalid_argument("name: 1..40 printable characters");
  }
  const bool take_over = body.contains("take_over") && body["take_over"] == true;
  {
    const std::lock_guard<std::mutex> guard(lock_mutex_);
    if (lock_ && Clock::now() - lock_->seen > options_.lock_idle) lock_.reset();
    if (lock_ && lock_->client != request.client && !take_over) {
      return JsonResponse(Json{{"ok", false},
                               {"error", "control is held by '" + lock_->name +
                                             "'; ask for it or take it over explicitly"},
                               {"holder", lock_->name}},
                          409);
    }
    const auto now = Clock::now();
    if (!lock_ || lock_->client != request.client) lock_ = Lock{request.client, name, now, now};
    lock_->name = name;
  }
  return LockJson(request.client);
}

Response PanelApi::ListFiles(const std::string& which) {
  fs::path dir;
  std::string ext;
  if (which == "plans") {
    dir = fs::path(options_.root) / "config/plans", ext = ".plan";
  } else if (which == "environments") {
    dir = fs::path(options_.root) / "config/environments", ext = ".xml";
  } else if (which == "robots") {
    dir = fs::path(options_.root) / "config/robots", ext = ".yaml";
  } else if (which == "results" && !options_.results_dir.empty()) {
    dir = options_.results_dir;
  } else {
    return ErrorResponse(400, "dir '" + core::Printable(which, 40) +
                                  "' is not allowed; allowed: plans, environments, robots" +
                                  (options_.results_dir.empty() ? "" : ", results"));
  }
  Json files = Json::array();
  std::error_code error;
  std::vector<std::string> names;
  for (const fs::directory_entry& entry : fs::directory_iterator(dir, error)) {
    if (!entry.is_regular_file()) continue;
    if (!ext.empty() && entry.path().extension() != ext) continue;
    names.push_back(entry.path().filename().string());
  }
  std::sort(names.begin(), names.end());
  const std::string shown = which == "results" ? dir.string() : "config/" + dir.filename().string();
  for (const std::string& name : names) files.push_back(shown + "/" + name);
  return JsonResponse(Json{{"dir", shown}, {"files", files}});
}

std::optional<fs::path> PanelApi::Allowed(const std::string& path, bool results) const {
  if (path.empty() || path.size() > 1000 || !core::IsPrintable(path)) return std::nullopt;
  std::error_code error;
  const fs::path root = fs::weakly_canonical(options_.root, error);
  const fs::path config = fs::weakly_canonical(root / "config", error);
  const fs::path given = fs::path(path).is_absolute() ? fs::path(path) : root / path;
  const fs::path real = fs::weakly_canonical(given, error);
  if (error) return std::nullopt;
  if (Inside(real, config)) return real;
  if (results && !options_.results_dir.empty() &&
      Inside(real, fs::weakly_canonical(options_.results_dir, error))) {
    return real;
  }
  return std::nullopt;
}

Response PanelApi::ReadFile(const std::string& path) {
  if (path.empty() || path.size() > 1000 || !core::IsPrintable(path)) {
    return ErrorResponse(400, "path: 1..1000 printable characters");
  }
  const std::optional<fs::path> real = Allowed(path, true);
  if (!real) {
    return ErrorResponse(403, "'" + core::Printable(path, 200) +
                                  "': the panel reads files under config/ and the results "
                                  "folder only");
  }
  std::error_code error;
  if (!fs::is_regular_file(*real, error)) {
    return ErrorResponse(404, "'" + core::Printable(path, 200) + "': no such file");
  }
  if (fs::file_size(*real, error) > kMaxFileBytes) {
    return ErrorResponse(413, "'" + core::Printable(path, 200) + "': larger than 1 MiB");
  }
  std::ifstream in(*real, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return JsonResponse(Json{{"path", path}, {"text", text.str()}});
}

Response PanelApi::SolveIk(const Json& body) {
  const std::vector<double> v = Numbers(body, "pose", 6);
  for (double value : v) {
    if (!std::isfinite(value)) throw std::invalid_argument("pose: values must be finite");
  }
  const std::optional<core::RobotModel> model = hub_.Model();
  if (!model) return ErrorResponse(503, "no robot model yet: is sirupp-sim running?");
  Eigen::Isometry3d target = Eigen::Isometry3d::Identity();
  target.translation() << v[0], v[1], v[2];
  target.linear() =
      core::QuaternionFromRpy(v[3] * kDeg, v[4] * kDeg, v[5] * kDeg).toRotationMatrix();
  const std::optional<std::vector<double>> present = hub_.VirtualJoints();
  const core::JointVector reference = core::ToJointVector(
      present && present->size() == model->joints.size() ? *present
                                                         : control::HomePositions(*model));
  // The library's one solver choice (the panel asks for neither numeric nor position-only).
  const core::IkRequest request;
  const bool closed_form = core::ChooseIkSolver(*model, request).closed_form;
  const core::IkResult result = core::SolveIk(*model, target, reference, request);
  Json solutions = Json::array();
  for (const core::IkSolution& solution : result.solutions) {
    Json q = Json::array();
    for (size_t j = 0; j < model->joints.size(); ++j) {
      q.push_back(ToDisplay(model->joints[j], solution.q[static_cast<Eigen::Index>(j)]));
    }
    solutions.push_back(Json{{"config", solution.config ? solution.config->Name() : "numeric"},
                             {"within_limits", solution.within_limits},
                             {"singularities", solution.singularities},
                             {"q", q}});
  }
  Json configs = Json::array();
  if (closed_form) {
    for (const char* shoulder : {"left", "right"}) {
      for (const char* elbow : {"up", "down"}) {
        for (const char* wrist : {"noflip", "flip"}) {
          const std::string name = std::string(shoulder) + "-" + elbow + "-" + wrist;
          bool reachable = false;
          bool within = false;
          for (const core::IkSolution& solution : result.solutions) {
            if (solution.config && solution.config->Name() == name) {
              reachable = true;
              within = within || solution.within_limits;
            }
          }
          configs.push_back(
              Json{{"config", name}, {"reachable", reachable}, {"within_limits", within}});
        }
      }
    }
  }
  const core::IkSolution* nearest = core::NearestSolution(result, reference);
  return JsonResponse(Json{{"ok", result.ok()},
                           {"reason", result.reason},
                           {"solver", closed_form ? "closed-form" : "numeric"},
                           {"nearest", nearest && nearest->config ? nearest->config->Name() : ""},
                           {"solutions", solutions},
                           {"configurations", configs}});
}

Response PanelApi::CheckEnvironment(const Json& body) {
  const std::string name = Text(body, "name", "page.xml");
  const std::string text = Text(body, "text");
  try {
    const core::Environment environment = core::ParseEnvironment(text, name);
    const sirupp::environment_t message = core::ToMessage(environment, 0, 0);
    Json objects = Json::array();
    for (const sirupp::environment_object_t& object : message.objects) {
      objects.push_back(Json{{"name", object.name},
                             {"static", object.is_static != 0},
                             {"mass", object.mass},
                             {"shape", ShapeJson(object.shape)}});
    }
    return JsonResponse(Json{{"ok", true}, {"name", environment.name}, {"objects", objects}});
  } catch (const core::ConfigError& error) {
    return JsonResponse(Json{{"ok", false},
                             {"error", error.what()},
                             {"line", error.where().line},
                             {"column", error.where().column}},
                        422);
  }
}

Response PanelApi::Download(const std::string& path) {
  const std::optional<fs::path> real = Allowed(path, true);
  std::error_code error;
  if (!real || !fs::is_regular_file(*real, error)) {
    return ErrorResponse(real ? 404 : 403,
                         "'" + core::Printable(path, 200) +
                             (real ? "': no such file"
                                   : "': the panel gives files under config/ and the results "
                                     "folder only"));
  }
  if (fs::file_size(*real, error) > kMaxDownloadBytes) {
    return ErrorResponse(413, "'" + core::Printable(path, 200) +
                                  "': larger than 256 MiB; copy it from the results folder");
  }
  std::ifstream in(*real, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  const std::string ext = real->extension().string();
  return Response{200,
                  ext == ".csv"                    ? "text/csv"
                  : ext == ".md" || ext == ".yaml" ? "text/plain; charset=utf-8"
                  : ext == ".png"                  ? "image/png"
                                                   : "application/octet-stream",
                  text.str()};
}

Response PanelApi::RecordJson() {
  // The logger as its heartbeat shows it; "recording NAME: ..." names the run being written.
  Json logger = nullptr;
  std::string recording;
  const Json processes = hub_.ProcessesJson();
  for (const Json& row : processes["processes"]) {
    if (row["process"] != "sirupp-logger" || !row["alive"].get<bool>()) continue;
    const std::string detail = row["detail"].get<std::string>();
    logger = Json{{"state", row["state"]}, {"detail", detail}, {"host", row["host"]}};
    if (detail.rfind("recording ", 0) == 0) {
      recording = detail.substr(
          10, detail.find(':') == std::string::npos ? std::string::npos : detail.find(':') - 10);
    }
  }
  Json runs = Json::array();
  if (!options_.results_dir.empty()) {
    // Data files grouped by run: NAME-NN-SET.csv, NAME-rK.csv, NAME.csv (and .K continuations).
    static const std::regex kSplit(R"(^(.+)-\d\d-[^.]+(\.\d+)?$)");
    static const std::regex kRestart(R"(^(.+)-r\d+(\.\d+)?$)");
    static const std::regex kContinued(R"(^(.+)\.\d+$)");
    std::map<std::string, std::vector<std::pair<std::string, uintmax_t>>> by_run;
    std::map<std::string, fs::file_time_type> newest;
    std::error_code error;
    for (const fs::directory_entry& entry : fs::directory_iterator(options_.results_dir, error)) {
      if (!entry.is_regular_file() || entry.path().extension() != ".csv") continue;
      const std::string stem = entry.path().stem().string();
      std::smatch match;
      std::string run = stem;
      if (std::regex_match(stem, match, kSplit) || std::regex_match(stem, match, kRestart) ||
          std::regex_match(stem, match, kContinued)) {
        run = match[1];
      }
      std::error_code size_error;
      by_run[run].emplace_back(entry.path().string(), entry.file_size(size_error));
      const fs::file_time_type time = entry.last_write_time(size_error);
      if (!newest.count(run) || time > newest[run]) newest[run] = time;
    }
    std::vector<std::string> names;
    for (const auto& [name, files] : by_run) names.push_back(name);
    std::sort(names.begin(), names.end(),
              [&](const std::string& a, const std::string& b) { return newest[a] > newest[b]; });
    for (const std::string& name : names) {
      std::vector<std::pair<std::string, uintmax_t>>& files = by_run[name];
      std::sort(files.begin(), files.end());
      Json list = Json::array();
      uintmax_t total = 0;
      for (const auto& [file, size] : files) {
        list.push_back(Json{{"path", file}, {"size", size}});
        total += size;
      }
      const fs::path report = fs::path(options_.results_dir) / (name + "-report") / "report.md";
      runs.push_back(Json{{"name", name},
                          {"recording", name == recording},
                          {"files", list},
                          {"bytes", total},
                          {"report", fs::exists(report, error) ? report.string() : ""}});
    }
  }
  return JsonResponse(Json{{"logger", logger},
                           {"recording", recording},
                           {"results_dir", options_.results_dir},
                           {"runs", runs}});
}

Response PanelApi::RunReport(const Json& body) {
  const std::string run = Text(body, "run");
  if (options_.results_dir.empty()) {
    return ErrorResponse(409, "no results folder: start sirupp-panel with --results DIR");
  }
  const Json record = Json::parse(RecordJson().body);
  for (const Json& entry : record["runs"]) {
    if (entry["name"] != run) continue;
    if (entry["recording"].get<bool>()) {
      return ErrorResponse(
          409, "run '" + core::Printable(run, 100) + "' is being recorded: stop it first");
    }
    std::vector<std::string> files;
    for (const Json& file : entry["files"]) files.push_back(file["path"].get<std::string>());
    logger::ReportOptions options;
    options.out_dir = (fs::path(options_.results_dir) / (run + "-report")).string();
    options.plots = false;
    try {
      const logger::ReportOutput output =
          logger::WriteReport(logger::ReadInputs(files, options.import), options);
      return JsonResponse(Json{{"ok", true},
                               {"markdown", output.markdown},
                               {"report", options.out_dir + "/report.md"},
                               {"moves", output.moves}});
    } catch (const core::ConfigError& error) {
      return ErrorResponse(422, error.what());
    }
  }
  return ErrorResponse(404,
                       "no run '" + core::Printable(run, 100) + "' in " + options_.results_dir);
}

Response PanelApi::ModelFields(const std::string& path) {
  std::string given = path;
  if (given.empty()) {
    const std::optional<core::RobotModel> model = hub_.Model();
    if (!model) return ErrorResponse(503, "no robot model yet: is sirupp-sim running?");
    given = model->source_file;
  }
  const Response file = ReadFile(given);
  if (file.status != 200) return file;
  const std::string text = Json::parse(file.body)["text"].get<std::string>();
  try {
    Json fields = Json::array();
    for (const ModelField& field : EditableFields(text, given)) {
      fields.push_back(Json{
          {"key", field.key}, {"group", field.group}, {"value", field.text}, {"line", field.line}});
    }
    std::string units;
    const size_t at = text.find("\nunits:");
    if (at != std::string::npos) units = text.substr(at + 8, text.find('\n', at + 1) - at - 8);
    return JsonResponse(Json{{"path", given}, {"units", units}, {"fields", fields}});
  } catch (const core::ConfigError& error) {
    return ErrorResponse(422, error.what());
  }
}

Response PanelApi::ModelEdit(const Json& body, bool save) {
  const std::string path = Text(body, "path");
  const Response file = ReadFile(path);
  if (file.status != 200) return file;
  if (!body.contains("edits") || !body["edits"].is_object()) {
    throw std::invalid_argument("edits: expected an object such as {\"dh[1].a\": \"8.5\"}");
  }
  std::map<std::string, std::string> edits;
  for (const auto& [key, value] : body["edits"].items()) {
    if (value.is_string()) {
      edits[key] = value.get<std::string>();
    } else if (value.is_number()) {
      edits[key] = value.dump();
    } else {
      throw std::invalid_argument("edits." + core::Printable(key, 80) +
                                  ": must be a number or a text");
    }
  }
  const std::string text = Json::parse(file.body)["text"].get<std::string>();
  std::vector<ModelField> fields;
  try {
    fields = EditableFields(text, path);
  } catch (const core::ConfigError& error) {
    return ErrorResponse(422, error.what());
  }
  const std::string edited = ApplyModelEdits(text, fields, edits);
  std::string target = path;
  std::string name;
  if (save) {
    name = Text(body, "name");
    CheckModelFileName(name);
    target = "config/robots/" + name + ".yaml";
  }
  ModelCheck check = CheckModelText(edited, target, EditableFields(edited, target));
  if (!check.ok && check.field.empty()) {
    // An error about a whole value ("joints[0].limits") names the edited part of it.
    for (const auto& [key, value] : edits) {
      if (!check.key_path.empty() && key.rfind(check.key_path, 0) == 0) check.field = key;
    }
  }
  if (!check.ok) {
    return JsonResponse(Json{{"ok", false},
                             {"error", check.error},
                             {"line", check.line},
                             {"key_path", check.key_path},
                             {"field", check.field}},
                        422);
  }
  if (!save) {
    return JsonResponse(Json{
        {"ok", true},
        {"message", "the edited model '" + check.model_name + "' passes the model loader's checks"},
        {"changed", edits.size()}});
  }
  const fs::path out = fs::path(options_.root) / target;
  std::error_code error;
  if (fs::exists(out, error)) {
    return ErrorResponse(409, target +
                                  " exists already: choose another name (the panel never "
                                  "replaces a model file)");
  }
  {
    std::ofstream file_out(out, std::ios::binary);
    file_out << "# Edited in the lab panel from " << path << " (" << edits.size()
             << " values changed).\n"
             << edited;
    if (!file_out) return ErrorResponse(500, "cannot write " + target);
  }
  return JsonResponse(Json{
      {"ok", true},
      {"path", target},
      {"message", "saved " + target + "; Apply loads it into the running sim and controller"}});
}

}  // namespace sirupp::panel
