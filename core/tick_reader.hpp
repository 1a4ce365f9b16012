#pragma once
// The per-tick channels of a udpm bus (SIM_ARM_STATE, ARM_SETPOINT, REAL_ARM_STATE, ...: up to
// 1953 Hz each, more in lockstep), read in batches from a socket of their own. LCM 1.3.1's receive
// thread wakes once for every datagram of the multicast group; a process that needs no message the
// moment it arrives (the logger, the viewer, the panel) reads them here instead:
//  - the reader's socket on the group takes only the channels asked for (a socket filter on the
//    channel name in LCM's short-message header, core/udpm_socket.hpp) and is read with recvmmsg,
//    many datagrams per system call, whenever the process chooses;
//  - the Bus's own LCM socket then drops them (Bus::TakeOffLcm), so LCM never wakes for them.
//    Every other channel (replies, status, heartbeats, the model, fragmented messages) still goes
//    through LCM.
// Two ways to read: every datagram in order with its kernel receive time (DrainEach: the logger,
// which must keep every message), or each channel's newest message only (Drain + TakeNewest: the
// viewer and the panel, which draw the newest state per frame; the older ones are never decoded).
// Datagrams the kernel dropped because the socket's buffer was full can be counted (SO_RXQ_OVFL);
// the kernel counts the datagrams a socket filter refuses as drops too, so a reader that counts
// drops has no filter: its socket queues every datagram of the group and the channels are picked
// here (a woken reader should filter, one drained on a timer can count).
// Not thread-safe: one thread reads.

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/udpm_socket.hpp"

namespace sirupp::core {

class Bus;

class TickReader {
 public:
  // How the socket picks the channels.
  enum class Pick {
    kFilter,      // a socket filter: only the channels are queued; dropped() stays 0
    kCountDrops,  // no filter: everything is queued, the channels picked here; dropped() counts
  };
  // full_channels: 1 to 8 names, rig prefix included. buffer_bytes: the socket's receive buffer
  // to ask for; 0 = the URL's recv_buf_size, else the kernel's default. As root it may exceed
  // net.core.rmem_max (SO_RCVBUFFORCE); otherwise the kernel caps it there.
  // Throws std::runtime_error naming the group and port when the socket cannot be set up.
  TickReader(const UdpmAddress& address, std::vector<std::string> full_channels,
             int buffer_bytes = 0, Pick pick = Pick::kFilter);
  ~TickReader();
  TickReader(const TickReader&) = delete;
  TickReader& operator=(const TickReader&) = delete;

  // Readable when a per-tick datagram waits.
  int fd() const { return fd_; }
  const std::vector<std::string>& channels() const { return names_; }

  // Reads every datagram waiting (without blocking) and calls
  // fn(channel_index, full_channel, data, size, recv_utime) for each, in arrival order
  // (recv_utime: the kernel's reception time, as LCM gives). Returns the number read.
  template <class Fn>
  int DrainEach(Fn&& fn) {
    return DrainWith([&fn, this](size_t index, const uint8_t* data, size_t size, int64_t at) {
      fn(index, slots_[index].channel, data, static_cast<int>(size), at);
    });
  }

  // Reads every datagram waiting and keeps each channel's newest message. Returns the number read.
  // No allocation once each channel's buffer has grown.
  int Drain();

  // Calls fn(full_channel, data, size, recv_utime) for each channel that got a message since the
  // previous call, once, with its newest message.
  template <class Fn>
  void TakeNewest(Fn&& fn) {
    for (Slot& slot : slots_) {
      if (!slot.fresh) continue;
      slot.fresh = false;
      fn(slot.channel, slot.data.data(), static_cast<int>(slot.data.size()), slot.recv_utime);
    }
  }

  int64_t datagrams() const { return datagrams_; }  // read since the start
  // Read but not one of the channels (with kFilter: only a truncated one).
  int64_t refused() const { return refused_; }
  // kCountDrops: datagrams for this socket the kernel dropped since the start (its buffer was
  // full), as of the last datagram read.
  int64_t dropped() const { return dropped_; }
  int buffer_bytes() const;  // the receive buffer the kernel gave (SO_RCVBUF)

 private:
  struct Slot {
    std::string channel;
    std::string header;  // "LC02" + 4 sequence bytes are skipped; channel + '\0' compared
    std::vector<uint8_t> data;
    int64_t recv_utime = 0;
    bool fresh = false;
  };
  // The channel a datagram is on (its index), or -1 (counted as refused).
  int Match(const uint8_t* datagram, size_t size);
  // recvmmsg until the queue is empty; each(index, payload, payload size, recv_utime).
  template <class Each>
  int DrainWith(Each&& each);
  int ReadBatch();  // one recvmmsg; fills batch_ below; <= 0 when nothing waits

  UdpmAddress address_;
  int fd_ = -1;
  std::vector<Slot> slots_;
  std::vector<std::string> names_;
  std::vector<uint8_t> buffers_;   // kBatch datagrams of kDatagramMax bytes
  std::vector<uint8_t> controls_;  // their control messages (timestamp, drop count)
  struct Received {
    const uint8_t* data = nullptr;
    size_t size = 0;
    int64_t recv_utime = 0;
    bool truncated = false;
  };
  std::vector<Received> batch_;
  int64_t datagrams_ = 0;
  int64_t refused_ = 0;
  int64_t dropped_ = 0;
};

template <class Each>
int TickReader::DrainWith(Each&& each) {
  int total = 0;
  for (;;) {
    const int got = ReadBatch();
    if (got <= 0) break;  // EAGAIN: nothing more; other errors: tried again next time
    for (int i = 0; i < got; ++i) {
      const Received& r = batch_[static_cast<size_t>(i)];
      const int index = r.truncated ? -1 : Match(r.data, r.size);
      if (index < 0) {
        ++refused_;
        continue;
      }
      const size_t start = 8 + slots_[static_cast<size_t>(index)].header.size();
      each(static_cast<size_t>(index), r.data + start, r.size - start, r.recv_utime);
    }
    datagrams_ += got;
    total += got;
    if (static_cast<size_t>(got) < batch_.size()) break;  // the queue is empty
  }
  return total;
}

// A TickReader on a Bus's group whose channels the Bus's LCM socket no longer takes (TakeOffLcm),
// put back on LCM when it ends. Must not outlive its Bus.
class TickFeed {
 public:
  // nullptr when the bus is not udpm:// (memq:// in tests: LCM's queue does the work) or when the
  // socket or LCM's filter cannot be set up; the second is said once on stderr, naming `who`,
  // and the channels then go through LCM as before.
  static std::unique_ptr<TickFeed> Open(Bus& bus, std::vector<std::string> full_channels,
                                        const std::string& who, int buffer_bytes = 0,
                                        TickReader::Pick pick = TickReader::Pick::kFilter);
  ~TickFeed();
  TickFeed(const TickFeed&) = delete;
  TickFeed& operator=(const TickFeed&) = delete;

  TickReader& reader() { return *reader_; }
  // Drains the socket and hands each channel's newest message to the bus's subscriptions
  // (Bus::DeliverRecorded, with its kernel receive time). Returns the datagrams read.
  int DeliverNewest();

 private:
  TickFeed(Bus& bus, std::unique_ptr<TickReader> reader);
  Bus& bus_;
  std::unique_ptr<TickReader> reader_;
};

}  // namespace sirupp::core
