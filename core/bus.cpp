#include "core/bus.hpp"

#include <poll.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cinttypes>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <limits>
#include <map>
#include <optional>
#include <regex>
#include <thread>
#include <utility>

#include "core/channels.hpp"
#include "core/tick_batch.hpp"
#include "core/tick_reader.hpp"
#include "core/udpm_socket.hpp"

namespace sirupp::core {

namespace {

const char kUrlHelp[] =
    "allowed: \"\" (LCM_DEFAULT_URL, else udpm://239.255.76.67:7667?ttl=0), "
    "\"udpm://239.255.76.67:7667?ttl=0\" (one PC), \"udpm://239.255.76.67:7667?ttl=1\" (lab "
    "network), \"memq://\" (inside one process, tests), \"file:///path/log?mode=r\" (replay a "
    "log), \"tcpq://host:7700\"";

bool IsChannelCharacter(char c) {
  // Characters a POSIX regular expression matches literally, so that subscribing to a name never
  // matches another channel.
  return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_' ||
         c == '-' || c == '/';
}

std::string DescribeUrl(const std::string& url) {
  if (!url.empty()) return "\"" + url + "\"";
  const char* from_environment = std::getenv("LCM_DEFAULT_URL");
  if (from_environment != nullptr && from_environment[0] != '\0') {
    return std::string("\"\" (LCM_DEFAULT_URL=\"") + from_environment + "\")";
  }
  return "\"\" (LCM's default udpm://239.255.76.67:7667?ttl=0)";
}

int64_t SaturatingAdd(int64_t total, uint64_t amount) {
  const auto room = static_cast<uint64_t>(std::numeric_limits<int64_t>::max() - total);
  return amount >= room ? std::numeric_limits<int64_t>::max()
                        : total + static_cast<int64_t>(amount);
}

}  // namespace

// ---- Counters
// ------------------------------------------------------------------------------------

struct Bus::Counters {
  ChannelStats stats;
  bool has_seq = false;
  int64_t last_seq = 0;
  // Per sender (types with a sender name): the last seq of each, at most kMaxSequenceSenders.
  std::map<std::string, int64_t> sender_seq;
  // Dispatch number of the message last counted in each counter (0 = none): a message handed to two
  // subscriptions of the same channel is one message.
  int64_t received_in = 0;
  int64_t decode_error_in = 0;
  int64_t rejected_in = 0;
  int64_t late_in = 0;
};

struct Bus::CounterTable {
  std::map<std::string, Counters> receiving;
  std::map<std::string, Counters> publishing;
};

struct Bus::LcmSocket {
  std::optional<UdpmAddress> address;    // nullopt: not udpm, nothing to filter
  std::vector<std::string> per_tick;     // full names, in Channels::PerTick() order
  std::vector<std::string> exchange;     // full names, Channels::Exchange(): muted only when taken
  std::vector<int> at_start;             // the process's sockets on the port when the Bus began
  int fd = -1;                           // LCM's receive socket, once found
  bool searched = false;                 // FindLcmSocket has run
  bool warned = false;                   // the one line on stderr
  std::map<std::string, int> elsewhere;  // TakeOffLcm counts
  std::vector<std::pair<std::string, std::optional<std::regex>>> raw_patterns;
  std::vector<std::string> muted;  // the filter on fd now
};

// ---- Subscription
// --------------------------------------------------------------------------------

Subscription::Subscription(Bus& bus, std::string full_channel)
    : bus_(bus), channel_(std::move(full_channel)) {}

Subscription::~Subscription() = default;

void Subscription::Unsubscribe() { bus_.Unsubscribe(*this); }

void Subscription::NoteDecodeError(const lcm::ReceiveBuffer& rbuf, const ReceiveInfo& info,
                                   const char* type_name, int64_t expected_fingerprint) {
  // Tell a wrong type (another fingerprint) from a damaged message of the right type: the first is
  // a wiring mistake between processes, the second a transport or publisher bug.
  std::string why;
  if (rbuf.data_size < 8) {
    why = "shorter than the 8-byte type fingerprint";
  } else {
    const auto* bytes = static_cast<const uint8_t*>(rbuf.data);
    uint64_t fingerprint = 0;
    for (int i = 0; i < 8; ++i) fingerprint = (fingerprint << 8) | bytes[i];
    char text[96];
    if (fingerprint != static_cast<uint64_t>(expected_fingerprint)) {
      std::snprintf(text, sizeof text, "fingerprint 0x%016" PRIx64 " is another type's",
                    fingerprint);
    } else {
      std::snprintf(text, sizeof text, "fingerprint matches, body truncated or corrupt");
    }
    why = text;
  }
  bus_.CountDecodeError(info.channel,
                        info.channel + ": " + std::to_string(info.encoded_size_bytes) +
                            "-byte message did not decode as " + type_name + " (" + why + ")");
}

void Subscription::NoteSequenceNumber(const ReceiveInfo& info, int64_t seq,
                                      const std::string& sender) {
  bus_.CountSequence(info.channel, seq, sender, !info.newest_only);
}

void Subscription::OnLcmMessage(const lcm::ReceiveBuffer* rbuf, const std::string& channel,
                                Subscription* self) noexcept {
  // A channel taken off LCM comes through its own socket (ReadDirectly, a tick reader): what LCM
  // still hands over of it was queued before the filter went on, older than what the other socket
  // has delivered since, and would go back in time (a controller saw its sim's tick go from 321
  // back to 296 right after its start and took it for a restarted sim; issue 41).
  const auto& taken = self->bus_.socket_->elsewhere;
  const auto found = taken.find(channel);
  if (found != taken.end() && found->second > 0) return;
  self->Dispatch(*rbuf, channel);
}

void Subscription::Dispatch(const lcm::ReceiveBuffer& rbuf, const std::string& channel,
                            bool newest_only) noexcept {
  // Unsubscribed from inside another handler of the same message: LCM still calls us this once.
  if (!active_) return;
  try {
    ReceiveInfo info;
    info.channel = channel;
    info.recv_utime = rbuf.recv_utime;
    info.encoded_size_bytes = rbuf.data_size;
    info.newest_only = newest_only;
    bus_.CountReceived(channel);
    try {
      Deliver(rbuf, info);
    } catch (const std::exception& error) {
      bus_.CountRejected(channel, error.what());
    } catch (...) {
      bus_.CountRejected(channel, "handler threw an exception not derived from std::exception");
    }
  } catch (...) {
    // Only the bookkeeping itself can get here (out of memory). Dropping one message is better than
    // unwinding through LCM's C frames, which is undefined behaviour.
  }
}

// ---- The ticks of SIM_ARM_TICKS
// ---------------------------------------------------------------------------------------

namespace bus_internal {

// Subscribed to SIM_ARM_TICKS while SIM_ARM_STATE or ARM_SETPOINT is: each tick in a batch goes to
// their subscriptions as its own message (core/tick_batch.hpp).
class TickUnbatcher final : public Subscription {
 public:
  TickUnbatcher(Bus& bus, std::string full_channel) : Subscription(bus, std::move(full_channel)) {}

