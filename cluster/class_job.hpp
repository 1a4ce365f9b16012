#pragma once
// A class's jobs as the class server and `sirupp grade --batch DIR --cluster FILE` submit them: a
// student's rig (class/rig_spawner.cpp) and a grading (class/submissions.cpp,
// tools/grade_cluster.cpp). Every one goes to the class file's partition and account with its
// limits and the extra sbatch arguments, and with --no-requeue: a job lost with its node ends
// NODE_FAIL instead of being run again by Slurm (JobRequeue), where a rig would report to a
// server that saw it end. For grading the rule is then the graders' own: submitted once more, and
// failed when lost twice (AfterGradingJob).

#include <string>

#include "cluster/cluster_config.hpp"
#include "cluster/slurm_engine.hpp"

namespace sirupp::cluster {

// The request for one of the class's jobs with `limits` (the class file's `rig:` or `grading:`).
JobRequest ClassJobRequest(const ClusterConfig& config, const JobLimits& limits,
                           const std::string& name, const std::string& script,
                           const std::string& output_file);

// The request for one grading job (`grading:`). `exec_line` is the script's command, one line of sh
// that execs the grader (proc::ExecLine), so the job's process is the grader itself and scancel's
// signal reaches it (a shell in between would die first and leave the grader to the process
// tracking). `comment` is the script's second line, for whoever reads the job (scontrol write
// batch_script).
JobRequest GradingJobRequest(const ClusterConfig& config, const std::string& name,
                             const std::string& comment, const std::string& exec_line,
                             const std::string& output_file);

enum class GradingNext {
  kGraded,  // COMPLETED: the job wrote its result
  kAgain,   // lost with its node on the first try: submit it once more
  kFailed,  // anything else: `problem` says why
};

struct GradingEnd {
  GradingNext next = GradingNext::kFailed;
  // kFailed: "the grading job ended: <Slurm's reason>" (" (twice)" when lost both times); empty
  // for FAILED, where the grader's own last line says why (the caller reads the job's log).
  std::string problem;
};

// What to do about a grading job that ended (status.state == kEnded) on try `attempt` (1, 2).
GradingEnd AfterGradingJob(const JobStatus& status, int attempt);

}  // namespace sirupp::cluster
