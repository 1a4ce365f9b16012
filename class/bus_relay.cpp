#include "class/bus_relay.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "class/rig_job.hpp"
#include "core/channels.hpp"

namespace sirupp::classroom {
namespace {

using Clock = std::chrono::steady_clock;

constexpr size_t kMaxQueued = 5000;  // frames waiting either way; the oldest go beyond it
constexpr auto kExchangePeriod = std::chrono::milliseconds(5);
constexpr auto kRetryAfterFailure = std::chrono::milliseconds(200);
constexpr int kListenBatchMs = 2;  // the tap wakes once per this, not once per tick

// Per-tick channels: only the newest message between two exchanges is carried.
bool PerTick(const std::string& channel) {
  const core::Channels c;
  return channel == c.sim_arm_state.name() || channel == c.arm_setpoint.name() ||
         channel == c.sim_arm_ticks.name();
}

void PutBig32(std::string& out, uint32_t value) {
  for (int shift = 24; shift >= 0; shift -= 8) out.push_back(static_cast<char>(value >> shift));
}

void Bounded(std::vector<RelayFrame>& frames, size_t* dropped = nullptr) {
  if (frames.size() <= kMaxQueued) return;
  const size_t extra = frames.size() - kMaxQueued;
  frames.erase(frames.begin(), frames.begin() + static_cast<std::ptrdiff_t>(extra));
  if (dropped != nullptr) *dropped += extra;
}

}  // namespace

const std::vector<std::string>& UpChannels() {
  static const std::vector<std::string> names = [] {
    const core::Channels c;
    return std::vector<std::string>{
        c.arm_move.name(),         c.arm_gains.name(),        c.controller_status.name(),
        c.robot_model.name(),      c.hardware_command.name(), c.estop.name(),
        c.controller_reply.name(), c.controller_gains.name(), c.sim_arm_state.name(),
        c.arm_setpoint.name(),     c.sim_arm_ticks.name()};
  }();
  return names;
}

const std::vector<std::string>& DownChannels() {
  static const std::vector<std::string> names = [] {
    const core::Channels c;
    return std::vector<std::string>{c.real_arm_state.name(), c.real_arm_setpoint.name(),
                                    c.real_arm_gains.name(), c.hardware_status.name(),
                                    c.hardware_reply.name(), c.heartbeat.name(),
                                    c.arm_target.name(),     c.arm_plan.name()};
  }();
  return names;
}

std::string EncodeFrames(const std::vector<RelayFrame>& frames) {
  std::string out;
  for (const RelayFrame& frame : frames) {
    if (frame.channel.empty() || frame.channel.size() > 255) {
      throw std::invalid_argument("a relayed channel name must be 1 to 255 bytes, not " +
                                  std::to_string(frame.channel.size()));
    }
    out.push_back(static_cast<char>(frame.channel.size()));
    out += frame.channel;
    PutBig32(out, static_cast<uint32_t>(frame.bytes.size()));
    out += frame.bytes;
  }
  return out;
}

std::vector<RelayFrame> DecodeFrames(const std::string& body) {
  std::vector<RelayFrame> frames;
  size_t at = 0;
  auto fail = [&](const std::string& what) {
    throw std::runtime_error("relay body of " + std::to_string(body.size()) +
                             " bytes is malformed at byte " + std::to_string(at) + ": " + what);
  };
  while (at < body.size()) {
    const size_t name_size = static_cast<unsigned char>(body[at]);
    if (name_size == 0) fail("an empty channel name");
    if (at + 1 + name_size + 4 > body.size()) fail("cut short in a frame's header");
    RelayFrame frame;
    frame.channel = body.substr(at + 1, name_size);
    at += 1 + name_size;
    uint32_t size = 0;
    for (int k = 0; k < 4; ++k) size = (size << 8) | static_cast<unsigned char>(body[at + k]);
    at += 4;
    if (size > body.size() - at) fail("a frame of " + std::to_string(size) + " bytes is cut short");
    frame.bytes = body.substr(at, size);
    at += size;
    frames.push_back(std::move(frame));
  }
  return frames;
}

// --- the node's side

RelayTap::RelayTap(std::string lcm_url) : url_(std::move(lcm_url)) {}

RelayTap::~RelayTap() {
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  if (listener_.joinable()) listener_.join();
}

void RelayTap::OnMessage(const lcm::ReceiveBuffer* rbuf, const std::string& channel,
                         RelayTap* self) {
  RelayFrame frame{channel, std::string(static_cast<const char*>(rbuf->data), rbuf->data_size)};
  const std::lock_guard<std::mutex> lock(self->mutex_);
  if (PerTick(channel)) {
    for (RelayFrame& held : self->up_) {
      if (held.channel == channel) {
        held.bytes = std::move(frame.bytes);
        return;
      }
    }
  }
  self->up_.push_back(std::move(frame));
  Bounded(self->up_, &self->dropped_);
}

void RelayTap::Listen() {
  std::unique_ptr<core::Bus> bus;
  std::vector<lcm::Subscription*> subscriptions;
  std::vector<std::string> noted;
  try {
    bus = std::make_unique<core::Bus>(url_, "");
    for (const std::string& name : UpChannels()) {
      const std::string full = bus->FullName(name);
      lcm::Subscription* s = bus->raw_lcm().subscribeFunction(full, &RelayTap::OnMessage, this);
      if (s == nullptr) throw std::runtime_error("cannot subscribe to " + full);
      // Per-tick: LCM drops the newest beyond the capacity, so room for a few batches.
      s->setQueueCapacity(PerTick(name) ? 30 : 1000);
      subscriptions.push_back(s);
      bus->NoteRawSubscription(full);  // a per-tick channel is not dropped by the bus's filter
      noted.push_back(full);
    }
  } catch (const std::exception& e) {
    const std::lock_guard<std::mutex> lock(mutex_);
    open_error_ = std::string("cannot listen on the rig's bus ") + url_ + ": " + e.what();
    listening_ = false;
    opened_.notify_all();
    return;
  }
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    bus_open_ = true;
    opened_.notify_all();
  }
  for (;;) {
    std::deque<RelayFrame> out;
    {
      const std::lock_guard<std::mutex> lock(mutex_);
      const double quiet_s = std::chrono::duration<double>(Clock::now() - last_exchange_).count();
      if (stopping_ || quiet_s > kTapIdleS) {
        up_.clear();
        down_.clear();
        bus_open_ = false;
        listening_ = false;
        break;
      }
      out.swap(down_);
    }
    for (const RelayFrame& frame : out) {
      bus->raw_lcm().publish(frame.channel, frame.bytes.data(),
                             static_cast<unsigned int>(frame.bytes.size()));
    }
    try {
      bus->HandleBatched(kListenBatchMs);
    } catch (const core::BusError&) {
      // An LCM error while waiting: tried again on the next round.
    }
  }
  for (lcm::Subscription* s : subscriptions) bus->raw_lcm().unsubscribe(s);
  for (const std::string& full : noted) bus->ForgetRawSubscription(full);
}

