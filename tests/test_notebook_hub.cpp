// The class server's side of the notebooks hub (issue 50): the hub's internal API
// (class/hub_api.hpp: the secret, who a browser is by the front's header or a class token, the
// rig routes' refusals) and the bus bridge into a notebook sandbox (class/notebook_bridge.hpp:
// frames, the echo filter, two bridges over a Unix socket between two udpm buses, ttl=0).

#include <gtest/gtest.h>
#include <lcm/lcm.h>
#include <poll.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <thread>

#include "class/class_config.hpp"
#include "class/hub_api.hpp"
#include "class/notebook_bridge.hpp"
#include "class/rig_pool.hpp"
#include "class/tokens.hpp"
#include "grade/port_lease.hpp"
#include "tests/class_server_harness.hpp"

namespace sirupp::classroom {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;

const char* const kFrontSecret = "0123456789abcdef0123456789abcdef";

struct HubApiFixture : ::testing::Test {
  void SetUp() override {
    dir = testing::TempDir("sirupp-hub-api");
    config = ParseClassConfig(
        std::string(testing::kClassOfTwo) + "notebooks: {hub_url: 'https://nb.example.edu'}\n",
        "c.yaml", dir);
    FrontConfig front_config;
    front_config.address = "127.0.0.1";
    front_config.secret = kFrontSecret;
    front_config.teachers = {"jsmith"};
    front = FrontAuth(front_config);
    tokens = std::make_unique<TokenStore>(dir + "/tokens.json");
    alice_token = tokens->Issue("alice");
    secret = EnsureHubSecret(config);
    RigPoolOptions options;
    options.log = [](const std::string&) {};
    rigs = std::make_unique<RigPool>(config, options, launcher);
  }

  void TearDown() override {
    rigs.reset();
    std::error_code error;
    fs::remove_all(dir, error);
  }

  panel::Response Ask(const std::string& rest, const Json& body, const std::string& offered = "") {
    const HubApiContext context{config, *tokens, front, throttle, *rigs, [](const std::string&) {}};
    return HubApiRoute(context, secret, offered.empty() ? secret : offered, "POST", rest,
                       body.dump());
  }

