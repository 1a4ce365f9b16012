#pragma once
// The paper's data file: CSV with a commented header (docs/logging.md, "Data files").
//
//   # sirupp-logger data file, format 2; the column line is line 14
//   # model: ...                        (one "# key: value" line each: model, joints, plan, ...)
//   time_s,j1_set_deg,j1_virt_deg,j1_real_deg,...,move_id,j1_done,...,set_lost,...,real_age_us,
//   real_clock_us,set_recv_us
//   12.345216,45.12345,45.01234,,...
//   # end: 2048 rows, ...               (written on a clean close only)
//
// Writing: whole rows only, one write() per batch, so a killed logger leaves complete lines (a
// kill inside that write() can leave one partial last line, which readers drop with a warning).
// Reading: strict. Anything that is not our format stops with "FILE:LINE: what is wrong", so no
// number is ever computed from a damaged file.

#include <array>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "logger/aligner.hpp"
#include "logger/samples.hpp"

namespace sirupp::logger {

// Format 2 added the real_clock_us and set_recv_us columns; format 1 files are still read.
inline constexpr const char* kFileMagic = "# sirupp-logger data file, format 2";
inline constexpr const char* kFileMagicFormat1 = "# sirupp-logger data file, format 1";
// real_clock_us of a row whose real cell is empty (or of a file without the column).
inline constexpr int64_t kNoClock = std::numeric_limits<int64_t>::min();

struct JointInfo {
  std::string name;  // e.g. "waist"; may be empty
  bool prismatic = false;

  const char* unit() const { return prismatic ? "mm" : "deg"; }  // of positions in files
  double scale() const;  // from SI (rad or m) to the file's unit
};

// Which columns a file has.
struct ColumnLayout {
  std::vector<JointInfo> joints;
  bool velocities = false;  // jN_STREAM_vel_{dps,mmps}
  bool efforts = false;     // jN_STREAM_effort_{nm,n}

  std::vector<std::string> Names() const;
  // Appends one CSV line (with '\n') for `row`.
  void AppendRow(const Row& row, std::string& out) const;
};

// One movement set of one input, as columns: what the analysis reads, whether it came from our CSV
// or an LCM log. Positions are in the file's units (deg, or mm for prismatic joints); NaN = empty.
struct RunTable {
  std::string source;     // the input file
  std::string label;      // movement set: the plan file's stem ("set7"), else the file's stem
  std::string plan_name;  // as the controller reported it; empty when none
  std::vector<JointInfo> joints;
  std::vector<double> time_s;
  std::vector<std::array<std::vector<double>, kNumStreams>> position;  // [joint][stream][row]
  std::vector<int64_t> move_id;                                        // -1 = empty
  std::vector<std::vector<int8_t>> done;                               // [joint][row], -1 empty
  std::array<int64_t, kNumStreams> lost{};  // missing messages per stream, at the last row
  // The same counts at the first row: the logger's counts run from its start, so a set's own
  // losses are lost - lost_at_start (LostInSet).
  std::array<int64_t, kNumStreams> lost_at_start{};
  std::array<int64_t, kNumStreams> cells{};  // filled cells per stream
  // Per stream and row: how old the cell's sample was at the row time, in s (the *_age_us columns;
  // a real arm polled at 100 Hz holds each sample for about 20 rows of 0.512 ms). NaN: empty cell,
  // or a file without age columns.
  std::array<std::vector<double>, kNumStreams> age_s;
  // Per row: the real cell's sample's own stamp, in microseconds on the real arm's clock (the wall
  // clock for a real or emulated arm; the real_clock_us column); kNoClock for an empty cell. Empty
  // (not one entry per row) for a file without the column (format 1).
  std::vector<int64_t> real_clock_us;
  // Per row: when the logger received the row's set-point sample, microseconds on its wall clock
  // (the set_recv_us column): the wall clock when the sim was at the row's time; kNoClock for an
  // empty cell or one without a receive time. Empty for a file without the column.
  std::vector<int64_t> set_recv_us;
  bool closed = false;             // the writer's "# end" line is there
  std::string continues;           // header "continues:": the file a restarted logger continued
  std::vector<std::string> gains;  // the "# gains: ..." lines among the rows, without "# "
  // Sim time over wall time over this data (the "# real-time factor:" lines, else the header's
  // factor so far); NaN when not known. Below 1 when the sim slipped behind the wall clock.
  double realtime_factor = std::numeric_limits<double>::quiet_NaN();
  // The real-arm stream is on the sim clock (a second sim standing in for the arm), not the wall
  // clock: no real-time factor applies to it.
  bool real_on_sim_clock = false;
  // The file-wide real-time factor as the real arm's clock scale (1 when the factor is unknown or
  // the real arm is on the sim clock): what RealSampleTimes falls back to without stamps.
  double RealClockScale() const;
  // The real arm on its own clock, per move (docs/logging.md, "Definitions"). For each row of
  // [begin, end): the time on the axis at which its real sample was taken, counted on the real
  // arm's own clock from row `anchor` (a move's first row, at S = time_s[anchor]): S + (W - W0),
  // W the sample's stamp (real_clock_us), W0 the real arm's clock at S: when the logger received
  // the set-point sample of row `anchor` (set_recv_us), if the real arm's stamps are on the same
  // clock (within 1 s, as the aligner takes them); else, or without it, interpolated between the
  // stamped samples around S (their time on the axis, row time minus age, against their stamps:
  // the sim clock's offsets the logger placed them by, which can be 0.1 s off when the sim runs in
  // bursts). However much and however unevenly the sim slipped behind the wall clock after S, the
  // real motion keeps its own timing. Rows without a
  // stamp (format 1 files) use the file-wide factor instead: S + (t - S) / RealClockScale(), t the
  // row time minus the age. NaN where the real cell is empty. analysis.cpp (PairErrors, the
  // responses), report.cpp's plots and lab/identify.cpp place real samples with this.
  std::vector<double> RealSampleTimes(size_t anchor, size_t begin, size_t end) const;
  // The rows where a move starts: a known move_id (>= 0) that differs from the previous known one.
  // The move in progress at the first row has no start here (its start is not in the data).
  std::vector<size_t> MoveStarts() const;
  // Messages missing on stream s between the first and the last row of this table.
  int64_t LostInSet(size_t s) const { return lost[s] - lost_at_start[s]; }
  std::vector<std::string> notes;  // warnings worth showing with the report

