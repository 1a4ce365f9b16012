// The bus master (hardware/nmc_bus.hpp) against a scripted port: replies parsed with the defined
// items, retries after a module's CKSUM_ERROR, resynchronisation after damage and silence, and
// the error that names module, command and problem when every try fails.
#include <gtest/gtest.h>

#include <cstring>
#include <deque>
#include <thread>
#include <vector>

#include "hardware/nmc_bus.hpp"

namespace sirupp::hardware {
namespace {

using Bytes = std::vector<uint8_t>;

// Each write of a command packet (starting 0xAA) takes the next scripted reply; other writes
// (resync zeros) take none. An empty reply is silence. The first `late` replies come late: they
// arrive with the next write (the resync burst), after the bus stopped waiting.
// `write_takes` is how long a write holds the caller: a bridge the scheduler held after sending,
// while the reply arrived.
class ScriptedPort : public BytePort {
 public:
  std::deque<Bytes> replies;
  std::vector<Bytes> written;
  int discards = 0;
  int late = 0;
  std::chrono::microseconds write_takes{0};

  void Write(const uint8_t* bytes, size_t n) override {
    written.emplace_back(bytes, bytes + n);
    if (!late_.empty()) {
      pending_.insert(pending_.end(), late_.begin(), late_.end());
      late_.clear();
    }
    if (n > 0 && bytes[0] == nmc::kHeader && !replies.empty()) {
      (late > 0 ? late_ : pending_) = replies.front();
      if (late > 0 && !replies.front().empty()) --late;
      replies.pop_front();
    }
    std::this_thread::sleep_for(write_takes);
  }
  size_t Read(uint8_t* bytes, size_t max, std::chrono::microseconds) override {
    const size_t n = std::min(max, pending_.size());
    if (n) std::memcpy(bytes, pending_.data(), n);
    pending_.erase(pending_.begin(), pending_.begin() + static_cast<long>(n));
    return n;
  }
  void SetBaud(int baud) override { baud_ = baud; }
  int baud() const override { return baud_; }
  void DiscardInput() override {
    ++discards;
    pending_.clear();
  }
  std::string name() const override { return "scripted"; }