  std::string dir;
  ClassConfig config;
  FrontAuth front;
  std::unique_ptr<TokenStore> tokens;
  std::string alice_token;
  std::string secret;
  BadTokenThrottle throttle;
  ProcessLauncher launcher;
  std::unique_ptr<RigPool> rigs;
};

TEST_F(HubApiFixture, TheSecretIsMadeOnceWithMode0600AndRequired) {
  struct stat info {};
  ASSERT_EQ(::stat(HubSecretFile(config).c_str(), &info), 0);
  EXPECT_EQ(info.st_mode & 0777, 0600u);
  EXPECT_EQ(EnsureHubSecret(config), secret) << "the second serve keeps the secret";
  EXPECT_GE(secret.size(), 32u);
  const panel::Response wrong = Ask("whoami", Json::object(), secret.substr(1) + "x");
  EXPECT_EQ(wrong.status, 403);
  EXPECT_EQ(wrong.body.find(secret), std::string::npos) << "the secret is never shown";
  fs::permissions(HubSecretFile(config), fs::perms::group_read, fs::perm_options::add);
  EXPECT_THROW(EnsureHubSecret(config), std::runtime_error)
      << "a secret others may read is refused";
}

TEST_F(HubApiFixture, WhoIsABrowserByTheFrontsHeader) {
  const Json front_headers = {{"X-Remote-User", "alice"}, {kFrontSecretHeader, kFrontSecret}};
  panel::Response r = Ask("whoami", {{"peer", "127.0.0.1"}, {"headers", front_headers}});
  EXPECT_EQ(r.status, 200) << r.body;
  EXPECT_EQ(Json::parse(r.body)["name"], "alice");
  r = Ask("whoami",
          {{"peer", "127.0.0.1"},
           {"headers", {{"x-remote-user", "alice"}, {"x-sirupp-front-secret", kFrontSecret}}}});
  EXPECT_EQ(r.status, 200) << "header names in any case: " << r.body;
  r = Ask("whoami",
          {{"peer", "127.0.0.1"},
           {"headers", {{"X-Remote-User", "mallory"}, {kFrontSecretHeader, kFrontSecret}}}});
  EXPECT_EQ(r.status, 403);
  EXPECT_NE(r.body.find("signed in as 'mallory'"), std::string::npos) << r.body;
  EXPECT_NE(r.body.find("not on the roster"), std::string::npos) << r.body;
  r = Ask("whoami",
          {{"peer", "127.0.0.1"},
           {"headers", {{"X-Remote-User", "jsmith"}, {kFrontSecretHeader, kFrontSecret}}}});
  EXPECT_EQ(r.status, 403) << "a teacher has no notebook server: " << r.body;
  EXPECT_NE(r.body.find("teacher"), std::string::npos) << r.body;
  r = Ask("whoami", {{"peer", "127.0.0.1"},
                     {"headers", {{"X-Remote-User", "alice"}, {kFrontSecretHeader, "wrong"}}}});
  EXPECT_EQ(r.status, 403) << "a wrong front secret";
  r = Ask("whoami", {{"peer", "10.0.0.9"}, {"headers", front_headers}});
  EXPECT_EQ(r.status, 403) << "the front's headers from another address";
}

TEST_F(HubApiFixture, WhoIsABrowserByItsClassToken) {
  panel::Response r = Ask("whoami", {{"student", "alice"}, {"token", alice_token}});
  EXPECT_EQ(r.status, 200) << r.body;
  r = Ask("whoami", {{"student", "bob"}, {"token", alice_token}});
  EXPECT_EQ(r.status, 403) << "alice's token is not bob's";
  EXPECT_NE(r.body.find("does not open bob's notebooks"), std::string::npos) << r.body;
  r = Ask("whoami", {{"student", "carol"}, {"token", alice_token}});
  EXPECT_NE(r.body.find("not on the roster"), std::string::npos) << r.body;
  r = Ask("whoami", {{"student", "alice"}, {"token", "%41%42"}});
  EXPECT_EQ(r.status, 403);
  EXPECT_NE(r.body.find("is not a token"), std::string::npos) << r.body;
  r = Ask("whoami", Json::object());
  EXPECT_EQ(r.status, 403);
  EXPECT_NE(r.body.find("not signed in"), std::string::npos) << r.body;
}

TEST_F(HubApiFixture, BadRequestsAreRefusedWithTheField) {
  const HubApiContext context{config, *tokens, front, throttle, *rigs, [](const std::string&) {}};
  EXPECT_EQ(HubApiRoute(context, secret, secret, "POST", "whoami", "not json").status, 400);
  panel::Response r = Ask("whoami", {{"student", 5}});
  EXPECT_EQ(r.status, 400);
  EXPECT_NE(r.body.find("student"), std::string::npos) << r.body;
  r = Ask("whoami", {{"headers", {{"X-Remote-User", 1}}}});
  EXPECT_EQ(r.status, 400);
  EXPECT_NE(r.body.find("headers.X-Remote-User"), std::string::npos) << r.body;
  EXPECT_EQ(HubApiRoute(context, secret, secret, "GET", "whoami", "").status, 405);
  EXPECT_EQ(Ask("rigs/carol/ensure", Json::object()).status, 404);
  EXPECT_EQ(Ask("rigs/alice/reboot", Json::object()).status, 404);
  EXPECT_EQ(Ask("nothing", Json::object()).status, 404);
  EXPECT_EQ(Ask("rigs/alice/touch", Json::object()).status, 200);
}

TEST_F(HubApiFixture, TheNotebooksLink) {
  EXPECT_EQ(NotebooksLink(config, "alice", ""), "https://nb.example.edu/hub/login");
  EXPECT_EQ(NotebooksLink(config, "alice", "abc"),
            "https://nb.example.edu/hub/login?student=alice&token=abc");
  ClassConfig none = config;
  none.notebooks.reset();
  EXPECT_FALSE(NotebooksLink(none, "alice", "abc").has_value());
}

TEST(BridgeFramesTest, FramesRoundTripInAnyPieces) {
  const std::string bytes =
      EncodeBridgeFrame("ARM_STATE", std::string("\0\1\2", 3)) + EncodeBridgeFrame("X", "");
  BridgeFrameReader reader;
  std::vector<BridgeFrameReader::Frame> frames;
  for (char c : bytes) {
    for (auto& f : reader.Feed(&c, 1)) frames.push_back(f);
  }
  ASSERT_EQ(frames.size(), 2u);
  EXPECT_EQ(frames[0].first, "ARM_STATE");
  EXPECT_EQ(frames[0].second, std::string("\0\1\2", 3));
  EXPECT_EQ(frames[1].first, "X");
}

TEST(BridgeFramesTest, BadFramesNameTheField) {
  const auto error = [](const std::string& bytes) {
    BridgeFrameReader reader;
    try {
      reader.Feed(bytes.data(), bytes.size());
    } catch (const std::runtime_error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(error("XXXX00000000").find("frame start"), std::string::npos);
  EXPECT_NE(error(std::string("SLB1\0\0\0\0\0\0\0\0", 12)).find("channel length 0"),
            std::string::npos);
  EXPECT_NE(error(std::string("SLB1\0\0\1\0\0\0\0\0", 12)).find("channel length 256"),
            std::string::npos);
  EXPECT_NE(error(std::string("SLB1\0\0\0\1\xff\0\0\0", 12)).find("data length"),
            std::string::npos);
}

TEST(EchoFilterTest, WhatWasPublishedComesBackOnceAsAnEcho) {
  EchoFilter echo(2.0);
  const auto t0 = EchoFilter::Clock::now();
  echo.Published("A", "1", t0);
  echo.Published("A", "1", t0);
  EXPECT_FALSE(echo.IsEcho("A", "2", t0)) << "other bytes: a new message";
  EXPECT_FALSE(echo.IsEcho("B", "1", t0)) << "another channel: a new message";
  EXPECT_TRUE(echo.IsEcho("A", "1", t0));
  EXPECT_TRUE(echo.IsEcho("A", "1", t0)) << "published twice, two echoes";
  EXPECT_FALSE(echo.IsEcho("A", "1", t0)) << "then the same bytes again are new";
  echo.Published("C", "1", t0);
  EXPECT_FALSE(echo.IsEcho("C", "1", t0 + std::chrono::seconds(3))) << "an old one is forgotten";
}

// Two bridges between two udpm buses (ttl=0, leased ports): a message on either bus reaches the
// other once, and nothing comes back (no echo loop).
TEST(NotebookBridgeTest, CarriesEveryMessageBothWaysOnce) {
  const int offset = static_cast<int>(::getpid() % 200);
  grade::PortLease outer_port = grade::PortLease::Acquire(7600, 200, offset);
  grade::PortLease inner_port = grade::PortLease::Acquire(7600, 200, offset + 1);
  const std::string outer_url =
      "udpm://239.255.76.67:" + std::to_string(outer_port.port()) + "?ttl=0";
  const std::string inner_url =
      "udpm://239.255.76.67:" + std::to_string(inner_port.port()) + "?ttl=0";
  const std::string socket_dir = testing::TempDir("sirupp-bridge");
  const std::string socket_path = socket_dir + "/bus.sock";
  std::atomic<bool> running{true};
  const auto run = [&](const std::string& url, bool listen) {
    BridgeOptions options;
    options.lcm_url = url;
    options.socket_path = socket_path;
    options.listen = listen;
    options.keep_running = [&running] { return running.load(); };
    options.log = [](const std::string&) {};
    return RunBridge(options);
  };
  std::pair<int64_t, int64_t> outer_counts;
  std::pair<int64_t, int64_t> inner_counts;
  std::thread outer([&] { outer_counts = run(outer_url, true); });
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  std::thread inner([&] { inner_counts = run(inner_url, false); });
  std::this_thread::sleep_for(std::chrono::milliseconds(300));

  struct Seen {
    std::map<std::string, int> count;
    static void On(const lcm_recv_buf_t*, const char* channel, void* user) {
      ++static_cast<Seen*>(user)->count[channel];
    }
  };
  lcm_t* outer_bus = lcm_create(outer_url.c_str());
  lcm_t* inner_bus = lcm_create(inner_url.c_str());
  ASSERT_NE(outer_bus, nullptr);
  ASSERT_NE(inner_bus, nullptr);
  Seen on_outer;
  Seen on_inner;
  lcm_subscribe(outer_bus, ".*", &Seen::On, &on_outer);
  lcm_subscribe(inner_bus, ".*", &Seen::On, &on_inner);
  for (int i = 0; i < 5; ++i) {
    const std::string out = "state " + std::to_string(i);
    const std::string in = "command " + std::to_string(i);
    lcm_publish(outer_bus, "RIG_STATE", out.data(), static_cast<unsigned>(out.size()));
    lcm_publish(inner_bus, "RIG_COMMAND", in.data(), static_cast<unsigned>(in.size()));
  }
  const auto until = std::chrono::steady_clock::now() + std::chrono::milliseconds(1500);
  while (std::chrono::steady_clock::now() < until) {
    for (lcm_t* bus : {outer_bus, inner_bus}) {
      pollfd fd{lcm_get_fileno(bus), POLLIN, 0};
      if (::poll(&fd, 1, 10) > 0) lcm_handle(bus);
    }
  }
  running = false;
  outer.join();
  inner.join();
  lcm_destroy(outer_bus);
  lcm_destroy(inner_bus);
  std::error_code error;
  fs::remove_all(socket_dir, error);
  // Each bus: its own 5 (LCM loops back to the sender) and the other bus's 5, no more.
  EXPECT_EQ(on_outer.count["RIG_STATE"], 5);
  EXPECT_EQ(on_outer.count["RIG_COMMAND"], 5) << "the inside's commands reach the rig's bus once";
  EXPECT_EQ(on_inner.count["RIG_STATE"], 5) << "the rig's state reaches the inside once";
  EXPECT_EQ(on_inner.count["RIG_COMMAND"], 5);
  EXPECT_EQ(outer_counts.first, 5) << "the outer bridge sent the rig's 5, not the echoes";
  EXPECT_EQ(inner_counts.first, 5) << "the inner bridge sent the inside's 5, not the echoes";
  EXPECT_EQ(outer_counts.second, 5);
  EXPECT_EQ(inner_counts.second, 5);
}

}  // namespace
}  // namespace sirupp::classroom
