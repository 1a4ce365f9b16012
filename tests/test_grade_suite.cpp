// Grading suites (grade/suite.hpp): every validation rule gives one error naming the suite's
// file:line:column, the key and what is allowed; good suites become the tasks they say, and a
// tracking task's minimum-jerk path is followed by the PIC-SERVO profile its generated plan drives
// (grade/trajectory.hpp), run here on the chip model itself.

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "control/plan.hpp"
#include "control/servo_bank.hpp"
#include "core/errors.hpp"
#include "core/model_loader.hpp"
#include "grade/suite.hpp"
#include "grade/trajectory.hpp"
#include "tests/helpers.hpp"

namespace sirupp::grade {
namespace {

constexpr double kDeg = 3.14159265358979323846 / 180;

std::string Same(const std::string& path) { return path; }

const core::RobotModel& Puma() {
  static const core::RobotModel model = core::LoadRobotModel("config/robots/puma260.yaml");
  return model;
}

// A suite with this header: the tasks text starts on line 4.
std::string WithTasks(const std::string& tasks) {
  return "format: sirupp-grade-suite-1\nname: t\ntasks:\n" + tasks;
}

Suite Parse(const std::string& text) { return ParseSuite(text, "s.yaml", &Same); }

std::string Error(const std::string& text) {
  return testing::ErrorText<core::ConfigError>([&] { Parse(text); });
}

struct Case {
  const char* rule;
  std::string text;
  const char* where;  // "s.yaml:LINE:COLUMN: " the message starts with
  const char* says;   // and contains
};

TEST(GradeSuite, EveryRuleNamesTheLineTheColumnAndWhatIsAllowed) {
  const std::string step = "  - {name: a, step: {joint: 2, to_deg: 30}, duration_s: 2}\n";
  const std::vector<Case> cases = {
      {"yaml syntax", "format: [\n", "s.yaml:", "s.yaml:"},
      {"unknown top-level key",
       "format: sirupp-grade-suite-1\nname: t\ncolour: red\ntasks:\n" + step,
       "s.yaml:3:1: ", "unknown key 'colour'"},
      {"format missing", "name: t\ntasks:\n" + step,
       "s.yaml:1:1: ", "missing required key 'format'"},
      {"another format", "format: sirupp-grade-suite-9\nname: t\ntasks:\n" + step,
       "s.yaml:1:9: ", "allowed sirupp-grade-suite-1"},
      {"name missing", "format: sirupp-grade-suite-1\ntasks:\n" + step,
       "s.yaml:1:1: ", "missing required key 'name'"},
      {"model file missing",
       "format: sirupp-grade-suite-1\nname: t\nmodel: nope.yaml\ntasks:\n" + step, "nope.yaml",
       "nope.yaml"},
      {"limit out of range",
       "format: sirupp-grade-suite-1\nname: t\nlimits: {tick_s: 0}\ntasks:\n" + step,
       "s.yaml:3:18: ", "limits.tick_s: 0 is not allowed; expected a finite number in [0.01, 60]"},
      {"unknown limit",
       "format: sirupp-grade-suite-1\nname: t\nlimits: {hours: 1}\ntasks:\n" + step,
       "s.yaml:3:", "unknown key 'hours'"},
      {"negative threshold",
       "format: sirupp-grade-suite-1\nname: t\npass: {settling_s: -1}\ntasks:\n" + step,
       "s.yaml:3:20: ", "pass.settling_s: -1 is not allowed; expected a finite number >= 0"},
      {"unknown threshold",
       "format: sirupp-grade-suite-1\nname: t\npass: {fast: 1}\ntasks:\n" + step,
       "s.yaml:3:", "unknown key 'fast'"},
      {"no tasks", "format: sirupp-grade-suite-1\nname: t\n",
       "s.yaml:1:1: ", "missing required key 'tasks'"},
      {"empty task list", "format: sirupp-grade-suite-1\nname: t\ntasks: []\n",
       "s.yaml:3:8: ", "a list of 0 entries is not allowed"},
      {"unknown task key",
       WithTasks("  - {name: a, step: {joint: 2, to_deg: 3}, duration_s: 2, colour: red}\n"),
       "s.yaml:4:", "unknown key 'colour'"},
      {"bad task name", WithTasks("  - {name: a b, hold: true, duration_s: 1}\n"),
       "s.yaml:4:", "task name 'a b': allowed letters, digits"},
      {"start_deg count",
       WithTasks("  - {name: a, hold: true, start_deg: [1, 2], duration_s: 1}\n"),
       "s.yaml:4:", "expected a list of 6 numbers"},
      {"start outside limits",
       WithTasks("  - {name: a, hold: true, start_deg: [0, 170, 0, 0, 0, 0], duration_s: 1}\n"),
       "s.yaml:4:", "joint 2 start 170 is outside the joint's limits"},
      {"duration out of range", WithTasks("  - {name: a, hold: true, duration_s: 700}\n"),
       "s.yaml:4:", "700 is not allowed"},
      {"no command", WithTasks("  - {name: a, duration_s: 1}\n"),
       "s.yaml:4:5: ", "needs exactly one of plan, step, hold, track (has 0)"},
      {"two commands",
       WithTasks("  - {name: a, hold: true, step: {joint: 1, to_deg: 3}, duration_s: 1}\n"),
       "s.yaml:4:5: ", "(has 2)"},
      {"plan file missing", WithTasks("  - {name: a, plan: nope.plan, duration_s: 1}\n"),
       "nope.plan", "nope.plan"},
      {"step joint out of range",
       WithTasks("  - {name: a, step: {joint: 9, to_deg: 3}, duration_s: 1}\n"),
       "s.yaml:4:29: ", "tasks[0].step.joint: 9 is not allowed; expected an integer in [1, 6]"},
      {"step goal outside the limits",
       WithTasks("  - {name: a, step: {joint: 2, to_deg: 300}, duration_s: 1}\n"),
       "s.yaml:4 task a (generated plan):", "outside"},
      {"step speed out of range",
       WithTasks("  - {name: a, step: {joint: 2, to_deg: 3, speed_percent: 0}, duration_s: 1}\n"),
       "s.yaml:4:", "0 is not allowed"},
      {"hold false", WithTasks("  - {name: a, hold: false, duration_s: 1}\n"),
       "s.yaml:4:", "hold: only true is allowed"},
      {"track amplitude out of range",
       WithTasks("  - {name: a, track: {joint: 2, amplitude_deg: 0.1, period_s: 4, cycles: 1}, "
                 "duration_s: 5}\n"),
       "s.yaml:4:", "0.1 is not allowed"},
      {"track period out of range",
       WithTasks("  - {name: a, track: {joint: 2, amplitude_deg: 10, period_s: 0, cycles: 1}, "
                 "duration_s: 5}\n"),
       "s.yaml:4:", "0 is not allowed"},
      {"track cycles out of range",
       WithTasks("  - {name: a, track: {joint: 2, amplitude_deg: 10, period_s: 1, cycles: 21}, "
                 "duration_s: 5}\n"),
       "s.yaml:4:", "tasks[0].track.cycles: 21 is not allowed; expected an integer in [1, 20]"},
      {"track leaves the soft limits",
       WithTasks("  - {name: a, track: {joint: 2, amplitude_deg: 160, period_s: 20, cycles: 1}, "
                 "duration_s: 25}\n"),
       "s.yaml:4:", "leaves the soft limits [-155.5, 155.5]"},
      {"track too fast",
       WithTasks("  - {name: a, track: {joint: 2, amplitude_deg: 30, period_s: 1, cycles: 1}, "
                 "duration_s: 2}\n"),
       "s.yaml:4:", "period 1 s is too short: the path's peak speed 225 is above joint 2's cap 90"},
      {"track accelerates too hard",
       WithTasks("  - {name: a, track: {joint: 2, amplitude_deg: 1, period_s: 0.4, cycles: 1}, "
                 "duration_s: 2}\n"),
       "s.yaml:4:61: ", "the path's peak acceleration 577.35 is above joint 2's cap 360"},
      {"track too long",
       WithTasks("  - {name: a, track: {joint: 2, amplitude_deg: 10, period_s: 20, cycles: 2}, "
                 "duration_s: 50}\n"),
       "s.yaml:4:", "cycles x period_s = 40 s; allowed at most 30 s"},
      {"track longer than the task",
       WithTasks("  - {name: a, track: {joint: 2, amplitude_deg: 10, period_s: 4, cycles: 2}, "
                 "duration_s: 5}\n"),
       "s.yaml:4:", "cycles x period_s = 8 s is longer than the task's duration_s 5"},
      {"track shape unknown",
       WithTasks("  - {name: a, track: {shape: circle, joint: 2}, duration_s: 5}\n"),
       "s.yaml:4:", "'circle' is not allowed; expected one of: back_and_forth, spline"},
      {"spline with a back_and_forth key",
       WithTasks(
           "  - {name: a, track: {shape: spline, joint: 2, waypoints: [{at_s: 2, deg: [0, 10, "
           "0, 0, 0, 0]}]}, duration_s: 5}\n"),
       "s.yaml:4:", "unknown key 'joint'"},
      {"spline waypoint with the wrong joint count",
       WithTasks("  - {name: a, track: {shape: spline, waypoints: [{at_s: 2, deg: [0, 10]}]}, "
                 "duration_s: 5}\n"),
       "s.yaml:4:", "deg"},
      {"spline waypoints out of time order",
       WithTasks("  - {name: a, track: {shape: spline, waypoints: [{at_s: 2, deg: [0, 10, 0, 0, 0, "
                 "0]}, {at_s: 1, deg: [0, 0, 0, 0, 0, 0]}]}, duration_s: 5}\n"),
       "s.yaml:4:", "at_s 1 must be at least 0.05 s after the waypoint before (2 s)"},
      {"spline waypoint after the task",
       WithTasks("  - {name: a, track: {shape: spline, waypoints: [{at_s: 6, deg: [0, 10, 0, 0, 0, "
                 "0]}]}, duration_s: 5}\n"),
       "s.yaml:4:", "at_s 6 is after the task's duration_s 5"},
      {"spline waypoint outside the soft limits",
       WithTasks(
           "  - {name: a, track: {shape: spline, waypoints: [{at_s: 4, deg: [0, 156, 0, 0, 0, "
           "0]}]}, duration_s: 5}\n"),
       "s.yaml:4:", "joint 2 at 156 is outside its soft limits [-155.5, 155.5]"},
      {"spline swings past the soft limits between waypoints",
       WithTasks(
           "  - {name: a, track: {shape: spline, waypoints: [{at_s: 3, deg: [0, 140, 0, 0, 0, "
           "0]}, {at_s: 5, deg: [0, 140, 0, 0, 0, 0]}, {at_s: 8, deg: [0, 0, 0, 0, 0, "
           "0]}]}, duration_s: 9}\n"),
       "s.yaml:4:",
       "the spline between waypoints 1 and 2: joint 2 reaches 160 deg at 4 s, outside "
       "its soft limits [-155.5, 155.5] deg"},
      {"spline too fast",
       WithTasks(
           "  - {name: a, track: {shape: spline, waypoints: [{at_s: 0.5, deg: [0, 30, 0, 0, 0, "
           "0]}]}, duration_s: 1}\n"),
       "s.yaml:4:",
       "the spline between the start and waypoint 1: joint 2's speed reaches 112.5 "
       "deg/s at 0.25 s, above its cap 90 deg/s"},
      {"spline accelerates too hard",
       WithTasks("  - {name: a, track: {shape: spline, waypoints: [{at_s: 1, deg: [0, 0, 0, 0, 0, "
                 "0]}, {at_s: 1.1, deg: [0, 2, 0, 0, 0, 0]}]}, duration_s: 2}\n"),
       "s.yaml:4:", "between waypoints 1 and 2: joint 2's acceleration reaches 655.8"},
      {"spline never moves",
       WithTasks("  - {name: a, track: {shape: spline, waypoints: [{at_s: 1, deg: [0, 0, 0, 0, 0, "
                 "0]}]}, duration_s: 2}\n"),
       "s.yaml:4:", "the waypoints never leave the start pose"},
      {"spline plan too large",
       WithTasks(
           "  - {name: a, track: {shape: spline, waypoints: [{at_s: 15, deg: [10, 10, 10, 10, "
           "10, 10]}, {at_s: 29, deg: [0, 0, 0, 0, 0, 0]}]}, duration_s: 30}\n"),
       "s.yaml:4:", "bytes; allowed at most 262144 (one ARM_PLAN)"},
      {"chirp with a spline key",
       WithTasks("  - {name: a, track: {shape: chirp, joint: 2, amplitude_deg: 5, from_hz: 0.5, "
                 "to_hz: 1, sweep_s: 6, waypoints: []}, duration_s: 7}\n"),
       "s.yaml:4:", "unknown key 'waypoints'"},
      {"chirp shorter than its fades",
       WithTasks("  - {name: a, track: {shape: chirp, joint: 2, amplitude_deg: 5, from_hz: 0.5, "
                 "to_hz: 1, sweep_s: 2}, duration_s: 7}\n"),
       "s.yaml:4:",
       "sweep_s 2 s is shorter than its fade in and out (1 / from_hz + 1 / to_hz = 3 s)"},
      {"chirp too fast",
       WithTasks("  - {name: a, track: {shape: chirp, joint: 2, amplitude_deg: 20, from_hz: 0.5, "
                 "to_hz: 2, sweep_s: 6}, duration_s: 7}\n"),
       "s.yaml:4:", "the chirp: joint 2's speed reaches"},
      {"payload out of range",
       WithTasks("  - {name: a, hold: true, arm: {payload_kg: 60}, duration_s: 1}\n"),
       "s.yaml:4:", "60 is not allowed"},
      {"friction scale out of range",
       WithTasks("  - {name: a, hold: true, arm: {friction_scale: -1}, duration_s: 1}\n"),
       "s.yaml:4:", "-1 is not allowed"},
      {"gravity neither on nor off",
       WithTasks("  - {name: a, hold: true, arm: {gravity: sideways}, duration_s: 1}\n"),
       "s.yaml:4:", "'sideways' is not allowed; expected one of: on, off"},
      {"disturbance above the effort limit",
       WithTasks(
           "  - {name: a, hold: true, disturbance: {joint: 2, effort: 99, from_s: 0, to_s: 1}, "
           "duration_s: 1}\n"),
       "s.yaml:4:", "99 is not allowed"},
      {"disturbance after the task",
       WithTasks(
           "  - {name: a, hold: true, disturbance: {joint: 2, effort: 1, from_s: 3, to_s: 4}, "
           "duration_s: 1}\n"),
       "s.yaml:4:", "3 is not allowed"},
      {"disturbance ends before it starts",
       WithTasks("  - {name: a, hold: true, disturbance: {joint: 2, effort: 1, from_s: 0.5, to_s: "
                 "0.2}, duration_s: 1}\n"),
       "s.yaml:4:", "to_s 0.2 must be after from_s 0.5"},
      {"task name used twice",
       WithTasks(
           "  - {name: a, hold: true, duration_s: 1}\n  - {name: a, hold: true, duration_s: 1}\n"),
       "s.yaml:5:5: ", "task name 'a' is used already at line 4"},
  };
  for (const Case& c : cases) {
    const std::string error = Error(c.text);
    EXPECT_EQ(error.rfind(c.where, 0), 0u) << c.rule << ": " << error;
    EXPECT_NE(error.find(c.says), std::string::npos) << c.rule << ": " << error;
  }
}

TEST(GradeSuite, TheShippedSuitesLoad) {
  const Suite basic = LoadSuite("config/grading/basic.yaml", &Same);
  ASSERT_EQ(basic.tasks.size(), 13u);
  EXPECT_EQ(basic.tasks[0].kind, "plan");
  EXPECT_EQ(basic.tasks[8].kind, "step");
  EXPECT_NEAR(basic.tasks[8].goal[1], 30 * kDeg, 1e-12);
  const Suite advanced = LoadSuite("config/grading/advanced.yaml", &Same);
  ASSERT_GE(advanced.tasks.size(), 2u);
  const Task& track = advanced.tasks[0];
  EXPECT_EQ(track.kind, "track");
  ASSERT_TRUE(track.track.has_value());
  EXPECT_EQ(track.track->shape, "back_and_forth");
  EXPECT_TRUE(track.track->path.joint(1).moves());
  EXPECT_FALSE(track.track->path.joint(0).moves());
  EXPECT_DOUBLE_EQ(track.track->path.end_s(), 8);
  // The plan runs the joint back to where it started.
  EXPECT_NEAR(track.goal[1], track.start[1], 1e-12);
  EXPECT_LT(track.plan_text.size(), control::kMaxPlanBytes);
  for (const Task& task : advanced.tasks) {
    if (!task.track) continue;
    RecordProperty(task.name + "_plan_bytes", std::to_string(task.plan_text.size()));
    RecordProperty(task.name + "_plan_fnv1a", core::Fnv1aHex(task.plan_text));
  }
}

TEST(GradeSuite, AMinimumJerkPathHasItsKnownShape) {
  const JointPath path = JointPath::BackAndForth(0.1, 0.5, 4, 2);
  EXPECT_DOUBLE_EQ(path.end_s(), 8);
  // At rest on the centre, then at the turning points, at the quarter and three quarter periods.
  for (double t : {0.0, 1.0, 3.0, 4.0, 5.0, 7.0, 8.0, 9.0}) {
    EXPECT_NEAR(path.At(t).velocity, 0, 1e-12) << t;
    EXPECT_NEAR(path.At(t).acceleration, 0, 1e-9) << t;
  }
  EXPECT_NEAR(path.At(1).position, 0.6, 1e-12);
  EXPECT_NEAR(path.At(3).position, -0.4, 1e-12);
  EXPECT_NEAR(path.At(4).position, 0.1, 1e-12);
  // Half way along a leg: half the distance, the peak speed 1.875 d / T.
  EXPECT_NEAR(path.At(0.5).position, 0.35, 1e-12);
  EXPECT_NEAR(path.At(2).velocity, -1.875 * 1.0 / 2, 1e-12);
  EXPECT_NEAR(path.peak_velocity().value, 1.875 * 1.0 / 2, 1e-12);
  EXPECT_NEAR(std::abs(path.At(path.peak_velocity().t_s).velocity), 1.875 * 1.0 / 2, 1e-12);
  EXPECT_NEAR(path.peak_acceleration().value, 5.773502691896258 * 0.5 / 1, 1e-12);
  EXPECT_NEAR(path.highest().value, 0.6, 1e-12);
  EXPECT_NEAR(path.lowest().value, -0.4, 1e-12);
  EXPECT_NEAR(path.lowest().t_s, 3, 1e-9);
  // Velocity and acceleration are the derivatives of the position (central differences).
  const double h = 1e-5;
  for (double t = 0.05; t < 8; t += 0.37) {
    EXPECT_NEAR((path.At(t + h).position - path.At(t - h).position) / (2 * h), path.At(t).velocity,
                1e-6)
        << t;
    EXPECT_NEAR((path.At(t + h).velocity - path.At(t - h).velocity) / (2 * h),
                path.At(t).acceleration, 1e-5)
        << t;
  }
  EXPECT_DOUBLE_EQ(path.NextWaypoint(0.5), 0.6);
  EXPECT_DOUBLE_EQ(path.NextWaypoint(2.5), -0.4);
  EXPECT_DOUBLE_EQ(path.NextWaypoint(100), 0.1);
}

TEST(GradeSuite, ASplinePassesItsWaypointsAtRestAtBothEndsAndIsC2) {
  // Symmetric: 0 -> 1 -> 0 in two seconds. The clamped cubic spline through these points has at
  // t = 1 the velocity 0 and the acceleration -6 (its second derivatives solve 2 M0 + M1 = 6,
  // M0 + 4 M1 + M2 = -12, M1 + 2 M2 = 6).
  const Path symmetric = Path::Spline({0, 0.5}, {1, 2}, {{1, 0.5}, {0, 0.5}});
  EXPECT_NEAR(symmetric.joint(0).At(1).velocity, 0, 1e-12);
  EXPECT_NEAR(symmetric.joint(0).At(1).acceleration, -6, 1e-12);
  EXPECT_NEAR(symmetric.joint(0).highest().value, 1, 1e-12);
  EXPECT_FALSE(symmetric.joint(1).moves());
  EXPECT_DOUBLE_EQ(symmetric.joint(1).At(1.3).position, 0.5);

  const std::vector<double> times = {1, 2.5, 4};
  const std::vector<std::vector<double>> poses = {{0.5, -0.2}, {-0.3, 0.4}, {0.1, 0.1}};
  const Path path = Path::Spline({0, 0}, times, poses);
  EXPECT_DOUBLE_EQ(path.end_s(), 4);
  for (size_t j = 0; j < 2; ++j) {
    const JointPath& p = path.joint(j);
    EXPECT_TRUE(p.moves());
    for (size_t i = 0; i < times.size(); ++i)
      EXPECT_NEAR(p.At(times[i]).position, poses[i][j], 1e-12);
    for (double t : {0.0, 4.0, 5.0}) {  // at rest, without acceleration, at both ends and after
      EXPECT_NEAR(p.At(t).velocity, 0, 1e-12) << t;
      EXPECT_NEAR(p.At(t).acceleration, 0, 1e-9) << t;
    }
    EXPECT_NEAR(p.At(-1).position, 0, 1e-12);
    EXPECT_NEAR(p.At(9).position, poses.back()[j], 1e-12);
    // C2 across each waypoint.
    const double e = 1e-9;
    for (double t : times) {
      EXPECT_NEAR(p.At(t - e).position, p.At(t + e).position, 1e-8) << t;
      EXPECT_NEAR(p.At(t - e).velocity, p.At(t + e).velocity, 1e-7) << t;
      EXPECT_NEAR(p.At(t - e).acceleration, p.At(t + e).acceleration, 1e-6) << t;
    }
    // Velocity and acceleration are the position's derivatives (central differences).
    const double h = 1e-5;
    for (double t = 0.05; t < 4; t += 0.13) {
      EXPECT_NEAR((p.At(t + h).position - p.At(t - h).position) / (2 * h), p.At(t).velocity, 1e-6);
      EXPECT_NEAR((p.At(t + h).velocity - p.At(t - h).velocity) / (2 * h), p.At(t).acceleration,
                  1e-5);
    }
    // The peaks are the largest values along the whole path (checked every 0.1 ms).
    double v_max = 0, a_max = 0, lo = 1e9, hi = -1e9;
    for (double t = 0; t <= 4; t += 1e-4) {
      const JointPath::Sample s = p.At(t);
      v_max = std::max(v_max, std::abs(s.velocity));
      a_max = std::max(a_max, std::abs(s.acceleration));
      lo = std::min(lo, s.position);
      hi = std::max(hi, s.position);
    }
    EXPECT_NEAR(p.peak_velocity().value, v_max, 1e-6);
    EXPECT_GE(p.peak_velocity().value, v_max);
    EXPECT_NEAR(p.peak_acceleration().value, a_max, 1e-4);
    EXPECT_GE(p.peak_acceleration().value, a_max - 1e-12);
    EXPECT_NEAR(p.lowest().value, lo, 1e-8);
    EXPECT_NEAR(p.highest().value, hi, 1e-8);
    // Each turning point is where the velocity changes sign.
    for (double turn : p.turns()) {
      if (turn >= p.end_s()) continue;
      EXPECT_LE(p.At(turn - 1e-3).velocity * p.At(turn + 1e-3).velocity, 0) << turn;
      EXPECT_DOUBLE_EQ(p.NextWaypoint(turn - 1e-3), p.At(turn).position);
    }
  }
}

TEST(GradeSuite, AChirpStartsAndEndsAtRestAndSweepsItsFrequency) {
  // 10 deg about 0.2 rad, 0.5 Hz to 2 Hz over 8 s.
  const double a = 10 * kDeg;
  const JointPath path = JointPath::Chirp(0.2, a, 0.5, 2, 8);
  EXPECT_DOUBLE_EQ(path.end_s(), 8);
  for (double t : {0.0, 8.0, 9.0}) {
    EXPECT_NEAR(path.At(t).position, 0.2, 1e-12) << t;
    EXPECT_NEAR(path.At(t).velocity, 0, 1e-12) << t;
    EXPECT_NEAR(path.At(t).acceleration, 0, 1e-9) << t;
  }
  // Between the fades (2 s .. 7.5 s) the exact chirp: phase 2 pi (0.5 t + 0.09375 t^2).
  for (double t = 2.05; t < 7.5; t += 0.31) {
    const double phase = 2 * 3.14159265358979323846 * (0.5 * t + 0.09375 * t * t);
    EXPECT_NEAR(path.At(t).position, 0.2 + a * std::sin(phase), 1e-7) << t;
  }
  EXPECT_LE(path.highest().value, 0.2 + a + 1e-9);
  EXPECT_GT(path.highest().value, 0.2 + a - 1e-4);
  EXPECT_GE(path.lowest().value, 0.2 - a - 1e-9);
  // The peak speed comes late, where the frequency is highest: about a * 2 pi * 1.9 Hz.
  EXPECT_GT(path.peak_velocity().t_s, 6);
  EXPECT_NEAR(path.peak_velocity().value, a * 2 * 3.14159265358979323846 * 1.9, 0.15 * a * 12);
  const double h = 1e-5;
  for (double t = 0.05; t < 8; t += 0.23) {
    EXPECT_NEAR((path.At(t + h).position - path.At(t - h).position) / (2 * h), path.At(t).velocity,
                1e-6);
    EXPECT_NEAR((path.At(t + h).velocity - path.At(t - h).velocity) / (2 * h),
                path.At(t).acceleration, 1e-4);
  }
}

// The chip's profile generators run the generated plan as sirupp-control's sequencer does (a move
// loads and the profile steps in the same tick, `wait T` counts the state's utime, the plan's first
// step at tick 1): the set-point stays on the path.
struct Followed {
  double max_deviation = 0;    // rad
  double max_speed_error = 0;  // rad/s
  double end_deviation = 0;    // rad, after the plan ended
  int64_t plan_end_tick = -1;
};

// How closely the chip's set-point must follow the path: within 0.005 deg; where a joint reverses
// with some acceleration inside a knot (a spline, a chirp), the chip stops on the turning point
// and starts back at the next knot, lagging the path by up to about its acceleration x knot^2 / 2:
// twice that.
double PositionTolerance(const Task& task) {
  const Path& path = task.track->path;
  double peak_a = 0;
  for (size_t j = 0; j < path.num_joints(); ++j) {
    peak_a = std::max(peak_a, path.joint(j).peak_acceleration().value);
  }
  const double knot_s = kKnotTicks * Puma().servo_tick_s;
  return task.track->shape == "back_and_forth" ? 0.005 * kDeg
                                               : std::max(0.005 * kDeg, peak_a * knot_s * knot_s);
}

// How closely the chip's speed must follow the path: within 1 % of the path's peak; where a
// joint reverses with some acceleration inside a knot (a spline, a chirp), the chip stops on the
// turning point and starts back at the next knot, so the speed may lag by what the path's
// acceleration changes it over one knot.
double SpeedTolerance(const Task& task) {
  const Path& path = task.track->path;
  double peak_v = 0, peak_a = 0;
  for (size_t j = 0; j < path.num_joints(); ++j) {
    peak_v = std::max(peak_v, path.joint(j).peak_velocity().value);
    peak_a = std::max(peak_a, path.joint(j).peak_acceleration().value);
  }
  const double knot_s = kKnotTicks * Puma().servo_tick_s;
  return task.track->shape == "back_and_forth" ? 0.01 * peak_v
                                               : std::max(0.01 * peak_v, peak_a * knot_s);
}

Followed RunOnTheChip(const Task& task) {
  const core::RobotModel& model = Puma();
  const control::Plan plan = control::ParsePlan(task.plan_text, task.name, model, task.start);
  control::ServoBank bank(model);
  bank.ServoOn(task.start);
  std::vector<double> held;  // the start as the servos hold it (whole encoder counts)
  for (int k = 0; k < model.num_joints(); ++k) held.push_back(bank.SetpointPosition(k));
  // The path's last pose as the servos hold it (whole encoder counts).
  std::vector<double> last;
  for (size_t k = 0; k < task.start.size(); ++k) {
    last.push_back(task.track->path.joint(k).At(task.track->path.end_s()).position);
  }
  control::ServoBank at_end(model);
  at_end.ServoOn(last);
  const Path& path = task.track->path;
  const double tick_s = model.servo_tick_s;
  const auto utime = [&](int64_t tick) { return tick * 512; };
  size_t step = 0;
  int64_t wait_until = -1;
  Followed result;
  std::vector<double> positions = task.start;
  const auto ticks = static_cast<int64_t>(std::ceil(task.duration_s / tick_s));
  for (int64_t tick = 1; tick <= ticks; ++tick) {
    while (step < plan.steps.size()) {
      const control::PlanStep& s = plan.steps[step];
      if (s.kind == control::PlanStep::Kind::kWaitDone) {
        if (!bank.AllDone()) break;
      } else if (s.kind == control::PlanStep::Kind::kWaitTime) {
        if (wait_until < 0) wait_until = utime(tick) + std::llround(s.wait_s * 1e6);
        if (utime(tick) < wait_until) break;
        wait_until = -1;
      } else {
        bank.Load(s.moves);
      }
      ++step;
    }
    if (step == plan.steps.size() && bank.AllDone() && result.plan_end_tick < 0) {
      result.plan_end_tick = tick;
    }
    for (int k = 0; k < model.num_joints(); ++k)
      positions[static_cast<size_t>(k)] = bank.SetpointPosition(k);
    bank.Tick(positions);
    const double t = static_cast<double>(tick) * tick_s;
    double end_deviation = 0;
    for (int k = 0; k < model.num_joints(); ++k) {
      const JointPath& joint = path.joint(static_cast<size_t>(k));
      if (!joint.moves()) {
        EXPECT_DOUBLE_EQ(bank.SetpointPosition(k), held[static_cast<size_t>(k)]);
        continue;
      }
      const JointPath::Sample want = joint.At(t);
      const double deviation = std::abs(bank.SetpointPosition(k) - want.position);
      result.max_deviation = std::max(result.max_deviation, deviation);
      result.max_speed_error =
          std::max(result.max_speed_error, std::abs(bank.SetpointVelocity(k) - want.velocity));
      end_deviation =
          std::max(end_deviation, std::abs(bank.SetpointPosition(k) - at_end.SetpointPosition(k)));
    }
    if (t > path.end_s()) result.end_deviation = end_deviation;
  }
  return result;
}

TEST(GradeSuite, TheChipFollowsATrackingTasksPathWithinAFewThousandthsOfADegree) {
  const Suite advanced = LoadSuite("config/grading/advanced.yaml", &Same);
  int tracks = 0;
  for (const Task& task : advanced.tasks) {
    if (!task.track) continue;
    ++tracks;
    const Followed followed = RunOnTheChip(task);
    EXPECT_LT(followed.max_deviation, PositionTolerance(task)) << task.name;
    EXPECT_LT(followed.max_speed_error, SpeedTolerance(task)) << task.name;
    EXPECT_LT(followed.end_deviation, 1e-4 * kDeg) << task.name;
    EXPECT_GT(followed.plan_end_tick, 0) << task.name << ": the plan did not end";
    RecordProperty(task.name + "_max_deviation_deg", std::to_string(followed.max_deviation / kDeg));
  }
  EXPECT_EQ(tracks, 5);
  // A fast one near the caps, and one from a start away from zero.
  const Suite fast = Parse(WithTasks(
      "  - {name: f, track: {joint: 3, amplitude_deg: 30, period_s: 3, cycles: 2}, duration_s: "
      "6.5}\n"
      "  - {name: g, start_deg: [0, 20, -30, 0, 0, 0], track: {joint: 5, amplitude_deg: 40, "
      "period_s: 4, cycles: 1}, duration_s: 4.5}\n"
      "  - {name: h, start_deg: [10, 20, -30, 0, 10, 0], track: {shape: spline, waypoints: [{at_s: "
      "1.2, deg: [40, -10, 0, 60, -30, 70]}, {at_s: 2.6, deg: [-20, 30, -60, -50, 40, -60]}]}, "
      "duration_s: 3}\n"
      "  - {name: c, start_deg: [0, 30, 0, 0, 0, 0], track: {shape: chirp, joint: 2, "
      "amplitude_deg: 3, from_hz: 0.5, to_hz: 1.5, sweep_s: 6}, duration_s: 6.5}\n"));
  for (const Task& task : fast.tasks) {
    const Followed followed = RunOnTheChip(task);
    EXPECT_LT(followed.max_deviation, PositionTolerance(task)) << task.name;
    EXPECT_LT(followed.max_speed_error, SpeedTolerance(task)) << task.name;
    EXPECT_LT(followed.end_deviation, 1e-4 * kDeg) << task.name;
  }
}

}  // namespace
}  // namespace sirupp::grade
