#pragma once
// The LCM bus every SIRUPP process talks through: a thin layer over lcm::LCM (1.3.1) that adds what
// the raw API leaves to each caller.
//
//  - Typed publish and subscribe with std::function handlers (1.3.1 only takes member functions).
//  - A rig prefix (e.g. "RIG3_") put in front of every channel name, so several rigs share a
//  network.
//  - Per-channel counters (messages, decode errors, rejected, late, sequence gaps, last error) that
//    feed heartbeat_t, so a silent fault on one channel shows up in `sirupp status`.
//  - A hard wall between handlers and LCM's C code: a message that does not decode never reaches a
//    handler, and an exception thrown by a handler is counted, never propagated through C frames.
//
// Thread model: single-threaded. Handlers run inside Handle()/HandleAvailable(), on the thread that
// calls them; nothing here locks. Use one Bus per thread if a process needs several.
//
// Channel names: every `channel` argument below is the name without the rig prefix, as written in
// Channels (core/channels.hpp). ReceiveInfo::channel and ChannelStats::channel are full names,
// prefix included, because that is what is on the wire and what lcm-spy shows. LCM treats a
// subscribed name as a regular expression, so names are restricted to characters that only match
// themselves.

#include <cstdint>
#include <functional>
#include <lcm/lcm-cpp.hpp>
#include <memory>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "core/channel.hpp"

namespace sirupp::core {

class TickFeed;  // core/tick_reader.hpp
namespace bus_internal {
class TickUnbatcher;  // core/bus.cpp
}

// Any failure of the bus: bad URL or channel name, a message that cannot be encoded or sent, an LCM
// error while waiting for messages.
class BusError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// What LCM tells us about one received message, besides its content.
struct ReceiveInfo {
  std::string channel;             // full name, prefix included
  int64_t recv_utime = 0;          // wall clock at reception, microseconds since the Unix epoch
  int64_t encoded_size_bytes = 0;  // size on the wire, fingerprint included
  // Handed over by a reader that keeps only each channel's newest message (TickFeed::DeliverNewest,
  // core/tick_reader.hpp): the messages skipped are not counted as sequence gaps.
  bool newest_only = false;
};

// Traffic counters of one channel in one direction; the fields of channel_stats_t except the rate,
// which the heartbeat computes from two snapshots.
struct ChannelStats {
  std::string channel;        // full name, prefix included
  bool publishing = false;    // true: counters of what we sent; false: of what we received
  int64_t messages = 0;       // sent, or received (decoded or not)
  int64_t decode_errors = 0;  // received but did not decode as the subscribed type
  int64_t rejected = 0;       // decoded but refused (Reject() or an exception from the handler)
  int64_t late = 0;           // arrived after their deadline (NoteLate())
  int64_t gaps = 0;           // missing sequence numbers (NoteSequence(), or automatic)
  std::string last_error;     // one line on the latest decode error or rejection
};

// Which side of a channel a ChannelStats entry describes. A process (or a memq:// test) that both
// publishes and subscribes a channel has one entry per side.
enum class ChannelSide { kReceiving, kPublishing };

class Bus;

// One subscription, owned by its Bus. Obtained from Bus::Subscribe; valid until Unsubscribe() or
// the end of the Bus.
class Subscription {
 public:
  Subscription(const Subscription&) = delete;
  Subscription& operator=(const Subscription&) = delete;
  virtual ~Subscription();

  const std::string& channel() const { return channel_; }  // full name
  bool active() const { return active_; }

  // Stops delivery at once. The object is destroyed (immediately, or when the message being handled
  // has been dispatched if called from inside a handler), so do not use it afterwards.
  void Unsubscribe();

 protected:
  Subscription(Bus& bus, std::string full_channel);

  // Decodes the message and hands it over. Exceptions are caught by the caller and counted.
  virtual void Deliver(const lcm::ReceiveBuffer& rbuf, const ReceiveInfo& info) = 0;

