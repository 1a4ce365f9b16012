#pragma once
// Where a student's rig runs, behind one interface (JupyterHub's Spawner idea): start, poll, stop,
// and how the class server reaches the running rig. Two implementations:
//
//   LocalRigSpawner  the rig's processes are the class server's children (class/rig.hpp) and its
//                    panel (hub, API) lives in the server's process; ready when Start returns
//   SlurmRigSpawner  the rig is one Slurm job running sirupp-rig-job on a node (class/rig_job.hpp);
//                    Start submits and returns at once (pending); the job reports its endpoint
//                    (Reported) and the server proxies to it (class/rig_proxy.hpp)
//
// A new engine (Kubernetes, HTCondor, ...) is one more implementation: submit the same
// sirupp-rig-job command (RigJobCommand), read the engine's state into RigStatus (anything it
// cannot read is kUnknown, never kEnded), cancel, and save/load what a restarted server needs to
// find the rig again (State / the constructor taking it).

#include <chrono>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "class/rig.hpp"
#include "class/rig_proxy.hpp"
#include "cluster/class_job.hpp"
#include "cluster/cluster_config.hpp"
#include "cluster/slurm_engine.hpp"
#include "grade/port_lease.hpp"

namespace sirupp::classroom {

enum class RigPhase { kPending, kRunning, kEnded, kUnknown };
const char* RigPhaseName(RigPhase phase);  // "pending", "running", "ended", "unknown"

struct RigStatus {
  RigPhase phase = RigPhase::kUnknown;
  std::string reason;  // pending: why it waits; ended: why it ended; unknown: why not known
};

class RigSpawner {
 public:
  virtual ~RigSpawner() = default;
  // Local: starts and returns when the rig is ready (throws std::runtime_error with the reason,
  // having stopped what started). Job: submits and returns (pending); throws when refused.
  virtual void Start() = 0;
  // Where it is now. Local: ended when one of its processes ended. Job: the engine's answer.
  virtual RigStatus Poll() = 0;
  // Ends it; "" when done, else why not (an engine that did not answer: the caller tries again).
  virtual std::string Stop() = 0;
  // How the server reaches it: its panel in this process (local), or its endpoint (job, once
  // reported). Exactly one of them while it runs.
  virtual std::shared_ptr<RigPanel> panel() const = 0;
  virtual std::optional<RigEndpoint> endpoint() const = 0;
  // Its LCM address when this server can reach its bus (local), else "" (a rig on a node).
  virtual std::string lcm_url() const = 0;
  // CPU use of its processes since the last call, % of one core (local; 0 where not measured).
  virtual double CpuPercent() = 0;
  // For the pages: "udpm port 7910", "Slurm job 12 on node07".
  virtual std::string Where() const = 0;
  // What a restarted server needs to find it again (jobs); null for a local rig, which ends with
  // the server.
  virtual nlohmann::json State() const = 0;
};

// Today's rig: the processes of `spec` started by `launcher`, on the leased port.
class LocalRigSpawner : public RigSpawner {
 public:
  LocalRigSpawner(RigSpec spec, ProcessLauncher& launcher, grade::PortLease lease);
  void Start() override;
  RigStatus Poll() override;
  std::string Stop() override;
  std::shared_ptr<RigPanel> panel() const override;
  std::optional<RigEndpoint> endpoint() const override { return std::nullopt; }
  std::string lcm_url() const override;
  double CpuPercent() override;
  std::string Where() const override;
  nlohmann::json State() const override { return nullptr; }
  double start_seconds() const { return rig_.start_seconds(); }
  Rig& rig() { return rig_; }

 private:
  Rig rig_;
  grade::PortLease lease_;
  std::string ended_;
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

  void Start() override;
  RigStatus Poll() override;
  std::string Stop() override;
  std::shared_ptr<RigPanel> panel() const override { return nullptr; }
  std::optional<RigEndpoint> endpoint() const override;
  std::string lcm_url() const override { return ""; }
  double CpuPercent() override { return 0; }
  std::string Where() const override;
  nlohmann::json State() const override;

  // The job's report (POST /cluster/report): true when `secret` and `job` are this rig's, and
  // then the endpoint is known.
  bool Reported(const std::string& secret, const std::string& job, const std::string& host,
                int port);
  const std::string& job_id() const { return job_id_; }
  const std::string& secret() const { return secret_; }
  // When the job was submitted (the wall clock, saved with the state, so a restarted server
  // knows it); nullopt for a state saved before it was kept.
  std::optional<std::chrono::system_clock::time_point> submitted() const;
  // Seconds from the submission to the job's report, and the wall-clock time of the report
  // ("HH:MM:SS"); 0 and "" until it reported (also kept with the state).
  double ready_s() const;
  std::string ready_at() const;

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
  std::optional<std::chrono::system_clock::time_point> submitted_;
  double ready_s_ = 0;
  std::string ready_at_;
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
