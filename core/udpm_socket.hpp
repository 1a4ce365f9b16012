#pragma once
// The socket-level pieces of a udpm:// LCM bus that LCM 1.3.1 does not expose, shared by the Bus
// (which mutes the per-tick channels on LCM's own receive socket, core/bus.hpp) and TickReader
// (a socket of its own that takes only those channels, core/tick_reader.hpp).
//
// Why: on one multicast group the kernel hands every datagram to every process's receive socket,
// and LCM's receive thread wakes once per datagram, whatever the process subscribed. A classic BPF
// socket filter on the channel name in LCM's short-message header ("LC02", sequence number, then
// the channel and '\0') lets the kernel drop a channel before any thread wakes for it
// (docs/timing.md, "What a tick costs"). Fragmented messages ("LC03") are never filtered: they go
// through LCM as before.

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace sirupp::core {

struct UdpmAddress {
  uint32_t group = 0;  // IPv4, host byte order
  int port = 0;
  int recv_buf_size = 0;  // the URL's recv_buf_size, 0 when not given
};

// The group and port of a udpm:// URL; "" means LCM_DEFAULT_URL, else LCM's default
// (udpm://239.255.76.67:7667). nullopt for another provider (memq://, file://) or a URL that
// does not parse (LCM itself then refuses it).
std::optional<UdpmAddress> ParseUdpmUrl(const std::string& url);

// "239.255.76.67:7667", for messages.
std::string DescribeUdpm(const UdpmAddress& address);

// At most this many channels in one filter, each at most 63 characters (LCM's limit).
constexpr size_t kMaxFilterChannels = 8;

// Puts a filter on socket `fd` that passes only LCM short messages on `channels` (full names)
// (keep_listed = true), or everything but them (keep_listed = false); replaces a filter already
// there. An empty `channels` with keep_listed = false takes the filter off. Returns false when the
// kernel refused (errno set) or the list is too long.
bool FilterChannels(int fd, const std::vector<std::string>& channels, bool keep_listed);

// The UDP sockets of this process bound to `port` (its open file descriptors, from
// /proc/self/fd), in ascending order. Empty when /proc is not there.
std::vector<int> UdpSocketsOnPort(int port);

}  // namespace sirupp::core
