#include "grade/metrics.hpp"

#include <algorithm>
#include <cmath>

#include "core/errors.hpp"
#include "core/units.hpp"

namespace sirupp::grade {
namespace {

constexpr double kMinStep = 0.5;      // deg (mm): a smaller step is "does not move"
constexpr double kFinalWindow = 0.1;  // s
constexpr double kMinBand = 0.1;      // deg (mm)

double Scale(const core::RobotModel& model, size_t j) {
  return model.joints[j].type == core::JointType::kRevolute ? 180 / kPi : 1000;
}

std::string Unit(const core::RobotModel& model, size_t j) {
  return model.joints[j].type == core::JointType::kRevolute ? " deg" : " mm";
}

// One joint's columns of a record, in degrees (mm for prismatic joints).
struct JointColumns {
  const TaskRecord& record;
  size_t n;  // joints per row
  size_t j;
  double scale;
  double At(const std::vector<double>& v, size_t row) const { return v[row * n + j] * scale; }
};

// The last move (from the last change of the goal): its step, whether it moves, and then its
// rise time, overshoot and settling time. Returns the goal it moves to.
double MeasureStep(const JointColumns& c, size_t rows, JointMetrics& m) {
  const TaskRecord& record = c.record;
  size_t begin = 0;
  for (size_t row = 1; row < rows; ++row) {
    if (c.At(record.goal, row) != c.At(record.goal, row - 1)) begin = row;
  }
  const double to = c.At(record.goal, rows - 1);
  const double from = c.At(record.position, begin);
  m.step = to - from;
  m.moves = std::abs(m.step) >= kMinStep;
  // Settling is timed from when the reference reaches the goal (the profile's end; the move's
  // start for a process controller, whose reference is the goal).
  size_t arrived = begin;
  for (size_t row = begin + 1; row < rows; ++row) {
    if (c.At(record.reference, row) != c.At(record.reference, row - 1)) arrived = row;
  }
  const double t0 = record.time_s[arrived];
  if (!m.moves) return to;
  const double sign = m.step > 0 ? 1 : -1;
  std::optional<double> t10, t90;
  double beyond = 0;
  const double band = std::max(0.02 * std::abs(m.step), kMinBand);
  std::optional<size_t> last_out;
  for (size_t row = begin; row < rows; ++row) {
    const double q = c.At(record.position, row);
    const double fraction = (q - from) / m.step;
    if (!t10 && fraction >= 0.1) t10 = record.time_s[row];
    if (!t90 && fraction >= 0.9) t90 = record.time_s[row];
    // On a tracking task the path itself may swing past the goal: only the end counts.
    if (!record.track || row >= arrived) beyond = std::max(beyond, sign * (q - to));
    if (std::abs(q - to) > band) last_out = row;
  }
  // On a tracking task the path sets the pace: no rise time.
  if (t10 && t90 && !record.track) m.rise_s = *t90 - *t10;
  m.overshoot_percent = 100 * beyond / std::abs(m.step);
  if (!last_out) {
    m.settling_s = 0.0;
  } else if (*last_out + 1 < rows) {
    m.settling_s = std::max(0.0, record.time_s[*last_out + 1] - t0);
  }
  return to;
}

// Over the whole run: the steady-state error (over the last kFinalWindow against the goal `to`),
// the tracking error, and the effort's peak, RMS, rate and time at `limit`.
void MeasureRun(const JointColumns& c, size_t rows, double to, double limit, JointMetrics& m) {
  const TaskRecord& record = c.record;
  const size_t n = c.n;
  const size_t j = c.j;
  const double dt = record.tick_s;
  const double end_s = record.time_s.back();
  double sum_final = 0, sum_track = 0, sum_effort = 0, sum_rate = 0;
  int64_t final_count = 0;
  int64_t saturated = 0;
  for (size_t row = 0; row < rows; ++row) {
    const double q = c.At(record.position, row);
    if (record.time_s[row] >= end_s - kFinalWindow) {
      sum_final += std::abs(to - q);
      ++final_count;
    }
    const double e = q - c.At(record.reference, row);
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
}

// Joint j's checks against the thresholds, in a fixed order; each failed one is added to `failed`.
void CheckJoint(const JointMetrics& m, size_t j, const std::string& unit, bool has_reference,
                bool track, const Thresholds& pass, std::vector<std::string>& failed) {
  const std::string joint = "joint " + std::to_string(j + 1) + ": ";
  const auto over = [&](const char* what, double value, const std::optional<double>& limit_value,
                        const std::string& value_unit) {
    if (limit_value && value > *limit_value) {
      failed.push_back(joint + what + " " + core::FormatApprox(value) + value_unit + " > " +
                       core::FormatNumber(*limit_value) + value_unit);
    }
  };
  if (m.moves) {
    if (pass.rise_s && !track) {
      if (!m.rise_s) {
        failed.push_back(joint + "never reached 90 % of its step");
      } else {
        over("rise time", *m.rise_s, pass.rise_s, " s");
      }
    }
    if (pass.settling_s) {
      if (!m.settling_s) {
        failed.push_back(joint + "did not settle within the task");
      } else {
        over("settling time", *m.settling_s, pass.settling_s, " s");
      }
    }
    if (m.overshoot_percent) over("overshoot", *m.overshoot_percent, pass.overshoot_percent, " %");
  }
  over("steady-state error", m.steady_state, pass.steady_state_deg, unit);
  if (has_reference) {
    over("RMS tracking error", m.rms_tracking, pass.rms_tracking_deg, unit);
    over("max tracking error", m.max_tracking, pass.max_tracking_deg, unit);
  }
  over("time saturated", m.saturated_s, pass.saturated_s, " s");
}

}  // namespace

TaskMetrics ComputeMetrics(const core::RobotModel& model, const TaskRecord& record,
                           const Thresholds& pass) {
  TaskMetrics result;
  const auto n = static_cast<size_t>(record.num_joints);
  const size_t rows = record.ticks();
  result.joints.resize(n);
  if (rows < 2) return result;
  double worst = -1;
  for (size_t j = 0; j < n; ++j) {
    JointMetrics& m = result.joints[j];
    const JointColumns columns{record, n, j, Scale(model, j)};
    const double to = MeasureStep(columns, rows, m);
    MeasureRun(columns, rows, to, model.joints[j].effort_max, m);
    if (m.rms_tracking > worst) {
      worst = m.rms_tracking;
      result.worst_joint = static_cast<int>(j);
    }
    CheckJoint(m, j, Unit(model, j), record.has_reference, record.track, pass,
               result.failed_checks);
  }
  return result;
}

}  // namespace sirupp::grade
