#pragma once
// sirupp-logger's logic over a core::Bus: the paper's data files, written without ever blocking
// the bus and without losing what was received (docs/logging.md).
//
// In:  ARM_SETPOINT (set-point), SIM_ARM_STATE (virtual arm), REAL_ARM_STATE (real arm, when a
//      bridge runs), CONTROLLER_STATUS (plan runs: one file per movement set), ARM_GAINS,
//      CONTROLLER_GAINS and REAL_ARM_GAINS (every change written into the file with its time).
// Out: the data files; HEARTBEAT; with --raw, the raw log (every message, and LOGGER_PASS: each
//      pass of the writer, so that ReplayRawLog writes the same files).
//
// Threads: the caller's thread runs the bus (Service); its handlers only copy each message into a
// queue (never waiting on the disk). A writer thread aligns the streams (logger/aligner.hpp) and
// appends whole rows to the file at least every flush period (25 ms by default), so a kill -9
// loses at most the rows of the last ~100 ms (the idle timeout plus one flush period, for a
// stream that has just gone quiet). Missing sequence numbers and queue overflow are counted per
// stream and written in every row (*_lost) and in the closing line.

#include <array>
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <lcm/lcm-cpp.hpp>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <variant>
#include <vector>

#include "core/bus.hpp"
#include "core/channels.hpp"
#include "core/heartbeat.hpp"
#include "core/model_check.hpp"
#include "core/robot_model.hpp"
#include "core/tick_reader.hpp"
#include "logger/aligner.hpp"
#include "logger/data_file.hpp"
#include "logger/samples.hpp"

namespace sirupp::logger {

struct LoggerOptions {
  std::string out_dir = "logs";
  std::string name;            // file stem; "" = sirupp-YYYYmmdd-HHMMSS (local time at start)
  bool split_per_plan = true;  // NAME-NN-LABEL.csv per movement set; false: NAME.csv
  AlignerOptions aligner;
  bool velocities = false;
  bool efforts = false;
  int flush_period_ms = 25;
  size_t queue_limit = 1000000;  // messages waiting for the writer; beyond it they are counted lost
  core::Channels channels;       // names without the rig prefix (the Bus adds it)
  std::string note;              // free text for the header (e.g. the lab layout)
  std::string process_name = "sirupp-logger";
  // Publish the heartbeat on this one (a Recorder's, which outlives its runs); nullptr: the node
  // has its own.
  core::Heartbeat* heartbeat = nullptr;
  // Raw log: every message on the bus (all channels, with or without the prefix) in lcm-logger's
  // format, each event stamped with the receive time this logger aligned it with, and each pass of
  // the writer (LOGGER_PASS: when, and how many messages it had taken), so that ReplayRawLog
  // writes the same rows. "" = none. An existing file is never replaced: NAME.lcmlog becomes
  // NAME.1.lcmlog, NAME.2.lcmlog, ...
  std::string raw_log;
  // Replay: no writer thread and no wall clock; the caller feeds recorded messages
  // (core::Bus::DeliverRecorded) and moves the clock on with AdvanceTo(), as the writer thread
  // would have run live (ReplayRawLog below).
  bool replay = false;
};

struct LoggerStats {
  int64_t rows = 0;
  std::array<int64_t, kNumStreams> samples{};  // messages received per stream
  std::array<int64_t, kNumStreams> lost{};     // missing per stream (gaps + overflow)
  int64_t queue_overflow = 0;
  // Per-tick datagrams the kernel dropped for the logger's own socket (its buffer was full); the
  // streams' `lost` above hold them too, as sequence gaps.
  int64_t kernel_dropped = 0;
  std::vector<std::string> files;  // written so far, in order
  std::string error;               // the writer's failure (disk full, ...), empty when fine
};

class LoggerNode {
 public:
  // Creates out_dir if needed. If data files of NAME are there already (a restart with the same
  // command line, as a launcher's `restart: on-failure` does), the logger continues the run in new
  // files and never replaces one (docs/logging.md, "Restarts").
  LoggerNode(core::Bus& bus, const core::RobotModel& model, LoggerOptions options);
  ~LoggerNode();
  LoggerNode(const LoggerNode&) = delete;
  LoggerNode& operator=(const LoggerNode&) = delete;

