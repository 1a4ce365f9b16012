#include "class/notebook_bridge.hpp"

#include <errno.h>
#include <fcntl.h>
#include <lcm/lcm.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cstring>
#include <stdexcept>
#include <string_view>
#include <thread>

#include "core/printable.hpp"

namespace sirupp::classroom {
namespace {

constexpr char kMagic[4] = {'S', 'L', 'B', '1'};
constexpr size_t kHeader = 12;
constexpr size_t kMaxPendingOut = 16u << 20;  // a peer that does not read: drop beyond this

void PutU32(std::string& out, uint32_t value) {
  for (int shift = 24; shift >= 0; shift -= 8)
    out.push_back(static_cast<char>((value >> shift) & 0xff));
}

uint32_t GetU32(const char* at) {
  uint32_t value = 0;
  for (int i = 0; i < 4; ++i) value = (value << 8) | static_cast<unsigned char>(at[i]);
  return value;
}

sockaddr_un UnixAddress(const std::string& path) {
  sockaddr_un address{};
  address.sun_family = AF_UNIX;
  if (path.empty() || path.size() >= sizeof(address.sun_path)) {
    throw std::runtime_error("socket path '" + core::Printable(path, 120) + "': 1 to " +
                             std::to_string(sizeof(address.sun_path) - 1) + " bytes allowed");
  }
  std::memcpy(address.sun_path, path.c_str(), path.size() + 1);
  return address;
}

void SetNonBlocking(int fd) { ::fcntl(fd, F_SETFL, ::fcntl(fd, F_GETFL) | O_NONBLOCK); }

// Everything one side holds while it runs.
struct Side {
  const BridgeOptions& options;
  lcm_t* lcm = nullptr;
  int peer = -1;
  std::string out;  // bytes for the peer not yet written
  BridgeFrameReader reader;
  EchoFilter echo;
  int64_t to_socket = 0;
  int64_t from_socket = 0;
  int64_t dropped = 0;

  explicit Side(const BridgeOptions& o) : options(o) {}

  static void OnMessage(const lcm_recv_buf_t* buffer, const char* channel, void* user) {
    auto* self = static_cast<Side*>(user);
    const std::string name(channel);
    // LCM's udpm self-test of each new instance on the bus: that instance's own, never carried.
    if (name == "LCM_SELF_TEST") return;
    const std::string data(static_cast<const char*>(buffer->data), buffer->data_size);
    if (self->echo.IsEcho(name, data, EchoFilter::Clock::now())) return;
    if (self->peer < 0 || data.size() > kMaxFrameData || name.empty() || name.size() > 255) return;
    if (self->out.size() > kMaxPendingOut) {
      ++self->dropped;
      return;
    }
    self->out += EncodeBridgeFrame(name, data);
    ++self->to_socket;
  }

  void Publish(const BridgeFrameReader::Frame& frame) {
    echo.Published(frame.first, frame.second, EchoFilter::Clock::now());
    if (lcm_publish(lcm, frame.first.c_str(), frame.second.data(),
                    static_cast<unsigned int>(frame.second.size())) != 0) {
      options.log("could not publish on " + core::Printable(frame.first, 80));
    }
    ++from_socket;
  }

  void ClosePeer(const std::string& why) {
    if (peer >= 0) ::close(peer);
    peer = -1;
    out.clear();
    reader = BridgeFrameReader();
    if (!why.empty()) options.log(why);
  }

  // Reads what the peer sent; false when the connection ended.
  bool ReadPeer() {
    char buffer[65536];
    for (;;) {
      const ssize_t n = ::read(peer, buffer, sizeof buffer);
      if (n > 0) {
        try {
          for (const auto& frame : reader.Feed(buffer, static_cast<size_t>(n))) Publish(frame);
        } catch (const std::exception& e) {
          ClosePeer(std::string("bad frame from the peer: ") + e.what() + "; connection closed");
          return false;
        }
        continue;
      }
      if (n == 0) {
        ClosePeer("the peer closed the connection");
        return false;
      }
      if (errno == EINTR) continue;
      if (errno == EAGAIN || errno == EWOULDBLOCK) return true;
      ClosePeer(std::string("reading from the peer: ") + std::strerror(errno));
      return false;
    }
  }

