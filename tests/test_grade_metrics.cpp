// The figures of a graded task (grade/metrics.hpp) on synthetic records whose answers are known:
// rise and settling time, overshoot, steady-state error, RMS and max tracking error, peak and RMS
// effort, time saturated, the effort-rate smoothness figure, and the pass checks they feed.

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <string>
#include <vector>

#include "core/model_loader.hpp"
#include "grade/metrics.hpp"

namespace sirupp::grade {
namespace {

constexpr double kDeg = 3.14159265358979323846 / 180;
constexpr double kTick = 0.001;  // s: round numbers for the synthetic records

const core::RobotModel& Puma() {
  static const core::RobotModel model = core::LoadRobotModel("config/robots/puma260.yaml");
  return model;
}

// `ticks` rows; joint 1 (index 0) from the functions (deg and N*m), the others at rest at 0.
struct Signals {
  std::function<double(double)> position = [](double) { return 0.0; };
  std::function<double(double)> reference = [](double) { return 0.0; };
  std::function<double(double)> goal = [](double) { return 0.0; };
  std::function<double(double)> effort = [](double) { return 0.0; };
};

TaskRecord Record(size_t ticks, const Signals& s, bool has_reference = true) {
  TaskRecord record;
  record.completed = true;
  record.num_joints = Puma().num_joints();
  record.tick_s = kTick;
  record.has_reference = has_reference;
  const auto n = static_cast<size_t>(record.num_joints);
  for (size_t row = 0; row < ticks; ++row) {
    const double t = static_cast<double>(row) * kTick;
    record.time_s.push_back(t);
    for (size_t j = 0; j < n; ++j) {
      record.position.push_back(j == 0 ? s.position(t) * kDeg : 0.0);
      record.reference.push_back(j == 0 ? s.reference(t) * kDeg : 0.0);
      record.goal.push_back(j == 0 ? s.goal(t) * kDeg : 0.0);
      record.effort.push_back(j == 0 ? s.effort(t) : 0.0);
    }
  }
  return record;
}

// A 10 deg step: the set-point jumps at 0; the joint ramps to 11 deg by 1.1 s (1 deg past the
// goal), back to 10 deg by 1.2 s, then stays.
Signals Step() {
  Signals s;
  s.goal = [](double) { return 10.0; };
  s.reference = [](double) { return 10.0; };
  s.position = [](double t) {
    if (t <= 1.1) return 10 * t;
    if (t <= 1.2) return 11 - 10 * (t - 1.1);
    return 10.0;
  };
  return s;
}

TEST(GradeMetrics, RiseSettlingAndOvershootOfAKnownStep) {
  const TaskMetrics m = ComputeMetrics(Puma(), Record(3001, Step()), Thresholds{});
  const JointMetrics& j = m.joints[0];
  EXPECT_TRUE(j.moves);
  EXPECT_NEAR(j.step, 10, 1e-9);
  // 10 % (1 deg) at 0.1 s, 90 % (9 deg) at 0.9 s.
  ASSERT_TRUE(j.rise_s.has_value());
  EXPECT_NEAR(*j.rise_s, 0.8, 1.5 * kTick);
  ASSERT_TRUE(j.overshoot_percent.has_value());
  EXPECT_NEAR(*j.overshoot_percent, 10, 1e-6);
  // The band is 2 % of 10 deg: inside it from 10.2 deg on the way back, at 1.18 s.
  ASSERT_TRUE(j.settling_s.has_value());
  EXPECT_NEAR(*j.settling_s, 1.18, 1.5 * kTick);
  EXPECT_NEAR(j.steady_state, 0, 1e-9);
  // The other joints do not move.
  EXPECT_FALSE(m.joints[1].moves);
  EXPECT_FALSE(m.joints[1].rise_s.has_value());
  EXPECT_TRUE(m.passed());
}

TEST(GradeMetrics, SettlingCountsFromWhenTheSetPointArrives) {
  // The set-point ramps to the goal over 0.5 s; the joint follows 0.2 s late, arriving at 0.7 s.
  Signals s;
  s.goal = [](double) { return 10.0; };
  s.reference = [](double t) { return t < 0.5 ? 20 * t : 10.0; };
  s.position = [](double t) { return t < 0.2 ? 0.0 : t < 0.7 ? 20 * (t - 0.2) : 10.0; };
  const TaskMetrics m = ComputeMetrics(Puma(), Record(2001, s), Thresholds{});
  ASSERT_TRUE(m.joints[0].settling_s.has_value());
  // Within 0.2 deg of 10 from 0.69 s; the set-point arrived at 0.5 s.
  EXPECT_NEAR(*m.joints[0].settling_s, 0.19, 1.5 * kTick);
  EXPECT_NEAR(*m.joints[0].overshoot_percent, 0, 1e-9);
}

TEST(GradeMetrics, AJointThatNeverGetsThereNeitherRisesNorSettles) {
  Signals s;
  s.goal = [](double) { return 10.0; };
  s.reference = [](double) { return 10.0; };
  s.position = [](double t) { return std::min(8 * t, 8.0); };  // stops at 80 %
  Thresholds pass;
  pass.rise_s = 1;
  pass.settling_s = 1;
  pass.steady_state_deg = 1.5;
  const TaskMetrics m = ComputeMetrics(Puma(), Record(2001, s), pass);
  EXPECT_FALSE(m.joints[0].rise_s.has_value());
  EXPECT_FALSE(m.joints[0].settling_s.has_value());
  EXPECT_NEAR(m.joints[0].steady_state, 2, 1e-9);
  const std::vector<std::string> want = {"joint 1: never reached 90 % of its step",
                                         "joint 1: did not settle within the task",
                                         "joint 1: steady-state error 2 deg > 1.5 deg"};
  EXPECT_EQ(m.failed_checks, want);
  EXPECT_FALSE(m.passed());
}

TEST(GradeMetrics, SteadyStateIsTheMeanErrorOverTheLastTenthOfASecond) {
  Signals s;
  s.goal = [](double) { return 10.0; };
  s.reference = [](double) { return 10.0; };
  // 9.7 deg until 1.9 s, then 9.5 deg: the last 0.1 s (101 rows from 1.9 s) see 0.5 deg off.
  s.position = [](double t) { return t < 1.9 - kTick / 2 ? 9.7 : 9.5; };
  const TaskMetrics m = ComputeMetrics(Puma(), Record(2001, s), Thresholds{});
  EXPECT_NEAR(m.joints[0].steady_state, 0.5, 1e-9);
}

TEST(GradeMetrics, TrackingErrorIsRmsAndMaxOfPositionMinusReference) {
  // 0.5 deg behind the reference for the first half, on it for the second: RMS 0.5 / sqrt(2).
  Signals s;
  s.reference = [](double t) { return 5 * std::sin(t); };
  s.position = [](double t) { return 5 * std::sin(t) - (t < 1 - kTick / 2 ? 0.5 : 0.0); };
  Thresholds pass;
  pass.rms_tracking_deg = 0.3;
  pass.max_tracking_deg = 0.4;
  const TaskMetrics m = ComputeMetrics(Puma(), Record(2000, s), pass);
  EXPECT_NEAR(m.joints[0].rms_tracking, 0.5 / std::sqrt(2), 1e-9);
  EXPECT_NEAR(m.joints[0].max_tracking, 0.5, 1e-9);
  EXPECT_EQ(m.worst_joint, 0);
  const std::vector<std::string> want = {"joint 1: RMS tracking error 0.353553 deg > 0.3 deg",
                                         "joint 1: max tracking error 0.5 deg > 0.4 deg"};
  EXPECT_EQ(m.failed_checks, want);
  // Without a reference the controller was given (a process controller on a step task), the
  // tracking checks do not apply; the figures are still there.
  const TaskMetrics unchecked = ComputeMetrics(Puma(), Record(2000, s, false), pass);
  EXPECT_TRUE(unchecked.passed());
  EXPECT_NEAR(unchecked.joints[0].rms_tracking, 0.5 / std::sqrt(2), 1e-9);
}

TEST(GradeMetrics, EffortPeakRmsSaturationAndRate) {
  const double limit = Puma().joints[0].effort_max;
  // 2 N*m for 1 s, then at the limit (negative) for 0.25 s, then 0.
  Signals s;
  s.effort = [limit](double t) {
    return t < 1 - kTick / 2 ? 2.0 : t < 1.25 - kTick / 2 ? -limit : 0.0;
  };
  Thresholds pass;
  pass.saturated_s = 0.2;
  const TaskMetrics m = ComputeMetrics(Puma(), Record(2000, s), pass);
  const JointMetrics& j = m.joints[0];
  EXPECT_DOUBLE_EQ(j.peak_effort, limit);
  EXPECT_NEAR(j.rms_effort, std::sqrt((1000 * 4.0 + 250 * limit * limit) / 2000), 1e-9);
  EXPECT_NEAR(j.saturated_s, 0.25, 1e-9);
  // Two jumps, 2 + limit and limit, each over one tick, among 1999 differences.
  const double rate =
      std::sqrt((std::pow((2 + limit) / kTick, 2) + std::pow(limit / kTick, 2)) / 1999);
  EXPECT_NEAR(j.effort_rate_rms, rate, 1e-6 * rate);
  const std::vector<std::string> want = {"joint 1: time saturated 0.25 s > 0.2 s"};
  EXPECT_EQ(m.failed_checks, want);
  // A smooth effort has a small rate: 1 N*m sine at 1 rad/s: RMS rate about 1/sqrt(2).
  Signals smooth;
  smooth.effort = [](double t) { return std::sin(t); };
  const TaskMetrics calm = ComputeMetrics(Puma(), Record(6284, smooth), Thresholds{});
  EXPECT_NEAR(calm.joints[0].effort_rate_rms, 1 / std::sqrt(2), 0.01);
  EXPECT_NEAR(calm.joints[0].rms_effort, 1 / std::sqrt(2), 0.01);
  EXPECT_DOUBLE_EQ(calm.joints[0].saturated_s, 0);
}

TEST(GradeMetrics, OnlyTheLastMoveCountsAsTheStep) {
  // A first move to 20 deg, then the goal changes to 10 deg at 1 s: the step is from where the
  // joint was then (20) to 10, i.e. -10 deg.
  Signals s;
  s.goal = [](double t) { return t < 1 ? 20.0 : 10.0; };
  s.reference = s.goal;
  s.position = [](double t) { return t < 1 ? 20 * t : std::max(10.0, 20 - 20 * (t - 1)); };
  const TaskMetrics m = ComputeMetrics(Puma(), Record(3001, s), Thresholds{});
  EXPECT_NEAR(m.joints[0].step, -10, 1e-6);
  ASSERT_TRUE(m.joints[0].rise_s.has_value());
  EXPECT_NEAR(*m.joints[0].rise_s, 0.4, 1.5 * kTick);
}

TEST(GradeMetrics, ASmallStepIsNotAMove) {
  Signals s;
  s.goal = [](double) { return 0.4; };
  s.reference = s.goal;
  s.position = [](double t) { return std::min(t, 0.4); };
  Thresholds pass;
  pass.settling_s = 0.001;
  pass.rise_s = 0.001;
  pass.overshoot_percent = 0;
  const TaskMetrics m = ComputeMetrics(Puma(), Record(1001, s), pass);
  EXPECT_FALSE(m.joints[0].moves);
  EXPECT_TRUE(m.passed());
}

TEST(GradeMetrics, TooShortARecordHasNoFigures) {
  const TaskMetrics m = ComputeMetrics(Puma(), Record(1, Step()), Thresholds{});
  ASSERT_EQ(m.joints.size(), 6u);
  EXPECT_FALSE(m.joints[0].moves);
}

// A tracking task's path may swing past the final goal on its way (0 -> 20 -> 10 deg, the path
// ending at 2 s): that is the path's doing, not an overshoot; after the path's end the joint goes
// 0.5 deg past the goal (5 % of the 10 deg step), and that is. The path sets the pace: no rise
// time.
TEST(GradeMetrics, OnATrackingTaskOnlyTheEndCountsForOvershootAndThereIsNoRiseTime) {
  Signals s;
  s.goal = [](double) { return 10.0; };
  s.reference = [](double t) { return t < 1 ? 20 * t : t < 2 ? 30 - 10 * t : 10.0; };
  s.position = [&s](double t) {
    if (t < 2) return s.reference(t);
    if (t < 2.5) return 10 + (t - 2);  // to 10.5 deg
    return 10.0;
  };
  TaskRecord record = Record(4001, s);
  Thresholds pass;
  pass.rise_s = 0.1;
  pass.overshoot_percent = 4;
  const TaskMetrics plain = ComputeMetrics(Puma(), record, pass);
  EXPECT_NEAR(*plain.joints[0].overshoot_percent, 100, 1e-6);  // 20 deg is 10 past the goal
  record.track = true;
  const TaskMetrics m = ComputeMetrics(Puma(), record, pass);
  const JointMetrics& j = m.joints[0];
  EXPECT_TRUE(j.moves);
  EXPECT_FALSE(j.rise_s.has_value());
  ASSERT_TRUE(j.overshoot_percent.has_value());
  EXPECT_NEAR(*j.overshoot_percent, 5, 0.05);
  ASSERT_EQ(m.failed_checks.size(), 1u);
  EXPECT_NE(m.failed_checks[0].find("joint 1: overshoot"), std::string::npos) << m.failed_checks[0];
}

}  // namespace
}  // namespace sirupp::grade
