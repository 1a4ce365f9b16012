#pragma once
// The class's rig pool: every student's rig over its whole life, in one place. The class server's
// routes (class/class_server.cpp) only ask it; where a rig runs is a RigSpawner
// (class/rig_spawner.hpp), chosen here once: the server's own processes (LocalRigSpawner), or a
// Slurm job with the class file's cluster: key (SlurmRigSpawner).
//
//   Ensure        a student's first visit (or their "start", the teacher's start): starts the rig
//                 unless it runs, counted against limits.max_rigs (TakeRigPlace); a local rig is
//                 ready when it returns, a job is pending until it reports (Reported)
//   Stop          the teacher's stop, a restart's first half, a rig switching controller
//   monitor       (1 Hz thread, StartMonitor): polls each rig through its spawner (a job at most
//                 every cluster.poll_s), stops a rig whose process or job ended with the reason,
//                 shows pending and unknown with why, samples CPU, fetches a job's live state for
//                 the teacher, stops rigs idle past limits.idle_timeout_s, retries cancels the
//                 engine did not take
//   reattach      with cluster:, the constructor takes back the jobs a previous server saved in
//                 DATA/cluster/rigs.json; every start, stop and report saves it again
//   BeginStop,    the class server's stop: no new rig starts, the monitor ends; then every rig
//   StopAll       is stopped (a job cancelled)
//
// What the pages show of a rig (SeatJson, Access) is read here too, so the state names (stopped,
// starting, pending, running, unknown, failed) have one source.

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "class/class_config.hpp"
#include "class/rig.hpp"
#include "class/rig_proxy.hpp"
#include "cluster/command_runner.hpp"
#include "cluster/slurm_engine.hpp"
#include "grade/port_lease.hpp"

namespace sirupp::classroom {

// A student's folder in the class's data folder (class_server.hpp has the same).
std::string StudentFolder(const ClassConfig& config, const std::string& name);

struct RigPoolOptions {
  std::string bin_dir;     // the rigs' programs (and sirupp-rig-job)
  std::string config_dir;  // the config/ copied into a new student's folder
  // The controller a student's rig runs ("" = the built-in law; class/submissions.hpp).
  std::function<std::string(const std::string& student)> controller;
  std::function<void(const std::string& line)> log;
};

// What the routes need of a rig to answer a request: how to reach it, or why it cannot be.
struct RigAccess {
  std::shared_ptr<RigPanel> panel;      // a local rig's panel
  std::optional<RigEndpoint> endpoint;  // a job's endpoint, once it reported
  std::string state;                    // as in SeatJson
  std::string waiting;                  // pending or unknown: why
  std::string last_stop;                // why it last stopped
};

class RigPool {
 public:
  // One seat per student of `config` (which must outlive the pool), all stopped; with cluster:
  // the saved jobs reattached.
  RigPool(const ClassConfig& config, RigPoolOptions options, ProcessLauncher& launcher);
  ~RigPool();  // BeginStop and StopAll
  RigPool(const RigPool&) = delete;
  RigPool& operator=(const RigPool&) = delete;

  // The real arm's queue (class file real_arm:): told when a rig stops; a rig it involves is not
  // idle. Set before StartMonitor.
  void SetRealArmHooks(
      std::function<void(const std::string& student, const std::string& why)> stopped,
      std::function<bool(const std::string& student)> involved);
  // The class server's port once bound (a job's default report_url).
  void SetServerPort(int port);

  bool Has(const std::string& student) const;
  std::vector<std::string> Students() const;  // sorted
  int running() const { return running_.load(); }

  // A request from the student: their rig is in use.
  void Touch(const std::string& student);
  // Starts the student's rig unless it runs. "" or why it cannot (for a 503).
  std::string Ensure(const std::string& student);
  // Stops the student's rig (a job: cancelled), if any, saying why on the pages.
  void Stop(const std::string& student, const std::string& why);
  // A job's report (POST /cluster/report): true when `secret` and `job` are those of the rig job
  // the student's seat waits for; then the rig runs at host:port.
  bool Reported(const std::string& student, const std::string& secret, const std::string& job,
                const std::string& host, int port);

  RigAccess Access(const std::string& student) const;
  // Held by the student's open event stream: the rig is not idle while it is held.
  std::shared_ptr<void> OpenStream(const std::string& student);
  // Whether a stream to `endpoint` should go on: the student's rig is still there and the server
  // is not stopping.
  bool StillAt(const std::string& student, const RigEndpoint& endpoint) const;
  // The rig's LCM address while it runs and this server reaches its bus (local), else "".
  std::string LcmUrl(const std::string& student) const;

  // The rig as the pages show it; `live` adds the arm's state (controller, sim, estop, q, lock).
  nlohmann::json SeatJson(const std::string& student, bool live) const;

  // The monitor thread; false (and no thread) after BeginStop.
  bool StartMonitor();
  // No rig starts from now on; the monitor ends. Safe to call twice.
  void BeginStop();
  bool Stopping() const;
  // Stops every rig, saying why.
  void StopAll(const std::string& why);

 private:
  struct Seat;
  Seat* Find(const std::string& student) const;
  void Log(const std::string& line) const;
  std::string PrepareFolder(const std::string& folder) const;
  std::string TakeRigPlace(Seat* local);
  std::string EnsureRig(Seat& seat);
  std::string StartLocal(Seat& seat);
  std::string StartJob(Seat& seat);
  // A start that threw (local or job): the seat failed with `why`, counted out; returns the reason.
  std::string StartFailed(Seat& seat, const std::string& why);
  grade::PortLease LeaseQuietPort();
  void StopRig(Seat& seat, const std::string& why, bool failed = false);
  int PickCpu();
  void ReleaseCpu(Seat& seat);
  std::string JobsFile() const;
  std::string OnNodes(const std::string& path) const;
  void SaveJobs();
  void Reattach();
  void Monitor();
  bool PollRig(Seat& seat);
  void FetchRemoteState(Seat& seat);
  void RetryCancels();

  const ClassConfig& config_;
  RigPoolOptions options_;
  ProcessLauncher& launcher_;
  std::function<void(const std::string&, const std::string&)> arm_stopped_;
  std::function<bool(const std::string&)> arm_involved_;
  std::atomic<int> server_port_{0};
  // cluster: the engine the rigs run on as jobs, the jobs whose scancel got no answer (tried
  // again each second), saved with the rigs for a restarted server.
  cluster::SystemRunner cluster_runner_;
  std::unique_ptr<cluster::SlurmEngine> engine_;
  std::mutex jobs_mutex_;
  std::vector<std::string> cancel_later_;
  // After the engine: a seat's job refers to it.
  std::map<std::string, std::unique_ptr<Seat>> seats_;
  std::atomic<int> running_{0};
  std::mutex start_mutex_;  // counts rigs against max_rigs
  // limits.pin_rigs: the CPUs this server may use (its affinity when it starts) and how many
  // rigs run on each; under start_mutex_. Empty: nothing is pinned.
  std::vector<int> cpus_;
  std::vector<int> rigs_on_cpu_;
  std::thread monitor_;
  mutable std::mutex monitor_mutex_;
  std::condition_variable monitor_wake_;
  bool stopping_ = false;
};

}  // namespace sirupp::classroom
