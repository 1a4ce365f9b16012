#pragma once
// Where a submission's grade runs, behind one interface, as the class's rigs are (the same
// factory decides both: class/rig_spawner.hpp, MakeRigSpawnerFactory). The submissions' service
// (class/submissions.hpp) queues and records grades; a place only runs `sirupp grade`:
//
//   LocalGradePlace  this server's child process, niced below the rigs, one at a time, killed at
//                    the time limit
//   SlurmGradePlace  one Slurm job per grade (cluster.grading: time, CPUs, memory),
//                    cluster.grading.jobs at once; a job lost with its node is submitted once more;
//                    the job is recorded in the submission (GradeHooks::save) so a restarted server
//                    takes it back (TakeBack) instead of grading twice
//
// Reads: the grade's command line and log file. Writes: what `sirupp grade` writes; the
// submission's record through the hooks.

#include <sys/types.h>

#include <functional>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "cluster/cluster_config.hpp"
#include "cluster/slurm_engine.hpp"
#include "proc/child.hpp"

namespace sirupp::classroom {

// One grading run of a submission.
struct GradeTask {
  std::string student;
  int id = 0;
  std::vector<std::string> argv;  // sirupp grade ... (paths as this server sees them)
  std::string log_file;           // its output
  // What TakeBack made of the record a previous server saved: the run to take back, not start.
  std::optional<nlohmann::json> taken_back;
};

// How one grading run ended: ok (sirupp grade exited 0), or the problem in words.
struct GradeRun {
  bool ok = false;
  bool stopped = false;  // by Stop(): graded again at the next start
  std::string problem;
};

// What a place tells the service while it grades.
struct GradeHooks {
  std::function<void(const std::string& line)> log;
  // The record a restarted server needs (kept in the submission's meta.json), and its end.
  std::function<void(const std::string& student, int id, const nlohmann::json& record)> save;
  std::function<void(const std::string& student, int id)> clear;
};

class GradePlace {
 public:
  virtual ~GradePlace() = default;
  // Grades at once.
  virtual int Slots() const = 0;
  // A record a previous server saved (GradeHooks::save) as the run to take back, or nullopt when
  // there is nothing of it to take back here.
  virtual std::optional<nlohmann::json> TakeBack(const nlohmann::json& record) const = 0;
  // Runs (or takes back) one grade and waits for its end. Thread-safe: Slots() at once.
  virtual GradeRun Grade(const GradeTask& task) = 0;
  // Kills or cancels what runs; a Grade in progress returns (stopped). Safe to call twice.
  virtual void Stop() = 0;
};

struct LocalGradeOptions {
  int nice = 10;  // above the rigs' rig_nice
  double time_limit_s = 1800;
};

class LocalGradePlace : public GradePlace {
 public:
  LocalGradePlace(LocalGradeOptions options, proc::Launcher& launcher);
  int Slots() const override { return 1; }
  std::optional<nlohmann::json> TakeBack(const nlohmann::json&) const override {
    return std::nullopt;  // a child of a stopped server ended with it
  }
  GradeRun Grade(const GradeTask& task) override;
  void Stop() override;

 private:
  LocalGradeOptions options_;
  proc::Launcher& launcher_;
  std::mutex mutex_;
  pid_t pid_ = 0;
  bool stopped_ = false;
};

class SlurmGradePlace : public GradePlace {
 public:
  // `data_dir`: the class's data folder as this server sees it (cluster.node_data on the nodes).
  SlurmGradePlace(cluster::SlurmEngine& engine, cluster::ClusterConfig config, std::string data_dir,
                  GradeHooks hooks);
  int Slots() const override { return config_.grading_jobs; }
  // {"id": JOB, "attempt": 1|2} as Grade saved it; nullopt when it names no job.
  std::optional<nlohmann::json> TakeBack(const nlohmann::json& record) const override;
  GradeRun Grade(const GradeTask& task) override;
  void Stop() override;

 private:
  bool Stopping();
  cluster::SlurmEngine& engine_;
  cluster::ClusterConfig config_;
  std::string data_dir_;
  GradeHooks hooks_;
  std::mutex mutex_;
  bool stopped_ = false;
  std::vector<std::string> jobs_;  // in progress, cancelled by Stop()
};

}  // namespace sirupp::classroom
