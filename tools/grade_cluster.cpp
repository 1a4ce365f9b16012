#include "tools/grade_cluster.hpp"

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <optional>
#include <ostream>
#include <sstream>
#include <thread>

#include "class/class_config.hpp"
#include "cluster/class_job.hpp"
#include "cluster/command_runner.hpp"
#include "cluster/slurm_engine.hpp"
#include "core/errors.hpp"
#include "core/yaml_reader.hpp"
#include "grade/result_file.hpp"
#include "proc/child.hpp"
#include "runtime/process_main.hpp"

namespace sirupp::tools {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

// The cluster: keys that only the class server uses: refused in a file made for sirupp grade.
const std::vector<std::string> kServerOnlyKeys = {"rig", "node_data", "report_url"};

std::string LastLine(const std::string& file) {
  std::ifstream in(file);
  std::string last;
  for (std::string line; std::getline(in, line);) {
    if (line.find_first_not_of(" \t\r") != std::string::npos) last = line;
  }
  return last;
}

// One job of the batch: a submission, or the baseline.
struct Part {
  std::string name;    // the sub-folder's name ("baseline" for the baseline)
  std::string folder;  // the submission's folder; "" for the baseline
  bool baseline = false;
  std::string dir;  // ClusterPartFolder
  std::string job_id;
  int attempt = 0;
  bool unknown_said = false;
  Clock::time_point submitted{};
  std::string problem;                    // why it gave no result
  std::optional<grade::ReadResult> read;  // what it gave
};

class Batch {
 public:
  Batch(const ClusterBatch& batch, const grade::Suite& suite, const core::RobotModel& model,
        std::ostream& err)
      : batch_(batch),
        suite_(suite),
        model_(model),
        err_(err),
        engine_(runner_, SlurmOptionsOf(batch.cluster)) {}

  ClusterBatchResult Run(std::vector<Part>& parts) {
    ClusterBatchResult result;
    runtime::InstallStopHandlers();
    std::vector<size_t> waiting;
    for (size_t i = 0; i < parts.size(); ++i) waiting.push_back(i);
    std::reverse(waiting.begin(), waiting.end());  // taken from the back: the first part first
    std::vector<size_t> flying;
    const size_t at_once = static_cast<size_t>(std::max(1, batch_.cluster.grading_jobs));
    while (!waiting.empty() || !flying.empty()) {
      if (runtime::StopRequested()) {
        for (const size_t i : flying) Cancel(parts[i]);
        err_ << "grade: stopped; " << flying.size() << " grading job(s) cancelled\n";
        result.stopped = true;
        return result;
      }
      while (flying.size() < at_once && !waiting.empty()) {
        const size_t i = waiting.back();
        waiting.pop_back();
        if (Submit(parts[i])) flying.push_back(i);
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(500));
      for (auto it = flying.begin(); it != flying.end();) {
        if (Poll(parts[*it])) {
          it = flying.erase(it);
        } else {
          ++it;
        }
      }
    }
    return result;
  }

 private:
  static cluster::SlurmOptions SlurmOptionsOf(const cluster::ClusterConfig& config) {
    cluster::SlurmOptions options;
    options.command_timeout_s = config.command_timeout_s;
    return options;
  }

  // Submits the part's job; false (with its problem) when the cluster refused it.
  bool Submit(Part& part) {
    ++part.attempt;
    fs::create_directories(part.dir);
    const std::string result_file = part.dir + "/result";
    const std::string log_file = part.dir + "/job.log";
    std::error_code ignored;
    fs::remove(result_file, ignored);  // never a result of an earlier run
    fs::remove(log_file, ignored);
    proc::ProcessSpec grading;
    grading.argv = {batch_.bin_dir + "/sirupp",
                    "grade",
                    "--cluster-part",
                    part.baseline ? std::string("baseline") : part.folder,
                    "--cluster-result",
                    result_file,
                    "--suite",
                    batch_.suite_file,
                    "--out",
                    batch_.out_dir,
                    "-j",
                    std::to_string(batch_.jobs)};
    if (!batch_.sandbox) grading.argv.push_back("--no-sandbox");
    const cluster::JobRequest request = cluster::GradingJobRequest(
        batch_.cluster, "sirupp-grade-batch-" + part.name,
        "sirupp grade --batch " + batch_.batch_dir +
            " --cluster: " + (part.baseline ? "the baseline" : "submission " + part.name),
        proc::ExecLine(grading), log_file);
    const cluster::SubmitResult submitted = engine_.Submit(request);
    if (!submitted.ok()) {
      part.problem = "the cluster refused the grading job: " + submitted.error;
      err_ << "grade: " << part.name << ": " << part.problem << "\n";
      return false;
    }
    part.job_id = submitted.job_id;
    part.unknown_said = false;
    part.submitted = Clock::now();
    err_ << "grade: " << part.name << ": Slurm job " << part.job_id
         << (part.attempt > 1 ? " (submitted once more)" : "") << "\n";
    return true;
  }

  void Cancel(Part& part) {
    const std::string error = engine_.Cancel(part.job_id);
    if (!error.empty()) err_ << "grade: " << part.name << ": " << error << "\n";
  }

