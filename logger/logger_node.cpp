#include "logger/logger_node.hpp"

#include <algorithm>
#include <cctype>
#include <chrono>
#include <climits>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sirupp/arm_state_t.hpp>
#include <sirupp/controller_status_t.hpp>
#include <sirupp/robot_model_t.hpp>
#include <sirupp/servo_gains_t.hpp>
#include <sirupp/servo_setpoint_t.hpp>
#include <stdexcept>
#include <utility>
#include <vector>

#include "core/errors.hpp"
#include "core/messages.hpp"
#include "core/real_arm_note.hpp"
#include "core/translate.hpp"
#include "logger/lcm_log.hpp"
#include "logger/raw_settings.hpp"

namespace sirupp::logger {

namespace {

int64_t WallMicros() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

// A wall-clock time in local time, for file names (compact) or headers (ISO 8601 with the UTC
// offset).
std::string LocalTimeText(int64_t utime, bool compact) {
  const auto seconds = static_cast<std::time_t>(utime / 1000000);
  std::tm local{};
  localtime_r(&seconds, &local);
  char text[64];
  if (compact) {
    std::strftime(text, sizeof text, "%Y%m%d-%H%M%S", &local);
  } else {
    std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%S%z", &local);
  }
  return text;
}

// A wall-clock time in microseconds as local ISO 8601 with milliseconds and the UTC offset.
std::string WallTimeText(int64_t utime) {
  const std::time_t seconds = static_cast<std::time_t>(utime / 1000000);
  std::tm local{};
  localtime_r(&seconds, &local);
  char date[32];
  char zone[8];
  std::strftime(date, sizeof date, "%Y-%m-%dT%H:%M:%S", &local);
  std::strftime(zone, sizeof zone, "%z", &local);
  char text[64];
  std::snprintf(text, sizeof text, "%s.%03d%s", date, static_cast<int>((utime / 1000) % 1000),
                zone);
  return text;
}

std::string Seconds(int64_t utime) {
  char text[32];
  std::snprintf(text, sizeof text, "%.6f", static_cast<double>(utime) * 1e-6);
  return text;
}

std::string JoinNumbers(const std::vector<double>& values) {
  std::string text;
  for (double value : values) text += (text.empty() ? "" : " ") + core::FormatNumber(value);
  return text;
}

// Joint names go into "name unit; ..." lists: keep them one word without separators.
std::string HeaderWord(const std::string& name) {
  std::string word = name.empty() ? "-" : name;
  for (char& c : word) {
    if (c == ' ' || c == ';' || c == ',' || c == '\t') c = '_';
  }
  return word;
}

}  // namespace

std::string DefaultRunName() { return "sirupp-" + LocalTimeText(WallMicros(), true); }

LoggerNode::LoggerNode(core::Bus& bus, const core::RobotModel& model, LoggerOptions options)
    : bus_(bus),
      model_(model),
      options_(std::move(options)),
      own_heartbeat_(options_.heartbeat != nullptr
                         ? nullptr
                         : std::make_unique<core::Heartbeat>(bus, options_.process_name,
                                                             options_.channels.heartbeat)),
      heartbeat_(options_.heartbeat != nullptr ? *options_.heartbeat : *own_heartbeat_),
      model_watch_(model_, options_.process_name),
      aligner_(options_.aligner) {
  if (options_.name.empty()) options_.name = DefaultRunName();
  for (const core::Joint& joint : model_.joints) {
    layout_.joints.push_back({joint.name, joint.type == core::JointType::kPrismatic});
  }
  layout_.velocities = options_.velocities;
  layout_.efforts = options_.efforts;
  started_utime_ = WallMicros();
  started_text_ = LocalTimeText(started_utime_, false);
  url_text_ = bus_.url().empty() ? "(LCM default)" : bus_.url();
  pass_channel_ = bus_.prefix() + options_.channels.logger_pass.name();

  namespace fs = std::filesystem;
  std::error_code error;
  fs::create_directories(options_.out_dir, error);
  if (!fs::is_directory(options_.out_dir)) {
    throw std::runtime_error("--out " + options_.out_dir + ": cannot create the directory" +
                             (error ? ": " + error.message() : ""));
  }
  // Files of an earlier logger with this name: NAME.csv, NAME-rK.csv, NAME-NN-SET.csv, each
  // perhaps with a continuation suffix (NAME-NN-SET.2.csv).
  fs::file_time_type newest_time = fs::file_time_type::min();
  for (const auto& entry : fs::directory_iterator(options_.out_dir)) {
    const std::string file = entry.path().filename().string();
    if (entry.path().extension() != ".csv" ||
        !(file == options_.name + ".csv" || file.rfind(options_.name + "-", 0) == 0 ||
          file.rfind(options_.name + ".", 0) == 0)) {
      continue;
    }
    std::string stem = entry.path().stem().string();
    const size_t dot = stem.rfind('.');
    if (dot != std::string::npos && dot + 1 < stem.size() &&
        stem.find_first_not_of("0123456789", dot + 1) == std::string::npos &&
        dot >= options_.name.size()) {
      stem.resize(dot);  // the continuation suffix
    }
    const std::string rest = stem.substr(options_.name.size());  // "", "-r3" or "-07-set2"
    if (rest.size() > 2 && rest.compare(0, 2, "-r") == 0 &&
        rest.find_first_not_of("0123456789", 2) == std::string::npos) {
      restart_.last_run = std::max(restart_.last_run, std::atoi(rest.c_str() + 2));
    } else if (rest.size() > 4 && rest[0] == '-' && rest[3] == '-' &&
               std::isdigit(static_cast<unsigned char>(rest[1])) &&
               std::isdigit(static_cast<unsigned char>(rest[2]))) {
      restart_.last_number = std::max(restart_.last_number, std::atoi(rest.c_str() + 1));
    } else if (!rest.empty()) {
      continue;  // another run's name that merely starts with ours ("lab-old.csv")
    }
    std::error_code time_error;
    const fs::file_time_type time = fs::last_write_time(entry.path(), time_error);
    if (!time_error && (restart_.previous_file.empty() || time > newest_time ||
                        (time == newest_time && entry.path().string() > restart_.previous_file))) {
      newest_time = time;
      restart_.previous_file = entry.path().string();
      restart_.previous_stem = stem;
    }
  }
  file_count_ = restart_.last_number;
  if (!restart_.previous_file.empty()) {
    // The plan the earlier logger was recording: a run of it under way now is joined, not split.
    std::ifstream previous(restart_.previous_file);
    std::string line;
    for (int i = 0; i < 40 && std::getline(previous, line) && line.rfind("#", 0) == 0; ++i) {
      if (line.rfind("# plan: ", 0) == 0 && line != "# plan: (none)") {
        restart_.previous_plan = line.substr(8);
        break;
      }
    }
    aligner_.ContinuePlan(restart_.previous_plan);
  }

  const int joints = model_.num_joints();
  auto check = [joints](const std::string& channel, int32_t count) {
    if (count != joints) {
      throw core::MessageError(
          channel, "num_joints",
          std::to_string(count) + " joints; the model has " + std::to_string(joints));
    }
  };
  // The raw log first: from the first message on, it gets every message the handlers below get.
  if (!options_.raw_log.empty()) OpenRawLog();
  constexpr int kQueue = 10000;  // LCM's own per-subscription queue between two Handle() calls
  subscriptions_.push_back(&bus_.Subscribe<sirupp::servo_setpoint_t>(
      options_.channels.arm_setpoint,
      [this, check](const sirupp::servo_setpoint_t& message, const core::ReceiveInfo& info) {
        if (!Live(info.recv_utime)) return;
        // A data file holds finite numbers only: the translation refuses a NaN or infinite
        // value whole (counted as rejected on its channel), whoever sent it.
        check(info.channel, message.num_joints);
        core::ServoSetpointFromMessage(message, info.channel);
        Sample sample = SampleFromSetpoint(message, info.recv_utime);
        sample.lost_before = set_seq_.Next(message.seq);
        Push(std::move(sample), Stream::kSetpoint);
      },
      kQueue));
  subscriptions_.push_back(&bus_.Subscribe<sirupp::arm_state_t>(
      options_.channels.sim_arm_state,
      [this, check](const sirupp::arm_state_t& message, const core::ReceiveInfo& info) {
        if (!Live(info.recv_utime)) return;
        check(info.channel, message.num_joints);
        core::ArmStateFromMessage(message, info.channel, -1);
        Sample sample = SampleFromArmState(message, Stream::kVirtual, info.recv_utime);
        sample.lost_before = virt_seq_.Next(message.seq);
        Push(std::move(sample), Stream::kVirtual);
      },
      kQueue));
  subscriptions_.push_back(&bus_.Subscribe<sirupp::arm_state_t>(
      options_.channels.real_arm_state,
      [this, check](const sirupp::arm_state_t& message, const core::ReceiveInfo& info) {
        if (!Live(info.recv_utime)) return;
        check(info.channel, message.num_joints);
        core::ArmStateFromMessage(message, info.channel, -1);
        Sample sample = SampleFromArmState(message, Stream::kReal, info.recv_utime);
        sample.lost_before = real_seq_.Next(message.seq);
        Push(std::move(sample), Stream::kReal);
      },
      kQueue));
  subscriptions_.push_back(&bus_.Subscribe<sirupp::controller_status_t>(
      options_.channels.controller_status,
      [this](const sirupp::controller_status_t& message, const core::ReceiveInfo& info) {
        if (!Live(info.recv_utime)) return;
        // Plan runs split the files: a status no controller could send is refused.
        core::ControllerStatusFromMessage(message, info.channel);
        NoteRealArm(message.last_error);
        Push(StatusFromMessage(message, info.recv_utime), Stream::kSetpoint);
      },
      kQueue));
  // Gains: requests, the virtual servos' live gains and the real boards'; every change is written
  // into the data file with its time.
  const std::pair<std::string, GainsSource> gains_channels[] = {
      {options_.channels.arm_gains, GainsSource::kRequest},
      {options_.channels.controller_gains, GainsSource::kController},
      {options_.channels.real_arm_gains, GainsSource::kReal}};
  for (const auto& [channel, source] : gains_channels) {
    subscriptions_.push_back(&bus_.Subscribe<sirupp::servo_gains_t>(
        channel,
        [this, check, gains_source = source](const sirupp::servo_gains_t& message,
                                             const core::ReceiveInfo& info) {
          if (!Live(info.recv_utime)) return;
          check(info.channel, message.num_joints);
          core::ServoGainsFromMessage(message, info.channel);
          GainsRecord gains = GainsFromMessage(message, gains_source, info.recv_utime);
          Push(std::move(gains), Stream::kSetpoint);
        },
        kQueue));
  }
  subscriptions_.push_back(&bus_.Subscribe<sirupp::robot_model_t>(
      options_.channels.robot_model,
      [this](const sirupp::robot_model_t& message, const core::ReceiveInfo& info) {
        if (model_watch_.Check(message, info.channel) && !model_watch_.mismatch().empty()) {
          std::cerr << options_.process_name << ": " << model_watch_.mismatch() << "\n";
          heartbeat_.Publish(core::ProcessState::kFault, model_watch_.mismatch());
        }
      }));
  if (!options_.replay) {
    // The per-tick channels in batches from a socket of the logger's own (every datagram, in
    // order, with the kernel's receive time, as LCM would give them). With --raw, every per-tick
    // channel of the rig, so that the raw log still holds the whole bus.
    std::vector<std::string> ticks{bus_.FullName(options_.channels.arm_setpoint),
                                   bus_.FullName(options_.channels.sim_arm_state),
                                   bus_.FullName(options_.channels.real_arm_state),
                                   bus_.FullName(options_.channels.sim_arm_ticks)};
    if (!options_.raw_log.empty()) {
      ticks.push_back(bus_.FullName(options_.channels.sim_arm_command));
      ticks.push_back(bus_.FullName(options_.channels.real_arm_setpoint));
    }
    // As large a buffer as allowed: it holds what arrives between two drains. No socket filter,
    // so that the kernel's drop count is only datagrams lost for a full buffer.
    constexpr int kTickBuffer = 32 << 20;
    ticks_ = core::TickFeed::Open(bus_, std::move(ticks), options_.process_name, kTickBuffer,
                                  core::TickReader::Pick::kCountDrops);
  }
  // From now on every subscription is in place: raw log and handlers take the same messages. A
  // message that reached LCM's socket before the feed took its channel over is older than this,
  // so none is taken twice.
  live_from_utime_ = options_.replay ? INT64_MIN
                                     : std::chrono::duration_cast<std::chrono::microseconds>(
                                           std::chrono::system_clock::now().time_since_epoch())
                                           .count();
  if (options_.replay) return;  // no heartbeat, no writer thread: the caller drives it
  if (own_heartbeat_) heartbeat_.Publish(core::ProcessState::kStarting, "");
  writer_ = std::thread([this] { WriterLoop(); });
}

LoggerNode::~LoggerNode() {
  // The bus may outlive this node (another logger on it after a restart): no handler may call
  // into it any more.
  for (core::Subscription* subscription : subscriptions_) subscription->Unsubscribe();
  try {
    Close();
  } catch (const std::exception&) {  // Close() only throws if joining fails; nothing to add here
  }
}

void LoggerNode::NoteRealArm(const std::string& last_error) {
  const bool lost = last_error.rfind(core::kRealArmLost, 0) == 0;
  std::lock_guard<std::mutex> lock(mutex_);
  real_arm_lost_now_ = lost;
  if (lost && (real_arm_notes_.empty() || real_arm_notes_.back() != last_error)) {
    real_arm_notes_.push_back(last_error);
  }
}

void LoggerNode::Push(Input input, Stream stream) {
  if (collecting_) {
    round_.emplace_back(std::move(input), stream);
    return;
  }
  std::lock_guard<std::mutex> lock(mutex_);
  QueueLocked(std::move(input), stream);
}

void LoggerNode::QueueLocked(Input&& input, Stream stream) {
  ++handed_;
  if (queue_.size() >= options_.queue_limit) {
    if (std::holds_alternative<Sample>(input)) ++overflow_[static_cast<size_t>(stream)];
    ++stats_.queue_overflow;
    return;
  }
  queue_.push_back(std::move(input));
}

void LoggerNode::HandOver() {
  collecting_ = false;
  if (round_.empty()) return;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    for (auto& [input, stream] : round_) QueueLocked(std::move(input), stream);
  }
  round_.clear();
}

