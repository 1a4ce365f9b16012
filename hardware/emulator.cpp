#include "hardware/emulator.hpp"

#include <poll.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <ctime>
#include <iostream>
#include <stdexcept>

#include "core/errors.hpp"

namespace sirupp::hardware {
namespace {

ArmOptions MakeArmOptions(const EmulatorOptions& options) {
  ArmOptions arm;
  arm.friction_scale = options.friction_scale;
  arm.start_positions = options.start_positions;
  arm.substeps = options.substeps;
  arm.brakes = options.brakes;
  arm.effects = options.effects;
  return arm;
}

// "0.401 s": to the millisecond.
std::string Seconds(double s) {
  char text[32];
  std::snprintf(text, sizeof text, "%.3f s", s);
  return text;
}

int ModuleCount(const EmulatorOptions& options) {
  const int n = options.modules == 0 ? options.model.num_joints() : options.modules;
  if (n < 1 || n > nmc::kMaxModules) {
    throw std::invalid_argument("modules " + std::to_string(n) + ": allowed 1.." +
                                std::to_string(nmc::kMaxModules) + " (0 = one per joint)");
  }
  return n;
}

}  // namespace

void Emulator::CheckRate(double p, const char* what) {
  if (!(p >= 0 && p <= 1)) {
    throw std::invalid_argument(std::string(what) + " " + core::FormatNumber(p) +
                                ": allowed a probability 0..1");
  }
}

Emulator::Emulator(EmulatorOptions options)
    : options_(std::move(options)),
      tick_s_(options_.model.servo_tick_s),
      epoch_(std::chrono::steady_clock::now()),
      modules_(static_cast<size_t>(ModuleCount(options_))),
      silent_(modules_.size(), false),
      arm_(options_.model, MakeArmOptions(options_)),
      pwm_(modules_.size(), 0),
      checksum_error_rate_(options_.checksum_error_rate),
      drop_rate_(options_.drop_rate),
      rng_(options_.seed) {
  CheckRate(checksum_error_rate_, "checksum error rate");
  CheckRate(drop_rate_, "drop rate");
  if (!(options_.max_catch_up_s >= 0)) {
    throw std::invalid_argument("catch-up bound " + core::FormatNumber(options_.max_catch_up_s) +
                                " s: allowed >= 0");
  }
  if (!(options_.inter_byte_timeout_s > 0)) {
    throw std::invalid_argument("inter-byte timeout " +
                                core::FormatNumber(options_.inter_byte_timeout_s) +
                                " s: allowed > 0");
  }
  if (options_.effects) {
    const int latency =
        static_cast<int>(std::lround(options_.effects->command_latency_s / tick_s_));
    for (PicServoModule& module : modules_) module.SetCommandLatencyTicks(latency);
  }
  for (int k : options_.silent_modules) {
    CheckModule(k, "silent module");
    silent_[static_cast<size_t>(k)] = true;
  }
  if (!options_.socket.empty()) {
    if (!options_.link.empty()) {
      throw std::invalid_argument("link " + options_.link + " and socket " + options_.socket +
                                  ": allowed one of them");
    }
    socket_ = std::make_unique<SocketLine>(options_.socket);
    device_ = options_.socket;
    return;
  }
  if (!options_.link.empty()) pty_.LinkTo(options_.link);
  device_ = options_.link.empty() ? pty_.slave_path() : options_.link;
}

Emulator::~Emulator() { Stop(); }

void Emulator::CheckModule(int module_index, const char* what) const {
  if (module_index < 0 || module_index >= num_modules()) {
    throw std::invalid_argument(std::string(what) + " " + std::to_string(module_index) +
                                ": allowed 0.." + std::to_string(num_modules() - 1));
  }
}

const std::string& Emulator::device() const { return device_; }

void Emulator::Start() {
  if (thread_.joinable()) return;
  stop_ = false;
  {
    // Emulated time carries on from where it stood: tick k + 1 is due one tick from now.
    std::lock_guard<std::mutex> lock(mutex_);
    clock_base_s_ = Now() - static_cast<double>(tick_index_) * tick_s_;
  }
  thread_ = std::thread([this] { Run(); });
}

void Emulator::Stop() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
}

double Emulator::Now() const {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - epoch_).count();
}

std::vector<double> Emulator::JointPositions() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return arm_.positions();
}

std::vector<int> Emulator::Pwm() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return pwm_;
}

nmc::Status Emulator::ModuleStatus(int module_index) const {
  CheckModule(module_index, "module");
  std::lock_guard<std::mutex> lock(mutex_);
  return modules_[static_cast<size_t>(module_index)].StatusNow();
}

nmc::Gains Emulator::ModuleGains(int module_index) const {
  CheckModule(module_index, "module");
  std::lock_guard<std::mutex> lock(mutex_);
  return modules_[static_cast<size_t>(module_index)].gains();
}

void Emulator::SetChecksumErrorRate(double p) {
  CheckRate(p, "checksum error rate");
  std::lock_guard<std::mutex> lock(mutex_);
  checksum_error_rate_ = p;
}

