#include "logger/aligner.hpp"

#include <algorithm>
#include <climits>
#include <cmath>
#include <utility>

namespace sirupp::logger {

namespace {

constexpr int64_t kRestartJumpUs = 1000000;  // sim time going back this far: the sim restarted
constexpr int64_t kOffsetWindowUs = 200000;  // the sim clock's offset: the best of this long
constexpr int64_t kRateWindowUs = 2000000;   // the sim clock's pace: over this long
constexpr int64_t kMinRateSpanUs = 500000;   // with less than this, the pace counts as 1
constexpr int64_t kClockApartUs = 1000000;   // a real-arm clock this far off the receive clock

// Smallest multiple of period at or after t (t may be negative).
int64_t CeilToPeriod(int64_t t, int64_t period) {
  int64_t k = t / period;
  if (k * period < t) ++k;
  return k * period;
}

bool Running(const PlanStatus& status) {
  return !status.plan_name.empty() && status.plan_step >= 0 && status.plan_step < status.plan_steps;
}

}  // namespace

Aligner::Aligner(AlignerOptions options) : options_(options) {
  if (options_.period_us < 1) options_.period_us = 1;
}

void Aligner::Add(Sample sample) {
  const auto s = static_cast<size_t>(sample.stream);
  ++samples_[s];
  lost_total_[s] += sample.lost_before;
  if (sample.stream == Stream::kReal) real_sources_ |= 1 << (sample.source & 7);
  if (sample.stream == Stream::kReal && sample.clock == SampleClock::kWall &&
      sample.recv_utime > 0) {
    NoteRealDelay(sample);
  }
  if (!pending_restart_.empty()) {
    pending_restart_.push_back(std::move(sample));
    return;
  }
  if (sample.clock == SampleClock::kSim) {
    if (axis_ == Axis::kUndecided) axis_ = Axis::kSim;
    if (axis_ == Axis::kSim) {
      if (started_ && sample.utime < next_row_us_ - kRestartJumpUs) {
        pending_restart_.push_back(std::move(sample));
        return;
      }
      if (sample.stream != Stream::kReal && sample.recv_utime > 0) {
        NoteOffset(sample);
        have_offset_ = true;
      }
    }
    Place(std::move(sample));
    if (have_offset_ && !pending_real_.empty()) {
      std::vector<Sample> waiting;
      waiting.swap(pending_real_);
      for (Sample& real : waiting) Place(std::move(real));
    }
    return;
  }
  if (axis_ == Axis::kUndecided || (axis_ == Axis::kSim && !have_offset_)) {
    pending_real_.push_back(std::move(sample));
    return;
  }
  Place(std::move(sample));
}

void Aligner::NoteOffset(const Sample& sim_sample) {
  const int64_t recv = sim_sample.recv_utime;
  if (!clock_.empty() && recv < clock_.back().first) return;  // out of order: keep it monotonic
  clock_.emplace_back(recv, sim_sample.utime);
  while (clock_.front().first < recv - kRateWindowUs) clock_.pop_front();
  clock_dirty_ = true;
}

void Aligner::NoteRealDelay(const Sample& real_sample) {
  const int64_t recv = real_sample.recv_utime;
  const int64_t delay = recv - real_sample.utime;
  // The smallest delay of the window at the front: drop those that can no longer be it.
  while (!real_delay_.empty() && real_delay_.back().second >= delay) real_delay_.pop_back();
  real_delay_.emplace_back(recv, delay);
  while (real_delay_.front().first < recv - kRateWindowUs) real_delay_.pop_front();
}

int64_t Aligner::RealClockShift() const {
  if (real_delay_.empty()) return 0;
  const int64_t delay = real_delay_.front().second;
  return delay > kClockApartUs || delay < -kClockApartUs ? delay : 0;
}

int64_t Aligner::WallToAxis(int64_t wall_utime) const {
  if (axis_ == Axis::kRealOnly || clock_.empty()) return wall_utime + wall_offset_;
  if (clock_dirty_) {
    clock_dirty_ = false;
    const auto& [newest_recv, newest_utime] = clock_.back();
    const auto& [oldest_recv, oldest_utime] = clock_.front();
    const int64_t span = newest_recv - oldest_recv;
    clock_rate_ = 1.0;
    if (span >= kMinRateSpanUs) {
      clock_rate_ = std::clamp(
          static_cast<double>(newest_utime - oldest_utime) / static_cast<double>(span), 1e-3, 1e3);
    }
    clock_reference_ = newest_recv;
    clock_intercept_ = -1e300;
    for (auto it = clock_.rbegin();
         it != clock_.rend() && it->first >= newest_recv - kOffsetWindowUs; ++it) {
      clock_intercept_ = std::max(clock_intercept_,
                                  static_cast<double>(it->second) -
                                      clock_rate_ * static_cast<double>(it->first - newest_recv));
    }
  }
  return std::llround(clock_intercept_ +
                      clock_rate_ * static_cast<double>(wall_utime - clock_reference_));
}

std::optional<int64_t> Aligner::AxisTimeAtWall(int64_t wall_utime) const {
  if (axis_ == Axis::kUndecided || !have_offset_) return std::nullopt;
  return WallToAxis(wall_utime);
}

int64_t Aligner::AxisTime(const Sample& sample) const {
  if (sample.clock == SampleClock::kSim) {
    return axis_ == Axis::kRealOnly ? sample.recv_utime + wall_offset_ : sample.utime;
  }
  return WallToAxis(sample.utime + (axis_ == Axis::kSim ? RealClockShift() : 0));
}

void Aligner::Place(Sample sample) {
  StreamState& stream = streams_[static_cast<size_t>(sample.stream)];
  Entry entry;
  entry.axis_us = AxisTime(sample);
  entry.sample = std::move(sample);
  const int64_t axis = entry.axis_us;
  if (stream.queue.empty() || stream.queue.back().axis_us <= axis) {
    stream.queue.push_back(std::move(entry));
  } else {  // a real-arm sample moved before its predecessor by a change of the clock offset
    auto at = std::upper_bound(stream.queue.begin(), stream.queue.end(), axis,
                               [](int64_t t, const Entry& e) { return t < e.axis_us; });
    stream.queue.insert(at, std::move(entry));
  }
  stream.latest_axis = stream.seen ? std::max(stream.latest_axis, axis) : axis;
  stream.last_recv = std::max(stream.last_recv, stream.queue.back().sample.recv_utime);
  stream.seen = true;
  if (!started_) {
    started_ = true;
    next_row_us_ = CeilToPeriod(axis, options_.period_us);
    first_axis_us_ = axis;
    first_recv_us_ = stream.queue.back().sample.recv_utime;
  }
}

void Aligner::AddStatus(const PlanStatus& status) {
  const bool running = Running(status);
  const bool first_status = !have_status_;
  const bool was_running = have_status_ && Running(last_status_);
  const bool new_run = running && (!was_running || status.plan_name != last_status_.plan_name ||
                                   status.plan_step < last_status_.plan_step);
  last_status_ = status;
  have_status_ = true;
  if (!new_run) return;
  PlanRun run;
  run.plan_name = status.plan_name;
  run.mode = status.mode;
  run.start_us = axis_ == Axis::kRealOnly ? status.recv_utime + wall_offset_ : status.utime;
  // The first status, soon after the first sample and before any row, shows a plan running: the
  // input began in the middle of that plan run, which the rows so far belong to.
  // A plan at its first step may as well have just started, unless an earlier logger (that this
  // one continues after a restart) was recording it.
  const bool under_way = status.plan_step > 0 || status.plan_name == options_.continue_plan;
  if (first_status && under_way && started_ && options_.join_window_us > 0 &&
      last_row_us_ == INT64_MIN && plan_runs_.size() == 1 && pending_plans_.empty() &&
      run.start_us - first_axis_us_ <= options_.join_window_us) {
    PlanRun& joined = plan_runs_.front();
    joined.plan_name = run.plan_name;
    joined.mode = run.mode;
    joined.start_us = first_axis_us_;
    joined.joined = true;
    return;
  }
  pending_plans_.push_back(run);
}

void Aligner::DecideAxis(int64_t now_utime) {
  if (axis_ != Axis::kUndecided || pending_real_.empty()) return;
  if (now_utime - pending_real_.front().recv_utime < options_.idle_us) return;
  axis_ = Axis::kRealOnly;
  wall_offset_ = -pending_real_.front().utime;
  have_offset_ = true;
  std::vector<Sample> waiting;
  waiting.swap(pending_real_);
  for (Sample& real : waiting) Place(std::move(real));
}

void Aligner::TakeRows(int64_t now_utime, bool final_flush,
                       const std::function<void(const Row&)>& sink) {
  DecideAxis(final_flush ? INT64_MAX / 2 : now_utime);
  if (final_flush && !pending_real_.empty()) {  // sim offset never known: place them by receive
    std::vector<Sample> waiting;
    waiting.swap(pending_real_);
    for (Sample& real : waiting) Place(std::move(real));
  }
  if (!pending_restart_.empty()) Restart(sink);

  int64_t latest = INT64_MIN;
  int64_t live_min = INT64_MAX;
  for (const StreamState& stream : streams_) {
    if (!stream.seen) continue;
    latest = std::max(latest, stream.latest_axis);
    if (now_utime - stream.last_recv < options_.idle_us) {
      live_min = std::min(live_min, stream.latest_axis);
    }
  }
  if (latest == INT64_MIN) return;
  // At the start, wait a little for the first plan status (see AddStatus).
  if (!final_flush && !have_status_ && options_.join_window_us > 0 && last_row_us_ == INT64_MIN &&
      latest - first_axis_us_ < options_.join_window_us &&
      now_utime - first_recv_us_ < options_.join_window_us + options_.idle_us) {
    return;
  }
  Produce(final_flush || live_min == INT64_MAX ? latest : live_min - options_.status_hold_us, sink);
}

void Aligner::Restart(const std::function<void(const Row&)>& sink) {
  int64_t latest = INT64_MIN;
  for (const StreamState& stream : streams_) {
    if (stream.seen) latest = std::max(latest, stream.latest_axis);
  }
  if (latest != INT64_MIN) Produce(latest, sink);
  for (StreamState& stream : streams_) {
    stream.queue.clear();
    stream.seen = false;
  }
  started_ = false;
  last_row_us_ = INT64_MIN;
  clock_.clear();
  clock_dirty_ = true;
  ++run_;
  std::vector<Sample> waiting;
  waiting.swap(pending_restart_);
  for (Sample& sample : waiting) {
    if (sample.stream != Stream::kReal && sample.recv_utime > 0) NoteOffset(sample);
    Place(std::move(sample));
  }
}

void Aligner::Produce(int64_t frontier, const std::function<void(const Row&)>& sink) {
  const int64_t period = options_.period_us;
  while (started_ && next_row_us_ <= frontier) {
    const int64_t t = next_row_us_;
    while (!pending_plans_.empty() && pending_plans_.front().start_us <= t) {
      plan_runs_.push_back(pending_plans_.front());
      pending_plans_.erase(pending_plans_.begin());
    }
    Row row;
    row.time_us = t;
    row.run = run_;
    row.plan_run = static_cast<int>(plan_runs_.size()) - 1;
    bool any = false;
    int64_t ahead = INT64_MAX;  // earliest sample after t, to skip empty stretches
    for (int s = 0; s < kNumStreams; ++s) {
      StreamState& stream = streams_[static_cast<size_t>(s)];
      std::deque<Entry>& queue = stream.queue;
      while (queue.size() >= 2 && queue[1].axis_us <= t) {
        if (!queue.front().counted) stream.lost += queue.front().sample.lost_before;
        queue.pop_front();
      }
      if (!queue.empty() && queue.front().axis_us <= t) {
        Entry& current = queue.front();
        if (!current.counted) {
          stream.lost += current.sample.lost_before;
          current.counted = true;
        }
        if (t - current.axis_us < options_.max_age_us) {
          row.cell[static_cast<size_t>(s)] = &current.sample;
          row.age_us[static_cast<size_t>(s)] = t - current.axis_us;
          any = true;
        }
        if (queue.size() >= 2) ahead = std::min(ahead, queue[1].axis_us);
      } else if (!queue.empty()) {
        ahead = std::min(ahead, queue.front().axis_us);
      }
      row.lost[static_cast<size_t>(s)] = stream.lost;
    }
    if (any) {
      sink(row);
      last_row_us_ = t;
      next_row_us_ = t + period;
    } else if (ahead != INT64_MAX) {
      next_row_us_ = std::max(t + period, CeilToPeriod(ahead, period));
    } else {
      next_row_us_ = t + period;
    }
  }
}

}  // namespace sirupp::logger