 private:
  void Deliver(const lcm::ReceiveBuffer& rbuf, const ReceiveInfo& info) override {
    sirupp::arm_ticks_t batch;
    int status = -1;
    try {
      status = batch.decode(rbuf.data, 0, static_cast<int>(rbuf.data_size));
    } catch (const std::exception&) {
      status = -1;
    }
    if (status < 0) {
      NoteDecodeError(rbuf, info, sirupp::arm_ticks_t::getTypeName(),
                      sirupp::arm_ticks_t::getHash());
      return;
    }
    NoteSequenceNumber(info, batch.seq);
    Bus& bus = this->bus();
    core::ForEachTick(
        batch, info.recv_utime, info.newest_only, scratch_,
        [&bus, &info](core::TickKind kind, const uint8_t* data, int size, int64_t recv_utime) {
          bus.DispatchNested(
              kind == core::TickKind::kState ? bus.states_channel_ : bus.setpoints_channel_, data,
              size, recv_utime, info.newest_only);
        });
  }

  std::vector<uint8_t> scratch_;
};

}  // namespace bus_internal

void Bus::FollowTickBatches(int queue_capacity) {
  if (unbatcher_ != nullptr) return;
  // A batch holds 16 ticks: the per-tick subscription's queue covers as much time in batches.
  unbatcher_ = &Attach(std::make_unique<bus_internal::TickUnbatcher>(*this, ticks_channel_),
                       std::max(kDefaultQueueCapacity, queue_capacity / 8));
}

void Bus::ForgetTickBatchesIfUnused() {
  if (unbatcher_ == nullptr) return;
  for (const auto& subscription : subscriptions_) {
    if (subscription->active_ && (subscription->channel() == states_channel_ ||
                                  subscription->channel() == setpoints_channel_)) {
      return;
    }
  }
  Subscription* unbatcher = unbatcher_;
  unbatcher_ = nullptr;
  Unsubscribe(*unbatcher);
}

std::vector<Subscription*> Bus::Matching(const std::string& full_channel) const {
  std::vector<Subscription*> matching;
  Matching(full_channel, matching);
  return matching;
}

void Bus::Matching(const std::string& full_channel, std::vector<Subscription*>& out) const {
  out.clear();
  for (const auto& subscription : subscriptions_) {
    if (subscription->active_ && subscription->channel() == full_channel) {
      out.push_back(subscription.get());
    }
  }
}

void Bus::DispatchNested(const std::string& full_channel, const uint8_t* data, int size_bytes,
                         int64_t recv_utime, bool newest_only) {
  lcm::ReceiveBuffer rbuf{};
  rbuf.data = const_cast<uint8_t*>(data);  // LCM's type; handlers only read it
  rbuf.data_size = static_cast<uint32_t>(size_bytes);
  rbuf.recv_utime = recv_utime;
  // Reused: a message unpacked from a batch is never dispatched from inside another one's handler.
  Matching(full_channel, nested_matching_);
  const int64_t outer = dispatch_number_;
  dispatch_number_ = --nested_number_;
  for (Subscription* subscription : nested_matching_) {
    subscription->Dispatch(rbuf, full_channel, newest_only);
  }
  dispatch_number_ = outer;
}

// ---- Bus
// -----------------------------------------------------------------------------------------

Bus::Bus(const std::string& lcm_url, const std::string& channel_prefix)
    : url_(lcm_url),
      prefix_(channel_prefix),
      lcm_(lcm_url),
      counters_(new CounterTable),
      socket_(new LcmSocket) {
  if (!lcm_.good()) {
    throw BusError("cannot start LCM with URL " + DescribeUrl(lcm_url) +
                   " (bad provider, address or file; LCM printed the detail above); " + kUrlHelp);
  }
  try {
    ValidateChannelPrefix(channel_prefix);
  } catch (const std::invalid_argument& error) {
    throw BusError(error.what());
  }
  const Channels defaults;
  ticks_channel_ = prefix_ + defaults.sim_arm_ticks.name();
  states_channel_ = prefix_ + defaults.sim_arm_state.name();
  setpoints_channel_ = prefix_ + defaults.arm_setpoint.name();
  socket_->address = ParseUdpmUrl(lcm_url);
  if (socket_->address) {
    // LCM 1.3.1 opens its receive socket with the first subscription, not here.
    socket_->at_start = UdpSocketsOnPort(socket_->address->port);
    for (const std::string& name : Channels{}.PerTick()) {
      socket_->per_tick.push_back(prefix_ + name);
    }
    for (const std::string& name : Channels{}.Exchange()) {
      socket_->exchange.push_back(prefix_ + name);
    }
  }
}

Bus::~Bus() = default;

std::string Bus::FullName(const std::string& channel) const {
  std::string full = prefix_ + channel;
  const bool characters_ok = std::all_of(channel.begin(), channel.end(), IsChannelCharacter);
  if (channel.empty() || !characters_ok || full.size() > kMaxChannelNameLength) {
    throw BusError("channel name \"" + full +
                   "\" is not allowed: use 1 to 63 characters (prefix included) from A-Z a-z 0-9 _ "
                   "- / (LCM reads subscribed names as regular expressions)");
  }
  return full;
}

uint8_t* Bus::PublishBuffer(int size_bytes) {
  publish_buffer_.resize(static_cast<std::size_t>(std::max(size_bytes, 0)));
  return publish_buffer_.data();
}

void Bus::SendEncoded(const std::string& channel, const char* type_name, int encoded_bytes) {
  const std::string full = FullName(channel);
  if (encoded_bytes < 0 || static_cast<std::size_t>(encoded_bytes) != publish_buffer_.size()) {
    throw BusError("cannot publish on " + full + ": encoding " + type_name +
                   " failed (a negative count field, or one that does not match its array?)");
  }
  if (lcm_.publish(full, publish_buffer_.data(), static_cast<unsigned int>(encoded_bytes)) != 0) {
    throw BusError("cannot publish on " + full + ": LCM refused the " +
                   std::to_string(encoded_bytes) + "-byte " + type_name +
                   " (message too large for the transport, or the network is down)");
  }
  Counters& counters = counters_->publishing[full];
  counters.stats.channel = full;
  counters.stats.publishing = true;
  ++counters.stats.messages;
}

void Bus::ThrowEmptyHandler(const std::string& channel) const {
  throw BusError("cannot subscribe to " + prefix_ + channel + ": the handler is empty");
}

Subscription& Bus::Attach(std::unique_ptr<Subscription> subscription, int queue_capacity) {
  const std::string& full = subscription->channel();
  if (queue_capacity < 1) {
    throw BusError("cannot subscribe to " + full + ": queue capacity " +
                   std::to_string(queue_capacity) + " (allowed: 1 or more messages)");
  }
  Receiving(full);  // listed in Stats() from now on, even before the first message
  const std::vector<int> before = SocketsBeforeLcmReceives();
  lcm::Subscription* lcm_subscription =
      lcm_.subscribeFunction(full, &Subscription::OnLcmMessage, subscription.get());
  FindLcmSocket(before);
  if (lcm_subscription == nullptr) {
    throw BusError("cannot subscribe to " + full + ": LCM refused the subscription");
  }
  lcm_subscription->setQueueCapacity(queue_capacity);
  subscription->lcm_subscription_ = lcm_subscription;
  subscriptions_.push_back(std::move(subscription));
  Subscription& attached = *subscriptions_.back();
  if (full == states_channel_ || full == setpoints_channel_) FollowTickBatches(queue_capacity);
  UpdateLcmFilter();
  return attached;
}

void Bus::Unsubscribe(Subscription& subscription) {
  if (!subscription.active_) return;
  subscription.active_ = false;
  // LCM is iterating over its handler list right now, and 1.3.1 leaks a subscription removed during
  // dispatch (LeakSanitizer shows it): remove it once the dispatch is over.
  if (dispatching_) {
    pending_removal_.push_back(&subscription);
  } else {
    Remove(&subscription);
  }
}

void Bus::Remove(Subscription* subscription) {
  if (subscription == unbatcher_) unbatcher_ = nullptr;
  lcm_.unsubscribe(subscription->lcm_subscription_);
  const auto owned = std::find_if(
      subscriptions_.begin(), subscriptions_.end(),
      [subscription](const std::unique_ptr<Subscription>& s) { return s.get() == subscription; });
  if (owned != subscriptions_.end()) subscriptions_.erase(owned);
  ForgetTickBatchesIfUnused();
  UpdateLcmFilter();
}

int Bus::Handle(int timeout_ms) {
  return direct_ ? HandleDirect(timeout_ms) : HandleLcm(timeout_ms);
}

bool Bus::ReadDirectly(const std::vector<std::string>& full_channels, const std::string& who) {
  if (direct_) return false;  // one direct socket per bus: the first caller's
  const int lcm_fd = Fileno();
  direct_ = TickFeed::Open(*this, full_channels, who);
  if (direct_) lcm_fd_ = lcm_fd;
  return direct_ != nullptr;
}

int Bus::HandleDirect(int timeout_ms) {
  if (dispatching_) throw BusError("Bus::Handle called from inside a message handler");
  pollfd fds[2] = {{direct_->reader().fd(), POLLIN, 0}, {lcm_fd_, POLLIN, 0}};
  const int ready = ::poll(fds, 2, timeout_ms < 0 ? -1 : timeout_ms);
  if (ready < 0) {
    if (errno == EINTR) return 0;  // as in HandleLcm: the caller looks at its signal flag
    throw BusError("waiting for messages on " + DescribeUrl(url_) +
                   " failed: " + std::strerror(errno));
  }
  int handled = 0;
  if (fds[0].revents != 0) {
    handled += direct_->reader().DrainEach(
        [this](size_t, const std::string& channel, const uint8_t* data, int size, int64_t at) {
          DeliverRecorded(channel, data, size, at);
        });
  }
  if (fds[1].revents != 0) handled += HandleLcm(0);
  return handled;
}

int Bus::HandleLcm(int timeout_ms) {
  if (dispatching_) {
    throw BusError(
        "Bus::Handle called from inside a message handler: LCM cannot dispatch re-entrantly; "
        "return from the handler and let the main loop handle the next message");
  }
  dispatching_ = true;
  ++dispatch_number_;
  // handleTimeout treats a negative timeout as an error, so "forever" is the blocking handle().
  errno = 0;
  const int status =
      timeout_ms < 0 ? (lcm_.handle() == 0 ? 1 : -1) : lcm_.handleTimeout(timeout_ms);
  // A signal that interrupted the wait (select() gives EINTR) is no failure of the bus: nothing
  // was handled, as after a timeout, and the caller looks at its own signal flag (a Python
  // program's Ctrl-C lands here when the signal reaches this thread).
  const bool interrupted = status < 0 && errno == EINTR;
  dispatching_ = false;
  std::vector<Subscription*> removals;
  removals.swap(pending_removal_);
  for (Subscription* subscription : removals) Remove(subscription);
  if (interrupted) return 0;
  if (status < 0) {
    throw BusError("LCM failed while waiting for messages on " + DescribeUrl(url_) + " (status " +
                   std::to_string(status) + ")");
  }
  return status > 0 ? 1 : 0;
}

int Bus::HandleAvailable(int max_messages) {
  int handled = 0;
  for (int got = 1; handled < max_messages && got > 0;) {
    got = Handle(0);
    handled += got;
  }
  return handled;
}

int Bus::HandleBatched(int wait_ms) {
  if (dispatching_) throw BusError("Bus::HandleBatched called from inside a message handler");
  if (wait_ms > 0) std::this_thread::sleep_for(std::chrono::milliseconds(wait_ms));
  return HandleAvailable();
}

int Bus::DeliverRecorded(const std::string& full_channel, const void* data, int size_bytes,
                         int64_t recv_utime, bool newest_only) {
  if (dispatching_) throw BusError("Bus::DeliverRecorded called from inside a message handler");
  lcm::ReceiveBuffer rbuf{};
  rbuf.data = const_cast<void*>(data);  // LCM's type; handlers only read it
  rbuf.data_size = static_cast<uint32_t>(size_bytes);
  rbuf.recv_utime = recv_utime;
  const std::vector<Subscription*> matching = Matching(full_channel);
  dispatching_ = true;
  ++dispatch_number_;  // one message: counted once however many subscriptions take it
  for (Subscription* subscription : matching) {
    subscription->Dispatch(rbuf, full_channel, newest_only);
  }
  dispatching_ = false;
  std::vector<Subscription*> removals;
  removals.swap(pending_removal_);
  for (Subscription* subscription : removals) Remove(subscription);
  return static_cast<int>(matching.size());
}

int Bus::Fileno() {
  const std::vector<int> before = SocketsBeforeLcmReceives();
  const int fd = lcm_.getFileno();  // 1.3.1 opens the receive socket here if not yet done
  FindLcmSocket(before);            // the filter goes on with the search, the first time only
  return fd;
}

// ---- The per-tick channels on LCM's socket
// ----------------------------------------------------------

std::vector<int> Bus::SocketsBeforeLcmReceives() const {
  if (!socket_->address || socket_->searched) return {};
  return UdpSocketsOnPort(socket_->address->port);
}

void Bus::FindLcmSocket(const std::vector<int>& before) {
  if (!socket_->address || socket_->searched) return;
  socket_->searched = true;
  const std::vector<int> now = UdpSocketsOnPort(socket_->address->port);
  const auto created_since = [&now](const std::vector<int>& then) {
    std::vector<int> created;
    for (const int fd : now) {
      if (!std::binary_search(then.begin(), then.end(), fd)) created.push_back(fd);
    }
    return created;
  };
  // Exactly one socket that came with the call: LCM's. None: LCM had opened it before (a
  // subscription through raw_lcm()); then the one socket opened since the Bus began. Otherwise
  // (another thread opened one at the same moment) it is not known and nothing is filtered.
  std::vector<int> created = created_since(before);
  if (created.empty()) created = created_since(socket_->at_start);
  if (created.size() == 1) socket_->fd = created.front();
  UpdateLcmFilter();
}

void Bus::UpdateLcmFilter() {
  LcmSocket& s = *socket_;
  if (!s.address || !s.searched) return;
  std::vector<std::string> muted;
  for (const std::string& name : s.per_tick) {
    const auto taken = s.elsewhere.find(name);
    bool wanted = false;
    for (const auto& subscription : subscriptions_) {
      if (subscription->active_ && subscription->channel() == name) wanted = true;
    }
    for (const auto& [text, pattern] : s.raw_patterns) {
      // A pattern std::regex cannot read keeps everything on LCM.
      if (!pattern || std::regex_match(name, *pattern)) wanted = true;
    }
    if ((taken != s.elsewhere.end() && taken->second > 0) || !wanted) muted.push_back(name);
  }
  for (const std::string& name : s.exchange) {
    const auto taken = s.elsewhere.find(name);
    if (taken != s.elsewhere.end() && taken->second > 0) muted.push_back(name);
  }
  if (muted == s.muted) return;
  if (s.fd >= 0 && FilterChannels(s.fd, muted, false)) {
    s.muted = std::move(muted);
    return;
  }
  if (!s.warned) {
    s.warned = true;
    std::cerr << "sirupp: LCM's receive socket on udpm " << DescribeUdpm(*s.address)
              << (s.fd < 0 ? " not found" : " refused the channel filter")
              << "; LCM still wakes for every per-tick message (docs/timing.md)\n";
  }
}

void Bus::NoteRawSubscription(const std::string& regex) {
  std::optional<std::regex> pattern;
  try {
    pattern.emplace(regex);
  } catch (const std::regex_error&) {
    pattern.reset();
  }
  socket_->raw_patterns.emplace_back(regex, std::move(pattern));
  UpdateLcmFilter();
}

void Bus::ForgetRawSubscription(const std::string& regex) {
  auto& patterns = socket_->raw_patterns;
  const auto found = std::find_if(patterns.begin(), patterns.end(),
                                  [&regex](const auto& p) { return p.first == regex; });
  if (found == patterns.end()) return;
  patterns.erase(found);
  UpdateLcmFilter();
}

bool Bus::TakeOffLcm(const std::vector<std::string>& full_channels) {
  if (!socket_->address) return false;
  Fileno();  // LCM's socket exists and has been looked for
  if (socket_->fd < 0) return false;
  for (const std::string& name : full_channels) ++socket_->elsewhere[name];
  UpdateLcmFilter();
  for (const std::string& name : full_channels) {
    const bool per_tick = std::find(socket_->per_tick.begin(), socket_->per_tick.end(), name) !=
                              socket_->per_tick.end() ||
                          std::find(socket_->exchange.begin(), socket_->exchange.end(), name) !=
                              socket_->exchange.end();
    if (!per_tick ||
        std::find(socket_->muted.begin(), socket_->muted.end(), name) == socket_->muted.end()) {
      PutBackOnLcm(full_channels);  // the filter was refused, or not a per-tick channel
      return false;
    }
  }
  return true;
}

void Bus::PutBackOnLcm(const std::vector<std::string>& full_channels) {
  for (const std::string& name : full_channels) {
    const auto taken = socket_->elsewhere.find(name);
    if (taken != socket_->elsewhere.end() && --taken->second <= 0) {
      socket_->elsewhere.erase(taken);
    }
  }
  UpdateLcmFilter();
}

std::vector<std::string> Bus::MutedOnLcm() const { return socket_->muted; }

// ---- Counting
// ------------------------------------------------------------------------------------

Bus::Counters& Bus::Receiving(const std::string& full_channel) {
  Counters& counters = counters_->receiving[full_channel];
  if (counters.stats.channel.empty()) counters.stats.channel = full_channel;
  return counters;
}

// Inside a dispatch each counter moves at most once per message; outside (a main loop calling
// Reject) every call counts.
void Bus::CountReceived(const std::string& full_channel) {
  Counters& counters = Receiving(full_channel);
  if (dispatching_ && counters.received_in == dispatch_number_) return;
  counters.received_in = dispatch_number_;
  ++counters.stats.messages;
}

void Bus::CountDecodeError(const std::string& full_channel, std::string description) {
  Counters& counters = Receiving(full_channel);
  counters.stats.last_error = std::move(description);
  if (dispatching_ && counters.decode_error_in == dispatch_number_) return;
  counters.decode_error_in = dispatch_number_;
  ++counters.stats.decode_errors;
}

void Bus::CountRejected(const std::string& full_channel, std::string reason) {
  Counters& counters = Receiving(full_channel);
  counters.stats.last_error = std::move(reason);
  if (dispatching_ && counters.rejected_in == dispatch_number_) return;
  counters.rejected_in = dispatch_number_;
  ++counters.stats.rejected;
}

void Bus::CountLate(const std::string& full_channel) {
  Counters& counters = Receiving(full_channel);
  if (dispatching_ && counters.late_in == dispatch_number_) return;
  counters.late_in = dispatch_number_;
  ++counters.stats.late;
}

void Bus::CountSequence(const std::string& full_channel, int64_t seq, const std::string& sender,
                        bool count_gaps) {
  Counters& counters = Receiving(full_channel);
  bool known = counters.has_seq;
  int64_t last = counters.last_seq;
  if (!sender.empty()) {
    // Followed per sender; a flood of distinct names forgets them all rather than grow.
    constexpr size_t kMaxSequenceSenders = 256;
    auto it = counters.sender_seq.find(sender);
    known = it != counters.sender_seq.end();
    if (known) last = it->second;
    if (!known && counters.sender_seq.size() >= kMaxSequenceSenders) counters.sender_seq.clear();
  }
  if (known && seq > last && count_gaps) {
    // Unsigned difference: a wild seq from a corrupt message must not overflow.
    const uint64_t step = static_cast<uint64_t>(seq) - static_cast<uint64_t>(last);
    counters.stats.gaps = SaturatingAdd(counters.stats.gaps, step - 1);
  }
  if (!sender.empty()) {
    counters.sender_seq[sender] = seq;
    return;
  }
  if (!counters.has_seq || seq != counters.last_seq) counters.last_seq = seq;
  counters.has_seq = true;
}

void Bus::Reject(const std::string& channel, const std::string& reason) {
  CountRejected(FullName(channel), reason);
}

void Bus::Reject(const ReceiveInfo& info, const std::string& reason) {
  CountRejected(info.channel, reason);
}

void Bus::NoteLate(const std::string& channel) { CountLate(FullName(channel)); }

void Bus::NoteLate(const ReceiveInfo& info) { CountLate(info.channel); }

void Bus::NoteSequence(const std::string& channel, int64_t seq) {
  CountSequence(FullName(channel), seq);
}

std::vector<ChannelStats> Bus::Stats() const {
  std::vector<ChannelStats> all;
  all.reserve(counters_->receiving.size() + counters_->publishing.size());
  for (const auto& [name, counters] : counters_->receiving) all.push_back(counters.stats);
  for (const auto& [name, counters] : counters_->publishing) all.push_back(counters.stats);
  std::stable_sort(all.begin(), all.end(), [](const ChannelStats& a, const ChannelStats& b) {
    return a.channel < b.channel;
  });
  return all;
}

ChannelStats Bus::StatsFor(const std::string& channel, ChannelSide side) const {
  const std::string full = FullName(channel);
  const auto& table =
      side == ChannelSide::kPublishing ? counters_->publishing : counters_->receiving;
  const auto found = table.find(full);
  if (found != table.end()) return found->second.stats;
  ChannelStats empty;
  empty.channel = full;
  empty.publishing = side == ChannelSide::kPublishing;
  return empty;
}

bool HandleUntil(Bus& bus, const std::function<bool()>& done, double timeout_s) {
  const auto end = std::chrono::steady_clock::now() +
                   std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                       std::chrono::duration<double>(timeout_s));
  while (!done()) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
        end - std::chrono::steady_clock::now());
    if (left.count() <= 0) return done();
    bus.Handle(static_cast<int>(std::min<int64_t>(left.count(), 50)));
  }
  return true;
}

int64_t WallMicros() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

int64_t SteadyMicros() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

}  // namespace sirupp::core
