#include "cluster/slurm_engine.hpp"

#include <algorithm>
#include <map>

namespace sirupp::cluster {
namespace {

std::string Trim(const std::string& text) {
  const size_t start = text.find_first_not_of(" \t\r\n");
  if (start == std::string::npos) return "";
  const size_t end = text.find_last_not_of(" \t\r\n");
  return text.substr(start, end - start + 1);
}

bool Contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

const std::vector<std::string> kPending = {"PENDING",      "CONFIGURING", "REQUEUED",
                                           "REQUEUE_HOLD", "REQUEUE_FED", "RESIZING",
                                           "SUSPENDED",    "STOPPED",     "RESV_DEL_HOLD"};
const std::vector<std::string> kRunning = {"RUNNING", "COMPLETING", "SIGNALING", "STAGE_OUT"};
const std::vector<std::string> kEnded = {"COMPLETED", "CANCELLED",     "FAILED",    "TIMEOUT",
                                         "NODE_FAIL", "OUT_OF_MEMORY", "PREEMPTED", "BOOT_FAIL",
                                         "DEADLINE",  "SPECIAL_EXIT",  "REVOKED"};

bool In(const std::vector<std::string>& list, const std::string& word) {
  return std::find(list.begin(), list.end(), word) != list.end();
}

}  // namespace

const char* JobStateName(JobState state) {
  switch (state) {
    case JobState::kPending:
      return "pending";
    case JobState::kRunning:
      return "running";
    case JobState::kEnded:
      return "ended";
    case JobState::kUnknown:
      return "unknown";
  }
  return "unknown";
}

bool LostWithItsNode(const JobStatus& status) {
  return status.state == JobState::kEnded &&
         (status.slurm_state == "NODE_FAIL" || status.slurm_state == "BOOT_FAIL" ||
          status.slurm_state == "PREEMPTED");
}

bool IsJobId(const std::string& text) {
  return !text.empty() && text.size() <= 20 &&
         std::all_of(text.begin(), text.end(), [](char c) { return c >= '0' && c <= '9'; });
}

std::string EndedReason(const std::string& slurm_state, const std::string& slurm_reason) {
  static const std::map<std::string, std::string> kWords = {
      {"COMPLETED", "the job ended by itself"},
      {"CANCELLED", "the job was cancelled (scancel: the class server, or the cluster's staff)"},
      {"FAILED", "the job's program failed"},
      {"TIMEOUT", "the job reached its time limit"},
      {"NODE_FAIL", "the node the job ran on failed"},
      {"OUT_OF_MEMORY", "the job ran out of memory (its --mem limit)"},
      {"PREEMPTED", "the job was preempted by another"},
      {"BOOT_FAIL", "the node could not boot for the job"},
      {"DEADLINE", "the job passed its deadline"},
      {"SPECIAL_EXIT", "the job ended in Slurm's special exit state"},
      {"REVOKED", "the job was revoked (federation)"}};
  const auto found = kWords.find(slurm_state);
  std::string text = found == kWords.end() ? "the job ended" : found->second;
  text += " (Slurm: " + slurm_state;
  if (!slurm_reason.empty() && slurm_reason != "None") text += ", " + slurm_reason;
  return text + ")";
}

JobStatus ParseSqueueLine(const std::string& line) {
  JobStatus status;
  const std::string text = Trim(line);
  const size_t first = text.find('|');
  const size_t second = first == std::string::npos ? first : text.find('|', first + 1);
  if (second == std::string::npos) {
    status.reason = "squeue printed '" + text.substr(0, 120) + "', not STATE|REASON|HOST";
    return status;
  }
  status.slurm_state = text.substr(0, first);
  // squeue may add a reason's detail after the state ("CANCELLED by 0"): the first word counts.
  status.slurm_state = status.slurm_state.substr(0, status.slurm_state.find(' '));
  const std::string reason = text.substr(first + 1, second - first - 1);
  const std::string host = text.substr(second + 1);
  if (In(kPending, status.slurm_state)) {
    status.state = JobState::kPending;
    status.reason = reason.empty() || reason == "None" ? status.slurm_state : reason;
  } else if (In(kRunning, status.slurm_state)) {
    status.state = JobState::kRunning;
    status.host = host == "n/a" || host == "(null)" ? "" : host;
  } else if (In(kEnded, status.slurm_state)) {
    status.state = JobState::kEnded;
    status.reason = EndedReason(status.slurm_state, reason);
  } else {
    status.reason = "Slurm state '" + status.slurm_state.substr(0, 40) + "' is not one this knows";
  }
  return status;
}

SlurmEngine::SlurmEngine(CommandRunner& runner, SlurmOptions options)
    : runner_(runner), options_(std::move(options)) {}

std::vector<std::string> SlurmEngine::SubmitCommand(const JobRequest& request) const {
  std::vector<std::string> argv = {options_.sbatch, "--parsable"};
  if (!request.name.empty()) argv.push_back("--job-name=" + request.name);
  if (!request.output_file.empty()) argv.push_back("--output=" + request.output_file);
  if (!request.work_dir.empty()) argv.push_back("--chdir=" + request.work_dir);
  if (!request.partition.empty()) argv.push_back("--partition=" + request.partition);
  if (!request.account.empty()) argv.push_back("--account=" + request.account);
  if (request.time_limit_min > 0)
    argv.push_back("--time=" + std::to_string(request.time_limit_min));
  argv.push_back("--nodes=1");
  argv.push_back("--ntasks=1");
  argv.push_back("--cpus-per-task=" + std::to_string(std::max(1, request.cpus)));
  if (request.memory_mb > 0) argv.push_back("--mem=" + std::to_string(request.memory_mb) + "M");
  argv.insert(argv.end(), request.extra_args.begin(), request.extra_args.end());
  return argv;
}

SubmitResult SlurmEngine::Submit(const JobRequest& request) {
  SubmitResult result;
  const CommandResult run =
      runner_.Run(SubmitCommand(request), request.script, options_.command_timeout_s);
  if (!run.Succeeded()) {
    result.error = run.Describe("sbatch");
    return result;
  }
  const std::string printed = Trim(run.out);
  // --parsable prints "ID" or "ID;CLUSTER" on its last line (warnings may come before it).
  const std::string last = Trim(printed.substr(
      printed.find_last_of('\n') == std::string::npos ? 0 : printed.find_last_of('\n') + 1));
  if (!IsJobId(last.substr(0, last.find(';')))) {
    result.error = "sbatch printed '" + printed.substr(0, 120) + "', not a job id";
    return result;
  }
  result.job_id = last.substr(0, last.find(';'));
  return result;
}

JobStatus SlurmEngine::Poll(const std::string& job_id, const std::string& end_record) {
  JobStatus status;
  if (!IsJobId(job_id)) {
    status.reason = "'" + job_id.substr(0, 40) + "' is not a Slurm job id";
    return status;
  }
  const CommandResult run = runner_.Run(
      {options_.squeue, "--noheader", "--states=all", "--jobs=" + job_id, "--format=%T|%r|%B"}, "",
      options_.command_timeout_s);
  const bool forgotten = run.started && !run.timed_out &&
                         ((run.exit_code == 0 && Trim(run.out).empty()) ||
                          (run.exit_code != 0 && Contains(run.err, "Invalid job id specified")));
  if (forgotten) {
    status.state = JobState::kEnded;
    status.reason = end_record.empty()
                        ? "the job ended (Slurm no longer lists it, and it left no end record)"
                        : Trim(end_record);
    return status;
  }
  if (!run.Succeeded()) {
    status.reason = run.Describe("squeue");
    return status;
  }
  const std::string out = Trim(run.out);
  status = ParseSqueueLine(out.substr(0, out.find('\n')));
  if (status.state == JobState::kEnded && !end_record.empty()) {
    status.reason += "; the job's own record: " + Trim(end_record);
  }
  return status;
}

std::string SlurmEngine::Cancel(const std::string& job_id) {
  if (!IsJobId(job_id)) return "'" + job_id.substr(0, 40) + "' is not a Slurm job id";
  const CommandResult run = runner_.Run({options_.scancel, job_id}, "", options_.command_timeout_s);
  if (run.Succeeded()) return "";
  // A job that already left: nothing to cancel.
  if (run.started && !run.timed_out &&
      (Contains(run.err, "Invalid job id specified") || Contains(run.err, "already completing") ||
       Contains(run.err, "Job/step already completing or completed"))) {
    return "";
  }
  return run.Describe("scancel");
}

}  // namespace sirupp::cluster
