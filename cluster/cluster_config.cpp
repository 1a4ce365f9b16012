#include "cluster/cluster_config.hpp"

#include <algorithm>
#include <filesystem>

namespace sirupp::cluster {
namespace {

const std::vector<std::string> kKeys = {"engine",  "partition",        "account",   "rig",
                                        "grading", "sbatch_args",      "node_data", "report_url",
                                        "poll_s",  "command_timeout_s"};
const std::vector<std::string> kRigKeys = {"time_limit_min", "cpus", "memory_mb"};
const std::vector<std::string> kGradingKeys = {"jobs", "time_limit_min", "cpus", "memory_mb"};

// sbatch options the other keys set (or that would break the job's handling): refused in
// sbatch_args, naming the key that sets it.
struct Owned {
  std::vector<std::string> spellings;
  std::string by;
};
const std::vector<Owned> kOwned = {
    {{"--job-name", "-J"}, "the class server (one name per rig or submission)"},
    {{"--output", "-o", "--error", "-e"},
     "the class server (the job's log in the student's folder)"},
    {{"--chdir", "-D"}, "the class server"},
    {{"--partition", "-p"}, "cluster.partition"},
    {{"--account", "-A"}, "cluster.account"},
    {{"--time", "-t"}, "cluster.rig.time_limit_min and cluster.grading.time_limit_min"},
    {{"--cpus-per-task", "-c"}, "cluster.rig.cpus and cluster.grading.cpus"},
    {{"--mem", "--mem-per-cpu", "--mem-per-gpu"},
     "cluster.rig.memory_mb and cluster.grading.memory_mb"},
    {{"--nodes", "-N", "--ntasks", "-n"}, "the class server (one task on one node per job)"},
    {{"--requeue", "--no-requeue"},
     "the class server (a grading job lost with its node is submitted once more by it)"},
    {{"--parsable", "--wrap", "--array", "-a", "--wait", "-W"},
     "the class server (one plain job, its id read back at once)"}};

// The option's name in an argument ("--mem=2G" -> "--mem", "-c4" -> "-c").
std::string OptionName(const std::string& arg) {
  if (arg.rfind("--", 0) == 0) return arg.substr(0, arg.find('='));
  return arg.substr(0, 2);
}

JobLimits ReadLimits(const core::YamlValue& value, const std::vector<std::string>& keys,
                     JobLimits limits, int* jobs) {
  const core::YamlMap map = value.Map(keys);
  if (const auto v = map.Find("time_limit_min")) {
    limits.time_limit_min = static_cast<int>(v->Integer(1, 525600));
  }
  if (const auto v = map.Find("cpus")) limits.cpus = static_cast<int>(v->Integer(1, 256));
  if (const auto v = map.Find("memory_mb")) {
    limits.memory_mb = static_cast<int>(v->Integer(256, 1 << 22));
  }
  if (jobs != nullptr) {
    if (const auto v = map.Find("jobs")) *jobs = static_cast<int>(v->Integer(1, 1000));
  }
  return limits;
}

}  // namespace

const std::vector<std::string>& ClusterKeys() { return kKeys; }

ClusterConfig ReadClusterConfig(const core::YamlValue& value) {
  ClusterConfig config;
  const core::YamlMap map = value.Map(kKeys);
  config.engine = map.Get("engine", "the engine the jobs run on (slurm)").Choice({"slurm"});
  for (const char* key : {"partition", "account"}) {
    if (const auto v = map.Find(key)) {
      const std::string text = v->String();
      if (text.size() > 64 || text.find_first_of(" \t\n'\"$`\\;|&<>") != std::string::npos ||
          text[0] == '-') {
        v->Fail("'" + text.substr(0, 64) + "' is not a Slurm " + key +
                " name; allowed: up to 64 characters, no spaces, quotes or shell characters, not "
                "starting with '-'");
      }
      (std::string(key) == "partition" ? config.partition : config.account) = text;
    }
  }
  if (const auto v = map.Find("rig")) config.rig = ReadLimits(*v, kRigKeys, config.rig, nullptr);
  if (const auto v = map.Find("grading")) {
    config.grading = ReadLimits(*v, kGradingKeys, config.grading, &config.grading_jobs);
  }
  if (const auto v = map.Find("sbatch_args")) {
    for (const core::YamlValue& entry : v->Sequence(0, 64)) {
      const std::string arg = entry.String();
      if (arg[0] != '-' || arg == "-" || arg == "--") {
        entry.Fail("'" + arg.substr(0, 64) +
                   "' is not an sbatch option; expected one like --qos=class (an option and its "
                   "value in one entry)");
      }
      const std::string name = OptionName(arg);
      for (const Owned& owned : kOwned) {
        if (std::find(owned.spellings.begin(), owned.spellings.end(), name) !=
            owned.spellings.end()) {
          entry.Fail("'" + arg.substr(0, 64) + "': " + name + " is set by " + owned.by +
                     "; remove it from sbatch_args");
        }
      }
      config.sbatch_args.push_back(arg);
    }
  }
  if (const auto v = map.Find("node_data")) {
    const std::string path = v->String();
    if (!std::filesystem::path(path).is_absolute()) {
      v->Fail("'" + path +
              "' is not an absolute path; node_data is the class's data folder as "
              "the nodes see it (a shared filesystem), e.g. /shared/robotics-2026-data");
    }
    config.node_data = std::filesystem::path(path).lexically_normal().string();
    while (config.node_data.size() > 1 && config.node_data.back() == '/') {
      config.node_data.pop_back();
    }
  }
  if (const auto v = map.Find("report_url")) {
    std::string url = v->String();
    if (url.rfind("http://", 0) != 0 && url.rfind("https://", 0) != 0) {
      v->Fail("'" + url +
              "' is not an address; expected http://HOST[:PORT] or https://... (the "
              "class server as the nodes reach it)");
    }
    while (!url.empty() && url.back() == '/') url.pop_back();
    config.report_url = url;
  }
  config.poll_s = map.NumberOr("poll_s", config.poll_s, core::NumberInRange(0.2, 600, "s"));
  config.command_timeout_s =
      map.NumberOr("command_timeout_s", config.command_timeout_s, core::NumberInRange(1, 300, "s"));
  return config;
}

}  // namespace sirupp::cluster
