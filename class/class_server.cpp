#include "class/class_server.hpp"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <mutex>
#include <optional>
#include <ostream>
#include <regex>
#include <sstream>
#include <thread>

#include "class/front_auth.hpp"
#include "class/hub_api.hpp"
#include "class/notebook_submissions.hpp"
#include "class/real_arm.hpp"
#include "class/rig_job.hpp"
#include "class/rig_pool.hpp"
#include "class/rig_proxy.hpp"
#include "class/submissions.hpp"
#include "class/tokens.hpp"
#include "core/errors.hpp"
#include "core/printable.hpp"
#include "panel/http_glue.hpp"
#include "panel/rig_commands.hpp"
#include "runtime/data_path.hpp"

// After Eigen (through panel/): httplib brings <resolv.h>, whose _res macro breaks Eigen's headers.
#include "class/http_guard.hpp"

namespace sirupp::classroom {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
using Json = nlohmann::json;

constexpr const char* kStudentCookie = "sirupp_student";
constexpr const char* kTeacherCookie = "sirupp_teacher";

std::string ContentType(const std::string& path) {
  const std::string ext = fs::path(path).extension().string();
  if (ext == ".html") return "text/html; charset=utf-8";
  if (ext == ".js") return "application/javascript";
  if (ext == ".css") return "text/css";
  if (ext == ".json") return "application/json";
  if (ext == ".png") return "image/png";
  if (ext == ".svg") return "image/svg+xml";
  return "application/octet-stream";
}

void SendJson(httplib::Response& res, int status, const Json& body) {
  panel::Send(panel::Response{status, "application/json", body.dump()}, res);
}

void SendError(httplib::Response& res, int status, const std::string& message) {
  panel::Send(panel::ErrorResponse(status, message), res);
}

// A file under `dir` named by `relative`, refused when it leaves `dir` (after symlinks) or is not
// a regular file.
bool ServeFileUnder(const std::string& dir, const std::string& relative, httplib::Response& res) {
  if (relative.empty() || relative.size() > 300 || relative.find("..") != std::string::npos) {
    return false;
  }
  std::error_code error;
  const fs::path base = fs::canonical(dir, error);
  if (error) return false;
  const fs::path file = fs::weakly_canonical(base / relative, error);
  if (error) return false;
  const std::string text = file.string();
  if (text.rfind(base.string() + "/", 0) != 0 || !fs::is_regular_file(file)) return false;
  std::ifstream in(file, std::ios::binary);
  std::ostringstream body;
  body << in.rdbuf();
  res.status = 200;
  res.set_header("Cache-Control", "no-cache");
  res.set_content(body.str(), ContentType(text).c_str());
  return true;
}

std::string ReadAll(const std::string& file) {
  std::ifstream in(file, std::ios::binary);
  std::ostringstream body;
  body << in.rdbuf();
  return body.str();
}

// The value of cookie `name` in a Cookie header; "" when absent.
std::string CookieValue(const std::string& header, const std::string& name) {
  std::istringstream in(header);
  std::string part;
  while (std::getline(in, part, ';')) {
    const size_t start = part.find_first_not_of(' ');
    if (start == std::string::npos) continue;
    part = part.substr(start);
    if (part.rfind(name + "=", 0) == 0) return part.substr(name.size() + 1);
  }
  return "";
}

std::string HtmlEscape(const std::string& text) {
  std::string out;
  for (const char c : text) {
    switch (c) {
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '&':
        out += "&amp;";
        break;
      case '"':
        out += "&quot;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

void SendHtmlMessage(httplib::Response& res, int status, const std::string& title,
                     const std::string& message) {
  res.status = status;
  res.set_header("Cache-Control", "no-store");
  res.set_content("<!doctype html><meta charset=\"utf-8\"><title>" + HtmlEscape(title) +
                      "</title><body style=\"font-family:sans-serif;margin:2em\"><h1>" +
                      HtmlEscape(title) + "</h1><p id=\"message\">" + HtmlEscape(message) +
                      "</p></body>",
                  "text/html; charset=utf-8");
}

enum class Role { kNone, kStudent, kTeacher };

// A token as the class issues them (RandomHex): letters and digits only, at most 256.
bool IsTokenText(const std::string& token) {
  return token.size() <= 256 && std::all_of(token.begin(), token.end(), [](char c) {
           return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z');
         });
}

// ?token= as it stands in the request's target: httplib decodes query values, and a token is
// compared as sent; a %-encoded one comes back with its '%' (and is refused by IsTokenText).
std::string QueryToken(const httplib::Request& req) {
  if (!req.has_param("token")) return "";
  const std::string& target = req.target;
  const size_t query = target.find('?');
  if (query == std::string::npos) return req.get_param_value("token");
  std::string found;
  size_t at = query + 1;
  while (at <= target.size()) {
    const size_t end = std::min(target.find('&', at), target.size());
    const std::string pair = target.substr(at, end - at);
    if (pair.rfind("token=", 0) == 0) {
      found = pair.substr(6);
      break;
    }
    at = end + 1;
  }
  return found.empty() ? req.get_param_value("token") : found;
}

}  // namespace

std::string TokensFile(const ClassConfig& config) { return config.data_dir + "/tokens.json"; }
std::string HandoutFile(const ClassConfig& config) { return config.data_dir + "/tokens.csv"; }
// StudentFolder: class/rig_pool.cpp.

std::string TurnsLogFile(const ClassConfig& config) { return config.data_dir + "/turns.jsonl"; }

std::string AddressWithToken(const ClassConfig& config, int port, const std::string& name,
                             const std::string& token) {
  const std::string base = BaseUrl(config, port);
  if (name == kTeacher) return base + "/teacher/?token=" + token;
  return base + "/s/" + name + "/?token=" + token;
}

std::vector<std::pair<std::string, std::string>> IssueMissingTokens(const ClassConfig& config,
                                                                    int port) {
  fs::create_directories(config.data_dir);
  TokenStore store(TokensFile(config));
  std::vector<std::pair<std::string, std::string>> rows;
  std::vector<std::string> names{kTeacher};
  names.insert(names.end(), config.students.begin(), config.students.end());
  for (const std::string& name : names) {
    if (store.Has(name)) continue;
    rows.emplace_back(name, AddressWithToken(config, port, name, store.Issue(name)));
  }
  if (!rows.empty()) AppendHandout(HandoutFile(config), rows);
  return rows;
}

std::pair<std::string, std::string> ReissueToken(const ClassConfig& config, int port,
                                                 const std::string& name) {
  if (name != kTeacher &&
      std::find(config.students.begin(), config.students.end(), name) == config.students.end()) {
    throw core::UsageError("--reissue " + core::Printable(name, 40) + ": not a student of " +
                           config.file + "; allowed: teacher or a name under students:");
  }
  fs::create_directories(config.data_dir);
  TokenStore store(TokensFile(config));
  const std::pair<std::string, std::string> row{
      name, AddressWithToken(config, port, name, store.Issue(name))};
  AppendHandout(HandoutFile(config), {row});
  return row;
}

// The HTTP side of the class server: tokens, cookies, pages and routes. Every rig is the rig
// pool's (class/rig_pool.hpp); the routes only ask it.
struct ClassServer::Impl {
  ClassConfig config;
  ServeOptions options;
  TokenStore tokens;
  BadTokenThrottle throttle;
  FrontAuth front;  // server.trusted_proxy: sign-in by the university's front (front_auth.hpp)
  ProcessLauncher launcher;  // outlives the rigs
  // Where the rigs and the grades run (class/rig_spawner.hpp), made once from the class file;
  // outlives the submissions and the rigs, which use it.
  std::unique_ptr<RigSpawnerFactory> spawners;
  // Students' controllers from the browser: store, builds, the grading worker (after the launcher,
  // so it ends first).
  std::unique_ptr<SubmissionService> submissions;
  // Notebook assignments (class/notebook_submissions.hpp): store, the grading worker.
  std::unique_ptr<NotebookSubmissionService> notebook_submissions;
  // Every student's rig: start, stop, idle, reattach, status (after the submissions: a rig asks
  // them for its controller).
  std::unique_ptr<RigPool> rigs;
  int port = 0;
  std::mutex log_mutex;
  // The real arm's queue (class file real_arm:), or none. After the rigs: it asks them for the
  // rigs' addresses, so it goes first.
  std::unique_ptr<RealArm> real_arm;
  // Last: destroyed first, so no request runs once the rigs are gone. HTTPS with a certificate
  // (OpenSSL); every connection under the limits of server: (class/http_guard.hpp).
  std::unique_ptr<GuardedServer> server;
  panel::ListenGate gate;
  // notebooks.hub_url: the hub's secret for its API (class/hub_api.hpp); "" = no hub.
  std::string hub_secret;

  Impl(ClassConfig c, ServeOptions o)
      : config(std::move(c)), options(std::move(o)), tokens(TokensFile(config)) {
    if (config.front) front = FrontAuth(*config.front);
    // HTTPS with the class file's certificate; deadlines and caps per connection (http_guard).
    server = std::make_unique<GuardedServer>(config.http, config.tls_cert, config.tls_key,
                                             config.front ? config.front->address : "");
    server->SetClientOf([this](const httplib::Request& req) -> std::string {
      const FrontAuth::HeaderOf header = [&req](const std::string& name) {
        return req.get_header_value(name);
      };
      if (!front.Vouched(req.remote_addr, header)) return "";
      const std::string client = front.ClientAddress(req.remote_addr, header);
      return SameAddress(client, req.remote_addr) ? "" : client;
    });
    spawners = MakeRigSpawnerFactory(
        config, RigSpawnerOptions{options.bin_dir, [this](const std::string& line) { Log(line); }},
        launcher);
    SubmissionOptions submission_options;
    submission_options.bin_dir = options.bin_dir;
    submission_options.include_dir =
        fs::path(runtime::ResolveDataPath("include/sirupp/controller.h"))
            .parent_path()
            .parent_path()
            .string();
    submissions = std::make_unique<SubmissionService>(
        config, submission_options, *spawners, [this](const std::string& line) { Log(line); });
    notebook_submissions = MakeNotebookSubmissions();
    RigPoolOptions pool_options;
    pool_options.bin_dir = options.bin_dir;
    pool_options.config_dir = options.config_dir;
    pool_options.controller = [this](const std::string& student) {
      return submissions->RigController(student);
    };
    pool_options.log = [this](const std::string& line) { Log(line); };
    rigs = std::make_unique<RigPool>(config, std::move(pool_options), *spawners);
    if (config.notebooks && !config.notebooks->hub_url.empty()) {
      hub_secret = EnsureHubSecret(config);
    }
    if (config.real_arm) {
      fs::create_directories(config.data_dir);
      real_arm = std::make_unique<RealArm>(
          config, TurnsLogFile(config),
          [this](const std::string& student) { return rigs->LcmUrl(student); },
          [this](const std::string& line) { Log("real arm: " + line); },
          // A rig job's bus is on its node: relayed through the job's endpoint.
          [this](const std::string& student) -> std::optional<RigEndpoint> {
            const RigAccess access = rigs->Access(student);
            if (access.phase != RigPhase::kRunning) return std::nullopt;
            return access.endpoint;
          });
      // Only a controller that passed the class's safety tasks in simulation drives the real arm
      // (a rig that switches controller restarts, which ends its place in the queue).
      real_arm->SetAdmit([this](const std::string& student) {
        const std::optional<std::string> why = submissions->RealArmRefusal(student);
        return why ? *why : std::string();
      });
      rigs->SetRealArmHooks(
          [this](const std::string& student, const std::string& why) {
            real_arm->RigStopped(student, why);
          },
          [this](const std::string& student) { return real_arm->Involved(student); });
    }
  }

  std::unique_ptr<NotebookSubmissionService> MakeNotebookSubmissions() {
    NotebookSubmissionOptions notebook_options;
    notebook_options.bin_dir = options.bin_dir;
    try {
      return std::make_unique<NotebookSubmissionService>(
          config, notebook_options, launcher, [this](const std::string& line) { Log(line); });
    } catch (const std::runtime_error& error) {  // a hidden tests file that cannot be read
      throw std::runtime_error(config.file + ": notebooks: assignments: " + error.what());
    }
  }

  // The counted controller grade of each student (percent), for the gradebook's CSV.
  std::function<std::optional<double>(const std::string&)> ControllerScores() {
    const Json grades = submissions->GradesJson();
    std::map<std::string, double> scores;
    for (const Json& row : grades.value("rows", Json::array())) {
      const auto grade = row.find("grade");
      if (grade == row.end() || !grade->is_object()) continue;
      const auto score = grade->find("score");
      if (score != grade->end() && score->is_number()) {
        scores[row.value("student", "")] = score->get<double>();
      }
    }
    return [scores](const std::string& student) -> std::optional<double> {
      const auto found = scores.find(student);
      if (found == scores.end()) return std::nullopt;
      return found->second;
    };
  }

  void Log(const std::string& line) {
    if (options.log == nullptr) return;
    const std::lock_guard<std::mutex> lock(log_mutex);
    *options.log << "sirupp class: " << line << std::endl;
  }

  // --- tokens -----------------------------------------------------------------------------------

  // Who the request's token makes its sender for /s/NAME/ (student = NAME only), or for /teacher/
  // (student_name empty). Fills `res` (403 or 429) and returns kNone when nobody.
  Role Authorize(const httplib::Request& req, const std::string& student_name,
                 httplib::Response& res) {
    const FrontAuth::HeaderOf header = [&req](const std::string& name) {
      return req.get_header_value(name);
    };
    // Behind the class's front, the throttle and the log name the client the front saw, but only
    // on a request with the front's secret (without it, X-Forwarded-For is anyone's).
    const std::string client = front.ClientAddress(req.remote_addr, header);
    const double wait = throttle.WaitFor(client, Clock::now());
    if (wait > 0) {
      const int seconds = static_cast<int>(wait) + 1;
      res.set_header("Retry-After", std::to_string(seconds));
      SendError(res, 429,
                "too many bad tokens from " + client + "; try again in " + std::to_string(seconds) +
                    " s");
      return Role::kNone;
    }
    const FrontVerdict verdict = front.Judge(req.remote_addr, header);
    if (verdict.kind != FrontVerdict::Kind::kNoFront) {
      return AuthorizeFront(verdict, client, student_name, res);
    }
    // The page a failure or a success counts for (BadTokenThrottle: a good token forgives only
    // the failures on its own page).
    const std::string page_owner = student_name.empty() ? std::string(kTeacher) : student_name;
    const std::string where =
        student_name.empty() ? "/teacher/" : "/s/" + core::Printable(student_name, 40) + "/";
    std::vector<std::string> offered;
    for (const std::string& token : {req.get_header_value("X-Sirupp-Token"), QueryToken(req),
                                     CookieValue(req.get_header_value("Cookie"), kStudentCookie),
                                     CookieValue(req.get_header_value("Cookie"), kTeacherCookie)}) {
      if (token.empty()) continue;
      if (!IsTokenText(token)) {
        // Compared as sent: a token is letters and digits, never %-encoded.
        throttle.Failed(client, page_owner, Clock::now());
        Log("refused a malformed token for " + where + " from " + client);
        SendError(res, 403,
                  "'" + core::Printable(token, 60) +
                      "' is not a token; allowed: the letters and digits of the address your "
                      "teacher gave you, as they are (no %-encoding)");
        return Role::kNone;
      }
      offered.push_back(token);
    }
    for (const std::string& token : offered) {
      if (!student_name.empty() && rigs->Has(student_name) && tokens.Check(student_name, token)) {
        throttle.Succeeded(client, page_owner);
        return Role::kStudent;
      }
      if (tokens.Check(kTeacher, token)) {
        throttle.Succeeded(client, page_owner);
        return Role::kTeacher;
      }
    }
    if (offered.empty()) {
      SendError(
          res, 403,
          "no token: open the address with ?token=... that your teacher gave you (" + where + ")");
    } else {
      throttle.Failed(client, page_owner, Clock::now());
      Log("refused a bad token for " + where + " from " + client);
      SendError(res, 403, "this token does not open " + where);
    }
    return Role::kNone;
  }

  // A request the class's front signed in (front_auth.hpp): a student's own page, any page for a
  // teacher; else 403 naming who the front says they are.
  Role AuthorizeFront(const FrontVerdict& verdict, const std::string& client,
                      const std::string& student_name, httplib::Response& res) {
    if (verdict.kind == FrontVerdict::Kind::kRefused) {
      Log("refused a request from " + client + ": " + verdict.reason);
      SendError(res, 403, verdict.reason);
      return Role::kNone;
    }
    const std::string who = core::Printable(verdict.user, 60);
    const std::string role = front.RoleOf(verdict.user, config.students);
    if (role == "teacher") return Role::kTeacher;
    if (role == "student" && verdict.user == student_name) return Role::kStudent;
    if (role.empty()) {
      SendError(res, 403,
                "you are signed in as '" + who + "', who is not in the class " + config.name +
                    " (neither a student nor in server.proxy_teachers); ask your teacher");
      return Role::kNone;
    }
    const std::string where =
        student_name.empty() ? "/teacher/" : "/s/" + core::Printable(student_name, 40) + "/";
    SendError(
        res, 403,
        "you are signed in as '" + who + "': " + where + " is not yours (yours: /s/" + who + "/)");
    return Role::kNone;
  }

  // After a good ?token= on a page: the token goes into a cookie for the path, and the browser to
  // the address without it (so it stays out of the address bar and history).
  bool RedirectWithCookie(const httplib::Request& req, httplib::Response& res,
                          const std::string& owner, const std::string& cookie,
                          const std::string& path, const std::string& page) {
    if (!req.has_param("token") || !tokens.Check(owner, req.get_param_value("token"))) {
      return false;
    }
    const std::string secure = config.tls_cert.empty() ? "" : "; Secure";
    res.set_header("Set-Cookie", cookie + "=" + req.get_param_value("token") + "; Path=" + path +
                                     "; HttpOnly; SameSite=Strict" + secure);
    res.set_redirect(page, 303);
    return true;
  }

  // --- what the pages are told -----------------------------------------------------------------

  Json ClassJson() const {
    Json list = Json::array();
    for (const std::string& name : rigs->Students()) list.push_back(rigs->SeatJson(name, true));
    return Json{{"class", config.name},
                {"description", config.description},
                {"max_rigs", config.max_rigs},
                {"running", rigs->running()},
                {"idle_timeout_s", config.idle_timeout_s},
                {"rigs", list},
                {"real_arm", real_arm ? real_arm->TeacherJson() : Json{{"enabled", false}}}};
  }

  size_t ResultFiles(const std::string& name) const {
    std::error_code error;
    size_t count = 0;
    for (fs::recursive_directory_iterator it(StudentFolder(config, name) + "/results", error), end;
         !error && it != end; it.increment(error)) {
      if (it->is_regular_file()) ++count;
    }
    return count;
  }

  // --- routes -----------------------------------------------------------------------------------

  static bool IsChange(const httplib::Request& req) { return req.method != "GET"; }

  // POSTs of our own pages carry X-Sirupp-Client (a cross-site form cannot without a preflight).
  static bool MissingClient(const httplib::Request& req, httplib::Response& res) {
    if (IsChange(req) && req.get_header_value("X-Sirupp-Client").empty()) {
      SendError(res, 400,
                "missing header X-Sirupp-Client (the page sends it; a request from another site "
                "cannot)");
      return true;
    }
    return false;
  }

  void ServeStudentPage(const std::string& name, Role role, httplib::Response& res) {
    if (role == Role::kStudent) {
      const std::string why = rigs->Ensure(name);
      if (!why.empty()) {
        SendHtmlMessage(res, 503, "Your rig is not available", why);
        return;
      }
    }
    std::string page = ReadAll(options.panel_web_dir + "/index.html");
    const size_t head = page.find("</head>");
    if (head != std::string::npos) {
      page.insert(head, "<link rel=\"stylesheet\" href=\"class.css\">\n");
    }
    const size_t body = page.find("<body");
    const size_t body_end = body == std::string::npos ? body : page.find('>', body);
    if (body_end != std::string::npos) {
      page.insert(body_end + 1,
                  "\n<!-- the class server's bar (class/web/student.js) -->\n"
                  "<div id=\"class-bar\" class=\"class-bar\"><span id=\"class-status\">class</span>"
                  "<section id=\"real-arm-queue\" class=\"class-queue\" hidden></section></div>\n");
    }
    const size_t end = page.rfind("</body>");
    if (end != std::string::npos) page.insert(end, "<script src=\"class.js\"></script>\n");
    res.status = 200;
    res.set_header("Cache-Control", "no-store");
    res.set_content(page, "text/html; charset=utf-8");
  }

  void Student(const httplib::Request& req, httplib::Response& res) {
    const std::string name = req.matches[1];
    const std::string rest = req.matches[2];
    const Role role = Authorize(req, name, res);
    if (role == Role::kNone) return;
    if (!rigs->Has(name)) {  // only the teacher's token gets here with an unknown name
      SendError(res, 404, "no student '" + core::Printable(name, 40) + "' in this class");
      return;
    }
    if (role == Role::kStudent) rigs->Touch(name);
    if (rest.empty() || rest == "index.html") {
      if (req.method != "GET") {
        SendError(res, 405, "method " + req.method + " on the page; allowed: GET");
        return;
      }
      const std::string page = "/s/" + name + "/";
      if (role == Role::kStudent &&
          RedirectWithCookie(req, res, name, kStudentCookie, page, page)) {
        return;
      }
      ServeStudentPage(name, role, res);
      return;
    }
    if (rest == "class/status") {
      Json status = rigs->SeatJson(name, false);
      status["class"] = config.name;
      status["role"] = role == Role::kStudent ? "student" : "teacher";
      status["files"] = ResultFiles(name);
      status["idle_timeout_s"] = config.idle_timeout_s;
      if (role == Role::kStudent) {
        if (auto link = NotebooksLink(config, name, StudentToken(req, name))) {
          status["notebooks_url"] = *link;
        }
      }
      SendJson(res, 200, status);
      return;
    }
    if (rest == "class/start") {
      if (req.method != "POST") {
        SendError(res, 405, "class/start: allowed: POST");
        return;
      }
      if (MissingClient(req, res)) return;
      if (role != Role::kStudent) {
        SendError(res, 403,
                  "only " + name + " starts this rig (the teacher restarts it from /teacher/)");
        return;
      }
      const std::string why = rigs->Ensure(name);
      if (why.empty()) {
        SendJson(res, 200, rigs->SeatJson(name, false));
      } else {
        SendError(res, 503, why);
      }
      return;
    }
    if (rest == "class/turns" || rest.rfind("class/turns/", 0) == 0) {
      StudentTurns(name, role, rest, req, res);
      return;
    }
    if (rest.rfind("api/", 0) == 0) {
      Api(name, role, rest, req, res);
      return;
    }
    // Controllers from the browser (class/submissions.hpp): submit, list, report, run on the rig.
    if (req.method == "POST" && rest.rfind("class/", 0) == 0 && MissingClient(req, res)) return;
    const auto restart = [this, name] {
      rigs->Stop(name, "restarted with another controller");
      return rigs->Ensure(name);
    };
    // Notebook assignments (class/notebook_submissions.hpp): submit, list, one result.
    if (auto answer = notebook_submissions->StudentRoute(name, role == Role::kStudent, req.method,
                                                         rest, req.body)) {
      panel::Send(*answer, res);
      return;
    }
    if (auto answer = submissions->StudentRoute(name, role == Role::kStudent, req.method, rest,
                                                req.body, restart)) {
      panel::Send(*answer, res);
      return;
    }
    if (req.method != "GET") {
      SendError(res, 405, "method " + req.method + " on a file; allowed: GET");
      return;
    }
    if (rest == "class.js" && ServeFileUnder(options.class_web_dir, "student.js", res)) return;
    if (rest == "submit.js" && ServeFileUnder(options.class_web_dir, "submit.js", res)) return;
    if (rest == "assignments.js" && ServeFileUnder(options.class_web_dir, "assignments.js", res)) {
      return;
    }
    if (rest == "class.css" && ServeFileUnder(options.class_web_dir, "class.css", res)) return;
    for (const char* library : {"three", "dygraphs"}) {
      const std::string prefix = std::string("js/") + library + "/";
      if (rest.rfind(prefix, 0) == 0 && ServeFileUnder(options.js_dir + "/" + std::string(library),
                                                       rest.substr(prefix.size()), res)) {
        return;
      }
    }
    if (rest.find('/') == std::string::npos && ServeFileUnder(options.panel_web_dir, rest, res)) {
      return;
    }
    SendError(res, 404, "no such page or file: /s/" + name + "/" + core::Printable(rest, 100));
  }

  // The token that opened `name`'s page in `req` ("" when the front signed them in).
  std::string StudentToken(const httplib::Request& req, const std::string& name) const {
    for (const std::string& token : {req.get_header_value("X-Sirupp-Token"), QueryToken(req),
                                     CookieValue(req.get_header_value("Cookie"), kStudentCookie)}) {
      if (!token.empty() && IsTokenText(token) && tokens.Check(name, token)) return token;
    }
    return "";
  }

  // /hub/api/...: the notebooks hub's questions (class/hub_api.hpp), only with its secret.
  void HubApi(const httplib::Request& req, httplib::Response& res) {
    const HubApiContext context{config,   tokens, front,
                                throttle, *rigs,  [this](const std::string& line) { Log(line); }};
    panel::Send(HubApiRoute(context, hub_secret, req.get_header_value(kHubSecretHeader), req.method,
                            req.matches[1], req.body),
                res);
  }

  // Runs a command of the real arm's queue; false after answering its refusal (409 with the
  // manager's reason, 404 for an unknown command).
  static bool TurnCommand(const std::function<void()>& command, httplib::Response& res) {
    try {
      command();
    } catch (const turns::TurnError& e) {
      SendError(res, 409, e.what());
      return false;
    } catch (const std::invalid_argument& e) {
      SendError(res, 404, e.what());
      return false;
    }
    return true;
  }

  // /s/NAME/class/turns: the real arm's queue as NAME sees it; POST .../join|leave|done|estop.
  void StudentTurns(const std::string& name, Role role, const std::string& rest,
                    const httplib::Request& req, httplib::Response& res) {
    if (!real_arm) {
      if (rest == "class/turns" && req.method == "GET") {
        SendJson(res, 200, Json{{"enabled", false}});
      } else {
        SendError(res, 404, "this class has no real arm (no real_arm: in the class file)");
      }
      return;
    }
    if (rest == "class/turns") {
      if (req.method != "GET") {
        SendError(res, 405, "class/turns: allowed: GET (POST class/turns/join|leave|done|estop)");
        return;
      }
      SendJson(res, 200, real_arm->StudentJson(name));
      return;
    }
    if (req.method != "POST") {
      SendError(res, 405, rest + ": allowed: POST");
      return;
    }
    if (MissingClient(req, res)) return;
    if (role != Role::kStudent) {
      SendError(res, 403,
                "the teacher's view of " + name +
                    "'s rig is read-only; the queue's commands are on /teacher/");
      return;
    }
    const std::string verb = rest.substr(std::string("class/turns/").size());
    if (!TurnCommand([&] { real_arm->StudentCommand(name, verb); }, res)) return;
    Log(name + ": real arm " + verb);
    SendJson(res, 200, real_arm->StudentJson(name));
  }

  void Api(const std::string& name, Role role, const std::string& rest, const httplib::Request& req,
           httplib::Response& res) {
    if (role == Role::kTeacher && IsChange(req)) {
      SendError(res, 403,
                "the teacher's view of " + name +
                    "'s rig is read-only (stop, restart and e-stop are on /teacher/)");
      return;
    }
    const RigAccess access = rigs->Access(name);
    const std::shared_ptr<RigPanel>& rig_panel = access.panel;
    const std::optional<RigEndpoint>& endpoint = access.endpoint;
    const std::string& last_stop = access.last_stop;
    const RigPhase phase = access.phase;
    const std::string& waiting = access.waiting;
    if (!rig_panel && !endpoint && (phase == RigPhase::kPending || phase == RigPhase::kUnknown)) {
      SendError(res, 503,
                name + "'s rig is " +
                    (phase == RigPhase::kPending ? "on its way"
                                                 : "not "
                                                   "known to be running") +
                    ": " + waiting);
      return;
    }
    if (!rig_panel && !endpoint) {
      SendError(res, 503,
                name + "'s rig is not running" + (last_stop.empty() ? "" : " (" + last_stop + ")") +
                    "; reload the page to start it again (your files are kept)");
      return;
    }
    if (endpoint) {
      ProxyApi(name, role, *endpoint, rest, req, res);
      return;
    }
    if (rest == "api/events") {
      if (role == Role::kStudent) {
        // Open while the stream's provider (and so this guard) lives: the rig is not idle.
        auto guard = rigs->OpenStream(name);
        auto keep = std::make_shared<std::pair<std::shared_ptr<RigPanel>, std::shared_ptr<void>>>(
            rig_panel, guard);
        panel::StreamState(*rig_panel->hub, *rig_panel->api, options.stream_hz, req, res, keep);
      } else {
        panel::StreamState(*rig_panel->hub, *rig_panel->api, options.stream_hz, req, res,
                           rig_panel);
      }
      return;
    }
    if (RefuseHardwareCommand(name, rest, req, res)) return;
    panel::Request request = panel::ToRequest(req);
    request.path = "/" + rest;
    panel::Send(rig_panel->api->Handle(request), res);
  }

  // A job's API through its endpoint: the same refusals as a local rig's, the stream passed on as
  // it comes.
  void ProxyApi(const std::string& name, Role role, const RigEndpoint& endpoint,
                const std::string& rest, const httplib::Request& req, httplib::Response& res) {
    if (rest == "api/events") {
      std::string query;
      for (const auto& [key, value] : req.params) {
        query += (query.empty() ? "?" : "&") + httplib::detail::encode_query_param(key) + "=" +
                 httplib::detail::encode_query_param(value);
      }
      std::shared_ptr<void> guard;
      if (role == Role::kStudent) guard = rigs->OpenStream(name);
      ProxyStream(endpoint, "/api/events" + query, res, guard,
                  [this, name, endpoint] { return rigs->StillAt(name, endpoint); });
      return;
    }
    if (RefuseHardwareCommand(name, rest, req, res)) return;
    ProxyRequest(endpoint, "/" + rest, req, res);
  }

  // Commands for the bridge (arm, link, ...) from anyone but the real arm's holder in their
  // turn, to a local rig or a job's: refused with the reason (they would reach no bridge anyway).
  // True when refused (the answer is sent).
  bool RefuseHardwareCommand(const std::string& name, const std::string& rest,
                             const httplib::Request& req, httplib::Response& res) {
    if (!IsChange(req) || rest.rfind("api/hardware/", 0) != 0) return false;
    const std::string why = real_arm ? real_arm->MayCommand(name)
                                     : "this class has no real arm (no real_arm: in the class "
                                       "file)";
    if (why.empty()) return false;
    SendError(res, 409, "the real arm: " + why);
    return true;
  }

  void Teacher(const httplib::Request& req, httplib::Response& res) {
    const std::string rest = req.matches[1];
    if (Authorize(req, "", res) != Role::kTeacher) return;
    if (rest.empty() || rest == "index.html") {
      if (RedirectWithCookie(req, res, kTeacher, kTeacherCookie, "/", "/teacher/")) return;
      if (!ServeFileUnder(options.class_web_dir, "teacher.html", res)) {
        SendError(res, 500, "the teacher's page is missing from " + options.class_web_dir);
      }
      return;
    }
    if (auto answer = submissions->TeacherRoute(rest)) {  // grades, class.csv, class.md
      panel::Send(*answer, res);
      return;
    }
    if (rest == "api/notebook-grades" || rest == "grades.csv") {  // notebook assignments, CSV
      if (req.method != "GET") {
        SendError(res, 405, "/teacher/" + rest + ": allowed: GET");
        return;
      }
      if (auto answer = notebook_submissions->TeacherRoute(rest, ControllerScores())) {
        panel::Send(*answer, res);
        return;
      }
    }
    if (rest == "teacher.js" || rest == "class.css" || rest == "grades.js" ||
        rest == "notebook_grades.js") {
      if (!ServeFileUnder(options.class_web_dir, rest, res)) SendError(res, 404, "no " + rest);
      return;
    }
    if (rest == "api/rigs") {
      SendJson(res, 200, ClassJson());
      return;
    }
    if (rest == "api/events") {
      TeacherEvents(res);
      return;
    }
    if (rest == "api/turns" && req.method == "GET") {
      SendJson(res, 200, real_arm ? real_arm->TeacherJson() : Json{{"enabled", false}});
      return;
    }
    if (req.method != "POST") {
      SendError(res, 404, "no such page: /teacher/" + core::Printable(rest, 100));
      return;
    }
    if (MissingClient(req, res)) return;
    if (rest == "api/estop") {
      Json body = Json::parse(req.body.empty() ? "{}" : req.body, nullptr, false);
      if (body.is_discarded() || !body.is_object()) {
        SendError(res, 400, "body: expected a JSON object like {\"engaged\": true}");
        return;
      }
      const auto engaged = body.find("engaged");
      if (engaged != body.end() && !engaged->is_boolean()) {
        SendError(res, 400, "engaged: expected true or false");
        return;
      }
      const bool engage = engaged == body.end() || engaged->get<bool>();
      Json sent = Json::array();
      for (const std::string& name : rigs->Students()) {
        const RigAccess access = rigs->Access(name);
        const std::shared_ptr<RigPanel>& rig_panel = access.panel;
        const std::optional<RigEndpoint>& endpoint = access.endpoint;
        if (!rig_panel && endpoint) {
          const int status =
              PostJson(*endpoint, "/api/estop",
                       Json{{"engaged", engage},
                            {"who", "teacher"},
                            {"reason", engage ? "class e-stop" : "class e-stop released"}},
                       5);
          if (status == 200) sent.push_back(name);
          continue;
        }
        if (!rig_panel) continue;
        panel::RigCommands commands(*rig_panel->hub);
        commands.Estop(engage, "teacher", engage ? "class e-stop" : "class e-stop released");
        sent.push_back(name);
      }
      Log(std::string("teacher ") + (engage ? "engaged" : "released") + " the e-stop of " +
          std::to_string(sent.size()) + " rig(s)");
      SendJson(res, 200, Json{{"engaged", engage}, {"rigs", sent}});
      return;
    }
    if (rest.rfind("api/turns/", 0) == 0) {
      TeacherTurns(rest.substr(std::string("api/turns/").size()), req, res);
      return;
    }
    static const std::regex kRigVerb(R"(api/rigs/([^/]+)/(stop|restart|start))");
    std::smatch match;
    if (std::regex_match(rest, match, kRigVerb)) {
      const std::string name = match[1].str();
      if (!rigs->Has(name)) {
        SendError(res, 404,
                  "no student '" + core::Printable(match[1].str(), 40) + "' in this class");
        return;
      }
      const std::string verb = match[2];
      if (verb != "start") {
        rigs->Stop(name, verb == "stop" ? "stopped by the teacher" : "restarted by the teacher");
      }
      std::string why;
      if (verb != "stop") why = rigs->Ensure(name);
      if (why.empty()) {
        SendJson(res, 200, rigs->SeatJson(name, false));
      } else {
        SendError(res, 503, why);
      }
      return;
    }
    SendError(res, 404, "no such command: /teacher/" + core::Printable(rest, 100));
  }

  // POST /teacher/api/turns/end|pause|resume|estop|release, and skip {"student": NAME}.
  void TeacherTurns(const std::string& verb, const httplib::Request& req, httplib::Response& res) {
    if (!real_arm) {
      SendError(res, 404, "this class has no real arm (no real_arm: in the class file)");
      return;
    }
    std::string student;
    if (verb == "skip") {
      const Json body = Json::parse(req.body.empty() ? "{}" : req.body, nullptr, false);
      if (!body.is_object() || !body.contains("student") || !body["student"].is_string()) {
        SendError(res, 400, "skip: expected a JSON body like {\"student\": \"alice\"}");
        return;
      }
      student = body["student"].get<std::string>();
    }
    if (!TurnCommand([&] { real_arm->TeacherCommand(verb, student); }, res)) return;
    Log("teacher: real arm " + verb + (student.empty() ? "" : " " + student));
    SendJson(res, 200, real_arm->TeacherJson());
  }

  // One stream for the whole class, twice a second.
  void TeacherEvents(httplib::Response& res) {
    res.set_header("Cache-Control", "no-store");
    res.set_header("X-Accel-Buffering", "no");
    auto next = std::make_shared<Clock::time_point>(Clock::now());
    res.set_chunked_content_provider(
        "text/event-stream", [this, next](size_t, httplib::DataSink& sink) {
          std::this_thread::sleep_until(*next);
          *next = std::max(*next + std::chrono::milliseconds(500), Clock::now());
          if (rigs->Stopping()) {
            sink.done();
            return true;
          }
          const std::string frame = "data: " + ClassJson().dump() + "\n\n";
          return sink.write(frame.data(), frame.size());
        });
  }

  // POST /cluster/report from a rig job: its endpoint, with its secret (not a student's token).
  void Report(const httplib::Request& req, httplib::Response& res) {
    Json body = Json::parse(req.body, nullptr, false);
    if (!body.is_object() || !body.contains("student") || !body["student"].is_string() ||
        !body.contains("host") || !body["host"].is_string() || !body.contains("port") ||
        !body["port"].is_number_integer()) {
      SendError(res, 400, "expected {\"student\", \"job\", \"host\", \"port\", \"udpm_port\"}");
      return;
    }
    const std::string job_id =
        body.contains("job") && body["job"].is_string() ? body["job"].get<std::string>() : "";
    // The rig's bus on its node, where a notebook server beside it joins (docs/notebooks.md).
    // A job that does not say (older than it) is taken; its notebooks say why they cannot start.
    int udpm_port = 0;
    if (body.contains("udpm_port")) {
      const Json& value = body["udpm_port"];
      if (!value.is_number_integer() || value.get<int64_t>() < 1 || value.get<int64_t>() > 65535) {
        SendError(
            res, 400,
            "udpm_port: expected a port from 1 to 65535, got " + core::Printable(value.dump(), 40));
        return;
      }
      udpm_port = value.get<int>();
    }
    if (!rigs->Reported(body["student"].get<std::string>(), req.get_header_value(kRigSecretHeader),
                        job_id, body["host"].get<std::string>(), body["port"].get<int>(),
                        udpm_port)) {
      Log("refused a rig report from " + req.remote_addr);
      SendError(res, 403, "not a rig of this class waiting for its report");
      return;
    }
    SendJson(res, 200, Json{{"ok", true}});
  }

  void Routes() {
    server->set_payload_max_length(1024 * 1024);
    server->set_keep_alive_max_count(1000);
    server->set_default_headers(
        {{"X-Content-Type-Options", "nosniff"}, {"Referrer-Policy", "no-referrer"}});
    server->Get("/", [this](const httplib::Request&, httplib::Response& res) {
      SendHtmlMessage(res, 200, "SIRUPP class " + config.name,
                      "Open the address with your token that your teacher gave you.");
    });
    const auto student = [this](const httplib::Request& req, httplib::Response& res) {
      Student(req, res);
    };
    const std::string student_path = R"(/s/([^/]+)/(.*))";
    server->Get(student_path, student);
    server->Post(student_path, student);
    server->Get(R"(/s/([^/]+))", [](const httplib::Request& req, httplib::Response& res) {
      const std::string token = QueryToken(req);
      res.set_redirect(
          req.path + "/" + (IsTokenText(token) && !token.empty() ? "?token=" + token : ""), 303);
    });
    const auto teacher = [this](const httplib::Request& req, httplib::Response& res) {
      Teacher(req, res);
    };
    server->Post(kRigReportPath,
                 [this](const httplib::Request& req, httplib::Response& res) { Report(req, res); });
    if (!hub_secret.empty()) {
      const auto hub = [this](const httplib::Request& req, httplib::Response& res) {
        HubApi(req, res);
      };
      server->Get(R"(/hub/api/(.*))", hub);
      server->Post(R"(/hub/api/(.*))", hub);
    }
    server->Get(R"(/teacher/(.*))", teacher);
    server->Post(R"(/teacher/(.*))", teacher);
    server->set_error_handler([](const httplib::Request& req, httplib::Response& res) {
      if (res.body.empty() && res.status == 413) {
        // httplib's own limits: 1 MiB for a body, 8 KiB for one sent as a form
        // (application/x-www-form-urlencoded, what a client sends when it names no type).
        SendError(res, 413,
                  core::Printable(req.path, 100) +
                      ": the request's body is too large: allowed at most 1 MiB (8 KiB as a form; "
                      "send a notebook as application/json)");
      } else if (res.body.empty()) {
        SendError(res, res.status == 200 ? 404 : res.status,
                  "no such page: " + core::Printable(req.path, 100));
      }
    });
    panel::AnswerExceptionsWith500(*server);
  }
};

ClassServer::ClassServer(ClassConfig config, ServeOptions options)
    : impl_(std::make_unique<Impl>(std::move(config), std::move(options))) {
  impl_->Routes();
}

ClassServer::~ClassServer() { Stop(); }

int ClassServer::Bind() {
  impl_->port = panel::BindServer(*impl_->server, impl_->config.listen, impl_->config.port);
  impl_->server->WidenBacklog(256);
  impl_->rigs->SetServerPort(impl_->port);
  return impl_->port;
}

void ClassServer::Serve() {
  // The rig pool's monitor; none after a Stop() that came first, and then no serving either.
  if (!impl_->rigs->StartMonitor()) return;
  impl_->gate.Listen(*impl_->server);
}

void ClassServer::Stop() {
  if (!impl_) return;
  impl_->rigs->BeginStop();  // no rig starts from now on; the monitor ends
  if (impl_->real_arm) impl_->real_arm->Stop();
  impl_->submissions->Stop();
  impl_->notebook_submissions->Stop();
  impl_->rigs->StopAll("the class server stopped");
  impl_->gate.Stop(*impl_->server);
}

}  // namespace sirupp::classroom
