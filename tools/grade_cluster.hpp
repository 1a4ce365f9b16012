#pragma once
// `sirupp grade --batch DIR --cluster FILE` (docs/cluster.md, "sirupp grade --batch on the
// cluster"): each submission of the batch is graded as one cluster job, and the baseline as one
// more, with the cluster: key's grading limits (time, CPUs, memory), cluster.grading.jobs of them
// at once. A job runs `sirupp grade --cluster-part FOLDER|baseline` on its node: the same build
// and sandbox as a local batch, its whole result written to a file (grade/result_file.hpp). The
// batch's reports are then written here from those files, the same as a local batch's.
//
// A job lost with its node (NODE_FAIL, BOOT_FAIL, PREEMPTED) is submitted once more, then its
// submission is marked failed with Slurm's reason; any other end but COMPLETED (time limit,
// memory, cancelled, the program failed) marks it failed at once. A state Slurm does not give is
// waited for, never read as an end. SIGINT or SIGTERM cancels every job in flight.
//
// Paths are the same on the nodes as here (the batch, the output folder, the suite and the
// programs on a shared filesystem); cluster.node_data and report_url are the class server's.

#include <iosfwd>
#include <string>
#include <vector>

#include "cluster/cluster_config.hpp"
#include "core/robot_model.hpp"
#include "grade/grade.hpp"
#include "grade/report.hpp"
#include "grade/suite.hpp"

namespace sirupp::tools {

// FILE: a class file with its cluster: key (read whole and strictly, as `sirupp class check`
// does), or a file whose one key is cluster:. Throws core::ConfigError at file:line:column, or
// core::UsageError for a class file without cluster:.
cluster::ClusterConfig ReadGradeCluster(const std::string& file);

struct ClusterBatch {
  cluster::ClusterConfig cluster;
  std::string bin_dir;     // sirupp, at the same path on the nodes
  std::string batch_dir;   // absolute
  std::string out_dir;     // absolute
  std::string suite_file;  // absolute
  int jobs = 1;            // -j: tasks at a time within each job
  bool sandbox = true;
  bool baseline = true;
};

struct ClusterBatchResult {
  std::vector<grade::ControllerResult> results;  // the graded submissions', then the baseline's
  std::vector<grade::Submission> submissions;    // every sub-folder, by name
  std::vector<size_t> graded;                    // submissions[i] -> results (-1: a problem)
  bool has_baseline = false;                     // results.back() is the baseline
  std::string baseline_problem;                  // why the baseline's job gave no result
  bool stopped = false;                          // SIGINT or SIGTERM: every job cancelled
};

// Grades `batch` on the cluster (see above); progress and problems go to `err`.
ClusterBatchResult GradeBatchOnCluster(const ClusterBatch& batch, const grade::Suite& suite,
                                       const core::RobotModel& model, std::ostream& err);

// Where a part's files go: OUT/cluster/baseline/ or OUT/cluster/submissions/NAME/ (result, the
// job's log, the tasks' logs).
std::string ClusterPartFolder(const std::string& out_dir, const std::string& name, bool baseline);

}  // namespace sirupp::tools