void LoggerNode::Service(int max_wait_ms) {
  // Messages in batches, one wake-up per kBatchMs rather than one per message: the receive times
  // are LCM's receive thread's, so the rows do not change, and the lockstep loop keeps the CPUs.
  // At 30 000 messages a second per channel a batch is 150 of the kQueue (10 000) LCM holds; the
  // per-tick channels wait in the feed's socket buffer (DrainTicks).
  collecting_ = ticks_ != nullptr;
  bus_.HandleBatched(std::min(max_wait_ms, drain_wait_ms_));
  if (ticks_) DrainTicks();
  HandOver();
  // The raw log reaches the disk at least every 0.1 s (a killed logger loses no more).
  if (!raw_path_.empty() &&
      std::chrono::steady_clock::now() - raw_flushed_ > std::chrono::milliseconds(100)) {
    std::lock_guard<std::mutex> lock(raw_mutex_);
    if (raw_file_) std::fflush(raw_file_->getFilePtr());
    raw_flushed_ = std::chrono::steady_clock::now();
  }
  const LoggerStats now = stats();
  if (!model_watch_.mismatch().empty()) {
    heartbeat_.PublishIfDue(core::ProcessState::kFault, model_watch_.mismatch());
  } else if (!now.error.empty()) {
    heartbeat_.PublishIfDue(core::ProcessState::kFault, now.error);
  } else {
    heartbeat_.PublishIfDue(core::ProcessState::kRunning,
                            "recording " + options_.name + ": " + std::to_string(now.rows) +
                                " rows" + (now.files.empty() ? "" : " in " + now.files.back()));
  }
}