  // Counts a message that did not decode as `type_name` and records why, in one line.
  void NoteDecodeError(const lcm::ReceiveBuffer& rbuf, const ReceiveInfo& info,
                       const char* type_name, int64_t expected_fingerprint);
  // `sender`: the message's sender name when its type has one (arm_command_t, estop_t, ...):
  // sequence numbers are then followed per sender, so two senders' counters do not look like gaps.
  void NoteSequenceNumber(const ReceiveInfo& info, int64_t seq, const std::string& sender = "");
  Bus& bus() { return bus_; }

 private:
  friend class Bus;
  // What LCM calls for each message. A static function with a context pointer (subscribeFunction)
  // rather than a member-function handler: GCC 12's -fsanitize=vptr miscompiles the member-function
  // pointer call inside lcm-cpp-impl.hpp, so the ASan+UBSan build would crash in LCM's own header.
  // noexcept: nothing may unwind into LCM's C dispatch loop.
  static void OnLcmMessage(const lcm::ReceiveBuffer* rbuf, const std::string& channel,
                           Subscription* self) noexcept;
  // Counts the message, then Deliver()s it, catching whatever the handler throws.
  void Dispatch(const lcm::ReceiveBuffer& rbuf, const std::string& channel,
                bool newest_only = false) noexcept;

  Bus& bus_;
  std::string channel_;
  lcm::Subscription* lcm_subscription_ = nullptr;  // owned by lcm::LCM
  bool active_ = true;
};

namespace bus_internal {

// True when Msg has an integral member `seq` (every SIRUPP type but image_t): the typed
// subscription then counts gaps without the handler having to remember to.
template <class Msg, class = void>
struct HasSeqField : std::false_type {};
template <class Msg>
struct HasSeqField<Msg, std::void_t<decltype(std::declval<const Msg&>().seq)>>
    : std::is_integral<
          std::remove_cv_t<std::remove_reference_t<decltype(std::declval<const Msg&>().seq)>>> {};

// True when Msg has a std::string member `sender`: sequence gaps are then counted per sender.
template <class Msg, class = void>
struct HasSenderField : std::false_type {};
template <class Msg>
struct HasSenderField<Msg, std::void_t<decltype(std::declval<const Msg&>().sender)>>
    : std::is_same<
          std::remove_cv_t<std::remove_reference_t<decltype(std::declval<const Msg&>().sender)>>,
          std::string> {};

template <class Msg>
class TypedSubscription final : public Subscription {
 public:
  using Handler = std::function<void(const Msg&, const ReceiveInfo&)>;

  TypedSubscription(Bus& bus, std::string full_channel, Handler handler)
      : Subscription(bus, std::move(full_channel)), handler_(std::move(handler)) {}

 private:
  void Deliver(const lcm::ReceiveBuffer& rbuf, const ReceiveInfo& info) override {
    Msg msg;
    int status = -1;
    try {
      // A corrupt count field with a matching fingerprint can make decode allocate absurd sizes.
      status = msg.decode(rbuf.data, 0, static_cast<int>(rbuf.data_size));
    } catch (const std::exception&) {
      status = -1;
    }
    if (status < 0) {
      NoteDecodeError(rbuf, info, Msg::getTypeName(), Msg::getHash());
      return;
    }
    if constexpr (HasSeqField<Msg>::value && HasSenderField<Msg>::value) {
      NoteSequenceNumber(info, static_cast<int64_t>(msg.seq), msg.sender);
    } else if constexpr (HasSeqField<Msg>::value) {
      NoteSequenceNumber(info, static_cast<int64_t>(msg.seq));
    }
    handler_(msg, info);
  }

  Handler handler_;
};

}  // namespace bus_internal

class Bus {
 public:
  // LCM's per-subscription queue (1.3.1 default). Messages beyond it are dropped by LCM, which then
  // shows up as gaps.
  static constexpr int kDefaultQueueCapacity = 30;
  // HandleAvailable() stops after this many messages, so a fast publisher cannot starve the caller.
  static constexpr int kDefaultHandleLimit = 10000;

