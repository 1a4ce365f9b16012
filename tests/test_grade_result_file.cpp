// A grade written whole and read back (grade/result_file.hpp, what a `sirupp grade --batch
// --cluster` job hands the batch): every double of the records exactly, why tasks ended, the
// submission's problem, the figures recomputed as a local run computes them; and each kind of bad
// file refused with one error naming it.

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>

#include "core/model_loader.hpp"
#include "grade/metrics.hpp"
#include "grade/result_file.hpp"

namespace sirupp::grade {
namespace {

namespace fs = std::filesystem;

// Paths as written: the tests run from the source root.
std::string Resolve(const std::string& path) { return path; }

class ResultFileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("sirupp-result-file-" + std::to_string(::getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string File(const std::string& name) const { return (dir_ / name).string(); }

  // grade_small.yaml: set1 (a plan) and step_j2.
  const Suite suite_ = LoadSuite("tests/data/grade_small.yaml", &Resolve);
  const core::RobotModel model_ = core::LoadRobotModel(suite_.model_file);
  fs::path dir_;
};

// set1 ran (a record with awkward doubles); step_j2 ended early.
ControllerResult Sample(const core::RobotModel& model) {
  ControllerResult result;
  result.label = "pd_gravity.so";
  TaskResult ran;
  ran.task = "set1";
  TaskRecord& record = ran.record;
  record.completed = true;
  record.num_joints = model.num_joints();
  record.tick_s = 0.001;
  record.has_reference = true;
  record.missing_rows = 3;
  record.setpoint_deviation = 1e-300;
  const double odd[] = {0.1, -0.0, 1.0 / 3.0, std::numeric_limits<double>::denorm_min(), 1e308};
  for (int row = 0; row < 400; ++row) {
    record.time_s.push_back(row * 0.001);
    for (int j = 0; j < record.num_joints; ++j) {
      const double v = odd[(row + j) % 5] + row * 1e-4;
      record.position.push_back(v);
      record.reference.push_back(v * 0.5);
      record.goal.push_back(1.5);
      record.effort.push_back(-v);
    }
  }
  TaskResult ended;
  ended.task = "step_j2";
  ended.ended = "sirupp-control ended (signal 11, SIGSEGV)";
  result.tasks = {ran, ended};
  return result;
}

TEST_F(ResultFileTest, EveryDoubleComesBackAndTheFiguresAreComputedAsARunDoes) {
  const ControllerResult written = Sample(model_);
  WriteResultFile(File("result"), written, "");
  const ReadResult read = ReadResultFile(File("result"), suite_, model_);
  EXPECT_EQ(read.problem, "");
  EXPECT_EQ(read.result.label, "pd_gravity.so");
  ASSERT_EQ(read.result.tasks.size(), 2u);
  const TaskRecord& a = written.tasks[0].record;
  const TaskRecord& b = read.result.tasks[0].record;
  EXPECT_TRUE(b.completed);
  EXPECT_EQ(b.num_joints, a.num_joints);
  EXPECT_EQ(b.missing_rows, 3);
  EXPECT_EQ(b.setpoint_deviation, 1e-300);
  ASSERT_EQ(b.position.size(), a.position.size());
  for (size_t i = 0; i < a.position.size(); ++i) {
    ASSERT_EQ(std::signbit(b.position[i]), std::signbit(a.position[i])) << i;
    ASSERT_EQ(b.position[i], a.position[i]) << i;
    ASSERT_EQ(b.reference[i], a.reference[i]) << i;
    ASSERT_EQ(b.effort[i], a.effort[i]) << i;
  }
  EXPECT_EQ(b.time_s, a.time_s);
  EXPECT_EQ(b.goal, a.goal);
  const TaskMetrics expected = ComputeMetrics(model_, a, suite_.tasks[0].pass);
  EXPECT_EQ(read.result.tasks[0].metrics.failed_checks, expected.failed_checks);
  EXPECT_EQ(read.result.tasks[0].passed, expected.passed());
  EXPECT_EQ(read.result.tasks[1].ended, "sirupp-control ended (signal 11, SIGSEGV)");
  EXPECT_FALSE(read.result.tasks[1].passed);
  EXPECT_EQ(read.result.tasks[1].record.ticks(), 0u);
}

TEST_F(ResultFileTest, ASubmissionsProblemAloneIsAResult) {
  WriteResultFile(File("problem"), ControllerResult{}, "does not build (g++ exit code 1)");
  const ReadResult read = ReadResultFile(File("problem"), suite_, model_);
  EXPECT_EQ(read.problem, "does not build (g++ exit code 1)");
  EXPECT_TRUE(read.result.tasks.empty());
}

TEST_F(ResultFileTest, BadFilesAreRefusedNamingTheFile) {
  const auto refused = [&](const std::string& file, const std::string& part) {
    try {
      ReadResultFile(file, suite_, model_);
      ADD_FAILURE() << file << " was read";
    } catch (const std::runtime_error& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(file), std::string::npos) << what;
      EXPECT_NE(what.find(part), std::string::npos) << what;
    }
  };
  refused(File("missing"), "missing or not readable");
  std::ofstream(File("text")) << "hello\n";
  refused(File("text"), "not a grade result");
  WriteResultFile(File("whole"), Sample(model_), "");
  std::string bytes;
  {
    std::ifstream in(File("whole"), std::ios::binary);
    std::ostringstream text;
    text << in.rdbuf();
    bytes = text.str();
  }
  std::ofstream(File("cut"), std::ios::binary) << bytes.substr(0, bytes.size() - 5);
  refused(File("cut"), "cut short");
  std::ofstream(File("longer"), std::ios::binary) << bytes << "x";
  refused(File("longer"), "more than one result");
  ControllerResult one = Sample(model_);
  one.tasks.pop_back();
  WriteResultFile(File("other"), one, "");
  refused(File("other"), "1 tasks where the suite small has 2");
  ControllerResult renamed = Sample(model_);
  renamed.tasks[1].task = "step_j3";
  WriteResultFile(File("renamed"), renamed, "");
  refused(File("renamed"), "'step_j3' where the suite has 'step_j2'");
}

}  // namespace
}  // namespace sirupp::grade
