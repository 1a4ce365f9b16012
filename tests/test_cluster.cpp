// cluster/: the Slurm engine's client against a fake command runner that answers from a table of
// patterns (as BatchSpawner's own tests mock sbatch and squeue): the sbatch command line, job ids,
// squeue's states mapped to pending/running/ended with their reasons, a failing or silent squeue
// read as unknown (never ended), scancel of a job that already left; the class file's cluster:
// key read strictly (file:line:column). The real SystemRunner runs real programs with a time limit.
// The same engine against a real one-node Slurm: tests/cluster/slurm_engine_live_test.cpp.

#include <gtest/gtest.h>

#include <chrono>
#include <regex>
#include <string>
#include <utility>
#include <vector>

#include "class/class_config.hpp"
#include "class/rig_spawner.hpp"
#include "cluster/class_job.hpp"
#include "cluster/cluster_config.hpp"
#include "cluster/command_runner.hpp"
#include "cluster/slurm_engine.hpp"
#include "core/errors.hpp"
#include "core/yaml_reader.hpp"

namespace sirupp::cluster {
namespace {

// Answers each command line (words joined by spaces) with the reply of the first pattern that
// matches it, and records what it was asked.
class FakeRunner : public CommandRunner {
 public:
  struct Reply {
    std::string pattern;
    CommandResult result;
  };
  std::vector<Reply> table;
  std::vector<std::string> asked;
  std::vector<std::string> inputs;

