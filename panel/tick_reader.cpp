#include "panel/tick_reader.hpp"

#include <arpa/inet.h>
#include <dirent.h>
#include <linux/filter.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/time.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <stdexcept>

namespace sirupp::panel {
namespace {

constexpr uint32_t kShortMagic = 0x4c433032;  // "LC02": a message in one datagram
constexpr size_t kShortHeader = 8;            // magic, sequence number, then the channel + '\0'
// A socket filter sees the datagram from its UDP header on.
constexpr uint32_t kUdpHeader = 8;
constexpr size_t kBatch = 64;
constexpr size_t kDatagramMax = 8192;  // a per-tick message of up to ~300 joints; longer: refused
constexpr size_t kMaxChannels = 8;

std::string Describe(const UdpmAddress& a) {
  in_addr group{};
  group.s_addr = htonl(a.group);
  char text[INET_ADDRSTRLEN] = "?";
  inet_ntop(AF_INET, &group, text, sizeof text);
  return std::string(text) + ":" + std::to_string(a.port);
}

// A classic BPF program: `keep` for an LCM short message on one of `channels`, else `other`.
// Every load is preceded by a length check, so a short datagram never ends the program early
// (which would drop it whatever `other` says).
std::vector<sock_filter> ChannelFilter(const std::vector<std::string>& channels, uint32_t keep,
                                       uint32_t other) {
  std::vector<sock_filter> code;
  // Jumps are filled in once the program's length is known: `to_other` holds the conditional
  // jumps whose "false" branch goes to the `other` return, `to_keep` the jumps to `keep`.
  std::vector<size_t> to_other;
  std::vector<size_t> to_keep;
  const auto op = [&code](uint16_t code_op, uint32_t k) {
    code.push_back(sock_filter{code_op, 0, 0, k});
    return code.size() - 1;
  };
  op(BPF_LD | BPF_W | BPF_LEN, 0);
  to_other.push_back(op(BPF_JMP | BPF_JGE | BPF_K, kUdpHeader + kShortHeader + 2));
  op(BPF_LD | BPF_W | BPF_ABS, kUdpHeader);
  to_other.push_back(op(BPF_JMP | BPF_JEQ | BPF_K, kShortMagic));
  for (size_t c = 0; c < channels.size(); ++c) {
    const std::string name = channels[c] + '\0';
    // Failing any comparison jumps to the next channel's first instruction (or to `other`).
    std::vector<size_t> to_next;
    op(BPF_LD | BPF_W | BPF_LEN, 0);
    to_next.push_back(op(BPF_JMP | BPF_JGE | BPF_K,
                         kUdpHeader + static_cast<uint32_t>(kShortHeader + name.size())));
    for (size_t at = 0; at < name.size();) {
      const size_t n = name.size() - at >= 4 ? 4 : name.size() - at >= 2 ? 2 : 1;
      uint32_t value = 0;
      for (size_t i = 0; i < n; ++i) {
        value = (value << 8) | static_cast<uint8_t>(name[at + i]);
      }
      const uint16_t size = n == 4 ? BPF_W : n == 2 ? BPF_H : BPF_B;
      op(static_cast<uint16_t>(BPF_LD | size | BPF_ABS),
         kUdpHeader + static_cast<uint32_t>(kShortHeader + at));
      to_next.push_back(op(BPF_JMP | BPF_JEQ | BPF_K, value));
      at += n;
    }
    to_keep.push_back(op(BPF_JMP | BPF_JA, 0));
    const size_t next = code.size();
    for (const size_t i : to_next) code[i].jf = static_cast<uint8_t>(next - i - 1);
  }
  const size_t other_at = op(BPF_RET | BPF_K, other);
  const size_t keep_at = op(BPF_RET | BPF_K, keep);
  for (const size_t i : to_other) {
    if (other_at - i - 1 > 255) throw std::runtime_error("TickReader: channel names too long");
    code[i].jf = static_cast<uint8_t>(other_at - i - 1);
  }
  for (const size_t i : to_keep) code[i].k = static_cast<uint32_t>(keep_at - i - 1);
  // A channel's failed comparison past the last channel lands on `other_at` (next == other_at).
  return code;
}

bool Attach(int fd, std::vector<sock_filter>& code) {
  sock_fprog program{};
  program.len = static_cast<unsigned short>(code.size());
  program.filter = code.data();
  return setsockopt(fd, SOL_SOCKET, SO_ATTACH_FILTER, &program, sizeof program) == 0;
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

TickReader::TickReader(const UdpmAddress& address, std::vector<std::string> full_channels,
                       std::vector<std::string> muted)
    : address_(address), muted_(std::move(muted)) {
  if (full_channels.empty() || full_channels.size() > kMaxChannels ||
      muted_.size() > kMaxChannels) {
    throw std::runtime_error("TickReader: 1 to 8 channels read, at most 8 muted");
  }
  for (std::string& channel : full_channels) {
    Slot slot;
    slot.header = channel + '\0';
    slot.channel = std::move(channel);
    slots_.push_back(std::move(slot));
  }
  const auto fail = [this](const std::string& what) {
    const std::string reason = std::strerror(errno);
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
    throw std::runtime_error("panel: cannot " + what + " on udpm " + Describe(address_) + ": " +
                             reason);
  };
  fd_ = ::socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (fd_ < 0) fail("open a socket");
  const int on = 1;
  if (setsockopt(fd_, SOL_SOCKET, SO_REUSEADDR, &on, sizeof on) != 0) fail("share the port");
  if (setsockopt(fd_, SOL_SOCKET, SO_TIMESTAMP, &on, sizeof on) != 0) fail("ask for timestamps");
  if (address_.recv_buf_size > 0) {
    setsockopt(fd_, SOL_SOCKET, SO_RCVBUF, &address_.recv_buf_size,
               sizeof address_.recv_buf_size);  // as LCM: a best effort
  }
  std::vector<std::string> names;
  for (const Slot& slot : slots_) names.push_back(slot.channel);
  // The filter first, so nothing else is queued between bind and attach... except what arrives in
  // that instant: Keep() checks every datagram again.
  std::vector<sock_filter> code = ChannelFilter(names, 0xffffffffU, 0);
  if (!Attach(fd_, code)) fail("attach the channel filter");
  sockaddr_in local{};
  local.sin_family = AF_INET;
  local.sin_addr.s_addr = htonl(INADDR_ANY);
  local.sin_port = htons(static_cast<uint16_t>(address_.port));
  if (::bind(fd_, reinterpret_cast<sockaddr*>(&local), sizeof local) != 0) fail("bind the port");
  ip_mreq join{};
  join.imr_multiaddr.s_addr = htonl(address_.group);
  join.imr_interface.s_addr = htonl(INADDR_ANY);
  if (setsockopt(fd_, IPPROTO_IP, IP_ADD_MEMBERSHIP, &join, sizeof join) != 0) fail("join");
  buffers_.resize(kBatch * kDatagramMax);
  controls_.resize(kBatch * CMSG_SPACE(sizeof(timeval)));
}

TickReader::~TickReader() {
  if (fd_ >= 0) ::close(fd_);
}

int TickReader::MuteOnLcmSockets() const {
  std::vector<sock_filter> code = ChannelFilter(muted_, 0, 0xffffffffU);
  int muted = 0;
  DIR* dir = ::opendir("/proc/self/fd");
  if (dir == nullptr) return 0;
  while (const dirent* entry = ::readdir(dir)) {
    char* end = nullptr;
    const long fd = std::strtol(entry->d_name, &end, 10);
    if (end == entry->d_name || *end != '\0' || fd == fd_ || fd == ::dirfd(dir)) continue;
    struct stat info {};
    if (::fstat(static_cast<int>(fd), &info) != 0 || !S_ISSOCK(info.st_mode)) continue;
    int type = 0;
    socklen_t type_size = sizeof type;
    sockaddr_in local{};
    socklen_t local_size = sizeof local;
    if (getsockopt(static_cast<int>(fd), SOL_SOCKET, SO_TYPE, &type, &type_size) != 0 ||
        type != SOCK_DGRAM ||
        getsockname(static_cast<int>(fd), reinterpret_cast<sockaddr*>(&local), &local_size) != 0 ||
        local.sin_family != AF_INET || ntohs(local.sin_port) != address_.port) {
      continue;
    }
    if (Attach(static_cast<int>(fd), code)) ++muted;
  }
  ::closedir(dir);
  return muted;
}

int TickReader::Drain() {
  mmsghdr messages[kBatch];
  iovec vectors[kBatch];
  const size_t control_size = CMSG_SPACE(sizeof(timeval));
  int total = 0;
  for (;;) {
    for (size_t i = 0; i < kBatch; ++i) {
      vectors[i].iov_base = buffers_.data() + i * kDatagramMax;
      vectors[i].iov_len = kDatagramMax;
      messages[i] = mmsghdr{};
      messages[i].msg_hdr.msg_iov = &vectors[i];
      messages[i].msg_hdr.msg_iovlen = 1;
      messages[i].msg_hdr.msg_control = controls_.data() + i * control_size;
      messages[i].msg_hdr.msg_controllen = control_size;
    }
    const int got = ::recvmmsg(fd_, messages, kBatch, MSG_DONTWAIT, nullptr);
    if (got <= 0) break;  // EAGAIN: nothing more; other errors: tried again next round
    for (int i = 0; i < got; ++i) {
      const msghdr& header = messages[i].msg_hdr;
      int64_t recv_utime = 0;
      for (cmsghdr* c = CMSG_FIRSTHDR(&header); c != nullptr;
           c = CMSG_NXTHDR(const_cast<msghdr*>(&header), c)) {
        if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SCM_TIMESTAMP) {
          timeval at{};
          std::memcpy(&at, CMSG_DATA(c), sizeof at);
          recv_utime = static_cast<int64_t>(at.tv_sec) * 1000000 + at.tv_usec;
        }
      }
      if (recv_utime == 0) {
        timeval now{};
        gettimeofday(&now, nullptr);
        recv_utime = static_cast<int64_t>(now.tv_sec) * 1000000 + now.tv_usec;
      }
      if ((header.msg_flags & MSG_TRUNC) != 0) {
        ++refused_;
        continue;
      }
      Keep(static_cast<const uint8_t*>(vectors[i].iov_base), messages[i].msg_len, recv_utime);
    }
    datagrams_ += got;
    total += got;
    if (static_cast<size_t>(got) < kBatch) break;  // the queue is empty: no EAGAIN call needed
  }
  return total;
}

void TickReader::Keep(const uint8_t* datagram, size_t size, int64_t recv_utime) {
  if (size < kShortHeader || std::memcmp(datagram, "LC02", 4) != 0) {
    ++refused_;
    return;
  }
  for (Slot& slot : slots_) {
    const size_t start = kShortHeader + slot.header.size();
    if (size < start ||
        std::memcmp(datagram + kShortHeader, slot.header.data(), slot.header.size()) != 0) {
      continue;
    }
    slot.data.assign(datagram + start, datagram + size);
    slot.recv_utime = recv_utime;
    slot.fresh = true;
    return;
  }
  ++refused_;
}

}  // namespace sirupp::panel
