#pragma once
// The per-tick channels of a udpm bus (SIM_ARM_STATE, ARM_SETPOINT, REAL_ARM_STATE: up to 1953 Hz
// each), read in batches. LCM 1.3.1's receive thread wakes once for every datagram of the multicast
// group and the panel keeps only the newest state per page frame; those wake-ups were two-thirds of
// the panel's CPU. So:
//  - the reader's own socket on the group takes only the per-tick channels (a socket filter on the
//    channel name in LCM's short-message header) and is read with recvmmsg once per round of the
//    hub (5 ms); each channel's newest message is kept, the older ones are never decoded;
//  - an inverted filter goes on LCM's own receive socket (MuteOnLcmSockets): LCM never wakes for
//    any per-tick channel of the rig, the ones read here and those the panel does not use
//    (SIM_ARM_COMMAND, REAL_ARM_SETPOINT). Every other channel (replies, status, heartbeats, the
//    model, fragmented messages) still goes through LCM as before.
// Not thread-safe: one thread reads (the hub's, under its lock).

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace sirupp::panel {

struct UdpmAddress {
  uint32_t group = 0;  // IPv4, host byte order
  int port = 0;
  int recv_buf_size = 0;  // the URL's recv_buf_size, 0 when not given
};

// The group and port of a udpm:// URL; "" means LCM_DEFAULT_URL, else LCM's default
// (udpm://239.255.76.67:7667). nullopt for another provider (memq://, file://) or a URL that
// does not parse (LCM itself then refuses it).
std::optional<UdpmAddress> ParseUdpmUrl(const std::string& url);

class TickReader {
 public:
  // read: the per-tick channels kept, rig prefix included (1 to 8); muted: the channels LCM's
  // socket is to drop (MuteOnLcmSockets), `read` and the per-tick channels nobody here uses.
  // Throws std::runtime_error naming the group and port when the socket cannot be set up.
  TickReader(const UdpmAddress& address, std::vector<std::string> read,
             std::vector<std::string> muted);
  ~TickReader();
  TickReader(const TickReader&) = delete;
  TickReader& operator=(const TickReader&) = delete;

  // Readable when a per-tick datagram waits.
  int fd() const { return fd_; }

  // Puts the inverted filter on every other UDP socket of this process bound to the port: LCM's
  // receive socket (it exists once the bus has a subscription). Returns how many were muted; with
  // 0, LCM still receives the per-tick channels and the reader should not be used.
  int MuteOnLcmSockets() const;

  // Reads every datagram waiting (without blocking) and keeps each channel's newest message.
  // Returns the number of datagrams read. No allocation once each channel's buffer has grown.
  int Drain();

  // Calls fn(full_channel, data, size, recv_utime) for each channel that got a message since the
  // previous call, once, with its newest message (recv_utime: the kernel's reception time).
  template <class Fn>
  void TakeNewest(Fn&& fn) {
    for (Slot& slot : slots_) {
      if (!slot.fresh) continue;
      slot.fresh = false;
      fn(slot.channel, slot.data.data(), static_cast<int>(slot.data.size()), slot.recv_utime);
    }
  }

  int64_t datagrams() const { return datagrams_; }  // read since the start
  int64_t refused() const { return refused_; }      // read but not a per-tick message (truncated)

 private:
  struct Slot {
    std::string channel;
    std::string header;  // "LC02" + 4 sequence bytes are skipped; channel + '\0' compared
    std::vector<uint8_t> data;
    int64_t recv_utime = 0;
    bool fresh = false;
  };
  void Keep(const uint8_t* datagram, size_t size, int64_t recv_utime);

  UdpmAddress address_;
  std::vector<std::string> muted_;
  int fd_ = -1;
  std::vector<Slot> slots_;
  std::vector<uint8_t> buffers_;   // kBatch datagrams of kDatagramMax bytes
  std::vector<uint8_t> controls_;  // their SO_TIMESTAMP control messages
  int64_t datagrams_ = 0;
  int64_t refused_ = 0;
};

}  // namespace sirupp::panel
