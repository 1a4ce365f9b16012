#pragma once
// The smooth paths of tracking tasks (`track:` in a suite, docs/grading.md) and the movement plan
// that makes sirupp-control's PIC-SERVO profile generators follow them.
//
// A joint's path (`JointPath`) is a chain of quintic pieces between knots, each knot a time, a
// position, a velocity and an acceleration: every piece meets its knots' values, so position,
// velocity and acceleration are continuous (C2) along the whole path. Before its first knot it
// holds the first position at rest, after its last knot the last one. Three shapes:
//  - back and forth (`shape: back_and_forth`): one joint, centre -> centre + A -> centre - A ->
//    centre per cycle, each leg a minimum-jerk move s(u) = 10u^3 - 15u^4 + 6u^5 (the quintic at
//    rest at both ends); the legs of size A take a quarter of the period each, the one across the
//    centre half of it;
//  - a spline through waypoints (`shape: spline`): every joint at once from the start pose at
//    time 0 through given poses at given times. At each waypoint the velocity and acceleration are
//    those of the cubic spline through the waypoints that starts and ends at rest (clamped); at the
//    start and the last waypoint the path is at rest with no acceleration;
//  - a chirp (`shape: chirp`): one joint swept in frequency about its start (JointPath::Chirp).
// Peaks (position, speed, acceleration) are exact: each piece's extremes are at its ends or where
// the next derivative is zero (found by bisection), so the suite checks the whole path.
//
// The plan: the chip has only trapezoidal moves, so the path is handed to it as a move per moving
// joint every `knot_ticks` servo ticks (16 ticks, 8.192 ms): the goal is the turning point ahead
// (where the joint next stops or reverses), the top speed the path's speed at the knot's end and
// the acceleration the change of speed over the knot, so the profile's speed ramps from knot to
// knot like the path's. Each move is tried first on the chip's own profile generators
// (control::ServoBank) and its speed corrected by half the error it would leave, so no drift
// builds up (test_grade_suite: within 0.005 deg, speed within 1 % of its peak).
// Every controller is measured against the path itself; a controller library and the baseline get
// the chip's set-points, a process controller the path as a file (grade/reference.hpp).

#include <string>
#include <vector>

#include "core/robot_model.hpp"

namespace sirupp::grade {

class JointPath {
 public:
  struct Sample {
    double position = 0;      // rad or m
    double velocity = 0;      // rad/s or m/s
    double acceleration = 0;  // rad/s^2 or m/s^2
  };
  struct Knot {
    double t_s = 0;
    Sample at;
  };
  // The largest (or smallest) value of a figure along the path and when it happens.
  struct Extreme {
    double value = 0;
    double t_s = 0;
  };

  JointPath() = default;
  // Knots in time order (times strictly increasing; at least one).
  explicit JointPath(std::vector<Knot> knots);
  // At rest at `position` all along.
  static JointPath Hold(double position);
  // Back and forth around `centre` by `amplitude` (SI, > 0), `cycles` times of `period_s` each.
  static JointPath BackAndForth(double centre, double amplitude, double period_s, int cycles);
  // A chirp about `centre`: amplitude x w(t) x sin(phase), the frequency sweeping linearly from
  // `from_hz` to `to_hz` over `duration_s`; w fades in over the first period (1 / from_hz) and out
  // over the last (1 / to_hz) as minimum-jerk ramps, so it starts and ends at rest on the centre.
  // Held as quintic pieces through the exact chirp's position, velocity and acceleration at knots
  // 1/64 of the fastest period apart (C2).
  static JointPath Chirp(double centre, double amplitude, double from_hz, double to_hz,
                         double duration_s);

  // The path at time t (s); before the first knot at rest there, after the last at rest there.
  Sample At(double t_s) const;
  double end_s() const;
  // Whether the joint moves at all.
  bool moves() const;
  Extreme peak_velocity() const;      // the largest |velocity|
  Extreme peak_acceleration() const;  // the largest |acceleration|
  Extreme lowest() const;             // the smallest position
  Extreme highest() const;            // the largest position
  // The position where the path next comes to rest or reverses after time t (the end's position
  // once past the last such point).
  double NextWaypoint(double t_s) const;
  // The times the path comes to rest or reverses, in order (the last knot's time last).
  const std::vector<double>& turns() const { return turns_; }

 private:
  struct Piece {
    double start_s = 0, duration_s = 0;
    double c[6] = {0, 0, 0, 0, 0, 0};  // position = sum c[k] u^k, u = (t - start) / duration
  };
  // The extreme of derivative `order` (0 position, 1 velocity, 2 acceleration), signed `sign`
  // (+1 largest, -1 smallest, 0 largest magnitude).
  Extreme Find(int order, int sign) const;
  std::vector<Piece> pieces_;
  Sample first_, last_;
  double start_s_ = 0;
  std::vector<double> turns_;
};

// Every joint's path: a tracking task's reference.
class Path {
 public:
  Path() = default;
  explicit Path(std::vector<JointPath> joints) : joints_(std::move(joints)) {}
  // One joint on `path`, the others holding their start.
  static Path OneJoint(const std::vector<double>& start, int joint, JointPath path);
  // From `start` at rest at time 0 through `poses[i]` (one value per joint, SI) at `times_s[i]`
  // (strictly increasing, after 0), at rest at the last one.
  static Path Spline(const std::vector<double>& start, const std::vector<double>& times_s,
                     const std::vector<std::vector<double>>& poses);

  size_t num_joints() const { return joints_.size(); }
  const JointPath& joint(size_t j) const { return joints_[j]; }
  double end_s() const;  // the latest end of any joint

 private:
  std::vector<JointPath> joints_;
};

// The movement-plan lines (after a `units` line the caller writes) that make sirupp-control's
// profiles follow `path` on every joint that moves, one move per moving joint every `knot_ticks`
// ticks, the plan starting one tick after tick 0 (as the grader starts it). Values in degrees (mm
// for a prismatic joint), the plan's `units deg mm`.
// `start`: every joint's position when the plan starts (SI). The moves are chosen on the chip's
// own profile generators (control::ServoBank), so the plan's set-point lands on the path.
std::string FollowPlanLines(const Path& path, const core::RobotModel& model,
                            const std::vector<double>& start, int knot_ticks);
inline constexpr int kKnotTicks = 16;

}  // namespace sirupp::grade
