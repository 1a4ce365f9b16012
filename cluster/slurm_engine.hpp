#pragma once
// Slurm, spoken to through its command line the way JupyterHub's BatchSpawner does: sbatch
// --parsable to submit, squeue to poll, scancel to cancel. Every command runs with a time limit
// through a CommandRunner (fake in unit tests). What it reads back is one of four states:
//
//   pending  PENDING, CONFIGURING, REQUEUED, RESIZING, SUSPENDED: with Slurm's reason (Resources,
//            Priority, ...), so a page can say why it waits
//   running  RUNNING, COMPLETING: with the node it runs on
//   ended    a final state (COMPLETED, CANCELLED, TIMEOUT, NODE_FAIL, OUT_OF_MEMORY, FAILED, ...)
//            while Slurm still lists the job (`squeue -t all`, MinJobAge), or Slurm answered that
//            it does not know the job any more; then the job's own end record, when it wrote one
//   unknown  squeue failed, timed out, or printed what is not understood: never read as ended, so
//            a controller that does not answer stops nothing (BatchSpawner's issues 174 and 315)

#include <optional>
#include <string>
#include <vector>

#include "cluster/command_runner.hpp"

namespace sirupp::cluster {

// One job to submit. The script is a shell script (first line #!...), given to sbatch on its
// standard input, so nothing lands in a file before the job exists.
struct JobRequest {
  std::string name;         // --job-name
  std::string script;       // the batch script
  std::string output_file;  // --output (the job's standard output and error); "" = Slurm's default
  std::string work_dir;     // --chdir; "" = sbatch's own
  std::string partition;    // "" = the cluster's default
  std::string account;      // "" = the user's default
  int time_limit_min = 0;   // --time; 0 = the partition's default
  int cpus = 1;             // --cpus-per-task
  int memory_mb = 0;        // --mem; 0 = the partition's default
  std::vector<std::string> extra_args;  // passed to sbatch as they are, before the script
};

enum class JobState { kPending, kRunning, kEnded, kUnknown };
const char* JobStateName(JobState state);  // "pending", "running", "ended", "unknown"

struct JobStatus {
  JobState state = JobState::kUnknown;
  std::string slurm_state;  // PENDING, RUNNING, TIMEOUT, ... ("" when Slurm no longer lists it)
  std::string reason;       // for people: why it waits, why it ended, or why the state is unknown
  std::string host;         // running: the node
};

struct SubmitResult {
  std::string job_id;  // "" when refused
  std::string error;   // sbatch's refusal, or why it could not be asked
  bool ok() const { return !job_id.empty(); }
};

struct SlurmOptions {
  double command_timeout_s = 10;  // each sbatch, squeue, scancel
  std::string sbatch = "sbatch";  // the programs (PATH lookup)
  std::string squeue = "squeue";
  std::string scancel = "scancel";
};

class SlurmEngine {
 public:
  SlurmEngine(CommandRunner& runner, SlurmOptions options = {});

  // The sbatch command line for `request` (without the script, which goes on standard input).
  std::vector<std::string> SubmitCommand(const JobRequest& request) const;
  SubmitResult Submit(const JobRequest& request);
  // `end_record`: the text the job wrote about its own end (a file it writes when it ends, read by
  // the caller), used when Slurm no longer lists the job; "" when there is none.
  JobStatus Poll(const std::string& job_id, const std::string& end_record = "");
  // scancel; "" when Slurm took it (a job that has already ended counts as taken), else why not.
  std::string Cancel(const std::string& job_id);

 private:
  CommandRunner& runner_;
  SlurmOptions options_;
};

// Reading squeue's line "STATE|REASON|HOST" (squeue -h -t all -j ID -o '%T|%r|%B') into a status.
// Exposed for tests.
JobStatus ParseSqueueLine(const std::string& line);

// A job that ended because its node went (NODE_FAIL, BOOT_FAIL) or another job took its place
// (PREEMPTED): not its own doing, so worth one more submission. Submitted with --no-requeue, such
// a job ends in one of these states instead of being run again by Slurm (JobRequeue).
bool LostWithItsNode(const JobStatus& status);

// What a final Slurm state means for a student or a teacher ("the job reached its time limit").
std::string EndedReason(const std::string& slurm_state, const std::string& slurm_reason);

// True for a job id: digits only ("123"; sbatch --parsable may add ";CLUSTER", dropped on submit).
bool IsJobId(const std::string& text);

}  // namespace sirupp::cluster
