#pragma once
// Where a student's rig runs, behind one interface (JupyterHub's Spawner idea): start, poll, stop,
// how the class server reaches the running rig, and what a restarted server needs to find it
// again. The class's rig pool (class/rig_pool.hpp) and its grading (class/submissions.hpp) are a
// hub over it that never asks which kind it has: a RigSpawnerFactory, made once from the class
// file (MakeRigSpawnerFactory), makes a spawner per seat, takes back saved ones, and says where a
// grade runs (class/grade_place.hpp). Two kinds:
//
//   local  LocalRigSpawner: the rig's processes are the class server's children (class/rig.hpp)
//          on a quiet leased udpm port, its panel (hub, API) in the server's process; running
//          when Start returns. Grades are the server's children (LocalGradePlace).
//   Slurm  SlurmRigSpawner (the class file's cluster: key): the rig is one Slurm job running
//          sirupp-rig-job on a node (class/rig_job.hpp); Start submits and returns at once
//          (pending); the job reports its endpoint (Report) and the server proxies to it
//          (class/rig_proxy.hpp); DATA/cluster/rigs.json keeps the jobs for a restarted server.
//          Grades are Slurm jobs (SlurmGradePlace).
//
// A new engine (Kubernetes, HTCondor, ...) is one more spawner and factory: submit the same
// sirupp-rig-job command (RigJobScript), read the engine's state into a RigStatus (anything it
// cannot read is kUnknown, never an end), cancel, and save/restore what a restarted server needs
// (State / Restore).

#include <chrono>
#include <functional>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "class/class_config.hpp"
#include "class/grade_place.hpp"
#include "class/rig.hpp"
#include "class/rig_proxy.hpp"
#include "cluster/class_job.hpp"
#include "cluster/cluster_config.hpp"
#include "cluster/command_runner.hpp"
#include "cluster/slurm_engine.hpp"
#include "grade/port_lease.hpp"

