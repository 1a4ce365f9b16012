#include "panel/panel_api.hpp"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "control/plan.hpp"
#include "core/environment.hpp"
#include "core/errors.hpp"
#include "core/geometry.hpp"
#include "core/inverse_kinematics.hpp"
#include "core/printable.hpp"

namespace sirupp::panel {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
constexpr double kDeg = 3.14159265358979323846 / 180;
constexpr size_t kMaxFileBytes = 1024 * 1024;

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
  return path == "/api/ik" || path == "/api/plan/check" || path == "/api/environment/check" ||
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
  if (path == "/api/file") {
    const auto it = request.query.find("path");
    if (it == request.query.end()) return ErrorResponse(400, "missing ?path=");
    return ReadFile(it->second);
  }
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
  if (path == "/api/plan/check") {
    return FromResult(commands_.CheckPlan(Text(body, "name", "page.plan"), Text(body, "text")));
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

Response PanelApi::ReadFile(const std::string& path) {
  if (path.empty() || path.size() > 1000 || !core::IsPrintable(path)) {
    return ErrorResponse(400, "path: 1..1000 printable characters");
  }
  std::error_code error;
  const fs::path root = fs::weakly_canonical(options_.root, error);
  const fs::path config = fs::weakly_canonical(root / "config", error);
  const fs::path given = fs::path(path).is_absolute() ? fs::path(path) : root / path;
  const fs::path real = fs::weakly_canonical(given, error);
  bool allowed = !error && Inside(real, config);
  if (!allowed && !options_.results_dir.empty()) {
    allowed = Inside(real, fs::weakly_canonical(options_.results_dir, error));
  }
  if (!allowed) {
    return ErrorResponse(403, "'" + core::Printable(path, 200) +
                                  "': the panel reads files under config/ and the results "
                                  "folder only");
  }
  if (!fs::is_regular_file(real, error)) {
    return ErrorResponse(404, "'" + core::Printable(path, 200) + "': no such file");
  }
  if (fs::file_size(real, error) > kMaxFileBytes) {
    return ErrorResponse(413, "'" + core::Printable(path, 200) + "': larger than 1 MiB");
  }
  std::ifstream in(real, std::ios::binary);
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
  const bool closed_form = !core::PumaIkNotApplicable(*model).has_value();
  const core::IkResult result = closed_form ? core::SolvePumaIk(*model, target, reference)
                                            : core::SolveNumericIk(*model, target, reference);
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

}  // namespace sirupp::panel
