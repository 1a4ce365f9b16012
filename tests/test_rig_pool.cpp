// The class's rig pool (class/rig_pool.hpp) as a hub over fake spawners on a test clock, the way
// JupyterHub tests its hub with MockSpawner: no process, no Slurm, no sleeping. Each test checks
// the seat as the pages show it (SeatJson, Access) and what the pool asked of its spawners.

#include <gtest/gtest.h>

#include <chrono>
#include <deque>
#include <filesystem>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "class/class_config.hpp"
#include "class/rig_pool.hpp"
#include "class/rig_spawner.hpp"
#include "tests/class_server_harness.hpp"

namespace sirupp::classroom {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;
using Clock = std::chrono::steady_clock;

// What the fake engine knows of one rig, shared by its spawner and the test.
struct FakeRig {
  std::string id;
  std::string student;
  bool alive = false;  // started and not yet stopped by a Stop that was taken
  RigStatus poll{RigPhase::kRunning, ""};
  std::optional<RigEndpoint> endpoint;
  std::deque<std::string> stop_answers;  // Stop's answers in turn; "" (taken) when none are left
  int polls = 0;
  int stops = 0;
  int refreshes = 0;
  Json live = nullptr;
};

// Everything the fakes do, seen by the test; `crashed` is the class server killed with -9: its
// stops do nothing and nothing more is saved, so the rigs run on and the file stays as it was.
struct FakeWorld {
  std::map<std::string, std::shared_ptr<FakeRig>> rigs;
  int made = 0;
  bool crashed = false;
  SavedRigs file;  // what the factory saved, as a restarted server reads it
  std::function<void(const std::string& student)> on_start;

  std::string StopOnce(FakeRig& rig) {
    if (crashed) return "";
    ++rig.stops;
    if (!rig.stop_answers.empty()) {
      const std::string answer = rig.stop_answers.front();
      rig.stop_answers.pop_front();
      if (!answer.empty()) return answer;
    }
    rig.alive = false;
    return "";
  }
};

// A saved state's "id" ("" when it has none).
std::string IdOf(const Json& state) {
  const auto id = state.is_object() ? state.find("id") : state.end();
  return id != state.end() && id->is_string() ? id->get<std::string>() : "";
}

constexpr const char* kSecret = "the-secret-of-this-fake-rig";

// `reports`: a job's kind (pending until it reports, saved for a restart, polled each
// poll_interval_s); else a local kind (running when Start returns, with a panel here).
class FakeSpawner : public RigSpawner {
 public:
  FakeSpawner(FakeWorld& world, std::shared_ptr<FakeRig> rig, bool reports, double poll_interval_s)
      : world_(world), rig_(std::move(rig)), reports_(reports), poll_interval_s_(poll_interval_s) {}

  std::string student() const override { return rig_->student; }
  RigStatus Start() override {
    if (world_.on_start) world_.on_start(rig_->student);
    rig_->alive = true;
    if (reports_) return RigStatus{RigPhase::kPending, "submitted to the fake engine"};
    panel_ = std::make_shared<RigPanel>();
    return RigStatus{RigPhase::kRunning, ""};
  }
  RigStatus Poll() override {
    ++rig_->polls;
    return rig_->poll;
  }
  double PollIntervalS() const override { return poll_interval_s_; }
  std::string Stop() override { return world_.StopOnce(*rig_); }
  RigReach Reach() const override {
    RigReach reach;
    reach.panel = panel_;
    reach.endpoint = rig_->endpoint;
    if (panel_) reach.lcm_url = "memq://" + rig_->id;
    return reach;
  }
  bool Report(const RigReport& report) override {
    if (!reports_ || report.secret != kSecret || report.job != rig_->id) return false;
    rig_->endpoint = RigEndpoint{report.host, report.port, kSecret};
    return true;
  }
  Json LiveState() const override { return rig_->live; }
  void Refresh() override { ++rig_->refreshes; }
  double CpuPercent() override { return 12.5; }
  std::string Where() const override { return "fake " + rig_->id; }
  std::optional<std::chrono::system_clock::time_point> Submitted() const override {
    return std::nullopt;
  }
  double ReadySeconds() const override { return rig_->endpoint || panel_ ? 0.25 : 0; }
  std::string ReadyAt() const override { return ""; }
  Json State() const override {
    if (!reports_) return nullptr;
    Json state{{"student", rig_->student}, {"id", rig_->id}};
    if (rig_->endpoint) state["port"] = rig_->endpoint->port;
    return state;
  }
  NotebookSite Notebook() const override {
    NotebookSite site;
    if (panel_) {
      site.lcm_url = "memq://" + rig_->id;
    } else {
      site.why_not = "no notebook beside " + Where();
    }
    return site;
  }

