#pragma once
// The NMC serial protocol of JR Kerr's PIC-SERVO SC modules, as bytes: command packets from the
// host, status replies from the modules, and every constant of shared/reference/picservo.md
// sections 1-2. Pure functions and small parsers; no I/O (nmc_bus.hpp does the talking,
// picservo_module.hpp the module side). docs/hardware.md explains the protocol in our words.
//
// Command packet (host -> modules):  AA  address  (N << 4 | command)  data[N]  checksum
//   checksum = 8-bit sum of address, command byte and data (the 0xAA header is not included).
// Status reply (module -> host):     status  [items chosen by DEF_STAT, in bit order]  checksum
//   checksum = 8-bit sum of every byte before it.
// Multi-byte values are little-endian.

#include <cstddef>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace sirupp::hardware::nmc {

inline constexpr uint8_t kHeader = 0xAA;
inline constexpr int kMaxData = 15;  // N is a nibble

// Addresses.
inline constexpr uint8_t kUnaddressed = 0x00;  // every module after reset
inline constexpr uint8_t kBroadcast = 0xFF;    // default group, no leader; universal reset address
inline constexpr int kMaxModules = 32;         // individual addresses 1..32
inline bool IsGroupAddress(uint8_t a) { return a >= 0x80; }

// Command codes (low nibble of the command byte).
enum Command : uint8_t {
  kResetPos = 0x0,
  kSetAddr = 0x1,
  kDefineStatus = 0x2,
  kReadStatus = 0x3,
  kLoadTraj = 0x4,
  kStartMove = 0x5,
  kSetGain = 0x6,
  kStopMotor = 0x7,
  kIoControl = 0x8,
  kSetHoming = 0x9,
  kSetBaud = 0xA,
  kClearBits = 0xB,
  kSaveAsHome = 0xC,
  kAddPathpoint = 0xD,
  kNop = 0xE,
  kHardReset = 0xF,
};
// "LOAD_TRAJ", "NOP", ...
const char* CommandName(uint8_t command);

// Status byte.
enum StatusBit : uint8_t {
  kStatusMoveDone = 0x01,
  kStatusChecksumError = 0x02,
  kStatusOvercurrent = 0x04,
  kStatusPowerOn = 0x08,
  kStatusPositionError = 0x10,
  kStatusLimit1 = 0x20,
  kStatusLimit2 = 0x40,
  kStatusHomeInProgress = 0x80,
};
// Auxiliary status byte.
enum AuxBit : uint8_t {
  kAuxIndex = 0x01,
  kAuxPositionWrap = 0x02,
  kAuxServoOn = 0x04,
  kAuxAccelDone = 0x08,
  kAuxSlewDone = 0x10,
  kAuxServoOverrun = 0x20,
  kAuxPathMode = 0x40,
};
// Status items (DEF_STAT / READ_STAT byte), in the order they follow the status byte.
enum StatusItem : uint8_t {
  kSendPosition = 0x01,       // int32 counts
  kSendAd = 0x02,             // uint8 current-sense reading
  kSendVelocity = 0x04,       // int16 counts per tick
  kSendAux = 0x08,            // uint8 auxiliary status
  kSendHome = 0x10,           // int32 home register
  kSendId = 0x20,             // uint8 type, uint8 version
  kSendPositionError = 0x40,  // int16 command - actual
  kSendNumPoints = 0x80,      // uint8 path points buffered
};
// LOAD_TRAJ control byte.
enum TrajBit : uint8_t {
  kLoadPosition = 0x01,
  kLoadVelocity = 0x02,
  kLoadAcceleration = 0x04,
  kLoadPwm = 0x08,
  kEnableServo = 0x10,
  kVelocityMode = 0x20,
  kReverse = 0x40,  // velocity / PWM mode: negative direction; position mode (SC): relative move
  kStartNow = 0x80,
};
// STOP_MOTOR control byte.
enum StopBit : uint8_t {
  kAmpEnable = 0x01,
  kMotorOff = 0x02,
  kStopAbrupt = 0x04,
  kStopSmooth = 0x08,
  kStopHere = 0x10,
  kAdvancedFeature = 0x20,
};
// SET_HOMING control byte.
enum HomingBit : uint8_t {
  kHomeOnLimit1 = 0x01,
  kHomeOnLimit2 = 0x02,
  kHomeMotorOff = 0x04,
  kHomeOnIndex = 0x08,
  kHomeStopAbrupt = 0x10,
  kHomeStopSmooth = 0x20,
  kHomeOnPositionError = 0x40,
  kHomeOnOvercurrent = 0x80,
};
// IO_CTRL byte (PIC-SERVO SC).
enum IoBit : uint8_t {
  kLimitStopOff = 0x04,
  kLimitStopAbrupt = 0x08,
  kThreePhase = 0x10,
  kAntiphase = 0x20,
  kFastPath = 0x40,
  kStepMode = 0x80,
};
// RESET_POS one-byte forms.
inline constexpr uint8_t kResetRelativeHome = 0x01;
inline constexpr uint8_t kResetSetPosition = 0x02;

// Module identity answered to SEND_ID.
inline constexpr uint8_t kTypePicServo = 0;
inline constexpr uint8_t kVersionPicServoSc = 10;

// Baud rates the SC supports, and SET_BAUD's divisor byte. Throws std::invalid_argument naming the
// allowed rates for any other value.
uint8_t BaudDivisor(int baud);
int BaudFromDivisor(uint8_t divisor);  // 0 if unknown
bool IsSupportedBaud(int baud);
inline constexpr int kPowerUpBaud = 19200;
// "9600, 19200, 57600, 115200, 230400"
std::string SupportedBauds();

