#include "hardware/picservo_module.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace sirupp::hardware {
namespace {

using namespace nmc;

// HARD_RESET's one-byte form (reference section 2.3).
constexpr uint8_t kSaveData = 0x01;
constexpr uint8_t kRestoreAddress = 0x02;
constexpr uint8_t kPowerUpAmp = 0x04;
constexpr uint8_t kPowerUpServo = 0x08;
constexpr uint8_t kPowerUpStep = 0x10;
constexpr uint8_t kPowerUpLimits = 0x20;
constexpr uint8_t kPowerUp3Phase = 0x40;
constexpr uint8_t kPowerUpAntiphase = 0x80;

constexpr double kTickHz = 1953.125;
// A path point's speed is reached in one tick (the chip interpolates; we do not).
constexpr int64_t kInstantAcceleration = int64_t{1} << 40;

int Sign(int64_t v) { return (v > 0) - (v < 0); }

int32_t GetSigned32(const uint8_t* p) {
  return static_cast<int32_t>(static_cast<uint32_t>(p[0]) | (static_cast<uint32_t>(p[1]) << 8) |
                              (static_cast<uint32_t>(p[2]) << 16) |
                              (static_cast<uint32_t>(p[3]) << 24));
}

int16_t Clamp16(int64_t v) {
  return static_cast<int16_t>(std::clamp<int64_t>(v, std::numeric_limits<int16_t>::min(),
                                                  std::numeric_limits<int16_t>::max()));
}

}  // namespace

PicServoModule::PicServoModule() {
  gains_ = Gains{};  // all zero, SR 1, SM 1
  ApplyGains(gains_);
}

PicServoModule::Addressing PicServoModule::Match(uint8_t address, uint8_t command,
                                                 bool addr_in) const {
  if (command == kHardReset && address == kBroadcast) return Addressing::kGroup;
  if (!addressed_ && !addr_in) return Addressing::kNone;
  if (address == kUnaddressed) {
    return !addressed_ && addr_in ? Addressing::kIndividual : Addressing::kNone;
  }
  if (addressed_ && address == address_) return Addressing::kIndividual;
  if (address == group_) return Addressing::kGroup;
  return Addressing::kNone;
}

PicServoModule::Result PicServoModule::Handle(const Packet& packet, bool checksum_ok,
                                              bool addr_in) {
  Result result;
  const Addressing addressing = Match(packet.address, packet.command, addr_in);
  if (addressing == Addressing::kNone) return result;
  result.heard = true;
  bool reply = addressing == Addressing::kIndividual || leader_;
  if (packet.command == kHardReset || packet.command == kSetBaud) reply = false;
  uint8_t items = defined_items_;
  // A bad checksum, or a length the command does not allow: reply with CKSUM_ERROR, do nothing.
  if (!checksum_ok || !CheckDataLength(packet).empty()) {
    checksum_error_ = true;
  } else {
    checksum_error_ = false;
    Execute(packet, &result, &items);
  }
  if (reply) result.reply = EncodeStatus(StatusNow(), items);
  return result;
}

