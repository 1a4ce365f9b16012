#pragma once
// The real arm's relay for a rig that runs as a job on a cluster node (issue 39).
//
// The turn manager (turns/turn_manager.hpp) relays the holder's rig bus to the bridge's bus. A
// local rig's bus is a udpm port of the class server's machine; a job's rig bus is a udpm port of
// its node with ttl=0, which the class server cannot hear. So for a job the class server's side
// is a bus inside its own process (memq://) that the manager opens like any rig's bus, and a
// RemoteRigBus carries the channels the manager uses between it and the node, over the rig
// job's HTTP endpoint with the rig's secret (POST kRelayPath, class/rig_job.hpp):
//
//   node -> class server (kUpChannels): ARM_MOVE, ARM_GAINS, CONTROLLER_STATUS, ROBOT_MODEL,
//       HARDWARE_COMMAND, ESTOP, CONTROLLER_REPLY, CONTROLLER_GAINS, and the per-tick
//       SIM_ARM_STATE and ARM_SETPOINT (only the newest of each between two exchanges)
//   class server -> node (kDownChannels): REAL_ARM_STATE, REAL_ARM_SETPOINT, REAL_ARM_GAINS,
//       HARDWARE_STATUS, HARDWARE_REPLY, HEARTBEAT (the bridge's), ARM_TARGET and ARM_PLAN (the
//       handover's move of the virtual arm)
//
// No channel is in both lists, so nothing is carried back to where it came from. Each exchange is
// one POST: its body the messages for the node, its answer the node's messages since the last
// one. The class server asks every few milliseconds while the manager holds the bus (a handover
// or a turn) and not at all otherwise. On the node a RelayTap listens on the rig's bus from the
// first exchange until none came for kTapIdleS.
//
// The network this needs: the class server reaches the node's endpoint port over TCP (the same
// port as the proxied pages); no multicast crosses machines (docs/cluster.md, "The real arm").

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "class/rig_proxy.hpp"
#include "core/bus.hpp"

namespace sirupp::classroom {

inline constexpr const char* kRelayPath = "/relay";
inline constexpr double kTapIdleS = 5;  // a tap with no exchange for this long stops listening

// One LCM message as carried: its full channel name and its encoded bytes.
struct RelayFrame {
  std::string channel;
  std::string bytes;
};

// The channels carried each way (names without prefix; a rig's bus has none).
const std::vector<std::string>& UpChannels();
const std::vector<std::string>& DownChannels();

// Frames as one body: per frame a 1-byte channel length, the channel, a 4-byte big-endian length,
// the bytes. DecodeFrames throws std::runtime_error naming the offset of a malformed body.
std::string EncodeFrames(const std::vector<RelayFrame>& frames);
std::vector<RelayFrame> DecodeFrames(const std::string& body);

// The node's side: listens on the rig's bus for the up channels (own thread, own Bus) and
// publishes what the class server sends. Thread-safe.
class RelayTap {
 public:
  explicit RelayTap(std::string lcm_url);
  ~RelayTap();
  RelayTap(const RelayTap&) = delete;
  RelayTap& operator=(const RelayTap&) = delete;

  // Publishes `down` on the rig's bus and returns the up frames heard since the last exchange
  // (encoded). Starts listening on the first call, and again after kTapIdleS without one. Throws
  // std::runtime_error on a malformed body or a bus that cannot be opened.
  std::string Exchange(const std::string& down);

 private:
  void Listen();
  static void OnMessage(const lcm::ReceiveBuffer* rbuf, const std::string& channel, RelayTap* self);

  std::string url_;
  std::mutex mutex_;
  std::condition_variable opened_;
  std::vector<RelayFrame> up_;   // heard, not yet fetched (the newest only per per-tick one)
  std::deque<RelayFrame> down_;  // to publish
  std::string open_error_;       // the listener could not open the bus
  bool listening_ = false;       // the listener thread runs
  bool bus_open_ = false;
  bool stopping_ = false;
  std::chrono::steady_clock::time_point last_exchange_;
  std::thread listener_;
  size_t dropped_ = 0;  // up frames dropped because the class server did not fetch them
};

// The class server's side: a bus in this process (memq://) for the turn manager, and a thread
// that exchanges its messages with the node's RelayTap. The bus is used on the manager's thread
// only: Pump() there hands it the node's messages; the down channels' messages are taken from it
// by a raw subscription while the manager handles it.
class RemoteRigBus {
 public:
  RemoteRigBus(std::string student, RigEndpoint endpoint);
  ~RemoteRigBus();  // Close() and joins the thread
  RemoteRigBus(const RemoteRigBus&) = delete;
  RemoteRigBus& operator=(const RemoteRigBus&) = delete;

  std::shared_ptr<core::Bus> bus() const { return bus_; }
  // Whether the manager let go of the bus (only this object holds it).
  bool Released() const { return bus_.use_count() == 1; }
  // On the manager's thread: the node's messages published on the bus.
  void Pump();
  // After Released(): takes what the manager published last (the "unlinked" status), sends it,
  // and ends the exchanges.
  void Close();
  bool Finished() const;
  // The last exchange's failure ("" when it worked), once per change (for the events).
  std::string TakeNewError();
  const std::string& student() const { return student_; }
  // The exchanges' round trips so far: "N exchanges, round trip p50 A ms, p95 B ms, max C ms"
  // (the bridge stops a moving arm after command_timeout_s without the controller).
  std::string RoundTrips() const;

 private:
  void Exchanges();
  static void OnDown(const lcm::ReceiveBuffer* rbuf, const std::string& channel,
                     RemoteRigBus* self);

  std::string student_;
  RigEndpoint endpoint_;
  std::shared_ptr<core::Bus> bus_;
  std::vector<lcm::Subscription*> subscriptions_;  // the down channels, raw, on bus_
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::vector<RelayFrame> down_;  // to send
  std::vector<RelayFrame> up_;    // heard, to publish
  std::string error_;
  bool error_told_ = true;
  bool closing_ = false;
  bool finished_ = false;
  // Round trips of the exchanges that worked: a histogram of 0.1 ms bins up to 1 s (the last bin
  // holds the longer ones), and the longest.
  std::vector<int64_t> round_trip_bins_ = std::vector<int64_t>(10001, 0);
  int64_t exchanges_ = 0;
  double longest_ms_ = 0;
  std::thread thread_;
};

}  // namespace sirupp::classroom