  // lcm_url: "" means LCM's default (the LCM_DEFAULT_URL environment variable, else
  // udpm://239.255.76.67:7667?ttl=0). channel_prefix: letters, digits and '_' only, may be empty.
  // Throws BusError if LCM cannot be started with that URL or the prefix is not allowed.
  explicit Bus(const std::string& lcm_url = "", const std::string& channel_prefix = "");
  ~Bus();
  Bus(const Bus&) = delete;
  Bus& operator=(const Bus&) = delete;

  const std::string& url() const { return url_; }
  const std::string& prefix() const { return prefix_; }
  // prefix + channel, after checking the result is a usable channel name (throws BusError if not).
  std::string FullName(const std::string& channel) const;

  // Encodes and sends msg on prefix + channel. Every count field (num_joints, ...) must match the
  // size of its vector: the generated encoder trusts it and reads past a short vector. Generated
  // types do not initialise their fields either, so build messages as `sirupp::arm_state_t msg{};`.
  // Throws BusError naming the channel on failure.
  template <class Msg>
  void Publish(const std::string& channel, const Msg& msg) {
    const int size_bytes = msg.getEncodedSize();
    uint8_t* buffer = PublishBuffer(size_bytes);
    const int encoded_bytes = msg.encode(buffer, 0, size_bytes);
    SendEncoded(channel, Msg::getTypeName(), encoded_bytes);
  }
  // Same on a typed channel: compiles only when Msg is the channel's type.
  template <class Msg, class ChannelMsg>
  void Publish(const Channel<ChannelMsg>& channel, const Msg& msg) {
    CheckChannelType<Msg, ChannelMsg>();
    Publish(channel.name(), msg);
  }

  // Calls handler for each message on prefix + channel that decodes as Msg. Messages that do not
  // decode are counted as decode_errors and never reach the handler; an exception from the handler
  // is counted as rejected, its what() kept as last_error. If Msg has a `seq` member, gaps are
  // counted. queue_capacity: messages LCM holds for this subscription between Handle() calls.
  // SIM_ARM_STATE and ARM_SETPOINT (this bus's prefix, default names) also take the ticks the sim
  // sends several at a time on SIM_ARM_TICKS (core/tick_batch.hpp): while either is subscribed the
  // bus subscribes that channel too and hands each tick in it to their subscriptions, counted on
  // their channels as if it had come alone, with the receive time it would have had.
  template <class Msg>
  Subscription& Subscribe(const std::string& channel,
                          std::function<void(const Msg&, const ReceiveInfo&)> handler,
                          int queue_capacity = kDefaultQueueCapacity) {
    if (!handler) ThrowEmptyHandler(channel);
    return Attach(std::make_unique<bus_internal::TypedSubscription<Msg>>(*this, FullName(channel),
                                                                         std::move(handler)),
                  queue_capacity);
  }
  // Same on a typed channel: compiles only when Msg is the channel's type.
  template <class Msg, class ChannelMsg>
  Subscription& Subscribe(const Channel<ChannelMsg>& channel,
                          std::function<void(const Msg&, const ReceiveInfo&)> handler,
                          int queue_capacity = kDefaultQueueCapacity) {
    CheckChannelType<Msg, ChannelMsg>();
    return Subscribe<Msg>(channel.name(), std::move(handler), queue_capacity);
  }
  // Same as subscription.Unsubscribe().
  void Unsubscribe(Subscription& subscription);