  // Polls the part's job; true once the part is done (a result or a problem).
  bool Poll(Part& part) {
    const cluster::JobStatus status = engine_.Poll(part.job_id);
    if (status.state == cluster::JobState::kUnknown) {
      if (!part.unknown_said) {
        err_ << "grade: " << part.name << ": Slurm job " << part.job_id << ": state unknown ("
             << status.reason << "); waiting\n";
        part.unknown_said = true;
      }
      return false;
    }
    if (status.state != cluster::JobState::kEnded) return false;
    const double seconds = std::chrono::duration<double>(Clock::now() - part.submitted).count();
    const std::string log_file = part.dir + "/job.log";
    const cluster::GradingEnd end = cluster::AfterGradingJob(status, part.attempt);
    if (end.next == cluster::GradingNext::kGraded) {
      try {
        part.read = grade::ReadResultFile(part.dir + "/result", suite_, model_);
        err_ << "grade: " << part.name << ": graded as Slurm job " << part.job_id << " in "
             << static_cast<int>(seconds) << " s\n";
      } catch (const std::exception& e) {
        part.problem = std::string("the grading job gave no result: ") + e.what();
        err_ << "grade: " << part.name << ": " << part.problem << "\n";
      }
      return true;
    }
    if (end.next == cluster::GradingNext::kAgain) {
      err_ << "grade: " << part.name << ": Slurm job " << part.job_id << ": " << status.reason
           << "; submitted once more\n";
      Cancel(part);  // gone with its node already; nothing of it may write on
      return !Submit(part);
    }
    part.problem = end.problem;
    if (part.problem.empty()) {  // FAILED: sirupp grade's own last line says why
      const std::string last = LastLine(log_file);
      part.problem = "the grading job failed: " + (last.empty() ? status.reason : last);
    }
    err_ << "grade: " << part.name << ": " << part.problem << " (its log: " << log_file << ")\n";
    return true;
  }

  const ClusterBatch& batch_;
  const grade::Suite& suite_;
  const core::RobotModel& model_;
  std::ostream& err_;
  cluster::SystemRunner runner_;
  cluster::SlurmEngine engine_;
};

}  // namespace

cluster::ClusterConfig ReadGradeCluster(const std::string& file) {
  const core::YamlDocument document = core::YamlDocument::Load(file);
  const core::YamlValue root = document.Root();
  if (root.node().IsMap() &&
      root.node()["class"]) {  // a class file: read whole, as the class server would
    const classroom::ClassConfig config = classroom::LoadClassConfig(file);
    if (!config.cluster) {
      throw core::UsageError("grade: --cluster " + file +
                             ": the class file has no cluster: key (docs/cluster.md)");
    }
    return *config.cluster;
  }
  const core::YamlMap top = root.Map({"cluster"});
  const core::YamlValue value =
      top.Get("cluster", "the cluster the submissions are graded on (docs/cluster.md)");
  const core::YamlMap keys = value.Map(cluster::ClusterKeys());
  for (const std::string& key : kServerOnlyKeys) {
    if (const auto found = keys.Find(key)) {
      found->Fail(key +
                  " is the class server's (sirupp class serve); sirupp grade --batch uses "
                  "engine, partition, account, grading, sbatch_args, poll_s and "
                  "command_timeout_s: remove it");
    }
  }
  return cluster::ReadClusterConfig(value);
}

std::string ClusterPartFolder(const std::string& out_dir, const std::string& name, bool baseline) {
  return out_dir + (baseline ? "/cluster/baseline" : "/cluster/submissions/" + name);
}

ClusterBatchResult GradeBatchOnCluster(const ClusterBatch& batch, const grade::Suite& suite,
                                       const core::RobotModel& model, std::ostream& err) {
  std::vector<fs::path> folders;
  for (const fs::directory_entry& entry : fs::directory_iterator(batch.batch_dir)) {
    if (entry.is_directory()) folders.push_back(entry.path());
  }
  std::sort(folders.begin(), folders.end());
  std::vector<Part> parts;
  if (batch.baseline) {
    Part part;
    part.name = "baseline";
    part.baseline = true;
    part.dir = ClusterPartFolder(batch.out_dir, part.name, true);
    parts.push_back(part);
  }
  for (const fs::path& folder : folders) {
    Part part;
    part.name = folder.filename().string();
    part.folder = fs::absolute(folder).string();
    part.dir = ClusterPartFolder(batch.out_dir, part.name, false);
    parts.push_back(part);
  }
  Batch runner(batch, suite, model, err);
  ClusterBatchResult result = runner.Run(parts);
  if (result.stopped) return result;
  for (const Part& part : parts) {
    if (part.baseline) continue;
    grade::Submission submission;
    submission.name = part.name;
    if (part.read && part.read->problem.empty()) {
      result.graded.push_back(result.results.size());
      result.results.push_back(part.read->result);
    } else {
      submission.problem = part.read ? part.read->problem : part.problem;
      result.graded.push_back(static_cast<size_t>(-1));
    }
    result.submissions.push_back(submission);
  }
  if (batch.baseline) {
    const Part& part = parts.front();
    if (part.read && part.read->problem.empty()) {
      result.results.push_back(part.read->result);
      result.has_baseline = true;
    } else {
      result.baseline_problem = part.read ? part.read->problem : part.problem;
    }
  }
  return result;
}

}  // namespace sirupp::tools
