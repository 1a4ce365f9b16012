#include "grade/metrics.hpp"

#include <algorithm>
#include <cmath>

#include "core/errors.hpp"

namespace sirupp::grade {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kMinStep = 0.5;      // deg (mm): a smaller step is "does not move"
constexpr double kFinalWindow = 0.1;  // s
constexpr double kMinBand = 0.1;      // deg (mm)

double Scale(const core::RobotModel& model, size_t j) {
  return model.joints[j].type == core::JointType::kRevolute ? 180 / kPi : 1000;
}

std::string Unit(const core::RobotModel& model, size_t j) {
  return model.joints[j].type == core::JointType::kRevolute ? " deg" : " mm";
}

}  // namespace

TaskMetrics ComputeMetrics(const core::RobotModel& model, const TaskRecord& record,
                           const Thresholds& pass) {
  TaskMetrics result;
  const auto n = static_cast<size_t>(record.num_joints);
  const size_t rows = record.ticks();
  result.joints.resize(n);
  if (rows < 2) return result;
  const double dt = record.tick_s;
  const double end_s = record.time_s.back();
  double worst = -1;
  for (size_t j = 0; j < n; ++j) {
    JointMetrics& m = result.joints[j];
    const double scale = Scale(model, j);
    const auto at = [&](const std::vector<double>& v, size_t row) {
      return v[row * n + j] * scale;
    };
    // The last move: from the last change of the goal.
    size_t begin = 0;
    for (size_t row = 1; row < rows; ++row) {
      if (at(record.goal, row) != at(record.goal, row - 1)) begin = row;
    }
    const double to = at(record.goal, rows - 1);
    const double from = at(record.position, begin);
    m.step = to - from;
    m.moves = std::abs(m.step) >= kMinStep;
    // Settling is timed from when the reference reaches the goal (the profile's end; the move's
    // start for a process controller, whose reference is the goal).
    size_t arrived = begin;
    for (size_t row = begin + 1; row < rows; ++row) {
      if (at(record.reference, row) != at(record.reference, row - 1)) arrived = row;
    }
    const double t0 = record.time_s[arrived];
    if (m.moves) {
      const double sign = m.step > 0 ? 1 : -1;
      std::optional<double> t10, t90;
      double beyond = 0;
      const double band = std::max(0.02 * std::abs(m.step), kMinBand);
      std::optional<size_t> last_out;
      for (size_t row = begin; row < rows; ++row) {
        const double q = at(record.position, row);
        const double fraction = (q - from) / m.step;
        if (!t10 && fraction >= 0.1) t10 = record.time_s[row];
        if (!t90 && fraction >= 0.9) t90 = record.time_s[row];
        beyond = std::max(beyond, sign * (q - to));
        if (std::abs(q - to) > band) last_out = row;
      }
      if (t10 && t90) m.rise_s = *t90 - *t10;
      m.overshoot_percent = 100 * beyond / std::abs(m.step);
      if (!last_out) {
        m.settling_s = 0.0;
      } else if (*last_out + 1 < rows) {
        m.settling_s = std::max(0.0, record.time_s[*last_out + 1] - t0);
      }
    }
    double sum_final = 0, sum_track = 0, sum_effort = 0, sum_rate = 0;
    int64_t final_count = 0;
    int64_t saturated = 0;
    const double limit = model.joints[j].effort_max;
    for (size_t row = 0; row < rows; ++row) {
      const double q = at(record.position, row);
      if (record.time_s[row] >= end_s - kFinalWindow) {
        sum_final += std::abs(to - q);
        ++final_count;
      }
      const double e = q - at(record.reference, row);
      sum_track += e * e;
      m.max_tracking = std::max(m.max_tracking, std::abs(e));
      const double u = record.effort[row * n + j];
      m.peak_effort = std::max(m.peak_effort, std::abs(u));
      sum_effort += u * u;
      if (std::abs(u) >= limit * (1 - 1e-9)) ++saturated;
      if (row > 0) {
        const double rate = (u - record.effort[(row - 1) * n + j]) / dt;
        sum_rate += rate * rate;
      }
    }
    const auto count = static_cast<double>(rows);
    m.steady_state = final_count > 0 ? sum_final / static_cast<double>(final_count) : 0;
    m.rms_tracking = std::sqrt(sum_track / count);
    m.rms_effort = std::sqrt(sum_effort / count);
    m.saturated_s = static_cast<double>(saturated) * dt;
    m.effort_rate_rms = std::sqrt(sum_rate / (count - 1));
    if (m.rms_tracking > worst) {
      worst = m.rms_tracking;
      result.worst_joint = static_cast<int>(j);
    }

    // The checks, in a fixed order.
    const std::string joint = "joint " + std::to_string(j + 1) + ": ";
    const std::string unit = Unit(model, j);
    const auto over = [&](const char* what, double value, const std::optional<double>& limit_value,
                          const std::string& value_unit) {
      if (limit_value && value > *limit_value) {
        result.failed_checks.push_back(joint + what + " " + core::FormatApprox(value) + value_unit +
                                       " > " + core::FormatNumber(*limit_value) + value_unit);
      }
    };
    if (m.moves) {
      if (pass.rise_s) {
        if (!m.rise_s) {
          result.failed_checks.push_back(joint + "never reached 90 % of its step");
        } else {
          over("rise time", *m.rise_s, pass.rise_s, " s");
        }
      }
      if (pass.settling_s) {
        if (!m.settling_s) {
          result.failed_checks.push_back(joint + "did not settle within the task");
        } else {
          over("settling time", *m.settling_s, pass.settling_s, " s");
        }
      }
      if (m.overshoot_percent)
        over("overshoot", *m.overshoot_percent, pass.overshoot_percent, " %");
    }
    over("steady-state error", m.steady_state, pass.steady_state_deg, unit);
    if (record.has_reference) {
      over("RMS tracking error", m.rms_tracking, pass.rms_tracking_deg, unit);
      over("max tracking error", m.max_tracking, pass.max_tracking_deg, unit);
    }
    over("time saturated", m.saturated_s, pass.saturated_s, " s");
  }
  return result;
}

}  // namespace sirupp::grade
