#pragma once
// The class file's `cluster:` key: where a class's rigs and grading run when they are jobs on a
// cluster rather than processes of the class server (absent: processes, as before). Read strictly
// like the rest of the class file: a mistake is one core::ConfigError at file:line:column.
//
//   cluster:
//     engine: slurm                   # the only engine so far
//     partition: class                # default: the cluster's default partition
//     account: robotics               # default: the submitting user's default account
//     rig: {time_limit_min: 480, cpus: 1, memory_mb: 2048}       # one job per running rig
//     grading: {jobs: 2, time_limit_min: 15, cpus: 1, memory_mb: 2048}   # one job per submission
//     sbatch_args: ["--qos=class"]    # passed to every sbatch as they are
//     node_data: /shared/robotics-2026-data   # the class's data folder as the nodes see it
//     report_url: "http://web01.example.edu:8800"   # the class server as the nodes reach it
//     poll_s: 5                       # how often each job's state is asked for
//     command_timeout_s: 10           # an sbatch, squeue or scancel that takes longer: unknown

#include <optional>
#include <string>
#include <vector>

#include "core/yaml_reader.hpp"

namespace sirupp::cluster {

// The limits of one kind of job.
struct JobLimits {
  int time_limit_min = 0;  // sbatch --time
  int cpus = 1;            // --cpus-per-task
  int memory_mb = 2048;    // --mem
};

struct ClusterConfig {
  std::string engine = "slurm";
  std::string partition;  // "" = the cluster's default
  std::string account;    // "" = the user's default
  JobLimits rig{480, 1, 2048};
  JobLimits grading{15, 1, 2048};
  int grading_jobs = 2;  // grading jobs at once
  std::vector<std::string> sbatch_args;
  std::string node_data;   // absolute; "" = the class's data folder, at the same path on the nodes
  std::string report_url;  // "" = the class server's own address (class file server:)
  double poll_s = 5;
  double command_timeout_s = 10;
};

// The keys `cluster:` allows, for the class file's reader.
const std::vector<std::string>& ClusterKeys();

// Reads the value of `cluster:`. Throws core::ConfigError at the bad key or value.
ClusterConfig ReadClusterConfig(const core::YamlValue& value);

}  // namespace sirupp::cluster