  // Handles bus traffic for at most max_wait_ms and publishes the heartbeat when due.
  void Service(int max_wait_ms);
  // Stops the writer after writing every row received, and closes the files with their "# end"
  // line. Idempotent.
  void Close();
  // Replay only: what the writer thread does once per flush period, at time now_utime (a recorded
  // pass's, or the log's clock): takes the messages delivered so far, up to the `taken`-th since
  // the start (all of them when taken < 0), and writes the rows that are final.
  void AdvanceTo(int64_t now_utime, int64_t taken = -1);
  // Replay only: the writer's last pass at now_utime, then the files are closed (as Close()).
  void Finish(int64_t now_utime);
  // Replay only: the start time and LCM URL the headers name (a recorded pass's).
  void UseRecordedStart(int64_t started_utime, const std::string& lcm_url);
  // Messages the handlers have handed to the writer so far (those dropped for a full queue
  // included): the count LOGGER_PASS's `taken` refers to.
  int64_t handed() const;
  // The raw log being written ("" when none).
  const std::string& raw_log() const { return raw_path_; }

  LoggerStats stats() const;
  bool failed() const;
  const std::string& name() const { return options_.name; }
  // The newest data file of an earlier logger with the same name and directory, which this one
  // continues; empty when none was there.
  const std::string& continues() const { return restart_.previous_file; }

 private:
  using Input = std::variant<Sample, PlanStatus, GainsRecord>;

  void Push(Input input, Stream stream);
  // A controller status's last_error: keeps what it says of the real arm (bus thread).
  void NoteRealArm(const std::string& last_error);
  void QueueLocked(Input&& input, Stream stream);  // mutex_ held
  // Bus thread: hands the messages of one Service() round to the writer at once, so that a writer
  // pass never takes the plan statuses LCM delivered without the per-tick samples of the same
  // round that wait in the feed (they are older; a pass would take rows past them).
  void HandOver();
  void WriterLoop();
  // One pass of the writer over `batch`; now_utime: the wall clock live, the recorded pass's (or
  // the log's clock) in a replay (only for a quiet bus); stopping: close the files after it.
  // False when the pass could not have changed anything (no message, the quiet rule not due): the
  // raw log leaves such passes out.
  bool ProcessBatch(std::vector<Input>& batch, int64_t now_utime, bool stopping);
  // Writer side: LOGGER_PASS into the raw log.
  void RecordPass(int64_t now_utime, bool last);
  void OpenRawLog();
  // Through LCM's C interface: LCM 1.3.1's C++ untyped subscription trips UBSan's vptr check.
  static void RecordRaw(const lcm_recv_buf_t* rbuf, const char* channel, void* node);
  void RecordRawEvent(const char* channel, const void* data, int size, int64_t recv_utime);
  // Bus thread: the per-tick datagrams waiting on the feed's socket, each in order into the raw
  // log and to the subscriptions above.
  void DrainTicks();
  void WriteRow(const Row& row);
  void OpenFile(const Row& row);
  void CloseFile();
  std::vector<std::string> HeaderLines(const Row& row) const;
  std::string EndLine() const;

  core::Bus& bus_;
  std::vector<core::Subscription*> subscriptions_;  // ended by the destructor
  // On udpm: the per-tick channels from a socket of the logger's own, every datagram in order, in
  // batches (core/tick_reader.hpp); LCM's socket no longer takes them. Null on memq:// and in a
  // replay.
  std::unique_ptr<core::TickFeed> ticks_;
  int drain_wait_ms_ = 5;  // the bus thread's wait between two drains (Service)
  // Inside Service() (bus thread only): Push() collects here, HandOver() queues them together.
  bool collecting_ = false;
  std::vector<std::pair<Input, Stream>> round_;
  core::RobotModel model_;
  LoggerOptions options_;
  ColumnLayout layout_;
  std::unique_ptr<core::Heartbeat> own_heartbeat_;  // when options_.heartbeat is null
  core::Heartbeat& heartbeat_;
  // One robot: the sim's ROBOT_MODEL against the model the columns are labelled from; a mismatch
  // is a fault on the heartbeat (the data would carry the wrong robot's names and units).
  core::ModelWatch model_watch_;
  int64_t started_utime_ = 0;  // wall clock at the start (live), or as recorded (replay)
  std::string started_text_;
  std::string url_text_;  // the bus, for the headers

  // What an earlier logger of the same NAME left in out_dir (found at start).
  struct RestartState {
    std::string previous_file;  // newest NAME*.csv (by modification time), "" if none
    std::string previous_stem;  // its name without ".csv" and without a ".K" continuation suffix
    std::string previous_plan;  // the plan in its header, "" for none
    int last_number = 0;        // highest NN of NAME-NN-SET files
    int last_run = 0;           // highest K of NAME-rK files
    bool continued = false;     // the first file of this logger has been opened
  };
  RestartState restart_;
  // A file name (without ".csv") not taken yet: `stem`, else `stem.1`, `stem.2`, ...
  std::string FreeStem(const std::string& stem, bool continuation) const;

