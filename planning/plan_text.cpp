#include "planning/plan_text.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>

#include "core/errors.hpp"

namespace sirupp::planning {
namespace {

using core::FormatNumber;

constexpr double kPi = 3.14159265358979323846;
constexpr size_t kPlanLimitBytes = 256 * 1024;  // control::kMaxPlanBytes (control is above us)
constexpr double kStill = 1e-9;                 // a joint changing less does not move
// Speeds and accelerations are written a little under their caps, so that rounding the printed
// number never lands above velocity_max.
constexpr double kUnderCap = 0.999;

struct Rates {
  std::vector<double> speed, accel;  // per joint, SI
};

Rates JointRates(const core::RobotModel& model, const PlanTextOptions& options) {
  if (!(options.speed_fraction > 0 && options.speed_fraction <= 1)) {
    throw std::invalid_argument("speed fraction " + FormatNumber(options.speed_fraction) +
                                ": allowed (0, 1]");
  }
  if (!(options.accel_fraction > 0 && options.accel_fraction <= 4)) {
    throw std::invalid_argument("acceleration fraction " + FormatNumber(options.accel_fraction) +
                                ": allowed (0, 4]");
  }
  Rates rates;
  for (const core::Joint& joint : model.joints) {
    const double v =
        joint.servo.default_velocity > 0 ? joint.servo.default_velocity : joint.velocity_max;
    rates.speed.push_back(std::min(v * options.speed_fraction, joint.velocity_max) * kUnderCap);
    const double a = joint.servo.default_acceleration > 0 ? joint.servo.default_acceleration
                                                          : 2 * joint.velocity_max;
    rates.accel.push_back(a * options.accel_fraction * kUnderCap);
  }
  return rates;
}

// The normalized trapezoid of a segment: s goes 0..1 at top speed k (1/s) and acceleration c
// (1/s^2); joint j then runs at k |dq_j| and c |dq_j|.
struct Pace {
  double k = 0, c = 0;
};

Pace SegmentPace(const Rates& rates, const JointVector& a, const JointVector& b) {
  Pace pace{std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity()};
  for (int j = 0; j < a.size(); ++j) {
    const double d = std::abs(b[j] - a[j]);
    if (d <= kStill) continue;
    pace.k = std::min(pace.k, rates.speed[static_cast<size_t>(j)] / d);
    pace.c = std::min(pace.c, rates.accel[static_cast<size_t>(j)] / d);
  }
  return pace;
}

std::string Number(double value) {
  char text[40];
  std::snprintf(text, sizeof text, "%.10g", value);
  return text;
}

void CheckPath(const core::RobotModel& model, const std::vector<JointVector>& path) {
  if (path.empty()) throw std::invalid_argument("path: no waypoints");
  for (size_t i = 0; i < path.size(); ++i) {
    if (path[i].size() != model.num_joints()) {
      throw std::invalid_argument("path[" + std::to_string(i) +
                                  "]: " + std::to_string(path[i].size()) + " joint values; model " +
                                  model.name + " has " + std::to_string(model.num_joints()));
    }
    if (!path[i].allFinite()) {
      throw std::invalid_argument("path[" + std::to_string(i) + "]: a value is not finite");
    }
  }
}

}  // namespace

double SegmentDuration(const core::RobotModel& model, const JointVector& a, const JointVector& b,
                       const PlanTextOptions& options) {
  const Pace pace = SegmentPace(JointRates(model, options), a, b);
  if (!std::isfinite(pace.k)) return 0;
  // Normalized distance 1: a trapezoid when k^2 / c < 1, else a triangle.
  if (pace.k * pace.k / pace.c < 1) return 1 / pace.k + pace.k / pace.c;
  return 2 * std::sqrt(1 / pace.c);
}

std::string PathToPlanText(const core::RobotModel& model, const std::vector<JointVector>& path,
                           const PlanTextOptions& options) {
  CheckPath(model, path);
  const Rates rates = JointRates(model, options);
  auto value = [&](int j, double q) {
    const bool revolute = model.joints[static_cast<size_t>(j)].type == core::JointType::kRevolute;
    return Number(revolute ? q * 180 / kPi : q);
  };
  std::string text;
  for (const std::string& comment : options.comments) text += "# " + comment + "\n";
  text +=
      "# Made by sirupp plan make: each segment is one synchronized trapezoid (every joint\n"
      "# starts and ends together), so the set-points stay on the checked straight segment.\n";
  text += "units deg m\n";
  if (options.move_to_start) {
    text += "move joints";
    for (int j = 0; j < model.num_joints(); ++j) text += " " + value(j, path.front()[j]);
    text += "\nwait done\n";
  }
  for (size_t i = 1; i < path.size(); ++i) {
    const JointVector& a = path[i - 1];
    const JointVector& b = path[i];
    const Pace pace = SegmentPace(rates, a, b);
    if (!std::isfinite(pace.k)) continue;  // no joint moves
    text += "# segment " + std::to_string(i) + " of " + std::to_string(path.size() - 1) + "\n";
    for (int j = 0; j < model.num_joints(); ++j) {
      const double d = std::abs(b[j] - a[j]);
      if (d <= kStill) continue;
      const std::string unit_speed = value(j, pace.k * d);
      const std::string unit_accel = value(j, pace.c * d);
      text += "move j" + std::to_string(j + 1) + "=" + value(j, b[j]) + " speed=" + unit_speed +
              " accel=" + unit_accel + "\n";
    }
    text += "wait done\n";
  }
  if (text.size() > kPlanLimitBytes) {
    throw std::invalid_argument("the plan would have " + std::to_string(text.size()) +
                                " bytes; a plan may hold at most 262144 (256 KiB): simplify the "
                                "path or use fewer waypoints");
  }
  return text;
}

}  // namespace sirupp::planning
