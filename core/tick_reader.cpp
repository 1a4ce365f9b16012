#include "core/tick_reader.hpp"

#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <iostream>
#include <stdexcept>

#include "core/bus.hpp"

namespace sirupp::core {
namespace {

constexpr size_t kLcmShortHeader = 8;  // "LC02", sequence number, then the channel + '\0'
constexpr size_t kBatch = 64;
constexpr size_t kDatagramMax = 8192;  // a per-tick message of up to ~300 joints; longer: refused
// Per datagram: the receive time and the socket's drop count.
constexpr size_t kControlSize = CMSG_SPACE(sizeof(timeval)) + CMSG_SPACE(sizeof(uint32_t));

int64_t NowMicros() {
  timeval now{};
  gettimeofday(&now, nullptr);
  return static_cast<int64_t>(now.tv_sec) * 1000000 + now.tv_usec;
}

}  // namespace

TickReader::TickReader(const UdpmAddress& address, std::vector<std::string> full_channels,
                       int buffer_bytes, Pick pick)
    : address_(address), names_(full_channels) {
  if (full_channels.empty() || full_channels.size() > kMaxFilterChannels) {
    throw std::runtime_error("TickReader: 1 to 8 channels");
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
    throw std::runtime_error("cannot " + what + " on udpm " + DescribeUdpm(address_) + ": " +
                             reason);
  };
  fd_ = ::socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (fd_ < 0) fail("open a socket");
  const int on = 1;
  if (setsockopt(fd_, SOL_SOCKET, SO_REUSEADDR, &on, sizeof on) != 0) fail("share the port");
  if (setsockopt(fd_, SOL_SOCKET, SO_TIMESTAMP, &on, sizeof on) != 0) fail("ask for timestamps");
  // The drop count is a best effort: without it, sequence gaps still show a loss.
  if (pick == Pick::kCountDrops) setsockopt(fd_, SOL_SOCKET, SO_RXQ_OVFL, &on, sizeof on);
  const int want = buffer_bytes > 0 ? buffer_bytes : address_.recv_buf_size;
  if (want > 0) {
    // Beyond net.core.rmem_max only with CAP_NET_ADMIN; else as much as allowed.
    if (setsockopt(fd_, SOL_SOCKET, SO_RCVBUFFORCE, &want, sizeof want) != 0) {
      setsockopt(fd_, SOL_SOCKET, SO_RCVBUF, &want, sizeof want);
    }
  }
  // The filter first, so nothing else is queued between bind and attach... except what arrives in
  // that instant: Match() checks every datagram again.
  if (pick == Pick::kFilter && !FilterChannels(fd_, names_, true)) {
    fail("attach the channel filter");
  }
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
  controls_.resize(kBatch * kControlSize);
  batch_.resize(kBatch);
}

TickReader::~TickReader() {
  if (fd_ >= 0) ::close(fd_);
}

int TickReader::buffer_bytes() const {
  int size = 0;
  socklen_t length = sizeof size;
  return getsockopt(fd_, SOL_SOCKET, SO_RCVBUF, &size, &length) == 0 ? size : 0;
}

int TickReader::ReadBatch() {
  mmsghdr messages[kBatch];
  iovec vectors[kBatch];
  for (size_t i = 0; i < kBatch; ++i) {
    vectors[i].iov_base = buffers_.data() + i * kDatagramMax;
    vectors[i].iov_len = kDatagramMax;
    messages[i] = mmsghdr{};
    messages[i].msg_hdr.msg_iov = &vectors[i];
    messages[i].msg_hdr.msg_iovlen = 1;
    messages[i].msg_hdr.msg_control = controls_.data() + i * kControlSize;
    messages[i].msg_hdr.msg_controllen = kControlSize;
  }
  const int got = ::recvmmsg(fd_, messages, kBatch, MSG_DONTWAIT, nullptr);
  for (int i = 0; i < got; ++i) {
    const msghdr& header = messages[i].msg_hdr;
    Received& r = batch_[static_cast<size_t>(i)];
    r.data = static_cast<const uint8_t*>(vectors[i].iov_base);
    r.size = messages[i].msg_len;
    r.truncated = (header.msg_flags & MSG_TRUNC) != 0;
    r.recv_utime = 0;
    for (cmsghdr* c = CMSG_FIRSTHDR(&header); c != nullptr;
         c = CMSG_NXTHDR(const_cast<msghdr*>(&header), c)) {
      if (c->cmsg_level != SOL_SOCKET) continue;
      if (c->cmsg_type == SCM_TIMESTAMP) {
        timeval at{};
        std::memcpy(&at, CMSG_DATA(c), sizeof at);
        r.recv_utime = static_cast<int64_t>(at.tv_sec) * 1000000 + at.tv_usec;
      } else if (c->cmsg_type == SO_RXQ_OVFL) {
        uint32_t drops = 0;
        std::memcpy(&drops, CMSG_DATA(c), sizeof drops);
        dropped_ = drops;  // the socket's count since it was made
      }
    }
    if (r.recv_utime == 0) r.recv_utime = NowMicros();
  }
  return got;
}

int TickReader::Match(const uint8_t* datagram, size_t size) {
  if (size < kLcmShortHeader || std::memcmp(datagram, "LC02", 4) != 0) return -1;
  for (size_t i = 0; i < slots_.size(); ++i) {
    const std::string& header = slots_[i].header;
    if (size >= kLcmShortHeader + header.size() &&
        std::memcmp(datagram + kLcmShortHeader, header.data(), header.size()) == 0) {
      return static_cast<int>(i);
    }
  }
  return -1;
}

int TickReader::Drain() {
  return DrainWith([this](size_t index, const uint8_t* data, size_t size, int64_t recv_utime) {
    Slot& slot = slots_[index];
    slot.data.assign(data, data + size);
    slot.recv_utime = recv_utime;
    slot.fresh = true;
  });
}

std::unique_ptr<TickFeed> TickFeed::Open(Bus& bus, std::vector<std::string> full_channels,
                                         const std::string& who, int buffer_bytes,
                                         TickReader::Pick pick) {
  const std::optional<UdpmAddress> address = ParseUdpmUrl(bus.url());
  if (!address) return nullptr;
  try {
    auto reader = std::make_unique<TickReader>(*address, full_channels, buffer_bytes, pick);
    if (!bus.TakeOffLcm(full_channels)) {
      std::cerr << who
                << ": LCM's receive socket could not be filtered; the per-tick channels go "
                   "through LCM\n";
      return nullptr;
    }
    return std::unique_ptr<TickFeed>(new TickFeed(bus, std::move(reader)));
  } catch (const std::exception& e) {
    std::cerr << who << ": " << e.what() << "; the per-tick channels go through LCM\n";
    return nullptr;
  }
}

TickFeed::TickFeed(Bus& bus, std::unique_ptr<TickReader> reader)
    : bus_(bus), reader_(std::move(reader)) {}

TickFeed::~TickFeed() { bus_.PutBackOnLcm(reader_->channels()); }

int TickFeed::DeliverNewest() {
  const int read = reader_->Drain();
  reader_->TakeNewest(
      [this](const std::string& channel, const uint8_t* data, int size, int64_t recv_utime) {
        bus_.DeliverRecorded(channel, data, size, recv_utime, true);
      });
  return read;
}

}  // namespace sirupp::core
