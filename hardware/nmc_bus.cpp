#include "hardware/nmc_bus.hpp"

#include <cstdio>
#include <thread>

#include "core/errors.hpp"

namespace sirupp::hardware {
namespace {

using Clock = std::chrono::steady_clock;

std::string BytesText(const std::vector<uint8_t>& bytes) {
  std::string s;
  for (uint8_t b : bytes) {
    char buf[4];
    std::snprintf(buf, sizeof buf, "%02X ", b);
    s += buf;
  }
  if (!s.empty()) s.pop_back();
  return s;
}

std::string AddressText(uint8_t address) {
  char buf[16];
  if (nmc::IsGroupAddress(address)) {
    std::snprintf(buf, sizeof buf, "group 0x%02X", address);
  } else {
    std::snprintf(buf, sizeof buf, "module %d", address);
  }
  return buf;
}

void SleepSeconds(double s) {
  std::this_thread::sleep_for(std::chrono::microseconds(static_cast<int64_t>(s * 1e6)));
}

// Bytes the vendor library sends to flush a module's receiver (FixSioError).
constexpr size_t kResyncZeros = 30;
// Zeros before a hard reset (NmcHardReset).
constexpr size_t kResetZeros = 20;
// Settling time after a hard reset or a baud change, as the vendor library waits.
constexpr double kSettleS = 0.1;

}  // namespace

NmcBus::NmcBus(BytePort& port, BusOptions options) : port_(port), options_(std::move(options)) {}

void NmcBus::Send(const std::vector<uint8_t>& bytes) {
  if (options_.trace) options_.trace("> " + BytesText(bytes));
  port_.Write(bytes.data(), bytes.size());
  counters_.bytes_sent += static_cast<int64_t>(bytes.size());
}

NmcBus::Outcome NmcBus::TryExchange(const std::vector<uint8_t>& bytes, uint8_t items,
                                    std::chrono::microseconds margin, nmc::Status* reply,
                                    std::string* problem) {
  const size_t want = nmc::ReplyLength(items);
  port_.DiscardInput();  // a late reply to an earlier try must not be taken for this one
  Send(bytes);
  ++counters_.exchanges;
  const auto budget = std::chrono::duration<double>(LineSeconds(bytes.size() + want));
  const auto deadline = Clock::now() + std::chrono::duration_cast<Clock::duration>(budget) + margin;
  std::vector<uint8_t> got(want);
  size_t have = 0;
  while (have < want) {
    // Past the deadline, what has already arrived is still taken: a bridge that the scheduler
    // held past it has not seen a silent module (a read with no wait looks without waiting).
    const auto left =
        std::max(std::chrono::duration_cast<std::chrono::microseconds>(deadline - Clock::now()),
                 std::chrono::microseconds(0));
    const size_t n = port_.Read(got.data() + have, want - have, left);
    have += n;
    if (n == 0 && left.count() == 0) break;
  }
  counters_.bytes_received += static_cast<int64_t>(have);
  got.resize(have);
  if (options_.trace) options_.trace("< " + BytesText(got));
  if (have == 0) {
    *problem = "no reply";
    return Outcome::kTimeout;
  }
  if (have < want) {
    *problem =
        "reply cut short: " + std::to_string(have) + " of " + std::to_string(want) + " bytes";
    return Outcome::kDamaged;
  }
  try {
    *reply = nmc::DecodeStatus(got.data(), got.size(), items);
  } catch (const nmc::ProtocolError& e) {
    *problem = e.what();
    return Outcome::kDamaged;
  }
  if (reply->status & nmc::kStatusChecksumError) {
    *problem = "the module reported a checksum error (CKSUM_ERROR)";
    return Outcome::kModuleChecksum;
  }
  return Outcome::kOk;
}

size_t NmcBus::Resync(std::chrono::microseconds margin) {
  ++counters_.resyncs;
  Send(std::vector<uint8_t>(kResyncZeros, 0));
  // Long enough for any reply still on its way to finish arriving, then throw it away, counting
  // it: bytes here after a timeout are a reply that came late.
  SleepSeconds(LineSeconds(kResyncZeros + 20) + std::chrono::duration<double>(margin).count() / 2);
  size_t late = 0;
  uint8_t buffer[64];
  for (size_t n; (n = port_.Read(buffer, sizeof buffer, std::chrono::microseconds(0))) > 0;) {
    late += n;
  }
  counters_.bytes_received += static_cast<int64_t>(late);
  if (late > 0 && options_.trace) options_.trace("< (late) " + std::to_string(late) + " bytes");
  port_.DiscardInput();
  return late;
}

std::chrono::microseconds NmcBus::Widened(std::chrono::microseconds margin) const {
  return std::min(margin * 2, std::max(options_.late_margin_max, margin));
}

NmcBus::Outcome NmcBus::TryAndResync(const std::vector<uint8_t>& bytes, uint8_t items,
                                     std::chrono::microseconds margin, nmc::Status* reply,
                                     std::string* problem, bool probe) {
  const Outcome outcome = TryExchange(bytes, items, margin, reply, problem);
  switch (outcome) {
    case Outcome::kOk:
    case Outcome::kModuleChecksum:  // in sync; the command was not carried out
    case Outcome::kLate:
      return outcome;
    case Outcome::kDamaged:
      ++counters_.checksum_errors;
      Resync(margin);
      return outcome;
    case Outcome::kTimeout:
      if (!probe) ++counters_.timeouts;
      if (Resync(margin) == 0) return outcome;
      ++counters_.late_replies;
      *problem = "the reply came late, after the " +
                 core::FormatNumber(std::chrono::duration<double, std::milli>(margin).count()) +
                 " ms the line allows beyond its transmission time";
      return Outcome::kLate;
  }
  return outcome;
}

nmc::Status NmcBus::Exchange(const nmc::Packet& packet, uint8_t items, uint8_t reply_address) {
  const std::vector<uint8_t> bytes = nmc::Encode(packet);
  std::string problem;
  nmc::Status reply;
  const int tries = 1 + std::max(0, options_.retries);
  auto margin = options_.reply_margin;
  int counted = 0;  // tries that count against `tries`: late ones do not, up to late_tries
  int late = 0;
  for (int attempt = 0; counted < tries; ++attempt) {
    if (attempt > 0) ++counters_.retries;
    const Outcome outcome = TryAndResync(bytes, items, margin, &reply, &problem);
    if (outcome == Outcome::kOk) return reply;
    if (outcome == Outcome::kModuleChecksum) ++counters_.module_checksum_errors;
    if (outcome == Outcome::kLate && late < options_.late_tries) {
      ++late;
      margin = Widened(margin);
      continue;
    }
    ++counted;
  }
  throw BusError(reply_address, packet.command,
                 AddressText(packet.address) + ": " + nmc::CommandName(packet.command) + ": " +
                     problem + " (" + std::to_string(counted + late) + " tries at " +
                     std::to_string(port_.baud()) + " baud on " + port_.name() + ")");
}

nmc::Status NmcBus::Command(const nmc::Packet& packet) {
  if (packet.address == 0 || nmc::IsGroupAddress(packet.address)) {
    throw std::invalid_argument(std::string("NmcBus::Command: ") +
                                nmc::CommandName(packet.command) +
                                " needs an individual address, got " + AddressText(packet.address));
  }
  uint8_t items = defined_items(packet.address);
  if (packet.command == nmc::kReadStatus || packet.command == nmc::kDefineStatus) {
    items = packet.data.at(0);
  }
  nmc::Status reply = Exchange(packet, items, packet.address);
  if (packet.command == nmc::kDefineStatus) defined_[packet.address] = items;
  return reply;
}

nmc::Status NmcBus::GroupCommand(const nmc::Packet& packet) {
  nmc::Packet p = packet;
  p.address = group_;
  return Exchange(p, defined_items(group_leader_), group_leader_);
}

void NmcBus::Broadcast(const nmc::Packet& packet) {
  nmc::Packet p = packet;
  p.address = group_;
  const std::vector<uint8_t> bytes = nmc::Encode(p);
  Send(bytes);
  ++counters_.exchanges;
  // Not waiting for an answer: a leader's reply (if the group has one) is thrown away. The
  // modules need the packet's line time plus 0.51 ms to act on it.
  const size_t reply = nmc::IsGroupAddress(group_) && group_ != nmc::kBroadcast
                           ? nmc::ReplyLength(defined_items(group_leader_))
                           : 0;
  SleepSeconds(LineSeconds(bytes.size() + reply) + 0.001);
  port_.DiscardInput();
}

void NmcBus::ChangeBaud(int baud) {
  const uint8_t divisor = nmc::BaudDivisor(baud);
  Broadcast(nmc::SetBaud(nmc::kBroadcast, divisor));
  SleepSeconds(kSettleS);
  port_.SetBaud(baud);
  port_.DiscardInput();
}

void NmcBus::HardReset() {
  Send(std::vector<uint8_t>(kResetZeros, 0));
  Send(nmc::Encode(nmc::HardReset(nmc::kBroadcast)));
  SleepSeconds(LineSeconds(kResetZeros + 4) + kSettleS);
  port_.SetBaud(nmc::kPowerUpBaud);
  port_.DiscardInput();
  modules_.clear();
  for (uint8_t& d : defined_) d = 0;
  group_ = nmc::kBroadcast;
}

std::vector<ModuleInfo> NmcBus::Initialize(int max_modules, int baud, uint8_t group) {
  if (max_modules < 1 || max_modules > nmc::kMaxModules) {
    throw std::invalid_argument("modules " + std::to_string(max_modules) + "; allowed: 1 to 32");
  }
  if (!nmc::IsGroupAddress(group) || group == nmc::kBroadcast) {
    throw std::invalid_argument("group address " + std::to_string(group) +
                                "; allowed: 0x80 to 0xFE");
  }
  nmc::BaudDivisor(baud);  // refuse an unsupported rate before touching the bus
  port_.SetBaud(nmc::kPowerUpBaud);
  HardReset();
  HardReset();
  // As the vendor library: every module into the default group 0xFF (no leader), so that one
  // SET_BAUD reaches them all; then into `group`, module 1 leading, for START_MOVE.
  group_ = nmc::kBroadcast;
  // Discovery waits longer than normal exchanges: a slow answer here would end the chain early.
  struct Restore {
    std::chrono::microseconds& margin;
    std::chrono::microseconds normal;
    ~Restore() { margin = normal; }
  } restore{options_.reply_margin, options_.reply_margin};
  options_.reply_margin = std::max(options_.reply_margin, std::chrono::microseconds(50000));
  for (int address = 1; address <= max_modules; ++address) {
    const auto a = static_cast<uint8_t>(address);
    if (!AddressNext(a)) break;  // no unaddressed module left on the chain
    const nmc::Status id = Command(nmc::ReadStatus(a, nmc::kSendId));
    modules_.push_back(ModuleInfo{a, id.type, id.version});
  }
  options_.reply_margin = restore.normal;
  if (modules_.empty()) return modules_;
  if (baud != nmc::kPowerUpBaud) ChangeBaud(baud);
  for (const ModuleInfo& m : modules_) {
    Command(nmc::SetAddress(m.address, m.address, group, m.address == 1));
  }
  group_ = group;
  group_leader_ = 1;
  return modules_;
}

std::vector<NmcBus::Addressed> NmcBus::FindAddressed(int max_modules, uint8_t items) {
  if (max_modules < 1 || max_modules > nmc::kMaxModules) {
    throw std::invalid_argument("modules " + std::to_string(max_modules) + "; allowed: 1 to 32");
  }
  const auto asked = static_cast<uint8_t>(items | nmc::kSendId);
  std::vector<Addressed> found;
  for (int address = 1; address <= max_modules; ++address) {
    const auto a = static_cast<uint8_t>(address);
    const std::vector<uint8_t> bytes = nmc::Encode(nmc::ReadStatus(a, asked));
    nmc::Status reply;
    std::string problem;
    Outcome outcome = Outcome::kTimeout;
    auto margin = options_.reply_margin;
    // A killed host may have left half a packet on the line: TryAndResync flushes the modules'
    // receivers after a timeout or damage. A late reply is a module there: it is asked again.
    for (int attempt = 0, late = 0; attempt < 2 && outcome != Outcome::kOk; ++attempt) {
      outcome = TryAndResync(bytes, asked, margin, &reply, &problem, /*probe=*/true);
      if (outcome == Outcome::kLate && late < options_.late_tries) {
        ++late;
        --attempt;
        margin = Widened(margin);
      }
    }
    if (outcome != Outcome::kOk) break;
    found.push_back({ModuleInfo{a, reply.type, reply.version}, reply});
  }
  return found;
}

void NmcBus::Adopt(const std::vector<ModuleInfo>& modules, uint8_t group) {
  if (!nmc::IsGroupAddress(group) || group == nmc::kBroadcast) {
    throw std::invalid_argument("group address " + std::to_string(group) +
                                "; allowed: 0x80 to 0xFE");
  }
  modules_ = modules;
  for (uint8_t& d : defined_) d = 0;
  for (const ModuleInfo& m : modules_) {
    // The module still answers with the items an earlier host defined: define none first.
    Command(nmc::DefineStatus(m.address, 0));
    Command(nmc::SetAddress(m.address, m.address, group, m.address == 1));
  }
  group_ = group;
  group_leader_ = 1;
}

bool NmcBus::AddressNext(uint8_t address) {
  const std::vector<uint8_t> set_address =
      nmc::Encode(nmc::SetAddress(nmc::kUnaddressed, address, nmc::kBroadcast, false));
  const std::vector<uint8_t> nop = nmc::Encode(nmc::Nop(address));
  std::string problem;
  nmc::Status reply;
  auto margin = options_.reply_margin;
  for (int attempt = 0, late = 0; attempt < 2; ++attempt) {
    Outcome outcome = TryAndResync(set_address, 0, margin, &reply, &problem);
    if (outcome == Outcome::kOk) return true;
    if (outcome == Outcome::kModuleChecksum) {
      ++counters_.module_checksum_errors;
      continue;  // the module threw it away: the same module is still at address 0
    }
    // The command may have been carried out with its answer lost or late: sending it again would
    // give the next module the same address. Ask the new address first; a late answer there is a
    // module that is slow, not absent, and it is asked again with a longer wait.
    for (;;) {
      if (outcome == Outcome::kLate && late < options_.late_tries) {
        ++late;
        margin = Widened(margin);
      }
      outcome = TryAndResync(nop, 0, margin, &reply, &problem, /*probe=*/true);
      if (outcome == Outcome::kOk) return true;
      if (outcome != Outcome::kLate || late >= options_.late_tries) break;
    }
  }
  return false;
}

uint8_t NmcBus::defined_items(uint8_t address) const {
  return address <= nmc::kMaxModules ? defined_[address] : 0;
}

}  // namespace sirupp::hardware
