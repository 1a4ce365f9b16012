#include "class/rig_spawner.hpp"

#include <openssl/crypto.h>
#include <openssl/rand.h>
#include <sched.h>
#include <sys/stat.h>

#include <algorithm>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "class/rig_job.hpp"
#include "panel/panel_api.hpp"
#include "panel/panel_hub.hpp"
#include "proc/child.hpp"
#include "proc/udpm_listen.hpp"

namespace sirupp::classroom {
namespace {

namespace fs = std::filesystem;

std::string ReadAll(const std::string& file) {
  std::ifstream in(file);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

std::string WallClockTime(std::chrono::system_clock::time_point at) {
  const std::time_t wall = std::chrono::system_clock::to_time_t(at);
  std::tm local{};
  localtime_r(&wall, &local);
  char text[16];
  std::strftime(text, sizeof text, "%H:%M:%S", &local);
  return text;
}

}  // namespace

const char* RigPhaseName(RigPhase phase) {
  switch (phase) {
    case RigPhase::kStopped:
      return "stopped";
    case RigPhase::kStarting:
      return "starting";
    case RigPhase::kPending:
      return "pending";
    case RigPhase::kRunning:
      return "running";
    case RigPhase::kUnknown:
      return "unknown";
    case RigPhase::kFailed:
      return "failed";
  }
  return "unknown";
}

std::string NewRigSecret() {
  unsigned char bytes[32];
  if (RAND_bytes(bytes, sizeof bytes) != 1) throw std::runtime_error("no randomness for a secret");
  static const char* kHex = "0123456789abcdef";
  std::string out;
  for (const unsigned char b : bytes) {
    out += kHex[b >> 4];
    out += kHex[b & 15];
  }
  return out;
}

// --- local ---------------------------------------------------------------------------------------

CpuShare::CpuShare(bool pin) {
  cpu_set_t allowed;
  CPU_ZERO(&allowed);
  if (pin && ::sched_getaffinity(0, sizeof allowed, &allowed) == 0) {
    for (int cpu = 0; cpu < CPU_SETSIZE; ++cpu) {
      if (CPU_ISSET(cpu, &allowed)) cpus_.push_back(cpu);
    }
    rigs_on_cpu_.assign(cpus_.size(), 0);
  }
}

// The allowed CPU with the fewest rigs (the lowest of equals), counted; -1 when nothing is
// pinned.
int CpuShare::Take() {
  const std::lock_guard<std::mutex> lock(mutex_);
  if (cpus_.size() < 2) return -1;
  const size_t least = static_cast<size_t>(
      std::min_element(rigs_on_cpu_.begin(), rigs_on_cpu_.end()) - rigs_on_cpu_.begin());
  ++rigs_on_cpu_[least];
  return cpus_[least];
}

void CpuShare::Give(int cpu) {
  if (cpu < 0) return;
  const std::lock_guard<std::mutex> lock(mutex_);
  const auto at = std::find(cpus_.begin(), cpus_.end(), cpu);
  if (at != cpus_.end()) --rigs_on_cpu_[static_cast<size_t>(at - cpus_.begin())];
}

LocalRigSpawner::LocalRigSpawner(RigSpec spec, ProcessLauncher& launcher, LeasePort lease,
                                 std::shared_ptr<CpuShare> cpus)
    : spec_(std::move(spec)),
      launcher_(launcher),
      lease_port_(std::move(lease)),
      cpus_(std::move(cpus)) {}

LocalRigSpawner::~LocalRigSpawner() { Stop(); }

RigStatus LocalRigSpawner::Start() {
  submitted_ = std::chrono::system_clock::now();
  try {
    cpu_ = cpus_ ? cpus_->Take() : -1;
    lease_ = lease_port_();
    spec_.port = lease_.port();
    spec_.limits.cpu = cpu_;
    rig_ = std::make_unique<Rig>(spec_, launcher_);
    rig_->Start();
    panel_ = rig_->panel();
    lcm_url_ = rig_->url();
  } catch (...) {
    Release();
    throw;
  }
  ready_at_ = WallClockTime(std::chrono::system_clock::now());
  return RigStatus{RigPhase::kRunning, ""};
}

RigStatus LocalRigSpawner::Poll() {
  if (!rig_) return RigStatus{RigPhase::kFailed, "not started"};
  if (ended_.empty()) ended_ = rig_->CheckProcesses();
  if (!ended_.empty()) return RigStatus{RigPhase::kFailed, ended_};
  return RigStatus{RigPhase::kRunning, ""};
}

void LocalRigSpawner::Release() {
  if (rig_) rig_->Stop();
  lease_.Release();
  if (cpus_) cpus_->Give(cpu_);
  cpu_ = -1;
}

std::string LocalRigSpawner::Stop() {
  Release();
  return "";
}

RigReach LocalRigSpawner::Reach() const {
  RigReach reach;
  if (!panel_) return reach;
  reach.panel = panel_;
  reach.lcm_url = lcm_url_;
  reach.port = spec_.port;
  reach.cpu = cpu_;
  return reach;
}

nlohmann::json LocalRigSpawner::LiveState() const {
  if (!panel_) return nullptr;
  nlohmann::json state = panel_->hub->StateJson();
  state["lock"] = panel_->api->LockHolder();
  return state;
}

double LocalRigSpawner::CpuPercent() { return rig_ ? rig_->CpuPercent() : 0; }

std::string LocalRigSpawner::Where() const { return "udpm port " + std::to_string(spec_.port); }

std::optional<std::chrono::system_clock::time_point> LocalRigSpawner::Submitted() const {
  return submitted_;
}

double LocalRigSpawner::ReadySeconds() const { return rig_ ? rig_->start_seconds() : 0; }

// The notebook server runs on this machine, its bridge on the rig's bus (docs/notebooks.md).
NotebookSite LocalRigSpawner::Notebook() const {
  NotebookSite site;
  site.lcm_url = lcm_url_;
  if (site.lcm_url.empty()) site.why_not = spec_.student + "'s rig is not running";
  return site;
}

// --- Slurm ---------------------------------------------------------------------------------------

std::string RigJobScript(const RigJobSpec& spec) {
  proc::ProcessSpec job;
  job.argv = {spec.bin_dir + "/sirupp-rig-job",
              "--student",
              spec.student,
              "--folder",
              spec.folder,
              "--robot",
              spec.robot,
              "--secret-file",
              spec.secret_file,
              "--report-url",
              spec.report_url,
              "--pace-ticks",
              std::to_string(spec.pace_ticks),
              "--memory-mb",
              std::to_string(spec.memory_mb)};
  if (!spec.controller.empty()) {
    job.argv.push_back("--controller");
    job.argv.push_back(spec.controller);
  }
  return "#!/bin/sh\n# " + spec.student + "'s rig (sirupp class serve, cluster:)\n" +
         proc::ExecLine(job) + "\n";
}

SlurmRigSpawner::SlurmRigSpawner(cluster::SlurmEngine& engine, const cluster::ClusterConfig& config,
                                 RigJobSpec spec, std::string secret_path, std::string folder_here)
    : engine_(engine),
      config_(config),
      spec_(std::move(spec)),
      secret_path_(std::move(secret_path)),
      folder_here_(std::move(folder_here)) {}

SlurmRigSpawner::SlurmRigSpawner(cluster::SlurmEngine& engine, const cluster::ClusterConfig& config,
                                 const nlohmann::json& state, std::string folder_here)
    : engine_(engine), config_(config), folder_here_(std::move(folder_here)) {
  const auto text = [&state](const char* key) {
    const auto found = state.find(key);
    return found != state.end() && found->is_string() ? found->get<std::string>() : std::string();
  };
  spec_.student = text("student");
  job_id_ = text("job");
  secret_ = text("secret");
  node_ = text("node");
  const auto port = state.find("port");
  if (!text("host").empty() && port != state.end() && port->is_number_integer()) {
    endpoint_ = RigEndpoint{text("host"), port->get<int>(), secret_};
    const auto udpm = state.find("udpm_port");
    if (udpm != state.end() && udpm->is_number_integer() && udpm->get<int>() > 0 &&
        udpm->get<int>() <= 65535) {
      udpm_port_ = udpm->get<int>();
    }
  }
  const auto submitted = state.find("submitted_unix_ms");
  if (submitted != state.end() && submitted->is_number_integer()) {
    submitted_ =
        std::chrono::system_clock::time_point(std::chrono::milliseconds(submitted->get<int64_t>()));
  }
  const auto ready = state.find("ready_s");
  if (ready != state.end() && ready->is_number()) ready_s_ = ready->get<double>();
  ready_at_ = text("ready_at");
  if (!cluster::IsJobId(job_id_) || secret_.size() < 32) {
    throw std::invalid_argument("not a rig job's saved state (job '" + job_id_.substr(0, 20) +
                                "')");
  }
}

RigStatus SlurmRigSpawner::Start() {
  secret_ = NewRigSecret();
  fs::create_directories(fs::path(secret_path_).parent_path());
  {
    const mode_t old = ::umask(077);
    std::ofstream out(secret_path_, std::ios::trunc);
    out << secret_ << "\n";
    ::umask(old);
    if (!out) throw std::runtime_error("cannot write the rig's secret to " + secret_path_);
  }
  fs::permissions(secret_path_, fs::perms::owner_read | fs::perms::owner_write,
                  fs::perm_options::replace);
  const cluster::JobRequest request =
      cluster::ClassJobRequest(config_, config_.rig, "sirupp-rig-" + spec_.student,
                               RigJobScript(spec_), spec_.folder + "/logs/rig-job-%j.log");
  const cluster::SubmitResult submitted = engine_.Submit(request);
  if (!submitted.ok())
    throw std::runtime_error("the cluster refused the rig's job: " + submitted.error);
  const std::lock_guard<std::mutex> lock(mutex_);
  job_id_ = submitted.job_id;
  endpoint_.reset();
  udpm_port_ = 0;
  submitted_ = std::chrono::system_clock::now();
  ready_s_ = 0;
  ready_at_.clear();
  live_state_ = nullptr;
  return RigStatus{RigPhase::kPending, "submitted to the cluster"};
}

std::optional<std::chrono::system_clock::time_point> SlurmRigSpawner::Submitted() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  return submitted_;
}

double SlurmRigSpawner::ReadySeconds() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  return ready_s_;
}