// One command packet.
struct Packet {
  uint8_t address = 0;
  uint8_t command = kNop;  // low nibble only
  std::vector<uint8_t> data;

  bool operator==(const Packet& o) const {
    return address == o.address && command == o.command && data == o.data;
  }
};

// 8-bit sum.
uint8_t Checksum(const uint8_t* bytes, size_t n);
// The packet's bytes, header to checksum. Throws std::invalid_argument over 15 data bytes.
std::vector<uint8_t> Encode(const Packet& packet);
// One line for logs and errors: "LOAD_TRAJ to 0x01 [97 00 ...]".
std::string Describe(const Packet& packet);

// Splits a byte stream into command packets (the module's receiver). Bytes before a header are
// skipped (and counted), so a burst of zeros or noise resynchronises it.
class PacketReader {
 public:
  struct Result {
    Packet packet;
    bool checksum_ok = true;
  };
  // Feeds one byte; returns a packet when this byte completed one.
  std::optional<Result> Feed(uint8_t byte);
  // Drops a partial packet (e.g. after the inter-byte timeout).
  void Reset() { state_ = State::kWaitHeader; }
  bool in_packet() const { return state_ != State::kWaitHeader; }
  uint64_t skipped_bytes() const { return skipped_; }

 private:
  enum class State { kWaitHeader, kAddress, kCommand, kData, kChecksum };
  State state_ = State::kWaitHeader;
  Packet partial_;
  size_t need_ = 0;
  uint64_t skipped_ = 0;
};

// ---- Command builders (host side), one per command of the reference. ----------------------------

// LOAD_TRAJ parameters; only those flagged in `control` are sent.
struct Trajectory {
  uint8_t control = 0;
  int32_t position = 0;       // counts
  uint32_t velocity = 0;      // counts per tick << 16, 0..83886080
  uint32_t acceleration = 0;  // counts per tick^2 << 16, 0..2^31-1
  uint8_t pwm = 0;            // 0..255
};
inline constexpr uint32_t kMaxVelocityWord = 83886080;
inline constexpr uint32_t kMaxAccelerationWord = 0x7FFFFFFF;

// SET_GAIN parameters (reference section 3.3).
struct Gains {
  int16_t kp = 0, kd = 0, ki = 0;
  int16_t integration_limit = 0;  // IL
  uint8_t output_limit = 0;       // OL
  uint8_t current_limit = 0;      // CL
  int16_t error_limit = 0;        // EL
  uint8_t servo_rate = 1;         // SR
  uint8_t deadband = 0;           // DB
  uint8_t step_multiplier = 1;    // SM, sent only in the 15-byte form
};

Packet ResetPosition(uint8_t address);                // counter and command position to 0
Packet ResetToHome(uint8_t address);                  // home register becomes the new zero
Packet SetPosition(uint8_t address, int32_t counts);  // v.10+: position := counts
// New individual address and group; `leader` makes the module its group's leader (bit 7 cleared).
Packet SetAddress(uint8_t address, uint8_t new_address, uint8_t group, bool leader);
Packet DefineStatus(uint8_t address, uint8_t items);
Packet ReadStatus(uint8_t address, uint8_t items);
Packet LoadTrajectory(uint8_t address, const Trajectory& trajectory);
Packet StartMove(uint8_t address);
Packet SetGain(uint8_t address, const Gains& gains, bool with_step_multiplier = false);
Packet StopMotor(uint8_t address, uint8_t control);  // kStopHere not allowed here
Packet StopHere(uint8_t address, uint8_t control, int32_t counts);
Packet IoControl(uint8_t address, uint8_t control);
Packet SetHoming(uint8_t address, uint8_t control);
Packet SetBaud(uint8_t address, uint8_t divisor);
Packet ClearBits(uint8_t address);
Packet SaveAsHome(uint8_t address);
Packet StartPathMode(uint8_t address);
Packet AddPathpoints(uint8_t address, const std::vector<uint16_t>& points);  // 1..7 points
Packet Nop(uint8_t address);
Packet HardReset(uint8_t address);
Packet HardResetConfig(uint8_t address, uint8_t control);  // SC: EEPROM save / erase

// ---- Decoding a command's data (module side).
// ---------------------------------------------------- Each returns std::nullopt and fills
// `problem` when the data length does not fit the command.
std::optional<Trajectory> DecodeTrajectory(const std::vector<uint8_t>& data, std::string* problem);
std::optional<Gains> DecodeGains(const std::vector<uint8_t>& data, std::string* problem);
// "" when the packet's data length is one the command allows, else what is wrong.
std::string CheckDataLength(const Packet& packet);

// ---- Status replies. ----------------------------------------------------------------------------

struct Status {
  uint8_t status = 0;
  // Items; meaningful only when their bit is in the reply's item set.
  int32_t position = 0;
  uint8_t ad = 0;
  int16_t velocity = 0;
  uint8_t aux = 0;
  int32_t home = 0;
  uint8_t type = 0;
  uint8_t version = 0;
  int16_t position_error = 0;
  uint8_t num_points = 0;
};

// Bytes of a reply carrying `items`, checksum included (2 with no items, at most 19).
size_t ReplyLength(uint8_t items);
std::vector<uint8_t> EncodeStatus(const Status& status, uint8_t items);

class ProtocolError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};
// Parses exactly ReplyLength(items) bytes. Throws ProtocolError ("checksum 0x12, expected 0x13")
// on a bad checksum or length.
Status DecodeStatus(const uint8_t* bytes, size_t n, uint8_t items);

// "MOVE_DONE|POWER_ON" (or "-" when 0), for status texts.
std::string DescribeStatusBits(uint8_t status);

}  // namespace sirupp::hardware::nmc
