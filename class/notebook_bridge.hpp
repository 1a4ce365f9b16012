#pragma once
// A bus bridge over a Unix socket (sirupp-notebook-bridge; docs/notebooks.md "The student's own
// rig"): a student's notebook kernel runs in a sandbox with no network but its own `lo`, so it
// cannot join the class rig's udpm bus on the host. Two bridges, one each side, carry every LCM
// message both ways over one Unix-domain socket: the outer one (started by the hub's spawner beside
// the sandbox, listening) joins the student's rig bus, the inner one (in the sandbox, connecting)
// joins the sandbox's own udpm bus, the kernel's LCM_DEFAULT_URL. Only that student's rig is
// reached: the spawner gives the outer bridge that rig's URL, and nothing in the sandbox can name
// another.
//
// No echo: a message a bridge publishes comes back to its own subscription (LCM loops udpm and
// memq back to the sender); each bridge remembers what it just published (channel and bytes, for
// 2 s) and does not send that back over the socket. LCM's self-test messages (LCM_SELF_TEST,
// each udpm instance's own) are not carried.
//
// Frames on the socket: "SLB1", channel length (u32, big-endian), data length (u32), channel,
// data. A channel is 1 to 255 bytes, data at most kMaxFrameData; a bad frame ends the connection
// with an error naming the field and the value.

#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <vector>

namespace sirupp::classroom {

inline constexpr uint32_t kMaxFrameData = 4u << 20;  // 4 MiB: larger than any rig message

// One frame's bytes.
std::string EncodeBridgeFrame(const std::string& channel, const std::string& data);

// Takes bytes as they come and yields whole frames; throws std::runtime_error naming the bad field.
class BridgeFrameReader {
 public:
  using Frame = std::pair<std::string, std::string>;  // channel, data
  // Appends `bytes`; returns the frames completed by them.
  std::vector<Frame> Feed(const char* bytes, size_t size);

 private:
  std::string pending_;
};

// What a bridge just published, so that it is not sent back (echo).
class EchoFilter {
 public:
  using Clock = std::chrono::steady_clock;
  explicit EchoFilter(double keep_s = 2.0)
      : keep_(std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(keep_s))) {}
  void Published(const std::string& channel, const std::string& data, Clock::time_point now);
  // True (and forgotten) when this message is the echo of one published; false: a new one.
  bool IsEcho(const std::string& channel, const std::string& data, Clock::time_point now);
  size_t size() const;

 private:
  static uint64_t Key(const std::string& channel, const std::string& data);
  void Prune(Clock::time_point now);
  Clock::duration keep_;
  std::multimap<uint64_t, Clock::time_point> published_;
};

struct BridgeOptions {
  std::string lcm_url;         // the bus this side joins
  std::string socket_path;     // the Unix socket
  bool listen = false;         // true: bind and accept (the outer side); false: connect (inner)
  double connect_wait_s = 10;  // connect: how long to retry while the socket is not there
  std::function<bool()> keep_running;
  std::function<void(const std::string&)> log;
};

// Runs the bridge until keep_running() turns false (checked every 200 ms) or, connecting, the
// connection ends and cannot be made again within connect_wait_s. Listening, a peer that goes is
// replaced by the next one. Throws
// std::runtime_error for a bus or socket that cannot be opened. Returns the messages carried each
// way (to the socket, from it).
std::pair<int64_t, int64_t> RunBridge(const BridgeOptions& options);

}  // namespace sirupp::classroom
