#pragma once
// Puts the three streams on one fixed sample clock (docs/logging.md, "Alignment"). Single-threaded:
// the logger's writer thread (or the log importer) feeds it in arrival order and takes the rows
// that can no longer change.
//
// The time axis is sim time (microseconds) when a set-point or virtual stream is present: their
// utime is on it already. A real arm's samples (wall clock, source REAL or EMULATED) are moved onto
// it by the offset sim utime - receive time of the sim samples (the largest over the last 0.2 s
// of them, so that one sample delivered late does not move the real arm's samples). A real arm
// whose clock is more than a second off the receive clock (a log played back onto the bus later,
// or a bridge PC whose clock is not in sync) is first put on the receive clock by its smallest
// delay over the last 2 s. Without any sim stream the axis is the real arm's wall clock, zero at
// its first sample.
//
// Row k is at time k * period. A stream's cell in a row is its newest sample at or before the row
// time, if that sample is younger than max_age; otherwise the cell is empty (never interpolated).
// A row is final once every live stream has a sample at or after its time; a stream that has sent
// nothing for idle_us of wall clock stops holding rows back. Rows with every cell empty are not
// produced. A sim clock that goes back by more than a second (the sim restarted) ends the run: the
// rows so far are final and a new run (a new file) begins. At the start, rows wait briefly for the
// first plan status, so that a plan run under way is joined rather than split off (join_window_us).

#include <array>
#include <cstdint>
#include <deque>
#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "logger/samples.hpp"

namespace sirupp::logger {

struct AlignerOptions {
  int64_t period_us = 512;     // the sample clock: one row per servo tick by default
  int64_t max_age_us = 25000;  // older samples leave their cell empty (2.5 polls at 100 Hz)
  int64_t idle_us = 50000;     // a stream silent this long (wall clock) stops holding rows back
  // A plan run already under way when the logger starts (a restart in the middle of a movement
  // set): rows wait until the first CONTROLLER_STATUS, for at most this much of the time axis
  // (and this plus idle_us of wall clock); if that status shows a plan past its first step (or
  // `continue_plan` at any step), the rows from the start belong to that run instead of to a
  // "manual" stretch. 0 = off.
  int64_t join_window_us = 250000;
  // While every stream is live, rows stay this much of the time axis behind the newest sample, so
  // that a plan's CONTROLLER_STATUS handled a round after the plan's first set-points (they reach
  // the logger by different sockets: LCM's and the tick feed's) still starts the plan's file at
  // its first row. A quiet bus or the end takes the rest. 0 = off.
  int64_t status_hold_us = 50000;
  std::string continue_plan;  // the plan an earlier logger was recording (restarts), or ""
};

// One movement set: a plan run seen on CONTROLLER_STATUS, or the time before the first plan.
struct PlanRun {
  std::string plan_name;  // "" before the first plan
  int64_t start_us = 0;   // on the time axis
  int8_t mode = 0;        // controller mode when it started
  bool joined = false;    // under way when the input began: its start is not in the data
};

// One output row; the pointers are valid only during the callback.
struct Row {
  int64_t time_us = 0;
  std::array<const Sample*, kNumStreams> cell{};  // null: empty cell
  std::array<int64_t, kNumStreams> lost{};        // cumulative missing messages per stream
  std::array<int64_t, kNumStreams> age_us{};      // row time - the cell's sample time (0 if empty)
  int run = 0;                                    // sim restarts so far
  int plan_run = 0;                               // index into Aligner::plan_runs()
};

class Aligner {
 public:
  explicit Aligner(AlignerOptions options);

  void Add(Sample sample);
  void AddStatus(const PlanStatus& status);
  // The time on the axis of the wall-clock time `wall_utime` (from the sim clock's offset), or
  // nullopt while the axis is not known yet.
  std::optional<int64_t> AxisTimeAtWall(int64_t wall_utime) const;
  // Sets AlignerOptions::continue_plan (before any input).
  void ContinuePlan(const std::string& plan_name) { options_.continue_plan = plan_name; }

  // Calls `sink` for every row that is final at wall time now_utime, in time order. final_flush:
  // the input has ended, every remaining row is final.
  void TakeRows(int64_t now_utime, bool final_flush, const std::function<void(const Row&)>& sink);

  const std::vector<PlanRun>& plan_runs() const { return plan_runs_; }
  const AlignerOptions& options() const { return options_; }
  // Samples taken per stream, and missing messages per stream (total).
  const std::array<int64_t, kNumStreams>& samples() const { return samples_; }
  const std::array<int64_t, kNumStreams>& lost_total() const { return lost_total_; }
  // Real-arm sources seen (arm_state_t::SOURCE_* bit set: 1 << source).
  int real_sources() const { return real_sources_; }

 private:
  struct Entry {
    Sample sample;
    int64_t axis_us = 0;
    bool counted = false;  // its lost_before is in StreamState::lost
  };
  struct StreamState {
    std::deque<Entry> queue;  // by time on the axis, front = current candidate
    bool seen = false;
    int64_t latest_axis = 0;
    int64_t last_recv = 0;
    int64_t lost = 0;  // counted up to the rows produced
  };
  enum class Axis { kUndecided, kSim, kRealOnly };

  void Place(Sample sample);
  int64_t AxisTime(const Sample& sample) const;
  void Produce(int64_t frontier, const std::function<void(const Row&)>& sink);
  void Restart(const std::function<void(const Row&)>& sink);
  void DecideAxis(int64_t now_utime);

  AlignerOptions options_;
  Axis axis_ = Axis::kUndecided;
  int64_t wall_offset_ = 0;  // real-only axis: axis = wall utime + wall_offset_
  // The sim clock against the wall clock, from the sim samples of the last 2 s (receive time,
  // utime): sim(w) = intercept + rate * (w - reference). The rate is the sim's pace (below 1 when
  // it slips in realtime mode); a sample received late only lowers its intercept utime - rate *
  // (receive time - reference), so the largest over the last 0.2 s is the estimate.
  std::deque<std::pair<int64_t, int64_t>> clock_;
  mutable bool clock_dirty_ = true;
  mutable double clock_rate_ = 1;
  mutable double clock_intercept_ = 0;
  mutable int64_t clock_reference_ = 0;
  void NoteOffset(const Sample& sim_sample);
  // The real arm's clock against the receive clock: receive time - utime of its samples over the
  // last 2 s (front: the smallest), used when it is more than a second off.
  std::deque<std::pair<int64_t, int64_t>> real_delay_;
  void NoteRealDelay(const Sample& real_sample);
  int64_t RealClockShift() const;
  // The axis time of a wall-clock time (sim axis: from the sim clock; real-only: the offset).
  int64_t WallToAxis(int64_t wall_utime) const;
  bool have_offset_ = false;
  std::vector<Sample> pending_real_;  // real samples before the axis is decided
  std::vector<Sample> pending_restart_;
  std::array<StreamState, kNumStreams> streams_;
  std::array<int64_t, kNumStreams> samples_{};
  std::array<int64_t, kNumStreams> lost_total_{};
  int real_sources_ = 0;
  bool started_ = false;
  int64_t first_axis_us_ = 0;  // the first sample's time on the axis
  int64_t first_recv_us_ = 0;  // and when it was received
  int64_t next_row_us_ = 0;
  int64_t last_row_us_ = INT64_MIN;
  int run_ = 0;
  std::vector<PlanRun> plan_runs_{PlanRun{}};
  std::vector<PlanRun> pending_plans_;  // plan starts not yet reached by the rows
  PlanStatus last_status_;
  bool have_status_ = false;
};

}  // namespace sirupp::logger
