// The emulator over its real pseudo-terminal, talked to with hardware::SerialPort as the bridge
// does: NmcInit's addressing, a three-joint move to its goal, SET_BAUD and the line's timing, the
// inter-byte timeout, and every fault setting; and over its socket line.

#include <gtest/gtest.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>
#include <thread>
#include <vector>

#include "core/model_loader.hpp"
#include "hardware/emulator.hpp"
#include "hardware/nmc_protocol.hpp"
#include "hardware/serial_port.hpp"
#include "servo/servo_units.hpp"

namespace sirupp::hardware {
namespace {

using namespace nmc;
using Bytes = std::vector<uint8_t>;
using Clock = std::chrono::steady_clock;

constexpr double kDeg = 3.14159265358979323846 / 180;

const core::RobotModel& Puma() {
  static const core::RobotModel model = core::LoadRobotModel("config/robots/puma260.yaml");
  return model;
}

EmulatorOptions Options() {
  EmulatorOptions options;
  options.model = Puma();
  return options;
}

void Sleep(double seconds) { std::this_thread::sleep_for(std::chrono::duration<double>(seconds)); }

// How long a reply that should come is waited for: a loaded machine can starve the emulator's
// thread for most of a second (0.7 s seen with an ASan build and two busy loops on two cores), and
// a reply read after the next packet was sent would be taken for that one's. Only a missing reply
// waits this long; the checks for silence pass a short timeout of their own.
constexpr double kReplyS = 10;

// Sends a packet and reads `expect` reply bytes (fewer if none come within `timeout_s`).
Bytes Transact(SerialPort& port, const Packet& packet, size_t expect, double timeout_s = kReplyS) {
  const Bytes out = Encode(packet);
  port.Write(out.data(), out.size());
  Bytes in;
  const auto deadline = Clock::now() + std::chrono::duration<double>(timeout_s);
  while (in.size() < expect && Clock::now() < deadline) {
    uint8_t buffer[64];
    const auto left =
        std::chrono::duration_cast<std::chrono::microseconds>(deadline - Clock::now());
    const size_t n = port.Read(buffer, std::min(sizeof buffer, expect - in.size()),
                               std::max(left, std::chrono::microseconds(1)));
    in.insert(in.end(), buffer, buffer + n);
  }
  return in;
}

// NmcInit: zeros and two hard resets, then SET_ADDR to address 0 until nobody answers; returns the
// number of modules found (each checked for type 0, version 10). The `expected` modules' answers
// are waited for as long as any reply (kReplyS); the end of the chain after them, where silence is
// the answer, 0.1 s.
int NmcInit(SerialPort& port, int expected) {
  const Bytes zeros(20, 0);
  port.Write(zeros.data(), zeros.size());
  for (int i = 0; i < 2; ++i) {
    EXPECT_TRUE(Transact(port, HardReset(kBroadcast), 1, 0.05).empty());
  }
  port.DiscardInput();
  int found = 0;
  for (uint8_t a = 1; a <= kMaxModules; ++a) {
    const Bytes r = Transact(port, SetAddress(0, a, 0xFF, false), 2, a <= expected ? kReplyS : 0.1);
    if (r.size() < 2) break;
    EXPECT_EQ(r[0], r[1]) << "checksum = status";
    const Bytes id = Transact(port, ReadStatus(a, kSendId), 4);
    EXPECT_EQ(id.size(), 4U);
    if (id.size() == 4) {
      EXPECT_EQ(id[1], kTypePicServo);
      EXPECT_EQ(id[2], kVersionPicServoSc);
    }
    ++found;
  }
  return found;
}

// Waits until the emulator has run `ticks` more servo ticks (a trigger acts at the next one).
void WaitTicks(const Emulator& emulator, uint64_t ticks) {
  const uint64_t until = emulator.counters().servo_ticks + ticks;
  const auto deadline = Clock::now() + std::chrono::seconds(5);
  while (emulator.counters().servo_ticks < until && Clock::now() < deadline) Sleep(0.001);
}

Gains ModelGains(const core::ServoParams& s) {
  Gains g;
  g.kp = static_cast<int16_t>(s.kp);
  g.kd = static_cast<int16_t>(s.kd);
  g.ki = static_cast<int16_t>(s.ki);
  g.integration_limit = static_cast<int16_t>(s.integration_limit);
  g.output_limit = static_cast<uint8_t>(s.output_limit);
  g.current_limit = static_cast<uint8_t>(s.current_limit);
  g.error_limit = static_cast<int16_t>(s.error_limit);
  g.servo_rate = 1;
  return g;
}

// Gains, amplifier on, servo on where each joint is, POS_ERR cleared.
void ServoOn(SerialPort& port, int modules) {
  for (int k = 0; k < modules; ++k) {
    const auto a = static_cast<uint8_t>(k + 1);
    ASSERT_EQ(Transact(port, SetGain(a, ModelGains(Puma().joints[k].servo)), 2).size(), 2U);
    ASSERT_EQ(Transact(port, StopMotor(a, kAmpEnable | kStopAbrupt), 2).size(), 2U);
    ASSERT_EQ(Transact(port, ClearBits(a), 2).size(), 2U);
  }
}

TEST(Emulator, NmcInitFindsEveryModuleOverThePty) {
  Emulator emulator(Options());
  emulator.Start();
  SerialPort port(emulator.device(), 19200);
  EXPECT_EQ(NmcInit(port, 6), 6);
  const EmulatorCounters c = emulator.counters();
  EXPECT_EQ(c.commands_received, 2U + 6 * 2 + 1);
  EXPECT_EQ(c.replies_sent, 12U);
  EXPECT_EQ(c.bytes_skipped, 20U) << "the zeros before the reset";
  EXPECT_GT(c.servo_ticks, 0U);
  emulator.Stop();
}

TEST(Emulator, AThreeJointMoveReachesItsGoal) {
  // The paper's set VII: joints 1 to 3 from 0 to 90 degrees, one START_MOVE to the group.
  Emulator emulator(Options());
  emulator.Start();
  SerialPort port(emulator.device(), 19200);
  ASSERT_EQ(NmcInit(port, 6), 6);
  ServoOn(port, 6);
  for (uint8_t a = 1; a <= 6; ++a) {
    ASSERT_EQ(Transact(port, SetAddress(a, a, 0x80, a == 1), 2).size(), 2U);
  }
  for (int j = 0; j < 3; ++j) {
    const core::Joint& joint = Puma().joints[static_cast<size_t>(j)];
    const servo::JointDrive drive(joint, Puma().servo_tick_s);
    Trajectory t;
    t.control = kLoadPosition | kLoadVelocity | kLoadAcceleration | kEnableServo;
    t.position = static_cast<int32_t>(drive.ToCounts(90 * kDeg));
    t.velocity = static_cast<uint32_t>(drive.VelocityWord(joint.servo.default_velocity));
    t.acceleration =
        static_cast<uint32_t>(drive.AccelerationWord(joint.servo.default_acceleration));
    ASSERT_EQ(Transact(port, LoadTrajectory(static_cast<uint8_t>(j + 1), t), 2).size(), 2U);
  }
  const auto start = Clock::now();
  const Bytes started = Transact(port, StartMove(0x80), 2);
  ASSERT_EQ(started.size(), 2U) << "the leader answers";
  double done_s = -1;
  double first_motion_s = -1;  // of the waist, which friction holds longest
  while (done_s < 0 && Clock::now() - start < std::chrono::seconds(60)) {
    if (first_motion_s < 0 && std::abs(emulator.JointPositions()[0]) > 1e-4) {
      first_motion_s = std::chrono::duration<double>(Clock::now() - start).count();
    }
    bool all = true;
    for (uint8_t a = 1; a <= 3; ++a) {
      const Bytes r = Transact(port, Nop(a), 2);
      all = all && r.size() == 2 && (r[0] & kStatusMoveDone);
    }
    if (all) done_s = std::chrono::duration<double>(Clock::now() - start).count();
  }
  ASSERT_GT(done_s, 0) << "MOVE_DONE on joints 1-3";
  // Settled: within 0.5 degree of the goal, and still.
  double settled_s = -1;
  while (Clock::now() - start < std::chrono::seconds(62)) {
    const std::vector<double> q = emulator.JointPositions();
    bool near = true;
    for (int j = 0; j < 3; ++j)
      near = near && std::abs(q[static_cast<size_t>(j)] - 90 * kDeg) < 0.5 * kDeg;
    if (near) {
      settled_s = std::chrono::duration<double>(Clock::now() - start).count();
      break;
    }
    Sleep(0.005);
  }
  Sleep(0.3);
  const std::vector<double> q = emulator.JointPositions();
  std::printf(
      "set VII on the emulator: waist moves after %.3f s, MOVE_DONE after %.3f s, within 0.5 deg "
      "after %.3f s; "
      "final %.3f %.3f %.3f deg; others %.3f %.3f %.3f deg; %llu ticks caught up, %llu slipped\n",
      first_motion_s, done_s, settled_s, q[0] / kDeg, q[1] / kDeg, q[2] / kDeg, q[3] / kDeg,
      q[4] / kDeg, q[5] / kDeg,
      static_cast<unsigned long long>(emulator.counters().ticks_caught_up),
      static_cast<unsigned long long>(emulator.counters().ticks_slipped));
  for (int j = 0; j < 3; ++j) EXPECT_NEAR(q[static_cast<size_t>(j)], 90 * kDeg, 0.5 * kDeg);
  for (int j = 3; j < 6; ++j) EXPECT_NEAR(q[static_cast<size_t>(j)], 0, 0.5 * kDeg);
  // The encoders agree with the arm.
  const Bytes pos = Transact(port, ReadStatus(2, kSendPosition), ReplyLength(kSendPosition));
  ASSERT_EQ(pos.size(), ReplyLength(kSendPosition));
  const servo::JointDrive shoulder(Puma().joints[1], Puma().servo_tick_s);
  EXPECT_NEAR(DecodeStatus(pos.data(), pos.size(), kSendPosition).position, shoulder.ToCounts(q[1]),
              2);
}

// ---- Emulated time on a clock the test keeps (Emulator::ServiceAt, no thread). ----

// One run: the arm in the ready pose, servos on at t = 0, joints 1-3 loaded with a 30 degree move
// (START_NOW) at tick 200, then the clock advanced tick by tick to `end_ticks` (each pass in the
// middle of a tick), except that no pass happens for `stall_ticks` ticks from tick `stall_from`:
// the process was descheduled. `history` (if given) gets the joint angles after every tick.
struct StallRun {
  EmulatorCounters counters;
  std::vector<double> final_position;
  std::vector<std::string> reports;
};

StallRun RunWithStall(int stall_from, int stall_ticks, int end_ticks,
                      std::vector<std::vector<double>>* history = nullptr) {
  StallRun run;
  EmulatorOptions options = Options();
  options.start_positions = {0, -90 * kDeg, 90 * kDeg, 0, 45 * kDeg, 0};
  options.line_timing = false;  // replies at once: this test is about the servo clock
  options.report = [&run](const std::string& line) { run.reports.push_back(line); };
  Emulator emulator(options);
  SerialPort port(emulator.device(), 19200);
  const double tick = Puma().servo_tick_s;
  // Writes the packets, then passes at time t until the emulator has read every byte (a pty hands
  // bytes over asynchronously).
  const auto deliver = [&](const std::vector<Packet>& packets, double t) {
    Bytes bytes;
    for (const Packet& p : packets) {
      const Bytes b = Encode(p);
      bytes.insert(bytes.end(), b.begin(), b.end());
    }
    const uint64_t want = emulator.counters().bytes_received + bytes.size();
    port.Write(bytes.data(), bytes.size());
    const auto deadline = Clock::now() + std::chrono::seconds(5);
    while (emulator.counters().bytes_received < want && Clock::now() < deadline) {
      emulator.ServiceAt(t);
    }
    EXPECT_EQ(emulator.counters().bytes_received, want);
  };
  std::vector<Packet> setup;
  for (uint8_t a = 1; a <= 6; ++a) setup.push_back(SetAddress(0, a, 0x80, a == 1));
  for (int k = 0; k < 6; ++k) {
    const auto a = static_cast<uint8_t>(k + 1);
    setup.push_back(SetGain(a, ModelGains(Puma().joints[static_cast<size_t>(k)].servo)));
    setup.push_back(StopMotor(a, kAmpEnable | kStopAbrupt));
    setup.push_back(ClearBits(a));
  }
  deliver(setup, 0);
  EXPECT_EQ(emulator.counters().replies_sent, setup.size());
  std::vector<Packet> move;
  const std::vector<double> goal_deg = {30, -60, 60};
  for (int j = 0; j < 3; ++j) {
    const core::Joint& joint = Puma().joints[static_cast<size_t>(j)];
    const servo::JointDrive drive(joint, tick);
    Trajectory t;
    t.control = kLoadPosition | kLoadVelocity | kLoadAcceleration | kEnableServo | kStartNow;
    t.position =
        static_cast<int32_t>(drive.ToCounts(goal_deg[static_cast<size_t>(j)] * kDeg) -
                             drive.ToCounts(options.start_positions[static_cast<size_t>(j)]));
    t.velocity = static_cast<uint32_t>(drive.VelocityWord(joint.servo.default_velocity));
    t.acceleration =
        static_cast<uint32_t>(drive.AccelerationWord(joint.servo.default_acceleration));
    move.push_back(LoadTrajectory(static_cast<uint8_t>(j + 1), t));
  }
  for (int k = 0; k <= end_ticks; ++k) {
    if (k >= stall_from && k < stall_from + stall_ticks) continue;
    const double t = (k + 0.5) * tick;
    if (k == 200) {
      deliver(move, t);
    } else {
      emulator.ServiceAt(t);
    }
    if (history) {
      const size_t stepped = emulator.counters().servo_ticks;
      if (history->size() <= stepped) history->resize(stepped + 1);
      (*history)[stepped] = emulator.JointPositions();
    }
  }
  run.counters = emulator.counters();
  run.final_position = emulator.JointPositions();
  return run;
}

TEST(Emulator, TicksMissedWhileDescheduledAreCaughtUpAndTheMotionIsTheSame) {
  const int end = 2500;  // 1.28 s of emulated time; the move takes about 1 s
  std::vector<std::vector<double>> history;
  const StallRun steady = RunWithStall(0, 0, end, &history);
  // No pass for 293 ticks (0.15 s) in the middle of the move: below the 0.25 s catch-up bound.
  const StallRun stalled = RunWithStall(600, 293, end);
  // No pass for 782 ticks (0.4 s): emulated time slips, and says so.
  const StallRun slipped = RunWithStall(600, 782, end);

  const auto due = static_cast<uint64_t>(end);  // ticks 1..end are due by the last pass
  EXPECT_EQ(steady.counters.servo_ticks, due);
  EXPECT_EQ(steady.counters.ticks_caught_up, 0u);
  EXPECT_EQ(steady.counters.ticks_slipped, 0u);
  EXPECT_GT(std::abs(steady.final_position[0] - 0), 25 * kDeg) << "the arm moved";

  // Every tick of emulated time stepped once: as many as elapsed time / tick, the 294 due during
  // the stall back to back at the next pass (293 of them more than a tick late), and the arm
  // exactly where the undisturbed run left it.
  EXPECT_EQ(stalled.counters.servo_ticks, due);
  EXPECT_EQ(stalled.counters.ticks_caught_up, 293u);
  EXPECT_EQ(stalled.counters.ticks_slipped, 0u);
  EXPECT_TRUE(stalled.reports.empty());
  for (size_t j = 0; j < 6; ++j) {
    EXPECT_EQ(stalled.final_position[j], steady.final_position[j]) << "joint " << j + 1;
  }

  // Past the bound: the 783 ticks due during the stall are slipped, not stepped and not stretched.
  // Stepped + slipped = elapsed, and the arm is exactly where the undisturbed run was after as
  // many ticks.
  EXPECT_EQ(slipped.counters.slips, 1u);
  EXPECT_EQ(slipped.counters.ticks_slipped, 783u);
  EXPECT_EQ(slipped.counters.servo_ticks + slipped.counters.ticks_slipped, due);
  ASSERT_LT(slipped.counters.servo_ticks, history.size());
  for (size_t j = 0; j < 6; ++j) {
    EXPECT_EQ(slipped.final_position[j], history[slipped.counters.servo_ticks][j])
        << "joint " << j + 1;
  }
  ASSERT_EQ(slipped.reports.size(), 1u);
  EXPECT_NE(slipped.reports[0].find("emulated time slipped 0.401 s (783 servo ticks not stepped)"),
            std::string::npos)
      << slipped.reports[0];
  std::printf(
      "stall of 293 ticks: %llu stepped (%llu caught up), arm as undisturbed; stall of 783: "
      "%llu stepped + %llu slipped; '%s'\n",
      static_cast<unsigned long long>(stalled.counters.servo_ticks),
      static_cast<unsigned long long>(stalled.counters.ticks_caught_up),
      static_cast<unsigned long long>(slipped.counters.servo_ticks),
      static_cast<unsigned long long>(slipped.counters.ticks_slipped), slipped.reports[0].c_str());
}

TEST(Emulator, SetBaudSwitchesTheLineAndRepliesTakeTheLinesTime) {
  Emulator emulator(Options());
  emulator.Start();
  SerialPort port(emulator.device(), 19200);
  ASSERT_EQ(NmcInit(port, 6), 6);
  // At 19200 baud a NOP (4 bytes) and its reply (2 bytes) take 6 * 10 / 19200 = 3.1 ms.
  auto round_trip = [&port]() {
    double best = 1;
    for (int i = 0; i < 5; ++i) {
      const auto t0 = Clock::now();
      EXPECT_EQ(Transact(port, Nop(1), 2).size(), 2U);
      best = std::min(best, std::chrono::duration<double>(Clock::now() - t0).count());
    }
    return best;
  };
  const double slow = round_trip();
  EXPECT_GE(slow, 6 * 10 / 19200.0);
  EXPECT_TRUE(Transact(port, SetBaud(kBroadcast, BaudDivisor(115200)), 1, 0.1).empty());
  port.SetBaud(115200);
  EXPECT_EQ(emulator.counters().baud, 115200);
  const double fast = round_trip();
  EXPECT_GE(fast, 6 * 10 / 115200.0);
  EXPECT_LT(fast, slow);
  std::printf("NOP round trip: %.3f ms at 19200, %.3f ms at 115200 (line alone: %.3f, %.3f)\n",
              slow * 1e3, fast * 1e3, 6e4 / 19200, 6e4 / 115200);
  // HARD_RESET returns every module, and the line, to 19200.
  EXPECT_TRUE(Transact(port, HardReset(kBroadcast), 1, 0.05).empty());
  EXPECT_EQ(emulator.counters().baud, 19200);
}

TEST(Emulator, APartialPacketIsDroppedAfterTheInterByteTimeout) {
  Emulator emulator(Options());
  emulator.Start();
  SerialPort port(emulator.device(), 19200);
  ASSERT_EQ(NmcInit(port, 6), 6);
  const Bytes half = {0xAA, 0x01, 0x4E};  // promises 4 data bytes, never sends them
  port.Write(half.data(), half.size());
  Sleep(0.1);
  EXPECT_EQ(Transact(port, Nop(1), 2).size(), 2U);
  EXPECT_EQ(emulator.counters().packet_timeouts, 1U);
}

TEST(Emulator, EachFaultIsObservable) {
  EmulatorOptions options = Options();
  options.seed = 7;
  Emulator emulator(options);
  emulator.Start();
  SerialPort port(emulator.device(), 19200);
  ASSERT_EQ(NmcInit(port, 6), 6);
  ServoOn(port, 6);

  // Checksum errors: every command seen as corrupted gets CKSUM_ERROR and is not executed.
  emulator.SetChecksumErrorRate(1.0);
  const uint64_t errors = emulator.counters().checksum_errors;
  const Bytes bad = Transact(port, StopMotor(1, kAmpEnable | kMotorOff), 2);
  ASSERT_EQ(bad.size(), 2U);
  EXPECT_TRUE(bad[0] & kStatusChecksumError);
  EXPECT_EQ(emulator.counters().checksum_errors, errors + 1);
  emulator.SetChecksumErrorRate(0);
  EXPECT_FALSE(Transact(port, Nop(1), 2)[0] & kStatusChecksumError);
  EXPECT_TRUE(emulator.ModuleStatus(0).aux & kAuxServoOn) << "the MOTOR_OFF did not run";

  // Dropped bytes: half the reply bytes lost on average; all of them at rate 1.
  emulator.SetDropRate(1.0);
  EXPECT_TRUE(Transact(port, Nop(1), 2, 0.05).empty());
  EXPECT_GE(emulator.counters().bytes_dropped, 2U);
  emulator.SetDropRate(0);
  port.DiscardInput();
  EXPECT_EQ(Transact(port, Nop(1), 2).size(), 2U);

  // A silent module: no reply, the others answer.
  emulator.SetSilent(1, true);
  EXPECT_TRUE(Transact(port, Nop(2), 2, 0.05).empty());
  EXPECT_EQ(Transact(port, Nop(3), 2).size(), 2U);
  emulator.SetSilent(1, false);
  EXPECT_EQ(Transact(port, Nop(2), 2).size(), 2U);

  // Overcurrent: latched OVERCURRENT, the motor off.
  EXPECT_FALSE(Transact(port, Nop(4), 2)[0] & kStatusOvercurrent);
  emulator.TriggerOvercurrent(3);
  WaitTicks(emulator, 2);
  const Bytes oc = Transact(port, Nop(4), 2);
  ASSERT_EQ(oc.size(), 2U);
  EXPECT_TRUE(oc[0] & kStatusOvercurrent);
  EXPECT_TRUE(oc[0] & kStatusPositionError);

  // Position-error trip: POS_ERR, the servo off (aux SERVO_ON clear).
  EXPECT_FALSE(Transact(port, Nop(5), 2)[0] & kStatusPositionError);
  emulator.TriggerPositionErrorTrip(4);
  WaitTicks(emulator, 2);
  const Bytes pe = Transact(port, ReadStatus(5, kSendAux), 3);
  ASSERT_EQ(pe.size(), 3U);
  EXPECT_TRUE(pe[0] & kStatusPositionError);
  EXPECT_FALSE(pe[1] & kAuxServoOn);
  EXPECT_FALSE(Transact(port, Nop(1), 2)[0] & kStatusPositionError) << "only module 5 tripped";
  EXPECT_THROW(emulator.SetSilent(6, true), std::invalid_argument);
  EXPECT_THROW(emulator.SetDropRate(1.5), std::invalid_argument);
}

TEST(Emulator, ASilentModuleFromTheStartEndsTheDaisyChain) {
  EmulatorOptions options = Options();
  options.silent_modules = {2};
  Emulator emulator(options);
  emulator.Start();
  SerialPort port(emulator.device(), 19200);
  EXPECT_EQ(NmcInit(port, 2), 2) << "module 3 never lowers its ADDR_OUT";
}

TEST(Emulator, StopsAndRestartsCleanlyAndLinksItsDevice) {
  char dir_template[] = "/tmp/sirupp_emu_XXXXXX";
  ASSERT_NE(mkdtemp(dir_template), nullptr);
  const std::string link = std::string(dir_template) + "/bus";
  {
    EmulatorOptions options = Options();
    options.link = link;
    options.modules = 2;
    Emulator emulator(options);
    EXPECT_EQ(emulator.device(), link);
    emulator.Start();
    SerialPort port(link, 19200);
    EXPECT_EQ(NmcInit(port, 2), 2);
    emulator.Stop();
    emulator.Start();
    EXPECT_EQ(Transact(port, Nop(1), 2).size(), 2U);
  }
  EXPECT_NE(::access(link.c_str(), F_OK), 0) << "the link goes with the emulator";
  ::rmdir(dir_template);
}

// The socket line the layouts use (a pty stalls behind the tty layer's kernel worker on a loaded
// machine): SerialPort connects to it as to a device, NmcInit finds the modules, a client that
// leaves is followed by the next one (a restarted bridge), a second client at once is refused,
// and the socket goes with the emulator.
TEST(Emulator, TheSocketLineServesOneClientAtATimeAndTheNextAfterIt) {
  char dir_template[] = "/tmp/sirupp_emu_XXXXXX";
  ASSERT_NE(mkdtemp(dir_template), nullptr);
  const std::string path = std::string(dir_template) + "/bus";
  {
    EmulatorOptions options = Options();
    options.socket = path;
    options.modules = 2;
    Emulator emulator(options);
    EXPECT_TRUE(emulator.on_socket());
    EXPECT_EQ(emulator.device(), path);
    emulator.Start();
    {
      SerialPort port(path, 19200);
      EXPECT_EQ(NmcInit(port, 2), 2);
      port.SetBaud(230400);  // a socket has no speed: recorded only
      EXPECT_EQ(port.baud(), 230400);
      EXPECT_EQ(Transact(port, Nop(1), 2).size(), 2U);
    }
    {
      SerialPort next(path, 19200);
      EXPECT_EQ(Transact(next, Nop(2), 2).size(), 2U) << "the next client is served";
      EXPECT_EQ(emulator.counters().connections, 2U);
    }
    {
      SerialPort first(path, 19200);
      EXPECT_EQ(Transact(first, Nop(1), 2).size(), 2U);
      // The lock file keeps a second port away, as on a real device ...
      EXPECT_THROW(SerialPort(path, 19200), SerialError);
      // ... and a client that ignores it is closed at once.
      const int raw = ::socket(AF_UNIX, SOCK_STREAM, 0);
      sockaddr_un address{};
      address.sun_family = AF_UNIX;
      std::snprintf(address.sun_path, sizeof address.sun_path, "%s", path.c_str());
      ASSERT_EQ(::connect(raw, reinterpret_cast<const sockaddr*>(&address), sizeof address), 0);
      pollfd p{raw, POLLIN, 0};
      ASSERT_EQ(::poll(&p, 1, 2000), 1);
      char byte = 0;
      EXPECT_EQ(::read(raw, &byte, 1), 0) << "closed by the emulator";
      ::close(raw);
      EXPECT_EQ(Transact(first, Nop(2), 2).size(), 2U) << "the first client is still served";
    }
  }
  EXPECT_NE(::access(path.c_str(), F_OK), 0) << "the socket goes with the emulator";
  ::rmdir(dir_template);
}

TEST(Emulator, ASocketPathThatIsAnotherFileIsNotReplaced) {
  char dir_template[] = "/tmp/sirupp_emu_XXXXXX";
  ASSERT_NE(mkdtemp(dir_template), nullptr);
  const std::string path = std::string(dir_template) + "/bus";
  std::FILE* file = std::fopen(path.c_str(), "w");
  ASSERT_NE(file, nullptr);
  std::fclose(file);
  EmulatorOptions options = Options();
  options.socket = path;
  try {
    Emulator emulator(options);
    ADD_FAILURE() << "a regular file was taken for the socket";
  } catch (const SerialError& e) {
    EXPECT_EQ(std::string(e.what()), path + ": exists and is not a socket; not replacing it");
  }
  EXPECT_EQ(::access(path.c_str(), F_OK), 0);
  options.link = path + ".link";
  options.socket = path + ".socket";
  EXPECT_THROW(Emulator{options}, std::invalid_argument);
  ::unlink(path.c_str());
  ::rmdir(dir_template);
}

}  // namespace
}  // namespace sirupp::hardware
