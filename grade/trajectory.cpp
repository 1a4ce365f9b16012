#include "grade/trajectory.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>

#include "control/servo_bank.hpp"
#include "core/errors.hpp"
#include "core/motion_limits.hpp"

namespace sirupp::grade {
namespace {

constexpr double kPi = 3.14159265358979323846;
// Peak speed and acceleration of s(u) = 10u^3 - 15u^4 + 6u^5 per unit of distance and time.
constexpr double kPeakVelocity = 1.875;
constexpr double kPeakAcceleration = 5.773502691896258;  // 10 / sqrt(3)

// Degrees (mm for a prismatic joint) per SI unit.
double Shown(const core::RobotModel& model, int joint) {
  return model.joints[static_cast<size_t>(joint)].type == core::JointType::kRevolute ? 180 / kPi
                                                                                     : 1000;
}

// 6 significant digits for the plan's speeds and accelerations (the plan stays short; the
// profile's fixed point resolves far less).
std::string Short(double value) {
  char buffer[40];
  std::snprintf(buffer, sizeof buffer, "%.6g", value);
  return buffer;
}

}  // namespace

MinJerkPath MinJerkPath::BackAndForth(double centre, double amplitude, double period_s,
                                      int cycles) {
  MinJerkPath path;
  double t = 0;
  double at = centre;
  const auto leg = [&](double to, double duration_s) {
    path.legs_.push_back({t, duration_s, at, to});
    t += duration_s;
    at = to;
  };
  for (int c = 0; c < cycles; ++c) {
    leg(centre + amplitude, period_s / 4);
    leg(centre - amplitude, period_s / 2);
    leg(centre, period_s / 4);
  }
  return path;
}

MinJerkPath::Sample MinJerkPath::At(double t_s) const {
  Sample sample;
  if (legs_.empty()) return sample;
  if (t_s <= legs_.front().start_s) {
    sample.position = legs_.front().from;
    return sample;
  }
  for (const Leg& leg : legs_) {
    if (t_s >= leg.start_s + leg.duration_s) continue;
    const double u = (t_s - leg.start_s) / leg.duration_s;
    const double d = leg.to - leg.from;
    const double T = leg.duration_s;
    sample.position = leg.from + d * u * u * u * (10 + u * (-15 + 6 * u));
    sample.velocity = d / T * u * u * (30 + u * (-60 + 30 * u));
    sample.acceleration = d / (T * T) * u * (60 + u * (-180 + 120 * u));
    return sample;
  }
  sample.position = legs_.back().to;
  return sample;
}

double MinJerkPath::end_s() const {
  return legs_.empty() ? 0 : legs_.back().start_s + legs_.back().duration_s;
}

double MinJerkPath::peak_velocity() const {
  double peak = 0;
  for (const Leg& leg : legs_) {
    peak = std::max(peak, kPeakVelocity * std::abs(leg.to - leg.from) / leg.duration_s);
  }
  return peak;
}

double MinJerkPath::peak_acceleration() const {
  double peak = 0;
  for (const Leg& leg : legs_) {
    peak = std::max(
        peak, kPeakAcceleration * std::abs(leg.to - leg.from) / (leg.duration_s * leg.duration_s));
  }
  return peak;
}

double MinJerkPath::NextWaypoint(double t_s) const {
  for (const Leg& leg : legs_) {
    if (t_s < leg.start_s + leg.duration_s) return leg.to;
  }
  return legs_.empty() ? 0 : legs_.back().to;
}

std::string FollowPlanLines(const MinJerkPath& path, const core::RobotModel& model, int joint,
                            const std::vector<double>& start, int knot_ticks) {
  const auto j = static_cast<size_t>(joint);
  const bool revolute = model.joints[j].type == core::JointType::kRevolute;
  const double scale = Shown(model, joint);
  // How the plan parser turns the written number back into SI (control/plan.cpp).
  const double unit = revolute ? M_PI / 180.0 : 1e-3;
  const auto written = [&](double si) { return std::strtod(Short(si * scale).c_str(), nullptr); };
  const double knot_s = knot_ticks * model.servo_tick_s;
  const double tick_s = model.servo_tick_s;
  const core::MotionLimits limits = core::DefaultMotionLimits(model);
  const double a_cap = limits.acceleration_max[j];
  const double v_cap = model.joints[j].velocity_max * limits.velocity_cap_fraction;
  // A move needs a speed and an acceleration above 0; these floors are far below what changes the
  // profile (the speed is reached within a tick, the path is at rest there).
  const double v_floor = 1e-4 * path.peak_velocity();
  const double a_floor = 1e-3 * path.peak_acceleration();

  // The chip itself (the profile generators sirupp-control runs), to see where each move takes
  // the set-point before writing it.
  control::ServoBank bank(model);
  bank.ServoOn(start);
  std::vector<control::JointMove> moves(start.size());
  std::vector<double> positions = start;
  const auto run = [&](control::ServoBank& chip, double goal, double speed, double accel) {
    moves[j] = {true, written(goal) * unit, written(speed) * unit, written(accel) * unit};
    chip.Load(moves);
    for (int k = 0; k < knot_ticks; ++k) {
      positions[j] = chip.SetpointPosition(joint);
      chip.Tick(positions);
    }
    return chip.SetpointPosition(joint);
  };

  std::ostringstream plan;
  const std::string wait = core::FormatNumber(knot_s);
  // The plan's first step runs at tick 1, and a move loads and the profile steps in the same
  // tick, so the knot k (its move loaded at tick 1 + k * knot_ticks) takes the set-point to the
  // path's position at (k + 1) * knot_s. Its speed is the path's half a tick earlier (the profile
  // adds each tick's velocity to its position), corrected by half the error the chip would leave
  // at the knot's end: a feedback that halves any drift from knot to knot.
  for (int64_t k = 0;; ++k) {
    const double t0 = static_cast<double>(k) * knot_s;
    if (t0 >= path.end_s()) break;
    const double t1 = t0 + knot_s;
    const double v0 = path.At(t0 - tick_s / 2).velocity;
    const double v1 = path.At(t1 - tick_s / 2).velocity;
    const double waypoint = path.NextWaypoint(t0);
    double accel = std::abs(v1 - v0) / knot_s;
    // The chip slows down when it could no longer stop on its goal (the turning point ahead):
    // the acceleration must allow the speed it is to have at the knot's end.
    const double left = std::abs(waypoint - path.At(t1).position);
    if (left > 1e-9 * path.peak_velocity()) accel = std::max(accel, 1.5 * v1 * v1 / (2 * left));
    accel = std::clamp(accel, a_floor, a_cap);
    const double direction = waypoint >= bank.SetpointPosition(joint) ? 1 : -1;
    control::ServoBank trial = bank;
    const double speed_nominal = std::clamp(std::abs(v1), v_floor, v_cap);
    const double error = run(trial, waypoint, speed_nominal, accel) - path.At(t1).position;
    const double speed = std::clamp(speed_nominal - direction * error / knot_s, v_floor, v_cap);
    // Enough acceleration to reach the corrected speed within the knot.
    accel = std::clamp(
        std::max(accel, std::abs(speed - std::abs(bank.SetpointVelocity(joint))) / knot_s), a_floor,
        a_cap);
    run(bank, waypoint, speed, accel);
    plan << "move j" << joint + 1 << "=" << core::FormatNumber(waypoint * scale)
         << " speed=" << Short(speed * scale) << " accel=" << Short(accel * scale) << "\n"
         << "wait " << wait << "\n";
  }
  // Onto the last point at the path's own pace, should the profile be short of it.
  plan << "move j" << joint + 1 << "=" << core::FormatNumber(path.At(path.end_s()).position * scale)
       << " speed=" << Short(std::min(path.peak_velocity(), v_cap) * scale)
       << " accel=" << Short(std::min(path.peak_acceleration(), a_cap) * scale) << "\nwait done\n";
  return plan.str();
}

}  // namespace sirupp::grade