namespace sirupp::classroom {

// A seat's rig as the pages show it, one enum for every kind: stopped (never started, or
// stopped when asked), starting (Start in progress), pending (on its way: waiting for the
// cluster, starting on its node), running, unknown (the engine did not say; never read as
// stopped), failed (it could not start, or ended without being asked).
enum class RigPhase { kStopped, kStarting, kPending, kRunning, kUnknown, kFailed };
// "stopped", "starting", "pending", "running", "unknown", "failed"
const char* RigPhaseName(RigPhase phase);

// A spawner's answer. Start: kRunning (ready) or kPending (on its way, why). Poll: kRunning,
// kPending (why it waits), kUnknown (why it is not known), kFailed (why it ended).
struct RigStatus {
  RigPhase phase = RigPhase::kUnknown;
  std::string reason;
};

// How the class server reaches a rig: its panel in this process, or its HTTP endpoint on a node
// (once reported); at most one of the two.
struct RigReach {
  std::shared_ptr<RigPanel> panel;
  std::optional<RigEndpoint> endpoint;
  std::string lcm_url;  // its bus when this server reaches it, else ""
  int port = 0;         // its udpm port on this machine, else 0
  int cpu = -1;         // the CPU its processes are pinned to (limits.pin_rigs), else -1
  bool reachable() const { return panel != nullptr || endpoint.has_value(); }
};

// Where the student's notebook server runs beside their rig (docs/notebooks.md): on this
// machine, its bridge on the rig's bus; inside the rig's job on its node (job set), its bridge
// on the rig's bus there; or nowhere yet, and why.
struct NotebookSite {
  std::string lcm_url;  // the bus the notebook's bridge joins, on the rig's machine ("" when none)
  std::string job;      // the rig's job the server runs in (a step of it); "" = this machine
  std::string host;     // the job's node as it reported itself: where the server listens
  std::string node;     // the node's name as the engine gives it (for the log), else ""
  std::string node_data;  // the class's data folder as the node sees it ("" = the same path)
  std::string why_not;    // "" when a notebook server can run beside the rig
  bool starting = false;  // why_not is passing: the rig is on its way (ask again in a moment)
};

// A rig job's report (POST /cluster/report).
struct RigReport {
  std::string secret;
  std::string job;
  std::string host;
  int port = 0;
  int udpm_port = 0;  // the rig's udpm port on its node; 0 = not told (a job before it was)
};

class RigSpawner {
 public:
  virtual ~RigSpawner() = default;
  virtual std::string student() const = 0;
  // Local: starts and returns when the rig is ready (kRunning; throws std::runtime_error with the
  // reason, having stopped what started). Job: submits and returns kPending; throws when refused.
  virtual RigStatus Start() = 0;
  // Where it is now. Local: failed when one of its processes ended. Job: the engine's answer.
  virtual RigStatus Poll() = 0;
  // Seconds between two Polls (0: each pass of the pool's monitor).
  virtual double PollIntervalS() const = 0;
  // Ends it; "" when done, else why not (an engine that did not answer: the pool tries again).
  virtual std::string Stop() = 0;
  virtual RigReach Reach() const = 0;
  // A report naming this rig: true when it is this rig's (then Reach() has the endpoint).
  // False for a rig that does not report (local).
  virtual bool Report(const RigReport& report) = 0;
  // The arm's state as /api/state gives it (controller, sim, estop, virtual.q; lock when known),
  // cheap to call from a page: read now (local) or as the last Refresh fetched it (job); null when
  // not known.
  virtual nlohmann::json LiveState() const = 0;
  // Called by the pool's monitor at each pass: a job fetches its live state (1 s at most).
  virtual void Refresh() = 0;
  // CPU use of its processes since the last call, % of one core (0 where not measured).
  virtual double CpuPercent() = 0;
  // For the pages: "udpm port 7910", "Slurm job 12 on node07".
  virtual std::string Where() const = 0;
  // When it was started (submitted), on the wall clock; nullopt when not known.
  virtual std::optional<std::chrono::system_clock::time_point> Submitted() const = 0;
  // Seconds from its start to ready and the wall-clock time it became ready ("HH:MM:SS");
  // 0 and "" until it is ready or when not known.
  virtual double ReadySeconds() const = 0;
  virtual std::string ReadyAt() const = 0;
  // What a restarted server needs to find it again (RigSpawnerFactory::Restore); null for a rig
  // that ends with the server (local).
  virtual nlohmann::json State() const = 0;
  // Where the student's notebook server runs beside this rig.
  virtual NotebookSite Notebook() const = 0;
};

// What a seat's new rig runs, as the pool prepared it.
struct RigRequest {
  std::string student;
  std::string folder;      // the student's folder as this server sees it
  std::string robot;       // the model file in it
  std::string controller;  // a student's controller; "" = the built-in law
  std::string server_url;  // this class server (BaseUrl), where a job reports
};

// What a previous server left: the States of its rigs, and of rigs whose stop it still owed.
struct SavedRigs {
  std::vector<nlohmann::json> rigs;
  std::vector<nlohmann::json> stops;
};

// The kind of spawner a class has, made once from its class file.
class RigSpawnerFactory {
 public:
  virtual ~RigSpawnerFactory() = default;
  // For the log: "this server's processes", "Slurm jobs (cluster:)".
  virtual std::string Describe() const = 0;
  // A new seat's spawner, not started.
  virtual std::unique_ptr<RigSpawner> Make(const RigRequest& request) = 0;
  // A spawner from a saved State(); throws std::invalid_argument when the state is not one.
  virtual std::unique_ptr<RigSpawner> Restore(const nlohmann::json& state) = 0;
  // What the last server saved (nothing for a kind that keeps nothing); throws std::runtime_error
  // naming the file when it cannot be read.
  virtual SavedRigs Load() = 0;
  // Saves it for the next server (nothing for a kind that keeps nothing); throws on failure.
  virtual void Save(const SavedRigs& saved) = 0;
  // The stop a saved state's rig is owed (one whose Stop did not end it): "" when done.
  virtual std::string StopSaved(const nlohmann::json& state) = 0;
  // Where the class's grades run (GradePlace::Slots at once).
  virtual std::unique_ptr<GradePlace> MakeGradePlace(const LocalGradeOptions& local,
                                                     GradeHooks hooks) = 0;
};

struct RigSpawnerOptions {
  std::string bin_dir;  // the rigs' programs (and sirupp-rig-job on the nodes)
  std::function<void(const std::string& line)> log;
};

// The class file's kind: Slurm jobs with its cluster: key, else this server's processes.
// `config` and `launcher` must outlive the factory and everything it makes.
std::unique_ptr<RigSpawnerFactory> MakeRigSpawnerFactory(const ClassConfig& config,
                                                         RigSpawnerOptions options,
                                                         ProcessLauncher& launcher);

// --- the two kinds ---------------------------------------------------------------------------

// Shares the CPUs this server may use among the local rigs (limits.pin_rigs): each rig on the
// CPU with the fewest. Thread-safe.
class CpuShare {
 public:
  explicit CpuShare(bool pin);
  int Take();  // -1 when nothing is pinned
  void Give(int cpu);

