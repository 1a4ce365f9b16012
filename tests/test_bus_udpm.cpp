// core::Bus on a real udpm bus (a private port, ttl=0): LCM's own receive socket drops the per-tick
// channels (Channels::PerTick()) that no subscription of the bus matches, keeps the subscribed ones
// and every other channel, unmutes a channel when it is subscribed later, honours the rig prefix
// and raw subscriptions, and drops a channel taken over by a TickReader (TakeOffLcm) until it is
// put back. What LCM's socket still takes is seen through a raw ".*" subscription the Bus is not
// told about.

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <map>
#include <sirupp/arm_command_t.hpp>
#include <sirupp/arm_state_t.hpp>
#include <sirupp/heartbeat_t.hpp>
#include <string>
#include <thread>
#include <vector>

#include "core/bus.hpp"
#include "core/tick_reader.hpp"

namespace sirupp::core {
namespace {

std::string PrivateUrl(int offset) {
  return "udpm://239.255.76.67:" + std::to_string(30000 + offset + ::getpid() % 5000) + "?ttl=0";
}

sirupp::arm_state_t State(int64_t seq) {
  sirupp::arm_state_t state{};
  state.seq = seq;
  state.tick = seq;
  state.num_joints = 1;
  state.position.assign(1, 0.0);
  state.velocity.assign(1, 0.0);
  state.effort.assign(1, 0.0);
  state.flags.assign(1, 0);
  return state;
}

sirupp::arm_command_t Command() {
  sirupp::arm_command_t command{};
  command.num_joints = 1;
  command.effort.assign(1, 0.0);
  return command;
}

// Every channel name LCM's socket of `bus` delivers, counted, through a raw subscription.
struct SeenByLcm {
  std::map<std::string, int> count;
  static void Add(const lcm::ReceiveBuffer*, const std::string& channel, SeenByLcm* self) {
    ++self->count[channel];
  }
};

// Publishes one message on each per-tick channel (with `prefix`) and a HEARTBEAT marker, then
// handles `bus` until the marker is in (datagrams on one host arrive in order).
void PublishRound(Bus& publisher, const std::string& prefix, Bus& bus, SeenByLcm& seen) {
  const int markers = seen.count["HEARTBEAT"];
  publisher.Publish(prefix + "SIM_ARM_STATE", State(1));
  publisher.Publish(prefix + "SIM_ARM_COMMAND", Command());
  publisher.Publish(prefix + "ARM_SETPOINT", State(1));  // the type does not matter here
  publisher.Publish(prefix + "REAL_ARM_STATE", State(1));
  publisher.Publish(prefix + "REAL_ARM_SETPOINT", State(1));
  publisher.Publish("HEARTBEAT", sirupp::heartbeat_t{});
  ASSERT_TRUE(HandleUntil(
      bus, [&] { return seen.count["HEARTBEAT"] > markers; }, 5.0));
}

TEST(BusUdpm, UnsubscribedPerTickChannelsAreDroppedSubscribedAndOtherChannelsStay) {
  const std::string url = PrivateUrl(0);
  Bus publisher(url);
  Bus bus(url);
  SeenByLcm seen;
  bus.raw_lcm().subscribeFunction(".*", &SeenByLcm::Add, &seen);  // not told to the Bus
  int states = 0;
  int heartbeats = 0;
  bus.Subscribe<sirupp::arm_state_t>(
      "SIM_ARM_STATE", [&](const sirupp::arm_state_t&, const ReceiveInfo&) { ++states; });
  bus.Subscribe<sirupp::heartbeat_t>(
      "HEARTBEAT", [&](const sirupp::heartbeat_t&, const ReceiveInfo&) { ++heartbeats; });
  EXPECT_EQ(bus.MutedOnLcm(), (std::vector<std::string>{"SIM_ARM_COMMAND", "ARM_SETPOINT",
                                                        "REAL_ARM_STATE", "REAL_ARM_SETPOINT"}));
  PublishRound(publisher, "", bus, seen);
  EXPECT_EQ(states, 1);
  EXPECT_EQ(heartbeats, 1);
  EXPECT_EQ(seen.count["SIM_ARM_STATE"], 1);
  EXPECT_EQ(seen.count["SIM_ARM_COMMAND"], 0);
  EXPECT_EQ(seen.count["ARM_SETPOINT"], 0);
  EXPECT_EQ(seen.count["REAL_ARM_STATE"], 0);
  EXPECT_EQ(seen.count["REAL_ARM_SETPOINT"], 0);

  // A later subscription unmutes its channel; unsubscribing mutes it again.
  int commands = 0;
  Subscription& later = bus.Subscribe<sirupp::arm_command_t>(
      "SIM_ARM_COMMAND", [&](const sirupp::arm_command_t&, const ReceiveInfo&) { ++commands; });
  EXPECT_EQ(bus.MutedOnLcm(),
            (std::vector<std::string>{"ARM_SETPOINT", "REAL_ARM_STATE", "REAL_ARM_SETPOINT"}));
  PublishRound(publisher, "", bus, seen);
  EXPECT_EQ(commands, 1);
  EXPECT_EQ(states, 2);
  EXPECT_EQ(seen.count["ARM_SETPOINT"], 0);
  later.Unsubscribe();
  PublishRound(publisher, "", bus, seen);
  EXPECT_EQ(seen.count["SIM_ARM_COMMAND"], 1);
  EXPECT_EQ(states, 3);

  // A raw subscription declared to the Bus keeps what it matches on LCM.
  bus.NoteRawSubscription("REAL_.*");
  EXPECT_EQ(bus.MutedOnLcm(), (std::vector<std::string>{"SIM_ARM_COMMAND", "ARM_SETPOINT"}));
  PublishRound(publisher, "", bus, seen);
  EXPECT_EQ(seen.count["REAL_ARM_STATE"], 1);
  EXPECT_EQ(seen.count["REAL_ARM_SETPOINT"], 1);
  bus.NoteRawSubscription(".*");
  EXPECT_TRUE(bus.MutedOnLcm().empty());
  PublishRound(publisher, "", bus, seen);
  EXPECT_EQ(seen.count["SIM_ARM_COMMAND"], 2);
  EXPECT_EQ(seen.count["ARM_SETPOINT"], 1);
  bus.ForgetRawSubscription(".*");
  bus.ForgetRawSubscription("REAL_.*");
  EXPECT_EQ(bus.MutedOnLcm().size(), 4U);
}

TEST(BusUdpm, OnlyTheBussOwnRigsChannelsAreDropped) {
  const std::string url = PrivateUrl(5000);
  Bus publisher(url);
  Bus bus(url, "RIG3_");
  SeenByLcm seen;
  bus.raw_lcm().subscribeFunction(".*", &SeenByLcm::Add, &seen);
  bus.Subscribe<sirupp::arm_state_t>("SIM_ARM_STATE",
                                     [](const sirupp::arm_state_t&, const ReceiveInfo&) {});
  EXPECT_EQ(bus.MutedOnLcm(),
            (std::vector<std::string>{"RIG3_SIM_ARM_COMMAND", "RIG3_ARM_SETPOINT",
                                      "RIG3_REAL_ARM_STATE", "RIG3_REAL_ARM_SETPOINT"}));
  PublishRound(publisher, "RIG3_", bus, seen);
  PublishRound(publisher, "", bus, seen);
  EXPECT_EQ(seen.count["RIG3_SIM_ARM_STATE"], 1);
  EXPECT_EQ(seen.count["RIG3_SIM_ARM_COMMAND"], 0);
  EXPECT_EQ(seen.count["RIG3_ARM_SETPOINT"], 0);
  // Another rig's (here: no prefix) channels are not this bus's business.
  EXPECT_EQ(seen.count["SIM_ARM_COMMAND"], 1);
  EXPECT_EQ(seen.count["ARM_SETPOINT"], 1);
}

TEST(BusUdpm, AChannelTakenOverByATickReaderComesOnlyThroughItUntilPutBack) {
  const std::string url = PrivateUrl(10000);
  Bus publisher(url);
  Bus bus(url);
  SeenByLcm seen;
  bus.raw_lcm().subscribeFunction(".*", &SeenByLcm::Add, &seen);
  std::vector<int64_t> seqs;
  bus.Subscribe<sirupp::arm_state_t>(
      "SIM_ARM_STATE",
      [&](const sirupp::arm_state_t& state, const ReceiveInfo&) { seqs.push_back(state.seq); });
  bus.Subscribe<sirupp::heartbeat_t>("HEARTBEAT",
                                     [](const sirupp::heartbeat_t&, const ReceiveInfo&) {});
  {
    const std::unique_ptr<TickFeed> feed = TickFeed::Open(bus, {"SIM_ARM_STATE"}, "test");
    ASSERT_NE(feed, nullptr);
    EXPECT_EQ(bus.MutedOnLcm().size(), 5U);
    for (int64_t seq = 1; seq <= 50; ++seq) publisher.Publish("SIM_ARM_STATE", State(seq));
    publisher.Publish("HEARTBEAT", sirupp::heartbeat_t{});
    ASSERT_TRUE(HandleUntil(
        bus, [&] { return seen.count["HEARTBEAT"] == 1; }, 5.0));
    EXPECT_EQ(seen.count["SIM_ARM_STATE"], 0);
    // Every datagram, in order, through the reader.
    std::vector<int64_t> read;
    for (int round = 0; round < 100 && read.size() < 50; ++round) {
      feed->reader().DrainEach(
          [&](size_t, const std::string& channel, const uint8_t* data, int size, int64_t at) {
            sirupp::arm_state_t state{};
            ASSERT_GT(state.decode(data, 0, size), 0);
            EXPECT_EQ(channel, "SIM_ARM_STATE");
            EXPECT_GT(at, 0);
            read.push_back(state.seq);
            bus.DeliverRecorded(channel, data, size, at);
          });
      HandleUntil(
          bus, [] { return false; }, 0.01);
    }
    std::vector<int64_t> expected;
    for (int64_t seq = 1; seq <= 50; ++seq) expected.push_back(seq);
    EXPECT_EQ(read, expected);
    EXPECT_EQ(seqs, expected);
    EXPECT_EQ(feed->reader().dropped(), 0);
    EXPECT_EQ(bus.StatsFor("SIM_ARM_STATE").gaps, 0);
  }
  // The feed has ended: the subscribed channel is LCM's again.
  EXPECT_EQ(bus.MutedOnLcm().size(), 4U);
  publisher.Publish("SIM_ARM_STATE", State(51));
  ASSERT_TRUE(HandleUntil(
      bus, [&] { return seqs.size() == 51; }, 5.0));
  EXPECT_EQ(seen.count["SIM_ARM_STATE"], 1);
}

TEST(BusUdpm, ATickReaderThatCountsDropsCountsWhatItsFullBufferLost) {
  const std::string url = PrivateUrl(15000);
  Bus publisher(url);
  const auto address = ParseUdpmUrl(url);
  ASSERT_TRUE(address.has_value());
  // The smallest buffer the kernel gives: a few datagrams.
  TickReader reader(*address, {"SIM_ARM_STATE"}, 1, TickReader::Pick::kCountDrops);
  publisher.Publish("HEARTBEAT", sirupp::heartbeat_t{});  // not a channel read: refused, not lost
  constexpr int kSent = 300;
  for (int64_t seq = 1; seq <= kSent; ++seq) publisher.Publish("SIM_ARM_STATE", State(seq));
  int64_t taken = 0;
  int64_t last_seq = 0;
  const auto count = [&] {
    reader.DrainEach([&](size_t, const std::string&, const uint8_t* data, int size, int64_t) {
      sirupp::arm_state_t state{};
      ASSERT_GT(state.decode(data, 0, size), 0);
      EXPECT_GT(state.seq, last_seq);  // in order, whatever was lost
      last_seq = state.seq;
      ++taken;
    });
  };
  // Multicast loopback delivers a moment after the send: wait until the last one is queued.
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  count();
  // The count comes with the next datagram queued: after one more, nothing is unaccounted for.
  publisher.Publish("SIM_ARM_STATE", State(kSent + 1));
  for (int round = 0; round < 500 && last_seq < kSent + 1; ++round) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
    count();
  }
  EXPECT_EQ(last_seq, kSent + 1);
  EXPECT_GT(reader.dropped(), 0);
  EXPECT_LT(taken, kSent);
  EXPECT_EQ(taken + reader.dropped(), kSent + 1);
  EXPECT_GE(reader.refused(), 1);  // the heartbeat
}

// ReadDirectly: Handle() itself reads the channel from a socket of its own, every message in
// order with its kernel receive time, and still handles LCM's channels; LCM's socket drops it.
TEST(BusUdpm, AChannelReadDirectlyComesThroughHandleInOrderBesideLcmsChannels) {
  const std::string url = PrivateUrl(20000);
  Bus publisher(url);
  Bus bus(url);
  SeenByLcm seen;
  bus.raw_lcm().subscribeFunction(".*", &SeenByLcm::Add, &seen);
  std::vector<int64_t> commands;
  int64_t last_recv_utime = 0;
  int heartbeats = 0;
  bus.Subscribe<sirupp::arm_command_t>(
      "SIM_ARM_COMMAND", [&](const sirupp::arm_command_t& command, const ReceiveInfo& info) {
        EXPECT_EQ(info.channel, "SIM_ARM_COMMAND");
        EXPECT_GE(info.recv_utime, last_recv_utime);
        last_recv_utime = info.recv_utime;
        commands.push_back(command.seq);
      });
  bus.Subscribe<sirupp::heartbeat_t>(
      "HEARTBEAT", [&](const sirupp::heartbeat_t&, const ReceiveInfo&) { ++heartbeats; });
  EXPECT_FALSE(bus.reads_directly());
  ASSERT_TRUE(bus.ReadDirectly({"SIM_ARM_COMMAND"}, "test"));
  EXPECT_TRUE(bus.reads_directly());
  EXPECT_FALSE(bus.ReadDirectly({"SIM_ARM_STATE"}, "test")) << "one direct socket per bus";
  std::vector<int64_t> expected;
  for (int64_t seq = 1; seq <= 40; ++seq) {
    sirupp::arm_command_t command = Command();
    command.seq = seq;
    publisher.Publish("SIM_ARM_COMMAND", command);
    expected.push_back(seq);
  }
  publisher.Publish("HEARTBEAT", sirupp::heartbeat_t{});
  ASSERT_TRUE(HandleUntil(
      bus, [&] { return heartbeats == 1 && commands.size() == expected.size(); }, 5.0));
  EXPECT_EQ(commands, expected);
  EXPECT_GT(last_recv_utime, 0);
  EXPECT_EQ(seen.count["SIM_ARM_COMMAND"], 0) << "LCM's socket drops the channel read directly";
  EXPECT_EQ(seen.count["HEARTBEAT"], 1);
  EXPECT_EQ(bus.StatsFor("SIM_ARM_COMMAND").messages, 40);
  EXPECT_EQ(bus.StatsFor("SIM_ARM_COMMAND").gaps, 0);
  // Handle() waits for a message on either socket, and returns 0 when none comes.
  const auto start = std::chrono::steady_clock::now();
  EXPECT_EQ(bus.Handle(30), 0);
  EXPECT_GE(std::chrono::steady_clock::now() - start, std::chrono::milliseconds(25));
  std::thread later([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    publisher.Publish("SIM_ARM_COMMAND", Command());
  });
  int handled = 0;
  for (int round = 0; round < 50 && handled == 0; ++round) handled = bus.Handle(100);
  later.join();
  EXPECT_EQ(handled, 1);
  EXPECT_EQ(commands.size(), 41U);
}

// A channel LCM was already receiving when it is taken off LCM (a controller subscribes to the
// sim's states, then reads them directly): what LCM had queued of it is older than what the direct
// socket delivers, and must not come after it (issue 41: a controller took its sim's tick going
// from 321 back to 296 for a restarted sim).
TEST(BusUdpm, NothingOlderComesThroughLcmOnceAChannelIsReadDirectly) {
  const std::string url = PrivateUrl(25000);
  Bus publisher(url);
  Bus bus(url);
  std::vector<int64_t> ticks;
  int heartbeats = 0;
  bus.Subscribe<sirupp::arm_state_t>(
      "SIM_ARM_STATE",
      [&](const sirupp::arm_state_t& state, const ReceiveInfo&) { ticks.push_back(state.tick); });
  bus.Subscribe<sirupp::heartbeat_t>(
      "HEARTBEAT", [&](const sirupp::heartbeat_t&, const ReceiveInfo&) { ++heartbeats; });
  // Received by LCM's thread and queued there, not handled yet.
  for (int64_t tick = 1; tick <= 20; ++tick) publisher.Publish("SIM_ARM_STATE", State(tick));
  publisher.Publish("HEARTBEAT", sirupp::heartbeat_t{});
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  ASSERT_TRUE(bus.ReadDirectly({"SIM_ARM_STATE"}, "test"));
  for (int64_t tick = 21; tick <= 40; ++tick) publisher.Publish("SIM_ARM_STATE", State(tick));
  publisher.Publish("HEARTBEAT", sirupp::heartbeat_t{});
  ASSERT_TRUE(HandleUntil(
      bus,
      [&] { return heartbeats == 2 && std::find(ticks.begin(), ticks.end(), 40) != ticks.end(); },
      5.0));
  bus.HandleAvailable();  // anything LCM still holds
  for (size_t i = 1; i < ticks.size(); ++i) {
    EXPECT_GT(ticks[i], ticks[i - 1]) << "tick " << ticks[i] << " came after " << ticks[i - 1];
  }
  EXPECT_GE(ticks.size(), 20U);
}

TEST(BusUdpm, OtherProvidersHaveNothingToMute) {
  Bus bus("memq://");
  bus.Subscribe<sirupp::arm_state_t>("SIM_ARM_STATE",
                                     [](const sirupp::arm_state_t&, const ReceiveInfo&) {});
  EXPECT_TRUE(bus.MutedOnLcm().empty());
  EXPECT_FALSE(bus.TakeOffLcm({"SIM_ARM_STATE"}));
  EXPECT_EQ(TickFeed::Open(bus, {"SIM_ARM_STATE"}, "test"), nullptr);
  EXPECT_FALSE(bus.ReadDirectly({"SIM_ARM_STATE"}, "test"));
  EXPECT_FALSE(bus.reads_directly());
}

}  // namespace
}  // namespace sirupp::core
