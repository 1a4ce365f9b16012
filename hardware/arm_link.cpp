#include "hardware/arm_link.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <thread>

#include "core/errors.hpp"

namespace sirupp::hardware {
namespace {

using Clock = std::chrono::steady_clock;
using sirupp::servo_move_t;

int64_t WallMicros() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

std::string JointName(const core::RobotModel& model, int j) {
  return "joint j" + std::to_string(j + 1) + " (" + model.joints[static_cast<size_t>(j)].name + ")";
}

// Degrees for revolute joints, metres for prismatic, as people read them.
std::string Shown(const core::Joint& joint, double v) {
  if (joint.type == core::JointType::kRevolute) return core::FormatApprox(v * 180 / M_PI) + " deg";
  return core::FormatApprox(v) + " m";
}

// To a tenth of a degree (or a millimetre), for positions read from counters: "-43.7 deg".
std::string ShownTenth(const core::Joint& joint, double v) {
  const bool revolute = joint.type == core::JointType::kRevolute;
  double x = std::round((revolute ? v * 180 / M_PI : v * 1000) * 10) / 10;
  if (x == 0) x = 0;  // no "-0"
  char text[32];
  std::snprintf(text, sizeof text, revolute ? "%.1f deg" : "%.1f mm", x);
  return text;
}

int32_t ClampCounts(int64_t counts) {
  return static_cast<int32_t>(std::clamp<int64_t>(counts, INT32_MIN, INT32_MAX));
}

}  // namespace

ArmLink::ArmLink(const core::RobotModel& model, const BridgeSettings& settings, BytePort& port)
    : model_(model),
      settings_(settings),
      bus_(port, BusOptions{std::chrono::milliseconds(settings.reply_margin_ms), settings.retries,
                            nullptr}) {
  for (const core::Joint& joint : model.joints) drives_.emplace_back(joint, model.servo_tick_s);
  gains_ = servo::ChipGainsFromModel(model);
  board_gains_.assign(drives_.size(), std::nullopt);
  goals_.assign(drives_.size(), 0.0);
  velocity_mode_.assign(drives_.size(), false);
  last_counts_.assign(drives_.size(), 0);
}

std::string ArmLink::ResumeProblem(const std::vector<NmcBus::Addressed>& kept) const {
  const int n = num_joints();
  if (static_cast<int>(kept.size()) != n) {
    return "only " + std::to_string(kept.size()) + " of the " + std::to_string(n) +
           " modules answered at their addresses";
  }
  for (int j = 0; j < n; ++j) {
    const nmc::Status& s = kept[static_cast<size_t>(j)].status;
    const std::string module = "module " + std::to_string(j + 1);
    if (s.type != nmc::kTypePicServo) {
      return module + " is of type " + std::to_string(s.type) + ", not a PIC-SERVO";
    }
    if (s.home != kCalibrationMarker) {
      return module + " holds no calibration (home register " + std::to_string(s.home) +
             ", not the bridge's marker " + std::to_string(kCalibrationMarker) + ")";
    }
    const core::Joint& joint = model_.joints[static_cast<size_t>(j)];
    const double q = drives_[static_cast<size_t>(j)].FromCounts(s.position);
    const double slack = kPoseToleranceDeg * M_PI / 180;
    if (!(q >= joint.position_min - slack && q <= joint.position_max + slack)) {
      return module + "'s counter puts " + JointName(model_, j) + " at " + ShownTenth(joint, q) +
             ", outside its limits [" + Shown(joint, joint.position_min) + ", " +
             Shown(joint, joint.position_max) + "]";
    }
  }
  return "";
}

void ArmLink::Resume(const std::vector<NmcBus::Addressed>& kept) {
  std::vector<ModuleInfo> modules;
  for (const NmcBus::Addressed& k : kept) modules.push_back(k.info);
  bus_.Adopt(modules, static_cast<uint8_t>(settings_.group_address));
  std::fill(board_gains_.begin(), board_gains_.end(), std::nullopt);  // not known: sent again
  bool all_on = true;
  bool all_revolute = true;
  std::string angles;
  for (int j = 0; j < num_joints(); ++j) {
    const auto i = static_cast<size_t>(j);
    const uint8_t a = Address(j);
    SendGains(j);
    const nmc::Status s = bus_.Command(nmc::DefineStatus(a, kPollItems));
    all_on = all_on && (s.aux & nmc::kAuxServoOn);
    goals_[i] = drives_[i].FromCounts(s.position);
    velocity_mode_[i] = false;
    const std::string shown = ShownTenth(model_.joints[i], goals_[i]);
    all_revolute = all_revolute && model_.joints[i].type == core::JointType::kRevolute;
    angles += (j ? " " : "") + shown.substr(0, shown.find(' '));
  }
  have_last_poll_ = false;
  connected_ = calibrated_ = resumed_ = true;
  armed_ = all_on;
  fresh_and_undriven_ = false;
  blind_reason_.clear();
  connect_report_ = "resumed without a reset: the " + std::to_string(num_joints()) +
                    " modules on " + bus_.port().name() +
                    " kept power and their calibration; joints at " + angles +
                    (all_revolute ? " deg" : " (deg; mm for prismatic joints)") + ", servos " +
                    (all_on ? "on" : "not all on");
}

void ArmLink::Connect() {
  const bool was_fresh_and_undriven = fresh_and_undriven_;
  connected_ = calibrated_ = armed_ = resumed_ = fresh_and_undriven_ = false;
  connect_report_.clear();
  const int n = num_joints();
  // Boards that kept power since an earlier bridge answer at their addresses, at the baud it set.
  bus_.port().SetBaud(settings_.baud);
  bus_.port().DiscardInput();
  const std::vector<NmcBus::Addressed> kept =
      bus_.FindAddressed(n, nmc::kSendHome | nmc::kSendPosition | nmc::kSendAux);
  if (!kept.empty()) {
    const std::string problem = ResumeProblem(kept);
    if (problem.empty()) {
      Resume(kept);
      return;
    }
    if (was_fresh_and_undriven) {
      // This bridge found them fresh and has not driven the arm since: still where it powered up.
      blind_reason_.clear();
      fresh_and_undriven_ = true;
    } else {
      blind_reason_ = "the modules on " + bus_.port().name() +
                      " had kept power since an earlier connection, but " + problem +
                      "; their counters said nothing sure about where the arm is, and the reset "
                      "zeroed them wherever it stands";
      connect_report_ = "the modules had kept power without a calibration (" + problem +
                        "): reset; calibrating by the pose is refused until the arm is shown to "
                        "be in it";
    }
  } else {
    blind_reason_.clear();
    fresh_and_undriven_ = true;
  }
  const std::vector<ModuleInfo> found =
      bus_.Initialize(n, settings_.baud, static_cast<uint8_t>(settings_.group_address));
  if (static_cast<int>(found.size()) != n) {
    throw std::runtime_error("found " + std::to_string(found.size()) + " PIC-SERVO module(s) on " +
                             bus_.port().name() + "; the model " + model_.name + " has " +
                             std::to_string(n) + " joints, one module each");
  }
  for (const ModuleInfo& m : found) {
    if (m.type != nmc::kTypePicServo) {
      throw std::runtime_error("module " + std::to_string(m.address) + " is of type " +
                               std::to_string(m.type) + ", not a PIC-SERVO (type 0)");
    }
  }
  std::fill(board_gains_.begin(), board_gains_.end(), std::nullopt);  // reset: power-up gains
  for (int j = 0; j < n; ++j) {
    const uint8_t a = Address(j);
    bus_.Command(nmc::StopMotor(a, nmc::kMotorOff));  // amplifier off while configuring
    SendGains(j);
    bus_.Command(nmc::ClearBits(a));
    bus_.Command(nmc::DefineStatus(a, kPollItems));
  }
  have_last_poll_ = false;
  connected_ = true;
}

nmc::Gains BoardGains(const servo::ChipGains& g) {
  nmc::Gains chip;
  chip.kp = static_cast<int16_t>(g.kp);
  chip.kd = static_cast<int16_t>(g.kd);
  chip.ki = static_cast<int16_t>(g.ki);
  chip.integration_limit = static_cast<int16_t>(g.integration_limit);
  chip.output_limit = static_cast<uint8_t>(g.output_limit);
  chip.current_limit = static_cast<uint8_t>(g.current_limit);
  chip.error_limit = static_cast<int16_t>(g.error_limit);
  chip.servo_rate = static_cast<uint8_t>(g.servo_rate_divisor);
  chip.deadband = static_cast<uint8_t>(g.deadband);
  return chip;
}

void ArmLink::SendGains(int j) {
  const auto i = static_cast<size_t>(j);
  const servo::ChipGains& g = gains_[i];
  const nmc::Gains chip = BoardGains(g);
  board_gains_[i].reset();  // unknown until acknowledged
  bus_.Command(nmc::SetGain(Address(j), chip));
  board_gains_[i] = g;
}

void ArmLink::SetGains(const std::vector<servo::ChipGains>& gains) {
  if (gains.size() != gains_.size()) {
    throw std::invalid_argument("SetGains: " + std::to_string(gains.size()) +
                                " joints; the arm has " + std::to_string(gains_.size()));
  }
  gains_ = gains;
  gains_set_ = true;
  if (!connected_) return;
  for (int j = 0; j < num_joints(); ++j) SendGains(j);
}

void ArmLink::ReplaceModel(const core::RobotModel& model, const BridgeSettings& settings) {
  const int n = num_joints();
  if (model.num_joints() != n) {
    throw std::runtime_error("the bridge drives " + std::to_string(n) + " modules; " + model.name +
                             " has " + std::to_string(model.num_joints()) + " joints");
  }
  std::vector<servo::JointDrive> drives;
  for (int j = 0; j < n; ++j) {
    const auto i = static_cast<size_t>(j);
    if (model.joints[i].type != model_.joints[i].type) {
      throw std::runtime_error(JointName(model, j) + " is of another type than " +
                               JointName(model_, j));
    }
    drives.emplace_back(model.joints[i], model.servo_tick_s);
    if (calibrated_ && drives[i].counts_per_unit() != drives_[i].counts_per_unit()) {
      throw std::runtime_error(JointName(model, j) + " has another encoder scale (" +
                               core::FormatNumber(drives[i].counts_per_unit()) + " counts/unit, " +
                               core::FormatNumber(drives_[i].counts_per_unit()) +
                               " now): the calibration would not hold; restart the bridge with it");
    }
  }
  model_ = model;
  settings_ = settings;
  drives_ = std::move(drives);
  if (gains_set_) return;
  gains_ = servo::ChipGainsFromModel(model_);
  if (connected_) {
    for (int j = 0; j < n; ++j) SendGains(j);
  }
}

std::string ArmLink::CalibrationNeeds() const {
  return "Needed: the arm shown to be in the calibration pose '" + settings_.calibration_pose +
         "': switch the boards off and on with the arm in that pose (their counters then start "
         "there), or give the joints a homing method (index, limit1 or limit2) in the settings' "
         "calibration.homing; then calibrate";
}

void ArmLink::SetCalibratedCounts(int j, int32_t counts) {
  const uint8_t a = Address(j);
  bus_.Command(nmc::SetPosition(a, kCalibrationMarker));
  bus_.Command(nmc::SaveAsHome(a));  // the marker stays in the home register
  bus_.Command(nmc::SetPosition(a, counts));
}

void ArmLink::Calibrate() {
  if (!connected_) throw std::runtime_error("calibrate: not connected");
  if (armed_) throw std::runtime_error("calibrate: disarm first (servos must be off)");
  const core::NamedPose* pose = model_.FindNamedPose(settings_.calibration_pose);
  if (!pose) {
    throw std::runtime_error("calibrate: the model has no pose '" + settings_.calibration_pose +
                             "'");
  }
  const int n = num_joints();
  bool by_pose = false;
  for (const JointHoming& h : settings_.homing) by_pose |= h.method == HomingMethod::kNone;
  if (by_pose && !blind_reason_.empty()) {
    throw CalibrationRefused("calibrate: refused: " + blind_reason_ + ". " + CalibrationNeeds());
  }
  if (by_pose && calibrated_) {
    // Calibrated already: the counters say where the arm is. Redefining it as the pose is only
    // a correction when it is there.
    for (int j = 0; j < n; ++j) {
      const auto i = static_cast<size_t>(j);
      if (settings_.homing[i].method != HomingMethod::kNone) continue;
      const double q = drives_[i].FromCounts(bus_.Command(nmc::Nop(Address(j))).position);
      const double want = pose->position[i];
      const core::Joint& joint = model_.joints[i];
      if (std::abs(q - want) > kPoseToleranceDeg * M_PI / 180) {
        throw CalibrationRefused(
            "calibrate: refused: the arm is calibrated, and its counters put " +
            JointName(model_, j) + " at " + ShownTenth(joint, q) + ", " +
            ShownTenth(joint, std::abs(q - want)) + " from the calibration pose '" +
            settings_.calibration_pose + "' (" + Shown(joint, want) +
            "); calibrating would define it as the pose. Move the arm to "
            "the pose first (within " +
            core::FormatNumber(kPoseToleranceDeg) +
            " deg of every joint), or keep the calibration");
      }
    }
  }
  calibrated_ = false;
  for (int j = 0; j < n; ++j) {
    const JointHoming& h = settings_.homing[static_cast<size_t>(j)];
    if (h.method == HomingMethod::kNone) {
      const double q = pose->position[static_cast<size_t>(j)];
      SetCalibratedCounts(j, ClampCounts(drives_[static_cast<size_t>(j)].ToCounts(q)));
      goals_[static_cast<size_t>(j)] = q;
    } else {
      Home(j, h);
    }
  }
  have_last_poll_ = false;
  calibrated_ = true;
  fresh_and_undriven_ = false;
}

void ArmLink::Home(int j, const JointHoming& h) {
  fresh_and_undriven_ = false;  // the search drives the joint
  const uint8_t a = Address(j);
  const auto& drive = drives_[static_cast<size_t>(j)];
  uint8_t condition = nmc::kHomeOnIndex;
  if (h.method == HomingMethod::kLimit1) condition = nmc::kHomeOnLimit1;
  if (h.method == HomingMethod::kLimit2) condition = nmc::kHomeOnLimit2;
  bus_.Command(nmc::StopMotor(a, nmc::kAmpEnable | nmc::kStopAbrupt));  // servo on, holding
  bus_.Command(nmc::ClearBits(a));
  bus_.Command(nmc::SetHoming(a, condition | nmc::kHomeStopSmooth));
  // Motor counts run the other way when the gear ratio is negative.
  const double motor_speed = h.speed * (drive.counts_per_unit() < 0 ? -1 : 1);
  nmc::Trajectory t;
  t.control = nmc::kLoadVelocity | nmc::kLoadAcceleration | nmc::kEnableServo | nmc::kVelocityMode |
              nmc::kStartNow;
  if (motor_speed < 0) t.control |= nmc::kReverse;
  t.velocity = static_cast<uint32_t>(drive.VelocityWord(std::abs(h.speed)));
  t.acceleration = static_cast<uint32_t>(drive.AccelerationWord(
      std::max(model_.joints[static_cast<size_t>(j)].servo.default_acceleration, 0.1)));
  bus_.Command(nmc::LoadTrajectory(a, t));
  const auto deadline = Clock::now() + std::chrono::milliseconds(
                                           static_cast<int64_t>(settings_.homing_timeout_s * 1000));
  for (;;) {
    const nmc::Status s = bus_.Command(nmc::Nop(a));
    if (!(s.status & nmc::kStatusHomeInProgress) && (s.status & nmc::kStatusMoveDone)) break;
    if (Clock::now() > deadline) {
      bus_.Command(nmc::StopMotor(a, nmc::kMotorOff));
      throw std::runtime_error("calibrate: " + JointName(model_, j) + ": no " +
                               HomingMethodName(h.method) + " change within " +
                               core::FormatNumber(settings_.homing_timeout_s) + " s of homing");
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  const nmc::Status home = bus_.Command(nmc::ReadStatus(a, nmc::kSendHome | nmc::kSendPosition));
  // Where the joint is now, given that the home position is at home_angle.
  const int64_t now_counts =
      static_cast<int64_t>(home.position) - home.home + drive.ToCounts(h.home_angle);
  bus_.Command(nmc::StopMotor(a, nmc::kMotorOff));  // amplifier off again
  SetCalibratedCounts(j, ClampCounts(now_counts));
  bus_.Command(nmc::ClearBits(a));
  goals_[static_cast<size_t>(j)] = drive.FromCounts(now_counts);
}

void ArmLink::Arm() {
  if (!calibrated_) throw std::runtime_error("arm: calibrate first");
  fresh_and_undriven_ = false;
  for (int j = 0; j < num_joints(); ++j) {
    // Servo on first: POS_ERR is set for as long as the servo is off, so it is cleared after.
    const nmc::Status s =
        bus_.Command(nmc::StopMotor(Address(j), nmc::kAmpEnable | nmc::kStopAbrupt));
    bus_.Command(nmc::ClearBits(Address(j)));
    goals_[static_cast<size_t>(j)] = drives_[static_cast<size_t>(j)].FromCounts(s.position);
    velocity_mode_[static_cast<size_t>(j)] = false;
  }
  armed_ = true;
}

void ArmLink::Disarm() {
  if (!connected_) return;
  StopAllSmoothly();
  const auto deadline = Clock::now() + std::chrono::seconds(5);
  for (int j = 0; j < num_joints(); ++j) {
    while (Clock::now() < deadline) {
      const nmc::Status s = bus_.Command(nmc::Nop(Address(j)));
      if (s.status & nmc::kStatusMoveDone) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    bus_.Command(nmc::StopMotor(Address(j), nmc::kMotorOff));  // servo and amplifier off
  }
  armed_ = false;
}

std::string ArmLink::CheckMove(const core::ServoMove& move) const {
  const int n = num_joints();
  if (move.joints.size() != static_cast<size_t>(n)) {
    return "num_joints: " + std::to_string(move.joints.size()) + " is not allowed; expected " +
           std::to_string(n) + " (the arm's joints)";
  }
  if (!connected_ || !calibrated_ || !armed_) {
    return std::string("the arm is not ") + (!connected_    ? "connected"
                                             : !calibrated_ ? "calibrated"
                                                            : "armed");
  }
  if (move.command != core::MoveCommand::kMove) return "";
  // One rule with the controller: core::CheckJointMove (soft limits, speed and acceleration caps).
  for (int j = 0; j < n; ++j) {
    const core::JointMove& joint = move.joints[static_cast<size_t>(j)];
    if (!(joint.flags & servo_move_t::FLAG_ACTIVE)) continue;
    const std::optional<std::string> refusal =
        core::CheckJointMove(model_, settings_.motion_limits, j, Goal(j, joint), joint.max_velocity,
                             joint.acceleration, joint.flags & servo_move_t::FLAG_VELOCITY_MODE);
    if (refusal) return *refusal;
  }
  return "";
}

double ArmLink::Goal(int j, const core::JointMove& move) const {
  return (move.flags & servo_move_t::FLAG_RELATIVE) ? goals_[static_cast<size_t>(j)] + move.goal
                                                    : move.goal;
}

nmc::Trajectory ArmLink::TrajectoryFor(int j, double goal, double velocity, double acceleration,
                                       bool velocity_mode) const {
  const auto& drive = drives_[static_cast<size_t>(j)];
  nmc::Trajectory t;
  t.control = nmc::kLoadVelocity | nmc::kLoadAcceleration | nmc::kEnableServo;
  t.velocity = static_cast<uint32_t>(
      std::min<int64_t>(drive.VelocityWord(std::abs(velocity)), nmc::kMaxVelocityWord));
  t.acceleration = static_cast<uint32_t>(
      std::min<int64_t>(drive.AccelerationWord(acceleration), nmc::kMaxAccelerationWord));
  if (velocity_mode) {
    t.control |= nmc::kVelocityMode;
    const bool motor_negative = (velocity < 0) != (drive.counts_per_unit() < 0);
    if (motor_negative) t.control |= nmc::kReverse;
  } else {
    t.control |= nmc::kLoadPosition;
    t.position = ClampCounts(drive.ToCounts(goal));
  }
  return t;
}

void ArmLink::Execute(const core::ServoMove& move) {
  const int n = num_joints();
  uint8_t stop = 0;
  switch (move.command) {
    case core::MoveCommand::kMove: {
      bool any = false;
      for (int j = 0; j < n; ++j) {
        const auto i = static_cast<size_t>(j);
        const core::JointMove& joint = move.joints[i];
        if (!(joint.flags & servo_move_t::FLAG_ACTIVE)) continue;
        const bool vel = joint.flags & servo_move_t::FLAG_VELOCITY_MODE;
        const double goal = Goal(j, joint);
        bus_.Command(nmc::LoadTrajectory(
            Address(j), TrajectoryFor(j, goal, joint.max_velocity, joint.acceleration, vel)));
        if (!vel) goals_[i] = goal;
        velocity_mode_[i] = vel;
        any = true;
      }
      if (any) bus_.GroupCommand(nmc::StartMove(0));  // every loaded joint starts on this packet
      return;
    }
    case core::MoveCommand::kStopSmooth:
      stop = nmc::kAmpEnable | nmc::kStopSmooth;
      break;
    case core::MoveCommand::kMotorOff:
      stop = nmc::kAmpEnable | (settings_.pass_motor_off ? nmc::kMotorOff : nmc::kStopAbrupt);
      break;
    case core::MoveCommand::kStopAbrupt:
    case core::MoveCommand::kServoOn:  // hold the present position
      stop = nmc::kAmpEnable | nmc::kStopAbrupt;
      break;
  }
  for (int j = 0; j < n; ++j) {
    const auto i = static_cast<size_t>(j);
    if (!(move.joints[i].flags & servo_move_t::FLAG_ACTIVE)) continue;
    const nmc::Status s = bus_.Command(nmc::StopMotor(Address(j), stop));
    velocity_mode_[i] = false;
    if (stop & nmc::kStopAbrupt) goals_[i] = drives_[i].FromCounts(s.position);
  }
}

std::string ArmLink::MoveAllTo(const std::vector<double>& goal) {
  core::ServoMove move;
  move.command = core::MoveCommand::kMove;
  for (size_t j = 0; j < static_cast<size_t>(num_joints()); ++j) {
    const core::ServoParams& p = model_.joints[j].servo;
    move.joints.push_back(
        {goal[j], p.default_velocity, p.default_acceleration, servo_move_t::FLAG_ACTIVE});
  }
  std::string refusal = CheckMove(move);
  if (refusal.empty()) Execute(move);
  return refusal;
}

ArmReading ArmLink::Poll() {
  const int n = num_joints();
  ArmReading r;
  r.answered.assign(static_cast<size_t>(n), false);
  r.errors.assign(static_cast<size_t>(n), "");
  r.status.assign(static_cast<size_t>(n), 0);
  r.aux.assign(static_cast<size_t>(n), 0);
  r.counts.assign(static_cast<size_t>(n), 0);
  r.position_error.assign(static_cast<size_t>(n), 0);
  r.position.assign(static_cast<size_t>(n), 0.0);
  r.velocity.assign(static_cast<size_t>(n), 0.0);
  r.setpoint.assign(static_cast<size_t>(n), 0.0);
  r.effort.assign(static_cast<size_t>(n), 0.0);
  const auto now = Clock::now();
  const int64_t started_us = WallMicros();
  const double dt = have_last_poll_ ? std::chrono::duration<double>(now - last_poll_).count() : 0;
  for (int j = 0; j < n; ++j) {
    const auto i = static_cast<size_t>(j);
    nmc::Status s;
    try {
      s = bus_.Command(nmc::Nop(Address(j)));
    } catch (const BusError& e) {
      r.errors[i] = e.what();
      continue;
    }
    const auto& drive = drives_[i];
    r.answered[i] = true;
    r.status[i] = s.status;
    r.aux[i] = s.aux;
    r.counts[i] = s.position;
    r.position_error[i] = s.position_error;
    r.position[i] = drive.FromCounts(s.position);
    r.setpoint[i] = drive.FromCounts(static_cast<int64_t>(s.position) + s.position_error);
    if (dt > 0)
      r.velocity[i] = (drive.FromCounts(s.position) - drive.FromCounts(last_counts_[i])) / dt;
    if (s.aux & nmc::kAuxServoOn) {
      const servo::ChipGains& g = gains_[i];  // the law the module runs
      const double u = g.kp * s.position_error / double(1 << servo::kOutputShift);
      const int pwm =
          static_cast<int>(std::clamp<long>(std::lround(u), -g.output_limit, g.output_limit));
      r.effort[i] = drive.EffortFromPwm(pwm);
    }
    last_counts_[i] = s.position;
  }
  last_poll_ = now;
  have_last_poll_ = true;
  // The modules answer one after another (about 0.7 ms each at 230400 baud): the middle of the
  // poll is the best single time for all six readings, off by at most half a poll for any joint.
  r.wall_us = started_us + (WallMicros() - started_us) / 2;
  return r;
}

void ArmLink::StopAllSmoothly() {
  bus_.Broadcast(nmc::StopMotor(nmc::kBroadcast, nmc::kAmpEnable | nmc::kStopSmooth));
  std::fill(velocity_mode_.begin(), velocity_mode_.end(), false);
}

void ArmLink::EmergencyStop() {
  bus_.Broadcast(nmc::StopMotor(nmc::kBroadcast, nmc::kAmpEnable | nmc::kStopAbrupt));
  bus_.Broadcast(nmc::StopMotor(nmc::kBroadcast, nmc::kMotorOff));  // amplifiers disabled
  std::fill(velocity_mode_.begin(), velocity_mode_.end(), false);
  armed_ = false;
}

void ArmLink::ClearFaults() {
  for (int j = 0; j < num_joints(); ++j) {
    try {
      bus_.Command(nmc::ClearBits(Address(j)));
    } catch (const BusError&) {
      // reported by the next poll
    }
  }
}

void ArmLink::Shutdown() {
  if (!connected_) return;
  try {
    bus_.Broadcast(nmc::StopMotor(nmc::kBroadcast, nmc::kAmpEnable | nmc::kStopAbrupt));
    bus_.Broadcast(nmc::StopMotor(nmc::kBroadcast, nmc::kMotorOff));
    bus_.HardReset();
  } catch (const std::exception&) {
    // the port itself failed: nothing more can be sent
  }
  connected_ = calibrated_ = armed_ = false;
  std::fill(board_gains_.begin(), board_gains_.end(), std::nullopt);
}

}  // namespace sirupp::hardware