 private:
  std::mutex mutex_;
  std::vector<int> cpus_;
  std::vector<int> rigs_on_cpu_;
};

// Today's rig: the processes of `spec` started by `launcher` (spec.port and spec.limits.cpu are
// filled at Start from a quiet leased port and `cpus`).
class LocalRigSpawner : public RigSpawner {
 public:
  using LeasePort = std::function<grade::PortLease()>;
  LocalRigSpawner(RigSpec spec, ProcessLauncher& launcher, LeasePort lease,
                  std::shared_ptr<CpuShare> cpus);
  ~LocalRigSpawner() override;
  std::string student() const override { return spec_.student; }
  RigStatus Start() override;
  RigStatus Poll() override;
  double PollIntervalS() const override { return 0; }
  std::string Stop() override;
  RigReach Reach() const override;
  bool Report(const RigReport&) override { return false; }
  nlohmann::json LiveState() const override;
  void Refresh() override {}
  double CpuPercent() override;
  std::string Where() const override;
  std::optional<std::chrono::system_clock::time_point> Submitted() const override;
  double ReadySeconds() const override;
  std::string ReadyAt() const override { return ready_at_; }
  nlohmann::json State() const override { return nullptr; }
  NotebookSite Notebook() const override;

 private:
  void Release();
  RigSpec spec_;
  ProcessLauncher& launcher_;
  LeasePort lease_port_;
  std::shared_ptr<CpuShare> cpus_;
  std::unique_ptr<Rig> rig_;
  std::shared_ptr<RigPanel> panel_;  // set once by Start (read by pages without a lock)
  std::string lcm_url_;
  grade::PortLease lease_;
  int cpu_ = -1;
  std::string ended_;
  std::optional<std::chrono::system_clock::time_point> submitted_;
  std::string ready_at_;
};

// What a rig job runs (paths as the nodes see them).
struct RigJobSpec {
  std::string student;
  std::string folder;       // the student's folder on the nodes
  std::string robot;        // the model file on the nodes
  std::string bin_dir;      // sirupp-rig-job and the rig's programs on the nodes
  std::string secret_file;  // on the nodes; written by the server (0600) before submitting
  std::string report_url;   // the class server as the nodes reach it
  std::string controller;   // a student's controller on the nodes; "" = the built-in law
  int pace_ticks = 4;
  int memory_mb = 0;  // each rig process's address-space limit (limits.rig_memory_mb)
};

// The job script: sh exec'ing sirupp-rig-job with the spec's flags, each word quoted.
std::string RigJobScript(const RigJobSpec& spec);

class SlurmRigSpawner : public RigSpawner {
 public:
  // A new rig: Start() writes the secret to `secret_path` (this server's path of
  // spec.secret_file) and submits.
  SlurmRigSpawner(cluster::SlurmEngine& engine, const cluster::ClusterConfig& config,
                  RigJobSpec spec, std::string secret_path, std::string folder_here);
  // A rig found in the class's data folder after a restart (`state` from State()).
  SlurmRigSpawner(cluster::SlurmEngine& engine, const cluster::ClusterConfig& config,
                  const nlohmann::json& state, std::string folder_here);

  std::string student() const override { return spec_.student; }
  RigStatus Start() override;
  RigStatus Poll() override;
  double PollIntervalS() const override { return config_.poll_s; }
  std::string Stop() override;
  RigReach Reach() const override;
  // The job's report: true when its secret and job are this rig's; then the endpoint is known.
  bool Report(const RigReport& report) override;
  nlohmann::json LiveState() const override;
  void Refresh() override;  // GET /api/state from the endpoint, once reported
  double CpuPercent() override { return 0; }
  std::string Where() const override;
  // Saved with the state, so a restarted server knows them (nullopt / 0 / "" for a state saved
  // before they were kept).
  std::optional<std::chrono::system_clock::time_point> Submitted() const override;
  double ReadySeconds() const override;
  std::string ReadyAt() const override;
  nlohmann::json State() const override;
  NotebookSite Notebook() const override;

  const std::string& job_id() const { return job_id_; }

 private:
  cluster::SlurmEngine& engine_;
  cluster::ClusterConfig config_;
  RigJobSpec spec_;
  std::string secret_path_;
  std::string folder_here_;  // the student's folder as this server sees it (the job's end record)
  std::string secret_;
  std::string job_id_;
  mutable std::mutex mutex_;
  std::optional<RigEndpoint> endpoint_;
  std::string node_;
  int udpm_port_ = 0;  // the rig's bus on its node, as reported (0: not told)
  std::optional<std::chrono::system_clock::time_point> submitted_;
  double ready_s_ = 0;
  std::string ready_at_;
  nlohmann::json live_state_;
};

// The class's rig jobs as a restarted server finds them: DATA/cluster/rigs.json (0600: it holds
// the rigs' secrets), {"rigs": [State()...], "cancel": [job ids whose scancel got no answer]}.
struct SavedRigJobs {
  std::vector<nlohmann::json> rigs;
  std::vector<std::string> cancel;
};
void SaveRigJobs(const std::string& file, const SavedRigJobs& jobs);
// Nothing when the file is absent; throws std::runtime_error naming it when it is not ours.
SavedRigJobs LoadRigJobs(const std::string& file);

// A new secret: 32 random bytes as 64 hex digits (OpenSSL RAND_bytes).
std::string NewRigSecret();

}  // namespace sirupp::classroom
