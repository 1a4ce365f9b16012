#pragma once
// A bus of emulated PIC-SERVO SC modules on a pseudo-terminal, with the arm behind them: what
// sirupp-picservo-emu runs, and what the bridge's tests talk to. One thread owns the pty's master
// side: it reads command bytes (nmc::PacketReader, resynchronising on 0xAA), hands each packet to
// the modules in daisy-chain order, writes their replies with the timing of a real serial line,
// and runs the servo tick (modules, then the arm) at the model's servo rate (1953.125 Hz for the
// PIC-SERVO SC). Servo ticks are counted in emulated time: every tick of emulated time is stepped
// exactly once with the same dt, and ticks the thread missed while descheduled are caught up back
// to back before anything else happens (a command is applied after the ticks due before it was
// read). Emulated time follows the wall clock; only after falling further behind than
// max_catch_up_s does it slip (the arm pauses, the slip is counted and reported), never does a
// tick stretch. The serial line (byte and reply timing) stays on the wall clock. Every public
// method is thread-safe. docs/hardware-emulator.md describes the behaviour, the timing and the
// faults.
//
// Chain order: module 0 is the farthest from the host, so the vendor's NmcInit (SET_ADDR to
// address 0 with 1, 2, ...) gives module k the address k + 1; module k drives joint k + 1.

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "core/robot_model.hpp"
#include "hardware/emulated_arm.hpp"
#include "hardware/picservo_module.hpp"
#include "hardware/serial_port.hpp"

namespace sirupp::hardware {

struct EmulatorOptions {
  core::RobotModel model;
  int modules = 0;   // 0 = one per model joint; 1..32. Modules past the joints have no motor.
  std::string link;  // if set, a symbolic link to the pty's slave (replaced if a link)
  // If set, the line is a Unix socket at this path (SocketLine) instead of the pty: what the demo
  // and the layouts use, because a pty stalls on a loaded machine. Not with `link`.
  std::string socket;
  double friction_scale = 1.5;          // static and Coulomb friction x this (ArmOptions)
  std::vector<double> start_positions;  // physical joint angles at power-up, rad; empty = zero
  uint32_t seed = 1;                    // for the random faults
  int substeps = 2;                     // arm integration substeps per servo tick
  bool brakes = true;  // a joint is braked while its module's amplifier is disabled
  // The real-arm effects (hardware/real_arm.hpp); unset: the model's arm with friction_scale.
  // Their command latency is given to every module.
  std::optional<RealArmParams> effects;
  // Faults at start (each can be changed at run time).
  double checksum_error_rate = 0;   // probability a received command is seen with a bad checksum
  double drop_rate = 0;             // probability a reply byte is lost
  std::vector<int> silent_modules;  // module indices (0-based) that hear and answer nothing
  // A partial packet is dropped when the next byte comes later than this after the last one.
  double inter_byte_timeout_s = 0.02;
  // Replies wait for the command's and their own transmission time at the line's baud.
  bool line_timing = true;
  // Catch-up bound: when emulated time is further behind the wall clock than this (the process was
  // stopped or starved), the missed ticks are not stepped: emulated time slips, the arm pauses for
  // that long, and `report` is told. Below the bound every missed tick is stepped, back to back.
  double max_catch_up_s = 0.25;
  // Told one line per slip; nullptr: the line goes to stderr.
  std::function<void(const std::string&)> report;
};

struct EmulatorCounters {
  uint64_t commands_received = 0;  // complete packets, any address
  uint64_t checksum_errors = 0;    // packets seen with a bad checksum (on the wire or injected)
  uint64_t replies_sent = 0;
  uint64_t bytes_received = 0;
  uint64_t bytes_skipped = 0;    // noise outside packets (before a header)
  uint64_t bytes_dropped = 0;    // reply bytes lost by the drop fault
  uint64_t packet_timeouts = 0;  // partial packets dropped by the inter-byte timeout
  // Servo ticks stepped: emulated time is servo_ticks x tick. Every tick of emulated time is
  // stepped exactly once, with the same dt.
  uint64_t servo_ticks = 0;
  uint64_t ticks_caught_up = 0;  // of those, stepped more than one tick after their wall time
  uint64_t ticks_slipped = 0;    // ticks of wall time never stepped (emulated time slipped)
  uint64_t slips = 0;            // times emulated time slipped (each reported)
  double max_lateness_s = 0;     // the furthest emulated time was behind the wall clock
  uint64_t baud_changes = 0;
  uint64_t connections = 0;      // clients that connected to the socket line
  int baud = nmc::kPowerUpBaud;  // the line speed now
};

class Emulator {
 public:
  // Builds the modules, the arm and the pty (and the link). Throws std::invalid_argument on bad
  // options (module count, start positions, rates) and SerialError if the pty cannot be made.
  explicit Emulator(EmulatorOptions options);
  ~Emulator();
  Emulator(const Emulator&) = delete;
  Emulator& operator=(const Emulator&) = delete;