std::string SlurmRigSpawner::ReadyAt() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  return ready_at_;
}

RigStatus SlurmRigSpawner::Poll() {
  const std::string end_record = ReadAll(RigJobEndFile(folder_here_, job_id_));
  const cluster::JobStatus job = engine_.Poll(job_id_, end_record);
  const std::lock_guard<std::mutex> lock(mutex_);
  switch (job.state) {
    case cluster::JobState::kPending:
      return RigStatus{RigPhase::kPending, "waiting for the cluster (Slurm: " + job.reason + ")"};
    case cluster::JobState::kRunning:
      if (!job.host.empty()) node_ = job.host;
      if (!endpoint_) {
        return RigStatus{RigPhase::kPending,
                         "starting on " + (node_.empty() ? std::string("a node") : node_)};
      }
      return RigStatus{RigPhase::kRunning, ""};
    case cluster::JobState::kEnded:
      return RigStatus{RigPhase::kFailed, job.reason};
    case cluster::JobState::kUnknown:
      return RigStatus{RigPhase::kUnknown, "the cluster did not say (" + job.reason + ")"};
  }
  return RigStatus{};
}

std::string SlurmRigSpawner::Stop() {
  if (job_id_.empty()) return "";
  return engine_.Cancel(job_id_);
}

RigReach SlurmRigSpawner::Reach() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  RigReach reach;
  reach.endpoint = endpoint_;
  return reach;
}