void PicServoModule::Execute(const Packet& packet, Result* result, uint8_t* reply_items) {
  const std::vector<uint8_t>& d = packet.data;
  std::string problem;
  switch (packet.command) {
    case kResetPos: {
      int64_t counter = 0;
      if (d.size() == 1) {
        counter = position_ - home_;  // REL_HOME: the home position becomes 0
        home_ = 0;
      } else if (d.size() == 5) {
        counter = GetSigned32(d.data() + 1);  // SET_POS
      }
      offset_ += counter - position_;
      position_ = counter;
      previous_position_ = counter;
      servo_.ResetPosition(counter);
      break;
    }
    case kSetAddr:
      address_ = d[0];
      group_ = static_cast<uint8_t>(d[1] | 0x80);
      leader_ = (d[1] & 0x80) == 0;
      addressed_ = true;  // ADDR_OUT goes low: the next module in the chain listens
      break;
    case kDefineStatus:
      defined_items_ = d[0];
      *reply_items = d[0];
      break;
    case kReadStatus:
      *reply_items = d[0];
      break;
    case kLoadTraj: {
      const Trajectory t = *DecodeTrajectory(d, &problem);
      if (t.control & kStartNow) {
        StartOrDefer(t);
      } else {
        buffered_ = t;  // a later LOAD_TRAJ overwrites it
      }
      break;
    }
    case kStartMove:
      if (buffered_) {
        const Trajectory t = *buffered_;
        buffered_.reset();
        StartOrDefer(t);
      }
      break;
    case kSetGain:
      ApplyGains(*DecodeGains(d, &problem));
      break;
    case kStopMotor:
      StopMotor(d[0], d.size() == 5 ? GetSigned32(d.data() + 1) : 0);
      break;
    case kIoControl:
      io_control_ = d[0];
      break;
    case kSetHoming:
      homing_control_ = d[0];
      home_in_progress_ = d[0] != 0;
      break;
    case kSetBaud:
      result->new_baud = BaudFromDivisor(d[0]);  // 0 (unknown divisor): the speed stays
      break;
    case kClearBits:
      overcurrent_ = false;
      position_wrap_ = false;
      servo_.ClearLatches();
      break;
    case kSaveAsHome:
      home_ = position_;
      break;
    case kAddPathpoint:
      if (d.empty()) {
        if (servo_.servo_on()) {
          path_mode_ = true;
          path_ticks_left_ = 0;
        }
      } else {
        for (size_t i = 0; i + 1 < d.size(); i += 2) {
          if (path_.size() < kPathBufferSize) {
            path_.push_back(static_cast<uint16_t>(d[i] | (d[i + 1] << 8)));
          }
        }
      }
      break;
    case kNop:
      break;
    case kHardReset:
      if (d.size() == 1) {
        if (d[0] & kSaveData) {
          eeprom_.valid = true;
          eeprom_.control = d[0];
          eeprom_.address = address_;
          eeprom_.group = group_;
          eeprom_.leader = leader_;
          eeprom_.velocity = velocity_word_;
          eeprom_.acceleration = acceleration_word_;
          eeprom_.gains = gains_;
        } else if (d[0] == 0) {
          eeprom_ = ModuleEeprom{};
        }
      }
      ResetToPowerUp();
      result->new_baud = kPowerUpBaud;
      break;
    default:
      break;
  }
}

void PicServoModule::StartOrDefer(const Trajectory& t) {
  if (latency_ticks_ == 0) {
    StartTrajectory(t);
    return;
  }
  pending_ = t;
  pending_ticks_ = latency_ticks_;
}

void PicServoModule::StartTrajectory(const Trajectory& t) {
  if (t.control & kLoadPosition) position_word_ = t.position;
  if (t.control & kLoadVelocity) velocity_word_ = t.velocity;
  if (t.control & kLoadAcceleration) acceleration_word_ = t.acceleration;
  if (t.control & kLoadPwm) pwm_word_ = t.pwm;
  const bool reverse = (t.control & kReverse) != 0;
  if (!(t.control & kEnableServo)) {
    // Open-loop PWM: the PWM byte, or the present output if none came with this command.
    const int pwm = (t.control & kLoadPwm) ? (reverse ? -pwm_word_ : pwm_word_) : servo_.output();
    path_mode_ = false;
    servo_.SetPwm(pwm);
    return;
  }
  // ENABLE_SERVO brings a PWM-mode module back under the servo; a module whose servo is off
  // (power-up, MOTOR_OFF, a trip) stays off until STOP_ABRUPT or STOP_HERE.
  if (servo_.pwm_mode()) servo_.ServoOn(position_);
  if (!servo_.servo_on()) return;
  path_mode_ = false;
  if (t.control & kVelocityMode) {
    if (acceleration_word_ == 0) return;  // could never change speed
    const int64_t v = static_cast<int64_t>(velocity_word_) * (reverse ? -1 : 1);
    servo_.LoadVelocity(v, acceleration_word_);
    return;
  }
  if (velocity_word_ == 0 || acceleration_word_ == 0) return;  // would never arrive
  int64_t goal = position_word_;
  if (reverse) goal += servo::WholeCounts(servo_.profile().goal());  // MOVE_REL: from the goal
  servo_.LoadTrajectory(goal, velocity_word_, acceleration_word_);
}

void PicServoModule::StopMotor(uint8_t control, int32_t here) {
  pending_.reset();  // a stop cancels a move still waiting for its latency
  amp_enabled_ = (control & kAmpEnable) != 0;
  if (control & (kMotorOff | kStopAbrupt | kStopSmooth | kStopHere)) path_mode_ = false;
  if (control & kMotorOff) {
    servo_.MotorOff();
  } else if (control & kStopAbrupt) {
    if (servo_.servo_on()) {
      servo_.StopAbrupt(position_);
    } else {
      servo_.ServoOn(position_);  // the usual way to switch the servo on
    }
  } else if (control & kStopSmooth) {
    if (servo_.servo_on()) {
      servo_.StopSmooth();
    } else if (servo_.pwm_mode()) {
      servo_.SetPwm(0);
    }
  }
  if (control & kStopHere) servo_.StopHere(here, position_);
}

