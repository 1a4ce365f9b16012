#include "hardware/nmc_protocol.hpp"

#include <cstdio>

namespace sirupp::hardware::nmc {
namespace {

struct BaudRow {
  int baud;
  uint8_t divisor;
};
// Reference section 2.4 (9600 is corroborated only by third-party code).
constexpr BaudRow kBauds[] = {{9600, 127}, {19200, 64}, {57600, 21}, {115200, 10}, {230400, 5}};

void Put16(std::vector<uint8_t>& out, int32_t v) {
  const auto u = static_cast<uint16_t>(v);
  out.push_back(static_cast<uint8_t>(u & 0xFF));
  out.push_back(static_cast<uint8_t>(u >> 8));
}
void Put32(std::vector<uint8_t>& out, uint32_t u) {
  for (int i = 0; i < 4; ++i) out.push_back(static_cast<uint8_t>((u >> (8 * i)) & 0xFF));
}
uint16_t Get16(const uint8_t* p) { return static_cast<uint16_t>(p[0] | (p[1] << 8)); }
uint32_t Get32(const uint8_t* p) {
  return static_cast<uint32_t>(p[0]) | (static_cast<uint32_t>(p[1]) << 8) |
         (static_cast<uint32_t>(p[2]) << 16) | (static_cast<uint32_t>(p[3]) << 24);
}

Packet Make(uint8_t address, uint8_t command, std::vector<uint8_t> data = {}) {
  Packet p;
  p.address = address;
  p.command = static_cast<uint8_t>(command & 0x0F);
  p.data = std::move(data);
  return p;
}

size_t TrajectoryLength(uint8_t control) {
  size_t n = 1;
  if (control & kLoadPosition) n += 4;
  if (control & kLoadVelocity) n += 4;
  if (control & kLoadAcceleration) n += 4;
  if (control & kLoadPwm) n += 1;
  return n;
}

std::string Hex(uint8_t b) {
  char buf[8];
  std::snprintf(buf, sizeof buf, "0x%02X", b);
  return buf;
}

}  // namespace

const char* CommandName(uint8_t command) {
  static const char* const kNames[16] = {"RESET_POS",    "SET_ADDR",      "DEF_STAT", "READ_STAT",
                                         "LOAD_TRAJ",    "START_MOVE",    "SET_GAIN", "STOP_MOTOR",
                                         "IO_CTRL",      "SET_HOMING",    "SET_BAUD", "CLEAR_BITS",
                                         "SAVE_AS_HOME", "ADD_PATHPOINT", "NOP",      "HARD_RESET"};
  return kNames[command & 0x0F];
}

uint8_t BaudDivisor(int baud) {
  for (const BaudRow& row : kBauds) {
    if (row.baud == baud) return row.divisor;
  }
  throw std::invalid_argument(
      "baud " + std::to_string(baud) +
      " is not one the PIC-SERVO SC supports; allowed: " + SupportedBauds());
}

int BaudFromDivisor(uint8_t divisor) {
  for (const BaudRow& row : kBauds) {
    if (row.divisor == divisor) return row.baud;
  }
  return 0;
}

bool IsSupportedBaud(int baud) {
  for (const BaudRow& row : kBauds) {
    if (row.baud == baud) return true;
  }
  return false;
}

std::string SupportedBauds() {
  std::string s;
  for (const BaudRow& row : kBauds) {
    if (!s.empty()) s += ", ";
    s += std::to_string(row.baud);
  }
  return s;
}

uint8_t Checksum(const uint8_t* bytes, size_t n) {
  unsigned sum = 0;
  for (size_t i = 0; i < n; ++i) sum += bytes[i];
  return static_cast<uint8_t>(sum & 0xFF);
}

std::vector<uint8_t> Encode(const Packet& packet) {
  if (packet.data.size() > static_cast<size_t>(kMaxData)) {
    throw std::invalid_argument(std::string(CommandName(packet.command)) + ": " +
                                std::to_string(packet.data.size()) +
                                " data bytes; a packet carries at most 15");
  }
  std::vector<uint8_t> out;
  out.reserve(packet.data.size() + 4);
  out.push_back(kHeader);
  out.push_back(packet.address);
  out.push_back(static_cast<uint8_t>((packet.data.size() << 4) | (packet.command & 0x0F)));
  out.insert(out.end(), packet.data.begin(), packet.data.end());
  out.push_back(Checksum(out.data() + 1, out.size() - 1));
  return out;
}

std::string Describe(const Packet& packet) {
  std::string s = std::string(CommandName(packet.command)) + " to " + Hex(packet.address);
  if (!packet.data.empty()) {
    s += " [";
    for (size_t i = 0; i < packet.data.size(); ++i) {
      if (i) s += ' ';
      char buf[4];
      std::snprintf(buf, sizeof buf, "%02X", packet.data[i]);
      s += buf;
    }
    s += "]";
  }
  return s;
}

std::optional<PacketReader::Result> PacketReader::Feed(uint8_t byte) {
  switch (state_) {
    case State::kWaitHeader:
      if (byte == kHeader) {
        state_ = State::kAddress;
      } else {
        ++skipped_;
      }
      return std::nullopt;
    case State::kAddress:
      partial_ = Packet{};
      partial_.address = byte;
      state_ = State::kCommand;
      return std::nullopt;
    case State::kCommand:
      partial_.command = static_cast<uint8_t>(byte & 0x0F);
      need_ = byte >> 4;
      state_ = need_ > 0 ? State::kData : State::kChecksum;
      return std::nullopt;
    case State::kData:
      partial_.data.push_back(byte);
      if (partial_.data.size() == need_) state_ = State::kChecksum;
      return std::nullopt;
    case State::kChecksum: {
      state_ = State::kWaitHeader;
      const std::vector<uint8_t> bytes = Encode(partial_);
      Result r;
      r.packet = partial_;
      r.checksum_ok = bytes.back() == byte;
      return r;
    }
  }
  return std::nullopt;
}

Packet ResetPosition(uint8_t address) { return Make(address, kResetPos); }
Packet ResetToHome(uint8_t address) { return Make(address, kResetPos, {kResetRelativeHome}); }
Packet SetPosition(uint8_t address, int32_t counts) {
  std::vector<uint8_t> d{kResetSetPosition};
  Put32(d, static_cast<uint32_t>(counts));
  return Make(address, kResetPos, d);
}
Packet SetAddress(uint8_t address, uint8_t new_address, uint8_t group, bool leader) {
  const auto g = static_cast<uint8_t>(leader ? (group & 0x7F) : (group | 0x80));
  return Make(address, kSetAddr, {new_address, g});
}
Packet DefineStatus(uint8_t address, uint8_t items) {
  return Make(address, kDefineStatus, {items});
}
Packet ReadStatus(uint8_t address, uint8_t items) { return Make(address, kReadStatus, {items}); }
Packet LoadTrajectory(uint8_t address, const Trajectory& t) {
  std::vector<uint8_t> d{t.control};
  if (t.control & kLoadPosition) Put32(d, static_cast<uint32_t>(t.position));
  if (t.control & kLoadVelocity) Put32(d, t.velocity);
  if (t.control & kLoadAcceleration) Put32(d, t.acceleration);
  if (t.control & kLoadPwm) d.push_back(t.pwm);
  return Make(address, kLoadTraj, d);
}
Packet StartMove(uint8_t address) { return Make(address, kStartMove); }
Packet SetGain(uint8_t address, const Gains& g, bool with_step_multiplier) {
  std::vector<uint8_t> d;
  Put16(d, g.kp);
  Put16(d, g.kd);
  Put16(d, g.ki);
  Put16(d, g.integration_limit);
  d.push_back(g.output_limit);
  d.push_back(g.current_limit);
  Put16(d, g.error_limit);
  d.push_back(g.servo_rate);
  d.push_back(g.deadband);
  if (with_step_multiplier) d.push_back(g.step_multiplier);
  return Make(address, kSetGain, d);
}
Packet StopMotor(uint8_t address, uint8_t control) {
  return Make(address, kStopMotor, {static_cast<uint8_t>(control & ~kStopHere)});
}
Packet StopHere(uint8_t address, uint8_t control, int32_t counts) {
  std::vector<uint8_t> d{static_cast<uint8_t>(control | kStopHere)};
  Put32(d, static_cast<uint32_t>(counts));
  return Make(address, kStopMotor, d);
}
Packet IoControl(uint8_t address, uint8_t control) { return Make(address, kIoControl, {control}); }
Packet SetHoming(uint8_t address, uint8_t control) { return Make(address, kSetHoming, {control}); }
Packet SetBaud(uint8_t address, uint8_t divisor) { return Make(address, kSetBaud, {divisor}); }
Packet ClearBits(uint8_t address) { return Make(address, kClearBits); }
Packet SaveAsHome(uint8_t address) { return Make(address, kSaveAsHome); }
Packet StartPathMode(uint8_t address) { return Make(address, kAddPathpoint); }
Packet AddPathpoints(uint8_t address, const std::vector<uint16_t>& points) {
  if (points.empty() || points.size() > 7) {
    throw std::invalid_argument("ADD_PATHPOINT: " + std::to_string(points.size()) +
                                " points; a packet carries 1 to 7");
  }
  std::vector<uint8_t> d;
  for (uint16_t p : points) Put16(d, p);
  return Make(address, kAddPathpoint, d);
}
Packet Nop(uint8_t address) { return Make(address, kNop); }
Packet HardReset(uint8_t address) { return Make(address, kHardReset); }
Packet HardResetConfig(uint8_t address, uint8_t control) {
  return Make(address, kHardReset, {control});
}

std::optional<Trajectory> DecodeTrajectory(const std::vector<uint8_t>& data, std::string* problem) {
  if (data.empty()) {
    *problem = "LOAD_TRAJ without its control byte";
    return std::nullopt;
  }
  Trajectory t;
  t.control = data[0];
  const size_t need = TrajectoryLength(t.control);
  if (data.size() != need) {
    *problem = "LOAD_TRAJ control byte " + Hex(t.control) + " needs " + std::to_string(need) +
               " data bytes, got " + std::to_string(data.size());
    return std::nullopt;
  }
  const uint8_t* p = data.data() + 1;
  if (t.control & kLoadPosition) {
    t.position = static_cast<int32_t>(Get32(p));
    p += 4;
  }
  if (t.control & kLoadVelocity) {
    t.velocity = Get32(p);
    p += 4;
  }
  if (t.control & kLoadAcceleration) {
    t.acceleration = Get32(p);
    p += 4;
  }
  if (t.control & kLoadPwm) t.pwm = *p;
  return t;
}

std::optional<Gains> DecodeGains(const std::vector<uint8_t>& data, std::string* problem) {
  if (data.size() != 14 && data.size() != 15) {
    *problem = "SET_GAIN needs 14 or 15 data bytes, got " + std::to_string(data.size());
    return std::nullopt;
  }
  const uint8_t* p = data.data();
  Gains g;
  g.kp = static_cast<int16_t>(Get16(p));
  g.kd = static_cast<int16_t>(Get16(p + 2));
  g.ki = static_cast<int16_t>(Get16(p + 4));
  g.integration_limit = static_cast<int16_t>(Get16(p + 6));
  g.output_limit = p[8];
  g.current_limit = p[9];
  g.error_limit = static_cast<int16_t>(Get16(p + 10));
  g.servo_rate = p[12];
  g.deadband = p[13];
  g.step_multiplier = data.size() == 15 ? p[14] : 1;
  return g;
}

std::string CheckDataLength(const Packet& packet) {
  const size_t n = packet.data.size();
  auto allowed = [&](std::initializer_list<size_t> ok, const char* what) -> std::string {
    for (size_t k : ok) {
      if (n == k) return "";
    }
    return std::string(CommandName(packet.command)) + " with " + std::to_string(n) +
           " data bytes; allowed: " + what;
  };
  std::string problem;
  switch (packet.command) {
    case kResetPos:
      if (n == 1 && packet.data[0] != kResetRelativeHome) {
        return "RESET_POS option " + Hex(packet.data[0]) + "; allowed: 0x01 (REL_HOME)";
      }
      if (n == 5 && packet.data[0] != kResetSetPosition) {
        return "RESET_POS option " + Hex(packet.data[0]) + " with a position; allowed: 0x02";
      }
      return allowed({0, 1, 5}, "0, 1 or 5");
    case kSetAddr:
      return allowed({2}, "2");
    case kDefineStatus:
    case kReadStatus:
    case kIoControl:
    case kSetHoming:
    case kSetBaud:
      return allowed({1}, "1");
    case kLoadTraj:
      return DecodeTrajectory(packet.data, &problem) ? "" : problem;
    case kSetGain:
      return DecodeGains(packet.data, &problem) ? "" : problem;
    case kStopMotor:
      if (n == 1 && !(packet.data[0] & kStopHere)) return "";
      if (n == 5 && (packet.data[0] & kStopHere)) return "";
      return "STOP_MOTOR with " + std::to_string(n) + " data bytes and control " +
             (n ? Hex(packet.data[0]) : std::string("none")) +
             "; allowed: 1 byte, or 5 with STOP_HERE (0x10) set";
    case kAddPathpoint:
      if (n % 2 == 0 && n <= 14) return "";
      return allowed({}, "0 or an even number up to 14");
    case kStartMove:
    case kClearBits:
    case kSaveAsHome:
    case kNop:
      return allowed({0}, "0");
    case kHardReset:
      return allowed({0, 1}, "0 or 1");
    default:
      return "";
  }
}

size_t ReplyLength(uint8_t items) {
  size_t n = 2;
  if (items & kSendPosition) n += 4;
  if (items & kSendAd) n += 1;
  if (items & kSendVelocity) n += 2;
  if (items & kSendAux) n += 1;
  if (items & kSendHome) n += 4;
  if (items & kSendId) n += 2;
  if (items & kSendPositionError) n += 2;
  if (items & kSendNumPoints) n += 1;
  return n;
}

std::vector<uint8_t> EncodeStatus(const Status& s, uint8_t items) {
  std::vector<uint8_t> out{s.status};
  if (items & kSendPosition) Put32(out, static_cast<uint32_t>(s.position));
  if (items & kSendAd) out.push_back(s.ad);
  if (items & kSendVelocity) Put16(out, s.velocity);
  if (items & kSendAux) out.push_back(s.aux);
  if (items & kSendHome) Put32(out, static_cast<uint32_t>(s.home));
  if (items & kSendId) {
    out.push_back(s.type);
    out.push_back(s.version);
  }
  if (items & kSendPositionError) Put16(out, s.position_error);
  if (items & kSendNumPoints) out.push_back(s.num_points);
  out.push_back(Checksum(out.data(), out.size()));
  return out;
}

Status DecodeStatus(const uint8_t* bytes, size_t n, uint8_t items) {
  const size_t need = ReplyLength(items);
  if (n != need) {
    throw ProtocolError("status reply of " + std::to_string(n) + " bytes, expected " +
                        std::to_string(need));
  }
  const uint8_t sum = Checksum(bytes, n - 1);
  if (sum != bytes[n - 1]) {
    throw ProtocolError("status reply checksum " + Hex(bytes[n - 1]) + ", expected " + Hex(sum));
  }
  Status s;
  s.status = bytes[0];
  const uint8_t* p = bytes + 1;
  if (items & kSendPosition) {
    s.position = static_cast<int32_t>(Get32(p));
    p += 4;
  }
  if (items & kSendAd) s.ad = *p++;
  if (items & kSendVelocity) {
    s.velocity = static_cast<int16_t>(Get16(p));
    p += 2;
  }
  if (items & kSendAux) s.aux = *p++;
  if (items & kSendHome) {
    s.home = static_cast<int32_t>(Get32(p));
    p += 4;
  }
  if (items & kSendId) {
    s.type = p[0];
    s.version = p[1];
    p += 2;
  }
  if (items & kSendPositionError) {
    s.position_error = static_cast<int16_t>(Get16(p));
    p += 2;
  }
  if (items & kSendNumPoints) s.num_points = *p;
  return s;
}

std::string DescribeStatusBits(uint8_t status) {
  static const char* const kNames[8] = {"MOVE_DONE", "CKSUM_ERROR", "OVERCURRENT", "POWER_ON",
                                        "POS_ERR",   "LIMIT1",      "LIMIT2",      "HOME_IN_PROG"};
  std::string s;
  for (int bit = 0; bit < 8; ++bit) {
    if (status & (1u << bit)) {
      if (!s.empty()) s += '|';
      s += kNames[bit];
    }
  }
  return s.empty() ? "-" : s;
}

}  // namespace sirupp::hardware::nmc
