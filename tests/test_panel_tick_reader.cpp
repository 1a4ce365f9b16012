// The panel's batched reading of the per-tick channels on a real udpm bus (core/tick_reader.hpp),
// on a private port with ttl=0: the reader's socket takes only those channels and keeps each one's
// newest message; once LCM's socket is muted, LCM no longer gets them (nor the per-tick channels
// nobody reads) but still gets every other channel, including names that only start like a
// per-tick one and names shorter than any; and the hub draws the arm from the reader's messages.

#include <gtest/gtest.h>
#include <poll.h>
#include <unistd.h>

#include <chrono>
#include <sirupp/arm_command_t.hpp>
#include <sirupp/arm_state_t.hpp>
#include <sirupp/heartbeat_t.hpp>
#include <thread>

#include "core/bus.hpp"
#include "core/model_loader.hpp"
#include "core/tick_reader.hpp"
#include "core/translate.hpp"
#include "panel/panel_hub.hpp"

namespace sirupp::panel {
namespace {

using core::ParseUdpmUrl;
using core::TickReader;

std::string PrivateUrl(int offset) {
  return "udpm://239.255.76.67:" + std::to_string(41000 + offset + ::getpid() % 8000) + "?ttl=0";
}

sirupp::arm_state_t State(int64_t tick, int joints = 6) {
  sirupp::arm_state_t state{};
  state.tick = tick;
  state.num_joints = joints;
  state.position.assign(static_cast<size_t>(joints), 0.1 * static_cast<double>(tick));
  state.velocity.assign(static_cast<size_t>(joints), 0.0);
  state.effort.assign(static_cast<size_t>(joints), 0.0);
  state.flags.assign(static_cast<size_t>(joints), 0);
  return state;
}

TEST(PanelTickReader, ParsesUdpmUrls) {
  const auto a = ParseUdpmUrl("udpm://239.255.76.67:7700?ttl=0&recv_buf_size=4096");
  ASSERT_TRUE(a.has_value());
  EXPECT_EQ(a->port, 7700);
  EXPECT_EQ(a->group, 0xEFFF4C43U);
  EXPECT_EQ(a->recv_buf_size, 4096);
  const auto b = ParseUdpmUrl("udpm://239.255.76.67");
  ASSERT_TRUE(b.has_value());
  EXPECT_EQ(b->port, 7667);
  EXPECT_FALSE(ParseUdpmUrl("memq://").has_value());
  EXPECT_FALSE(ParseUdpmUrl("udpm://239.255.76.67:99999").has_value());
  EXPECT_FALSE(ParseUdpmUrl("udpm://not-an-address:7667").has_value());
}

TEST(PanelTickReader, TakesOnlyThePerTickChannelsNewestOnlyAndLcmNoLongerWakesForThem) {
  const std::string url = PrivateUrl(0);
  core::Bus publisher(url);
  core::Bus listener(url);
  int lcm_states = 0;
  int lcm_commands = 0;
  int lcm_longer = 0;
  int lcm_short = 0;
  listener.Subscribe<sirupp::arm_state_t>(
      "SIM_ARM_STATE", [&](const sirupp::arm_state_t&, const core::ReceiveInfo&) { ++lcm_states; });
  listener.Subscribe<sirupp::arm_command_t>(
      "SIM_ARM_COMMAND",
      [&](const sirupp::arm_command_t&, const core::ReceiveInfo&) { ++lcm_commands; });
  listener.Subscribe<sirupp::arm_state_t>(
      "SIM_ARM_STATEX",
      [&](const sirupp::arm_state_t&, const core::ReceiveInfo&) { ++lcm_longer; });
  listener.Subscribe<sirupp::heartbeat_t>(
      "A", [&](const sirupp::heartbeat_t&, const core::ReceiveInfo&) { ++lcm_short; });

  // Before muting, LCM gets the per-tick channel (so what follows can tell the difference).
  publisher.Publish("SIM_ARM_STATE", State(0));
  ASSERT_TRUE(core::HandleUntil(
      listener, [&] { return lcm_states == 1; }, 5.0));

  const auto address = ParseUdpmUrl(url);
  ASSERT_TRUE(address.has_value());
  TickReader reader(*address, {"SIM_ARM_STATE", "ARM_SETPOINT"});
  // The listener's LCM socket already drops SIM_ARM_COMMAND? No: it is subscribed above. Taking
  // the two read here off LCM leaves SIM_ARM_COMMAND on it.
  ASSERT_TRUE(listener.TakeOffLcm({"SIM_ARM_STATE", "ARM_SETPOINT"}));
  EXPECT_EQ(listener.MutedOnLcm(),
            (std::vector<std::string>{"SIM_ARM_STATE", "ARM_SETPOINT", "REAL_ARM_STATE",
                                      "REAL_ARM_SETPOINT"}));

  for (int64_t tick = 1; tick <= 5; ++tick) publisher.Publish("SIM_ARM_STATE", State(tick));
  sirupp::arm_command_t command{};
  command.num_joints = 1;
  command.effort.assign(1, 0.0);
  publisher.Publish("SIM_ARM_COMMAND", command);
  for (int64_t tick = 1; tick <= 3; ++tick) publisher.Publish("SIM_ARM_STATEX", State(tick));
  sirupp::heartbeat_t beat{};
  publisher.Publish("A", beat);

  // Datagrams on one host arrive in order: once "A" is in, anything LCM would get is in.
  ASSERT_TRUE(core::HandleUntil(
      listener, [&] { return lcm_short == 1; }, 5.0));
  core::HandleUntil(
      listener, [] { return false; }, 0.2);
  EXPECT_EQ(lcm_states, 1);    // only the one before muting
  EXPECT_EQ(lcm_commands, 1);  // subscribed and not taken off LCM
  EXPECT_EQ(lcm_longer, 3);    // a name that only starts like a per-tick channel
  EXPECT_EQ(lcm_short, 1);     // a name shorter than any per-tick one

  const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while (reader.datagrams() < 5 && std::chrono::steady_clock::now() < end) {
    pollfd fd{reader.fd(), POLLIN, 0};
    ::poll(&fd, 1, 50);
    reader.Drain();
  }
  EXPECT_EQ(reader.datagrams(), 5);  // the state before muting was sent before the socket existed
  EXPECT_EQ(reader.refused(), 0);
  std::vector<int64_t> ticks;
  std::vector<std::string> channels;
  reader.TakeNewest([&](const std::string& channel, const uint8_t* data, int size, int64_t at) {
    sirupp::arm_state_t state{};
    ASSERT_GT(state.decode(data, 0, size), 0);
    EXPECT_GT(at, 0);
    channels.push_back(channel);
    ticks.push_back(state.tick);
  });
  ASSERT_EQ(channels, std::vector<std::string>{"SIM_ARM_STATE"});
  EXPECT_EQ(ticks, std::vector<int64_t>{5});
  int again = 0;
  reader.TakeNewest([&](const std::string&, const uint8_t*, int, int64_t) { ++again; });
  EXPECT_EQ(again, 0);  // each message is handed over once
}

TEST(PanelTickReader, TheHubDrawsTheArmFromTheBatchedStates) {
  const std::string url = PrivateUrl(8000);
  core::Bus sim(url);
  core::Bus panel_bus(url);
  HubOptions options;
  options.fallback_model = core::LoadRobotModel("config/robots/puma260.yaml");
  PanelHub hub(panel_bus, options);
  ASSERT_TRUE(hub.batching_ticks());
  for (int round = 0; round < 200 && !hub.StateJson().contains("virtual"); ++round) {
    for (int64_t tick = 1; tick <= 20; ++tick) sim.Publish("SIM_ARM_STATE", State(tick));
    hub.ServiceOnce(20);
  }
  const Json state = hub.StateJson();
  ASSERT_TRUE(state.contains("virtual")) << state.dump();
  EXPECT_EQ(state["tick"].get<int64_t>(), 20);  // the newest of its round
  // Far fewer handled than sent: the older ones of a round are never decoded.
  EXPECT_LT(hub.states_received(), 20);

  HubOptions through_lcm = options;
  through_lcm.batch_ticks = false;
  core::Bus other_bus(PrivateUrl(16000));
  PanelHub plain(other_bus, through_lcm);
  EXPECT_FALSE(plain.batching_ticks());
}

}  // namespace
}  // namespace sirupp::panel
