#pragma once
// The host end of an NMC bus: sends command packets, waits for status replies with a timeout
// derived from the line speed, retries after a resynchronisation, and counts every error. Also the
// vendor library's start-up (reset, address the modules one by one, read their ids, change baud).
// One thread uses a bus at a time. docs/hardware.md, section "The bus master".

#include <chrono>
#include <cstdint>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include "hardware/nmc_protocol.hpp"
#include "hardware/serial_port.hpp"

namespace sirupp::hardware {

struct BusOptions {
  // Wait for a reply beyond its transmission time (the module's turnaround, the adapter's and the
  // operating system's latency).
  std::chrono::microseconds reply_margin{10000};
  // Further tries of one exchange after a timeout, a damaged reply or a module's CKSUM_ERROR.
  int retries = 2;
  // Called with each packet sent and each reply ("> " / "< " lines), for --trace.
  std::function<void(const std::string&)> trace;
  // A reply that comes after the deadline (seen while resynchronising) shows a module that is
  // slow, not silent: such a try is not counted among the retries, and the next one waits twice
  // as long (at most `late_margin_max`), up to `late_tries` times per exchange. A silent module
  // sends nothing at all and fails after 1 + retries tries at `reply_margin`, as before.
  int late_tries = 4;
  std::chrono::microseconds late_margin_max{1000000};
};

struct BusCounters {
  int64_t exchanges = 0;               // commands sent
  int64_t checksum_errors = 0;         // replies with a bad checksum or length
  int64_t module_checksum_errors = 0;  // replies with CKSUM_ERROR set (the module saw damage)
  int64_t timeouts = 0;                // replies that did not come in time
  int64_t resyncs = 0;                 // resynchronisations (zero burst, wait, flush)
  int64_t retries = 0;                 // exchanges tried again
  int64_t late_replies = 0;            // timeouts whose reply came after the deadline
  int64_t bytes_sent = 0;
  int64_t bytes_received = 0;
};

// An exchange that failed after every retry: names the module, the command and the last problem.
class BusError : public std::runtime_error {
 public:
  BusError(uint8_t address, uint8_t command, const std::string& what)
      : std::runtime_error(what), address_(address), command_(command) {}
  uint8_t address() const { return address_; }
  uint8_t command() const { return command_; }

 private:
  uint8_t address_;
  uint8_t command_;
};

struct ModuleInfo {
  uint8_t address = 0;
  uint8_t type = 0;
  uint8_t version = 0;
};

class NmcBus {
 public:
  explicit NmcBus(BytePort& port, BusOptions options = {});

  // The vendor start-up: hard reset (twice) at the power-up baud, SET_ADDR to address 0 for
  // addresses 1, 2, ... in the default group 0xFF until nobody answers or `max_modules` are
  // found, READ_STAT(SEND_ID) of each, SET_BAUD to `baud` for all; then each module joins
  // `group` (module 1 its leader). Returns the modules found.
  std::vector<ModuleInfo> Initialize(int max_modules, int baud, uint8_t group = 0x80);

  // Modules that kept power and their addresses since a host addressed them (a board fresh from
  // power-up or HARD_RESET has address 0 and does not answer): READ_STAT(SEND_ID | items) to
  // addresses 1, 2, ... at the port's present baud, two tries each, until one does not answer or
  // `max_modules` did. Sends no reset and changes nothing on the modules. Returns each module that
  // answered, with its reply (type and version, and `items`).
  struct Addressed {
    ModuleInfo info;
    nmc::Status status;
  };
  std::vector<Addressed> FindAddressed(int max_modules, uint8_t items);
  // Takes modules found by FindAddressed as this bus's, without a reset: their status items
  // defined anew as none (DEF_STAT 0), and each put in `group` again, module 1 its leader.
  void Adopt(const std::vector<ModuleInfo>& modules, uint8_t group);

  // An individually addressed command; returns the reply, parsed with the module's defined status
  // items (READ_STAT: with the items it asks for; DEF_STAT: with the new ones). Retries, then
  // throws BusError.
  nmc::Status Command(const nmc::Packet& packet);
  // A command to the group address given to Initialize; its leader answers.
  nmc::Status GroupCommand(const nmc::Packet& packet);
  // A command to every module of the group, not waiting for an answer: it takes effect on every
  // module that hears it even when the leader is silent (stops, e-stop, SET_BAUD).
  void Broadcast(const nmc::Packet& packet);

  // SET_BAUD to every module, then the host follows.
  void ChangeBaud(int baud);
  // HARD_RESET to every module, host back to the power-up baud; modules forget their addresses.
  void HardReset();

  void set_trace(std::function<void(const std::string&)> trace) {
    options_.trace = std::move(trace);
  }
  uint8_t defined_items(uint8_t address) const;
  const std::vector<ModuleInfo>& modules() const { return modules_; }
  uint8_t group() const { return group_; }
  const BusCounters& counters() const { return counters_; }
  BytePort& port() { return port_; }
  // Seconds of line time for `bytes` at the present baud.
  double LineSeconds(size_t bytes) const { return ByteSeconds(port_.baud()) * double(bytes); }

 private:
  enum class Outcome { kOk, kTimeout, kDamaged, kModuleChecksum, kLate };
  Outcome TryExchange(const std::vector<uint8_t>& bytes, uint8_t items,
                      std::chrono::microseconds margin, nmc::Status* reply, std::string* problem);
  // TryExchange, then after a timeout or damage a resync; a timeout whose reply arrived during
  // the resync is kLate (counted in timeouts and late_replies). A `probe` asks where silence is
  // an answer (is there a module at this address?): its timeouts are not counted.
  Outcome TryAndResync(const std::vector<uint8_t>& bytes, uint8_t items,
                       std::chrono::microseconds margin, nmc::Status* reply, std::string* problem,
                       bool probe = false);
  nmc::Status Exchange(const nmc::Packet& packet, uint8_t items, uint8_t reply_address);
  // Zero burst, a wait for anything in flight (`margin` / 2 beyond the line time), then reads and
  // throws away what arrived; returns how many bytes that was.
  size_t Resync(std::chrono::microseconds margin);
  // The next try's margin after a late reply: twice `margin`, at most late_margin_max.
  std::chrono::microseconds Widened(std::chrono::microseconds margin) const;
  // SET_ADDR to the next unaddressed module; false when none answers (end of the chain).
  bool AddressNext(uint8_t address);
  void Send(const std::vector<uint8_t>& bytes);

  BytePort& port_;
  BusOptions options_;
  BusCounters counters_;
  std::vector<ModuleInfo> modules_;
  uint8_t defined_[nmc::kMaxModules + 1] = {};
  uint8_t group_ = nmc::kBroadcast;
  uint8_t group_leader_ = 1;
};

}  // namespace sirupp::hardware