nlohmann::json SlurmRigSpawner::LiveState() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  return live_state_;
}

void SlurmRigSpawner::Refresh() {
  std::optional<RigEndpoint> endpoint;
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    endpoint = endpoint_;
  }
  if (!endpoint) return;
  const std::optional<nlohmann::json> state = FetchJson(*endpoint, "/api/state", 1.0);
  const std::lock_guard<std::mutex> lock(mutex_);
  live_state_ = state ? *state : nlohmann::json();
}

// The notebook server runs inside the rig's job, as a step on its node beside the rig, its
// bridge on the rig's bus there (docs/notebooks.md): known once the job has reported.
NotebookSite SlurmRigSpawner::Notebook() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  NotebookSite site;
  const std::string job = job_id_.empty() ? std::string("its job") : "Slurm job " + job_id_;
  if (!endpoint_) {
    site.why_not = spec_.student + "'s rig is still starting (" + job +
                   (node_.empty() ? std::string() : " on " + node_) +
                   " has not reported yet): try again in a few seconds";
    site.starting = true;
    return site;
  }
  if (udpm_port_ <= 0) {
    site.why_not = spec_.student + "'s rig (" + job + " on " + endpoint_->host +
                   ") did not report its bus (udpm_port; a sirupp-rig-job older than notebooks on "
                   "a cluster): restart the rig from the teacher's page";
    return site;
  }
  site.lcm_url = RigUrl(udpm_port_);
  site.job = job_id_;
  site.host = endpoint_->host;
  site.node = node_;
  site.node_data = config_.node_data;
  return site;
}

