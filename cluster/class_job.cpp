#include "cluster/class_job.hpp"

namespace sirupp::cluster {

JobRequest ClassJobRequest(const ClusterConfig& config, const JobLimits& limits,
                           const std::string& name, const std::string& script,
                           const std::string& output_file) {
  JobRequest request;
  request.name = name;
  request.script = script;
  request.output_file = output_file;
  request.partition = config.partition;
  request.account = config.account;
  request.time_limit_min = limits.time_limit_min;
  request.cpus = limits.cpus;
  request.memory_mb = limits.memory_mb;
  request.extra_args = {"--no-requeue"};
  request.extra_args.insert(request.extra_args.end(), config.sbatch_args.begin(),
                            config.sbatch_args.end());
  return request;
}

JobRequest GradingJobRequest(const ClusterConfig& config, const std::string& name,
                             const std::string& comment, const std::string& exec_line,
                             const std::string& output_file) {
  return ClassJobRequest(config, config.grading, name,
                         "#!/bin/sh\n# " + comment + "\n" + exec_line + "\n", output_file);
}

GradingEnd AfterGradingJob(const JobStatus& status, int attempt) {
  if (status.slurm_state == "COMPLETED") return {GradingNext::kGraded, ""};
  const bool lost = LostWithItsNode(status);
  if (lost && attempt == 1) return {GradingNext::kAgain, ""};
  if (status.slurm_state == "FAILED") return {GradingNext::kFailed, ""};
  return {GradingNext::kFailed,
          "the grading job ended: " + status.reason + (lost ? " (twice)" : "")};
}

}  // namespace sirupp::cluster