 private:
  FakeWorld& world_;
  std::shared_ptr<FakeRig> rig_;
  bool reports_;
  double poll_interval_s_;
  std::shared_ptr<RigPanel> panel_;
};

class FakeFactory : public RigSpawnerFactory {
 public:
  FakeFactory(FakeWorld& world, bool reports, double poll_interval_s = 0)
      : world_(world), reports_(reports), poll_interval_s_(poll_interval_s) {}
  std::string Describe() const override { return "fakes"; }
  std::unique_ptr<RigSpawner> Make(const RigRequest& request) override {
    auto rig = std::make_shared<FakeRig>();
    rig->id = "fake-" + std::to_string(++world_.made);
    rig->student = request.student;
    world_.rigs[rig->id] = rig;
    return std::make_unique<FakeSpawner>(world_, rig, reports_, poll_interval_s_);
  }
  std::unique_ptr<RigSpawner> Restore(const Json& state) override {
    const auto found = world_.rigs.find(IdOf(state));
    if (found == world_.rigs.end()) throw std::invalid_argument("no such fake rig");
    return std::make_unique<FakeSpawner>(world_, found->second, reports_, poll_interval_s_);
  }
  SavedRigs Load() override { return world_.file; }
  void Save(const SavedRigs& saved) override {
    if (reports_ && !world_.crashed) world_.file = saved;
  }
  std::string StopSaved(const Json& state) override {
    const auto found = world_.rigs.find(IdOf(state));
    return found == world_.rigs.end() ? "" : world_.StopOnce(*found->second);
  }
  std::unique_ptr<GradePlace> MakeGradePlace(const LocalGradeOptions&, GradeHooks) override {
    return nullptr;
  }

 private:
  FakeWorld& world_;
  bool reports_;
  double poll_interval_s_;
};

struct RigPoolTest : ::testing::Test {
  void SetUp() override {
    dir = testing::TempDir("sirupp-rig-pool");
    fs::create_directories(dir + "/config-template");
  }
  void TearDown() override {
    pool.reset();
    std::error_code error;
    fs::remove_all(dir, error);
  }

  // The test's factory (it outlives the pool, as the class server's does).
  FakeFactory& UseFactory(bool reports, double poll_interval_s = 0) {
    factory_ = std::make_unique<FakeFactory>(world, reports, poll_interval_s);
    return *factory_;
  }

  // A pool over `factory` for a class of `students` with these limits, on the test clock.
  void MakePool(RigSpawnerFactory& factory, const std::string& students = "[alice, bob]",
                int max_rigs = 2, int idle_timeout_s = 60) {
    config = ParseClassConfig(
        "class: robotics-1\n"
        "robot: config/robots/puma260.yaml\n"
        "students: " +
            students +
            "\n"
            "data: class-data\n"
            "limits: {max_rigs: " +
            std::to_string(max_rigs) + ", idle_timeout_s: " + std::to_string(idle_timeout_s) +
            "}\n"
            "server: {port: 0}\n",
        "c.yaml", dir);
    RigPoolOptions options;
    options.config_dir = dir + "/config-template";
    options.log = [this](const std::string& line) { log.push_back(line); };
    options.clock = [this] { return now; };
    pool = std::make_unique<RigPool>(config, options, factory);
  }

  std::string State(const std::string& student) const {
    return pool->SeatJson(student, false)["state"].get<std::string>();
  }
  std::shared_ptr<FakeRig> Latest(const std::string& student) const {
    std::shared_ptr<FakeRig> latest;
    for (const auto& [id, rig] : world.rigs) {
      if (rig->student == student && (!latest || id > latest->id)) latest = rig;
    }
    return latest;
  }
  void Advance(double seconds) {
    now += std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(seconds));
  }