void Emulator::SetDropRate(double p) {
  CheckRate(p, "drop rate");
  std::lock_guard<std::mutex> lock(mutex_);
  drop_rate_ = p;
}

void Emulator::SetSilent(int module_index, bool silent) {
  CheckModule(module_index, "silent module");
  std::lock_guard<std::mutex> lock(mutex_);
  silent_[static_cast<size_t>(module_index)] = silent;
}

void Emulator::TriggerOvercurrent(int module_index) {
  CheckModule(module_index, "overcurrent module");
  std::lock_guard<std::mutex> lock(mutex_);
  modules_[static_cast<size_t>(module_index)].TriggerOvercurrent();
}

void Emulator::TriggerPositionErrorTrip(int module_index) {
  CheckModule(module_index, "position-error module");
  std::lock_guard<std::mutex> lock(mutex_);
  modules_[static_cast<size_t>(module_index)].TriggerPositionErrorTrip();
}

EmulatorCounters Emulator::counters() const {
  std::lock_guard<std::mutex> lock(mutex_);
  EmulatorCounters c = counters_;
  c.bytes_skipped = reader_.skipped_bytes();
  return c;
}

void Emulator::TickOnce() {
  const int joints = arm_.num_joints();
  for (size_t k = 0; k < modules_.size(); ++k) {
    const int j = static_cast<int>(k);
    const MotorInputs inputs = j < joints ? arm_.Inputs(j) : MotorInputs{};
    pwm_[k] = modules_[k].Tick(inputs);
  }
  std::vector<int> joint_pwm(static_cast<size_t>(joints), 0);
  std::vector<bool> brakes(static_cast<size_t>(joints), true);  // no module: no amplifier
  for (int j = 0; j < joints && j < num_modules(); ++j) {
    const auto u = static_cast<size_t>(j);
    joint_pwm[u] = pwm_[u];
    brakes[u] = !modules_[u].amp_enabled();
  }
  arm_.SetBrakes(brakes);
  arm_.Step(joint_pwm);
  ++counters_.servo_ticks;
}

void Emulator::Receive(const uint8_t* bytes, size_t n, double now_s) {
  const double byte_s = options_.line_timing ? ByteSeconds(counters_.baud) : 0.0;
  if (reader_.in_packet() && last_byte_s_ >= 0 &&
      now_s - last_byte_s_ > options_.inter_byte_timeout_s) {
    reader_.Reset();
    ++counters_.packet_timeouts;
  }
  last_byte_s_ = now_s;
  for (size_t i = 0; i < n; ++i) {
    ++counters_.bytes_received;
    // The byte is fully on the line one byte time after the line is free and it was sent.
    rx_free_s_ = std::max(rx_free_s_, now_s) + byte_s;
    const std::optional<nmc::PacketReader::Result> result = reader_.Feed(bytes[i]);
    if (result) Process(*result, rx_free_s_);
  }
}

void Emulator::Process(const nmc::PacketReader::Result& result, double arrival_s) {
  ++counters_.commands_received;
  bool checksum_ok = result.checksum_ok;
  if (checksum_ok && checksum_error_rate_ > 0 &&
      std::uniform_real_distribution<double>(0, 1)(rng_) < checksum_error_rate_) {
    checksum_ok = false;
  }
  if (!checksum_ok) ++counters_.checksum_errors;
  // Every module sees the chain as it was before this packet.
  std::vector<bool> addr_in(modules_.size());
  for (size_t k = 0; k < modules_.size(); ++k) addr_in[k] = k == 0 || modules_[k - 1].addr_out();
  int new_baud = 0;
  for (size_t k = 0; k < modules_.size(); ++k) {
    if (silent_[k]) continue;
    PicServoModule::Result r = modules_[k].Handle(result.packet, checksum_ok, addr_in[k]);
    if (r.new_baud != 0) new_baud = r.new_baud;
    if (r.reply.empty()) continue;
    const double byte_s = options_.line_timing ? ByteSeconds(counters_.baud) : 0.0;
    const double start = std::max(arrival_s, tx_free_s_);
    tx_free_s_ = start + byte_s * static_cast<double>(r.reply.size());
    replies_.push_back({tx_free_s_, std::move(r.reply)});
  }
  if (new_baud != 0 && new_baud != counters_.baud) {
    counters_.baud = new_baud;
    ++counters_.baud_changes;
  }
}

int Emulator::LineFd() const { return socket_ ? socket_->client_fd() : pty_.master_fd(); }

void Emulator::AcceptClient() {
  if (socket_ && socket_->Accept()) {
    ++counters_.connections;
    reader_.Reset();  // a new client starts a new conversation
    replies_.clear();
  }
}

ssize_t Emulator::ReadLine(uint8_t* buffer, size_t size) {
  const int fd = LineFd();
  if (fd < 0) return 0;
  const ssize_t r = ::read(fd, buffer, size);
  if (r == 0 && socket_) {  // the client closed its end: wait for the next one
    socket_->Drop();
    reader_.Reset();
    replies_.clear();
  }
  return r;
}

