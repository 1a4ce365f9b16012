#include "class/class_server.hpp"

#include <sched.h>

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <ctime>
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
#include "class/real_arm.hpp"
#include "class/rig.hpp"
#include "class/rig_job.hpp"
#include "class/rig_proxy.hpp"
#include "class/rig_spawner.hpp"
#include "class/submissions.hpp"
#include "class/tokens.hpp"
#include "cluster/slurm_engine.hpp"
#include "core/errors.hpp"
#include "core/printable.hpp"
#include "grade/port_lease.hpp"
#include "panel/http_glue.hpp"
#include "panel/rig_commands.hpp"
#include "proc/udpm_listen.hpp"
#include "runtime/data_path.hpp"

namespace sirupp::classroom {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
using Json = nlohmann::json;

constexpr const char* kStudentCookie = "sirupp_student";
constexpr const char* kTeacherCookie = "sirupp_teacher";
// How long a rig's port must be silent before a rig starts on it: every SIRUPP process sends a
// heartbeat each second.
constexpr double kQuietListenS = 1.2;

int64_t NowNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now().time_since_epoch())
      .count();
}

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

}  // namespace

std::string TokensFile(const ClassConfig& config) { return config.data_dir + "/tokens.json"; }
std::string HandoutFile(const ClassConfig& config) { return config.data_dir + "/tokens.csv"; }
std::string StudentFolder(const ClassConfig& config, const std::string& name) {
  return config.data_dir + "/students/" + name;
}

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

// One student's place in the class: their rig when it runs, and what the pages show about it.
struct Seat {
  std::string name;
  std::mutex mutex;  // held while the rig starts or stops
  // Where the rig runs (class/rig_spawner.hpp): the server's own processes, or a cluster job.
  std::unique_ptr<RigSpawner> rig;
  // Read by the pages; written under `mutex` and `info_mutex`.
  mutable std::mutex info_mutex;
  // stopped, starting, running, failed; a cluster job also pending (waiting for the cluster or
  // starting on its node) and unknown (the cluster did not say; never read as stopped)
  std::string state = "stopped";
  std::string last_stop;                // why the rig last stopped ("" = never ran in this server)
  std::string waiting;                  // pending or unknown: why
  std::string where;                    // "udpm port 7910", "Slurm job 12 on node07"
  std::shared_ptr<RigPanel> panel;      // a local rig's panel
  std::optional<RigEndpoint> endpoint;  // a job's endpoint, once it reported
  Json remote_state;                    // a job's live state, fetched by the monitor
  std::string lcm_url;                  // a local rig's bus ("" for a job)
  std::chrono::steady_clock::time_point submitted{};
  std::chrono::steady_clock::time_point next_poll{};
  int starts = 0;
  double start_s = 0;
  double cpu = 0;
  // The CPU the rig's processes run on (limits.pin_rigs), else -1; counted under start_mutex.
  std::atomic<int> on_cpu{-1};
  int port = 0;
  std::string started_at;  // wall clock
  std::atomic<int64_t> activity_ns{0};
  std::atomic<int> streams{0};  // the student's open event streams (activity while open)

  void Touch() { activity_ns = NowNs(); }
  double IdleSeconds() const {
    if (streams > 0) return 0;
    return static_cast<double>(NowNs() - activity_ns.load()) / 1e9;
  }
};

struct ClassServer::Impl {
  ClassConfig config;
  ServeOptions options;
  TokenStore tokens;
  BadTokenThrottle throttle;
  FrontAuth front;  // server.trusted_proxy: sign-in by the university's front (front_auth.hpp)
  ProcessLauncher launcher;  // outlives the rigs
  // Students' controllers from the browser: store, builds, the grading worker (after the launcher,
  // so it ends first).
  std::unique_ptr<SubmissionService> submissions;
  std::map<std::string, std::unique_ptr<Seat>> seats;
  // cluster: the engine the rigs run on as jobs (class/rig_spawner.hpp), the jobs whose scancel
  // got no answer (tried again each second), and the file a restarted server finds them in.
  cluster::SystemRunner cluster_runner;
  std::unique_ptr<cluster::SlurmEngine> engine;
  std::mutex jobs_mutex;
  std::vector<std::string> cancel_later;
  std::atomic<int> running{0};
  std::mutex start_mutex;  // counts rigs against max_rigs
  // limits.pin_rigs: the CPUs this server may use (its affinity when it starts) and how many
  // rigs run on each; under start_mutex. Empty: nothing is pinned.
  std::vector<int> cpus;
  std::vector<int> rigs_on_cpu;
  std::thread monitor;
  std::mutex monitor_mutex;
  std::condition_variable monitor_wake;
  bool stopping = false;
  int port = 0;
  std::mutex log_mutex;
  // The real arm's queue (class file real_arm:), or none. After the seats: it asks them for the
  // rigs' addresses, so it goes first.
  std::unique_ptr<RealArm> real_arm;
  // Last: destroyed first, so no request runs once the seats are gone. HTTPS with a certificate
  // (Debian's cpp-httplib is built with OpenSSL).
  std::unique_ptr<httplib::Server> server;
  panel::ListenGate gate;