  // Waits up to timeout_ms (< 0: forever) for one message and dispatches it to every matching
  // handler. Returns 1 if a message was handled, 0 on timeout. Throws BusError if LCM reports an
  // error, or if called from inside a handler (LCM cannot dispatch re-entrantly).
  int Handle(int timeout_ms);
  // Handles the messages already queued without blocking, at most max_messages of them. Returns the
  // number handled.
  int HandleAvailable(int max_messages = kDefaultHandleLimit);
  // For observers that need no message the moment it arrives (logger, viewer): sleeps wait_ms
  // without watching the bus, then handles everything queued meanwhile; returns the number handled.
  // LCM's receive thread still takes each datagram as it comes (receive times are unchanged), but
  // this thread wakes once per call instead of once per message, which leaves the CPUs to the
  // lockstep loop (docs/timing.md, "What a tick costs"). Keep wait_ms well under a subscription's
  // queue capacity divided by its message rate: a full queue drops the newest messages.
  int HandleBatched(int wait_ms);
  // Hands one recorded message (an LCM log event: full channel name, encoded bytes, the time it was
  // received when recorded) to this bus's subscriptions of that channel, as if it had just arrived
  // with that receive time. Used to run a node over a raw log exactly as it ran live
  // (sirupp-logger --from-log). Returns how many subscriptions took it.
  // newest_only: see ReceiveInfo::newest_only.
  int DeliverRecorded(const std::string& full_channel, const void* data, int size_bytes,
                      int64_t recv_utime, bool newest_only = false);
  // A file descriptor that becomes readable when a message is waiting: for poll()/select() loops.
  // Not with ReadDirectly (its channels arrive on another socket): use Handle() to wait.
  int Fileno();

  // For the per-tick channel a process must answer at once (the sim's SIM_ARM_COMMAND, the
  // controller's SIM_ARM_STATE; full names, 1 to 8; also the exchange channels of
  // Channels::Exchange() read with it, in the order they were sent): Handle() and HandleAvailable()
  // read them from a socket of their own (core/tick_reader.hpp), every datagram in order with its
  // kernel receive time, in this thread, and LCM's socket drops them. LCM 1.3.1 hands each message
  // from its receive thread to this one through a pipe: two wake-ups and five system calls per
  // message where this takes one wake-up (docs/timing.md, "What a tick costs"). Call once, after
  // subscribing. Returns false, and these channels go through LCM as before, on another provider
  // (memq://), when LCM's socket cannot be filtered (said once on stderr, naming `who`), or when
  // this bus already reads others directly (one direct socket per bus: the first caller's).
  bool ReadDirectly(const std::vector<std::string>& full_channels, const std::string& who);
  bool reads_directly() const { return direct_ != nullptr; }

  // The per-tick channels on a udpm:// bus (Channels::PerTick(), with this bus's prefix): LCM's
  // own receive socket drops each one that no subscription of this bus matches, or that is
  // TakenOffLcm, with a socket filter, so LCM's receive thread never wakes for them
  // (docs/timing.md, "What a tick costs"). Recomputed whenever subscriptions change: a later
  // subscription unmutes its channel. Other providers (memq://, file://): nothing to do. If LCM's
  // socket cannot be found, every channel goes through LCM as before, said once on stderr.
  //
  // Subscriptions made on raw_lcm() directly are not seen: declare their pattern here (LCM reads it
  // as a regular expression, as a whole: ".*" keeps every per-tick channel on LCM).
  void NoteRawSubscription(const std::string& regex);
  void ForgetRawSubscription(const std::string& regex);  // undoes one NoteRawSubscription
  // For per-tick channels (full names) this process reads from a socket of its own
  // (core/tick_reader.hpp): LCM's socket drops them even when subscribed, and the reader hands
  // them to the subscriptions (DeliverRecorded). Counted: PutBackOnLcm undoes one TakeOffLcm.
  // Returns false (and takes nothing off) when LCM's socket cannot be filtered: the caller must
  // then leave the channels to LCM, or every message would arrive twice.
  bool TakeOffLcm(const std::vector<std::string>& full_channels);
  void PutBackOnLcm(const std::vector<std::string>& full_channels);
  // The per-tick channels LCM's socket drops now (full names, in Channels::PerTick() order).
  std::vector<std::string> MutedOnLcm() const;