void PicServoModule::ApplyGains(const Gains& g) {
  gains_ = g;
  servo::ServoGains s;
  s.kp = std::max<int>(0, g.kp);
  s.kd = std::max<int>(0, g.kd);
  s.ki = std::max<int>(0, g.ki);
  s.integration_limit = std::max<int>(0, g.integration_limit);
  s.output_limit = g.output_limit;
  s.error_limit = std::max<int>(0, g.error_limit);
  s.deadband = g.deadband;
  servo_.SetGains(s);
}

void PicServoModule::ResetToPowerUp() {
  const ModuleEeprom eeprom = eeprom_;
  const MotorInputs inputs = last_inputs_;
  const int latency = latency_ticks_;  // the board's, not a setting a reset clears
  *this = PicServoModule();
  latency_ticks_ = latency;
  eeprom_ = eeprom;
  last_inputs_ = inputs;
  offset_ = -inputs.encoder_counts;  // the counter reads 0 after a reset
  if (!eeprom.valid) return;
  ApplyGains(eeprom.gains);
  velocity_word_ = eeprom.velocity;
  acceleration_word_ = eeprom.acceleration;
  if (eeprom.control & kRestoreAddress) {
    address_ = eeprom.address;
    group_ = eeprom.group;
    leader_ = eeprom.leader;
    addressed_ = true;
  }
  if (eeprom.control & kPowerUpAmp) amp_enabled_ = true;
  if (eeprom.control & kPowerUpServo) servo_.ServoOn(0);
  if (eeprom.control & kPowerUpLimits) io_control_ |= kLimitStopOff;
  if (eeprom.control & kPowerUpStep) io_control_ |= kStepMode;
  if (eeprom.control & kPowerUp3Phase) io_control_ |= kThreePhase;
  if (eeprom.control & kPowerUpAntiphase) io_control_ |= kAntiphase;
}

int PicServoModule::Tick(const MotorInputs& in) {
  const MotorInputs previous = last_inputs_;
  last_inputs_ = in;
  previous_position_ = position_;
  position_ = in.encoder_counts + offset_;
  if (position_ > std::numeric_limits<int32_t>::max() ||
      position_ < std::numeric_limits<int32_t>::min()) {
    position_wrap_ = true;
  }
  velocity_ = static_cast<int>(position_ - previous_position_);

  // Overcurrent: CL odd trips above it, CL even below it, 0 and 255 disable the check.
  bool overcurrent_trip = inject_overcurrent_;
  inject_overcurrent_ = false;
  const uint8_t cl = gains_.current_limit;
  if (amp_enabled_ && cl != 0 && cl != 255) {
    overcurrent_trip |= (cl & 1) ? in.current_ad > cl : in.current_ad < cl;
  }
  if (overcurrent_trip) {
    overcurrent_ = true;
    servo_.MotorOff();
    path_mode_ = false;
  }
  bool position_error_trip = false;
  if (inject_position_error_) {
    inject_position_error_ = false;
    servo_.TripPositionError();
    path_mode_ = false;
    position_error_trip = true;
  }
  LimitStop(in);
  if (pending_ && --pending_ticks_ <= 0) {
    const Trajectory t = *pending_;
    pending_.reset();
    StartTrajectory(t);
  }

  const bool was_on = servo_.servo_on();
  if (++servo_rate_count_ >= std::max<int>(1, gains_.servo_rate)) {
    servo_rate_count_ = 0;
    PathTick();
    servo_.Tick(position_);
  }
  if (was_on && !servo_.servo_on() && (servo_.status() & servo::kPositionError)) {
    position_error_trip = true;
  }
  if (home_in_progress_) {
    const uint8_t c = homing_control_;
    bool fire = false;
    int64_t latch = position_;
    if ((c & kHomeOnLimit1) && in.limit1 != previous.limit1) fire = true;
    if ((c & kHomeOnLimit2) && in.limit2 != previous.limit2) fire = true;
    if ((c & kHomeOnPositionError) && position_error_trip) fire = true;
    if ((c & kHomeOnOvercurrent) && overcurrent_trip) fire = true;
    if ((c & kHomeOnIndex) && in.index_crossed) {
      fire = true;
      latch = in.index_edge_counts + offset_;  // captured at the edge, as the chip's hardware does
    }
    if (fire) {
      home_ = latch;
      home_in_progress_ = false;
      if (c & kHomeMotorOff) {
        servo_.MotorOff();
      } else if ((c & kHomeStopAbrupt) && servo_.servo_on()) {
        servo_.StopAbrupt(position_);
      } else if ((c & kHomeStopSmooth) && servo_.servo_on()) {
        servo_.StopSmooth();
      }
    }
  }
  pwm_ = amp_enabled_ && in.power_ok ? servo_.output() : 0;
  return pwm_;
}