  // Bus thread only.
  SequenceCounter set_seq_, virt_seq_, real_seq_;

  // Shared between the bus thread and the writer.
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::vector<Input> queue_;
  int64_t handed_ = 0;                           // Push() calls so far
  std::array<int64_t, kNumStreams> overflow_{};  // dropped since the writer last looked
  bool stop_ = false;
  LoggerStats stats_;
  // The controller's reports that the real arm's half of the run was lost (core::kRealArmLost),
  // in order, and whether the newest status still says so: the data files' end lines name them.
  std::vector<std::string> real_arm_notes_;
  bool real_arm_lost_now_ = false;

  // Writer thread only.
  Aligner aligner_;
  std::unique_ptr<DataFileWriter> file_;
  size_t file_real_arm_notes_ = 0;  // real_arm_notes_.size() when file_ was opened
  int file_run_ = -1;
  int file_plan_ = -1;
  int file_count_ = 0;
  GainsRecord gains_;  // last ARM_GAINS request, for the header
  bool have_gains_ = false;
  std::array<std::optional<GainsRecord>, kNumGainsSources> last_gains_;  // per source
  // Gain-change lines waiting for the rows up to their time.
  struct PendingNote {
    int64_t time_us = 0;  // on the time axis; INT64_MIN if not known yet
    std::string text;
  };
  std::deque<PendingNote> notes_;
  bool stopping_ = false;
  // The real-time factor (sim time over wall time) of the run so far and of the present file;
  // a "# real-time factor:" line every kFactorLineUs of wall clock and when the file closes.
  static constexpr int64_t kFactorLineUs = 2000000;
  ClockRate run_rate_;
  ClockRate file_rate_;
  int64_t last_factor_line_us_ = 0;
  void NoteGains(const GainsRecord& gains);
  void WriteNotes(int64_t up_to_us);
  int8_t last_mode_ = -1;

  std::thread writer_;
  bool closed_ = false;
  // Writer side (writer thread, or the replay caller).
  std::array<int64_t, kNumStreams> carry_{};  // overflow not yet put into a sample's lost_before
  bool write_failed_ = false;
  int64_t bus_now_ = 0;  // receive time of the newest message taken: the aligner's clock
  int64_t taken_ = 0;    // handed_ as of the last pass
  int64_t quiet_taken_ = 0;
  static constexpr int64_t kQuietUs = 500000;  // the whole bus quiet this long: rows move on

  // Raw log: messages from the bus thread, passes from the writer.
  std::string raw_path_;
  std::string pass_channel_;  // LOGGER_PASS with the prefix
  // Messages received before every subscription of the logger was in place are neither recorded
  // raw nor handled: the raw log and the data files start from the same message (the receive
  // time is the same for every subscription of a message). INT64_MAX until then; a replay takes
  // every message.
  std::atomic<int64_t> live_from_utime_{INT64_MAX};
  bool Live(int64_t recv_utime) const { return recv_utime >= live_from_utime_.load(); }
  std::mutex raw_mutex_;  // raw_file_ and the two below
  std::unique_ptr<lcm::LogFile> raw_file_;
  int64_t raw_last_utime_ = 0;  // timestamp of the last event written
  int64_t pass_seq_ = 0;
  lcm_subscription_t* raw_subscription_ = nullptr;  // bus thread only
  std::chrono::steady_clock::time_point raw_flushed_;
};

// Runs a logger over a raw log (LoggerOptions::raw_log of an earlier run): every message goes to
// the node with its recorded receive time, and the writer's passes recorded on LOGGER_PASS run
// where they ran live (after the same messages, with the same clock), so the data files are the
// ones the live logger wrote, header lines included (docs/logging.md, "Raw logs"). An empty
// options.name takes the recorded one. A log without passes (lcm-logger's) gets a pass every flush
// period of its clock instead. `options.replay` is set here. Throws core::ConfigError for a
// damaged log or pass.
LoggerStats ReplayRawLog(const std::string& log_path, const core::RobotModel& model,
                         LoggerOptions options, const std::string& prefix);

// "sirupp-YYYYmmdd-HHMMSS" for the present local time.
std::string DefaultRunName();

}  // namespace sirupp::logger
