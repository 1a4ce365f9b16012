#include "class/rig_spawner.hpp"

#include <openssl/crypto.h>
#include <openssl/rand.h>
#include <sys/stat.h>

#include <algorithm>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "class/rig_job.hpp"
#include "proc/child.hpp"

namespace sirupp::classroom {
namespace {

namespace fs = std::filesystem;

std::string ReadAll(const std::string& file) {
  std::ifstream in(file);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

}  // namespace

const char* RigPhaseName(RigPhase phase) {
  switch (phase) {
    case RigPhase::kPending:
      return "pending";
    case RigPhase::kRunning:
      return "running";
    case RigPhase::kEnded:
      return "ended";
    case RigPhase::kUnknown:
      return "unknown";
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

LocalRigSpawner::LocalRigSpawner(RigSpec spec, ProcessLauncher& launcher, grade::PortLease lease)
    : rig_(std::move(spec), launcher), lease_(std::move(lease)) {}

void LocalRigSpawner::Start() { rig_.Start(); }

RigStatus LocalRigSpawner::Poll() {
  if (ended_.empty()) ended_ = rig_.CheckProcesses();
  if (!ended_.empty()) return RigStatus{RigPhase::kEnded, ended_};
  return RigStatus{RigPhase::kRunning, ""};
}

std::string LocalRigSpawner::Stop() {
  rig_.Stop();
  lease_.Release();
  return "";
}

std::shared_ptr<RigPanel> LocalRigSpawner::panel() const { return rig_.panel(); }

std::string LocalRigSpawner::lcm_url() const { return rig_.url(); }

double LocalRigSpawner::CpuPercent() { return rig_.CpuPercent(); }

std::string LocalRigSpawner::Where() const {
  return "udpm port " + std::to_string(rig_.spec().port);
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

void SlurmRigSpawner::Start() {
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
  submitted_ = std::chrono::system_clock::now();
  ready_s_ = 0;
  ready_at_.clear();
}

std::optional<std::chrono::system_clock::time_point> SlurmRigSpawner::submitted() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  return submitted_;
}

double SlurmRigSpawner::ready_s() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  return ready_s_;
}

std::string SlurmRigSpawner::ready_at() const {
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
      return RigStatus{RigPhase::kEnded, job.reason};
    case cluster::JobState::kUnknown:
      return RigStatus{RigPhase::kUnknown, "the cluster did not say (" + job.reason + ")"};
  }
  return RigStatus{};
}

std::string SlurmRigSpawner::Stop() {
  if (job_id_.empty()) return "";
  return engine_.Cancel(job_id_);
}

std::optional<RigEndpoint> SlurmRigSpawner::endpoint() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  return endpoint_;
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

bool SlurmRigSpawner::Reported(const std::string& secret, const std::string& job,
                               const std::string& host, int port) {
  const std::lock_guard<std::mutex> lock(mutex_);
  if (secret_.empty() || secret.size() != secret_.size() ||
      CRYPTO_memcmp(secret.data(), secret_.data(), secret_.size()) != 0) {
    return false;
  }
  if (!job.empty() && job != job_id_) return false;
  if (host.empty() || port <= 0 || port > 65535) return false;
  endpoint_ = RigEndpoint{host, port, secret_};
  const auto now = std::chrono::system_clock::now();
  ready_s_ =
      submitted_ ? std::max(0.0, std::chrono::duration<double>(now - *submitted_).count()) : 0;
  const std::time_t wall = std::chrono::system_clock::to_time_t(now);
  std::tm local{};
  localtime_r(&wall, &local);
  char text[16];
  std::strftime(text, sizeof text, "%H:%M:%S", &local);
  ready_at_ = text;
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

}  // namespace sirupp::classroom
