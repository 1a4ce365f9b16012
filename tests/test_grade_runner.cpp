// The grader's driving of a task (grade/driver.hpp, grade/runner.hpp) and its private ports
// (grade/port_lease.hpp):
//  - on memq://, through the client's request/reply matching (core::Replier on CONTROLLER_REPLY):
//    a refused plan gives the controller's reason, silence gives "not taken", a fault in the
//    controller's status is read back;
//  - with real processes on a leased udpm port (ttl=0): a plan sirupp-control refuses, and a
//    controller that answers the sim but never replies to the plan, each end the task with that
//    reason; a tracking task is graded for a process controller against the path it was handed
//    in {reference_csv}, and for the baseline, whose set-point follows the same path; on a step
//    and a plan task the set-points computed for a process controller (grade/reference.hpp) are
//    the baseline's ARM_SETPOINT tick by tick, and a process controller following them is graded
//    against them;
//  - port leases: two at once never share a port, within a process or across processes, and a
//    port comes free when its holder ends.

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <sirupp/controller_status_t.hpp>
#include <sirupp/plan_command_t.hpp>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "core/bus.hpp"
#include "core/channels.hpp"
#include "core/command_reply.hpp"
#include "core/errors.hpp"
#include "core/model_loader.hpp"
#include "grade/driver.hpp"
#include "grade/grade.hpp"
#include "grade/metrics.hpp"
#include "grade/port_lease.hpp"
#include "grade/reference.hpp"
#include "grade/runner.hpp"
#include "grade/suite.hpp"

namespace sirupp::grade {
namespace {

namespace fs = std::filesystem;
constexpr double kDeg = 3.14159265358979323846 / 180;

std::string Same(const std::string& path) { return path; }

const core::RobotModel& Puma() {
  static const core::RobotModel model = core::LoadRobotModel("config/robots/puma260.yaml");
  return model;
}

// --- the driver on memq://

// Answers ARM_PLAN as sirupp-control does (core::Replier), refusing with `refusal` when it is
// not empty.
struct FakeController {
  FakeController(core::Bus& bus, std::string refusal)
      : replier(bus, core::Channels{}.controller_reply, "sirupp-control"),
        refusal_(std::move(refusal)) {
    bus.Subscribe<sirupp::plan_command_t>(
        core::Channels{}.arm_plan,
        [this](const sirupp::plan_command_t& m, const core::ReceiveInfo& info) {
          ++plans;
          replier.Answer(
              m, info,
              [this] {
                if (!refusal_.empty()) throw core::MessageError("ARM_PLAN", "text", refusal_);
              },
              [] { return core::ReplyFacts{}; });
        });
  }
  core::Replier replier;
  int plans = 0;

