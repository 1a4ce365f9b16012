#include "logger/analysis.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

#include "core/errors.hpp"

namespace sirupp::logger {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// The value of `values` at row i, or the nearest value before it within [begin, i].
double LastFinite(const std::vector<double>& values, size_t begin, size_t i) {
  for (size_t k = i + 1; k-- > begin;) {
    if (std::isfinite(values[k])) return values[k];
  }
  return kNaN;
}

StreamResponse Respond(const RunTable& table, Stream stream, const std::vector<double>& q,
                       size_t begin, size_t end, double travel, const AnalysisOptions& options) {
  StreamResponse response;
  for (size_t i = begin; i < end; ++i) response.samples += std::isfinite(q[i]) ? 1 : 0;
  if (response.samples == 0) return response;
  const double t0 = table.time_s[begin];
  // When row i's sample was taken: the row time minus its age (a held sample, a real arm polled
  // at 100 Hz, is older than its row); the real arm's on its own clock from the move's start.
  const std::vector<double> real_times =
      stream == Stream::kReal ? table.RealSampleTimes(begin, begin, end) : std::vector<double>{};
  auto taken = [&](size_t i) {
    return stream == Stream::kReal ? real_times[i - begin] : table.time_s[i] - table.Age(stream, i);
  };
  double baseline = begin > 0 && std::isfinite(q[begin - 1]) ? q[begin - 1] : kNaN;
  for (size_t i = begin; std::isnan(baseline) && i < end; ++i) baseline = q[i];

  // Start: when the stream crossed start_threshold, between the first sample past it and the
  // sample before (linear in between). The first sample past it alone is late by up to the gap
  // between two samples: a real arm polled at 100 Hz, 10 ms (more when the polls come late on a
  // busy PC), against 0.5 ms for the streams on the rows.
  response.start_delay_s = kNaN;
  for (size_t i = begin; i < end; ++i) {
    const double moved = std::abs(q[i] - baseline);
    if (!std::isfinite(q[i]) || moved < options.start_threshold) continue;
    double crossed = taken(i);
    // The sample before: the nearest earlier row holding an older reading (a polled stream
    // repeats each reading over many rows), still short of the threshold.
    for (size_t k = i; k-- > begin;) {
      if (!std::isfinite(q[k]) || !(taken(k) < taken(i))) continue;
      const double before = std::abs(q[k] - baseline);
      crossed =
          taken(k) + (taken(i) - taken(k)) * (options.start_threshold - before) / (moved - before);
      break;
    }
    response.start_delay_s = std::max(0.0, crossed - t0);
    break;
  }
  const double window_start = table.time_s[end - 1] - options.final_window_s;
  double sum = 0;
  int64_t count = 0;
  for (size_t i = begin; i < end; ++i) {
    if (table.time_s[i] >= window_start && std::isfinite(q[i])) {
      sum += q[i];
      ++count;
    }
  }
  response.final_value =
      count > 0 ? sum / static_cast<double>(count) : LastFinite(q, begin, end - 1);
  const double band = options.settle_band_fraction * std::abs(travel);
  size_t settled_from = begin;
  for (size_t i = begin; i < end; ++i) {
    if (std::isfinite(q[i]) && std::abs(q[i] - response.final_value) > band) settled_from = i + 1;
  }
  // The first sample inside the band for good (the row after the last one outside it holds a new
  // sample, unless that stretch has none: then the row's own time).
  size_t settled_row = settled_from;
  while (settled_row < end && !std::isfinite(q[settled_row])) ++settled_row;
  response.settling_s = settled_from >= end ? kNaN
                        : settled_row < end ? std::max(0.0, taken(settled_row) - t0)
                                            : table.time_s[settled_from] - t0;
  const double direction = travel >= 0 ? 1.0 : -1.0;
  double overshoot = 0;
  for (size_t i = begin; i < end; ++i) {
    if (std::isfinite(q[i]))
      overshoot = std::max(overshoot, (q[i] - response.final_value) * direction);
  }
  response.overshoot = overshoot;
  response.overshoot_percent = travel != 0 ? 100.0 * overshoot / std::abs(travel) : 0;
  return response;
}

}  // namespace

Stream PairFirst(Pair pair) {
  return pair == Pair::kVirtReal ? Stream::kVirtual : Stream::kSetpoint;
}
Stream PairSecond(Pair pair) { return pair == Pair::kSetVirt ? Stream::kVirtual : Stream::kReal; }
const char* PairTitle(Pair pair) {
  switch (pair) {
    case Pair::kSetVirt:
      return "set-point vs virtual";
    case Pair::kSetReal:
      return "set-point vs real";
    case Pair::kVirtReal:
      return "virtual vs real";
  }
  return "?";
}
const char* PairKey(Pair pair) {
  switch (pair) {
    case Pair::kSetVirt:
      return "set_virt";
    case Pair::kSetReal:
      return "set_real";
    case Pair::kVirtReal:
      return "virt_real";
  }
  return "?";
}

