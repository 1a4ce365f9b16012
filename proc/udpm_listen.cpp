#include "proc/udpm_listen.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <stdexcept>

namespace sirupp::proc {
namespace {

// An open socket, closed on every path out.
struct Socket {
  int fd = -1;
  ~Socket() {
    if (fd >= 0) ::close(fd);
  }
};

// "LCM channel NAME" for an LCM datagram (short: "LC02", fragment: "LC03"), else "".
std::string LcmChannel(const unsigned char* data, size_t size) {
  if (size < 9 || data[0] != 'L' || data[1] != 'C' || data[2] != '0') return "";
  size_t start = 0;
  if (data[3] == '2') {
    start = 8;  // magic, sequence number
  } else if (data[3] == '3' && size > 20) {
    // magic, sequence, size, offset, fragment number, count; the name in fragment 0 only
    if (data[16] != 0 || data[17] != 0) return "";
    start = 20;
  } else {
    return "";
  }
  size_t end = start;
  while (end < size && end - start < 64 && data[end] != 0) ++end;
  if (end == start || end >= size || data[end] != 0) return "";
  return "LCM channel " + std::string(reinterpret_cast<const char*>(data) + start, end - start);
}

}  // namespace

std::string HeardOnUdpm(const std::string& group, int port, double seconds) {
  const std::string where = group + ":" + std::to_string(port);
  if (port < 1 || port > 65535) {
    throw std::invalid_argument("udpm port " + std::to_string(port) + ": allowed 1..65535");
  }
  in_addr group_address{};
  if (::inet_pton(AF_INET, group.c_str(), &group_address) != 1) {
    throw std::invalid_argument("udpm group '" + group + "': allowed an IPv4 multicast address");
  }
  const auto fail = [&where](const std::string& step) {
    return std::runtime_error("cannot listen on " + where + ": " + step + ": " +
                              std::strerror(errno));
  };
  Socket socket;
  socket.fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, IPPROTO_UDP);
  if (socket.fd < 0) throw fail("socket");
  const int one = 1;
  if (::setsockopt(socket.fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one) != 0) {
    throw fail("SO_REUSEADDR");
  }
  sockaddr_in bind_to{};
  bind_to.sin_family = AF_INET;
  bind_to.sin_addr.s_addr = htonl(INADDR_ANY);
  bind_to.sin_port = htons(static_cast<uint16_t>(port));
  if (::bind(socket.fd, reinterpret_cast<const sockaddr*>(&bind_to), sizeof bind_to) != 0) {
    throw fail("bind");
  }
  ip_mreq membership{};
  membership.imr_multiaddr = group_address;
  membership.imr_interface.s_addr = htonl(INADDR_ANY);
  if (::setsockopt(socket.fd, IPPROTO_IP, IP_ADD_MEMBERSHIP, &membership, sizeof membership) != 0) {
    throw fail("joining the group");
  }
  using Clock = std::chrono::steady_clock;
  const auto deadline = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                           std::chrono::duration<double>(seconds));
  unsigned char buffer[2048];
  while (true) {
    const auto left =
        std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
    if (left <= 0) return "";
    pollfd wait{socket.fd, POLLIN, 0};
    const int ready = ::poll(&wait, 1, static_cast<int>(left));
    if (ready < 0 && errno == EINTR) continue;
    if (ready < 0) throw fail("poll");
    if (ready == 0) return "";
    sockaddr_in from{};
    socklen_t from_size = sizeof from;
    const ssize_t got = ::recvfrom(socket.fd, buffer, sizeof buffer, MSG_DONTWAIT,
                                   reinterpret_cast<sockaddr*>(&from), &from_size);
    if (got < 0) continue;
    char text[INET_ADDRSTRLEN] = "?";
    ::inet_ntop(AF_INET, &from.sin_addr, text, sizeof text);
    const std::string channel = LcmChannel(buffer, static_cast<size_t>(got));
    return "a datagram on " + where + " from " + text + ":" + std::to_string(ntohs(from.sin_port)) +
           (channel.empty() ? "" : " (" + channel + ")");
  }
}

}  // namespace sirupp::proc
