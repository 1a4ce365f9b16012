#pragma once
// The smooth path of a tracking task (`track:` in a suite, docs/grading.md) and the movement plan
// that makes sirupp-control's PIC-SERVO profile generators follow it.
//
// The path: one joint back and forth around a centre, centre -> centre + A -> centre - A ->
// centre per cycle, each leg a minimum-jerk move s(u) = 10u^3 - 15u^4 + 6u^5 (u = t / T of the
// leg), at rest at each turning point: position, velocity and acceleration are continuous. The
// two legs of size A take a quarter of the period each, the leg across the centre half of it. It
// starts at time 0 (tick 0) and holds the centre after its end.
//
// The plan: the chip has only trapezoidal moves, so the path is handed to it as a move every
// `knot_ticks` servo ticks (16 ticks, 8.192 ms): the goal is the turning point ahead, the top speed
// the path's speed at the knot's end and the acceleration the change of speed over the knot, so
// the profile's speed ramps from knot to knot like the path's. Each move is tried first on the
// chip's own profile generators (control::ServoBank) and its speed corrected by half the error it
// would leave, so no drift builds up (test_grade_suite: within 0.005 deg, speed within 1 % of its
// peak).
// Every controller is measured against the path itself; a controller library and the baseline get
// the chip's set-points, a process controller the path as a file (grade/reference.hpp).

#include <string>
#include <vector>

#include "core/robot_model.hpp"

namespace sirupp::grade {

class MinJerkPath {
 public:
  struct Sample {
    double position = 0;      // rad or m
    double velocity = 0;      // rad/s or m/s
    double acceleration = 0;  // rad/s^2 or m/s^2
  };

  // Back and forth around `centre` by `amplitude` (SI, > 0), `cycles` times of `period_s` each.
  static MinJerkPath BackAndForth(double centre, double amplitude, double period_s, int cycles);

  // The path at time t (s); before 0 the start at rest, after the end the last point at rest.
  Sample At(double t_s) const;
  double end_s() const;
  double peak_velocity() const;      // the largest |velocity| (1.875 d / T on the longest leg)
  double peak_acceleration() const;  // the largest |acceleration| (5.7735 d / T^2)
  // The turning point the path is heading for at time t (the end of the leg t lies in).
  double NextWaypoint(double t_s) const;

 private:
  struct Leg {
    double start_s = 0, duration_s = 0, from = 0, to = 0;
  };
  std::vector<Leg> legs_;
};

// The movement-plan lines (after a `units` line the caller writes) that make sirupp-control's
// profile on `joint` (0-based) follow `path`, one move every `knot_ticks` ticks, the plan starting
// one tick after tick 0 (as the grader starts it). Values in degrees (mm for a prismatic joint),
// the plan's `units deg mm`.
// `start`: every joint's position when the plan starts (SI). The moves are chosen on the chip's
// own profile generators (control::ServoBank), so the plan's set-point lands on the path.
std::string FollowPlanLines(const MinJerkPath& path, const core::RobotModel& model, int joint,
                            const std::vector<double>& start, int knot_ticks);
inline constexpr int kKnotTicks = 16;

}  // namespace sirupp::grade