 private:
  Bytes pending_;
  Bytes late_;
  int baud_ = 230400;
};

std::deque<Bytes> Replies(size_t n, const Bytes& reply) { return std::deque<Bytes>(n, reply); }

BusOptions Fast() {
  BusOptions o;
  o.reply_margin = std::chrono::microseconds(200);
  o.retries = 2;
  return o;
}

TEST(NmcBus, RepliesUseTheDefinedItems) {
  ScriptedPort port;
  NmcBus bus(port, Fast());
  nmc::Status s;
  s.status = nmc::kStatusMoveDone;
  s.position = 1234;
  s.aux = nmc::kAuxServoOn;
  port.replies.push_back(nmc::EncodeStatus(s, nmc::kSendPosition | nmc::kSendAux));
  bus.Command(nmc::DefineStatus(1, nmc::kSendPosition | nmc::kSendAux));
  EXPECT_EQ(bus.defined_items(1), nmc::kSendPosition | nmc::kSendAux);
  s.position = -99;
  port.replies.push_back(nmc::EncodeStatus(s, nmc::kSendPosition | nmc::kSendAux));
  const nmc::Status got = bus.Command(nmc::Nop(1));
  EXPECT_EQ(got.position, -99);
  EXPECT_EQ(got.aux, nmc::kAuxServoOn);
  // READ_STAT is parsed with what it asks for, once.
  s.home = 77;
  port.replies.push_back(nmc::EncodeStatus(s, nmc::kSendHome));
  EXPECT_EQ(bus.Command(nmc::ReadStatus(1, nmc::kSendHome)).home, 77);
  EXPECT_EQ(bus.defined_items(1), nmc::kSendPosition | nmc::kSendAux);
  EXPECT_EQ(port.written.back(), nmc::Encode(nmc::ReadStatus(1, nmc::kSendHome)));
  EXPECT_EQ(bus.counters().exchanges, 3);
  EXPECT_EQ(bus.counters().retries, 0);
}

TEST(NmcBus, ModuleChecksumErrorIsSentAgainWithoutResync) {
  ScriptedPort port;
  NmcBus bus(port, Fast());
  nmc::Status bad;
  bad.status = nmc::kStatusChecksumError | nmc::kStatusMoveDone;
  nmc::Status good;
  good.status = nmc::kStatusMoveDone;
  port.replies = {nmc::EncodeStatus(bad, 0), nmc::EncodeStatus(good, 0)};
  bus.Command(nmc::ClearBits(2));
  EXPECT_EQ(bus.counters().module_checksum_errors, 1);
  EXPECT_EQ(bus.counters().retries, 1);
  EXPECT_EQ(bus.counters().resyncs, 0);
  EXPECT_EQ(port.written.size(), 2u);
  EXPECT_EQ(port.written[0], port.written[1]);
}

TEST(NmcBus, DamagedReplyResynchronises) {
  ScriptedPort port;
  NmcBus bus(port, Fast());
  nmc::Status good;
  good.status = nmc::kStatusPowerOn;
  Bytes damaged = nmc::EncodeStatus(good, 0);
  damaged[1] ^= 0x01;
  port.replies = {damaged, nmc::EncodeStatus(good, 0)};
  EXPECT_EQ(bus.Command(nmc::Nop(3)).status, nmc::kStatusPowerOn);
  EXPECT_EQ(bus.counters().checksum_errors, 1);
  EXPECT_EQ(bus.counters().resyncs, 1);
  // The resync burst: 30 zero bytes between the two tries.
  ASSERT_EQ(port.written.size(), 3u);
  EXPECT_EQ(port.written[1], Bytes(30, 0));
}

TEST(NmcBus, SilenceBecomesAnErrorNamingModuleAndCommand) {
  ScriptedPort port;
  NmcBus bus(port, Fast());
  port.replies = {{}, {}, {}};
  try {
    bus.Command(nmc::LoadTrajectory(4, nmc::Trajectory{nmc::kLoadPosition, 10, 0, 0, 0}));
    FAIL() << "no error";
  } catch (const BusError& e) {
    EXPECT_EQ(e.address(), 4);
    EXPECT_EQ(e.command(), nmc::kLoadTraj);
    EXPECT_EQ(std::string(e.what()),
              "module 4: LOAD_TRAJ: no reply (3 tries at 230400 baud on scripted)");
  }
  EXPECT_EQ(bus.counters().timeouts, 3);
  EXPECT_EQ(bus.counters().resyncs, 3);
  // A short reply is damage, not silence.
  port.replies = {{0x08}, {0x08}, {0x08}};
  try {
    bus.Command(nmc::Nop(1));
    FAIL();
  } catch (const BusError& e) {
    EXPECT_NE(std::string(e.what()).find("reply cut short: 1 of 2 bytes"), std::string::npos);
  }
}

// A bridge held by the scheduler past its deadline (a loaded machine) takes the reply that arrived
// meanwhile: the module answered in time and is not silent.
TEST(NmcBus, AReplyThatArrivedWhileTheBridgeWasHeldIsTaken) {
  ScriptedPort port;
  NmcBus bus(port, Fast());
  port.write_takes = std::chrono::milliseconds(20);  // 100 times the margin
  nmc::Status s;
  s.status = nmc::kStatusMoveDone;
  port.replies = {nmc::EncodeStatus(s, 0)};
  EXPECT_EQ(bus.Command(nmc::Nop(2)).status, nmc::kStatusMoveDone);
  EXPECT_EQ(bus.counters().timeouts, 0);
  EXPECT_EQ(bus.counters().retries, 0);
}

// A module that answers after the deadline is slow, not silent: its late tries do not count among
// the retries and the next try waits longer; a module late every time is an error that says so.
TEST(NmcBus, ALateReplyIsNotSilence) {
  ScriptedPort port;
  NmcBus bus(port, Fast());
  nmc::Status s;
  s.status = nmc::kStatusPowerOn;
  // Late three times (more than the 2 retries), then in time.
  port.late = 3;
  port.replies = {nmc::EncodeStatus(s, 0), nmc::EncodeStatus(s, 0), nmc::EncodeStatus(s, 0),
                  nmc::EncodeStatus(s, 0)};
  EXPECT_EQ(bus.Command(nmc::Nop(5)).status, nmc::kStatusPowerOn);
  EXPECT_EQ(bus.counters().late_replies, 3);
  EXPECT_EQ(bus.counters().timeouts, 3);
  EXPECT_EQ(bus.counters().retries, 3);
  // Late every time: after the 4 late tries and the 3 counted ones, an error naming lateness.
  port.late = 100;
  port.replies = Replies(7, nmc::EncodeStatus(s, 0));
  try {
    bus.Command(nmc::Nop(5));
    FAIL() << "no error";
  } catch (const BusError& e) {
    EXPECT_EQ(e.address(), 5);
    EXPECT_EQ(std::string(e.what()),
              "module 5: NOP: the reply came late, after the 3.2 ms the line allows beyond its "
              "transmission time (7 tries at 230400 baud on scripted)");
  }
  EXPECT_EQ(bus.counters().late_replies, 3 + 7);
  // Silence is not lateness: 3 tries, as before.
  port.late = 0;
  port.replies = {{}, {}, {}};
  const int64_t exchanges = bus.counters().exchanges;
  EXPECT_THROW(bus.Command(nmc::Nop(5)), BusError);
  EXPECT_EQ(bus.counters().exchanges - exchanges, 3);
  EXPECT_EQ(bus.counters().late_replies, 10);
}

TEST(NmcBus, GroupCommandsTakeTheLeadersReplyAndBroadcastsNone) {
  ScriptedPort port;
  NmcBus bus(port, Fast());
  // Initialize with two modules answering SET_ADDR and READ_STAT(SEND_ID), then silence.
  nmc::Status s;
  s.status = nmc::kStatusPowerOn | nmc::kStatusMoveDone;
  s.type = nmc::kTypePicServo;
  s.version = nmc::kVersionPicServoSc;
  port.replies = {{},
                  {},  // the two hard resets: no reply
                  nmc::EncodeStatus(s, 0),
                  nmc::EncodeStatus(s, nmc::kSendId),
                  nmc::EncodeStatus(s, 0),
                  nmc::EncodeStatus(s, nmc::kSendId),
                  {},  // nobody left at address 0: SET_ADDR 3,
                  {},  // NOP to 3 (did it take effect?),
                  {},  // SET_ADDR 3 again,
                  {},  // NOP to 3 again: the end of the chain
                  {},  // SET_BAUD: no reply
                  nmc::EncodeStatus(s, 0),
                  nmc::EncodeStatus(s, 0)};
  const std::vector<ModuleInfo> found = bus.Initialize(6, 115200, 0x80);
  ASSERT_EQ(found.size(), 2u);
  EXPECT_EQ(found[1].address, 2);
  EXPECT_EQ(found[1].version, 10);
  EXPECT_EQ(port.baud(), 115200);
  // The regrouping: module 1 leads group 0x80 (bit 7 cleared), module 2 is a member.
  const size_t n = port.written.size();
  EXPECT_EQ(port.written[n - 2], nmc::Encode(nmc::SetAddress(1, 1, 0x80, true)));
  EXPECT_EQ(port.written[n - 1], nmc::Encode(nmc::SetAddress(2, 2, 0x80, false)));
  port.replies = {nmc::EncodeStatus(s, 0)};
  bus.GroupCommand(nmc::StartMove(0));
  EXPECT_EQ(port.written.back(), nmc::Encode(nmc::StartMove(0x80)));
  bus.Broadcast(nmc::StopMotor(0, nmc::kAmpEnable | nmc::kStopSmooth));
  EXPECT_EQ(port.written.back(),
            nmc::Encode(nmc::StopMotor(0x80, nmc::kAmpEnable | nmc::kStopSmooth)));
}

}  // namespace
}  // namespace sirupp::hardware
