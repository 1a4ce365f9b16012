#include "core/udpm_socket.hpp"

#include <arpa/inet.h>
#include <dirent.h>
#include <linux/filter.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <cstring>

namespace sirupp::core {
namespace {

constexpr uint32_t kShortMagic = 0x4c433032;  // "LC02": a message in one datagram
constexpr uint32_t kShortHeader = 8;          // magic, sequence number, then the channel + '\0'
// A socket filter sees the datagram from its UDP header on.
constexpr uint32_t kUdpHeader = 8;
constexpr size_t kMaxChannelName = 63;

// A classic BPF program: `keep` for an LCM short message on one of `channels`, else `other`.
// Every load is preceded by a length check, so a short datagram never ends the program early
// (which would drop it whatever `other` says).
std::vector<sock_filter> ChannelFilter(const std::vector<std::string>& channels, uint32_t keep,
                                       uint32_t other) {
  std::vector<sock_filter> code;
  // Jumps to `keep` are filled in once the program's length is known (unconditional jumps, 32-bit
  // offsets); conditional jumps (8-bit offsets) only ever go a few instructions on.
  std::vector<size_t> to_keep;
  const auto op = [&code](uint16_t code_op, uint32_t k) {
    code.push_back(sock_filter{code_op, 0, 0, k});
    return code.size() - 1;
  };
  // Not an LCM short message: `other` at once (true: skip the return).
  op(BPF_LD | BPF_W | BPF_LEN, 0);
  code[op(BPF_JMP | BPF_JGE | BPF_K, kUdpHeader + kShortHeader + 2)].jt = 1;
  op(BPF_RET | BPF_K, other);
  op(BPF_LD | BPF_W | BPF_ABS, kUdpHeader);
  code[op(BPF_JMP | BPF_JEQ | BPF_K, kShortMagic)].jt = 1;
  op(BPF_RET | BPF_K, other);
  for (const std::string& channel : channels) {
    const std::string name = channel + '\0';
    // Failing any comparison jumps to the next channel's first instruction (or to `other`).
    std::vector<size_t> to_next;
    op(BPF_LD | BPF_W | BPF_LEN, 0);
    to_next.push_back(op(BPF_JMP | BPF_JGE | BPF_K,
                         kUdpHeader + kShortHeader + static_cast<uint32_t>(name.size())));
    for (size_t at = 0; at < name.size();) {
      const size_t n = name.size() - at >= 4 ? 4 : name.size() - at >= 2 ? 2 : 1;
      uint32_t value = 0;
      for (size_t i = 0; i < n; ++i) {
        value = (value << 8) | static_cast<uint8_t>(name[at + i]);
      }
      const uint16_t size = n == 4 ? BPF_W : n == 2 ? BPF_H : BPF_B;
      op(static_cast<uint16_t>(BPF_LD | size | BPF_ABS),
         kUdpHeader + kShortHeader + static_cast<uint32_t>(at));
      to_next.push_back(op(BPF_JMP | BPF_JEQ | BPF_K, value));
      at += n;
    }
    to_keep.push_back(op(BPF_JMP | BPF_JA, 0));
    const size_t next = code.size();
    for (const size_t i : to_next) code[i].jf = static_cast<uint8_t>(next - i - 1);
  }
  op(BPF_RET | BPF_K, other);
  const size_t keep_at = op(BPF_RET | BPF_K, keep);
  for (const size_t i : to_keep) code[i].k = static_cast<uint32_t>(keep_at - i - 1);
  // A failed comparison of the last channel lands on the `other` return just before `keep`.
  return code;
}

}  // namespace

std::optional<UdpmAddress> ParseUdpmUrl(const std::string& given) {
  std::string url = given;
  if (url.empty()) {
    const char* from_environment = std::getenv("LCM_DEFAULT_URL");
    url = from_environment != nullptr && *from_environment != '\0'
              ? from_environment
              : "udpm://239.255.76.67:7667?ttl=0";
  }
  const std::string scheme = "udpm://";
  if (url.rfind(scheme, 0) != 0) return std::nullopt;
  const size_t query = url.find('?');
  const std::string network = url.substr(scheme.size(), query - scheme.size());
  const size_t colon = network.find(':');
  UdpmAddress address;
  address.port = 7667;
  if (colon != std::string::npos) {
    char* end = nullptr;
    const long port = std::strtol(network.c_str() + colon + 1, &end, 10);
    if (end == network.c_str() + colon + 1 || *end != '\0' || port <= 0 || port > 65535) {
      return std::nullopt;
    }
    address.port = static_cast<int>(port);
  }
  in_addr group{};
  if (inet_pton(AF_INET, network.substr(0, colon).c_str(), &group) != 1) return std::nullopt;
  address.group = ntohl(group.s_addr);
  if (query != std::string::npos) {
    const std::string options = "&" + url.substr(query + 1);
    const size_t at = options.find("&recv_buf_size=");
    if (at != std::string::npos) {
      address.recv_buf_size = std::atoi(options.c_str() + at + 15);
    }
  }
  return address;
}

std::string DescribeUdpm(const UdpmAddress& a) {
  in_addr group{};
  group.s_addr = htonl(a.group);
  char text[INET_ADDRSTRLEN] = "?";
  inet_ntop(AF_INET, &group, text, sizeof text);
  return std::string(text) + ":" + std::to_string(a.port);
}

bool FilterChannels(int fd, const std::vector<std::string>& channels, bool keep_listed) {
  if (channels.size() > kMaxFilterChannels) {
    errno = EINVAL;
    return false;
  }
  for (const std::string& channel : channels) {
    if (channel.empty() || channel.size() > kMaxChannelName) {
      errno = EINVAL;
      return false;
    }
  }
  if (channels.empty() && !keep_listed) {
    const int unused = 0;
    // ENOENT: there was no filter, which is what was asked.
    return setsockopt(fd, SOL_SOCKET, SO_DETACH_FILTER, &unused, sizeof unused) == 0 ||
           errno == ENOENT;
  }
  std::vector<sock_filter> code = keep_listed ? ChannelFilter(channels, 0xffffffffU, 0)
                                              : ChannelFilter(channels, 0, 0xffffffffU);
  sock_fprog program{};
  program.len = static_cast<unsigned short>(code.size());
  program.filter = code.data();
  return setsockopt(fd, SOL_SOCKET, SO_ATTACH_FILTER, &program, sizeof program) == 0;
}

std::vector<int> UdpSocketsOnPort(int port) {
  std::vector<int> found;
  DIR* dir = ::opendir("/proc/self/fd");
  if (dir == nullptr) return found;
  while (const dirent* entry = ::readdir(dir)) {
    char* end = nullptr;
    const long fd = std::strtol(entry->d_name, &end, 10);
    if (end == entry->d_name || *end != '\0' || fd == ::dirfd(dir)) continue;
    struct stat info {};
    if (::fstat(static_cast<int>(fd), &info) != 0 || !S_ISSOCK(info.st_mode)) continue;
    int type = 0;
    socklen_t type_size = sizeof type;
    sockaddr_in local{};
    socklen_t local_size = sizeof local;
    if (getsockopt(static_cast<int>(fd), SOL_SOCKET, SO_TYPE, &type, &type_size) != 0 ||
        type != SOCK_DGRAM ||
        getsockname(static_cast<int>(fd), reinterpret_cast<sockaddr*>(&local), &local_size) != 0 ||
        local.sin_family != AF_INET || ntohs(local.sin_port) != port) {
      continue;
    }
    found.push_back(static_cast<int>(fd));
  }
  ::closedir(dir);
  std::sort(found.begin(), found.end());
  return found;
}

}  // namespace sirupp::core
