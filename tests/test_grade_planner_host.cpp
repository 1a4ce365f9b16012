// A planning assignment graded for a C++ planning library (include/sirupp/student_planner.h,
// grade/planner_host.hpp): the shipped RRT (config/grading/planning_rrt.cpp) passes every query
// of config/grading/planning.yaml; a straight path fails naming the segment, the link and the
// table; libraries that crash, spin, return NaN, too many or no waypoints, write past the buffer,
// throw, refuse, are built against another ABI or lack sirupp_plan each cost their query with
// one clear line and a zero score; the host given bad arguments exits 2 with one line. Checked
// without the run on the rig (test_grade_planning.py runs a C++ planner's path on the rig), in
// the sandbox where the machine gives it.

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "core/model_loader.hpp"
#include "grade/child.hpp"
#include "grade/planner_host.hpp"
#include "grade/planning_assignment.hpp"
#include "sandbox/sandbox.hpp"

namespace sirupp::grade {
namespace {
namespace fs = std::filesystem;

std::string AsGiven(const std::string& path) { return path; }

std::string ReadText(const std::string& file) {
  std::ifstream in(file);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// The shipped suite, its planning time cut to `plan_s` and, with `one_query`, its queries to
// the first one (over_table: the straight way touches the table).
PlanningSuite Suite(double plan_s, bool one_query) {
  std::string text = ReadText("config/grading/planning.yaml");
  const size_t limits = text.find("limits: {plan_s: 60}");
  EXPECT_NE(limits, std::string::npos);
  text.replace(limits, 20, "limits: {plan_s: " + std::to_string(plan_s) + "}");
  if (one_query) {
    const size_t second = text.find("  # The tool low beside the table");
    EXPECT_NE(second, std::string::npos);
    text.resize(second);
  }
  return ParsePlanningSuite(text, "planning.yaml", &AsGiven);
}

class PlannerHostTest : public ::testing::Test {
 protected:
  void SetUp() override {
    work_ = fs::temp_directory_path() /
            ("sirupp-planner-host-" + std::to_string(::getpid()) + "-" +
             ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(work_);
    fs::create_directories(work_);
    options_.bin_dir = SIRUPP_PLANNER_HOST_DIR;
    options_.work_dir = work_.string();
    options_.sandbox = sandbox::ProbeMachine().usable;
    options_.run_on_rig = false;
    if (!options_.sandbox) {
      std::cerr << "the sandbox cannot be had here (" << sandbox::ProbeMachine().problem
                << "): the test's own libraries run unconfined\n";
    }
  }
  void TearDown() override { fs::remove_all(work_); }

  PlanningResult Grade(const std::string& library, double plan_s = 5, bool one_query = true) {
    const PlanningSuite suite = Suite(plan_s, one_query);
    const core::RobotModel model = core::LoadRobotModel(suite.model_file);
    return GradePlanning(suite, model, library, options_);
  }
  static std::string Bad(const std::string& name) {
    return std::string(SIRUPP_BAD_PLANNER_DIR) + "/" + name + ".so";
  }
  // The one query's problem, which must fail it with a zero score.
  std::string OnlyProblem(const std::string& name, double plan_s = 5) {
    const PlanningResult result = Grade(Bad(name), plan_s);
    EXPECT_EQ(result.queries.size(), 1u);
    if (result.queries.empty()) return "";
    EXPECT_FALSE(result.queries[0].passed);
    EXPECT_FALSE(result.queries[0].returned);
    EXPECT_EQ(result.score(), 0);
    EXPECT_TRUE(result.queries[0].reference_solved);  // OMPL's reference is there all the same
    return result.queries[0].problem;
  }

  fs::path work_;
  PlanningGradeOptions options_;
};

TEST_F(PlannerHostTest, TheShippedRrtPassesEveryQuery) {
  const PlanningResult result = Grade(SIRUPP_RRT_PLANNER_LIB, 20, false);
  ASSERT_EQ(result.queries.size(), 3u);
  EXPECT_EQ(result.passed(), 3);
  for (const PlanningQueryResult& q : result.queries) {
    EXPECT_TRUE(q.passed) << q.query << ": " << q.problem;
    EXPECT_GE(q.path.size(), 2u) << q.query;
    EXPECT_GT(q.length_rad, 0) << q.query;
    EXPECT_GT(q.states_checked, 100u) << q.query;  // the grader's own check ran
    EXPECT_GE(q.student_s, 0) << q.query;
  }
  // Around the table: not the straight line.
  EXPECT_GT(result.queries[1].path.size(), 2u);
}

TEST_F(PlannerHostTest, AStraightPathThroughTheTableNamesTheSegmentLinkAndObject) {
  const PlanningResult result = Grade(Bad("straight"), 5, false);
  ASSERT_EQ(result.queries.size(), 3u);
  // ready_to_table's straight way is free; over_table's passes the check too, and touches only
  // on the rig, where the PID's lag leaves the line (test_grade_planning.py)
  EXPECT_EQ(result.passed(), 2);
  EXPECT_TRUE(result.queries[0].passed) << result.queries[0].problem;
  const PlanningQueryResult& around = result.queries[1];
  EXPECT_TRUE(around.returned);
  EXPECT_FALSE(around.passed);
  EXPECT_EQ(around.problem.rfind("segment 1 (waypoint 0 to 1) at ", 0), 0u) << around.problem;
  EXPECT_NE(around.problem.find("link "), std::string::npos) << around.problem;
  EXPECT_NE(around.problem.find("touches static object 'table_top'"), std::string::npos)
      << around.problem;
  EXPECT_TRUE(result.queries[2].passed) << result.queries[2].problem;
}

TEST_F(PlannerHostTest, ACrashIsNamedBySignal) {
  const std::string problem = OnlyProblem("crash");
  EXPECT_EQ(problem, "the planner failed (crashed with SIGSEGV (Segmentation fault))");
}

TEST_F(PlannerHostTest, AWritePastThePathBufferIsNamed) {
  const std::string problem = OnlyProblem("overrun");
  EXPECT_NE(problem.find("crashed with SIGSEGV"), std::string::npos) << problem;
  EXPECT_NE(problem.find("sirupp_plan wrote past the end of the path buffer (max_waypoints = "
                         "10000 waypoints of 6 joints)"),
            std::string::npos)
      << problem;
}

TEST_F(PlannerHostTest, APlannerThatNeverReturnsIsStoppedAtTheLimit) {
  const auto began = std::chrono::steady_clock::now();
  const std::string problem = OnlyProblem("spin", 1);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - began).count();
  EXPECT_EQ(problem, "sirupp_plan did not return within 1 s (the suite's limits.plan_s)");
  EXPECT_LT(seconds, 5);
}

TEST_F(PlannerHostTest, GarbageIsOneClearLine) {
  // A NaN reaches the grader's own check, which names it.
  const PlanningResult nan = Grade(Bad("nan"));
  ASSERT_EQ(nan.queries.size(), 1u);
  EXPECT_TRUE(nan.queries[0].returned);
  EXPECT_EQ(nan.queries[0].problem, "waypoint 1: joint 2 is nan");
  EXPECT_EQ(nan.score(), 0);
  EXPECT_NE(
      OnlyProblem("too_many")
          .find("sirupp_plan returned *num_waypoints = 10001; allowed 1 to 10000 (max_waypoints)"),
      std::string::npos);
  EXPECT_NE(OnlyProblem("no_count").find("sirupp_plan returned without setting *num_waypoints"),
            std::string::npos);
}

TEST_F(PlannerHostTest, ARefusalAnExceptionAndBadSceneCallsAreNamed) {
  const std::string refused = OnlyProblem("refuses");
  EXPECT_NE(refused.find("sirupp_plan returned 1: no path within 5 nodes (is_free(nan) = -1, "
                         "edge_free(step 0) = -1, is_free(start) = 1) (the first bad scene call: "
                         "is_free: q[0] = nan)"),
            std::string::npos)
      << refused;
  const std::string thrown = OnlyProblem("throws");
  EXPECT_NE(thrown.find("sirupp_plan threw std::runtime_error: the tree is empty"),
            std::string::npos)
      << thrown;
}

TEST_F(PlannerHostTest, ALibraryThatIsNoPlannerIsRefusedByName) {
  EXPECT_NE(
      OnlyProblem("wrong_abi")
          .find("wrong_abi.so: built against planner ABI version 99; this grader has version 1"),
      std::string::npos);
  EXPECT_NE(OnlyProblem("no_plan").find("no_plan.so: no function sirupp_plan"), std::string::npos);
  const std::string text = (work_ / "text.so").string();
  std::ofstream(text) << "not a library\n";
  ::chmod(text.c_str(), 0644);
  const PlanningResult result = Grade(text);
  ASSERT_EQ(result.queries.size(), 1u);
  EXPECT_NE(result.queries[0].problem.find("text.so: cannot be loaded: "), std::string::npos)
      << result.queries[0].problem;
  const PlanningResult other = Grade((work_ / "planner.cpp").string());
  ASSERT_EQ(other.queries.size(), 1u);
  EXPECT_NE(other.queries[0].problem.find("allowed a Python file (.py) or a library (.so"),
            std::string::npos)
      << other.queries[0].problem;
}

// The host itself, given bad arguments (it is started by the grader only): exit 2, one line.
TEST_F(PlannerHostTest, TheHostRefusesBadArguments) {
  const std::string host = std::string(SIRUPP_PLANNER_HOST_DIR) + "/sirupp-planner-host";
  const std::string model = "config/robots/puma260.yaml";
  const std::string env = "config/environments/table.xml";
  const std::string out = (work_ / "path.txt").string();
  struct Case {
    std::vector<std::string> args;
    std::string says;
  };
  const std::vector<Case> cases = {
      {{}, "expected at least 8 arguments, got 0"},
      {{Bad("straight"), model, env, "x", "1", out, "0", "0"}, "PADDING_M 'x' is not a number"},
      {{Bad("straight"), model, env, "0", "-1", out, "0", "0"}, "TIME_S '-1' is not a number > 0"},
      {{Bad("straight"), model, env, "0", "1", out, "0", "nan"},
       "argument 8 'nan' is not a finite number"},
      {{Bad("straight"), model, env, "0", "1", out, "0", "0"},
       "expected 12 joint values (start, goal) for puma260, got 2"},
      {{Bad("straight"), "no/such.yaml", env, "0", "1", out, "0", "0"}, "no/such.yaml"},
      {{Bad("straight"), model, env, "0.5", "1", out, "0", "0"}, "padding"},
  };
  for (const Case& c : cases) {
    std::vector<std::string> argv = {host};
    argv.insert(argv.end(), c.args.begin(), c.args.end());
    const std::string log = (work_ / "host.log").string();
    fs::remove(log);
    Child child;
    child.Start(argv, log);
    while (child.Running()) ::usleep(5000);
    EXPECT_EQ(child.HowEnded(), "exit code 2") << c.says;
    const std::string said = ReadText(log);
    EXPECT_NE(said.find(c.says), std::string::npos) << said;
    EXPECT_FALSE(fs::exists(out));
  }
}

}  // namespace
}  // namespace sirupp::grade