std::string SlurmRigSpawner::Where() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  return "Slurm job " + job_id_ + (node_.empty() ? "" : " on " + node_);
}

nlohmann::json SlurmRigSpawner::State() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  nlohmann::json state{
      {"student", spec_.student}, {"job", job_id_}, {"secret", secret_}, {"node", node_}};
  if (endpoint_) {
    state["host"] = endpoint_->host;
    state["port"] = endpoint_->port;
    if (udpm_port_ > 0) state["udpm_port"] = udpm_port_;
  }
  if (submitted_) {
    state["submitted_unix_ms"] =
        std::chrono::duration_cast<std::chrono::milliseconds>(submitted_->time_since_epoch())
            .count();
  }
  if (!ready_at_.empty()) {
    state["ready_s"] = ready_s_;
    state["ready_at"] = ready_at_;
  }
  return state;
}

bool SlurmRigSpawner::Report(const RigReport& report) {
  const std::string& secret = report.secret;
  const std::string& job = report.job;
  const std::string& host = report.host;
  const int port = report.port;
  const std::lock_guard<std::mutex> lock(mutex_);
  if (secret_.empty() || secret.size() != secret_.size() ||
      CRYPTO_memcmp(secret.data(), secret_.data(), secret_.size()) != 0) {
    return false;
  }
  if (!job.empty() && job != job_id_) return false;
  if (host.empty() || port <= 0 || port > 65535) return false;
  if (report.udpm_port < 0 || report.udpm_port > 65535) return false;
  endpoint_ = RigEndpoint{host, port, secret_};
  udpm_port_ = report.udpm_port;
  const auto now = std::chrono::system_clock::now();
  ready_s_ =
      submitted_ ? std::max(0.0, std::chrono::duration<double>(now - *submitted_).count()) : 0;
  ready_at_ = WallClockTime(now);
  return true;
}

void SaveRigJobs(const std::string& file, const SavedRigJobs& jobs) {
  nlohmann::json out{{"rigs", jobs.rigs}, {"cancel", jobs.cancel}};
  fs::create_directories(fs::path(file).parent_path());
  const std::string temporary = file + ".new";
  {
    const mode_t old = ::umask(077);
    std::ofstream stream(temporary, std::ios::trunc);
    ::umask(old);
    stream << out.dump(1) << "\n";
    if (!stream) throw std::runtime_error("cannot write " + temporary);
  }
  fs::permissions(temporary, fs::perms::owner_read | fs::perms::owner_write,
                  fs::perm_options::replace);
  fs::rename(temporary, file);
}