  std::string dir;
  ClassConfig config;
  FakeWorld world;
  Clock::time_point now = Clock::time_point() + std::chrono::hours(100);
  std::vector<std::string> log;
  std::unique_ptr<FakeFactory> factory_;
  std::unique_ptr<RigPool> pool;  // after the factory: destroyed first
};

TEST_F(RigPoolTest, ARigIsStartingWhileItStartsThenRunning) {
  FakeFactory& factory = UseFactory(false);
  MakePool(factory);
  EXPECT_EQ(State("alice"), "stopped");
  std::string seen_while_starting;
  world.on_start = [&](const std::string& student) { seen_while_starting = State(student); };
  ASSERT_EQ(pool->Ensure("alice"), "");
  EXPECT_EQ(seen_while_starting, "starting");
  EXPECT_EQ(State("alice"), "running");
  const RigAccess access = pool->Access("alice");
  EXPECT_EQ(access.phase, RigPhase::kRunning);
  EXPECT_NE(access.panel, nullptr);
  EXPECT_EQ(pool->LcmUrl("alice"), "memq://fake-1");
  EXPECT_EQ(pool->SeatJson("alice", false)["starts"], 1);
  EXPECT_EQ(pool->SeatJson("alice", false)["where"], "fake fake-1");
  EXPECT_EQ(pool->running(), 1);
  ASSERT_EQ(pool->Ensure("alice"), "") << "a running rig is not started twice";
  EXPECT_EQ(world.made, 1);
  EXPECT_EQ(State("bob"), "stopped");
}

TEST_F(RigPoolTest, APendingRigShowsWhyItWaitsUntilItReports) {
  FakeFactory& factory = UseFactory(true);
  MakePool(factory);
  ASSERT_EQ(pool->Ensure("alice"), "");
  EXPECT_EQ(State("alice"), "pending");
  EXPECT_EQ(pool->SeatJson("alice", false)["waiting"], "submitted to the fake engine");
  const std::shared_ptr<FakeRig> rig = Latest("alice");
  rig->poll = RigStatus{RigPhase::kPending, "waiting for the cluster (Resources)"};
  pool->MonitorPass();
  EXPECT_EQ(State("alice"), "pending");
  EXPECT_EQ(pool->SeatJson("alice", false)["waiting"], "waiting for the cluster (Resources)");
  EXPECT_FALSE(pool->Access("alice").endpoint) << "nothing to reach before the report";
  EXPECT_EQ(pool->LcmUrl("alice"), "");
  EXPECT_FALSE(pool->Reported("alice", "not-the-secret", rig->id, "node07", 8123));
  EXPECT_FALSE(pool->Reported("bob", kSecret, rig->id, "node07", 8123)) << "bob has no rig";
  EXPECT_EQ(State("alice"), "pending");
  ASSERT_TRUE(pool->Reported("alice", kSecret, rig->id, "node07", 8123));
  EXPECT_EQ(State("alice"), "running");
  ASSERT_TRUE(pool->Access("alice").endpoint);
  EXPECT_EQ(pool->Access("alice").endpoint->port, 8123);
  EXPECT_EQ(pool->SeatJson("alice", false)["starts"], 1);
  EXPECT_EQ(pool->SeatJson("alice", false)["waiting"], "");
  EXPECT_EQ(pool->Notebook("alice").why_not, "no notebook beside fake " + rig->id)
      << "where the notebook server runs is the spawner's to say";
}

TEST_F(RigPoolTest, UnknownIsNeverReadAsStopped) {
  FakeFactory& factory = UseFactory(false);
  MakePool(factory);
  ASSERT_EQ(pool->Ensure("alice"), "");
  const std::shared_ptr<FakeRig> rig = Latest("alice");
  rig->poll = RigStatus{RigPhase::kUnknown, "the cluster did not say (squeue timed out)"};
  for (int pass = 0; pass < 5; ++pass) {
    pool->Touch("alice");
    Advance(1);
    pool->MonitorPass();
  }
  EXPECT_EQ(State("alice"), "unknown");
  EXPECT_EQ(pool->SeatJson("alice", false)["waiting"],
            "the cluster did not say (squeue timed out)");
  EXPECT_EQ(rig->stops, 0) << "an unknown rig is not stopped";
  EXPECT_TRUE(rig->alive);
  EXPECT_EQ(pool->running(), 1);
  rig->poll = RigStatus{RigPhase::kRunning, ""};
  pool->MonitorPass();
  EXPECT_EQ(State("alice"), "running");
  EXPECT_EQ(pool->SeatJson("alice", false)["waiting"], "");
}