  bool WritePeer() {
    while (!out.empty()) {
      const ssize_t n = ::send(peer, out.data(), out.size(), MSG_NOSIGNAL);
      if (n > 0) {
        out.erase(0, static_cast<size_t>(n));
        continue;
      }
      if (n < 0 && errno == EINTR) continue;
      if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) return true;
      ClosePeer(std::string("writing to the peer: ") + std::strerror(errno));
      return false;
    }
    return true;
  }
};

int ConnectWithin(const std::string& path, double wait_s, const std::function<bool()>& keep) {
  const sockaddr_un address = UnixAddress(path);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(wait_s);
  for (;;) {
    const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
    if (fd < 0) throw std::runtime_error(std::string("socket: ") + std::strerror(errno));
    if (::connect(fd, reinterpret_cast<const sockaddr*>(&address), sizeof address) == 0) return fd;
    const int error = errno;
    ::close(fd);
    if (std::chrono::steady_clock::now() > deadline || !keep()) {
      throw std::runtime_error("cannot connect to " + path + ": " + std::strerror(error));
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
}

int ListenOn(const std::string& path) {
  const sockaddr_un address = UnixAddress(path);
  ::unlink(path.c_str());
  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) throw std::runtime_error(std::string("socket: ") + std::strerror(errno));
  if (::bind(fd, reinterpret_cast<const sockaddr*>(&address), sizeof address) != 0 ||
      ::listen(fd, 4) != 0) {
    const int error = errno;
    ::close(fd);
    throw std::runtime_error("cannot listen on " + path + ": " + std::strerror(error));
  }
  return fd;
}

}  // namespace

std::string EncodeBridgeFrame(const std::string& channel, const std::string& data) {
  std::string out(kMagic, sizeof kMagic);
  PutU32(out, static_cast<uint32_t>(channel.size()));
  PutU32(out, static_cast<uint32_t>(data.size()));
  out += channel;
  out += data;
  return out;
}

std::vector<BridgeFrameReader::Frame> BridgeFrameReader::Feed(const char* bytes, size_t size) {
  pending_.append(bytes, size);
  std::vector<Frame> frames;
  size_t at = 0;
  while (pending_.size() - at >= kHeader) {
    const char* head = pending_.data() + at;
    if (std::memcmp(head, kMagic, sizeof kMagic) != 0) {
      throw std::runtime_error("frame start: '" + core::Printable(std::string(head, 4), 8) +
                               "'; expected 'SLB1'");
    }
    const uint32_t channel_size = GetU32(head + 4);
    const uint32_t data_size = GetU32(head + 8);
    if (channel_size == 0 || channel_size > 255) {
      throw std::runtime_error("channel length " + std::to_string(channel_size) +
                               "; allowed: 1 to 255");
    }
    if (data_size > kMaxFrameData) {
      throw std::runtime_error("data length " + std::to_string(data_size) + "; allowed: at most " +
                               std::to_string(kMaxFrameData));
    }
    if (pending_.size() - at < kHeader + channel_size + data_size) break;
    frames.emplace_back(pending_.substr(at + kHeader, channel_size),
                        pending_.substr(at + kHeader + channel_size, data_size));
    at += kHeader + channel_size + data_size;
  }
  pending_.erase(0, at);
  return frames;
}

uint64_t EchoFilter::Key(const std::string& channel, const std::string& data) {
  const uint64_t a = std::hash<std::string_view>{}(channel);
  const uint64_t b = std::hash<std::string_view>{}(data);
  return a * 0x9e3779b97f4a7c15ull ^ b ^ (static_cast<uint64_t>(data.size()) << 1);
}

void EchoFilter::Prune(Clock::time_point now) {
  for (auto it = published_.begin(); it != published_.end();) {
    it = now - it->second > keep_ ? published_.erase(it) : std::next(it);
  }
}

void EchoFilter::Published(const std::string& channel, const std::string& data,
                           Clock::time_point now) {
  if (published_.size() > 4096) Prune(now);
  published_.emplace(Key(channel, data), now);
}

bool EchoFilter::IsEcho(const std::string& channel, const std::string& data,
                        Clock::time_point now) {
  const auto found = published_.find(Key(channel, data));
  if (found == published_.end()) return false;
  const bool fresh = now - found->second <= keep_;
  published_.erase(found);
  return fresh;
}

size_t EchoFilter::size() const { return published_.size(); }

std::pair<int64_t, int64_t> RunBridge(const BridgeOptions& options) {
  Side side(options);
  side.lcm = lcm_create(options.lcm_url.c_str());
  if (side.lcm == nullptr) {
    throw std::runtime_error("cannot join the bus " + options.lcm_url +
                             " (LCM: a udpm bus needs a multicast route)");
  }
  lcm_subscription_t* subscription = lcm_subscribe(side.lcm, ".*", &Side::OnMessage, &side);
  lcm_subscription_set_queue_capacity(subscription, 1000);
  int listener = -1;
  try {
    if (options.listen) {
      listener = ListenOn(options.socket_path);
    } else {
      side.peer = ConnectWithin(options.socket_path, options.connect_wait_s, options.keep_running);
      SetNonBlocking(side.peer);
    }
  } catch (...) {
    lcm_destroy(side.lcm);
    throw;
  }
  options.log(std::string(options.listen ? "listening on " : "connected to ") +
              options.socket_path + ", bus " + options.lcm_url);
  const int lcm_fd = lcm_get_fileno(side.lcm);
  while (options.keep_running()) {
    if (!options.listen && side.peer < 0) {
      // The outer side went (the spawner moved it to the rig's new bus): connect again.
      try {
        side.peer =
            ConnectWithin(options.socket_path, options.connect_wait_s, options.keep_running);
      } catch (const std::exception& e) {
        options.log(e.what());
        break;
      }
      SetNonBlocking(side.peer);
      options.log("connected again to " + options.socket_path);
    }
    pollfd fds[3];
    nfds_t count = 0;
    fds[count++] = pollfd{lcm_fd, POLLIN, 0};
    const int peer_index = side.peer >= 0 ? static_cast<int>(count) : -1;
    if (side.peer >= 0) {
      fds[count++] =
          pollfd{side.peer, static_cast<short>(POLLIN | (side.out.empty() ? 0 : POLLOUT)), 0};
    }
    const int listen_index = listener >= 0 ? static_cast<int>(count) : -1;
    if (listener >= 0) fds[count++] = pollfd{listener, POLLIN, 0};
    const int ready = ::poll(fds, count, 200);
    if (ready < 0 && errno != EINTR) break;
    if (ready <= 0) continue;
    if (fds[0].revents & POLLIN) lcm_handle(side.lcm);
    if (peer_index >= 0 && side.peer >= 0) {
      const short events = fds[peer_index].revents;
      if (events & (POLLIN | POLLHUP | POLLERR)) side.ReadPeer();
    }
    if (side.peer >= 0 && !side.out.empty()) side.WritePeer();
    if (listen_index >= 0 && (fds[listen_index].revents & POLLIN)) {
      const int fd = ::accept4(listener, nullptr, nullptr, SOCK_CLOEXEC | SOCK_NONBLOCK);
      if (fd >= 0) {
        side.ClosePeer(side.peer >= 0 ? "a new peer replaces the old one" : "");
        side.peer = fd;
        options.log("peer connected");
      }
    }
  }
  if (side.dropped > 0) {
    options.log(std::to_string(side.dropped) + " message(s) dropped: the peer did not read");
  }
  side.ClosePeer("");
  if (listener >= 0) {
    ::close(listener);
    ::unlink(options.socket_path.c_str());
  }
  lcm_unsubscribe(side.lcm, subscription);
  lcm_destroy(side.lcm);
  return {side.to_socket, side.from_socket};
}

}  // namespace sirupp::classroom
