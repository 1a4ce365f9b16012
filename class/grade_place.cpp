#include "class/grade_place.hpp"

#include <signal.h>
#include <sys/wait.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <thread>

#include "class/store_files.hpp"
#include "cluster/class_job.hpp"

namespace sirupp::classroom {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;
using Clock = std::chrono::steady_clock;

}  // namespace

// --- this server's child ---------------------------------------------------------------------

LocalGradePlace::LocalGradePlace(LocalGradeOptions options, proc::Launcher& launcher)
    : options_(options), launcher_(launcher) {}

// sirupp grade as this server's child: niced below the rigs, its own process group, killed at
// the time limit.
GradeRun LocalGradePlace::Grade(const GradeTask& task) {
  const auto start = Clock::now();
  proc::ProcessSpec grading;
  grading.argv = task.argv;
  grading.log_path = task.log_file;
  grading.limits.nice = options_.nice;
  grading.death_signal = SIGTERM;
  proc::Child grader;
  grader.Start(grading, 0, &launcher_);
  const pid_t pid = grader.pid();
  bool stopped = false;
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    pid_ = pid;
    stopped = stopped_;
    if (stopped) ::kill(-pid, SIGKILL);
  }
  bool timed_out = false;
  while (grader.Running()) {
    if (!timed_out &&
        std::chrono::duration<double>(Clock::now() - start).count() > options_.time_limit_s) {
      ::kill(-pid, SIGKILL);
      timed_out = true;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  proc::KillGroup(grader.group());  // anything of its group left behind
  const int status = grader.status();
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    pid_ = 0;
    stopped = stopped_;
  }
  GradeRun run;
  run.stopped = stopped;
  run.ok = !stopped && !timed_out && WIFEXITED(status) && WEXITSTATUS(status) == 0;
  if (timed_out) {
    run.problem = "grading took longer than " +
                  std::to_string(static_cast<int>(options_.time_limit_s)) + " s and was stopped";
  }
  return run;
}

void LocalGradePlace::Stop() {
  const std::lock_guard<std::mutex> lock(mutex_);
  stopped_ = true;
  if (pid_ > 0) ::kill(-pid_, SIGKILL);
}

// --- Slurm jobs ------------------------------------------------------------------------------

SlurmGradePlace::SlurmGradePlace(cluster::SlurmEngine& engine, cluster::ClusterConfig config,
                                 std::string data_dir, GradeHooks hooks)
    : engine_(engine),
      config_(std::move(config)),
      data_dir_(std::move(data_dir)),
      hooks_(std::move(hooks)) {}

std::optional<Json> SlurmGradePlace::TakeBack(const Json& record) const {
  const Json job_id = record.is_object() && record.contains("id") ? record["id"] : Json();
  const Json attempt =
      record.is_object() && record.contains("attempt") ? record["attempt"] : Json(1);
  if (!job_id.is_string() || !cluster::IsJobId(job_id.get<std::string>())) return std::nullopt;
  return Json{{"id", job_id},
              {"attempt", attempt.is_number_integer() ? std::clamp(attempt.get<int>(), 1, 2) : 1}};
}

bool SlurmGradePlace::Stopping() {
  const std::lock_guard<std::mutex> lock(mutex_);
  return stopped_;
}

void SlurmGradePlace::Stop() {
  const std::lock_guard<std::mutex> lock(mutex_);
  stopped_ = true;
  for (const std::string& job : jobs_) engine_.Cancel(job);
}

// sirupp grade as one Slurm job (cluster.grading's time, CPUs and memory), writing into the
// submission's folder on the shared filesystem. A job lost with its node (or preempted) is
// submitted once more, then the submission is marked failed with Slurm's reason. An unknown
// state is waited out (it is not an end).
GradeRun SlurmGradePlace::Grade(const GradeTask& task) {
  const std::string node_data = config_.node_data.empty() ? data_dir_ : config_.node_data;
  const auto on_nodes = [&](const std::string& path) {
    if (path.rfind(data_dir_ + "/", 0) != 0) return path;
    return node_data + path.substr(data_dir_.size());
  };
  proc::ProcessSpec grading;
  for (const std::string& word : task.argv) grading.argv.push_back(on_nodes(word));
  grading.log_path = on_nodes(task.log_file);
  const std::string& student = task.student;
  const int id = task.id;
  const cluster::JobRequest request = cluster::GradingJobRequest(
      config_, "sirupp-grade-" + student + "-" + std::to_string(id),
      student + "'s submission " + std::to_string(id) + " (sirupp class serve, cluster:)",
      proc::ExecLine(grading), on_nodes(task.log_file) + ".job");
  const std::string which = student + ": submission " + std::to_string(id);
  const std::optional<Json> resume = task.taken_back ? TakeBack(*task.taken_back) : std::nullopt;
  const int resume_attempt = resume ? (*resume)["attempt"].get<int>() : 0;
  GradeRun run;
  for (int attempt = resume ? resume_attempt : 1; attempt <= 2; ++attempt) {
    std::string job_id;
    const bool taken_back = resume && attempt == resume_attempt;
    if (taken_back) {
      job_id = (*resume)["id"].get<std::string>();
      hooks_.log(which + ": took back grading job " + job_id +
                 " (left running by the last class server)");
    } else {
      const cluster::SubmitResult submitted = engine_.Submit(request);
      if (!submitted.ok()) {
        run.problem = "the cluster refused the grading job: " + submitted.error;
        return run;
      }
      job_id = submitted.job_id;
      hooks_.save(student, id, Json{{"id", job_id}, {"attempt", attempt}});
      hooks_.log(which + " grading as Slurm job " + job_id);
    }
    {
      const std::lock_guard<std::mutex> lock(mutex_);
      jobs_.push_back(job_id);
      if (stopped_) engine_.Cancel(job_id);
    }
    cluster::JobStatus status;
    while (!Stopping()) {  // Stop() cancelled the job
      status = engine_.Poll(job_id);
      if (status.state == cluster::JobState::kEnded) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(500));
    }
    {
      const std::lock_guard<std::mutex> lock(mutex_);
      jobs_.erase(std::remove(jobs_.begin(), jobs_.end(), job_id), jobs_.end());
    }
    if (Stopping()) {
      // Cancelled by Stop(): the next start grades it again, unless the cancel was not taken
      // (then the job is still ours to take back).
      if (engine_.Cancel(job_id).empty()) hooks_.clear(student, id);
      run.stopped = true;
      return run;
    }
    if (taken_back && status.slurm_state.empty() &&
        !Json::parse(
             ReadAll((fs::path(task.log_file).parent_path() / "grade/results.json").string()),
             nullptr, false)
             .is_discarded()) {
      run.ok = true;  // ended while no server watched and Slurm has forgotten it: its result
      return run;
    }
    if (taken_back && status.slurm_state == "CANCELLED" && attempt == 1) {
      hooks_.log(which + ": grading job " + job_id +
                 " was cancelled while the class server was down; graded once more");
      continue;
    }
    const cluster::GradingEnd end = cluster::AfterGradingJob(status, attempt);
    if (end.next == cluster::GradingNext::kAgain) {
      hooks_.log(which + ": " + status.reason + "; submitted once more");
      continue;
    }
    run.ok = end.next == cluster::GradingNext::kGraded;
    run.problem = end.problem;  // "" for FAILED: sirupp grade's own last line says why
    return run;
  }
  return run;
}

}  // namespace sirupp::classroom