TEST_F(RigPoolTest, ARigThatEndedIsStoppedWithItsReason) {
  FakeFactory& factory = UseFactory(false);
  MakePool(factory);
  ASSERT_EQ(pool->Ensure("alice"), "");
  const std::shared_ptr<FakeRig> rig = Latest("alice");
  pool->MonitorPass();
  EXPECT_EQ(State("alice"), "running");
  EXPECT_EQ(pool->SeatJson("alice", false)["cpu_percent"], 12.5);
  rig->poll = RigStatus{RigPhase::kFailed, "sirupp-sim exited with status 3"};
  pool->MonitorPass();
  EXPECT_EQ(State("alice"), "failed");
  EXPECT_EQ(pool->SeatJson("alice", false)["last_stop"], "sirupp-sim exited with status 3");
  EXPECT_EQ(rig->stops, 1);
  EXPECT_FALSE(rig->alive);
  EXPECT_EQ(pool->running(), 0);
  EXPECT_EQ(pool->Access("alice").panel, nullptr);
  EXPECT_EQ(pool->Notebook("alice").why_not,
            "alice's rig is not running (sirupp-sim exited with status 3)");
  ASSERT_EQ(pool->Ensure("alice"), "") << "the next visit starts it again";
  EXPECT_EQ(State("alice"), "running");
  EXPECT_EQ(pool->SeatJson("alice", false)["starts"], 2);
}

TEST_F(RigPoolTest, IdleRigsStopAfterTheIdleTimeoutOnTheClock) {
  FakeFactory& factory = UseFactory(false);
  MakePool(factory, "[alice, bob]", 2, 60);
  ASSERT_EQ(pool->Ensure("alice"), "");
  ASSERT_EQ(pool->Ensure("bob"), "");
  Advance(59);
  pool->MonitorPass();
  EXPECT_EQ(State("alice"), "running");
  pool->Touch("alice");
  const std::shared_ptr<void> stream = pool->OpenStream("bob");  // bob's page is open
  Advance(2);
  pool->MonitorPass();
  EXPECT_EQ(State("alice"), "running") << "touched 2 s ago";
  EXPECT_EQ(State("bob"), "running") << "an open stream is activity";
  Advance(59);
  pool->MonitorPass();
  EXPECT_EQ(State("alice"), "stopped");
  EXPECT_EQ(pool->SeatJson("alice", false)["last_stop"],
            "stopped after 60 s without a visit (idle)");
  EXPECT_FALSE(Latest("alice")->alive);
  EXPECT_EQ(State("bob"), "running");
  EXPECT_EQ(pool->running(), 1);
}

TEST_F(RigPoolTest, StudentsBeyondMaxRigsWaitForAPlace) {
  FakeFactory& factory = UseFactory(false);
  MakePool(factory, "[alice, bob, carol]", 2);
  ASSERT_EQ(pool->Ensure("alice"), "");
  ASSERT_EQ(pool->Ensure("bob"), "");
  const std::string refused = pool->Ensure("carol");
  EXPECT_NE(refused.find("already runs its limit of 2 rigs"), std::string::npos) << refused;
  EXPECT_EQ(State("carol"), "stopped");
  EXPECT_EQ(world.made, 2) << "no spawner for a student beyond the limit";
  pool->Stop("alice", "stopped by the teacher");
  EXPECT_EQ(pool->SeatJson("alice", false)["last_stop"], "stopped by the teacher");
  ASSERT_EQ(pool->Ensure("carol"), "");
  EXPECT_EQ(State("carol"), "running");
  EXPECT_EQ(pool->running(), 2);
}

TEST_F(RigPoolTest, ARigIsPolledAtItsSpawnersIntervalAndRefreshedEachPass) {
  FakeFactory& factory = UseFactory(true, 5);
  MakePool(factory);
  ASSERT_EQ(pool->Ensure("alice"), "");
  const std::shared_ptr<FakeRig> rig = Latest("alice");
  pool->MonitorPass();  // due at once after the start
  EXPECT_EQ(rig->polls, 1);
  for (int pass = 0; pass < 4; ++pass) {
    Advance(1);
    pool->MonitorPass();
  }
  EXPECT_EQ(rig->polls, 1) << "not again within 5 s";
  EXPECT_EQ(rig->refreshes, 5);
  Advance(1);
  pool->MonitorPass();
  EXPECT_EQ(rig->polls, 2);
}