 private:
  std::string refusal_;
};

TEST(GradeDriver, APlanTheControllerTakesIsAccepted) {
  core::Bus bus("memq://");
  FakeController controller(bus, "");
  PlanDriver driver(bus, 5);
  EXPECT_EQ(driver.RunPlan("p", "units deg\nmove j1=1\n"), "");
  EXPECT_TRUE(driver.PlanAccepted());
  EXPECT_EQ(controller.plans, 1);
}

TEST(GradeDriver, ARefusedPlanGivesTheControllersReason) {
  core::Bus bus("memq://");
  FakeController controller(bus, "p:2:9: move: joint j2 goal 500 deg is outside its limits");
  PlanDriver driver(bus, 5);
  const std::string failure = driver.RunPlan("p", "units deg\nmove j2=500\n");
  EXPECT_EQ(failure,
            "the controller refused the plan: channel ARM_PLAN: text: p:2:9: move: joint j2 goal "
            "500 deg is outside its limits");
  EXPECT_FALSE(driver.PlanAccepted());
}

TEST(GradeDriver, NoReplyMeansThePlanWasNotTaken) {
  core::Bus bus("memq://");
  PlanDriver driver(bus, 0.3);
  const std::string failure = driver.RunPlan("p", "units deg\nmove j1=1\n");
  EXPECT_EQ(failure.rfind("the plan was not taken: ", 0), 0u) << failure;
  EXPECT_NE(failure.find("CONTROLLER_REPLY"), std::string::npos) << failure;
  EXPECT_FALSE(driver.PlanAccepted());
}

TEST(GradeDriver, AFaultInTheControllersStatusIsReadBack) {
  core::Bus bus("memq://");
  PlanDriver driver(bus, 1);
  EXPECT_EQ(driver.Fault(), "");
  sirupp::controller_status_t status{};
  status.state = sirupp::controller_status_t::STATE_MOVING;
  bus.Publish(core::Channels{}.controller_status, status);
  bus.HandleAvailable();
  EXPECT_EQ(driver.Fault(), "");
  status.state = sirupp::controller_status_t::STATE_FAULT;
  status.last_error = "joint j2 tripped its position-error limit";
  bus.Publish(core::Channels{}.controller_status, status);
  bus.HandleAvailable();
  EXPECT_EQ(driver.Fault(), "joint j2 tripped its position-error limit");
}

// --- port leases

TEST(GradePorts, TwoLeasesAtOnceNeverShareAPort) {
  const std::string dir =
      (fs::temp_directory_path() / ("sirupp-test-ports-" + std::to_string(::getpid()))).string();
  {
    // The same start: the second takes the next port; a third wraps around the range.
    PortLease a = PortLease::Acquire(30000, 2, 0, dir);
    PortLease b = PortLease::Acquire(30000, 2, 0, dir);
    EXPECT_EQ(a.port(), 30000);
    EXPECT_EQ(b.port(), 30001);
    const std::string full = [&] {
      try {
        PortLease::Acquire(30000, 2, 1, dir);
      } catch (const std::runtime_error& error) {
        return std::string(error.what());
      }
      return std::string();
    }();
    EXPECT_NE(full.find("no free grading port in 30000..30001"), std::string::npos) << full;
    a.Release();
    EXPECT_EQ(PortLease::Acquire(30000, 2, 1, dir).port(), 30000);
    // Many leases at once: all different.
    std::vector<PortLease> leases;
    std::set<int> ports;
    for (int k = 0; k < 50; ++k) {
      leases.push_back(PortLease::Acquire(31000, 60, k % 3, dir));
      ports.insert(leases.back().port());
    }
    EXPECT_EQ(ports.size(), 50u);
  }
  // Another process (another grader) holds a port: it is skipped until that process ends.
  int ready[2], go[2];
  ASSERT_EQ(::pipe(ready), 0);
  ASSERT_EQ(::pipe(go), 0);
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    PortLease held = PortLease::Acquire(32000, 10, 0, dir);
    char c = held.port() == 32000 ? 'y' : 'n';
    if (::write(ready[1], &c, 1) != 1) ::_exit(3);
    if (::read(go[0], &c, 1) != 1) ::_exit(3);
    ::_exit(0);  // the kernel drops the lock
  }
  char c = 0;
  ASSERT_EQ(::read(ready[0], &c, 1), 1);
  EXPECT_EQ(c, 'y');
  EXPECT_EQ(PortLease::Acquire(32000, 10, 0, dir).port(), 32001);
  ASSERT_EQ(::write(go[1], "x", 1), 1);
  int status = 0;
  ASSERT_EQ(::waitpid(child, &status, 0), child);
  EXPECT_EQ(PortLease::Acquire(32000, 10, 0, dir).port(), 32000);
  for (int fd : {ready[0], ready[1], go[0], go[1]}) ::close(fd);
  fs::remove_all(dir);
}

// --- tasks with real processes

std::string BinDir() {
  const char* dir = std::getenv("SIRUPP_BIN_DIR");
  return dir != nullptr ? dir : "build/bin";
}

struct TaskRun {
  TaskRun() {
    work =
        (fs::temp_directory_path() / ("sirupp-test-grade-" + std::to_string(::getpid()))).string();
    fs::create_directories(work);
    lease = PortLease::Acquire(kPortBase, kPortCount, static_cast<int>(::getpid() % 9000));
    options.bin_dir = BinDir();
    options.work_dir = work;
    options.port = lease.port();
  }
  ~TaskRun() { fs::remove_all(work); }
  std::string work;
  PortLease lease;
  RunOptions options;
};

Suite SmallSuite(const std::string& tasks) {
  return ParseSuite(
      "format: sirupp-grade-suite-1\nname: t\nlimits: {tick_s: 2, start_s: 20, "
      "task_s: 240}\ntasks:\n" +
          tasks,
      "t.yaml", &Same);
}

TEST(GradeRunner, APlanSirupControlRefusesEndsTheTaskWithItsReason) {
  Suite suite = SmallSuite("  - {name: a, step: {joint: 2, to_deg: 10}, duration_s: 0.5}\n");
  // What the suite would have refused at load: sirupp-control refuses it too, naming the line.
  suite.tasks[0].plan_text = "units deg\nmove j2=500\nwait done\n";
  TaskRun run;
  const TaskRecord record = RunTask(suite, Puma(), suite.tasks[0], ControllerSpec{}, run.options);
  EXPECT_FALSE(record.completed);
  EXPECT_EQ(record.failure.rfind("the controller refused the plan: channel ARM_PLAN: ", 0), 0u)
      << record.failure;
  EXPECT_NE(record.failure.find("a:2:"), std::string::npos) << record.failure;
  EXPECT_NE(record.failure.find("500"), std::string::npos) << record.failure;
}

TEST(GradeRunner, AControllerThatNeverRepliesToThePlanEndsTheTask) {
  Suite suite = SmallSuite("  - {name: a, step: {joint: 2, to_deg: 10}, duration_s: 0.5}\n");
  suite.limits.start_s = 2;
  TaskRun run;
  // sirupp-sim as it is; "sirupp-control" is one that answers the sim but never replies.
  const std::string bin = run.work + "/bin";
  fs::create_directories(bin);
  fs::create_symlink(fs::absolute(BinDir() + "/sirupp-sim"), bin + "/sirupp-sim");
  fs::create_symlink(fs::absolute(std::string(SIRUPP_SILENT_CONTROL)), bin + "/sirupp-control");
  run.options.bin_dir = bin;
  const TaskRecord record = RunTask(suite, Puma(), suite.tasks[0], ControllerSpec{}, run.options);
  EXPECT_FALSE(record.completed);
  EXPECT_EQ(record.failure.rfind("the plan was not taken: ", 0), 0u) << record.failure;
  EXPECT_NE(record.failure.find("CONTROLLER_REPLY"), std::string::npos) << record.failure;
}

// controllers/track_process: computed torque on the rows of {reference_csv}.
ControllerSpec TrackProcess() {
  ControllerSpec process;
  process.kind = ControllerSpec::Kind::kProcess;
  process.command = {
      SIRUPP_TRACK_PROCESS,         "--lcm-url",   "{url}",          "--name", "{name}", "--model",
      "config/robots/puma260.yaml", "--reference", "{reference_csv}"};
  return process;
}

TEST(GradeRunner, ATrackingTaskIsGradedAgainstThePathForAProcessAndForTheBaseline) {
  const Suite suite = SmallSuite(
      "  - {name: tr, track: {joint: 2, amplitude_deg: 20, period_s: 3, cycles: 1}, duration_s: "
      "3.3, pass: {rms_tracking_deg: 0.5}}\n");
  const Task& task = suite.tasks[0];
  const ControllerSpec process = TrackProcess();
  TaskRun run;
  const TaskRecord mine = RunTask(suite, Puma(), task, process, run.options);
  ASSERT_TRUE(mine.completed) << mine.failure;
  EXPECT_TRUE(mine.has_reference);
  // The file the process got: a header and one row per tick, the path on joint 2.
  std::ifstream csv(run.work + "/reference.csv");
  std::string header, row;
  std::getline(csv, header);
  EXPECT_EQ(header.rfind("tick,time_s,q1_deg,v1_deg_s,a1_deg_s2,q2_deg,", 0), 0u) << header;
  for (int k = 0; k <= 1465; ++k) std::getline(csv, row);  // tick 1465: 0.75008 s, at +20 deg
  EXPECT_EQ(row.rfind("1465,0.75008,0,0,0,20,", 0), 0u) << row;
  // Its reference in the record is the path (not the goal), and it followed it.
  ASSERT_GT(mine.ticks(), 4000u);
  const size_t n = 6;
  EXPECT_NEAR(mine.reference[1465 * n + 1], task.track->path.joint(1).At(1465 * 0.000512).position,
              1e-12);
  EXPECT_NEAR(mine.reference[1465 * n + 1], 20 * kDeg, 0.01 * kDeg);
  const TaskMetrics m = ComputeMetrics(Puma(), mine, task.pass);
  EXPECT_LT(m.joints[1].rms_tracking, 0.5) << "deg";
  EXPECT_GT(m.joints[1].max_tracking, 0.0);
  EXPECT_TRUE(m.passed()) << (m.failed_checks.empty() ? "" : m.failed_checks.front());

  // The baseline through sirupp-control: the chip's set-point followed the path closely, and the
  // PID's error against the path is measured the same way.
  TaskRun run2;
  const TaskRecord base = RunTask(suite, Puma(), task, ControllerSpec{}, run2.options);
  ASSERT_TRUE(base.completed) << base.failure;
  EXPECT_LT(base.setpoint_deviation, 0.01 * kDeg);
  EXPECT_NEAR(base.reference[1465 * n + 1], mine.reference[1465 * n + 1], 1e-15);
  const TaskMetrics b = ComputeMetrics(Puma(), base, task.pass);
  EXPECT_GT(b.joints[1].rms_tracking, 0.0);
  RecordProperty("process_rms_tracking_deg", std::to_string(m.joints[1].rms_tracking));
  RecordProperty("baseline_rms_tracking_deg", std::to_string(b.joints[1].rms_tracking));
  RecordProperty("baseline_setpoint_deviation_deg", std::to_string(base.setpoint_deviation / kDeg));
}

TEST(GradeRunner, AProcessControllerGetsTheSetPointsALibraryGetsOnStepAndPlanTasks) {
  const Suite suite = SmallSuite(
      "  - {name: st, step: {joint: 2, to_deg: 20}, duration_s: 1.2, pass: {rms_tracking_deg: "
      "0.5}}\n"
      "  - {name: s1, plan: config/plans/set1.plan, duration_s: 3.0}\n");
  const size_t n = 6;
  for (const Task& task : suite.tasks) {
    SCOPED_TRACE(task.name);
    // The baseline's set-points, as sirupp-control published them (ARM_SETPOINT), against those
    // computed before the task on an arm that follows them.
    TaskRun run;
    const TaskRecord base = RunTask(suite, Puma(), task, ControllerSpec{}, run.options);
    ASSERT_TRUE(base.completed) << base.failure;
    ASSERT_EQ(base.missing_rows, 0);
    const ReferenceTable given = ChipProfile(Puma(), task, base.ticks());
    double worst = 0, worst_goal = 0, moved = 0;
    for (size_t row = 0; row < base.ticks(); ++row) {
      for (size_t j = 0; j < n; ++j) {
        worst = std::max(worst, std::abs(given.At(row, j).position - base.reference[row * n + j]));
        worst_goal = std::max(worst_goal, std::abs(given.At(row, j).goal - base.goal[row * n + j]));
        moved = std::max(moved, std::abs(given.At(row, j).position - task.start[j]));
      }
    }
    EXPECT_EQ(worst, 0.0) << "rad";
    EXPECT_EQ(worst_goal, 0.0) << "rad";
    EXPECT_GT(moved, 19 * kDeg);  // the profile moves (not the goal from tick 0)
    RecordProperty(task.name + "_profile_vs_setpoint_rad", std::to_string(worst));
  }
  // A process controller reading {reference_csv} gets that profile, and is measured against it.
  const Task& step = suite.tasks[0];
  const ControllerSpec process = TrackProcess();
  TaskRun run;
  const TaskRecord mine = RunTask(suite, Puma(), step, process, run.options);
  ASSERT_TRUE(mine.completed) << mine.failure;
  const ReferenceTable given = ChipProfile(Puma(), step, mine.ticks());
  // Mid-move (0.3 s, tick 586) the file has the profile's position and speed on joint 2.
  std::ifstream csv(run.work + "/reference.csv");
  std::string row;
  for (int k = 0; k <= 586 + 1; ++k) std::getline(csv, row);
  std::vector<double> values;
  std::istringstream fields(row);
  for (std::string cell; std::getline(fields, cell, ',');) values.push_back(std::stod(cell));
  ASSERT_EQ(values.size(), 2 + 3 * n) << row;
  EXPECT_EQ(values[0], 586);
  EXPECT_NEAR(values[2 + 3], given.At(586, 1).position / kDeg, 1e-6);
  EXPECT_NEAR(values[3 + 3], given.At(586, 1).velocity / kDeg, 1e-6);
  EXPECT_GT(std::abs(values[3 + 3]), 1.0) << "deg/s: moving";
  EXPECT_NEAR(mine.reference[586 * n + 1], given.At(586, 1).position, 1e-15);
  const TaskMetrics m = ComputeMetrics(Puma(), mine, step.pass);
  EXPECT_LT(m.joints[1].rms_tracking, 0.5) << "deg";
  EXPECT_TRUE(m.passed()) << (m.failed_checks.empty() ? "" : m.failed_checks.front());
  RecordProperty("process_step_rms_tracking_deg", std::to_string(m.joints[1].rms_tracking));
}

}  // namespace
}  // namespace sirupp::grade