void LoggerNode::DrainTicks() {
  core::TickReader& reader = ticks_->reader();
  int64_t charged = 0;  // what the datagrams took of the socket's buffer, about
  reader.DrainEach([this, &charged](size_t, const std::string& channel, const uint8_t* data,
                                    int size, int64_t recv_utime) {
    if (!raw_path_.empty() && Live(recv_utime)) {
      RecordRawEvent(channel.c_str(), data, size, recv_utime);
    }
    bus_.DeliverRecorded(channel, data, size, recv_utime);
    // The kernel charges a datagram's whole allocation: about 1.3 KiB for a tick's message, the
    // next power of two (16 KiB) for a batch of 16 ticks (SIM_ARM_TICKS).
    charged += 2 * static_cast<int64_t>(size) + 768;
  });
  // The next wait from how full the buffer got since the last drain, so that a busy machine that
  // delays this thread does not fill it: past an eighth 1 ms, else 5 ms. (A lockstep sim as fast
  // as it goes sends 100 000 ticks a second or more, and an unprivileged logger's buffer is
  // net.core.rmem_max, 208 KiB by default: about 13 batches. Not waiting at all was worse on 2
  // cores: the drain then takes the CPU the sim and the writer need.)
  const int64_t buffer = std::max(64 * 1024, reader.buffer_bytes());
  drain_wait_ms_ = charged > buffer / 8 ? 1 : 5;
  if (reader.dropped() > 0) {
    std::lock_guard<std::mutex> lock(mutex_);
    stats_.kernel_dropped = reader.dropped();
  }
}

