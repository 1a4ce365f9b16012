#pragma once
// The Table II analysis of one movement set (docs/logging.md, "Report: definitions"). Pure
// functions over a RunTable; positions in the table's units (deg, or mm for prismatic joints).
//
// A move is a run of rows with the same set-point move_id; it starts at the first row with its id
// (the servo tick the move was loaded) and ends where the next move starts or the data ends. The
// move before the file's first change of move_id started before the file and is not analysed.
// A joint takes part in a move when its set-point travels at least min_travel in it.

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "logger/data_file.hpp"

namespace sirupp::logger {

struct AnalysisOptions {
  double settle_window_s = 0.25;  // the transient lasts until move-done + this
  // The steady state lasts until the next move, and at most this long after the transient: the
  // last move of a file then ends at the same row whenever the next set started (a wall-clock
  // matter), so its figures do not depend on the machine's timing.
  double steady_window_s = 1.0;
  double start_threshold = 0.5;        // deg (mm): a stream has started once it moved this far
  double settle_band_fraction = 0.02;  // settling band: this fraction of the travel, +-
  double final_window_s = 0.1;         // final value: the stream's mean over the move's last ...
  double min_travel = 0.5;             // deg (mm): smaller set-point travel = joint not moving
  std::vector<int> joints;             // 1-based joints to report; empty = all
  // Only each movement set's last move: the paper's sets first return the arm to zero, then make
  // the move Table II measures.
  bool last_move_only = false;
};

// The three comparisons of the report; error = second minus first.
enum class Pair : int { kSetVirt = 0, kSetReal = 1, kVirtReal = 2 };
inline constexpr int kNumPairs = 3;
inline constexpr Pair kAllPairs[kNumPairs] = {Pair::kSetVirt, Pair::kSetReal, Pair::kVirtReal};
Stream PairFirst(Pair pair);
Stream PairSecond(Pair pair);
const char* PairTitle(Pair pair);  // "set-point vs virtual", ...
const char* PairKey(Pair pair);    // "set_virt", ...
// The pair's error at row i of joint j (0-based), second minus first; NaN where either stream has
// no value or only repeats a reading taken before the row (between two polls of a real arm, the
// motion since would count as error). period: table.period_s().
double PairError(const RunTable& table, Pair pair, size_t j, size_t i, double period);

// One error of a pair within a move, at a time on the first stream's clock (the time axis).
struct PairPoint {
  double time_s = 0;
  double error = 0;  // second minus first
};
// The pair's errors over the move of rows [begin, end) for joint j, compared per move from the
// move's own start. Set-point vs virtual: row by row (PairError). Pairs with the real arm: each
// real sample taken within its row's period is compared with the first stream at the time it has
// on the real arm's own clock since the move's start S (RunTable::RealSampleTimes: S + (W - W0),
// its stamp W against the real arm's clock W0 at S; in files without stamps S + (t - S) / r, r the
// file's real-time factor). The real arm runs on the wall clock, so when the sim slips its motion
// is compressed on the sim-time axis, by as much as the sim slipped at each moment; this undoes
// that. The first stream is interpolated between its rows there; samples whose time falls past
// the move's last row are left out. With a sim that kept pace this is PairError row by row.
std::vector<PairPoint> PairErrors(const RunTable& table, Pair pair, size_t j, size_t begin,
                                  size_t end, double period);

struct PairMetrics {
  int64_t transient_samples = 0;  // rows where both streams have a value
  int64_t steady_samples = 0;
  double mean_transient = 0;  // mean |error| in the transient
  double mean_steady = 0;     // mean |error| in the steady state
  double rms = 0;             // over the whole move
  double max = 0;             // largest |error| over the whole move
  bool has() const { return transient_samples + steady_samples > 0; }
};

// Times of the real stream are on its own clock from the move's start (RunTable::RealSampleTimes).
struct StreamResponse {
  int64_t samples = 0;
  double start_delay_s = 0;  // NaN: never moved start_threshold
  double settling_s = 0;     // NaN: still outside the band at the move's end
  double overshoot = 0;      // deg (mm) beyond the final value, in the direction of travel
  double overshoot_percent = 0;
  double final_value = 0;
  double final_error = 0;  // final value - the set-point's end
  bool has() const { return samples > 0; }
};

struct MoveResult {
  const RunTable* table = nullptr;
  int64_t move_id = 0;
  int joint = 0;               // 1-based
  size_t begin = 0, end = 0;   // rows [begin, end) of the table
  double start_s = 0;          // time of the first row of the move
  double done_s = 0;           // the joint's set-point profile finished (move-done)
  double transient_end_s = 0;  // done_s + settle window (clipped to the move's end)
  double end_s = 0;            // time of the move's last row
  bool done_seen = true;       // false: the profile did not finish within the move
  double from = 0, to = 0;     // set-point at the start and at the end
  std::array<PairMetrics, kNumPairs> pairs{};
  std::array<StreamResponse, kNumStreams> streams{};
};

struct Analysis {
  std::vector<MoveResult> moves;
  std::vector<std::string> notes;
};

// Throws core::ConfigError naming the table's source if an asked-for joint does not exist. A table
// without set-point data (moves cannot be found without it) gives no moves and a note.
Analysis Analyze(const RunTable& table, const AnalysisOptions& options);

}  // namespace sirupp::logger
