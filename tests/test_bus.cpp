// Tests of core/bus: typed publish/subscribe, prefix, Latest, and the counters that make faults on
// a channel visible. Only memq:// is used, so the tests need no network and see every message.

#include <gtest/gtest.h>

#include <cstdint>
#include <fstream>
#include <sirupp/arm_command_t.hpp>
#include <sirupp/arm_state_t.hpp>
#include <sirupp/image_t.hpp>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/bus.hpp"

namespace sirupp::core {
namespace {

constexpr char kMemq[] = "memq://";

sirupp::arm_state_t MakeState(int64_t seq, int num_joints = 6) {
  sirupp::arm_state_t state{};
  state.utime = 512 * seq;
  state.seq = seq;
  state.tick = seq;
  state.source = sirupp::arm_state_t::SOURCE_SIM;
  state.num_joints = num_joints;
  for (int i = 0; i < num_joints; ++i) {
    state.position.push_back(0.1 * i + static_cast<double>(seq));
    state.velocity.push_back(-0.5 * i);
    state.effort.push_back(2.0 * i);
    state.flags.push_back(static_cast<int8_t>(i % 2 == 0 ? 0 : sirupp::arm_state_t::FLAG_STICKING));
  }
  return state;
}

// Counts what arrives on one exact channel name through the raw LCM API, bypassing the Bus. A plain
// function with a context, as the Bus does: LCM's member-function subscribe trips a GCC 12 UBSan
// bug.
void CountRaw(const lcm::ReceiveBuffer* /*rbuf*/, const std::string& /*channel*/, int* messages) {
  ++*messages;
}

static_assert(bus_internal::HasSeqField<sirupp::arm_state_t>::value,
              "arm_state_t has seq: gaps must be counted automatically");
static_assert(!bus_internal::HasSeqField<sirupp::image_t>::value,
              "image_t (bot_core layout) has no seq field");

TEST(BusTest, PublishSubscribeRoundTripsArmState) {
  Bus bus(kMemq);
  std::vector<sirupp::arm_state_t> received;
  std::vector<ReceiveInfo> infos;
  bus.Subscribe<sirupp::arm_state_t>("SIM_ARM_STATE",
                                     [&](const sirupp::arm_state_t& msg, const ReceiveInfo& info) {
                                       received.push_back(msg);
                                       infos.push_back(info);
                                     });

  const sirupp::arm_state_t sent = MakeState(7);
  bus.Publish("SIM_ARM_STATE", sent);
  EXPECT_EQ(bus.HandleAvailable(), 1);

  ASSERT_EQ(received.size(), 1u);
  const sirupp::arm_state_t& got = received[0];
  EXPECT_EQ(got.utime, sent.utime);
  EXPECT_EQ(got.seq, 7);
  EXPECT_EQ(got.tick, 7);
  EXPECT_EQ(got.num_joints, 6);
  EXPECT_EQ(got.position, sent.position);
  EXPECT_EQ(got.velocity, sent.velocity);
  EXPECT_EQ(got.effort, sent.effort);
  EXPECT_EQ(got.flags, sent.flags);
  EXPECT_EQ(infos[0].channel, "SIM_ARM_STATE");
  EXPECT_EQ(infos[0].encoded_size_bytes, sent.getEncodedSize());
  EXPECT_GT(infos[0].recv_utime, 0);

  const ChannelStats in = bus.StatsFor("SIM_ARM_STATE");
  EXPECT_FALSE(in.publishing);
  EXPECT_EQ(in.messages, 1);
  EXPECT_EQ(in.decode_errors, 0);
  EXPECT_EQ(in.rejected, 0);
  EXPECT_EQ(in.gaps, 0);
  const ChannelStats out = bus.StatsFor("SIM_ARM_STATE", ChannelSide::kPublishing);
  EXPECT_TRUE(out.publishing);
  EXPECT_EQ(out.messages, 1);
}

TEST(BusTest, HandleReturnsZeroWhenNothingIsQueued) {
  Bus bus(kMemq);
  EXPECT_EQ(bus.Handle(0), 0);
  EXPECT_EQ(bus.Handle(1), 0);
  EXPECT_EQ(bus.HandleAvailable(), 0);
  EXPECT_GE(bus.Fileno(), 0);
}

TEST(BusTest, PrefixIsPutInFrontOfEveryChannel) {
  Bus bus(kMemq, "RIG3_");
  EXPECT_EQ(bus.FullName("SIM_ARM_STATE"), "RIG3_SIM_ARM_STATE");

  int prefixed = 0;
  int unprefixed = 0;
  bus.raw_lcm().subscribeFunction("RIG3_SIM_ARM_STATE", &CountRaw, &prefixed);
  bus.raw_lcm().subscribeFunction("SIM_ARM_STATE", &CountRaw, &unprefixed);
  std::string typed_channel;
  bus.Subscribe<sirupp::arm_state_t>(
      "SIM_ARM_STATE",
      [&](const sirupp::arm_state_t&, const ReceiveInfo& info) { typed_channel = info.channel; });

  bus.Publish("SIM_ARM_STATE", MakeState(0));
  EXPECT_EQ(bus.HandleAvailable(), 1);

  EXPECT_EQ(prefixed, 1);
  EXPECT_EQ(unprefixed, 0);
  EXPECT_EQ(typed_channel, "RIG3_SIM_ARM_STATE");
  EXPECT_EQ(bus.StatsFor("SIM_ARM_STATE").channel, "RIG3_SIM_ARM_STATE");
  EXPECT_EQ(bus.StatsFor("SIM_ARM_STATE").messages, 1);
}

TEST(BusTest, LatestHoldsTheNewestMessage) {
  Bus bus(kMemq);
  Latest<sirupp::arm_state_t> latest(bus, "SIM_ARM_STATE");
  EXPECT_FALSE(latest.Has());
  EXPECT_EQ(latest.count(), 0);
  EXPECT_EQ(latest.recv_utime(), 0);
  EXPECT_THROW(latest.Get(), BusError);

  for (int64_t seq = 0; seq < 3; ++seq) bus.Publish("SIM_ARM_STATE", MakeState(seq));
  EXPECT_EQ(bus.HandleAvailable(), 3);

  ASSERT_TRUE(latest.Has());
  EXPECT_EQ(latest.count(), 3);
  EXPECT_EQ(latest.Get().seq, 2);
  EXPECT_DOUBLE_EQ(latest.Get().position[0], 2.0);
  EXPECT_GT(latest.recv_utime(), 0);
  EXPECT_EQ(latest.channel(), "SIM_ARM_STATE");
}

TEST(BusTest, HandleBatchedTakesEverythingQueuedInOrderAndIsNotReentrant) {
  Bus bus(kMemq);
  std::vector<int64_t> seen;
  bus.Subscribe<sirupp::arm_state_t>(
      "SIM_ARM_STATE", [&](const sirupp::arm_state_t& state, const ReceiveInfo& info) {
        seen.push_back(state.seq);
        EXPECT_GT(info.recv_utime, 0);
        EXPECT_THROW(bus.HandleBatched(0), BusError);
      });
  EXPECT_EQ(bus.HandleBatched(1), 0);  // nothing queued: waits, handles none
  for (int64_t seq = 0; seq < 5; ++seq) bus.Publish("SIM_ARM_STATE", MakeState(seq));
  EXPECT_EQ(bus.HandleBatched(2), 5);
  EXPECT_EQ(seen, (std::vector<int64_t>{0, 1, 2, 3, 4}));
  EXPECT_EQ(bus.StatsFor("SIM_ARM_STATE").messages, 5);
  EXPECT_EQ(bus.StatsFor("SIM_ARM_STATE").gaps, 0);
}

TEST(BusTest, LatestUnsubscribesWhenDestroyed) {
  Bus bus(kMemq);
  int witness_calls = 0;  // keeps the channel subscribed, so LCM still dispatches after the Latest
  bus.Subscribe<sirupp::arm_state_t>(
      "SIM_ARM_STATE", [&](const sirupp::arm_state_t&, const ReceiveInfo&) { ++witness_calls; });
  {
    Latest<sirupp::arm_state_t> latest(bus, "SIM_ARM_STATE");
    bus.Publish("SIM_ARM_STATE", MakeState(0));
    bus.HandleAvailable();
    EXPECT_EQ(latest.count(), 1);
  }
  // With the Latest gone its handler must not run (it would write to freed memory under ASan).
  bus.Publish("SIM_ARM_STATE", MakeState(1));
  EXPECT_EQ(bus.HandleAvailable(), 1);
  EXPECT_EQ(witness_calls, 2);
  EXPECT_EQ(bus.StatsFor("SIM_ARM_STATE").messages, 2);
}

TEST(BusTest, WrongTypeAndGarbageAreDecodeErrorsAndNeverReachTheHandler) {
  Bus bus(kMemq);
  int handler_calls = 0;
  bus.Subscribe<sirupp::arm_state_t>(
      "SIM_ARM_STATE", [&](const sirupp::arm_state_t&, const ReceiveInfo&) { ++handler_calls; });

  // An arm_command_t where an arm_state_t is expected: a fingerprint mismatch.
  sirupp::arm_command_t command{};  // {}: generated types leave fields uninitialized
  command.sender = "student";
  command.num_joints = 2;
  command.effort = {1.0, 2.0};
  bus.Publish("SIM_ARM_STATE", command);
  // Raw garbage through the underlying LCM, shorter and longer than a fingerprint.
  const uint8_t garbage[20] = {0xde, 0xad, 0xbe, 0xef, 1, 2, 3, 4, 5, 6};
  bus.raw_lcm().publish("SIM_ARM_STATE", garbage, 3);
  bus.raw_lcm().publish("SIM_ARM_STATE", garbage, sizeof garbage);
  // A real arm_state_t cut short: right fingerprint, body missing.
  const sirupp::arm_state_t state = MakeState(0);
  std::vector<uint8_t> encoded(static_cast<std::size_t>(state.getEncodedSize()));
  ASSERT_EQ(state.encode(encoded.data(), 0, static_cast<int>(encoded.size())),
            static_cast<int>(encoded.size()));
  bus.raw_lcm().publish("SIM_ARM_STATE", encoded.data(), 30);

  EXPECT_EQ(bus.HandleAvailable(), 4);
  EXPECT_EQ(handler_calls, 0);
  const ChannelStats stats = bus.StatsFor("SIM_ARM_STATE");
  EXPECT_EQ(stats.messages, 4);
  EXPECT_EQ(stats.decode_errors, 4);
  EXPECT_EQ(stats.rejected, 0);
  // The last one was the truncated state: the description says so, with type and size.
  EXPECT_NE(stats.last_error.find("SIM_ARM_STATE"), std::string::npos) << stats.last_error;
  EXPECT_NE(stats.last_error.find("arm_state_t"), std::string::npos) << stats.last_error;
  EXPECT_NE(stats.last_error.find("30-byte"), std::string::npos) << stats.last_error;
  EXPECT_NE(stats.last_error.find("truncated"), std::string::npos) << stats.last_error;

  // The channel still works for good messages.
  bus.Publish("SIM_ARM_STATE", state);
  bus.HandleAvailable();
  EXPECT_EQ(handler_calls, 1);
  EXPECT_EQ(bus.StatsFor("SIM_ARM_STATE").decode_errors, 4);
}

// Peak resident memory of this process so far, KiB (VmHWM).
long PeakResidentKib() {
  std::ifstream status("/proc/self/status");
  for (std::string line; std::getline(status, line);) {
    if (line.rfind("VmHWM:", 0) == 0) return std::stol(line.substr(6));
  }
  return 0;
}

TEST(BusTest, AbsurdArrayCountsAreDecodeErrorsWithoutAllocating) {
  // Right fingerprint, num_joints patched to 50 million (400 MB per array once resized) or -1: the
  // generated decoder, with the count check cmake/SiruppLcmGen.cmake adds, refuses it before it
  // resizes any vector, so the peak memory does not grow.
  Bus bus(kMemq);
  int handler_calls = 0;
  bus.Subscribe<sirupp::arm_state_t>(
      "SIM_ARM_STATE", [&](const sirupp::arm_state_t&, const ReceiveInfo&) { ++handler_calls; });
  const sirupp::arm_state_t state = MakeState(0);
  std::vector<uint8_t> encoded(static_cast<std::size_t>(state.getEncodedSize()));
  ASSERT_EQ(state.encode(encoded.data(), 0, static_cast<int>(encoded.size())),
            static_cast<int>(encoded.size()));
  const std::size_t count_at = 8 + 8 + 8 + 8 + 1;  // fingerprint, utime, seq, tick, source
  ASSERT_EQ(encoded[count_at + 3], state.num_joints);
  const long peak_before = PeakResidentKib();
  for (const uint32_t count : {50000000u, 0xffffffffu}) {
    std::vector<uint8_t> bad = encoded;
    for (int b = 0; b < 4; ++b) bad[count_at + b] = static_cast<uint8_t>(count >> (24 - 8 * b));
    bus.raw_lcm().publish("SIM_ARM_STATE", bad.data(), static_cast<unsigned>(bad.size()));
  }
  EXPECT_EQ(bus.HandleAvailable(), 2);
  EXPECT_EQ(handler_calls, 0);
  EXPECT_EQ(bus.StatsFor("SIM_ARM_STATE").decode_errors, 2);
  EXPECT_LT(PeakResidentKib() - peak_before, 100 * 1024) << "decode allocated for the bad count";
}

TEST(BusTest, WrongTypeDescriptionNamesTheForeignFingerprint) {
  Bus bus(kMemq);
  bus.Subscribe<sirupp::arm_state_t>("SIM_ARM_STATE",
                                     [](const sirupp::arm_state_t&, const ReceiveInfo&) {});
  sirupp::arm_command_t command{};
  bus.Publish("SIM_ARM_STATE", command);
  bus.HandleAvailable();
  const std::string error = bus.StatsFor("SIM_ARM_STATE").last_error;
  EXPECT_NE(error.find("another type"), std::string::npos) << error;
  EXPECT_NE(error.find(std::to_string(command.getEncodedSize()) + "-byte"), std::string::npos)
      << error;
}

TEST(BusTest, ThrowingHandlerIsCountedAsRejectedAndDoesNotCrash) {
  Bus bus(kMemq);
  int handler_calls = 0;
  bus.Subscribe<sirupp::arm_state_t>(
      "SIM_ARM_STATE", [&](const sirupp::arm_state_t& msg, const ReceiveInfo&) {
        ++handler_calls;
        if (msg.seq == 1) throw std::runtime_error("num_joints 5, the model has 6");
        if (msg.seq == 2) throw 42;  // not a std::exception: must be caught all the same
      });

  for (int64_t seq = 0; seq < 4; ++seq) bus.Publish("SIM_ARM_STATE", MakeState(seq));
  EXPECT_EQ(bus.HandleAvailable(), 4);

  EXPECT_EQ(handler_calls, 4);  // still subscribed after throwing
  ChannelStats stats = bus.StatsFor("SIM_ARM_STATE");
  EXPECT_EQ(stats.messages, 4);
  EXPECT_EQ(stats.rejected, 2);
  EXPECT_EQ(stats.decode_errors, 0);
  EXPECT_NE(stats.last_error.find("not derived from std::exception"), std::string::npos);

  bus.Publish("SIM_ARM_STATE", MakeState(1));
  bus.HandleAvailable();
  stats = bus.StatsFor("SIM_ARM_STATE");
  EXPECT_EQ(stats.rejected, 3);
  EXPECT_EQ(stats.last_error, "num_joints 5, the model has 6");
}

TEST(BusTest, HandlerCanRejectAndCountLateMessages) {
  Bus bus(kMemq);
  bus.Subscribe<sirupp::arm_state_t>(
      "SIM_ARM_STATE", [&](const sirupp::arm_state_t& msg, const ReceiveInfo& info) {
        if (msg.num_joints != 6) bus.Reject(info, "num_joints " + std::to_string(msg.num_joints));
        if (msg.seq == 3) bus.NoteLate(info);
      });
  bus.Publish("SIM_ARM_STATE", MakeState(0));
  bus.Publish("SIM_ARM_STATE", MakeState(1, 5));
  bus.Publish("SIM_ARM_STATE", MakeState(2));
  bus.Publish("SIM_ARM_STATE", MakeState(3));
  bus.HandleAvailable();
  bus.NoteLate("SIM_ARM_STATE");  // from the main loop, e.g. a lockstep deadline

  const ChannelStats stats = bus.StatsFor("SIM_ARM_STATE");
  EXPECT_EQ(stats.rejected, 1);
  EXPECT_EQ(stats.last_error, "num_joints 5");
  EXPECT_EQ(stats.late, 2);
}

TEST(BusTest, ValidatorRejectionIsCountedAndNotStored) {
  Bus bus(kMemq);
  Latest<sirupp::arm_state_t> latest(bus, "SIM_ARM_STATE", [](const sirupp::arm_state_t& msg) {
    return msg.num_joints == 6 ? std::string()
                               : "num_joints " + std::to_string(msg.num_joints) + ", expected 6";
  });

  bus.Publish("SIM_ARM_STATE", MakeState(0));
  bus.Publish("SIM_ARM_STATE", MakeState(1, 5));
  EXPECT_EQ(bus.HandleAvailable(), 2);

  ASSERT_TRUE(latest.Has());
  EXPECT_EQ(latest.count(), 1);
  EXPECT_EQ(latest.Get().seq, 0);
  EXPECT_EQ(latest.Get().num_joints, 6);
  const ChannelStats stats = bus.StatsFor("SIM_ARM_STATE");
  EXPECT_EQ(stats.messages, 2);
  EXPECT_EQ(stats.rejected, 1);
  EXPECT_EQ(stats.last_error, "num_joints 5, expected 6");
}

TEST(BusTest, SequenceGapsAreCountedAutomatically) {
  Bus bus(kMemq);
  int handler_calls = 0;
  bus.Subscribe<sirupp::arm_state_t>(
      "SIM_ARM_STATE", [&](const sirupp::arm_state_t&, const ReceiveInfo&) { ++handler_calls; });
  for (int64_t seq : {0, 1, 2, 5}) bus.Publish("SIM_ARM_STATE", MakeState(seq));
  bus.HandleAvailable();
  EXPECT_EQ(handler_calls, 4);
  EXPECT_EQ(bus.StatsFor("SIM_ARM_STATE").gaps, 2);
}

TEST(BusTest, NoteSequenceCountsSkippedNumbersOnly) {
  Bus bus(kMemq);
  for (int64_t seq : {0, 1, 2, 5}) bus.NoteSequence("HEARTBEAT", seq);
  EXPECT_EQ(bus.StatsFor("HEARTBEAT").gaps, 2);
  bus.NoteSequence("HEARTBEAT", 5);  // repeated: nothing lost
  EXPECT_EQ(bus.StatsFor("HEARTBEAT").gaps, 2);
  bus.NoteSequence("HEARTBEAT", 0);  // publisher restarted
  bus.NoteSequence("HEARTBEAT", 1);
  EXPECT_EQ(bus.StatsFor("HEARTBEAT").gaps, 2);
  bus.NoteSequence("HEARTBEAT", 11);
  EXPECT_EQ(bus.StatsFor("HEARTBEAT").gaps, 11);
  // A wild value from a corrupt message saturates instead of overflowing.
  bus.NoteSequence("HEARTBEAT", INT64_MIN);
  bus.NoteSequence("HEARTBEAT", INT64_MAX);
  EXPECT_EQ(bus.StatsFor("HEARTBEAT").gaps, INT64_MAX);
}

TEST(BusTest, TwoSubscriptionsOfOneChannelCountEachMessageOnce) {
  Bus bus(kMemq);
  int first = 0;
  int second = 0;
  bus.Subscribe<sirupp::arm_state_t>(
      "SIM_ARM_STATE", [&](const sirupp::arm_state_t&, const ReceiveInfo&) { ++first; });
  bus.Subscribe<sirupp::arm_state_t>("SIM_ARM_STATE",
                                     [&](const sirupp::arm_state_t&, const ReceiveInfo&) {
                                       ++second;
                                       throw std::runtime_error("refused twice?");
                                     });
  bus.Publish("SIM_ARM_STATE", MakeState(0));
  bus.Publish("SIM_ARM_STATE", MakeState(3));
  EXPECT_EQ(bus.HandleAvailable(), 2);
  EXPECT_EQ(first, 2);
  EXPECT_EQ(second, 2);
  const ChannelStats stats = bus.StatsFor("SIM_ARM_STATE");
  EXPECT_EQ(stats.messages, 2);
  EXPECT_EQ(stats.rejected, 2);
  EXPECT_EQ(stats.gaps, 2);
}

TEST(BusTest, UnsubscribeStopsDeliveryAlsoFromInsideAHandler) {
  Bus bus(kMemq);
  int calls = 0;
  Subscription* self = nullptr;
  self = &bus.Subscribe<sirupp::arm_state_t>("SIM_ARM_STATE",
                                             [&](const sirupp::arm_state_t&, const ReceiveInfo&) {
                                               ++calls;
                                               self->Unsubscribe();  // one-shot subscription
                                             });
  int other_calls = 0;
  Subscription& other = bus.Subscribe<sirupp::arm_state_t>(
      "SIM_ARM_STATE", [&](const sirupp::arm_state_t&, const ReceiveInfo&) { ++other_calls; });
  EXPECT_TRUE(other.active());
  EXPECT_EQ(other.channel(), "SIM_ARM_STATE");
  int witness_calls = 0;  // stays subscribed, so LCM keeps dispatching the channel
  bus.Subscribe<sirupp::arm_state_t>(
      "SIM_ARM_STATE", [&](const sirupp::arm_state_t&, const ReceiveInfo&) { ++witness_calls; });

  bus.Publish("SIM_ARM_STATE", MakeState(0));
  bus.Publish("SIM_ARM_STATE", MakeState(1));
  bus.HandleAvailable();
  EXPECT_EQ(calls, 1);
  EXPECT_EQ(other_calls, 2);

  bus.Unsubscribe(other);
  bus.Publish("SIM_ARM_STATE", MakeState(2));
  EXPECT_EQ(bus.HandleAvailable(), 1);
  EXPECT_EQ(witness_calls, 3);
  EXPECT_EQ(other_calls, 2);
  EXPECT_EQ(calls, 1);
}

TEST(BusTest, SubscriptionRemovedByAnotherHandlerMissesTheSameMessage) {
  Bus bus(kMemq);
  Subscription* victim = nullptr;
  int victim_calls = 0;
  // LCM calls handlers in subscription order: the first one removes the second mid-dispatch.
  bus.Subscribe<sirupp::arm_state_t>("SIM_ARM_STATE",
                                     [&](const sirupp::arm_state_t&, const ReceiveInfo&) {
                                       if (victim != nullptr) victim->Unsubscribe();
                                       victim = nullptr;
                                     });
  victim = &bus.Subscribe<sirupp::arm_state_t>(
      "SIM_ARM_STATE", [&](const sirupp::arm_state_t&, const ReceiveInfo&) { ++victim_calls; });
  bus.Publish("SIM_ARM_STATE", MakeState(0));
  bus.Publish("SIM_ARM_STATE", MakeState(1));
  EXPECT_EQ(bus.HandleAvailable(), 2);
  EXPECT_EQ(victim_calls, 0);
}

TEST(BusTest, HandleInsideAHandlerIsRefusedAndCounted) {
  Bus bus(kMemq);
  bus.Subscribe<sirupp::arm_state_t>(
      "SIM_ARM_STATE", [&](const sirupp::arm_state_t&, const ReceiveInfo&) { bus.Handle(0); });
  bus.Publish("SIM_ARM_STATE", MakeState(0));
  bus.Publish("SIM_ARM_STATE", MakeState(1));
  EXPECT_EQ(bus.HandleAvailable(), 2);
  const ChannelStats stats = bus.StatsFor("SIM_ARM_STATE");
  EXPECT_EQ(stats.rejected, 2);
  EXPECT_NE(stats.last_error.find("inside a message handler"), std::string::npos);
}

TEST(BusTest, BadUrlThrowsBusErrorNamingTheUrlAndTheChoices) {
  try {
    Bus bus("bogus://nowhere");
    FAIL() << "a bogus URL must not give a working bus";
  } catch (const BusError& error) {
    const std::string text = error.what();
    EXPECT_NE(text.find("\"bogus://nowhere\""), std::string::npos) << text;
    EXPECT_NE(text.find("memq://"), std::string::npos) << text;
    EXPECT_NE(text.find("udpm://239.255.76.67:7667?ttl=0"), std::string::npos) << text;
    EXPECT_NE(text.find("file://"), std::string::npos) << text;
  }
  EXPECT_THROW(Bus("udpm://999.1.2.3:7667"), BusError);
}

TEST(BusTest, BadPrefixAndChannelNamesThrow) {
  try {
    Bus bus(kMemq, "RIG-3");
    FAIL() << "prefix with '-' accepted";
  } catch (const BusError& error) {
    EXPECT_NE(std::string(error.what()).find("RIG-3"), std::string::npos) << error.what();
  }

  Bus bus(kMemq, "RIG3_");
  const sirupp::arm_state_t state = MakeState(0);
  EXPECT_THROW(bus.Publish("ARM STATE", state), BusError);
  EXPECT_THROW(bus.Publish("ARM.*", state), BusError);
  EXPECT_THROW(bus.Publish("", state), BusError);
  EXPECT_THROW(bus.Publish(std::string(59, 'X'), state), BusError);  // 5 + 59 > 63
  EXPECT_NO_THROW(bus.Publish(std::string(58, 'X'), state));
  EXPECT_THROW(bus.Subscribe<sirupp::arm_state_t>(
                   "A B", [](const sirupp::arm_state_t&, const ReceiveInfo&) {}),
               BusError);
  EXPECT_THROW(bus.Subscribe<sirupp::arm_state_t>("SIM_ARM_STATE", nullptr), BusError);
  EXPECT_THROW(bus.Subscribe<sirupp::arm_state_t>(
                   "SIM_ARM_STATE", [](const sirupp::arm_state_t&, const ReceiveInfo&) {}, 0),
               BusError);
}

TEST(BusTest, PublishingAMessageThatCannotBeEncodedThrows) {
  Bus bus(kMemq);
  sirupp::arm_state_t state = MakeState(0);
  state.num_joints = -1;  // a negative count: the encoder fails instead of writing
  try {
    bus.Publish("SIM_ARM_STATE", state);
    FAIL() << "negative count published";
  } catch (const BusError& error) {
    EXPECT_NE(std::string(error.what()).find("SIM_ARM_STATE"), std::string::npos) << error.what();
  }
  EXPECT_EQ(bus.StatsFor("SIM_ARM_STATE", ChannelSide::kPublishing).messages, 0);
}

TEST(BusTest, StatsListsPublishingAndSubscribingChannels) {
  Bus bus(kMemq, "RIG3_");
  bus.Subscribe<sirupp::arm_state_t>("SIM_ARM_STATE",
                                     [](const sirupp::arm_state_t&, const ReceiveInfo&) {});
  bus.Subscribe<sirupp::arm_command_t>("SIM_ARM_COMMAND",
                                       [](const sirupp::arm_command_t&, const ReceiveInfo&) {});
  sirupp::arm_command_t command{};
  bus.Publish("SIM_ARM_COMMAND", command);
  bus.Publish("SIM_ARM_COMMAND", command);
  bus.HandleAvailable();

  const std::vector<ChannelStats> stats = bus.Stats();
  // SIM_ARM_STATE's subscription brings the bus's own one of SIM_ARM_TICKS (core/tick_batch.hpp).
  ASSERT_EQ(stats.size(), 4u);
  EXPECT_EQ(stats[0].channel, "RIG3_SIM_ARM_COMMAND");
  EXPECT_FALSE(stats[0].publishing);
  EXPECT_EQ(stats[0].messages, 2);
  EXPECT_EQ(stats[1].channel, "RIG3_SIM_ARM_COMMAND");
  EXPECT_TRUE(stats[1].publishing);
  EXPECT_EQ(stats[1].messages, 2);
  EXPECT_EQ(stats[2].channel, "RIG3_SIM_ARM_STATE");  // listed before any message arrived
  EXPECT_FALSE(stats[2].publishing);
  EXPECT_EQ(stats[2].messages, 0);
  EXPECT_EQ(stats[3].channel, "RIG3_SIM_ARM_TICKS");
  EXPECT_FALSE(stats[3].publishing);

  const ChannelStats unused = bus.StatsFor("ESTOP");
  EXPECT_EQ(unused.channel, "RIG3_ESTOP");
  EXPECT_EQ(unused.messages, 0);
}

}  // namespace
}  // namespace sirupp::core