void LoggerNode::Close() {
  if (closed_) return;
  if (raw_subscription_ != nullptr) {
    lcm_unsubscribe(bus_.raw_lcm().getUnderlyingLCM(), raw_subscription_);
    raw_subscription_ = nullptr;
    bus_.ForgetRawSubscription(".*");
  }
  if (options_.replay) {
    Finish(0);
    return;
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  if (writer_.joinable()) writer_.join();  // its last pass goes into the raw log
  closed_ = true;
  std::lock_guard<std::mutex> lock(raw_mutex_);
  raw_file_.reset();  // flushes and closes
}

void LoggerNode::Finish(int64_t now_utime) {
  if (!options_.replay) throw std::logic_error("LoggerNode::Finish: not a replay");
  if (closed_) return;
  std::vector<Input> batch;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    batch.swap(queue_);
    taken_ = handed_;
  }
  ProcessBatch(batch, now_utime, true);
  closed_ = true;
}

void LoggerNode::UseRecordedStart(int64_t started_utime, const std::string& lcm_url) {
  if (!options_.replay) throw std::logic_error("LoggerNode::UseRecordedStart: not a replay");
  started_utime_ = started_utime;
  started_text_ = LocalTimeText(started_utime, false);
  url_text_ = lcm_url.empty() ? "(LCM default)" : lcm_url;
}

int64_t LoggerNode::handed() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return handed_;
}

LoggerStats LoggerNode::stats() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return stats_;
}

bool LoggerNode::failed() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return !stats_.error.empty();
}

void LoggerNode::WriterLoop() {
  std::vector<Input> batch;
  while (true) {
    bool stopping = false;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      wake_.wait_for(lock, std::chrono::milliseconds(options_.flush_period_ms),
                     [this] { return stop_; });
      batch.swap(queue_);
      taken_ = handed_;  // every message handed over is in the batch or was dropped (overflow)
      stopping = stop_;
    }
    // The pass's clock and how many messages it took go into the raw log (after the pass: a
    // replay runs it once that many messages have been delivered, wherever the event lies).
    const int64_t now = WallMicros();
    if (ProcessBatch(batch, now, stopping)) RecordPass(now, stopping);
    if (stopping) break;
  }
}

void LoggerNode::RecordPass(int64_t now_utime, bool last) {
  std::lock_guard<std::mutex> lock(raw_mutex_);
  if (!raw_file_) return;
  core::LoggerPass pass;
  pass.utime = now_utime;
  pass.seq = pass_seq_++;
  pass.taken = taken_;
  pass.last = last;
  pass.started_utime = started_utime_;
  pass.name = options_.name;
  pass.lcm_url = bus_.url();
  PutSettings(options_, model_, bus_.prefix(), pass);
  const sirupp::logger_pass_t message = core::ToMessage(pass);
  std::vector<uint8_t> data(static_cast<size_t>(message.getEncodedSize()));
  message.encode(data.data(), 0, static_cast<int>(data.size()));
  lcm::LogEvent event{};
  event.eventnum = 0;  // numbered by LCM
  // In receive-time order with the messages around it (its own clock is in the message).
  event.timestamp = raw_last_utime_ > 0 ? raw_last_utime_ : now_utime;
  event.channel = pass_channel_;
  event.datalen = static_cast<int32_t>(data.size());
  event.data = data.data();
  if (raw_file_->writeEvent(&event) != 0) {
    std::lock_guard<std::mutex> stats_lock(mutex_);
    if (stats_.error.empty()) stats_.error = "--raw " + raw_path_ + ": write failed (disk full?)";
  }
}

void LoggerNode::AdvanceTo(int64_t now_utime, int64_t taken) {
  if (!options_.replay) throw std::logic_error("LoggerNode::AdvanceTo: not a replay");
  std::vector<Input> batch;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    // The queue holds the messages handed over since the last pass, in order (a replay drops
    // none: its passes come at least as often as the live ones did).
    const int64_t want = taken < 0 ? handed_ : std::min(taken, handed_);
    const auto count = static_cast<size_t>(
        std::clamp<int64_t>(want - taken_, 0, static_cast<int64_t>(queue_.size())));
    batch.assign(std::make_move_iterator(queue_.begin()),
                 std::make_move_iterator(queue_.begin() + static_cast<std::ptrdiff_t>(count)));
    queue_.erase(queue_.begin(), queue_.begin() + static_cast<std::ptrdiff_t>(count));
    taken_ = std::max(taken_, want);
  }
  ProcessBatch(batch, now_utime, false);
}

