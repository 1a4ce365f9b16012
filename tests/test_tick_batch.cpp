// Several ticks in one message (core/tick_batch.hpp) and the Bus handing them to the per-tick
// channels' subscriptions (core/bus.hpp): every tick arrives, in order, counted on its own channel
// with the receive time it would have had alone; a reader of the newest gets the newest; a batch
// that does not decode is counted on SIM_ARM_TICKS and delivers nothing; the bus follows
// SIM_ARM_TICKS only while a per-tick channel is subscribed. memq:// only.

#include <gtest/gtest.h>

#include <sirupp/arm_state_t.hpp>
#include <sirupp/arm_ticks_t.hpp>
#include <sirupp/servo_setpoint_t.hpp>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/bus.hpp"
#include "core/tick_batch.hpp"

namespace sirupp::core {
namespace {

sirupp::arm_state_t State(int64_t tick, int joints = 6) {
  sirupp::arm_state_t state{};
  state.utime = 512 * tick;
  state.seq = tick;
  state.tick = tick;
  state.num_joints = joints;
  for (int j = 0; j < joints; ++j) {
    state.position.push_back(0.01 * static_cast<double>(tick) + j);
    state.velocity.push_back(0.5);
    state.effort.push_back(-1.0 * j);
    state.flags.push_back(0);
  }
  return state;
}

sirupp::servo_setpoint_t Setpoint(int64_t tick, int joints = 6) {
  sirupp::servo_setpoint_t setpoint{};
  setpoint.utime = 512 * tick;
  setpoint.seq = tick;
  setpoint.tick = tick;
  setpoint.move_id = 3;
  setpoint.num_joints = joints;
  for (int j = 0; j < joints; ++j) {
    setpoint.position.push_back(0.02 * static_cast<double>(tick));
    setpoint.velocity.push_back(0.1);
    setpoint.goal.push_back(1.0);
    setpoint.position_error.push_back(0.0);
    setpoint.effort.push_back(0.3);
    setpoint.status.push_back(2);
  }
  return setpoint;
}

// Ticks first..first+count-1, tick k made at 1000 + 10 k us of wall clock.
TickBatch Gathered(int64_t first, int count, int max_ticks = 16) {
  TickBatch batch(max_ticks);
  for (int64_t k = first; k < first + count; ++k) {
    batch.Add(Setpoint(k), 1000 + 10 * k);
    batch.Add(State(k), 1000 + 10 * k);
  }
  return batch;
}

TEST(TickBatch, IsFullAtItsTickCountOrBeforeItsBytesRunOut) {
  TickBatch batch(16);
  EXPECT_TRUE(batch.empty());
  for (int k = 0; k < 15; ++k) {
    batch.Add(Setpoint(k), k);
    batch.Add(State(k), k);
    EXPECT_FALSE(batch.Full()) << k;
  }
  batch.Add(Setpoint(15), 15);
  batch.Add(State(15), 15);
  EXPECT_TRUE(batch.Full());
  const sirupp::arm_ticks_t& first = batch.Take(99);
  EXPECT_EQ(first.num_states, 16);
  EXPECT_EQ(first.num_setpoints, 16);
  EXPECT_EQ(first.seq, 0);
  EXPECT_EQ(first.sent_utime, 99);
  EXPECT_LE(first.getEncodedSize(), kTickBatchMaxBytes) << "a PUMA 260's 16 ticks fit";
  EXPECT_TRUE(batch.empty());
  EXPECT_EQ(batch.Take(100).seq, 1);

  // A 40-joint arm: the bytes fill before 16 ticks, and what was gathered still fits.
  TickBatch wide(16);
  int ticks = 0;
  while (!wide.Full()) {
    wide.Add(Setpoint(ticks, 40), ticks);
    wide.Add(State(ticks, 40), ticks);
    ++ticks;
  }
  EXPECT_LT(ticks, 16);
  EXPECT_LE(wide.Take(0).getEncodedSize(), kTickBatchMaxBytes);

  EXPECT_THROW(TickBatch(0), std::invalid_argument);
  EXPECT_THROW(TickBatch(kTickBatchMaxTicks + 1), std::invalid_argument);
}

TEST(TickBatch, TheBusHandsEveryTickToThePerTickSubscriptionsInOrder) {
  Bus bus("memq://");
  std::vector<sirupp::arm_state_t> states;
  std::vector<int64_t> state_recv;
  std::vector<sirupp::servo_setpoint_t> setpoints;
  bus.Subscribe<sirupp::arm_state_t>("SIM_ARM_STATE",
                                     [&](const sirupp::arm_state_t& m, const ReceiveInfo& info) {
                                       EXPECT_EQ(info.channel, "SIM_ARM_STATE");
                                       states.push_back(m);
                                       state_recv.push_back(info.recv_utime);
                                     });
  bus.Subscribe<sirupp::servo_setpoint_t>(
      "ARM_SETPOINT",
      [&](const sirupp::servo_setpoint_t& m, const ReceiveInfo&) { setpoints.push_back(m); });
  bus.Publish("SIM_ARM_STATE", State(0));  // alone first, as a sim does before the first answer
  TickBatch batch = Gathered(1, 16);
  const sirupp::arm_ticks_t& message = batch.Take(1000 + 10 * 16);
  bus.Publish("SIM_ARM_TICKS", message);
  bus.HandleAvailable();

  ASSERT_EQ(states.size(), 17u);
  ASSERT_EQ(setpoints.size(), 16u);
  for (size_t i = 0; i < states.size(); ++i) {
    EXPECT_EQ(states[i].tick, static_cast<int64_t>(i));
    EXPECT_EQ(states[i].position, State(static_cast<int64_t>(i)).position);
  }
  for (size_t i = 0; i < setpoints.size(); ++i) {
    EXPECT_EQ(setpoints[i].tick, static_cast<int64_t>(i) + 1);
    EXPECT_EQ(setpoints[i].goal, Setpoint(1).goal);
  }
  // Tick 1 waited 150 us in the batch, tick 16 none.
  const int64_t batch_recv = state_recv.back();
  EXPECT_EQ(state_recv[1], batch_recv - 150);
  EXPECT_EQ(state_recv[16], batch_recv);

  const ChannelStats state_stats = bus.StatsFor("SIM_ARM_STATE");
  EXPECT_EQ(state_stats.messages, 17);
  EXPECT_EQ(state_stats.gaps, 0);
  EXPECT_EQ(bus.StatsFor("ARM_SETPOINT").messages, 16);
  EXPECT_EQ(bus.StatsFor("SIM_ARM_TICKS").messages, 1);

  // A lost tick inside the next batch is a gap on SIM_ARM_STATE, as a lost datagram was.
  TickBatch next(16);
  next.Add(State(17), 0);
  next.Add(State(19), 0);
  bus.Publish("SIM_ARM_TICKS", next.Take(0));
  bus.HandleAvailable();
  EXPECT_EQ(bus.StatsFor("SIM_ARM_STATE").gaps, 1);
  EXPECT_EQ(states.back().tick, 19);
}

TEST(TickBatch, AReaderOfTheNewestGetsTheNewestTickOfEachKind) {
  Bus bus("memq://");
  Latest<sirupp::arm_state_t> latest(bus, "SIM_ARM_STATE");
  std::vector<int64_t> ticks;
  bus.Subscribe<sirupp::servo_setpoint_t>(
      "ARM_SETPOINT",
      [&](const sirupp::servo_setpoint_t& m, const ReceiveInfo&) { ticks.push_back(m.tick); });
  TickBatch batch = Gathered(32, 16);
  const sirupp::arm_ticks_t& message = batch.Take(0);
  std::vector<uint8_t> bytes(static_cast<size_t>(message.getEncodedSize()));
  ASSERT_GT(message.encode(bytes.data(), 0, static_cast<int>(bytes.size())), 0);
  // As a tick reader that keeps each channel's newest hands it over (TickFeed::DeliverNewest).
  bus.DeliverRecorded("SIM_ARM_TICKS", bytes.data(), static_cast<int>(bytes.size()), 5000, true);
  ASSERT_TRUE(latest.Has());
  EXPECT_EQ(latest.Get().tick, 47);
  EXPECT_EQ(latest.count(), 1) << "only the newest state is decoded";
  EXPECT_EQ(ticks, std::vector<int64_t>{47});
  EXPECT_EQ(bus.StatsFor("SIM_ARM_STATE").gaps, 0) << "skipped on purpose, not lost";
}

TEST(TickBatch, ABadBatchIsCountedOnItsChannelAndAThrowingHandlerLosesOnlyItsTick) {
  Bus bus("memq://");
  std::vector<int64_t> ticks;
  bus.Subscribe<sirupp::arm_state_t>("SIM_ARM_STATE",
                                     [&](const sirupp::arm_state_t& m, const ReceiveInfo&) {
                                       if (m.tick == 3) throw std::runtime_error("tick 3 refused");
                                       ticks.push_back(m.tick);
                                     });
  // Not an arm_ticks_t: a state published on the batch channel.
  bus.Publish("SIM_ARM_TICKS", State(1));
  bus.HandleAvailable();
  EXPECT_TRUE(ticks.empty());
  const ChannelStats bad = bus.StatsFor("SIM_ARM_TICKS");
  EXPECT_EQ(bad.decode_errors, 1);
  EXPECT_NE(bad.last_error.find("did not decode as arm_ticks_t"), std::string::npos)
      << bad.last_error;

  TickBatch batch = Gathered(1, 5);
  bus.Publish("SIM_ARM_TICKS", batch.Take(0));
  bus.HandleAvailable();
  EXPECT_EQ(ticks, (std::vector<int64_t>{1, 2, 4, 5}));
  const ChannelStats states = bus.StatsFor("SIM_ARM_STATE");
  EXPECT_EQ(states.rejected, 1);
  EXPECT_EQ(states.last_error, "tick 3 refused");
}

TEST(TickBatch, TheBusFollowsTheBatchesOnlyWhileAPerTickChannelIsSubscribed) {
  Bus bus("memq://");
  int states = 0;
  Subscription& first = bus.Subscribe<sirupp::arm_state_t>(
      "SIM_ARM_STATE", [&](const sirupp::arm_state_t&, const ReceiveInfo&) { ++states; });
  Subscription& second = bus.Subscribe<sirupp::servo_setpoint_t>(
      "ARM_SETPOINT", [&](const sirupp::servo_setpoint_t&, const ReceiveInfo&) {});
  TickBatch batch = Gathered(1, 4);
  bus.Publish("SIM_ARM_TICKS", batch.Take(0));
  bus.HandleAvailable();
  EXPECT_EQ(states, 4);
  first.Unsubscribe();
  bus.Publish("SIM_ARM_TICKS", Gathered(5, 4).Take(0));
  bus.HandleAvailable();
  EXPECT_EQ(bus.StatsFor("SIM_ARM_TICKS").messages, 2) << "still followed for ARM_SETPOINT";
  second.Unsubscribe();
  bus.Publish("SIM_ARM_TICKS", Gathered(9, 4).Take(0));
  bus.HandleAvailable();
  EXPECT_EQ(bus.StatsFor("SIM_ARM_TICKS").messages, 2) << "no subscription left: not followed";

  // A rig prefix: the batch channel is the rig's too.
  Bus rig("memq://", "RIG3_");
  int rig_states = 0;
  rig.Subscribe<sirupp::arm_state_t>(
      "SIM_ARM_STATE", [&](const sirupp::arm_state_t&, const ReceiveInfo&) { ++rig_states; });
  rig.Publish("SIM_ARM_TICKS", Gathered(1, 3).Take(0));
  rig.HandleAvailable();
  EXPECT_EQ(rig_states, 3);
  EXPECT_EQ(rig.StatsFor("SIM_ARM_TICKS").messages, 1);
  EXPECT_EQ(rig.StatsFor("SIM_ARM_TICKS").channel, "RIG3_SIM_ARM_TICKS");
}

}  // namespace
}  // namespace sirupp::core