  // Starts the thread. Emulated time resumes where it stopped (the time between Stop() and Start()
  // is neither stepped nor counted as slipped).
  void Start();
  // Stops and joins the thread (also done by the destructor).
  void Stop();
  // Without Start(), for tests that keep the clock themselves: one pass of the thread's loop at
  // time `now_s` (seconds since construction, never decreasing): steps every tick due by then
  // (slipping past the bound), reads every byte waiting on the pty and handles it at now_s, and
  // writes the replies due by now_s. Tick k (from 1) is due at k x tick.
  void ServiceAt(double now_s);

  // What a client opens: the link if one was asked for, else /dev/pts/N.
  const std::string& device() const;
  const std::string& slave_path() const { return pty_.slave_path(); }
  // True when the line is a Unix socket (options.socket), not the pty.
  bool on_socket() const { return socket_ != nullptr; }
  int num_modules() const { return static_cast<int>(modules_.size()); }

  // True physical joint angles (rad or m), one per model joint.
  std::vector<double> JointPositions() const;
  // The PWM each module applies to its motor now.
  std::vector<int> Pwm() const;
  // Module `index`'s status now, every item filled in.
  nmc::Status ModuleStatus(int module_index) const;
  // The gains module `index` runs its PID with (its last SET_GAIN, or its power-up gains).
  nmc::Gains ModuleGains(int module_index) const;

  void SetChecksumErrorRate(double p);
  void SetDropRate(double p);
  void SetSilent(int module_index, bool silent);
  void TriggerOvercurrent(int module_index);
  void TriggerPositionErrorTrip(int module_index);

  EmulatorCounters counters() const;

 private:
  struct PendingReply {
    double write_time_s;  // on the emulator's clock
    std::vector<uint8_t> bytes;
  };
  void Run();
  double Now() const;
  void TickOnce();
  // Steps every tick due by now_s (or slips past the bound). Caller holds the mutex.
  void CatchUp(double now_s);
  double NextTickDue() const {
    return clock_base_s_ + static_cast<double>(tick_index_ + 1) * tick_s_;
  }
  // The descriptor the line's bytes come and go through: the pty's master, or the socket's
  // client (-1: no client connected). ReadLine reads what waits (0: nothing; a client that left
  // is dropped); WriteLine loses what cannot be written, as a line nobody listens to.
  int LineFd() const;
  ssize_t ReadLine(uint8_t* buffer, size_t size);
  void WriteLine(const uint8_t* bytes, size_t n);
  // Socket line: takes a waiting client. Caller holds the mutex.
  void AcceptClient();
  void Receive(const uint8_t* bytes, size_t n, double now_s);
  void Process(const nmc::PacketReader::Result& result, double arrival_s);
  void FlushReplies(double now_s);
  void CheckModule(int module_index, const char* what) const;
  static void CheckRate(double p, const char* what);

  EmulatorOptions options_;
  PseudoTerminal pty_;
  std::unique_ptr<SocketLine> socket_;
  std::string device_;
  double tick_s_;
  std::chrono::steady_clock::time_point epoch_;

  mutable std::mutex mutex_;  // everything below
  std::vector<PicServoModule> modules_;
  std::vector<bool> silent_;
  EmulatedArm arm_;
  std::vector<int> pwm_;
  EmulatorCounters counters_;
  double checksum_error_rate_;
  double drop_rate_;
  std::mt19937 rng_;
  nmc::PacketReader reader_;
  double last_byte_s_ = -1;
  double rx_free_s_ = 0;  // when the line finishes carrying the bytes received so far
  double tx_free_s_ = 0;  // when the line finishes carrying the replies queued so far
  std::vector<PendingReply> replies_;
  // Tick k of emulated time (counted from 1 since clock_base_s_, slipped ones included) is due at
  // clock_base_s_ + k x tick_s_.
  double clock_base_s_ = 0;
  uint64_t tick_index_ = 0;

  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace sirupp::hardware