TEST_F(RigPoolTest, ARestartedPoolReattachesTheRigsItSaved) {
  FakeFactory& factory = UseFactory(true);
  MakePool(factory);
  ASSERT_EQ(pool->Ensure("alice"), "");
  ASSERT_EQ(pool->Ensure("bob"), "");
  const std::shared_ptr<FakeRig> alice = Latest("alice");
  const std::shared_ptr<FakeRig> bob = Latest("bob");
  ASSERT_TRUE(pool->Reported("alice", kSecret, alice->id, "node07", 8123));
  // A rig of a student who left the class, saved by an older server.
  auto mallory = std::make_shared<FakeRig>();
  mallory->id = "fake-99";
  mallory->student = "mallory";
  mallory->alive = true;
  world.rigs[mallory->id] = mallory;
  world.file.rigs.push_back(Json{{"student", "mallory"}, {"id", "fake-99"}});
  world.crashed = true;  // kill -9: the rigs run on, the file stays
  pool.reset();
  world.crashed = false;
  ASSERT_TRUE(alice->alive);

  MakePool(factory);
  EXPECT_EQ(world.made, 2) << "nothing started again";
  EXPECT_EQ(State("alice"), "running");
  ASSERT_TRUE(pool->Access("alice").endpoint);
  EXPECT_EQ(pool->Access("alice").endpoint->host, "node07");
  EXPECT_EQ(State("bob"), "pending");
  EXPECT_EQ(pool->SeatJson("bob", false)["waiting"],
            "reattached after a restart of the class server");
  EXPECT_EQ(pool->running(), 2);
  ASSERT_TRUE(pool->Reported("bob", kSecret, bob->id, "node08", 8124))
      << "the reattached rig takes its report";
  EXPECT_EQ(State("bob"), "running");
  pool->MonitorPass();
  EXPECT_FALSE(mallory->alive) << "a rig without a seat is stopped";
  EXPECT_TRUE(alice->alive);
  EXPECT_TRUE(bob->alive);
}

TEST_F(RigPoolTest, AStopTheEngineDidNotTakeIsTriedAgainAlsoAfterARestart) {
  FakeFactory& factory = UseFactory(true);
  MakePool(factory);
  ASSERT_EQ(pool->Ensure("alice"), "");
  const std::shared_ptr<FakeRig> rig = Latest("alice");
  rig->stop_answers = {"scancel timed out", "scancel timed out", "scancel timed out"};
  pool->Stop("alice", "stopped by the teacher");
  EXPECT_EQ(State("alice"), "stopped") << "the seat is free at once";
  EXPECT_EQ(pool->running(), 0);
  EXPECT_TRUE(rig->alive);
  ASSERT_EQ(world.file.stops.size(), 1u) << "the owed stop is saved";
  pool->MonitorPass();
  EXPECT_EQ(rig->stops, 2);
  EXPECT_TRUE(rig->alive);
  world.crashed = true;
  pool.reset();
  world.crashed = false;
  MakePool(factory);  // the restarted server owes it too
  EXPECT_EQ(State("alice"), "stopped");
  pool->MonitorPass();
  EXPECT_EQ(rig->stops, 3);
  EXPECT_TRUE(rig->alive);
  pool->MonitorPass();
  EXPECT_EQ(rig->stops, 4);
  EXPECT_FALSE(rig->alive) << "taken at last";
  EXPECT_TRUE(world.file.stops.empty());
  pool->MonitorPass();
  EXPECT_EQ(rig->stops, 4) << "not stopped once more after it was taken";
}

