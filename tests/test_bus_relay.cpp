// The real arm's relay to a rig on a cluster node (class/bus_relay.hpp): the frames' encoding and
// its errors; the node's RelayTap on a real udpm bus (a private port, ttl=0); the class server's
// RemoteRigBus exchanging with a tap behind an HTTP endpoint of this test, as sirupp-rig-job
// serves it (POST /relay with the rig's secret), both ways, the last message after the manager
// let go, and a node that does not answer named in the error.

#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <functional>
#include <sirupp/arm_state_t.hpp>
#include <sirupp/estop_t.hpp>
#include <stdexcept>
#include <string>
#include <thread>

#include "class/bus_relay.hpp"
#include "class/rig_job.hpp"
#include "core/channels.hpp"
#include "panel/http_glue.hpp"

namespace sirupp::classroom {
namespace {

using Clock = std::chrono::steady_clock;

std::string PrivateUrl() {
  return "udpm://239.255.76.67:" + std::to_string(31000 + ::getpid() % 4000) + "?ttl=0";
}

bool Eventually(const std::function<bool()>& done, double seconds) {
  const auto end = Clock::now() + std::chrono::duration<double>(seconds);
  while (Clock::now() < end) {
    if (done()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return done();
}

sirupp::arm_state_t State(int64_t utime) {
  sirupp::arm_state_t s{};
  s.utime = utime;
  s.num_joints = 0;
  return s;
}

TEST(RelayFramesTest, RoundTripAndMalformedBodies) {
  const std::vector<RelayFrame> frames = {{"ARM_MOVE", std::string("\0\1\2", 3)},
                                          {"HEARTBEAT", ""}};
  const std::vector<RelayFrame> back = DecodeFrames(EncodeFrames(frames));
  ASSERT_EQ(back.size(), 2u);
  EXPECT_EQ(back[0].channel, "ARM_MOVE");
  EXPECT_EQ(back[0].bytes, std::string("\0\1\2", 3));
  EXPECT_EQ(back[1].channel, "HEARTBEAT");
  EXPECT_TRUE(DecodeFrames("").empty());
  std::string body = EncodeFrames(frames);
  try {
    DecodeFrames(body.substr(0, body.size() - 1));
    FAIL() << "a body cut short was taken";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("cut short"), std::string::npos) << e.what();
  }
  EXPECT_THROW(DecodeFrames(std::string(1, '\0')), std::runtime_error);  // empty channel name
  EXPECT_THROW(EncodeFrames({{"", "x"}}), std::invalid_argument);
}

TEST(RelayFramesTest, NoChannelIsCarriedBothWays) {
  for (const std::string& up : UpChannels()) {
    for (const std::string& down : DownChannels()) EXPECT_NE(up, down);
  }
}

TEST(RelayTapTest, CarriesUpChannelsNewestPerTickAndPublishesDownOnes) {
  const std::string url = PrivateUrl();
  const core::Channels c;
  RelayTap tap(url);
  EXPECT_TRUE(DecodeFrames(tap.Exchange("")).empty());  // starts listening
  // Refused: a channel the relay does not carry to a rig.
  EXPECT_THROW(tap.Exchange(EncodeFrames({{c.arm_move.name(), ""}})), std::invalid_argument);

  core::Bus rig(url, "");
  std::vector<int64_t> heard;
  rig.Subscribe<sirupp::arm_state_t>(
      c.real_arm_state,
      [&](const sirupp::arm_state_t& s, const core::ReceiveInfo&) { heard.push_back(s.utime); });
  sirupp::estop_t estop{};
  estop.utime = 7;
  estop.engaged = 1;
  estop.sender = "test";
  rig.Publish(c.estop, estop);
  for (int k = 1; k <= 20; ++k) rig.Publish(c.sim_arm_state, State(k));  // within the queue

  std::vector<RelayFrame> up;
  ASSERT_TRUE(Eventually(
      [&] {
        for (RelayFrame& f : DecodeFrames(tap.Exchange(""))) up.push_back(std::move(f));
        int sim = 0;
        bool newest = false;
        bool estop_seen = false;
        for (const RelayFrame& f : up) {
          if (f.channel == c.sim_arm_state.name()) {
            ++sim;
            sirupp::arm_state_t s{};
            s.decode(f.bytes.data(), 0, static_cast<int>(f.bytes.size()));
            newest = newest || s.utime == 20;
          }
          estop_seen = estop_seen || f.channel == c.estop.name();
        }
        return newest && estop_seen;
      },
      5));
  int sim = 0;
  for (const RelayFrame& f : up) sim += f.channel == c.sim_arm_state.name() ? 1 : 0;
  EXPECT_LT(sim, 20) << "every per-tick state was carried, not only the newest";

  // Down: published on the rig's bus.
  const sirupp::arm_state_t real = State(42);
  std::string bytes(static_cast<size_t>(real.getEncodedSize()), '\0');
  real.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  tap.Exchange(EncodeFrames({{c.real_arm_state.name(), bytes}}));
  EXPECT_TRUE(Eventually(
      [&] {
        rig.HandleAvailable();
        return !heard.empty() && heard.back() == 42;
      },
      5));
}

// A node's endpoint as sirupp-rig-job serves it: POST /relay with the secret, a RelayTap behind.
class FakeNode {
 public:
  FakeNode(const std::string& url, const std::string& secret) : tap_(url), secret_(secret) {
    server_.Post(kRelayPath, [this](const httplib::Request& req, httplib::Response& res) {
      if (req.get_header_value(kRigSecretHeader) != secret_) {
        res.status = 403;
        return;
      }
      res.set_content(tap_.Exchange(req.body), "application/octet-stream");
    });
    port_ = panel::BindServer(server_, "127.0.0.1", 0);
    thread_ = std::thread([this] { gate_.Listen(server_); });
  }
  ~FakeNode() {
    gate_.Stop(server_);
    thread_.join();
  }
  int port() const { return port_; }

 private:
  RelayTap tap_;
  std::string secret_;
  httplib::Server server_;
  panel::ListenGate gate_;
  int port_ = 0;
  std::thread thread_;
};

TEST(RemoteRigBusTest, BothWaysThroughTheEndpointAndTheLastMessageAfterRelease) {
  const std::string url = PrivateUrl();
  const std::string secret(40, 's');
  const core::Channels c;
  FakeNode node(url, secret);
  auto remote =
      std::make_unique<RemoteRigBus>("alice", RigEndpoint{"127.0.0.1", node.port(), secret});
  std::shared_ptr<core::Bus> bus = remote->bus();  // as the turn manager holds it
  core::Bus rig(url, "");
  std::vector<int64_t> on_node;
  rig.Subscribe<sirupp::arm_state_t>(
      c.real_arm_state,
      [&](const sirupp::arm_state_t& s, const core::ReceiveInfo&) { on_node.push_back(s.utime); });
  int64_t on_server = 0;
  bus->Subscribe<sirupp::estop_t>(
      c.estop, [&](const sirupp::estop_t& e, const core::ReceiveInfo&) { on_server = e.utime; });

  // Down: the manager publishes on its bus and handles it; the node's bus hears it.
  bus->Publish(c.real_arm_state, State(11));
  bus->HandleAvailable();
  EXPECT_TRUE(Eventually(
      [&] {
        rig.HandleAvailable();
        return !on_node.empty() && on_node.back() == 11;
      },
      5));
  // Up: published on the node's bus; pumped into the manager's bus.
  sirupp::estop_t estop{};
  estop.utime = 99;
  estop.sender = "alice's page";
  ASSERT_TRUE(Eventually(
      [&] {
        rig.Publish(c.estop, estop);  // until the tap listens (it starts on the first exchange)
        remote->Pump();
        bus->HandleAvailable();
        return on_server == 99;
      },
      5));
  EXPECT_EQ(remote->TakeNewError(), "");
  const std::string round_trips = remote->RoundTrips();
  EXPECT_NE(round_trips.rfind("0 exchanges", 0), 0u) << round_trips;  // not none
  EXPECT_NE(round_trips.find("round trip p50 "), std::string::npos) << round_trips;

  // The manager publishes its last message (the "unlinked" status) and lets go at once.
  bus->Publish(c.real_arm_state, State(12));
  bus.reset();
  ASSERT_TRUE(remote->Released());
  remote->Close();
  EXPECT_TRUE(Eventually([&] { return remote->Finished(); }, 5));
  EXPECT_TRUE(Eventually(
      [&] {
        rig.HandleAvailable();
        return !on_node.empty() && on_node.back() == 12;
      },
      5));
}

TEST(RemoteRigBusTest, ANodeThatDoesNotAnswerIsNamed) {
  // A port nothing listens on: bound (not listened on) and closed again.
  int port = 0;
  {
    const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
    ASSERT_GE(fd, 0);
    sockaddr_in at{};
    at.sin_family = AF_INET;
    at.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t size = sizeof at;
    ASSERT_EQ(::bind(fd, reinterpret_cast<sockaddr*>(&at), size), 0);
    ASSERT_EQ(::getsockname(fd, reinterpret_cast<sockaddr*>(&at), &size), 0);
    port = ntohs(at.sin_port);
    ::close(fd);
  }
  RemoteRigBus remote("bob", RigEndpoint{"127.0.0.1", port, std::string(40, 's')});
  std::string error;
  ASSERT_TRUE(Eventually(
      [&] {
        error = remote.TakeNewError();
        return !error.empty();
      },
      10));
  EXPECT_NE(error.find("relay to bob's rig"), std::string::npos) << error;
  EXPECT_NE(error.find("127.0.0.1:" + std::to_string(port)), std::string::npos) << error;
}

TEST(RemoteRigBusTest, AWrongSecretIsAnError) {
  const std::string url = PrivateUrl();
  FakeNode node(url, std::string(40, 's'));
  RemoteRigBus remote("carol", RigEndpoint{"127.0.0.1", node.port(), std::string(40, 'x')});
  std::string error;
  ASSERT_TRUE(Eventually(
      [&] {
        error = remote.TakeNewError();
        return !error.empty();
      },
      10));
  EXPECT_NE(error.find("HTTP 403"), std::string::npos) << error;
}

}  // namespace
}  // namespace sirupp::classroom