std::string RelayTap::Exchange(const std::string& down) {
  std::vector<RelayFrame> frames = DecodeFrames(down);
  for (const RelayFrame& frame : frames) {
    const std::vector<std::string>& allowed = DownChannels();
    if (std::find(allowed.begin(), allowed.end(), frame.channel) == allowed.end()) {
      throw std::invalid_argument("the relay does not carry '" + frame.channel +
                                  "' to a rig (it carries the bridge's channels and the "
                                  "handover's ARM_TARGET and ARM_PLAN only)");
    }
  }
  std::unique_lock<std::mutex> lock(mutex_);
  last_exchange_ = Clock::now();
  if (!listening_) {
    if (listener_.joinable()) {
      lock.unlock();
      listener_.join();  // an earlier listener that went idle (it ends by itself)
      lock.lock();
    }
    if (!listening_) {
      open_error_.clear();
      bus_open_ = false;
      listening_ = true;
      listener_ = std::thread([this] { Listen(); });
      opened_.wait_for(lock, std::chrono::seconds(5),
                       [this] { return bus_open_ || !open_error_.empty(); });
      if (!open_error_.empty()) throw std::runtime_error(open_error_);
    }
  }
  for (RelayFrame& frame : frames) down_.push_back(std::move(frame));
  while (down_.size() > kMaxQueued) down_.pop_front();
  std::vector<RelayFrame> up;
  up.swap(up_);
  lock.unlock();
  return EncodeFrames(up);
}

// --- the class server's side

RemoteRigBus::RemoteRigBus(std::string student, RigEndpoint endpoint)
    : student_(std::move(student)),
      endpoint_(std::move(endpoint)),
      bus_(std::make_shared<core::Bus>("memq://", "")) {
  for (const std::string& name : DownChannels()) {
    lcm::Subscription* s =
        bus_->raw_lcm().subscribeFunction(bus_->FullName(name), &RemoteRigBus::OnDown, this);
    if (s == nullptr) throw core::BusError("cannot subscribe to " + name + " on memq://");
    s->setQueueCapacity(1000);
    subscriptions_.push_back(s);
  }
  thread_ = std::thread([this] { Exchanges(); });
}

RemoteRigBus::~RemoteRigBus() {
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    closing_ = true;
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
  for (lcm::Subscription* s : subscriptions_) bus_->raw_lcm().unsubscribe(s);
}