  Impl(ClassConfig c, ServeOptions o)
      : config(std::move(c)), options(std::move(o)), tokens(TokensFile(config)) {
    if (config.front) front = FrontAuth(*config.front);
    if (config.tls_cert.empty()) {
      server = std::make_unique<httplib::Server>();
    } else {
      auto tls =
          std::make_unique<httplib::SSLServer>(config.tls_cert.c_str(), config.tls_key.c_str());
      if (!tls->is_valid()) {
        throw std::runtime_error("cannot use the certificate " + config.tls_cert + " with key " +
                                 config.tls_key + " (unreadable, or not a matching PEM pair)");
      }
      server = std::move(tls);
    }
    SubmissionOptions submission_options;
    submission_options.bin_dir = options.bin_dir;
    submission_options.include_dir =
        fs::path(runtime::ResolveDataPath("include/sirupp/controller.h"))
            .parent_path()
            .parent_path()
            .string();
    submissions = std::make_unique<SubmissionService>(
        config, submission_options, launcher, [this](const std::string& line) { Log(line); });
    cpu_set_t allowed;
    CPU_ZERO(&allowed);
    if (config.pin_rigs && ::sched_getaffinity(0, sizeof allowed, &allowed) == 0) {
      for (int cpu = 0; cpu < CPU_SETSIZE; ++cpu) {
        if (CPU_ISSET(cpu, &allowed)) cpus.push_back(cpu);
      }
      rigs_on_cpu.assign(cpus.size(), 0);
    }
    for (const std::string& name : config.students) {
      auto seat = std::make_unique<Seat>();
      seat->name = name;
      seat->Touch();
      seats[name] = std::move(seat);
    }
    if (config.cluster) {
      cluster::SlurmOptions slurm;
      slurm.command_timeout_s = config.cluster->command_timeout_s;
      engine = std::make_unique<cluster::SlurmEngine>(cluster_runner, slurm);
      Reattach();
    }
    if (config.real_arm) {
      fs::create_directories(config.data_dir);
      real_arm = std::make_unique<RealArm>(
          config, TurnsLogFile(config),
          [this](const std::string& student) -> std::string {
            const Seat* seat = Find(student);
            if (seat == nullptr) return "";
            const std::lock_guard<std::mutex> info(seat->info_mutex);
            return seat->state == "running" ? seat->lcm_url : "";
          },
          [this](const std::string& line) { Log("real arm: " + line); });
      // Only a controller that passed the class's safety tasks in simulation drives the real arm
      // (a rig that switches controller restarts, which ends its place in the queue).
      real_arm->SetAdmit([this](const std::string& student) {
        const std::optional<std::string> why = submissions->RealArmRefusal(student);
        return why ? *why : std::string();
      });
    }
  }

  void Log(const std::string& line) {
    if (options.log == nullptr) return;
    const std::lock_guard<std::mutex> lock(log_mutex);
    *options.log << "sirupp class: " << line << std::endl;
  }

  Seat* Find(const std::string& name) {
    const auto found = seats.find(name);
    return found == seats.end() ? nullptr : found->second.get();
  }

  // --- tokens -----------------------------------------------------------------------------------