bool LoggerNode::ProcessBatch(std::vector<Input>& batch, int64_t now_utime, bool stopping) {
  const bool had_input = !batch.empty();
  const int64_t quiet_before = quiet_taken_;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    for (size_t s = 0; s < kNumStreams; ++s) {
      carry_[s] += overflow_[s];
      overflow_[s] = 0;
    }
  }
  // The aligner's clock is the receive time of the newest message taken, not the wall clock: the
  // rows then depend on the messages and their receive times only, so a replay of the raw log
  // writes the same rows, and a bus thread that lags behind under load does not make every
  // stream look idle. Rows are taken once per pass (every flush period), so a plan's status
  // that arrives a few ms after its first set-point still starts that plan's file. When the
  // whole bus has been quiet for kQuietUs (wall clock live, receive times in a replay), the clock
  // moves on by that much, so the last rows reach the file.
  std::string error;
  auto take = [&](int64_t clock_utime, bool final_flush) {
    if (write_failed_) return;
    try {
      aligner_.TakeRows(clock_utime, final_flush, [this](const Row& row) { WriteRow(row); });
    } catch (const std::exception& e) {
      write_failed_ = true;
      error = e.what();
      file_.reset();
    }
  };
  auto quiet = [&](int64_t at_utime) {
    if (bus_now_ > 0 && at_utime >= bus_now_ + kQuietUs && quiet_taken_ != bus_now_) {
      quiet_taken_ = bus_now_;
      take(bus_now_ + kQuietUs, false);
    }
  };
  for (Input& input : batch) {
    std::visit([&](const auto& in) { quiet(in.recv_utime); }, input);
    if (auto* sample = std::get_if<Sample>(&input)) {
      int64_t& pending = carry_[static_cast<size_t>(sample->stream)];
      sample->lost_before += pending;
      pending = 0;
      bus_now_ = std::max(bus_now_, sample->recv_utime);
      aligner_.Add(std::move(*sample));
    } else if (auto* status = std::get_if<PlanStatus>(&input)) {
      last_mode_ = status->mode;
      bus_now_ = std::max(bus_now_, status->recv_utime);
      aligner_.AddStatus(*status);
    } else if (auto* gains = std::get_if<GainsRecord>(&input)) {
      NoteGains(*gains);
    }
  }
  batch.clear();
  quiet(now_utime);
  take(bus_now_, stopping);
  if (!write_failed_) {
    try {
      if (file_) file_->Flush();
      if (stopping) {
        stopping_ = true;
        CloseFile();
      }
    } catch (const std::exception& e) {
      write_failed_ = true;
      error = e.what();
      file_.reset();
    }
  }
  std::lock_guard<std::mutex> lock(mutex_);
  stats_.samples = aligner_.samples();
  stats_.lost = aligner_.lost_total();
  for (size_t s = 0; s < kNumStreams; ++s) stats_.lost[s] += carry_[s];
  if (!error.empty()) stats_.error = error;
  // A pass with no message and no quiet step takes the rows a pass at the same bus clock took.
  return had_input || quiet_taken_ != quiet_before || stopping;
}

void LoggerNode::OpenRawLog() {
  namespace fs = std::filesystem;
  fs::path path(options_.raw_log);
  std::error_code error;
  if (path.has_parent_path()) fs::create_directories(path.parent_path(), error);
  // Never replace a file: a restarted logger with the same command line goes on in NAME.1.EXT.
  for (int k = 1; fs::exists(path); ++k) {
    const fs::path original(options_.raw_log);
    path = original.parent_path() /
           (original.stem().string() + "." + std::to_string(k) + original.extension().string());
  }
  raw_file_ = std::make_unique<lcm::LogFile>(path.string(), "w");
  if (!raw_file_->good()) {
    raw_file_.reset();
    throw std::runtime_error("--raw " + path.string() + ": cannot create the file" +
                             (error ? ": " + error.message() : ""));
  }
  raw_path_ = path.string();
  // Every channel, whatever its prefix.
  raw_subscription_ =
      lcm_subscribe(bus_.raw_lcm().getUnderlyingLCM(), ".*", &LoggerNode::RecordRaw, this);
  if (raw_subscription_ == nullptr) throw std::runtime_error("--raw: LCM refused the subscription");
  // No limit of its own: it must not drop what the logger's own subscriptions keep.
  lcm_subscription_set_queue_capacity(raw_subscription_, 0);
  // LCM's socket keeps every per-tick channel for it, except those the tick feed takes over.
  bus_.NoteRawSubscription(".*");
  raw_flushed_ = std::chrono::steady_clock::now();
}

// Bus thread: called by LCM in the same dispatch as the logger's own handler of the message, so
// the log holds the messages in the order, and with the receive times, the logger aligned them.
void LoggerNode::RecordRaw(const lcm_recv_buf_t* rbuf, const char* channel, void* node) {
  auto* self = static_cast<LoggerNode*>(node);
  // Passes are this logger's own; another logger's (a log played back onto the bus) are not.
  if (self->pass_channel_ == channel || !self->Live(rbuf->recv_utime)) return;
  self->RecordRawEvent(channel, rbuf->data, static_cast<int>(rbuf->data_size), rbuf->recv_utime);
}