double PairError(const RunTable& table, Pair pair, size_t j, size_t i, double period) {
  const double a = table.position[j][static_cast<size_t>(PairFirst(pair))][i];
  const double b = table.position[j][static_cast<size_t>(PairSecond(pair))][i];
  if (!std::isfinite(a) || !std::isfinite(b) || !table.Fresh(PairFirst(pair), i, period) ||
      !table.Fresh(PairSecond(pair), i, period)) {
    return kNaN;
  }
  return b - a;
}

std::vector<PairPoint> PairErrors(const RunTable& table, Pair pair, size_t j, size_t begin,
                                  size_t end, double period) {
  std::vector<PairPoint> points;
  if (begin >= end) return points;
  const std::vector<double>& times = table.time_s;
  if (PairSecond(pair) != Stream::kReal) {
    for (size_t i = begin; i < end; ++i) {
      const double e = PairError(table, pair, j, i, period);
      if (!std::isnan(e)) points.push_back({times[i], e});
    }
    return points;
  }
  const Stream first = PairFirst(pair);
  const std::vector<double>& a = table.position[j][static_cast<size_t>(first)];
  const std::vector<double>& b = table.position[j][static_cast<size_t>(Stream::kReal)];
  const std::vector<double> real_times = table.RealSampleTimes(begin, begin, end);
  const double start = times[begin];
  const double last = times[end - 1];
  constexpr double kSameTime = 1e-9;  // times are whole microseconds
  auto usable = [&](size_t k) { return std::isfinite(a[k]) && table.Fresh(first, k, period); };
  for (size_t i = begin; i < end; ++i) {
    if (!std::isfinite(b[i]) || !table.Fresh(Stream::kReal, i, period)) continue;
    const double at = real_times[i - begin];  // on the first stream's clock
    if (std::isnan(at)) continue;
    if (at < start - kSameTime || at > last + kSameTime) continue;
    // The first stream at `at`: its row there, or between the two rows around it.
    const auto after =
        std::upper_bound(times.begin() + static_cast<std::ptrdiff_t>(begin),
                         times.begin() + static_cast<std::ptrdiff_t>(end), at + kSameTime);
    const auto k = static_cast<size_t>(after - times.begin()) - 1;  // times[k] <= at (+tolerance)
    if (k < begin) continue;
    double value = kNaN;
    if (at - times[k] <= kSameTime) {
      if (usable(k)) value = a[k];
    } else if (k + 1 < end && usable(k) && usable(k + 1)) {
      const double w = (at - times[k]) / (times[k + 1] - times[k]);
      value = a[k] + w * (a[k + 1] - a[k]);
    }
    if (std::isfinite(value)) points.push_back({at, b[i] - value});
  }
  return points;
}