void PicServoModule::LimitStop(const MotorInputs& in) {
  if (!(io_control_ & (kLimitStopOff | kLimitStopAbrupt))) return;
  // Limit 1 inhibits motion up the counts, limit 2 down (the 3PH manual's forward and reverse).
  const int direction =
      servo_.servo_on() ? Sign(servo_.profile().velocity()) : Sign(servo_.output());
  if (!((in.limit1 && direction > 0) || (in.limit2 && direction < 0))) return;
  path_mode_ = false;
  if ((io_control_ & kLimitStopOff) || !servo_.servo_on()) {
    servo_.MotorOff();
  } else {
    servo_.StopAbrupt(position_);
  }
}

void PicServoModule::PathTick() {
  if (!path_mode_) return;
  if (!servo_.servo_on()) {
    path_mode_ = false;
    return;
  }
  if (path_ticks_left_ > 0) {
    --path_ticks_left_;
    return;
  }
  if (path_.empty()) {
    path_mode_ = false;
    servo_.LoadVelocity(0, kInstantAcceleration);
    return;
  }
  const uint16_t point = path_.front();
  path_.erase(path_.begin());
  const bool fast = (io_control_ & kFastPath) != 0;
  const bool slower = (point & 0x02) != 0;
  const double hz = fast ? (slower ? 60 : 120) : (slower ? 30 : 60);
  // The word is the speed in 1/256 count per tick; bit 0 = reverse, bit 1 = the slower rate.
  const int64_t speed = static_cast<int64_t>(point & 0xFFFC) * 256;
  servo_.LoadVelocity((point & 0x01) ? -speed : speed, kInstantAcceleration);
  path_ticks_left_ = static_cast<int>(std::lround(kTickHz / hz)) - 1;
}

uint8_t PicServoModule::status_byte() const {
  const servo::PicServo::ChipFlags f = servo_.chip_flags();
  uint8_t s = 0;
  if (f.move_done && !path_mode_ && !pending_) s |= kStatusMoveDone;
  if (checksum_error_) s |= kStatusChecksumError;
  if (overcurrent_) s |= kStatusOvercurrent;
  if (last_inputs_.power_ok) s |= kStatusPowerOn;
  if (f.position_error) s |= kStatusPositionError;
  if (last_inputs_.limit1) s |= kStatusLimit1;
  if (last_inputs_.limit2) s |= kStatusLimit2;
  if (home_in_progress_) s |= kStatusHomeInProgress;
  return s;
}

uint8_t PicServoModule::aux_byte() const {
  const servo::PicServo::ChipFlags f = servo_.chip_flags();
  uint8_t a = 0;
  if (last_inputs_.index) a |= kAuxIndex;
  if (position_wrap_) a |= kAuxPositionWrap;
  if (f.servo_on) a |= kAuxServoOn;
  if (f.accel_done) a |= kAuxAccelDone;
  if (f.slew_done) a |= kAuxSlewDone;
  if (path_mode_) a |= kAuxPathMode;
  return a;
}

Status PicServoModule::StatusNow() const {
  Status s;
  s.status = status_byte();
  s.position = static_cast<int32_t>(position_);
  s.ad = last_inputs_.current_ad;
  s.velocity = Clamp16(velocity_);
  s.aux = aux_byte();
  s.home = static_cast<int32_t>(home_);
  s.type = kTypePicServo;
  s.version = kVersionPicServoSc;
  s.position_error = Clamp16(servo_.position_error());
  s.num_points = static_cast<uint8_t>(std::min<size_t>(255, path_.size()));
  return s;
}

}  // namespace sirupp::hardware