void RemoteRigBus::OnDown(const lcm::ReceiveBuffer* rbuf, const std::string& channel,
                          RemoteRigBus* self) {
  const std::lock_guard<std::mutex> lock(self->mutex_);
  self->down_.push_back(
      RelayFrame{channel, std::string(static_cast<const char*>(rbuf->data), rbuf->data_size)});
  Bounded(self->down_);
}

void RemoteRigBus::Pump() {
  std::vector<RelayFrame> up;
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    up.swap(up_);
  }
  for (const RelayFrame& frame : up) {
    bus_->raw_lcm().publish(frame.channel, frame.bytes.data(),
                            static_cast<unsigned int>(frame.bytes.size()));
  }
}

void RemoteRigBus::Close() {
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    if (closing_) return;
  }
  bus_->HandleAvailable();  // what the manager published last reaches OnDown
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    closing_ = true;
  }
  wake_.notify_all();
}

bool RemoteRigBus::Finished() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  return finished_;
}

std::string RemoteRigBus::TakeNewError() {
  const std::lock_guard<std::mutex> lock(mutex_);
  if (error_told_) return "";
  error_told_ = true;
  return error_.empty() ? "relay to " + student_ + "'s rig at " + endpoint_.Address() + " works"
                        : error_;
}

std::string RemoteRigBus::RoundTrips() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  auto percentile = [this](double fraction) {
    const auto wanted = static_cast<int64_t>(std::ceil(fraction * static_cast<double>(exchanges_)));
    int64_t seen = 0;
    for (size_t bin = 0; bin < round_trip_bins_.size(); ++bin) {
      seen += round_trip_bins_[bin];
      if (seen >= wanted) return static_cast<double>(bin + 1) / 10;  // the bin's upper edge
    }
    return longest_ms_;
  };
  char text[160];
  std::snprintf(text, sizeof text,
                "%lld exchanges, round trip p50 %.1f ms, p95 %.1f ms, max %.1f ms",
                static_cast<long long>(exchanges_), exchanges_ > 0 ? percentile(0.5) : 0.0,
                exchanges_ > 0 ? percentile(0.95) : 0.0, longest_ms_);
  return text;
}

void RemoteRigBus::Exchanges() {
  httplib::Client client(endpoint_.host, endpoint_.port);
  client.set_connection_timeout(std::chrono::seconds(3));
  client.set_read_timeout(std::chrono::seconds(5));
  client.set_write_timeout(std::chrono::seconds(5));
  client.set_keep_alive(true);
  // Small requests on one connection: without TCP_NODELAY, Nagle's algorithm and the peer's
  // delayed ACK held each exchange about 40 ms (p50 42.7 ms on 127.0.0.1).
  client.set_tcp_nodelay(true);
  const httplib::Headers headers = {{kRigSecretHeader, endpoint_.secret}};
  bool failing = false;
  for (;;) {
    std::vector<RelayFrame> send;
    bool closing = false;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      wake_.wait_for(lock, failing ? kRetryAfterFailure : kExchangePeriod,
                     [this] { return closing_; });
      send.swap(down_);
      closing = closing_;
    }
    std::string error;
    std::vector<RelayFrame> heard;
    const Clock::time_point sent = Clock::now();
    const httplib::Result answer =
        client.Post(kRelayPath, headers, EncodeFrames(send), "application/octet-stream");
    const double round_trip_ms =
        std::chrono::duration<double, std::milli>(Clock::now() - sent).count();
    if (!answer) {
      error = "relay to " + student_ + "'s rig: its node (" + endpoint_.Address() +
              ") did not answer: " + httplib::to_string(answer.error());
    } else if (answer->status != 200) {
      error = "relay to " + student_ + "'s rig: its node (" + endpoint_.Address() +
              ") answered HTTP " + std::to_string(answer->status) + ": " +
              answer->body.substr(0, 200);
    } else {
      try {
        heard = DecodeFrames(answer->body);
      } catch (const std::exception& e) {
        error = "relay to " + student_ + "'s rig: " + e.what();
      }
    }
    failing = !error.empty();
    const std::lock_guard<std::mutex> lock(mutex_);
    if (!failing) {
      const size_t bin = std::min(round_trip_bins_.size() - 1,
                                  static_cast<size_t>(std::max(0.0, round_trip_ms * 10)));
      ++round_trip_bins_[bin];
      ++exchanges_;
      longest_ms_ = std::max(longest_ms_, round_trip_ms);
    }
    if (error != error_) {
      error_ = error;
      error_told_ = false;
    }
    for (RelayFrame& frame : heard) up_.push_back(std::move(frame));
    Bounded(up_);
    if (closing) {
      finished_ = true;
      return;
    }
  }
}

}  // namespace sirupp::classroom