void LoggerNode::RecordRawEvent(const char* channel, const void* data, int size,
                                int64_t recv_utime) {
  std::lock_guard<std::mutex> lock(raw_mutex_);
  if (!raw_file_) return;
  raw_last_utime_ = recv_utime;
  lcm::LogEvent event{};
  event.eventnum = 0;  // numbered by LCM
  event.timestamp = recv_utime;
  event.channel = channel;
  event.datalen = static_cast<int32_t>(size);
  event.data = const_cast<void*>(data);
  if (raw_file_->writeEvent(&event) != 0) {
    std::lock_guard<std::mutex> stats_lock(mutex_);
    if (stats_.error.empty()) stats_.error = "--raw " + raw_path_ + ": write failed (disk full?)";
  }
}

void LoggerNode::NoteGains(const GainsRecord& gains) {
  const auto s = static_cast<size_t>(gains.source);
  if (gains.source == GainsSource::kRequest) {
    gains_ = gains;  // for the headers
    have_gains_ = true;
  }
  std::string change;
  if (!last_gains_[s]) {
    change = "first heard: " + DescribeGains(gains);
  } else {
    change = DescribeGainsChange(*last_gains_[s], gains);
    if (change.empty()) return;  // a repeat
  }
  last_gains_[s] = gains;
  const core::Channels& c = options_.channels;
  const std::string& channel = gains.source == GainsSource::kRequest      ? c.arm_gains
                               : gains.source == GainsSource::kController ? c.controller_gains
                                                                          : c.real_arm_gains;
  const std::optional<int64_t> at = aligner_.AxisTimeAtWall(gains.recv_utime);
  PendingNote note;
  note.time_us = at.value_or(INT64_MIN);
  note.text = "gains: time_s " + (at ? Seconds(*at) : std::string("-")) + ", wall " +
              WallTimeText(gains.recv_utime) + ": " + bus_.prefix() + channel + " (" +
              GainsSourceTitle(gains.source) + ") " + change;
  notes_.push_back(std::move(note));
}

void LoggerNode::WriteNotes(int64_t up_to_us) {
  while (file_ && !notes_.empty() && notes_.front().time_us <= up_to_us) {
    file_->AppendComment(notes_.front().text);
    notes_.pop_front();
  }
}

void LoggerNode::WriteRow(const Row& row) {
  const int plan = options_.split_per_plan ? row.plan_run : 0;
  if (!file_ || row.run != file_run_ || plan != file_plan_) {
    CloseFile();
    if (row.run != file_run_) run_rate_.Reset();  // a restarted sim: a new clock
    file_run_ = row.run;
    file_plan_ = plan;
    OpenFile(row);
  }
  WriteNotes(row.time_us);  // gain changes in time order among the rows
  file_->Append(row);
  // The real-time factor: the virtual arm's sim time against when its states arrived.
  const auto v = static_cast<size_t>(Stream::kVirtual);
  const Sample* virt = row.cell[v];
  if (virt != nullptr && row.age_us[v] == 0 && virt->recv_utime > 0) {
    run_rate_.Add(virt->utime, virt->recv_utime);
    file_rate_.Add(virt->utime, virt->recv_utime);
    if (file_rate_.known() && virt->recv_utime - last_factor_line_us_ >= kFactorLineUs) {
      file_->AppendComment("real-time factor: " + file_rate_.Describe() + ", this file so far");
      last_factor_line_us_ = virt->recv_utime;
    }
  }
  std::lock_guard<std::mutex> lock(mutex_);
  ++stats_.rows;
}

std::string LoggerNode::FreeStem(const std::string& stem, bool continuation) const {
  namespace fs = std::filesystem;
  const fs::path dir(options_.out_dir);
  if (!continuation && !fs::exists(dir / (stem + ".csv"))) return stem;
  for (int k = 1;; ++k) {
    const std::string candidate = stem + "." + std::to_string(k);
    if (!fs::exists(dir / (candidate + ".csv"))) return candidate;
  }
}

void LoggerNode::OpenFile(const Row& row) {
  // The first file of a restarted logger continues the earlier logger's newest file when it holds
  // the same movement set (or the same run, unsplit): NAME-03-set2.csv -> NAME-03-set2.1.csv.
  // Otherwise numbering goes on after the earlier files. A name already taken gets the next free
  // continuation suffix: no file is ever replaced.
  const bool first = !restart_.continued;
  restart_.continued = true;
  std::string file_name = options_.name;
  const std::string label =
      PlanLabel(aligner_.plan_runs()[static_cast<size_t>(row.plan_run)].plan_name);
  bool continuation = false;
  if (options_.split_per_plan) {
    const std::string& previous = restart_.previous_stem;
    const std::string& name = options_.name;
    continuation = first && previous.size() == name.size() + 4 + label.size() &&
                   previous.compare(0, name.size(), name) == 0 &&
                   previous.compare(name.size() + 3, std::string::npos, "-" + label) == 0;
    if (!continuation) ++file_count_;
    char number[16];
    std::snprintf(number, sizeof number, "-%02d-", file_count_);
    file_name = continuation ? previous : file_name + number + label;
  } else if (first && !restart_.previous_stem.empty()) {
    continuation = true;
    file_name = restart_.previous_stem;
  } else if (row.run > 0 || restart_.last_run > 0) {
    file_name += "-r" + std::to_string(restart_.last_run + row.run);
  }
  file_name = FreeStem(file_name, continuation);
  const std::string path =
      (std::filesystem::path(options_.out_dir) / (file_name + ".csv")).string();
  std::vector<std::string> header = HeaderLines(row);
  header.push_back("real-time factor so far: " + run_rate_.Describe() +
                   ", sim time over wall time since the logger first heard the sim");
  file_rate_.Reset();
  last_factor_line_us_ = 0;
  for (int source = 0; source < kNumGainsSources; ++source) {
    const std::optional<GainsRecord>& gains = last_gains_[static_cast<size_t>(source)];
    if (gains) {
      header.push_back(std::string("gains now, ") +
                       GainsSourceTitle(static_cast<GainsSource>(source)) + ": " +
                       DescribeGains(*gains));
    }
  }
  if (aligner_.plan_runs()[static_cast<size_t>(row.plan_run)].joined) {
    header.push_back("plan run: under way when the logger started; its start is not in this file");
  }
  if (!restart_.previous_file.empty()) {
    header.push_back("restart: this logger started with data files of " + options_.name +
                     " already in " + options_.out_dir +
                     " (a restart); it continues that run in new files and never replaces one");
    if (continuation) {
      header.push_back(
          "continues: " + std::filesystem::path(restart_.previous_file).filename().string() +
          " (the rows between its last one and this file's first were not logged)");
    }
  }
  file_ = std::make_unique<DataFileWriter>(path, header, layout_);
  std::lock_guard<std::mutex> lock(mutex_);
  stats_.files.push_back(path);
  file_real_arm_notes_ = real_arm_notes_.size();
}

