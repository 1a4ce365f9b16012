// cluster::SlurmEngine against a real one-node Slurm (run by tests/cluster/with_cluster.sh, which
// exports SLURM_CONF and SLURM_TEST_DIR): submit, pending with Slurm's reason, running on the
// node, cancelled with its reason, a job's own end (completed, failed), a job Slurm never had, a
// controller that does not answer read as unknown (never ended), and cancel of a job that left.

#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <string>
#include <thread>

#include "cluster/command_runner.hpp"
#include "cluster/slurm_engine.hpp"

namespace sirupp::cluster {
namespace {

using Clock = std::chrono::steady_clock;

std::string ClusterDir() {
  const char* dir = std::getenv("SLURM_TEST_DIR");
  return dir == nullptr ? "" : dir;
}

// Polls until `done` says yes or `seconds` pass; returns the last status. The limits are generous:
// a machine loaded 10 times over its cores took seconds where an idle one takes 0.1 to 1 s.
JobStatus PollUntil(SlurmEngine& engine, const std::string& id, double seconds,
                    const std::function<bool(const JobStatus&)>& done) {
  const auto start = Clock::now();
  JobStatus status;
  while (true) {
    status = engine.Poll(id);
    if (done(status)) return status;
    if (std::chrono::duration<double>(Clock::now() - start).count() > seconds) return status;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
}

// The sleepers `exec` their command: the job's process is the sleep itself. As a child of the
// batch shell, a cancelled job's `sleep 300` was twice left behind (on an idle machine too): the
// harness's proctrack/linuxproc finds a job's processes by descent, and a child whose shell died
// first is no one's descendant any more.
JobRequest Sleeper(const std::string& name, const std::string& body) {
  JobRequest request;
  request.name = name;
  request.script = "#!/bin/sh\n" + body + "\n";
  request.output_file = ClusterDir() + "/" + name + ".out";
  request.time_limit_min = 5;
  request.memory_mb = 256;
  return request;
}

class SlurmLive : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_NE(std::getenv("SLURM_CONF"), nullptr) << "run through tests/cluster/with_cluster.sh";
    ASSERT_FALSE(ClusterDir().empty());
  }
  SystemRunner runner;
  SlurmEngine engine{runner};
};

TEST_F(SlurmLive, ARunningJobIsCancelledWithItsReason) {
  const SubmitResult submitted = engine.Submit(Sleeper("live-run", "exec sleep 300"));
  ASSERT_TRUE(submitted.ok()) << submitted.error;
  const JobStatus running = PollUntil(engine, submitted.job_id, 30, [](const JobStatus& s) {
    return s.state == JobState::kRunning;
  });
  ASSERT_EQ(running.state, JobState::kRunning) << running.slurm_state << " " << running.reason;
  char host[256] = {};
  ::gethostname(host, sizeof host - 1);
  EXPECT_EQ(running.host, std::string(host).substr(0, std::string(host).find('.')));
  EXPECT_EQ(engine.Cancel(submitted.job_id), "");
  const JobStatus ended = PollUntil(engine, submitted.job_id, 30,
                                    [](const JobStatus& s) { return s.state == JobState::kEnded; });
  ASSERT_EQ(ended.state, JobState::kEnded) << ended.slurm_state << " " << ended.reason;
  EXPECT_EQ(ended.slurm_state, "CANCELLED");
  EXPECT_NE(ended.reason.find("cancelled"), std::string::npos) << ended.reason;
  EXPECT_EQ(engine.Cancel(submitted.job_id), "") << "a job that already ended counts as cancelled";
}

TEST_F(SlurmLive, AHeldJobIsPendingWithSlurmsReason) {
  JobRequest request = Sleeper("live-held", "exec sleep 300");
  request.extra_args = {"--hold"};
  const SubmitResult submitted = engine.Submit(request);
  ASSERT_TRUE(submitted.ok()) << submitted.error;
  const JobStatus status = engine.Poll(submitted.job_id);
  EXPECT_EQ(status.state, JobState::kPending) << status.slurm_state << " " << status.reason;
  EXPECT_EQ(status.reason, "JobHeldUser");
  EXPECT_EQ(engine.Cancel(submitted.job_id), "");
}

TEST_F(SlurmLive, AJobsOwnEndIsCompletedOrFailed) {
  const SubmitResult good = engine.Submit(Sleeper("live-good", "exit 0"));
  const SubmitResult bad = engine.Submit(Sleeper("live-bad", "exit 3"));
  ASSERT_TRUE(good.ok() && bad.ok()) << good.error << bad.error;
  const auto ended = [](const JobStatus& s) { return s.state == JobState::kEnded; };
  const JobStatus good_end = PollUntil(engine, good.job_id, 30, ended);
  const JobStatus bad_end = PollUntil(engine, bad.job_id, 30, ended);
  EXPECT_EQ(good_end.slurm_state, "COMPLETED") << good_end.reason;
  EXPECT_EQ(bad_end.slurm_state, "FAILED") << bad_end.reason;
  EXPECT_NE(bad_end.reason.find("failed"), std::string::npos) << bad_end.reason;
}

TEST_F(SlurmLive, AJobSlurmNeverHadHasEnded) {
  const JobStatus status = engine.Poll("987654");
  EXPECT_EQ(status.state, JobState::kEnded) << status.reason;
  EXPECT_NE(status.reason.find("no longer lists it"), std::string::npos) << status.reason;
}

TEST_F(SlurmLive, AControllerThatDoesNotAnswerIsUnknownNotEnded) {
  const SubmitResult submitted = engine.Submit(Sleeper("live-unknown", "exec sleep 300"));
  ASSERT_TRUE(submitted.ok()) << submitted.error;
  ASSERT_EQ(PollUntil(engine, submitted.job_id, 30,
                      [](const JobStatus& s) { return s.state == JobState::kRunning; })
                .state,
            JobState::kRunning);
  std::ifstream pid_file(ClusterDir() + "/slurmctld.pid");
  pid_t controller = 0;
  pid_file >> controller;
  ASSERT_GT(controller, 0);
  SlurmOptions quick;
  quick.command_timeout_s = 2;
  SlurmEngine impatient(runner, quick);
  ASSERT_EQ(::kill(controller, SIGSTOP), 0);
  const JobStatus frozen = impatient.Poll(submitted.job_id);
  const std::string cancel = impatient.Cancel(submitted.job_id);
  ASSERT_EQ(::kill(controller, SIGCONT), 0);
  EXPECT_EQ(frozen.state, JobState::kUnknown) << frozen.reason;
  EXPECT_NE(frozen.reason.find("squeue"), std::string::npos) << frozen.reason;
  EXPECT_NE(cancel, "") << "a scancel that got no answer is not a cancel";
  // Once it answers again the job is still there, running (or ending from the scancel that may
  // have reached it), and it ends when cancelled.
  const JobStatus after = PollUntil(engine, submitted.job_id, 30, [](const JobStatus& s) {
    return s.state != JobState::kUnknown;
  });
  EXPECT_NE(after.state, JobState::kUnknown) << after.reason;
  EXPECT_EQ(engine.Cancel(submitted.job_id), "");
  EXPECT_EQ(PollUntil(engine, submitted.job_id, 30,
                      [](const JobStatus& s) { return s.state == JobState::kEnded; })
                .state,
            JobState::kEnded);
}

TEST_F(SlurmLive, ARefusedSubmissionSaysWhy) {
  JobRequest request = Sleeper("live-refused", "true");
  request.partition = "nosuchpartition";
  const SubmitResult refused = engine.Submit(request);
  EXPECT_FALSE(refused.ok());
  EXPECT_NE(refused.error.find("nosuchpartition"), std::string::npos) << refused.error;
}

}  // namespace
}  // namespace sirupp::cluster