SavedRigJobs LoadRigJobs(const std::string& file) {
  SavedRigJobs jobs;
  if (!fs::exists(file)) return jobs;
  const nlohmann::json in = nlohmann::json::parse(ReadAll(file), nullptr, false);
  const auto rigs = in.is_object() ? in.find("rigs") : in.end();
  const auto cancel = in.is_object() ? in.find("cancel") : in.end();
  if (!in.is_object() || rigs == in.end() || !rigs->is_array() || cancel == in.end() ||
      !cancel->is_array()) {
    throw std::runtime_error(file + " is not the class server's list of rig jobs");
  }
  for (const nlohmann::json& rig : *rigs) jobs.rigs.push_back(rig);
  for (const nlohmann::json& id : *cancel) {
    if (id.is_string()) jobs.cancel.push_back(id.get<std::string>());
  }
  return jobs;
}

// --- the factories -------------------------------------------------------------------------------

namespace {

// How long a rig's port must be silent before a rig starts on it: every SIRUPP process sends a
// heartbeat each second.
constexpr double kQuietListenS = 1.2;

class LocalRigSpawnerFactory : public RigSpawnerFactory {
 public:
  LocalRigSpawnerFactory(const ClassConfig& config, RigSpawnerOptions options,
                         ProcessLauncher& launcher)
      : config_(config),
        options_(std::move(options)),
        launcher_(launcher),
        cpus_(std::make_shared<CpuShare>(config.pin_rigs)) {}

  std::string Describe() const override { return "this server's processes"; }

  std::unique_ptr<RigSpawner> Make(const RigRequest& request) override {
    RigSpec spec;
    spec.robot = request.robot;
    spec.student = request.student;
    spec.bin_dir = options_.bin_dir;
    spec.folder = request.folder;
    spec.limits = ChildLimits{config_.rig_nice, config_.rig_memory_mb, -1};
    spec.pace_ticks = config_.pace_ticks;
    spec.controller = request.controller;
    return std::make_unique<LocalRigSpawner>(
        spec, launcher_, [this] { return LeaseQuietPort(); }, cpus_);
  }

  std::unique_ptr<RigSpawner> Restore(const nlohmann::json&) override {
    throw std::invalid_argument("a rig of this server's own processes ended with its server");
  }
  SavedRigs Load() override { return {}; }
  void Save(const SavedRigs&) override {}
  std::string StopSaved(const nlohmann::json&) override { return ""; }

  std::unique_ptr<GradePlace> MakeGradePlace(const LocalGradeOptions& local, GradeHooks) override {
    return std::make_unique<LocalGradePlace>(local, launcher_);
  }

 private:
  void Log(const std::string& line) const {
    if (options_.log) options_.log(line);
  }

  // A port of the rigs' range that no other class server or grader holds (grade::PortLease) and
  // on which nothing is heard: LCM shares its port, so another program on it (a lab's `sirupp
  // launch`, a test's rig, a rig that did not end) would talk on the student's bus. Ports where
  // something talks are held while the next is tried, then given back; at most kQuietTries.
  grade::PortLease LeaseQuietPort() {
    constexpr int kQuietTries = 8;
    std::vector<grade::PortLease> busy;
    std::string heard;
    const int offset = static_cast<int>(
        std::chrono::steady_clock::now().time_since_epoch().count() % config_.port_count);
    for (int k = 0; k < std::min(kQuietTries, config_.port_count); ++k) {
      grade::PortLease lease;
      try {
        lease = grade::PortLease::Acquire(config_.first_port, config_.port_count, offset + k);
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
        "no quiet udpm port for a rig in " + std::to_string(config_.first_port) + ".." +
        std::to_string(config_.first_port + config_.port_count - 1) + ": " +
        std::to_string(busy.size()) + " tried, something else talks on each (" + heard + ")");
  }

  const ClassConfig& config_;
  RigSpawnerOptions options_;
  ProcessLauncher& launcher_;
  std::shared_ptr<CpuShare> cpus_;
};

class SlurmRigSpawnerFactory : public RigSpawnerFactory {
 public:
  SlurmRigSpawnerFactory(const ClassConfig& config, RigSpawnerOptions options)
      : config_(config),
        cluster_(*config.cluster),
        options_(std::move(options)),
        engine_(runner_, SlurmOptionsOf(cluster_)) {}

  std::string Describe() const override { return "Slurm jobs (cluster:)"; }