namespace {

// The joints asked for (1-based), all of them when none were named.
std::vector<int> JointsToAnalyse(const RunTable& table, const AnalysisOptions& options) {
  const int num_joints = static_cast<int>(table.joints.size());
  std::vector<int> joints = options.joints;
  for (int joint : joints) {
    if (joint < 1 || joint > num_joints) {
      throw core::ConfigError(core::SourceLocation{table.source, 0, 0}, "",
                              "unknown joint " + std::to_string(joint) + ": this file has " +
                                  std::to_string(num_joints) + " joints (1 to " +
                                  std::to_string(num_joints) + ")");
    }
  }
  if (joints.empty()) {
    for (int j = 1; j <= num_joints; ++j) joints.push_back(j);
  }
  return joints;
}

// Move boundaries: rows where a known move_id differs from the previous known one.
std::vector<size_t> MoveStarts(const RunTable& table, bool last_move_only) {
  std::vector<size_t> starts = table.MoveStarts();
  if (last_move_only && starts.size() > 1) starts.erase(starts.begin(), starts.end() - 1);
  return starts;
}

// Move-done: the set-point's flag; without flags, the first row from which the set-point stays at
// its end value. `end` when the move is not done within [begin, end).
size_t DoneRow(const RunTable& table, size_t j, size_t begin, size_t end, double to) {
  const std::vector<double>& set = table.position[j][static_cast<size_t>(Stream::kSetpoint)];
  size_t done_row = end;
  const bool have_flags = std::any_of(table.done[j].begin() + static_cast<std::ptrdiff_t>(begin),
                                      table.done[j].begin() + static_cast<std::ptrdiff_t>(end),
                                      [](int8_t flag) { return flag >= 0; });
  if (have_flags) {
    for (size_t i = begin; i < end && done_row == end; ++i) {
      if (table.done[j][i] == 1) done_row = i;
    }
  } else {
    done_row = end;
    for (size_t i = end; i-- > begin;) {
      if (std::isfinite(set[i]) && std::abs(set[i] - to) > 1e-9) break;
      done_row = i;
    }
  }
  return done_row;
}

// One pair's errors over a move: mean before and after the settle window's end, RMS and maximum.
PairMetrics MetricsOf(const RunTable& table, Pair pair, size_t j, const MoveResult& result,
                      const AnalysisOptions& options) {
  PairMetrics metrics;
  double sum_transient = 0, sum_steady = 0, sum_squares = 0;
  for (const PairPoint& point :
       PairErrors(table, pair, j, result.begin, result.end, table.period_s())) {
    const double error = std::abs(point.error);
    if (point.time_s <= result.done_s + options.settle_window_s) {
      sum_transient += error;
      ++metrics.transient_samples;
    } else {
      sum_steady += error;
      ++metrics.steady_samples;
    }
    sum_squares += error * error;
    metrics.max = std::max(metrics.max, error);
  }
  const int64_t all = metrics.transient_samples + metrics.steady_samples;
  metrics.mean_transient = metrics.transient_samples > 0
                               ? sum_transient / static_cast<double>(metrics.transient_samples)
                               : kNaN;
  metrics.mean_steady =
      metrics.steady_samples > 0 ? sum_steady / static_cast<double>(metrics.steady_samples) : kNaN;
  metrics.rms = all > 0 ? std::sqrt(sum_squares / static_cast<double>(all)) : kNaN;
  if (all == 0) metrics.max = kNaN;
  return metrics;
}

// One joint over the move in rows [begin, end); nullopt when it travels less than min_travel.
std::optional<MoveResult> AnalyseMove(const RunTable& table, int joint, size_t begin, size_t end,
                                      const AnalysisOptions& options) {
  const auto j = static_cast<size_t>(joint - 1);
  const std::vector<double>& set = table.position[j][static_cast<size_t>(Stream::kSetpoint)];
  const double from =
      begin > 0 && std::isfinite(set[begin - 1]) ? set[begin - 1] : LastFinite(set, begin, begin);
  const double to = LastFinite(set, begin, end - 1);
  if (!std::isfinite(from) || !std::isfinite(to) || std::abs(to - from) < options.min_travel) {
    return std::nullopt;
  }
  MoveResult result;
  result.table = &table;
  result.move_id = table.move_id[begin];
  result.joint = joint;
  result.begin = begin;
  result.end = end;
  result.start_s = table.time_s[begin];
  result.end_s = table.time_s[end - 1];
  result.from = from;
  result.to = to;
  const size_t done_row = DoneRow(table, j, begin, end, to);
  result.done_seen = done_row < end;
  result.done_s = result.done_seen ? table.time_s[done_row] : result.end_s;
  // The move is analysed up to the end of the settle and steady windows after move-done.
  size_t window_end = end;
  if (result.done_seen) {
    const double last_s = result.done_s + options.settle_window_s + options.steady_window_s;
    for (size_t i = done_row; i < end; ++i) {
      if (table.time_s[i] > last_s) {
        window_end = i;
        break;
      }
    }
  }
  result.end = window_end;
  result.end_s = table.time_s[window_end - 1];
  result.transient_end_s = std::min(result.done_s + options.settle_window_s, result.end_s);

  for (Pair pair : kAllPairs) {
    result.pairs[static_cast<size_t>(pair)] = MetricsOf(table, pair, j, result, options);
  }
  for (Stream stream : kAllStreams) {
    StreamResponse& response = result.streams[static_cast<size_t>(stream)];
    response = Respond(table, stream, table.position[j][static_cast<size_t>(stream)], begin,
                       window_end, to - from, options);
    if (response.has()) response.final_error = response.final_value - to;
  }
  return result;
}

}  // namespace

Analysis Analyze(const RunTable& table, const AnalysisOptions& options) {
  Analysis analysis;
  const std::vector<int> joints = JointsToAnalyse(table, options);
  if (table.cells[static_cast<size_t>(Stream::kSetpoint)] == 0 ||
      std::all_of(table.move_id.begin(), table.move_id.end(), [](int64_t id) { return id < 0; })) {
    analysis.notes.push_back(table.source + " (" + table.label +
                             "): no set-point data (ARM_SETPOINT); moves are found by the "
                             "set-point's move_id, so this part is not analysed");
    return analysis;
  }
  const std::vector<size_t> starts = MoveStarts(table, options.last_move_only);
  if (starts.empty()) {
    analysis.notes.push_back(table.source + " (" + table.label +
                             "): no move starts in this data (move_id never changes)");
  }
  for (size_t m = 0; m < starts.size(); ++m) {
    const size_t begin = starts[m];
    const size_t end = m + 1 < starts.size() ? starts[m + 1] : table.rows();
    for (int joint : joints) {
      if (auto result = AnalyseMove(table, joint, begin, end, options)) {
        analysis.moves.push_back(*result);
      }
    }
  }
  return analysis;
}

}  // namespace sirupp::logger