  // Who the request's token makes its sender for /s/NAME/ (student = NAME only), or for /teacher/
  // (student_name empty). Fills `res` (403 or 429) and returns kNone when nobody.
  Role Authorize(const httplib::Request& req, const std::string& student_name,
                 httplib::Response& res) {
    // Behind the class's front, the throttle and the log name the client the front saw.
    const std::string client =
        front.ClientAddress(req.remote_addr, req.get_header_value("X-Forwarded-For"));
    const double wait = throttle.WaitFor(client, Clock::now());
    if (wait > 0) {
      const int seconds = static_cast<int>(wait) + 1;
      res.set_header("Retry-After", std::to_string(seconds));
      SendError(res, 429,
                "too many bad tokens from " + client + "; try again in " + std::to_string(seconds) +
                    " s");
      return Role::kNone;
    }
    const FrontVerdict verdict = front.Judge(
        req.remote_addr, [&req](const std::string& name) { return req.get_header_value(name); });
    if (verdict.kind != FrontVerdict::Kind::kNoFront) {
      return AuthorizeFront(verdict, client, student_name, res);
    }
    std::vector<std::string> offered;
    for (const std::string& token :
         {req.get_header_value("X-Sirupp-Token"), req.get_param_value("token"),
          CookieValue(req.get_header_value("Cookie"), kStudentCookie),
          CookieValue(req.get_header_value("Cookie"), kTeacherCookie)}) {
      if (!token.empty()) offered.push_back(token);
    }
    for (const std::string& token : offered) {
      if (!student_name.empty() && Find(student_name) != nullptr &&
          tokens.Check(student_name, token)) {
        throttle.Succeeded(client);
        return Role::kStudent;
      }
      if (tokens.Check(kTeacher, token)) {
        throttle.Succeeded(client);
        return Role::kTeacher;
      }
    }
    const std::string where =
        student_name.empty() ? "/teacher/" : "/s/" + core::Printable(student_name, 40) + "/";
    if (offered.empty()) {
      SendError(
          res, 403,
          "no token: open the address with ?token=... that your teacher gave you (" + where + ")");
    } else {
      throttle.Failed(client, Clock::now());
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

  // --- rigs -------------------------------------------------------------------------------------

  // A new student's folder gets a copy of config/ (what the panel's file lists show and where a
  // saved model goes). The class's robot model is copied into it at every start, so the rig runs
  // a file the student's panel may read. Returns the rig's model file.
  std::string PrepareFolder(const std::string& folder) {
    if (!fs::exists(folder + "/config")) {
      fs::create_directories(folder);
      fs::copy(options.config_dir, folder + "/config", fs::copy_options::recursive);
    }
    fs::create_directories(folder + "/config/robots");
    const std::string model =
        folder + "/config/robots/" + fs::path(config.robot).filename().string();
    if (fs::absolute(model).lexically_normal() != fs::path(config.robot)) {
      fs::copy_file(config.robot, model, fs::copy_options::overwrite_existing);
    }
    return model;
  }

  // Counts a rig in against max_rigs (and, for a `local` seat, picks its CPU), or says why not: the
  // server is stopping or the class runs its limit. The caller gives the place back (--running)
  // when the start fails.
  std::string TakeRigPlace(Seat* local) {
    {
      const std::lock_guard<std::mutex> stop_lock(monitor_mutex);
      if (stopping) return "the class server is stopping";
    }
    const std::lock_guard<std::mutex> count_lock(start_mutex);
    if (running >= config.max_rigs) {
      return "the class server already runs its limit of " + std::to_string(config.max_rigs) +
             " rigs; try again in a few minutes (idle rigs stop after " +
             std::to_string(static_cast<int>(config.idle_timeout_s)) + " s)";
    }
    ++running;
    if (local != nullptr) local->on_cpu = PickCpu();
    return "";
  }

  // Starts the seat's rig unless it runs. Returns "" or why it cannot (for a 503).
  std::string EnsureRig(Seat& seat) {
    const std::lock_guard<std::mutex> lock(seat.mutex);
    if (seat.rig) return "";
    if (config.cluster) return StartJob(seat);
    if (std::string why = TakeRigPlace(&seat); !why.empty()) return why;
    try {
      grade::PortLease lease = LeaseQuietPort();
      const std::string folder = StudentFolder(config, seat.name);
      RigSpec spec;
      spec.robot = PrepareFolder(folder);
      spec.student = seat.name;
      spec.bin_dir = options.bin_dir;
      spec.folder = folder;
      spec.port = lease.port();
      spec.limits = ChildLimits{config.rig_nice, config.rig_memory_mb, seat.on_cpu.load()};
      spec.pace_ticks = config.pace_ticks;
      spec.controller = submissions->RigController(seat.name);
      {
        const std::lock_guard<std::mutex> info(seat.info_mutex);
        seat.state = "starting";
      }
      auto rig = std::make_unique<LocalRigSpawner>(spec, launcher, std::move(lease));
      rig->Start();
      const std::lock_guard<std::mutex> info(seat.info_mutex);
      seat.panel = rig->panel();
      seat.lcm_url = rig->lcm_url();
      seat.where = rig->Where();
      seat.start_s = rig->start_seconds();
      seat.port = spec.port;
      seat.state = "running";
      ++seat.starts;
      seat.started_at = WallClock();
      seat.rig = std::move(rig);
      seat.Touch();
      Log("started " + seat.name + "'s rig on " + RigUrl(spec.port) +
          (spec.limits.cpu >= 0 ? " (CPU " + std::to_string(spec.limits.cpu) + ")" : "") + " in " +
          std::to_string(seat.start_s).substr(0, 4) + " s");
      return "";
    } catch (const std::exception& e) {
      ReleaseCpu(seat);
      --running;
      const std::lock_guard<std::mutex> info(seat.info_mutex);
      seat.state = "failed";
      seat.last_stop = std::string("could not start: ") + e.what();
      Log(seat.name + "'s rig could not start: " + e.what());
      return seat.last_stop;
    }
  }

  // A port of the rigs' range that no other class server or grader holds (grade::PortLease) and
  // on which nothing is heard: LCM shares its port, so another program on it (a lab's `sirupp
  // launch`, a test's rig, a rig that did not end) would talk on the student's bus. Ports where
  // something talks are held while the next is tried, then given back; at most kQuietTries.
  grade::PortLease LeaseQuietPort() {
    constexpr int kQuietTries = 8;
    std::vector<grade::PortLease> busy;
    std::string heard;
    const int offset = static_cast<int>(NowNs() % config.port_count);
    for (int k = 0; k < std::min(kQuietTries, config.port_count); ++k) {
      grade::PortLease lease;
      try {
        lease = grade::PortLease::Acquire(config.first_port, config.port_count, offset + k);
      } catch (const std::exception&) {
        if (busy.empty()) throw;
        break;  // the rest are held by others
      }
      const std::string talk = proc::HeardOnUdpm(proc::kRigGroup, lease.port(), kQuietListenS);
      if (talk.empty()) return lease;
      Log("udpm port " + std::to_string(lease.port()) + " skipped: something else talks on it (" +
          talk + ")");
      heard = talk;
      busy.push_back(std::move(lease));
    }
    throw std::runtime_error(
        "no quiet udpm port for a rig in " + std::to_string(config.first_port) + ".." +
        std::to_string(config.first_port + config.port_count - 1) + ": " +
        std::to_string(busy.size()) + " tried, something else talks on each (" + heard + ")");
  }

  // Stops the seat's rig (if any), saying why. `locked`: the caller holds seat.mutex.
  void StopRig(Seat& seat, const std::string& why, bool failed = false) {
    std::unique_ptr<RigSpawner> rig;
    {
      const std::lock_guard<std::mutex> info(seat.info_mutex);
      if (!seat.rig) return;
      rig = std::move(seat.rig);
      seat.panel.reset();
      seat.endpoint.reset();
      seat.remote_state = nullptr;
      seat.lcm_url.clear();
      seat.waiting.clear();
      seat.state = failed ? "failed" : "stopped";
      seat.last_stop = why;
      seat.cpu = 0;
    }
    if (real_arm) real_arm->RigStopped(seat.name, why);
    const std::string not_stopped = rig->Stop();
    if (!not_stopped.empty()) {
      // The engine did not answer: the job may still run. Cancelled again each second (and
      // after a restart: the list is saved) until the engine takes it.
      const nlohmann::json state = rig->State();
      const std::lock_guard<std::mutex> jobs(jobs_mutex);
      const auto job = state.is_object() ? state.find("job") : state.end();
      if (job != state.end() && job->is_string()) cancel_later.push_back(job->get<std::string>());
      Log(seat.name + "'s rig job: " + not_stopped + "; cancelled again until it is taken");
    }
    rig.reset();
    ReleaseCpu(seat);
    --running;
    SaveJobs();
    Log("stopped " + seat.name + "'s rig: " + why);
  }

  // --- rigs as cluster jobs (class file cluster:) -----------------------------------------------

  static std::string WallClock() {
    const std::time_t now = std::time(nullptr);
    std::tm local{};
    localtime_r(&now, &local);
    char text[16];
    std::strftime(text, sizeof text, "%H:%M:%S", &local);
    return text;
  }

  std::string JobsFile() const { return config.data_dir + "/cluster/rigs.json"; }

  // The class's data folder as the nodes see it.
  std::string NodeData() const {
    return config.cluster->node_data.empty() ? config.data_dir : config.cluster->node_data;
  }
  // A path under the data folder, as the nodes see it.
  std::string OnNodes(const std::string& path) const {
    if (path.rfind(config.data_dir + "/", 0) != 0) return path;
    return NodeData() + path.substr(config.data_dir.size());
  }

  // Saves every job's state (and the cancels still owed), so a restarted server reattaches.
  void SaveJobs() {
    if (!config.cluster) return;
    SavedRigJobs saved;
    for (auto& [name, seat] : seats) {
      const std::lock_guard<std::mutex> info(seat->info_mutex);
      if (!seat->rig) continue;
      const nlohmann::json state = seat->rig->State();
      if (!state.is_null()) saved.rigs.push_back(state);
    }
    {
      const std::lock_guard<std::mutex> jobs(jobs_mutex);
      saved.cancel = cancel_later;
    }
    try {
      SaveRigJobs(JobsFile(), saved);
    } catch (const std::exception& e) {
      Log(std::string("cannot save the rig jobs: ") + e.what());
    }
  }

  // Submits the seat's rig as a job; it is pending until the job reports its endpoint. Holds
  // seat.mutex. Returns "" or why it cannot.
  std::string StartJob(Seat& seat) {
    if (std::string why = TakeRigPlace(nullptr); !why.empty()) return why;
    try {
      const std::string folder = StudentFolder(config, seat.name);
      const std::string model = PrepareFolder(folder);
      fs::create_directories(folder + "/logs");
      fs::create_directories(folder + "/results");
      RigJobSpec spec;
      spec.student = seat.name;
      spec.folder = OnNodes(folder);
      spec.robot = OnNodes(model);
      spec.bin_dir = options.bin_dir;
      const std::string secret_file = config.data_dir + "/cluster/secrets/" + seat.name;
      spec.secret_file = OnNodes(secret_file);
      spec.report_url =
          config.cluster->report_url.empty() ? BaseUrl(config, port) : config.cluster->report_url;
      spec.controller = OnNodes(submissions->RigController(seat.name));
      spec.pace_ticks = config.pace_ticks;
      spec.memory_mb = config.rig_memory_mb;
      auto rig =
          std::make_unique<SlurmRigSpawner>(*engine, *config.cluster, spec, secret_file, folder);
      {
        const std::lock_guard<std::mutex> info(seat.info_mutex);
        seat.state = "starting";
      }
      rig->Start();
      {
        const std::lock_guard<std::mutex> info(seat.info_mutex);
        seat.state = "pending";
        seat.waiting = "submitted to the cluster";
        seat.where = rig->Where();
        seat.submitted = Clock::now();
        seat.next_poll = Clock::now();
        seat.rig = std::move(rig);
      }
      seat.Touch();
      SaveJobs();
      Log("submitted " + seat.name + "'s rig as " + seat.where);
      return "";
    } catch (const std::exception& e) {
      --running;
      const std::lock_guard<std::mutex> info(seat.info_mutex);
      seat.state = "failed";
      seat.last_stop = std::string("could not start: ") + e.what();
      Log(seat.name + "'s rig could not start: " + e.what());
      return seat.last_stop;
    }
  }

  // The rig jobs a previous server left (DATA/cluster/rigs.json): each seat takes its job back
  // as it was (running at its endpoint, or pending); the monitor's first poll says what became of
  // it. No job is started twice, none is left without a seat.
  void Reattach() {
    SavedRigJobs saved;
    try {
      saved = LoadRigJobs(JobsFile());
    } catch (const std::exception& e) {
      Log(std::string("the saved rig jobs are not readable (") + e.what() + "); none reattached");
      return;
    }
    cancel_later = saved.cancel;
    for (const nlohmann::json& state : saved.rigs) {
      const auto named = state.is_object() ? state.find("student") : state.end();
      const std::string student =
          named != state.end() && named->is_string() ? named->get<std::string>() : "";
      Seat* seat = Find(student);
      std::unique_ptr<SlurmRigSpawner> rig;
      try {
        rig = std::make_unique<SlurmRigSpawner>(*engine, *config.cluster, state,
                                                StudentFolder(config, student));
      } catch (const std::exception& e) {
        Log(std::string("a saved rig job is not readable: ") + e.what());
        continue;
      }
      if (seat == nullptr || seat->rig) {  // no longer in the class, or twice: end it
        cancel_later.push_back(rig->job_id());
        continue;
      }
      ++running;
      seat->endpoint = rig->endpoint();
      seat->state = seat->endpoint ? "running" : "pending";
      seat->waiting = seat->endpoint ? "" : "reattached after a restart of the class server";
      seat->where = rig->Where();
      seat->started_at = WallClock();
      seat->next_poll = Clock::now();
      seat->rig = std::move(rig);
      Log("reattached " + student + "'s rig, " + seat->where);
    }
  }

  // POST /cluster/report from a rig job: its endpoint, with its secret (not a student's token).
  void Report(const httplib::Request& req, httplib::Response& res) {
    Json body = Json::parse(req.body, nullptr, false);
    if (!body.is_object() || !body.contains("student") || !body["student"].is_string() ||
        !body.contains("host") || !body["host"].is_string() || !body.contains("port") ||
        !body["port"].is_number_integer()) {
      SendError(res, 400, "expected {\"student\", \"job\", \"host\", \"port\"}");
      return;
    }
    Seat* seat = config.cluster ? Find(body["student"].get<std::string>()) : nullptr;
    bool taken = false;
    if (seat != nullptr) {
      const std::lock_guard<std::mutex> lock(seat->mutex);
      auto* job = dynamic_cast<SlurmRigSpawner*>(seat->rig.get());
      const std::string job_id =
          body.contains("job") && body["job"].is_string() ? body["job"].get<std::string>() : "";
      if (job != nullptr &&
          job->Reported(req.get_header_value(kRigSecretHeader), job_id,
                        body["host"].get<std::string>(), body["port"].get<int>())) {
        const std::lock_guard<std::mutex> info(seat->info_mutex);
        seat->endpoint = job->endpoint();
        seat->state = "running";
        seat->waiting.clear();
        seat->where = job->Where();
        seat->start_s = std::chrono::duration<double>(Clock::now() - seat->submitted).count();
        seat->started_at = WallClock();
        ++seat->starts;
        taken = true;
      }
    }
    if (!taken) {
      Log("refused a rig report from " + req.remote_addr);
      SendError(res, 403, "not a rig of this class waiting for its report");
      return;
    }
    SaveJobs();
    Log(seat->name + "'s rig job is ready at " + seat->endpoint->Address() + ", " +
        std::to_string(seat->start_s).substr(0, 4) + " s after it was submitted");
    SendJson(res, 200, Json{{"ok", true}});
  }

  // The allowed CPU with the fewest rigs (the lowest of equals), counted for the seat; -1 when
  // nothing is pinned. Under start_mutex.
  int PickCpu() {
    if (cpus.size() < 2) return -1;
    const size_t least = static_cast<size_t>(
        std::min_element(rigs_on_cpu.begin(), rigs_on_cpu.end()) - rigs_on_cpu.begin());
    ++rigs_on_cpu[least];
    return cpus[least];
  }

  void ReleaseCpu(Seat& seat) {
    const std::lock_guard<std::mutex> count_lock(start_mutex);
    const int cpu = seat.on_cpu.exchange(-1);
    if (cpu < 0) return;
    const auto at = std::find(cpus.begin(), cpus.end(), cpu);
    if (at != cpus.end()) --rigs_on_cpu[static_cast<size_t>(at - cpus.begin())];
  }

  void Monitor() {
    std::unique_lock<std::mutex> lock(monitor_mutex);
    while (!stopping) {
      monitor_wake.wait_for(lock, std::chrono::seconds(1));
      if (stopping) break;
      lock.unlock();
      RetryCancels();
      for (auto& [name, seat] : seats) {
        std::unique_lock<std::mutex> seat_lock(seat->mutex, std::try_to_lock);
        if (!seat_lock.owns_lock() || !seat->rig) continue;
        const bool runs = PollRig(*seat);
        if (!seat->rig) continue;  // it ended
        if (runs) {
          const double cpu = seat->rig->CpuPercent();
          const std::lock_guard<std::mutex> info(seat->info_mutex);
          seat->cpu = cpu;
        }
        // A job waiting for the cluster is idle too when nobody asks for it (its place goes).
        if (seat->IdleSeconds() > config.idle_timeout_s &&
            !(real_arm && real_arm->Involved(name))) {  // waiting for the real arm is not idle
          StopRig(*seat, "stopped after " +
                             std::to_string(static_cast<int>(config.idle_timeout_s)) +
                             " s without a visit (idle)");
        }
      }
      lock.lock();
    }
  }

  // Asks the seat's rig where it is (a job: at most every cluster.poll_s) and acts on it: ended ->
  // stopped with the reason; pending or unknown -> shown with why. False when it is not running.
  // A running job's live state is fetched for the teacher's page. Holds seat.mutex.
  bool PollRig(Seat& seat) {
    const bool job = seat.rig->panel() == nullptr;
    if (job && Clock::now() < seat.next_poll) {
      if (seat.endpoint) FetchRemoteState(seat);
      return seat.endpoint.has_value();
    }
    if (job) {
      seat.next_poll =
          Clock::now() + std::chrono::milliseconds(static_cast<int>(config.cluster->poll_s * 1000));
    }
    const RigStatus status = seat.rig->Poll();
    if (status.phase == RigPhase::kEnded) {
      StopRig(seat, status.reason, true);
      return false;
    }
    {
      const std::lock_guard<std::mutex> info(seat.info_mutex);
      if (status.phase == RigPhase::kPending || status.phase == RigPhase::kUnknown) {
        seat.state = status.phase == RigPhase::kPending && !seat.endpoint ? "pending" : "unknown";
        if (status.phase == RigPhase::kPending && seat.endpoint) seat.state = "running";
        seat.waiting = status.reason;
      } else if (seat.state != "running" && (!job || seat.endpoint)) {
        seat.state = "running";
        seat.waiting.clear();
      }
      seat.where = seat.rig->Where();
    }
    if (job && seat.endpoint) FetchRemoteState(seat);
    return status.phase == RigPhase::kRunning;
  }

  void FetchRemoteState(Seat& seat) {
    const std::optional<Json> state = FetchJson(*seat.endpoint, "/api/state", 1.0);
    const std::lock_guard<std::mutex> info(seat.info_mutex);
    seat.remote_state = state ? *state : Json();
  }

  // Cancels whose engine did not answer before, again.
  void RetryCancels() {
    std::vector<std::string> owed;
    {
      const std::lock_guard<std::mutex> jobs(jobs_mutex);
      owed.swap(cancel_later);
    }
    if (owed.empty() || !engine) return;
    std::vector<std::string> still;
    for (const std::string& id : owed) {
      const std::string error = engine->Cancel(id);
      if (!error.empty()) still.push_back(id);
    }
    {
      const std::lock_guard<std::mutex> jobs(jobs_mutex);
      cancel_later.insert(cancel_later.end(), still.begin(), still.end());
    }
    if (still.size() != owed.size()) SaveJobs();
  }

  // --- what the pages are told -----------------------------------------------------------------

  Json SeatJson(const Seat& seat, bool live) const {
    std::shared_ptr<RigPanel> rig_panel;
    Json out;
    Json remote;
    {
      const std::lock_guard<std::mutex> info(seat.info_mutex);
      rig_panel = seat.panel;
      remote = seat.remote_state;
      out = Json{{"name", seat.name},
                 {"state", seat.state},
                 {"waiting", seat.waiting},
                 {"where", seat.where},
                 {"starts", seat.starts},
                 {"start_s", seat.start_s},
                 {"last_stop", seat.last_stop},
                 {"cpu_percent", seat.cpu},
                 {"on_cpu", seat.on_cpu.load()},
                 {"port", seat.port},
                 {"started_at", seat.started_at},
                 {"idle_s", seat.IdleSeconds()},
                 {"streams", seat.streams.load()}};
    }
    if (live && rig_panel) {
      const Json state = rig_panel->hub->StateJson();
      if (state.contains("controller")) out["controller"] = state["controller"];
      if (state.contains("sim")) out["sim"] = state["sim"];
      if (state.contains("estop")) out["estop"] = state["estop"];
      if (state.contains("virtual")) out["q"] = state["virtual"]["q"];
      out["lock"] = rig_panel->api->LockHolder();
    }
    if (live && !rig_panel && remote.is_object()) {  // a job's, as the monitor last fetched it
      for (const char* key : {"controller", "sim", "estop"}) {
        if (remote.contains(key)) out[key] = remote[key];
      }
      if (remote.contains("virtual") && remote["virtual"].contains("q")) {
        out["q"] = remote["virtual"]["q"];
      }
    }
    return out;
  }

  Json ClassJson() const {
    Json rigs = Json::array();
    for (const auto& [name, seat] : seats) rigs.push_back(SeatJson(*seat, true));
    return Json{{"class", config.name},
                {"description", config.description},
                {"max_rigs", config.max_rigs},
                {"running", running.load()},
                {"idle_timeout_s", config.idle_timeout_s},
                {"rigs", rigs},
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

  void ServeStudentPage(Seat& seat, Role role, httplib::Response& res) {
    if (role == Role::kStudent) {
      const std::string why = EnsureRig(seat);
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
    Seat* seat = Find(name);
    if (seat == nullptr) {  // only the teacher's token gets here with an unknown name
      SendError(res, 404, "no student '" + core::Printable(name, 40) + "' in this class");
      return;
    }
    if (role == Role::kStudent) seat->Touch();
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
      ServeStudentPage(*seat, role, res);
      return;
    }
    if (rest == "class/status") {
      Json status = SeatJson(*seat, false);
      status["class"] = config.name;
      status["role"] = role == Role::kStudent ? "student" : "teacher";
      status["files"] = ResultFiles(name);
      status["idle_timeout_s"] = config.idle_timeout_s;
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
      const std::string why = EnsureRig(*seat);
      if (why.empty()) {
        SendJson(res, 200, SeatJson(*seat, false));
      } else {
        SendError(res, 503, why);
      }
      return;
    }
    if (rest == "class/turns" || rest.rfind("class/turns/", 0) == 0) {
      StudentTurns(*seat, role, rest, req, res);
      return;
    }
    if (rest.rfind("api/", 0) == 0) {
      Api(*seat, role, rest, req, res);
      return;
    }
    // Controllers from the browser (class/submissions.hpp): submit, list, report, run on the rig.
    if (req.method == "POST" && rest.rfind("class/", 0) == 0 && MissingClient(req, res)) return;
    const auto restart = [this, seat] {
      {
        const std::lock_guard<std::mutex> lock(seat->mutex);
        StopRig(*seat, "restarted with another controller");
      }
      return EnsureRig(*seat);
    };
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
  void StudentTurns(Seat& seat, Role role, const std::string& rest, const httplib::Request& req,
                    httplib::Response& res) {
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
      SendJson(res, 200, real_arm->StudentJson(seat.name));
      return;
    }
    if (req.method != "POST") {
      SendError(res, 405, rest + ": allowed: POST");
      return;
    }
    if (MissingClient(req, res)) return;
    if (role != Role::kStudent) {
      SendError(res, 403,
                "the teacher's view of " + seat.name +
                    "'s rig is read-only; the queue's commands are on /teacher/");
      return;
    }
    const std::string verb = rest.substr(std::string("class/turns/").size());
    if (!TurnCommand([&] { real_arm->StudentCommand(seat.name, verb); }, res)) return;
    Log(seat.name + ": real arm " + verb);
    SendJson(res, 200, real_arm->StudentJson(seat.name));
  }

  void Api(Seat& seat, Role role, const std::string& rest, const httplib::Request& req,
           httplib::Response& res) {
    if (role == Role::kTeacher && IsChange(req)) {
      SendError(res, 403,
                "the teacher's view of " + seat.name +
                    "'s rig is read-only (stop, restart and e-stop are on /teacher/)");
      return;
    }
    std::shared_ptr<RigPanel> rig_panel;
    std::optional<RigEndpoint> endpoint;
    std::string last_stop;
    std::string state;
    std::string waiting;
    {
      const std::lock_guard<std::mutex> info(seat.info_mutex);
      rig_panel = seat.panel;
      endpoint = seat.endpoint;
      last_stop = seat.last_stop;
      state = seat.state;
      waiting = seat.waiting;
    }
    if (!rig_panel && !endpoint && (state == "pending" || state == "unknown")) {
      SendError(res, 503,
                seat.name + "'s rig is " +
                    (state == "pending" ? "on its way"
                                        : "not "
                                          "known to be running") +
                    ": " + waiting);
      return;
    }
    if (!rig_panel && !endpoint) {
      SendError(res, 503,
                seat.name + "'s rig is not running" +
                    (last_stop.empty() ? "" : " (" + last_stop + ")") +
                    "; reload the page to start it again (your files are kept)");
      return;
    }
    if (endpoint) {
      ProxyApi(seat, role, *endpoint, rest, req, res);
      return;
    }
    if (rest == "api/events") {
      if (role == Role::kStudent) {
        ++seat.streams;
        // The count goes down when the stream's provider (and so this guard) is destroyed.
        auto guard = std::shared_ptr<void>(nullptr, [&seat](void*) {
          --seat.streams;
          seat.Touch();
        });
        auto keep = std::make_shared<std::pair<std::shared_ptr<RigPanel>, std::shared_ptr<void>>>(
            rig_panel, guard);
        panel::StreamState(*rig_panel->hub, *rig_panel->api, options.stream_hz, req, res, keep);
      } else {
        panel::StreamState(*rig_panel->hub, *rig_panel->api, options.stream_hz, req, res,
                           rig_panel);
      }
      return;
    }
    // Commands for the bridge (arm, link, ...) from anyone but the real arm's holder in their
    // turn: refused here with the reason (they would reach no bridge anyway).
    if (IsChange(req) && rest.rfind("api/hardware/", 0) == 0) {
      const std::string why = real_arm ? real_arm->MayCommand(seat.name)
                                       : "this class has no real arm (no real_arm: in the class "
                                         "file)";
      if (!why.empty()) {
        SendError(res, 409, "the real arm: " + why);
        return;
      }
    }
    panel::Request request = panel::ToRequest(req);
    request.path = "/" + rest;
    panel::Send(rig_panel->api->Handle(request), res);
  }

  // A job's API through its endpoint: the same refusals as a local rig's, the stream passed on as
  // it comes.
  void ProxyApi(Seat& seat, Role role, const RigEndpoint& endpoint, const std::string& rest,
                const httplib::Request& req, httplib::Response& res) {
    if (rest == "api/events") {
      std::string query;
      for (const auto& [key, value] : req.params) {
        query += (query.empty() ? "?" : "&") + httplib::detail::encode_query_param(key) + "=" +
                 httplib::detail::encode_query_param(value);
      }
      std::shared_ptr<void> guard;
      if (role == Role::kStudent) {
        ++seat.streams;
        guard = std::shared_ptr<void>(nullptr, [&seat](void*) {
          --seat.streams;
          seat.Touch();
        });
      }
      ProxyStream(endpoint, "/api/events" + query, res, guard, [this, &seat, endpoint] {
        const std::lock_guard<std::mutex> info(seat.info_mutex);
        return seat.endpoint && seat.endpoint->port == endpoint.port &&
               seat.endpoint->host == endpoint.host && !StoppingNow();
      });
      return;
    }
    if (IsChange(req) && rest.rfind("api/hardware/", 0) == 0) {
      const std::string why = real_arm ? real_arm->MayCommand(seat.name)
                                       : "this class has no real arm (no real_arm: in the class "
                                         "file)";
      if (!why.empty()) {
        SendError(res, 409, "the real arm: " + why);
        return;
      }
    }
    ProxyRequest(endpoint, "/" + rest, req, res);
  }

  bool StoppingNow() {
    const std::lock_guard<std::mutex> lock(monitor_mutex);
    return stopping;
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
    if (rest == "teacher.js" || rest == "class.css" || rest == "grades.js") {
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
      for (auto& [name, seat] : seats) {
        std::shared_ptr<RigPanel> rig_panel;
        std::optional<RigEndpoint> endpoint;
        {
          const std::lock_guard<std::mutex> info(seat->info_mutex);
          rig_panel = seat->panel;
          endpoint = seat->endpoint;
        }
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
      Seat* seat = Find(match[1].str());
      if (seat == nullptr) {
        SendError(res, 404,
                  "no student '" + core::Printable(match[1].str(), 40) + "' in this class");
        return;
      }
      const std::string verb = match[2];
      if (verb != "start") {
        const std::lock_guard<std::mutex> lock(seat->mutex);
        StopRig(*seat, verb == "stop" ? "stopped by the teacher" : "restarted by the teacher");
      }
      std::string why;
      if (verb != "stop") why = EnsureRig(*seat);
      if (why.empty()) {
        SendJson(res, 200, SeatJson(*seat, false));
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
          {
            const std::lock_guard<std::mutex> lock(monitor_mutex);
            if (stopping) {
              sink.done();
              return true;
            }
          }
          const std::string frame = "data: " + ClassJson().dump() + "\n\n";
          return sink.write(frame.data(), frame.size());
        });
  }

  void Routes() {
    const size_t threads = static_cast<size_t>(std::min(512, 16 + 3 * config.max_rigs));
    server->new_task_queue = [threads] { return new httplib::ThreadPool(threads); };
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
      res.set_redirect(
          req.path + "/" + (req.has_param("token") ? "?token=" + req.get_param_value("token") : ""),
          303);
    });
    const auto teacher = [this](const httplib::Request& req, httplib::Response& res) {
      Teacher(req, res);
    };
    server->Post(kRigReportPath,
                 [this](const httplib::Request& req, httplib::Response& res) { Report(req, res); });
    server->Get(R"(/teacher/(.*))", teacher);
    server->Post(R"(/teacher/(.*))", teacher);
    server->set_error_handler([](const httplib::Request& req, httplib::Response& res) {
      if (res.body.empty()) {
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
  return impl_->port;
}

void ClassServer::Serve() {
  {
    // The monitor thread is made under the lock Stop() sets `stopping` under, so a Stop() that
    // comes first sees no thread to join and this Serve() starts none.
    const std::lock_guard<std::mutex> lock(impl_->monitor_mutex);
    if (impl_->stopping) return;
    impl_->monitor = std::thread([this] { impl_->Monitor(); });
  }
  impl_->gate.Listen(*impl_->server);
}

void ClassServer::Stop() {
  if (!impl_) return;
  {
    const std::lock_guard<std::mutex> lock(impl_->monitor_mutex);
    impl_->stopping = true;
  }
  impl_->monitor_wake.notify_all();
  if (impl_->monitor.joinable()) impl_->monitor.join();
  if (impl_->real_arm) impl_->real_arm->Stop();
  impl_->submissions->Stop();
  for (auto& [name, seat] : impl_->seats) {
    const std::lock_guard<std::mutex> lock(seat->mutex);
    impl_->StopRig(*seat, "the class server stopped");
  }
  impl_->gate.Stop(*impl_->server);
}

}  // namespace sirupp::classroom