  // Counters a handler (or the process's main loop) adds to. `channel` is without prefix; the
  // ReceiveInfo overloads are for use inside handlers. A rejection counts once per message even
  // when several handlers of the same channel refuse it.
  void Reject(const std::string& channel, const std::string& reason);
  void Reject(const ReceiveInfo& info, const std::string& reason);
  void NoteLate(const std::string& channel);
  void NoteLate(const ReceiveInfo& info);
  // Counts seq values skipped since the previous call: 0,1,2,5 gives 2 gaps. A smaller seq (the
  // publisher restarted) starts counting afresh; a repeated seq counts nothing.
  void NoteSequence(const std::string& channel, int64_t seq);

  // Every channel this bus has published or subscribed, sorted by name, receiving side first.
  std::vector<ChannelStats> Stats() const;
  // One channel's counters (all zero if the channel was never used on that side).
  ChannelStats StatsFor(const std::string& channel,
                        ChannelSide side = ChannelSide::kReceiving) const;

  // The underlying LCM instance, for tools that need raw access. Traffic through it is not counted.
  lcm::LCM& raw_lcm() { return lcm_; }

 private:
  friend class Subscription;
  friend class bus_internal::TickUnbatcher;
  struct Counters;
  struct CounterTable;
  struct LcmSocket;

  uint8_t* PublishBuffer(int size_bytes);
  void SendEncoded(const std::string& channel, const char* type_name, int encoded_bytes);
  Subscription& Attach(std::unique_ptr<Subscription> subscription, int queue_capacity);
  [[noreturn]] void ThrowEmptyHandler(const std::string& channel) const;
  void Remove(Subscription* subscription);
  // SIM_ARM_TICKS taken while SIM_ARM_STATE or ARM_SETPOINT is subscribed (Subscribe).
  void FollowTickBatches(int queue_capacity);
  void ForgetTickBatchesIfUnused();
  // The active subscriptions of one channel (full name), taken before a dispatch so that a handler
  // that subscribes or unsubscribes does not change the list being walked.
  std::vector<Subscription*> Matching(const std::string& full_channel) const;
  void Matching(const std::string& full_channel, std::vector<Subscription*>& out) const;
  // Inside a dispatch: hands one message unpacked from a batch to the subscriptions of
  // full_channel, counted as its own message there.
  void DispatchNested(const std::string& full_channel, const uint8_t* data, int size_bytes,
                      int64_t recv_utime, bool newest_only);
  // Around the call that creates LCM's receive socket (the first subscription, Fileno()): the
  // process's sockets on the port before it, then LCM's socket is the one that came with it.
  std::vector<int> SocketsBeforeLcmReceives() const;
  void FindLcmSocket(const std::vector<int>& before);
  // Puts on LCM's socket the filter that MutedOnLcm() should be now.
  void UpdateLcmFilter();
  // Handle() with ReadDirectly: waits on both sockets, handles every direct datagram waiting and
  // at most one message of LCM's.
  int HandleDirect(int timeout_ms);
  int HandleLcm(int timeout_ms);  // Handle() without ReadDirectly

  // Counting by full channel name, used by Subscription and the public overloads.
  Counters& Receiving(const std::string& full_channel);
  void CountReceived(const std::string& full_channel);
  void CountDecodeError(const std::string& full_channel, std::string description);
  void CountRejected(const std::string& full_channel, std::string reason);
  void CountLate(const std::string& full_channel);
  void CountSequence(const std::string& full_channel, int64_t seq, const std::string& sender = "",
                     bool count_gaps = true);

