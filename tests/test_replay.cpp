// `sirupp replay`'s core (tools/replay_commands.hpp) in process, on memq://: every event of a log
// written with lcm::LogFile is published once, in order, with its bytes, at the recorded gaps
// divided by the speed; a stop request ends it early; a missing file is an error.
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <lcm/lcm-cpp.hpp>
#include <string>
#include <vector>

#include "tools/replay_commands.hpp"

namespace sirupp::tools {
namespace {

struct Received {
  std::string channel;
  std::string data;
};

struct Recorder {
  std::vector<Received> got;
};

// Through LCM's C interface: the C++ header's untyped member subscription trips UBSan's vptr check
// in sanitizer builds (lcm-cpp-impl.hpp casts its subscription object through void*).
void RecordEvent(const lcm_recv_buf_t* buffer, const char* channel, void* user) {
  static_cast<Recorder*>(user)->got.push_back(
      {channel, std::string(static_cast<const char*>(buffer->data), buffer->data_size)});
}

// A log of `count` events 100 ms apart on two channels; returns its path.
std::string WriteLog(int count) {
  char path[] = "/tmp/sirupp_replay_XXXXXX";
  const int fd = mkstemp(path);
  EXPECT_GE(fd, 0);
  close(fd);
  lcm::LogFile log(path, "w");
  EXPECT_TRUE(log.good());
  for (int i = 0; i < count; ++i) {
    std::string payload = "message " + std::to_string(i) + std::string(1, '\0') + "\t\xff";
    lcm::LogEvent event;
    event.eventnum = i;
    event.timestamp = 1700000000000000 + i * 100000;  // 100 ms apart
    event.channel = i % 2 ? "ODD" : "EVEN";
    event.datalen = static_cast<int32_t>(payload.size());
    event.data = payload.data();
    EXPECT_EQ(log.writeEvent(&event), 0);
  }
  return path;
}

TEST(Replay, PublishesEveryEventInOrderAtTheScaledTiming) {
  const std::string path = WriteLog(9);  // a span of 0.8 s
  lcm::LCM lcm("memq://");
  ASSERT_TRUE(lcm.good());
  Recorder recorder;
  lcm_subscribe(lcm.getUnderlyingLCM(), ".*", RecordEvent, &recorder);
  const ReplayStats stats = ReplayLog(path, lcm, 4.0, [] { return false; });
  while (lcm.handleTimeout(0) > 0) {
  }
  std::remove(path.c_str());

  EXPECT_EQ(stats.events, 9);
  EXPECT_EQ(stats.channels, 2);
  EXPECT_DOUBLE_EQ(stats.log_span_s, 0.8);
  EXPECT_GE(stats.wall_s, 0.2 - 1e-3);  // never early
  EXPECT_LT(stats.wall_s, 0.6);         // late only by scheduling; at speed 1 it would take 0.8 s
  EXPECT_FALSE(stats.stopped);
  ASSERT_EQ(recorder.got.size(), 9U);
  for (size_t i = 0; i < recorder.got.size(); ++i) {
    EXPECT_EQ(recorder.got[i].channel, i % 2 ? "ODD" : "EVEN");
    EXPECT_EQ(recorder.got[i].data,
              "message " + std::to_string(i) + std::string(1, '\0') + "\t\xff");
  }
}

TEST(Replay, StopsWhenAsked) {
  const std::string path = WriteLog(50);  // 4.9 s at speed 1
  lcm::LCM lcm("memq://");
  const auto start = std::chrono::steady_clock::now();
  const ReplayStats stats = ReplayLog(path, lcm, 1.0, [start] {
    return std::chrono::steady_clock::now() - start > std::chrono::milliseconds(250);
  });
  std::remove(path.c_str());
  EXPECT_TRUE(stats.stopped);
  EXPECT_GE(stats.events, 2);
  EXPECT_LE(stats.events, 5);
}

TEST(Replay, MissingFileAndBadSpeedAreErrors) {
  lcm::LCM lcm("memq://");
  EXPECT_THROW(ReplayLog("/nonexistent/run.lcm", lcm, 1.0, {}), std::runtime_error);
  EXPECT_THROW(ReplayLog("/nonexistent/run.lcm", lcm, 0.0, {}), std::invalid_argument);
}

}  // namespace
}  // namespace sirupp::tools