  std::unique_ptr<RigSpawner> Make(const RigRequest& request) override {
    fs::create_directories(request.folder + "/logs");
    fs::create_directories(request.folder + "/results");
    RigJobSpec spec;
    spec.student = request.student;
    spec.folder = OnNodes(request.folder);
    spec.robot = OnNodes(request.robot);
    spec.bin_dir = options_.bin_dir;
    const std::string secret_file = config_.data_dir + "/cluster/secrets/" + request.student;
    spec.secret_file = OnNodes(secret_file);
    spec.report_url = cluster_.report_url.empty() ? request.server_url : cluster_.report_url;
    spec.controller = OnNodes(request.controller);
    spec.pace_ticks = config_.pace_ticks;
    spec.memory_mb = config_.rig_memory_mb;
    return std::make_unique<SlurmRigSpawner>(engine_, cluster_, spec, secret_file, request.folder);
  }

  std::unique_ptr<RigSpawner> Restore(const nlohmann::json& state) override {
    const auto named = state.is_object() ? state.find("student") : state.end();
    const std::string student =
        named != state.end() && named->is_string() ? named->get<std::string>() : "";
    return std::make_unique<SlurmRigSpawner>(engine_, cluster_, state,
                                             config_.data_dir + "/students/" + student);
  }

  // DATA/cluster/rigs.json: {"rigs": [State()...], "cancel": [job ids]}.
  SavedRigs Load() override {
    const SavedRigJobs jobs = LoadRigJobs(JobsFile());
    SavedRigs saved;
    saved.rigs = jobs.rigs;
    for (const std::string& id : jobs.cancel) saved.stops.push_back(nlohmann::json{{"job", id}});
    return saved;
  }

  void Save(const SavedRigs& saved) override {
    SavedRigJobs jobs;
    jobs.rigs = saved.rigs;
    for (const nlohmann::json& state : saved.stops) {
      const std::string id = JobOf(state);
      if (!id.empty()) jobs.cancel.push_back(id);
    }
    SaveRigJobs(JobsFile(), jobs);
  }

  std::string StopSaved(const nlohmann::json& state) override {
    const std::string id = JobOf(state);
    return id.empty() ? "" : engine_.Cancel(id);
  }

  std::unique_ptr<GradePlace> MakeGradePlace(const LocalGradeOptions&, GradeHooks hooks) override {
    return std::make_unique<SlurmGradePlace>(engine_, cluster_, config_.data_dir, std::move(hooks));
  }

 private:
  static cluster::SlurmOptions SlurmOptionsOf(const cluster::ClusterConfig& cluster) {
    cluster::SlurmOptions slurm;
    slurm.command_timeout_s = cluster.command_timeout_s;
    return slurm;
  }
  static std::string JobOf(const nlohmann::json& state) {
    const auto job = state.is_object() ? state.find("job") : state.end();
    return job != state.end() && job->is_string() && cluster::IsJobId(job->get<std::string>())
               ? job->get<std::string>()
               : "";
  }
  std::string JobsFile() const { return config_.data_dir + "/cluster/rigs.json"; }
  // A path under the data folder, as the nodes see it.
  std::string OnNodes(const std::string& path) const {
    if (path.rfind(config_.data_dir + "/", 0) != 0) return path;
    const std::string node_data =
        cluster_.node_data.empty() ? config_.data_dir : cluster_.node_data;
    return node_data + path.substr(config_.data_dir.size());
  }

  const ClassConfig& config_;
  cluster::ClusterConfig cluster_;
  RigSpawnerOptions options_;
  cluster::SystemRunner runner_;
  cluster::SlurmEngine engine_;  // after the runner it uses
};

}  // namespace

std::unique_ptr<RigSpawnerFactory> MakeRigSpawnerFactory(const ClassConfig& config,
                                                         RigSpawnerOptions options,
                                                         ProcessLauncher& launcher) {
  if (config.cluster) return std::make_unique<SlurmRigSpawnerFactory>(config, std::move(options));
  return std::make_unique<LocalRigSpawnerFactory>(config, std::move(options), launcher);
}

}  // namespace sirupp::classroom