void LoggerNode::CloseFile() {
  if (!file_) return;
  if (stopping_) WriteNotes(INT64_MAX);  // the last file takes what is left
  file_->AppendComment("real-time factor: " +
                       (file_rate_.known() ? file_rate_.Describe() + ", this file"
                                           : std::string("not known (under 0.1 s of sim states "
                                                         "in this file)")));
  file_->Close(EndLine());
  file_.reset();
}

std::vector<std::string> LoggerNode::HeaderLines(const Row& row) const {
  const PlanRun& run = aligner_.plan_runs()[static_cast<size_t>(row.plan_run)];
  std::vector<std::string> lines;
  lines.push_back("model: " + model_.name + " (" + model_.source_file + ", fnv1a " +
                  model_.source_hash + ")");
  std::string joints = std::to_string(layout_.joints.size()) + ":";
  for (size_t j = 0; j < layout_.joints.size(); ++j) {
    joints += std::string(j ? ";" : "") + " j" + std::to_string(j + 1) + " " +
              HeaderWord(layout_.joints[j].name) + " " + layout_.joints[j].unit();
  }
  lines.push_back("joints: " + joints);
  lines.push_back("plan: " + (run.plan_name.empty() ? std::string("(none)") : run.plan_name));
  const int8_t mode = run.plan_name.empty() ? last_mode_ : run.mode;
  const int sources = aligner_.real_sources();
  std::string real = "none heard yet";
  if (sources != 0) {
    real.clear();
    if (sources & (1 << sirupp::arm_state_t::SOURCE_REAL)) real += "real";
    if (sources & (1 << sirupp::arm_state_t::SOURCE_EMULATED))
      real += real.empty() ? "emulated" : ", emulated";
    if (sources & (1 << sirupp::arm_state_t::SOURCE_SIM)) real += real.empty() ? "sim" : ", sim";
  }
  lines.push_back(std::string("mode: controller ") +
                  (mode == sirupp::controller_status_t::MODE_AUTOMATIC ? "automatic"
                   : mode == sirupp::controller_status_t::MODE_MANUAL  ? "manual"
                                                                       : "unknown") +
                  "; real arm: " + real);
  std::vector<double> kp, kd, ki;
  for (const core::Joint& joint : model_.joints) {
    kp.push_back(joint.servo.kp);
    kd.push_back(joint.servo.kd);
    ki.push_back(joint.servo.ki);
  }
  lines.push_back(std::string("gains (chip units, ") +
                  (have_gains_ ? "last ARM_GAINS" : "the model's; no ARM_GAINS heard") + "): kp " +
                  JoinNumbers(have_gains_ ? gains_.kp : kp) + "; kd " +
                  JoinNumbers(have_gains_ ? gains_.kd : kd) + "; ki " +
                  JoinNumbers(have_gains_ ? gains_.ki : ki));
  const std::string prefix = bus_.prefix();
  const core::Channels& c = options_.channels;
  lines.push_back("channels: set " + prefix + c.arm_setpoint + ", virt " + prefix +
                  c.sim_arm_state + ", real " + prefix + c.real_arm_state + ", plans " + prefix +
                  c.controller_status + ", gains " + prefix + c.arm_gains + "; LCM URL " +
                  url_text_);
  const AlignerOptions& a = aligner_.options();
  lines.push_back("sample clock: a row every " + std::to_string(a.period_us) +
                  " us of time_s; a cell holds its stream's newest sample at or before the row "
                  "time if younger than " +
                  std::to_string(a.max_age_us) + " us, else it stays empty");
  lines.push_back(
      "time: time_s is sim time in s (the set-point's and the virtual arm's utime); real-arm "
      "samples on the wall clock are moved onto it by the sim clock's offset (docs/logging.md)");
  lines.push_back(
      "units: positions in deg (mm for prismatic joints); jN_done 1 = the joint's set-point "
      "profile has finished; *_lost = messages missing so far (sequence gaps, logger overflow); "
      "*_age_us = how old the cell's sample is at the row time (a real arm polled at 100 Hz "
      "repeats each sample until the next); real_clock_us = the real cell's sample's own stamp "
      "(us on the real arm's clock, the wall clock for a real or emulated arm); set_recv_us = when "
      "the logger received the row's set-point sample (us, wall clock)");
  std::string config;
  for (const std::string& line : lines) config += line + "\n";
  lines.push_back("config hash: fnv1a " + core::Fnv1aHex(config) + " (of the lines above)");
  lines.push_back("started: logger " + started_text_ + " (wall clock); this file from time_s " +
                  Seconds(row.time_us));
  if (!options_.note.empty()) lines.push_back("note: " + options_.note);
  return lines;
}