TEST_F(RigPoolTest, StopAllStopsEveryRigAndNoneStartsAfterBeginStop) {
  FakeFactory& factory = UseFactory(false);
  MakePool(factory);
  ASSERT_EQ(pool->Ensure("alice"), "");
  ASSERT_EQ(pool->Ensure("bob"), "");
  pool->BeginStop();
  pool->StopAll("the class server stopped");
  for (const char* student : {"alice", "bob"}) {
    EXPECT_EQ(State(student), "stopped") << student;
    EXPECT_EQ(pool->SeatJson(student, false)["last_stop"], "the class server stopped");
    EXPECT_FALSE(Latest(student)->alive) << student;
  }
  EXPECT_EQ(pool->running(), 0);
  EXPECT_EQ(pool->Ensure("alice"), "the class server is stopping");
  EXPECT_EQ(world.made, 2);
  EXPECT_FALSE(pool->StartMonitor());
}

TEST_F(RigPoolTest, TheLiveStateComesFromTheSpawner) {
  FakeFactory& factory = UseFactory(false);
  MakePool(factory);
  ASSERT_EQ(pool->Ensure("alice"), "");
  Latest("alice")->live = Json{{"controller", "picservo"},
                               {"sim", "running"},
                               {"estop", false},
                               {"lock", "alice"},
                               {"virtual", {{"q", {0.1, 0.2, 0.3}}}}};
  const Json live = pool->SeatJson("alice", true);
  EXPECT_EQ(live["controller"], "picservo");
  EXPECT_EQ(live["lock"], "alice");
  EXPECT_EQ(live["q"], Json({0.1, 0.2, 0.3}));
  EXPECT_FALSE(pool->SeatJson("alice", false).contains("controller"));
  EXPECT_FALSE(pool->SeatJson("bob", true).contains("controller"));
  EXPECT_EQ(pool->Notebook("alice").lcm_url, "memq://fake-1");
}

// The class file decides the kind once: its factory says where rigs and grades run, and only the
// kind that keeps rigs for a restarted server saves them. Nothing is started here.
TEST_F(RigPoolTest, TheClassFileDecidesWhereRigsAndGradesRun) {
  const std::string base =
      "class: robotics-1\nrobot: config/robots/puma260.yaml\nstudents: [alice]\n"
      "data: class-data\nserver: {port: 0}\n";
  ProcessLauncher launcher;
  const ClassConfig local_config = ParseClassConfig(base, "c.yaml", dir);
  const auto local = MakeRigSpawnerFactory(local_config, RigSpawnerOptions{}, launcher);
  EXPECT_EQ(local->Describe(), "this server's processes");
  const auto here = local->MakeGradePlace(LocalGradeOptions{}, GradeHooks{});
  EXPECT_EQ(here->Slots(), 1);
  EXPECT_FALSE(here->TakeBack(Json{{"id", "12"}, {"attempt", 1}}))
      << "a grade of a stopped server's own ended with it";
  EXPECT_TRUE(local->Load().rigs.empty());
  EXPECT_THROW(local->Restore(Json{{"student", "alice"}}), std::invalid_argument);

  const ClassConfig cluster_config =
      ParseClassConfig(base + "cluster: {engine: slurm, grading: {jobs: 3}}\n", "c.yaml", dir);
  const auto slurm = MakeRigSpawnerFactory(cluster_config, RigSpawnerOptions{}, launcher);
  EXPECT_EQ(slurm->Describe(), "Slurm jobs (cluster:)");
  const auto jobs = slurm->MakeGradePlace(LocalGradeOptions{}, GradeHooks{});
  EXPECT_EQ(jobs->Slots(), 3);
  const std::optional<Json> back = jobs->TakeBack(Json{{"id", "12"}, {"attempt", 7}});
  ASSERT_TRUE(back);
  EXPECT_EQ(*back, (Json{{"id", "12"}, {"attempt", 2}}));
  EXPECT_FALSE(jobs->TakeBack(Json{{"id", "12; rm -rf /"}}));
  EXPECT_TRUE(slurm->Load().rigs.empty()) << "no file yet";
  SavedRigs saved;
  saved.stops.push_back(Json{{"student", "alice"}, {"job", "41"}, {"secret", "x"}});
  slurm->Save(saved);
  const SavedRigs loaded = slurm->Load();
  ASSERT_EQ(loaded.stops.size(), 1u);
  EXPECT_EQ(loaded.stops[0], (Json{{"job", "41"}})) << "rigs.json keeps only the job id of a stop";
  EXPECT_THROW(slurm->Restore(Json{{"student", "alice"}, {"job", "41"}}), std::invalid_argument)
      << "a rig without its secret is not taken back";
}

}  // namespace
}  // namespace sirupp::classroom