  std::string url_;
  std::string prefix_;
  lcm::LCM lcm_;
  std::unique_ptr<CounterTable> counters_;
  std::unique_ptr<LcmSocket> socket_;  // the per-tick filter on LCM's socket (udpm only)
  std::vector<uint8_t>
      publish_buffer_;  // reused so that publishing at the servo rate does not allocate
  // Declared after lcm_ so that they are destroyed first; LCM's own wrappers go with lcm_.
  std::vector<std::unique_ptr<Subscription>> subscriptions_;
  std::vector<Subscription*> pending_removal_;  // unsubscribed from inside a handler
  bool dispatching_ = false;
  // Numbers each dispatched message so that several subscriptions of one channel count it once.
  int64_t dispatch_number_ = 0;
  // The messages unpacked from a batch are numbered downwards from -1, so that they never take a
  // number an outer message has or will have.
  int64_t nested_number_ = 0;
  // SIM_ARM_TICKS and the two channels its ticks go to (full names), and the subscription that
  // unpacks it while one of those is subscribed.
  std::string ticks_channel_;
  std::string states_channel_;
  std::string setpoints_channel_;
  Subscription* unbatcher_ = nullptr;
  std::vector<Subscription*> nested_matching_;  // DispatchNested's list, kept between ticks
  int lcm_fd_ = -1;                             // LCM's notification descriptor, with ReadDirectly
  // Last: destroyed first, while what it gives the channels back to is still there.
  std::unique_ptr<TickFeed> direct_;
};

// The newest valid message of one channel, for code that samples rather than reacts (a viewer
// frame, the model a controller was built for). Must not outlive its Bus. Single-threaded like the
// Bus.
template <class Msg>
class Latest {
 public:
  // Returns "" to accept a message, else why it is refused. Refused messages are counted with
  // Bus::Reject and do not replace the held one.
  using Validator = std::function<std::string(const Msg&)>;

  Latest(Bus& bus, const std::string& channel, Validator validator = nullptr,
         int queue_capacity = Bus::kDefaultQueueCapacity)
      : bus_(bus),
        validator_(std::move(validator)),
        subscription_(&bus.Subscribe<Msg>(
            channel, [this](const Msg& msg, const ReceiveInfo& info) { Accept(msg, info); },
            queue_capacity)) {}
  // Same on a typed channel: compiles only when Msg is the channel's type.
  template <class ChannelMsg>
  Latest(Bus& bus, const Channel<ChannelMsg>& channel, Validator validator = nullptr,
         int queue_capacity = Bus::kDefaultQueueCapacity)
      : Latest(bus, channel.name(), std::move(validator), queue_capacity) {
    CheckChannelType<Msg, ChannelMsg>();
  }
  ~Latest() { subscription_->Unsubscribe(); }
  Latest(const Latest&) = delete;
  Latest& operator=(const Latest&) = delete;

  bool Has() const { return count_ > 0; }
  // The newest accepted message. Throws BusError if none has arrived yet.
  const Msg& Get() const {
    if (!Has()) ThrowNothingYet(subscription_->channel());
    return message_;
  }
  int64_t count() const { return count_; }            // messages accepted so far
  int64_t recv_utime() const { return recv_utime_; }  // reception time of Get(), 0 if none
  const std::string& channel() const { return subscription_->channel(); }

 private:
  void Accept(const Msg& msg, const ReceiveInfo& info) {
    if (validator_) {
      std::string reason = validator_(msg);
      if (!reason.empty()) {
        bus_.Reject(info, reason);
        return;
      }
    }
    message_ = msg;
    recv_utime_ = info.recv_utime;
    ++count_;
  }
  [[noreturn]] static void ThrowNothingYet(const std::string& channel) {
    throw BusError("no message received yet on " + channel);
  }

  Bus& bus_;
  Validator validator_;
  Msg message_{};
  int64_t count_ = 0;
  int64_t recv_utime_ = 0;
  Subscription* subscription_;  // last: subscribes once everything above is ready
};

// Handles messages on `bus` until done() holds or timeout_s passed (waiting at most 50 ms at a
// time, so done() is asked often); returns done().
bool HandleUntil(Bus& bus, const std::function<bool()>& done, double timeout_s);

// Microseconds since the Unix epoch: the utime of messages people and tools send.
int64_t WallMicros();
// Microseconds of the steady clock: for intervals, never for message fields.
int64_t SteadyMicros();

}  // namespace sirupp::core