std::string LoggerNode::EndLine() const {
  const auto& lost = aligner_.lost_total();
  const auto& samples = aligner_.samples();
  std::string text = std::to_string(file_->rows()) + " rows, time_s " +
                     core::FormatApprox(file_->first_time_s()) + " to " +
                     core::FormatApprox(file_->last_time_s()) + "; run so far: messages";
  for (Stream s : kAllStreams) {
    text += std::string(" ") + StreamKey(s) + " " + std::to_string(samples[static_cast<size_t>(s)]);
  }
  text += ", lost";
  for (Stream s : kAllStreams) {
    text += std::string(" ") + StreamKey(s) + " " + std::to_string(lost[static_cast<size_t>(s)]);
  }
  text += " (sequence gaps and logger overflow)";
  // Only when there were any, so that a file is the same whether or not the logger had a socket
  // of its own (a replay has none).
  int64_t dropped = 0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    dropped = stats_.kernel_dropped;
  }
  if (dropped > 0) {
    text += "; " + std::to_string(dropped) +
            " per-tick datagrams dropped by the kernel (its buffer was full), counted in the gaps";
  }
  // The real arm's half lost during this file (or before it and not back): its real columns
  // after that repeat the last sample heard.
  std::lock_guard<std::mutex> lock(mutex_);
  for (size_t i = file_real_arm_notes_; i < real_arm_notes_.size(); ++i) {
    text += "; " + real_arm_notes_[i];
  }
  if (file_real_arm_notes_ == real_arm_notes_.size() && real_arm_lost_now_) {
    text += "; still lost: " + real_arm_notes_.back();
  }
  return text;
}

namespace {

// The writer's passes recorded in a raw log (LOGGER_PASS), in order; empty for a log without them.
std::vector<core::LoggerPass> RecordedPasses(const std::string& log_path,
                                             const std::string& pass_channel) {
  std::vector<core::LoggerPass> passes;
  LcmLogReader reader(log_path);
  LcmLogEvent event;
  while (reader.Next(event)) {
    if (event.channel != pass_channel) continue;
    passes.push_back(DecodePassEvent(log_path, event));
    if (passes.size() >= 2 && passes.back().taken < passes[passes.size() - 2].taken) {
      throw PassEventError(
          log_path, event,
          "taken " + std::to_string(passes.back().taken) + " is below the pass before it (" +
              std::to_string(passes[passes.size() - 2].taken) + "): passes of two loggers?");
    }
  }
  return passes;
}

}  // namespace

LoggerStats ReplayRawLog(const std::string& log_path, const core::RobotModel& model,
                         LoggerOptions options, const std::string& prefix) {
  options.replay = true;
  options.raw_log.clear();
  core::Bus bus("memq://", prefix);
  const std::string pass_channel = bus.prefix() + options.channels.logger_pass.name();
  const std::vector<core::LoggerPass> passes = RecordedPasses(log_path, pass_channel);
  if (options.name.empty() && !passes.empty()) options.name = passes.front().name;
  LoggerNode node(bus, model, options);
  if (!passes.empty()) node.UseRecordedStart(passes.front().started_utime, passes.front().lcm_url);
  const auto period = static_cast<int64_t>(options.flush_period_ms) * 1000;
  LcmLogReader reader(log_path);
  LcmLogEvent event;
  bool started = false;
  int64_t next_pass = 0;
  size_t pass = 0;
  std::optional<int64_t> last_pass_utime;  // the live logger's last pass, before it closed
  // The recorded passes whose messages have all been delivered, each as it ran live.
  auto run_passes = [&] {
    while (pass < passes.size() && !last_pass_utime && passes[pass].taken <= node.handed()) {
      if (passes[pass].last) {
        last_pass_utime = passes[pass].utime;
      } else {
        node.AdvanceTo(passes[pass].utime, passes[pass].taken);
      }
      ++pass;
    }
  };
  while (reader.Next(event)) {
    if (event.channel == pass_channel) continue;  // read above
    if (passes.empty()) {
      // No recorded passes: one every flush period of the log's clock (the quiet stretches
      // included), as a live writer would run.
      if (!started) {
        started = true;
        next_pass = event.timestamp_us + period;
      }
      while (event.timestamp_us >= next_pass) {
        node.AdvanceTo(next_pass);
        next_pass += period;
      }
    } else {
      run_passes();
    }
    bus.DeliverRecorded(event.channel, event.data.data(), static_cast<int>(event.data.size()),
                        event.timestamp_us);
  }
  run_passes();
  node.Finish(last_pass_utime.value_or(0));
  for (const std::string& note : reader.notes()) {
    std::cerr << options.process_name << ": " << log_path << ": " << note << "\n";
  }
  if (pass < passes.size()) {
    std::cerr << options.process_name << ": " << log_path << ": " << passes.size() - pass
              << " recorded writer passes took more messages than the log holds (" << node.handed()
              << "): the last rows may differ from the live ones\n";
  }
  return node.stats();
}

}  // namespace sirupp::logger
