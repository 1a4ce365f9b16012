#pragma once
// The class's rig pool: every student's rig over its whole life, in one place. The class server's
// routes (class/class_server.cpp) only ask it. It is a hub that never asks which kind of rig it
// has: where a rig runs is a RigSpawner (class/rig_spawner.hpp) made by the class's
// RigSpawnerFactory (MakeRigSpawnerFactory: this server's processes, or Slurm jobs with the class
// file's cluster: key), and everything the pool does goes through that interface.
//
//   Ensure        a student's first visit (or their "start", the teacher's start): starts the rig
//                 unless it runs, counted against limits.max_rigs (TakeRigPlace); running when
//                 the spawner's Start says so (a local rig), else pending until it reports
//                 (Reported)
//   Stop          the teacher's stop, a restart's first half, a rig switching controller
//   monitor       (1 Hz thread, StartMonitor; one pass is MonitorPass): polls each rig through its
//                 spawner (at most every PollIntervalS), stops a rig that ended with the reason
//                 (failed), shows pending and unknown with why, samples CPU, refreshes a rig's
//                 live state, stops rigs idle past limits.idle_timeout_s, retries stops the
//                 spawner did not finish
//   reattach      the constructor takes back the rigs the factory saved for a previous server
//                 (Load/Restore: a Slurm class's DATA/cluster/rigs.json); every start, stop and
//                 report saves them again
//   BeginStop,    the class server's stop: no new rig starts, the monitor ends; then every rig
//   StopAll       is stopped
//
// Time is the pool's clock (RigPoolOptions::clock, the steady clock by default), so a test drives
// idle timeouts and poll intervals without sleeping. What the pages show of a rig (SeatJson,
// Access) is read here too, so the state names (RigPhaseName) have one source.

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
#include "class/rig_spawner.hpp"

namespace sirupp::classroom {

// A student's folder in the class's data folder (class_server.hpp has the same).
std::string StudentFolder(const ClassConfig& config, const std::string& name);

struct RigPoolOptions {
  std::string bin_dir;     // the rigs' programs (and sirupp-rig-job)
  std::string config_dir;  // the config/ copied into a new student's folder
  // The controller a student's rig runs ("" = the built-in law; class/submissions.hpp).
  std::function<std::string(const std::string& student)> controller;
  std::function<void(const std::string& line)> log;
  // The pool's clock (idle time, poll intervals, start times); the steady clock when empty.
  std::function<std::chrono::steady_clock::time_point()> clock;
};

// What the routes need of a rig to answer a request: how to reach it, or why it cannot be.
struct RigAccess {
  std::shared_ptr<RigPanel> panel;      // a rig's panel in this process
  std::optional<RigEndpoint> endpoint;  // a rig's endpoint on a node, once it reported
  RigPhase phase = RigPhase::kStopped;  // as in SeatJson
  std::string waiting;                  // pending or unknown: why
  std::string last_stop;                // why it last stopped
};

class RigPool {
 public:
  // One seat per student of `config` (which must outlive the pool), all stopped; the rigs the
  // factory saved for a previous server reattached. `spawners` must outlive the pool.
  RigPool(const ClassConfig& config, RigPoolOptions options, RigSpawnerFactory& spawners);
  // The same with the class file's own factory (MakeRigSpawnerFactory), owned by the pool.
  RigPool(const ClassConfig& config, RigPoolOptions options, ProcessLauncher& launcher);
  ~RigPool();  // BeginStop and StopAll
  RigPool(const RigPool&) = delete;
  RigPool& operator=(const RigPool&) = delete;

  // The real arm's queue (class file real_arm:): told when a rig stops; a rig it involves is not
  // idle. Set before StartMonitor.
  void SetRealArmHooks(
      std::function<void(const std::string& student, const std::string& why)> stopped,
      std::function<bool(const std::string& student)> involved);
  // The class server's port once bound (where a job reports by default).
  void SetServerPort(int port);

  bool Has(const std::string& student) const;
  std::vector<std::string> Students() const;       // sorted
  int running() const { return running_.load(); }  // rigs counted against max_rigs

  // A request from the student: their rig is in use.
  void Touch(const std::string& student);
  // Starts the student's rig unless it runs. "" or why it cannot (for a 503).
  std::string Ensure(const std::string& student);
  // Stops the student's rig, if any, saying why on the pages.
  void Stop(const std::string& student, const std::string& why);
  // A job's report (POST /cluster/report): true when `secret` and `job` are those of the rig
  // the student's seat waits for; then the rig runs at host:port, its bus on udpm_port there
  // (0: the job did not say).
  bool Reported(const std::string& student, const std::string& secret, const std::string& job,
                const std::string& host, int port, int udpm_port = 0);

  RigAccess Access(const std::string& student) const;
  // Held by the student's open event stream: the rig is not idle while it is held.
  std::shared_ptr<void> OpenStream(const std::string& student);
  // Whether a stream to `endpoint` should go on: the student's rig is still there and the server
  // is not stopping.
  bool StillAt(const std::string& student, const RigEndpoint& endpoint) const;
  // The rig's LCM address while it runs and this server reaches its bus (local), else "".
  std::string LcmUrl(const std::string& student) const;
  // Where the student's notebook server runs beside their rig (its spawner decides).
  NotebookSite Notebook(const std::string& student) const;

  // The rig as the pages show it; `live` adds the arm's state (controller, sim, estop, q, lock).
  nlohmann::json SeatJson(const std::string& student, bool live) const;

  // The monitor thread (a MonitorPass each second); false (and no thread) after BeginStop.
  bool StartMonitor();
  // One pass of the monitor at the pool's clock's now (tests call it with a test clock).
  void MonitorPass();
  // No rig starts from now on; the monitor ends. Safe to call twice.
  void BeginStop();
  bool Stopping() const;
  // Stops every rig, saying why.
  void StopAll(const std::string& why);

 private:
  struct Seat;
  using Clock = std::chrono::steady_clock;
  Clock::time_point Now() const;
  Seat* Find(const std::string& student) const;
  void Log(const std::string& line) const;
  std::string PrepareFolder(const std::string& folder) const;
  std::string TakeRigPlace();
  std::string EnsureRig(Seat& seat);
  // A start that threw: the seat failed with `why`, counted out; returns the reason.
  std::string StartFailed(Seat& seat, const std::string& why);
  void StopRig(Seat& seat, const std::string& why, bool failed = false);
  void SaveRigs();
  // One seat per student of the class file, then the rigs a previous server left taken back.
  void AddSeats();
  void Reattach();
  void Monitor();
  bool PollRig(Seat& seat, Clock::time_point now);
  void RetryStops();

  const ClassConfig& config_;
  RigPoolOptions options_;
  std::unique_ptr<RigSpawnerFactory> own_spawners_;  // when made by the pool
  RigSpawnerFactory& spawners_;
  std::function<void(const std::string&, const std::string&)> arm_stopped_;
  std::function<bool(const std::string&)> arm_involved_;
  std::atomic<int> server_port_{0};
  // The saved states of rigs whose Stop did not end them (an engine that did not answer): stopped
  // again at each monitor pass, and saved for a restarted server.
  std::mutex stops_mutex_;
  std::vector<nlohmann::json> owed_stops_;
  std::map<std::string, std::unique_ptr<Seat>> seats_;
  std::atomic<int> running_{0};
  std::mutex start_mutex_;  // counts rigs against max_rigs
  std::thread monitor_;
  mutable std::mutex monitor_mutex_;
  std::condition_variable monitor_wake_;
  bool stopping_ = false;
};

}  // namespace sirupp::classroom