  size_t rows() const { return time_s.size(); }
  // Prepares the columns for these joints (no rows).
  void Reset(const std::vector<JointInfo>& joint_list);
  // Appends an aligner row (SI values converted to file units).
  void Append(const Row& row);
  // The sample clock: the smallest step between consecutive rows (rows lie on multiples of it);
  // 0 with fewer than two rows.
  double period_s() const;
  // The age of row i's sample of `stream` in s; 0 when unknown.
  double Age(Stream stream, size_t i) const;
  // Whether row i holds a sample of `stream` taken within the row's own period, that is, not one
  // held over from an earlier row. True when the age is unknown. period: period_s().
  bool Fresh(Stream stream, size_t i, double period) const;
};

// The movement-set label of a plan name: the file stem ("config/plans/set7.plan" -> "set7"), made
// of letters, digits, '-' and '_' only; "manual" when empty.
std::string PlanLabel(const std::string& plan_name);

// Writes one data file. Not thread-safe; the logger's writer thread owns it.
class DataFileWriter {
 public:
  // Creates `path` (refusing to replace an existing file) and writes the magic line, the
  // "# key: value" header lines and the column line. Throws std::runtime_error naming the path.
  DataFileWriter(const std::string& path, const std::vector<std::string>& header_lines,
                 ColumnLayout layout);
  ~DataFileWriter();
  DataFileWriter(const DataFileWriter&) = delete;
  DataFileWriter& operator=(const DataFileWriter&) = delete;

  void Append(const Row& row);
  // Appends "# TEXT" (one line; line ends in TEXT are replaced by spaces) after the rows so far.
  void AppendComment(const std::string& text);
  // Writes the buffered rows (whole lines) to the file.
  void Flush();
  // Flushes, writes "# end: ..." and closes.
  void Close(const std::string& end_line);

  const std::string& path() const { return path_; }
  int64_t rows() const { return rows_; }
  double first_time_s() const { return first_time_s_; }
  double last_time_s() const { return last_time_s_; }

 private:
  void WriteAll(const std::string& text);

  std::string path_;
  ColumnLayout layout_;
  int fd_ = -1;
  std::string buffer_;
  int64_t rows_ = 0;
  double first_time_s_ = 0;
  double last_time_s_ = 0;
};

// Reads one data file. Throws core::ConfigError "FILE:LINE: problem" for anything malformed; a
// partial last line (the logger killed mid-write) and a missing "# end" line become notes.
RunTable ReadDataFile(const std::string& path);

}  // namespace sirupp::logger