  CommandResult Run(const std::vector<std::string>& argv, const std::string& input,
                    double) override {
    std::string line;
    for (const std::string& word : argv) line += (line.empty() ? "" : " ") + word;
    asked.push_back(line);
    inputs.push_back(input);
    for (const Reply& reply : table) {
      if (std::regex_search(line, std::regex(reply.pattern))) return reply.result;
    }
    ADD_FAILURE() << "no reply for: " << line;
    return CommandResult{};
  }
};

CommandResult Ok(const std::string& out) {
  CommandResult result;
  result.started = true;
  result.exit_code = 0;
  result.out = out;
  return result;
}

CommandResult Exit(int code, const std::string& err) {
  CommandResult result;
  result.started = true;
  result.exit_code = code;
  result.err = err;
  return result;
}

CommandResult TimedOut() {
  CommandResult result;
  result.started = true;
  result.timed_out = true;
  return result;
}

TEST(SlurmEngineTest, SubmitsWithEveryLimitAndTheScriptOnStandardInput) {
  FakeRunner runner;
  runner.table = {{"^sbatch ", Ok("sbatch: warning: something\n4711\n")}};
  SlurmEngine engine(runner);
  JobRequest request;
  request.name = "sirupp-rig-alice";
  request.script = "#!/bin/sh\nexec sirupp-rig-job\n";
  request.output_file = "/d/students/alice/logs/job.log";
  request.partition = "class";
  request.account = "robotics";
  request.time_limit_min = 240;
  request.cpus = 2;
  request.memory_mb = 1536;
  request.extra_args = {"--qos=class"};
  const SubmitResult result = engine.Submit(request);
  ASSERT_TRUE(result.ok()) << result.error;
  EXPECT_EQ(result.job_id, "4711");
  ASSERT_EQ(runner.asked.size(), 1u);
  EXPECT_EQ(runner.asked[0],
            "sbatch --parsable --job-name=sirupp-rig-alice --output=/d/students/alice/logs/job.log "
            "--partition=class --account=robotics --time=240 --nodes=1 --ntasks=1 "
            "--cpus-per-task=2 --mem=1536M --qos=class");
  EXPECT_EQ(runner.inputs[0], request.script);
}

TEST(SlurmEngineTest, AClusterSuffixIsDroppedAndNonsenseIsRefused) {
  FakeRunner runner;
  runner.table = {{"job-name=a", Ok("12;cluster2\n")},
                  {"job-name=b", Ok("Submitted batch job 12\n")},
                  {"job-name=c", Exit(1, "sbatch: error: invalid partition specified: nope\n")},
                  {"job-name=d", TimedOut()}};
  SlurmEngine engine(runner);
  JobRequest request;
  request.name = "a";
  EXPECT_EQ(engine.Submit(request).job_id, "12");
  request.name = "b";
  SubmitResult refused = engine.Submit(request);
  EXPECT_FALSE(refused.ok());
  EXPECT_NE(refused.error.find("not a job id"), std::string::npos) << refused.error;
  request.name = "c";
  refused = engine.Submit(request);
  EXPECT_FALSE(refused.ok());
  EXPECT_NE(refused.error.find("invalid partition specified: nope"), std::string::npos)
      << refused.error;
  request.name = "d";
  refused = engine.Submit(request);
  EXPECT_FALSE(refused.ok());
  EXPECT_NE(refused.error.find("no answer in time"), std::string::npos) << refused.error;
}

TEST(SlurmEngineTest, SqueueStatesMapToPendingRunningAndEndedWithTheirReasons) {
  const std::vector<std::pair<std::string, JobState>> cases = {
      {"PENDING|Resources|n/a", JobState::kPending},
      {"CONFIGURING|None|n/a", JobState::kPending},
      {"RUNNING|None|node07", JobState::kRunning},
      {"COMPLETING|None|node07", JobState::kRunning},
      {"TIMEOUT|TimeLimit|node07", JobState::kEnded},
      {"NODE_FAIL|NodeDown|node07", JobState::kEnded},
      {"CANCELLED|None|node07", JobState::kEnded},
      {"OUT_OF_MEMORY|OutOfMemory|node07", JobState::kEnded},
      {"COMPLETED|None|node07", JobState::kEnded},
      {"FAILED|NonZeroExitCode|node07", JobState::kEnded},
      {"WEIRD_NEW_STATE|None|node07", JobState::kUnknown},
      {"gibberish", JobState::kUnknown}};
  for (const auto& [line, expected] : cases) {
    FakeRunner runner;
    runner.table = {{"^squeue ", Ok(line + "\n")}};
    SlurmEngine engine(runner);
    const JobStatus status = engine.Poll("42");
    EXPECT_EQ(JobStateName(status.state), std::string(JobStateName(expected))) << line;
    EXPECT_EQ(runner.asked[0], "squeue --noheader --states=all --jobs=42 --format=%T|%r|%B");
  }
  FakeRunner runner;
  SlurmEngine engine(runner);
  runner.table = {{"", Ok("PENDING|Resources|n/a\n")}};
  EXPECT_EQ(engine.Poll("42").reason, "Resources");
  runner.table = {{"", Ok("RUNNING|None|node07\n")}};
  EXPECT_EQ(engine.Poll("42").host, "node07");
  runner.table = {{"", Ok("TIMEOUT|TimeLimit|node07\n")}};
  EXPECT_EQ(engine.Poll("42").reason, "the job reached its time limit (Slurm: TIMEOUT, TimeLimit)");
  runner.table = {{"", Ok("NODE_FAIL|NodeDown|node07\n")}};
  EXPECT_NE(engine.Poll("42").reason.find("node the job ran on failed"), std::string::npos);
  runner.table = {{"", Ok("OUT_OF_MEMORY|OutOfMemory|node07\n")}};
  EXPECT_NE(engine.Poll("42").reason.find("out of memory"), std::string::npos);
  runner.table = {{"", Ok("CANCELLED|None|node07\n")}};
  EXPECT_EQ(engine.Poll("42").reason,
            "the job was cancelled (scancel: the class server, or the cluster's staff) (Slurm: "
            "CANCELLED)");
}

TEST(GradingJobTest, TheRequestTakesTheGradingLimitsAndTheScriptExecsTheGrader) {
  ClusterConfig config;
  config.partition = "class";
  config.account = "robotics";
  config.grading = {20, 2, 1024};
  config.sbatch_args = {"--qos=class"};
  const JobRequest request =
      GradingJobRequest(config, "sirupp-grade-alice-3", "alice's submission 3",
                        "exec /opt/sirupp/bin/sirupp grade x", "/d/job.log");
  EXPECT_EQ(request.script,
            "#!/bin/sh\n# alice's submission 3\nexec /opt/sirupp/bin/sirupp grade x\n");
  EXPECT_EQ(request.name, "sirupp-grade-alice-3");
  EXPECT_EQ(request.output_file, "/d/job.log");
  EXPECT_EQ(request.partition, "class");
  EXPECT_EQ(request.account, "robotics");
  EXPECT_EQ(request.time_limit_min, 20);
  EXPECT_EQ(request.cpus, 2);
  EXPECT_EQ(request.memory_mb, 1024);
  EXPECT_EQ(request.extra_args, (std::vector<std::string>{"--no-requeue", "--qos=class"}));
}

TEST(GradingJobTest, ALostJobGoesOnceMoreThenFailsWithSlurmsReason) {
  const auto ended = [](const std::string& line) { return ParseSqueueLine(line); };
  EXPECT_EQ(AfterGradingJob(ended("COMPLETED|None|n1"), 1).next, GradingNext::kGraded);
  EXPECT_EQ(AfterGradingJob(ended("COMPLETED|None|n1"), 2).next, GradingNext::kGraded);
  EXPECT_EQ(AfterGradingJob(ended("NODE_FAIL|NodeDown|n1"), 1).next, GradingNext::kAgain);
  EXPECT_EQ(AfterGradingJob(ended("PREEMPTED|None|n1"), 1).next, GradingNext::kAgain);
  const GradingEnd twice = AfterGradingJob(ended("NODE_FAIL|NodeDown|n1"), 2);
  EXPECT_EQ(twice.next, GradingNext::kFailed);
  EXPECT_NE(twice.problem.find("the grading job ended: the node the job ran on failed"),
            std::string::npos)
      << twice.problem;
  EXPECT_EQ(twice.problem.substr(twice.problem.size() - 8), " (twice)");
  const GradingEnd failed = AfterGradingJob(ended("FAILED|NonZeroExitCode|n1"), 1);
  EXPECT_EQ(failed.next, GradingNext::kFailed);
  EXPECT_EQ(failed.problem, "");  // the grader's own last line says why
  const GradingEnd timeout = AfterGradingJob(ended("TIMEOUT|TimeLimit|n1"), 1);
  EXPECT_EQ(timeout.next, GradingNext::kFailed);
  EXPECT_EQ(timeout.problem,
            "the grading job ended: the job reached its time limit (Slurm: TIMEOUT, TimeLimit)");
}

TEST(SlurmEngineTest, AFailingOrSilentSqueueIsUnknownNeverEnded) {
  const std::vector<CommandResult> replies = {
      Exit(1, "slurm_load_jobs error: Unable to contact slurm controller (connect failure)\n"),
      Exit(1, "slurm_load_jobs error: Socket timed out on send/recv operation\n"),
      Exit(1, "squeue: error: something new\n"), TimedOut(), CommandResult{}};
  for (const CommandResult& reply : replies) {
    FakeRunner runner;
    runner.table = {{"", reply}};
    SlurmEngine engine(runner);
    const JobStatus status = engine.Poll("42");
    EXPECT_EQ(status.state, JobState::kUnknown) << reply.err;
    EXPECT_NE(status.reason.find("squeue"), std::string::npos) << status.reason;
  }
}

TEST(SlurmEngineTest, AJobSlurmForgotHasEndedWithItsOwnRecordWhenItLeftOne) {
  FakeRunner runner;
  runner.table = {{"", Exit(1, "slurm_load_jobs error: Invalid job id specified\n")}};
  SlurmEngine engine(runner);
  JobStatus status = engine.Poll("42");
  EXPECT_EQ(status.state, JobState::kEnded);
  EXPECT_NE(status.reason.find("no longer lists it"), std::string::npos) << status.reason;
  status = engine.Poll("42", "the rig job ended on SIGTERM (time limit or scancel)\n");
  EXPECT_EQ(status.state, JobState::kEnded);
  EXPECT_EQ(status.reason, "the rig job ended on SIGTERM (time limit or scancel)");
  runner.table = {{"", Ok("")}};  // newer squeue: nothing, exit 0
  EXPECT_EQ(engine.Poll("42").state, JobState::kEnded);
  // Not a job id: nothing is asked.
  const size_t asked = runner.asked.size();
  EXPECT_EQ(engine.Poll("42; rm -rf /").state, JobState::kUnknown);
  EXPECT_EQ(runner.asked.size(), asked);
}

TEST(SlurmEngineTest, CancelTakesAJobThatAlreadyLeftAndReportsAFailure) {
  FakeRunner runner;
  runner.table = {
      {"scancel 1$", Ok("")},
      {"scancel 2$", Exit(1,
                          "scancel: error: Kill job error on job id 2: Invalid job id "
                          "specified\n")},
      {"scancel 3$", Exit(1,
                          "scancel: error: Kill job error on job id 3: Job/step already "
                          "completing or completed\n")},
      {"scancel 4$", Exit(1, "scancel: error: Unable to contact slurm controller\n")},
      {"scancel 5$", TimedOut()}};
  SlurmEngine engine(runner);
  EXPECT_EQ(engine.Cancel("1"), "");
  EXPECT_EQ(engine.Cancel("2"), "");
  EXPECT_EQ(engine.Cancel("3"), "");
  EXPECT_NE(engine.Cancel("4").find("Unable to contact"), std::string::npos);
  EXPECT_NE(engine.Cancel("5").find("no answer in time"), std::string::npos);
  EXPECT_NE(engine.Cancel("-1").find("not a Slurm job id"), std::string::npos);
}

TEST(SystemRunnerTest, RunsAProgramWithInputOutputAndATimeLimit) {
  SystemRunner runner;
  CommandResult result = runner.Run({"sh", "-c", "cat; echo err >&2; exit 3"}, "hello\n", 10);
  EXPECT_TRUE(result.started);
  EXPECT_FALSE(result.timed_out);
  EXPECT_EQ(result.exit_code, 3);
  EXPECT_EQ(result.out, "hello\n");
  EXPECT_EQ(result.err, "err\n");
  EXPECT_EQ(result.Describe("sh"), "sh: exit 3: err");

  const auto start = std::chrono::steady_clock::now();
  // The grandchild keeps the output open: the whole group is killed at the limit.
  result = runner.Run({"sh", "-c", "sleep 30 & sleep 30"}, "", 0.5);
  const double took =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_TRUE(result.timed_out);
  EXPECT_FALSE(result.Succeeded());
  EXPECT_LT(took, 5.0);

  result = runner.Run({"/nonexistent/sbatch"}, "", 5);
  EXPECT_FALSE(result.started);
  EXPECT_NE(result.Describe("sbatch").find("could not be run"), std::string::npos);
}

std::string ErrorOf(const std::string& text) {
  try {
    const core::YamlDocument document = core::YamlDocument::Parse(text, "c.yaml");
    ReadClusterConfig(core::YamlMap(document.Root(), {"cluster"}).Get("cluster", "cluster"));
  } catch (const core::ConfigError& e) {
    return e.what();
  }
  return "";
}

ClusterConfig Read(const std::string& text) {
  const core::YamlDocument document = core::YamlDocument::Parse(text, "c.yaml");
  return ReadClusterConfig(core::YamlMap(document.Root(), {"cluster"}).Get("cluster", "cluster"));
}

TEST(ClusterConfigTest, ReadsEveryKeyAndKeepsDefaults) {
  const ClusterConfig full = Read(
      "cluster:\n"
      "  engine: slurm\n"
      "  partition: class\n"
      "  account: robotics\n"
      "  rig: {time_limit_min: 120, cpus: 2, memory_mb: 1024}\n"
      "  grading: {jobs: 4, time_limit_min: 10, cpus: 1, memory_mb: 3000}\n"
      "  sbatch_args: [--qos=class, --reservation=lab]\n"
      "  node_data: /shared/class-data/\n"
      "  report_url: http://web01:8800/\n"
      "  poll_s: 2\n"
      "  command_timeout_s: 20\n");
  EXPECT_EQ(full.engine, "slurm");
  EXPECT_EQ(full.partition, "class");
  EXPECT_EQ(full.account, "robotics");
  EXPECT_EQ(full.rig.time_limit_min, 120);
  EXPECT_EQ(full.rig.cpus, 2);
  EXPECT_EQ(full.rig.memory_mb, 1024);
  EXPECT_EQ(full.grading_jobs, 4);
  EXPECT_EQ(full.grading.time_limit_min, 10);
  EXPECT_EQ(full.grading.memory_mb, 3000);
  EXPECT_EQ(full.sbatch_args, (std::vector<std::string>{"--qos=class", "--reservation=lab"}));
  EXPECT_EQ(full.node_data, "/shared/class-data");
  EXPECT_EQ(full.report_url, "http://web01:8800");
  EXPECT_EQ(full.poll_s, 2);
  EXPECT_EQ(full.command_timeout_s, 20);
  const ClusterConfig least = Read("cluster: {engine: slurm}\n");
  EXPECT_EQ(least.partition, "");
  EXPECT_EQ(least.rig.time_limit_min, 480);
  EXPECT_EQ(least.rig.cpus, 1);
  EXPECT_EQ(least.grading_jobs, 2);
  EXPECT_EQ(least.node_data, "");
}

TEST(ClusterConfigTest, AMistakeIsOneErrorAtItsPlace) {
  const auto expect = [](const std::string& text, const std::string& where,
                         const std::string& words) {
    const std::string e = ErrorOf(text);
    EXPECT_NE(e.find(where), std::string::npos) << "want " << where << " in: " << e;
    EXPECT_NE(e.find(words), std::string::npos) << "want '" << words << "' in: " << e;
  };
  expect("cluster: {engine: kubernetes}\n", "c.yaml:1:19", "kubernetes");
  expect("cluster: {partition: x}\n", "c.yaml:1:10", "engine");
  expect("cluster:\n  engine: slurm\n  partitoin: x\n", "c.yaml:3:3", "partitoin");
  expect("cluster:\n  engine: slurm\n  partition: 'a b'\n", "c.yaml:3:14", "not a Slurm partition");
  expect("cluster:\n  engine: slurm\n  rig: {cpus: 0}\n", "c.yaml:3:15", "cpus");
  expect("cluster:\n  engine: slurm\n  rig: {memory_mb: 100}\n", "c.yaml:3:20", "100");
  expect("cluster:\n  engine: slurm\n  rig: {jobs: 2}\n", "c.yaml:3:", "jobs");
  expect("cluster:\n  engine: slurm\n  grading: {jobs: 0}\n", "c.yaml:3:19", "jobs");
  expect("cluster:\n  engine: slurm\n  sbatch_args: [--time=5]\n", "c.yaml:3:17",
         "set by cluster.rig.time_limit_min");
  expect("cluster:\n  engine: slurm\n  sbatch_args: [-c4]\n", "c.yaml:3:17", "-c is set by");
  expect("cluster:\n  engine: slurm\n  sbatch_args: [--wrap=x]\n", "c.yaml:3:17", "--wrap");
  expect("cluster:\n  engine: slurm\n  sbatch_args: [qos]\n", "c.yaml:3:17",
         "not an sbatch option");
  expect("cluster:\n  engine: slurm\n  node_data: shared/data\n", "c.yaml:3:14",
         "not an absolute path");
  expect("cluster:\n  engine: slurm\n  report_url: web01:8800\n", "c.yaml:3:15", "not an address");
  expect("cluster:\n  engine: slurm\n  poll_s: 0\n", "c.yaml:3:11", "poll_s");
}

TEST(ClusterConfigTest, TheClassFileTakesItStrictlyAndWithoutItNothingChanges) {
  const std::string base =
      "class: a\nrobot: config/robots/puma260.yaml\nstudents: [alice, bob]\ndata: d\n";
  EXPECT_FALSE(classroom::ParseClassConfig(base, "c.yaml", "/tmp/x").cluster.has_value());
  const classroom::ClassConfig jobs = classroom::ParseClassConfig(
      base + "cluster: {engine: slurm, partition: class, grading: {jobs: 3}}\n", "c.yaml",
      "/tmp/x");
  ASSERT_TRUE(jobs.cluster.has_value());
  EXPECT_EQ(jobs.cluster->partition, "class");
  EXPECT_EQ(jobs.cluster->grading_jobs, 3);
  try {
    classroom::ParseClassConfig(base + "cluster:\n  engine: slurm\n  rig: {cpu: 2}\n", "c.yaml",
                                "/tmp/x");
    ADD_FAILURE() << "an unknown key was taken";
  } catch (const core::ConfigError& e) {
    const std::string text = e.what();
    EXPECT_NE(text.find("c.yaml:7:"), std::string::npos) << text;
    EXPECT_NE(text.find("cpu"), std::string::npos) << text;
  }
}

// Where a rig job's notebook server runs (class/rig_spawner.hpp, docs/notebooks.md): nowhere
// while the job has not reported (starting: the hub asks again), inside the job on the node it
// reported with the rig's bus there once it has, clearly not for a job that did not say its bus;
// the bus is kept for a restarted server.
TEST(SlurmRigSpawnerTest, TheNotebookRunsInTheJobOnceItReportedItsBus) {
  FakeRunner runner;
  SlurmEngine engine(runner);
  ClusterConfig config;
  config.node_data = "/shared/data";
  const std::string secret(64, 'a');
  const nlohmann::json saved{
      {"student", "alice"}, {"job", "12"}, {"secret", secret}, {"node", "node07"}};
  classroom::SlurmRigSpawner rig(engine, config, saved, "/tmp/nowhere");
  classroom::NotebookSite site = rig.Notebook();
  EXPECT_TRUE(site.starting);
  EXPECT_NE(site.why_not.find("still starting"), std::string::npos) << site.why_not;
  EXPECT_NE(site.why_not.find("Slurm job 12"), std::string::npos) << site.why_not;

  EXPECT_FALSE(rig.Report(classroom::RigReport{secret, "12", "10.0.0.7", 8123, 70000}))
      << "a bus port out of range is not taken";
  ASSERT_TRUE(rig.Report(classroom::RigReport{secret, "12", "10.0.0.7", 8123, 7911}));
  site = rig.Notebook();
  EXPECT_EQ(site.why_not, "");
  EXPECT_FALSE(site.starting);
  EXPECT_EQ(site.job, "12");
  EXPECT_EQ(site.host, "10.0.0.7");
  EXPECT_EQ(site.node, "node07");
  EXPECT_EQ(site.node_data, "/shared/data");
  EXPECT_EQ(site.lcm_url, "udpm://239.255.76.67:7911?ttl=0");

  // A restarted server knows the bus from the saved state.
  classroom::SlurmRigSpawner again(engine, config, rig.State(), "/tmp/nowhere");
  EXPECT_EQ(again.Notebook().lcm_url, site.lcm_url);
  EXPECT_EQ(again.Notebook().job, "12");

  // A job that reported no bus (older than udpm_port in the report): its panel works, its
  // notebooks say why not, and not as "starting".
  classroom::SlurmRigSpawner old(engine, config, saved, "/tmp/nowhere");
  ASSERT_TRUE(old.Report(classroom::RigReport{secret, "12", "10.0.0.7", 8123, 0}));
  EXPECT_TRUE(old.Reach().reachable());
  site = old.Notebook();
  EXPECT_FALSE(site.starting);
  EXPECT_NE(site.why_not.find("udpm_port"), std::string::npos) << site.why_not;
  EXPECT_EQ(site.job, "");
}

}  // namespace
}  // namespace sirupp::cluster