void Emulator::WriteLine(const uint8_t* bytes, size_t n) {
  if (socket_) {
    if (socket_->client_fd() >= 0 && !socket_->Send(bytes, n)) socket_->Drop();
    return;
  }
  size_t done = 0;
  while (done < n) {
    const ssize_t w = ::write(pty_.master_fd(), bytes + done, n - done);
    if (w <= 0) break;  // nobody reads and the pty is full: the rest is lost, as on a line
    done += static_cast<size_t>(w);
  }
}

void Emulator::FlushReplies(double now_s) {
  size_t sent = 0;
  for (; sent < replies_.size() && replies_[sent].write_time_s <= now_s; ++sent) {
    std::vector<uint8_t> out;
    for (uint8_t b : replies_[sent].bytes) {
      if (drop_rate_ > 0 && std::uniform_real_distribution<double>(0, 1)(rng_) < drop_rate_) {
        ++counters_.bytes_dropped;
      } else {
        out.push_back(b);
      }
    }
    WriteLine(out.data(), out.size());
    ++counters_.replies_sent;
  }
  replies_.erase(replies_.begin(), replies_.begin() + static_cast<std::ptrdiff_t>(sent));
}

void Emulator::CatchUp(double now_s) {
  double due_s = NextTickDue();
  if (due_s > now_s) return;
  const double behind_s = now_s - due_s;
  counters_.max_lateness_s = std::max(counters_.max_lateness_s, behind_s);
  if (behind_s > options_.max_catch_up_s) {
    // Too far behind to catch up: every tick due by now is slipped, none is stepped or stretched.
    const auto slipped = static_cast<uint64_t>(std::floor((now_s - due_s) / tick_s_)) + 1;
    tick_index_ += slipped;
    counters_.ticks_slipped += slipped;
    ++counters_.slips;
    const std::string line =
        "emulated time slipped " + Seconds(static_cast<double>(slipped) * tick_s_) + " (" +
        std::to_string(slipped) + " servo ticks not stepped): the emulator was " +
        Seconds(behind_s) + " behind the wall clock, more than the " +
        core::FormatNumber(options_.max_catch_up_s) +
        " s it catches up; the emulated arm paused for that long (slip " +
        std::to_string(counters_.slips) + ", " + std::to_string(counters_.ticks_slipped) +
        " ticks slipped in all)";
    if (options_.report) {
      options_.report(line);
    } else {
      std::cerr << "sirupp-picservo-emu: " << line << std::endl;
    }
    return;
  }
  for (; due_s <= now_s; due_s = NextTickDue()) {
    if (now_s - due_s > tick_s_) ++counters_.ticks_caught_up;
    TickOnce();
    ++tick_index_;
  }
}

void Emulator::ServiceAt(double now_s) {
  uint8_t buffer[256];
  std::lock_guard<std::mutex> lock(mutex_);
  CatchUp(now_s);
  AcceptClient();
  for (;;) {
    const ssize_t r = ReadLine(buffer, sizeof buffer);
    if (r <= 0) break;
    Receive(buffer, static_cast<size_t>(r), now_s);
  }
  FlushReplies(now_s);
}

void Emulator::Run() {
  uint8_t buffer[256];
  while (!stop_) {
    double wake_s = 0;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      const double now_s = Now();
      CatchUp(now_s);
      FlushReplies(now_s);
      wake_s = NextTickDue();
      if (!replies_.empty()) wake_s = std::min(wake_s, replies_.front().write_time_s);
    }
    const double wait_s = std::max(0.0, wake_s - Now());
    timespec timeout{};
    timeout.tv_sec = static_cast<time_t>(wait_s);
    timeout.tv_nsec = static_cast<long>((wait_s - static_cast<double>(timeout.tv_sec)) * 1e9);
    // Only this thread changes the line's descriptors (AcceptClient, ReadLine). On a socket line
    // the listening socket is watched too: a client that comes while one is served is closed.
    const int line = LineFd();
    pollfd p[2] = {{line, POLLIN, 0}, {socket_ ? socket_->listen_fd() : -1, POLLIN, 0}};
    const int ready = ::ppoll(p, 2, &timeout, nullptr);
    if (ready > 0 && (p[1].revents & POLLIN)) {
      std::lock_guard<std::mutex> lock(mutex_);
      AcceptClient();
    }
    if (ready > 0 && line >= 0 && (p[0].revents & (POLLIN | POLLHUP))) {
      std::lock_guard<std::mutex> lock(mutex_);
      const ssize_t r = ReadLine(buffer, sizeof buffer);
      if (r > 0) {
        const double now_s = Now();
        // The ticks due before the bytes were read come first: a command is applied at the
        // emulated time it arrived, even when the thread was descheduled before reading it.
        CatchUp(now_s);
        Receive(buffer, static_cast<size_t>(r), now_s);
      }
    }
  }
}

}  // namespace sirupp::hardware
