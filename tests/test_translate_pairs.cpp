// Tests of core/translate.hpp as a whole: every type in lcmtypes/ has a To/From pair, each pair
// survives the wire (ToMessage, encode, decode, FromMessage, ToMessage gives the same bytes), and
// each check of a FromMessage gives its one error text naming the channel and the field. Run from
// the source root (as CTest does): the type list is read from lcmtypes/*.lcm.

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <functional>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include "core/environment.hpp"
#include "core/errors.hpp"
#include "core/model_loader.hpp"
#include "core/translate.hpp"
#include "tests/helpers.hpp"

namespace sirupp::core {
namespace {

using sirupp::testing::ErrorText;
using sirupp::testing::ThroughTheWire;

const double kNan = std::numeric_limits<double>::quiet_NaN();

template <class Msg>
std::vector<uint8_t> Bytes(const Msg& message) {
  std::vector<uint8_t> buffer(static_cast<size_t>(message.getEncodedSize()));
  EXPECT_EQ(message.encode(buffer.data(), 0, static_cast<int>(buffer.size())),
            static_cast<int>(buffer.size()));
  return buffer;
}

// To, encode, decode, From, To again: the second message must encode to the same bytes as the
// first (every field of the value travels), and From must accept what To built.
template <class Value, class From>
void ExpectRoundTrip(const Value& value, From from) {
  const auto message = ToMessage(value);
  const auto decoded = ThroughTheWire(message);
  const Value back = from(decoded);
  EXPECT_EQ(Bytes(ToMessage(back)), Bytes(message));
}

// ---- sample values, none of them all defaults

ServoSetpoint SampleSetpoint() {
  ServoSetpoint s;
  s.utime = 11;
  s.seq = 12;
  s.tick = 13;
  s.move_id = 14;
  s.joints = {{0.1, 0.2, 0.3, 0.004, 1.5, 3}, {-1, -0.5, -2, -0.001, -0.25, 64}};
  return s;
}

ServoMove SampleMove() {
  ServoMove m;
  m.utime = 1;
  m.seq = 2;
  m.move_id = 3;
  m.command = MoveCommand::kStopSmooth;
  m.joints = {{0.5, 1, 2, 1}, {-0.25, 0, 0, 0}, {1e-3, 0.5, 3, 7}};
  return m;
}

ServoGainsSet SampleGains() {
  ServoGainsSet g;
  g.utime = 5;
  g.seq = 6;
  g.joints = {{100, 1000, 0, 0, 255, 0, 4000, 1, 0}, {200, 2000, 5, 100, 200, 100, 1000, 1, 2}};
  return g;
}

JointTarget SampleTarget() {
  JointTarget t;
  t.utime = 7;
  t.seq = 8;
  t.joints = {{0.5, 1, 2, true}, {-0.3, 0, 0, false}};
  return t;
}

PoseTarget SamplePose() {
  PoseTarget p;
  p.utime = 9;
  p.seq = 10;
  p.position = Eigen::Vector3d(0.3, -0.1, 0.4);
  p.orientation = Eigen::Quaterniond(0.5, 0.5, -0.5, 0.5);
  p.shoulder = ArmChoice::kFirst;
  p.elbow = ArmChoice::kSecond;
  p.wrist = ArmChoice::kAny;
  p.speed_scale = 0.5;
  return p;
}

SimStatus SampleSimStatus() {
  SimStatus s;
  s.utime = 1;
  s.seq = 2;
  s.run_id = 3;
  s.mode = TimingMode::kRealtime;
  s.tick = 4;
  s.sim_time_s = 0.5;
  s.realtime_factor = 1.01;
  s.realtime_factor_run = 0.99;
  s.slipped_s = 0.002;
  s.estop = true;
  s.estop_reason = "test";
  s.participants = {{"ctl", ParticipantState::kAnswering, 0.1, 0.5},
                    {"other", ParticipantState::kSilent, 0, 0}};
  s.refused = {{"x", 3, "bad tick"}};
  s.refused_others = 1;
  s.detail = "fine";
  return s;
}

HardwareStatus SampleHardwareStatus() {
  HardwareStatus h;
  h.utime = 1;
  h.seq = 2;
  h.state = BridgeState::kLinked;
  h.calibrated = true;
  h.port = "/dev/ttyUSB0";
  h.baud = 19200;
  h.modules = {{1, 2, 300, -4}, {5, 6, -700, 8}};
  h.checksum_errors = 1;
  h.timeouts = 2;
  h.resyncs = 3;
  h.last_error = "none";
  return h;
}

HeartbeatReport SampleHeartbeat() {
  HeartbeatReport h;
  h.utime = 1;
  h.seq = 2;
  h.process = "sirupp-sim";
  h.host = "lab1";
  h.pid = 1234;
  h.state = ProcessState::kDegraded;
  h.detail = "slow";
  h.uptime_s = 12.5;
  ChannelTraffic t;
  t.stats.channel = "SIM_ARM_STATE";
  t.stats.publishing = true;
  t.stats.messages = 100;
  t.stats.decode_errors = 1;
  t.stats.rejected = 2;
  t.stats.late = 3;
  t.stats.gaps = 4;
  t.rate_hz = 1953.125;
  h.channels = {t, t};
  h.channels[1].stats.publishing = false;
  return h;
}

Image SampleImage() {
  Image i;
  i.utime = 3;
  i.width = 2;
  i.height = 1;
  i.row_stride = 6;
  i.pixelformat = sirupp::image_t::PIXEL_FORMAT_RGB;
  i.data = {1, 2, 3, 4, 5, 6};
  i.metadata = {{"camera", {'a', 'b'}}, {"empty", {}}};
  return i;
}

// ---- the registry: one round trip per lcmtypes type, keyed by the type's name

using RoundTrips = std::map<std::string, std::function<void()>>;

template <class Msg>
void Add(RoundTrips& trips, std::function<void()> trip) {
  trips[Msg::getTypeName()] = std::move(trip);
}

RoundTrips AllRoundTrips() {
  const std::string ch = "TEST";
  RoundTrips trips;
  Add<sirupp::robot_model_t>(trips, [ch] {
    const RobotModel model = LoadRobotModel("config/robots/puma260.yaml");
    const sirupp::robot_model_t message = ToMessage(model, 1, 2);
    const RobotModel back = RobotModelFromMessage(ThroughTheWire(message), ch);
    EXPECT_EQ(Bytes(ToMessage(back, 1, 2)), Bytes(message));
  });
  Add<sirupp::joint_model_t>(trips, [ch] {
    const RobotModel model = LoadRobotModel("config/robots/stanford.yaml");
    for (const Joint& joint : model.joints) {
      ExpectRoundTrip(joint, [&](const auto& m) { return JointFromMessage(m, ch, "joint"); });
    }
  });
  Add<sirupp::link_model_t>(trips, [ch] {
    const RobotModel model = LoadRobotModel("config/robots/puma260.yaml");
    for (const Link& link : model.links) {
      ExpectRoundTrip(link, [&](const auto& m) { return LinkFromMessage(m, ch, "link"); });
    }
  });
  Add<sirupp::named_pose_t>(trips, [ch] {
    ExpectRoundTrip(NamedPose{"ready", {0.1, -0.2, 3}},
                    [&](const auto& m) { return NamedPoseFromMessage(m, ch, "pose"); });
  });
  Add<sirupp::shape_t>(trips, [ch] {
    Shape shape;
    shape.type = ShapeType::kCapsule;
    shape.pose.position_m = Eigen::Vector3d(1, 2, 3);
    shape.size_m = Eigen::Vector3d(0.1, 0.5, 0);
    shape.rgba = {{0.25F, 0.5F, 0.75F, 1.0F}};
    ExpectRoundTrip(shape, [&](const auto& m) { return ShapeFromMessage(m, ch, "shape"); });
  });
  Add<sirupp::environment_t>(trips, [ch] {
    const Environment environment = LoadEnvironment("config/environments/table.xml");
    ASSERT_FALSE(environment.objects.empty());
    const sirupp::environment_t message = ToMessage(environment, 3, 4);
    const Environment back = EnvironmentFromMessage(ThroughTheWire(message), ch);
    EXPECT_EQ(Bytes(ToMessage(back, 3, 4)), Bytes(message));
  });
  Add<sirupp::environment_object_t>(trips, [ch] {
    const Environment environment = LoadEnvironment("config/environments/table.xml");
    for (const EnvironmentObject& object : environment.objects) {
      ExpectRoundTrip(object,
                      [&](const auto& m) { return EnvironmentObjectFromMessage(m, ch, "o"); });
    }
  });
  Add<sirupp::arm_state_t>(trips, [ch] {
    ArmState state;
    state.utime = 5;
    state.tick = 6;
    state.source = StateSource::kEmulated;
    state.position = {0.1, 0.2};
    state.velocity = {-1, 1};
    state.effort = {3, 4};
    state.flags = {1, 16};
    const sirupp::arm_state_t message = ToMessage(state, 9);
    const ArmState back = ArmStateFromMessage(ThroughTheWire(message), ch, 2);
    EXPECT_EQ(Bytes(ToMessage(back, 9)), Bytes(message));
  });
  Add<sirupp::arm_command_t>(trips, [ch] {
    ArmCommand command;
    command.utime = 5;
    command.tick = 6;
    command.sender = "me";
    command.mode = CommandMode::kHold;
    command.effort = {0.5, -0.5, 1};
    const sirupp::arm_command_t message = ToMessage(command, 3);
    const ArmCommand back = ArmCommandFromMessage(ThroughTheWire(message), ch, 3);
    EXPECT_EQ(Bytes(ToMessage(back, 3)), Bytes(message));
  });
  Add<sirupp::servo_setpoint_t>(trips, [ch] {
    ExpectRoundTrip(SampleSetpoint(),
                    [&](const auto& m) { return ServoSetpointFromMessage(m, ch); });
  });
  Add<sirupp::board_status_t>(trips, [ch] {
    BoardStatus status;
    status.utime = 5;
    status.seq = 7;
    status.tick = 32;
    status.next_tick = 48;
    status.command_seq = 3;
    status.arm.utime = 5;
    status.arm.tick = 32;
    status.arm.position = {0.1, 0.2};
    status.arm.velocity = {-1, 1};
    status.arm.effort = {0.5, 0};
    status.arm.flags = {0, 8};
    status.boards = SampleSetpoint();
    status.boards.joints.resize(2);
    const sirupp::board_status_t message = ToMessage(status);
    const BoardStatus back = BoardStatusFromMessage(ThroughTheWire(message), ch, 2);
    EXPECT_EQ(Bytes(ToMessage(back)), Bytes(message));
  });
  Add<sirupp::arm_ticks_t>(trips, [ch] {
    ArmTicks ticks;
    ticks.sent_utime = 900;
    ticks.seq = 4;
    for (int64_t k = 0; k < 3; ++k) {
      TickedState state;
      state.state.utime = 512 * k;
      state.state.tick = 16 + k;
      state.state.position = {0.1 * static_cast<double>(k), 0.2};
      state.state.velocity = {-1, 1};
      state.state.effort = {0.5, 0};
      state.state.flags = {0, 8};
      state.seq = 40 + k;
      state.made_utime = 800 + k;
      ticks.states.push_back(state);
      TickedSetpoint setpoint{SampleSetpoint(), 700 + k};
      setpoint.setpoint.joints.resize(2);
      ticks.setpoints.push_back(setpoint);
    }
    const sirupp::arm_ticks_t message = ToMessage(ticks);
    const ArmTicks back = ArmTicksFromMessage(ThroughTheWire(message), ch, 2);
    EXPECT_EQ(Bytes(ToMessage(back)), Bytes(message));
    sirupp::arm_ticks_t backwards = message;
    backwards.states[2].tick = 3;
    try {
      ArmTicksFromMessage(backwards, ch, 2);
      ADD_FAILURE() << "ticks out of order accepted";
    } catch (const MessageError& error) {
      EXPECT_NE(std::string(error.what()).find("states[2].tick"), std::string::npos)
          << error.what();
    }
    EXPECT_THROW(ArmTicksFromMessage(message, ch, 3), MessageError) << "3 joints expected";
  });
  Add<sirupp::servo_move_t>(trips, [ch] {
    ExpectRoundTrip(SampleMove(), [&](const auto& m) { return ServoMoveFromMessage(m, ch); });
  });
  Add<sirupp::servo_gains_t>(trips, [ch] {
    ExpectRoundTrip(SampleGains(), [&](const auto& m) { return ServoGainsFromMessage(m, ch); });
  });
  Add<sirupp::joint_target_t>(trips, [ch] {
    ExpectRoundTrip(SampleTarget(), [&](const auto& m) { return JointTargetFromMessage(m, ch); });
  });
  Add<sirupp::pose_target_t>(trips, [ch] {
    ExpectRoundTrip(SamplePose(), [&](const auto& m) { return PoseTargetFromMessage(m, ch); });
  });
  Add<sirupp::plan_command_t>(trips, [ch] {
    ExpectRoundTrip(PlanCommand{1, 2, PlanAction::kClearFault, "p", "move j1 10\n"},
                    [&](const auto& m) { return PlanCommandFromMessage(m, ch); });
  });
  Add<sirupp::hardware_command_t>(trips, [ch] {
    ExpectRoundTrip(HardwareCommand{1, 2, HardwareAction::kClearFaults, "cli"},
                    [&](const auto& m) { return HardwareCommandFromMessage(m, ch); });
  });
  Add<sirupp::hardware_status_t>(trips, [ch] {
    ExpectRoundTrip(SampleHardwareStatus(),
                    [&](const auto& m) { return HardwareStatusFromMessage(m, ch); });
  });
  Add<sirupp::estop_t>(trips, [ch] {
    ExpectRoundTrip(EStop{1, 2, true, "panel", "test"},
                    [&](const auto& m) { return EStopFromMessage(m, ch); });
  });
  Add<sirupp::sim_command_t>(trips, [ch] {
    ExpectRoundTrip(SimCommand{1, 2, "panel", SimAction::kLoadEnvironment, "cell.xml", "<x/>"},
                    [&](const auto& m) { return SimCommandFromMessage(m, ch); });
    ExpectRoundTrip(SimCommand{3, 4, "panel", SimAction::kLoadModel, "arm.yaml", "name: x"},
                    [&](const auto& m) { return SimCommandFromMessage(m, ch); });
  });
  Add<sirupp::logger_command_t>(trips, [ch] {
    ExpectRoundTrip(LoggerCommand{1, 2, "panel", LoggerAction::kStart, "run1"},
                    [&](const auto& m) { return LoggerCommandFromMessage(m, ch); });
    ExpectRoundTrip(LoggerCommand{1, 2, "panel", LoggerAction::kStop, ""},
                    [&](const auto& m) { return LoggerCommandFromMessage(m, ch); });
  });
  Add<sirupp::logger_pass_t>(trips, [ch] {
    ExpectRoundTrip(
        LoggerPass{1, 2, 3, true, 4, "demo", "udpm://239.255.76.67:7667?ttl=0", 1024, 30000, 60000,
                   false, true, true, "a note", "config/robots/puma260.yaml", "RIG1_"},
        [&](const auto& m) { return LoggerPassFromMessage(m, ch); });
    ExpectRoundTrip(LoggerPass{1, 2, 0, false, 4, "", "", 1, 0, 1, true, false, false, "", "", ""},
                    [&](const auto& m) { return LoggerPassFromMessage(m, ch); });
  });
  Add<sirupp::sim_reset_t>(trips, [ch] {
    ExpectRoundTrip(SimReset{1, 2, "cli", {0.1, 0.2}, {0, -1}, true},
                    [&](const auto& m) { return SimResetFromMessage(m, ch); });
    ExpectRoundTrip(SimReset{1, 2, "cli", {0.1, 0.2}, {}, false},
                    [&](const auto& m) { return SimResetFromMessage(m, ch); });
  });
  Add<sirupp::sim_status_t>(trips, [ch] {
    ExpectRoundTrip(SampleSimStatus(), [&](const auto& m) { return SimStatusFromMessage(m, ch); });
  });
  Add<sirupp::viewer_camera_t>(trips, [ch] {
    ViewerCamera camera;
    camera.utime = 1;
    camera.seq = 2;
    camera.set_camera = true;
    camera.azimuth = 0.5;
    camera.elevation = 0.25;
    camera.distance = 2;
    camera.target = Eigen::Vector3d(0, 0, 0.3);
    camera.show_frames = Switch::kOn;
    camera.show_ghost = Switch::kOff;
    camera.snapshot = true;
    ExpectRoundTrip(camera, [&](const auto& m) { return ViewerCameraFromMessage(m, ch); });
  });
  Add<sirupp::controller_status_t>(trips, [ch] {
    ExpectRoundTrip(ControllerStatus{1, 2, ControllerMode::kAutomatic, ControllerState::kPaused, 3,
                                     "plan", 1, 4, 7, "no"},
                    [&](const auto& m) { return ControllerStatusFromMessage(m, ch); });
  });
  Add<sirupp::command_reply_t>(trips, [ch] {
    ExpectRoundTrip(CommandReply{1, 2, "ctl", "ARM_TARGET", 3, 4, false, "why", 5, 6},
                    [&](const auto& m) { return CommandReplyFromMessage(m, ch); });
  });
  Add<sirupp::heartbeat_t>(trips, [ch] {
    ExpectRoundTrip(SampleHeartbeat(), [&](const auto& m) { return HeartbeatFromMessage(m, ch); });
  });
  Add<sirupp::channel_stats_t>(trips, [ch] {
    ExpectRoundTrip(SampleHeartbeat().channels[0],
                    [&](const auto& m) { return ChannelTrafficFromMessage(m, ch, "c"); });
  });
  Add<sirupp::image_t>(trips, [ch] {
    ExpectRoundTrip(SampleImage(), [&](const auto& m) { return ImageFromMessage(m, ch); });
  });
  Add<sirupp::image_metadata_t>(trips, [ch] {
    ExpectRoundTrip(SampleImage().metadata[0],
                    [&](const auto& m) { return ImageMetadataFromMessage(m, ch, "m"); });
  });
  return trips;
}

TEST(TranslatePairs, EveryLcmTypeHasARoundTrippedPair) {
  const RoundTrips trips = AllRoundTrips();
  int types = 0;
  for (const auto& entry : std::filesystem::directory_iterator("lcmtypes")) {
    if (entry.path().extension() != ".lcm") continue;
    ++types;
    const std::string type = entry.path().stem().string();
    EXPECT_EQ(trips.count(type), 1u)
        << "lcmtypes/" << type << ".lcm has no translate pair in core/translate.hpp (add one and "
        << "its round trip here)";
  }
  EXPECT_GE(types, 27) << "run from the source root";
  EXPECT_EQ(trips.size(), static_cast<size_t>(types)) << "a round trip for a type that is gone";
}

TEST(TranslatePairs, EachRoundTrip) {
  for (const auto& [type, trip] : AllRoundTrips()) {
    SCOPED_TRACE(type);
    trip();
  }
}

// ---- validation: each check gives its one error text

template <class Body>
std::string Error(Body body) {
  return ErrorText<MessageError>(body);
}

TEST(TranslatePairs, CountsMustMatchArrays) {
  sirupp::servo_setpoint_t s = ToMessage(SampleSetpoint());
  s.goal.pop_back();
  EXPECT_EQ(Error([&] { ServoSetpointFromMessage(s, "ARM_SETPOINT"); }),
            "channel ARM_SETPOINT: goal: 1 entries sent; num_joints says 2");
  s = ToMessage(SampleSetpoint());
  s.num_joints = -1;
  EXPECT_EQ(Error([&] { ServoSetpointFromMessage(s, "ARM_SETPOINT"); }),
            "channel ARM_SETPOINT: num_joints: -1 is not allowed; expected a count >= 0");

  sirupp::sim_status_t st = ToMessage(SampleSimStatus());
  st.refused_reason.clear();
  EXPECT_EQ(Error([&] { SimStatusFromMessage(st, "SIM_STATUS"); }),
            "channel SIM_STATUS: refused_reason: 0 entries sent; num_refused says 1");

  sirupp::hardware_status_t h = ToMessage(SampleHardwareStatus());
  h.position_error_counts.push_back(0);
  EXPECT_EQ(Error([&] { HardwareStatusFromMessage(h, "HARDWARE_STATUS"); }),
            "channel HARDWARE_STATUS: position_error_counts: 3 entries sent; num_joints says 2");

  sirupp::heartbeat_t hb = ToMessage(SampleHeartbeat());
  hb.num_channels = 3;
  EXPECT_EQ(Error([&] { HeartbeatFromMessage(hb, "HEARTBEAT"); }),
            "channel HEARTBEAT: channels: 2 entries sent; num_channels says 3");

  sirupp::image_t image = ToMessage(SampleImage());
  image.metadata[1].n = 4;
  EXPECT_EQ(Error([&] { ImageFromMessage(image, "VIEWER_IMAGE"); }),
            "channel VIEWER_IMAGE: metadata[1].value: 0 entries sent; metadata[1].n says 4");
  image = ToMessage(SampleImage());
  image.size = 5;
  EXPECT_EQ(Error([&] { ImageFromMessage(image, "VIEWER_IMAGE"); }),
            "channel VIEWER_IMAGE: data: 6 entries sent; size says 5");

  sirupp::sim_reset_t reset = ToMessage(SimReset{1, 2, "cli", {0.1, 0.2, 0.3}, {1}, false});
  EXPECT_EQ(Error([&] { SimResetFromMessage(reset, "SIM_RESET"); }),
            "channel SIM_RESET: num_velocities: 1 is not allowed; expected 0 or num_joints (3)");

  sirupp::servo_gains_t g = ToMessage(SampleGains());
  g.deadband.pop_back();
  EXPECT_EQ(Error([&] { ServoGainsFromMessage(g, "ARM_GAINS"); }),
            "channel ARM_GAINS: deadband: 1 entries sent; num_joints says 2");
  sirupp::joint_target_t t = ToMessage(SampleTarget());
  t.active.pop_back();
  EXPECT_EQ(Error([&] { JointTargetFromMessage(t, "ARM_TARGET"); }),
            "channel ARM_TARGET: active: 1 entries sent; num_joints says 2");
  sirupp::servo_move_t mv = ToMessage(SampleMove());
  mv.flags.clear();
  EXPECT_EQ(Error([&] { ServoMoveFromMessage(mv, "ARM_MOVE"); }),
            "channel ARM_MOVE: flags: 0 entries sent; num_joints says 3");
}

TEST(TranslatePairs, NumbersMustBeFiniteAndInRange) {
  sirupp::servo_setpoint_t s = ToMessage(SampleSetpoint());
  s.effort[1] = kNan;
  EXPECT_EQ(Error([&] { ServoSetpointFromMessage(s, "REAL_ARM_SETPOINT"); }),
            "channel REAL_ARM_SETPOINT: effort[1]: nan is not allowed; expected a finite number");
  sirupp::servo_move_t mv = ToMessage(SampleMove());
  mv.max_velocity[2] = -1;
  EXPECT_EQ(Error([&] { ServoMoveFromMessage(mv, "ARM_MOVE"); }),
            "channel ARM_MOVE: max_velocity[2]: -1 is not allowed; expected a finite number >= 0");
  sirupp::servo_gains_t g = ToMessage(SampleGains());
  g.kd[0] = std::numeric_limits<double>::infinity();
  EXPECT_EQ(Error([&] { ServoGainsFromMessage(g, "ARM_GAINS"); }),
            "channel ARM_GAINS: kd[0]: inf is not allowed; expected a finite number");
  sirupp::joint_target_t t = ToMessage(SampleTarget());
  t.acceleration[0] = -2;
  EXPECT_EQ(Error([&] { JointTargetFromMessage(t, "ARM_TARGET"); }),
            "channel ARM_TARGET: acceleration[0]: -2 is not allowed; expected a finite number "
            ">= 0");
  sirupp::pose_target_t p = ToMessage(SamplePose());
  p.position[1] = kNan;
  EXPECT_EQ(Error([&] { PoseTargetFromMessage(p, "ARM_POSE_TARGET"); }),
            "channel ARM_POSE_TARGET: position[1]: nan is not allowed; expected a finite number");
  p = ToMessage(SamplePose());
  p.orientation[0] = 2;
  p.orientation[1] = p.orientation[2] = p.orientation[3] = 0;
  EXPECT_EQ(Error([&] { PoseTargetFromMessage(p, "ARM_POSE_TARGET"); }),
            "channel ARM_POSE_TARGET: orientation: quaternion norm 2 is not allowed; "
            "expected a unit quaternion (w, x, y, z), norm 1 +- 0.001");
  p.position_only = 1;
  EXPECT_NO_THROW(PoseTargetFromMessage(p, "ARM_POSE_TARGET"));
  p = ToMessage(SamplePose());
  p.speed_scale = 1.5;
  EXPECT_EQ(Error([&] { PoseTargetFromMessage(p, "ARM_POSE_TARGET"); }),
            "channel ARM_POSE_TARGET: speed_scale: 1.5 is not allowed; expected (0, 1], or 0 "
            "for 1");
  sirupp::viewer_camera_t c{};
  c.set_camera = 1;
  c.distance = 0;
  EXPECT_EQ(Error([&] { ViewerCameraFromMessage(c, "VIEWER_CAMERA"); }),
            "channel VIEWER_CAMERA: distance: 0 is not allowed; expected a finite number > 0 (m)");
  c.set_camera = 0;
  EXPECT_NO_THROW(ViewerCameraFromMessage(c, "VIEWER_CAMERA"));
  sirupp::sim_reset_t reset = ToMessage(SimReset{1, 2, "cli", {0.1, kNan}, {}, false});
  EXPECT_EQ(Error([&] { SimResetFromMessage(reset, "SIM_RESET"); }),
            "channel SIM_RESET: position[1]: nan is not allowed; expected a finite number");
  sirupp::sim_status_t st = ToMessage(SampleSimStatus());
  st.answer_max_ms[0] = -1;
  EXPECT_EQ(Error([&] { SimStatusFromMessage(st, "SIM_STATUS"); }),
            "channel SIM_STATUS: answer_max_ms[0]: -1 is not allowed; expected a finite number "
            ">= 0");
  sirupp::heartbeat_t hb = ToMessage(SampleHeartbeat());
  hb.channels[1].gaps = -3;
  EXPECT_EQ(Error([&] { HeartbeatFromMessage(hb, "HEARTBEAT"); }),
            "channel HEARTBEAT: channels[1].gaps: -3 is not allowed; expected a count >= 0");
  sirupp::hardware_status_t h = ToMessage(SampleHardwareStatus());
  h.timeouts = -1;
  EXPECT_EQ(Error([&] { HardwareStatusFromMessage(h, "HARDWARE_STATUS"); }),
            "channel HARDWARE_STATUS: timeouts: -1 is not allowed; expected a count >= 0");
  sirupp::image_t image = ToMessage(SampleImage());
  image.width = -2;
  EXPECT_EQ(Error([&] { ImageFromMessage(image, "VIEWER_IMAGE"); }),
            "channel VIEWER_IMAGE: width: -2 is not allowed; expected a count >= 0");
  sirupp::controller_status_t cs = ToMessage(ControllerStatus{});
  cs.plan_step = -2;
  EXPECT_EQ(Error([&] { ControllerStatusFromMessage(cs, "CONTROLLER_STATUS"); }),
            "channel CONTROLLER_STATUS: plan_step: -2 is not allowed; expected -1 (no plan) or "
            ">= 0");
}

TEST(TranslatePairs, EnumsFlagsAndBitsMustBeKnown) {
  sirupp::controller_status_t cs = ToMessage(ControllerStatus{});
  cs.mode = 2;
  EXPECT_EQ(Error([&] { ControllerStatusFromMessage(cs, "CONTROLLER_STATUS"); }),
            "channel CONTROLLER_STATUS: mode: 2 is not allowed; expected 0..1 (MODE_MANUAL, "
            "MODE_AUTOMATIC)");
  cs.mode = 0;
  cs.state = 6;
  EXPECT_EQ(Error([&] { ControllerStatusFromMessage(cs, "CONTROLLER_STATUS"); }),
            "channel CONTROLLER_STATUS: state: 6 is not allowed; expected 0..5 (STATE_*)");
  sirupp::servo_move_t mv = ToMessage(SampleMove());
  mv.command = 5;
  EXPECT_EQ(Error([&] { ServoMoveFromMessage(mv, "ARM_MOVE"); }),
            "channel ARM_MOVE: command: 5 is not allowed; expected 0..4 (COMMAND_*)");
  mv = ToMessage(SampleMove());
  mv.flags[1] = 8;
  EXPECT_EQ(Error([&] { ServoMoveFromMessage(mv, "ARM_MOVE"); }),
            "channel ARM_MOVE: flags[1]: 8 is not allowed; expected a sum of FLAG_* bits, 0..7");
  sirupp::servo_setpoint_t s = ToMessage(SampleSetpoint());
  s.status[0] = -1;
  EXPECT_EQ(Error([&] { ServoSetpointFromMessage(s, "ARM_SETPOINT"); }),
            "channel ARM_SETPOINT: status[0]: -1 is not allowed; expected a sum of STATUS_* bits, "
            "0..127");
  sirupp::joint_target_t t = ToMessage(SampleTarget());
  t.active[1] = 2;
  EXPECT_EQ(Error([&] { JointTargetFromMessage(t, "ARM_TARGET"); }),
            "channel ARM_TARGET: active[1]: 2 is not allowed; expected 0 or 1");
  sirupp::pose_target_t p = ToMessage(SamplePose());
  p.elbow = 3;
  EXPECT_EQ(Error([&] { PoseTargetFromMessage(p, "ARM_POSE_TARGET"); }),
            "channel ARM_POSE_TARGET: elbow: 3 is not allowed; expected 0..2 (ELBOW_ANY, "
            "ELBOW_UP, ELBOW_DOWN)");
  sirupp::plan_command_t plan = ToMessage(PlanCommand{});
  plan.command = 8;
  EXPECT_EQ(Error([&] { PlanCommandFromMessage(plan, "ARM_PLAN"); }),
            "channel ARM_PLAN: command: 8 is not allowed; expected 0..7 (COMMAND_*)");
  sirupp::hardware_command_t hc = ToMessage(HardwareCommand{});
  hc.command = -1;
  EXPECT_EQ(Error([&] { HardwareCommandFromMessage(hc, "HARDWARE_COMMAND"); }),
            "channel HARDWARE_COMMAND: command: -1 is not allowed; expected 0..7 (COMMAND_*)");
  sirupp::hardware_status_t h = ToMessage(SampleHardwareStatus());
  h.state = 7;
  EXPECT_EQ(Error([&] { HardwareStatusFromMessage(h, "HARDWARE_STATUS"); }),
            "channel HARDWARE_STATUS: state: 7 is not allowed; expected 0..6 (STATE_*)");
  sirupp::sim_command_t sc = ToMessage(SimCommand{});
  sc.command = 3;
  EXPECT_EQ(Error([&] { SimCommandFromMessage(sc, "SIM_COMMAND"); }),
            "channel SIM_COMMAND: command: 3 is not allowed; expected 0 (load environment) or 1 "
            "(load model)");
  sirupp::logger_command_t lc = ToMessage(LoggerCommand{});
  lc.command = 2;
  EXPECT_EQ(Error([&] { LoggerCommandFromMessage(lc, "LOGGER_COMMAND"); }),
            "channel LOGGER_COMMAND: command: 2 is not allowed; expected 0 (start) or 1 (stop)");
  sirupp::logger_pass_t lp = ToMessage(LoggerPass{});
  lp.taken = -1;
  EXPECT_EQ(Error([&] { LoggerPassFromMessage(lp, "LOGGER_PASS"); }),
            "channel LOGGER_PASS: taken: -1 is not allowed; expected 0 or more messages");
  lp.taken = 0;
  lp.last = 2;
  EXPECT_EQ(
      Error([&] { LoggerPassFromMessage(lp, "LOGGER_PASS"); }),
      "channel LOGGER_PASS: last: 2 is not allowed; expected 0 (more passes) or 1 (the last)");
  lp.last = 0;
  lp.period_us = 0;
  EXPECT_EQ(Error([&] { LoggerPassFromMessage(lp, "LOGGER_PASS"); }),
            "channel LOGGER_PASS: period_us: 0 is not allowed; expected 1 us or more");
  lp.period_us = 512;
  lp.velocities = 3;
  EXPECT_EQ(Error([&] { LoggerPassFromMessage(lp, "LOGGER_PASS"); }),
            "channel LOGGER_PASS: velocities: 3 is not allowed; expected 0 or 1");
  sirupp::estop_t e = ToMessage(EStop{});
  e.engaged = 3;
  EXPECT_EQ(Error([&] { EStopFromMessage(e, "ESTOP"); }),
            "channel ESTOP: engaged: 3 is not allowed; expected 0 (release) or 1 (engage)");
  sirupp::sim_status_t st = ToMessage(SampleSimStatus());
  st.participant_state[1] = 3;
  EXPECT_EQ(Error([&] { SimStatusFromMessage(st, "SIM_STATUS"); }),
            "channel SIM_STATUS: participant_state[1]: 3 is not allowed; expected 0..2 "
            "(PARTICIPANT_*)");
  sirupp::viewer_camera_t c = ToMessage(ViewerCamera{});
  c.show_ghost = 3;
  EXPECT_EQ(Error([&] { ViewerCameraFromMessage(c, "VIEWER_CAMERA"); }),
            "channel VIEWER_CAMERA: show_ghost: 3 is not allowed; expected 0..2 (SWITCH_KEEP, "
            "SWITCH_ON, SWITCH_OFF)");
  sirupp::heartbeat_t hb = ToMessage(SampleHeartbeat());
  hb.state = 5;
  EXPECT_EQ(Error([&] { HeartbeatFromMessage(hb, "HEARTBEAT"); }),
            "channel HEARTBEAT: state: 5 is not allowed; expected 0..4 (STATE_*)");
  sirupp::command_reply_t r = ToMessage(CommandReply{});
  r.result = 2;
  EXPECT_EQ(Error([&] { CommandReplyFromMessage(r, "CONTROLLER_REPLY"); }),
            "channel CONTROLLER_REPLY: result: 2 is not allowed; expected 0 (RESULT_ACCEPTED) or "
            "1 (RESULT_REFUSED)");
  r.result = sirupp::command_reply_t::RESULT_REFUSED;
  EXPECT_EQ(Error([&] { CommandReplyFromMessage(r, "CONTROLLER_REPLY"); }),
            "channel CONTROLLER_REPLY: error: an empty reason for a refusal is not allowed; "
            "expected the reason the command was refused");
  sirupp::joint_model_t j = ToMessage(LoadRobotModel("config/robots/puma260.yaml").joints[0]);
  j.type = 2;
  EXPECT_EQ(Error([&] { JointFromMessage(j, "ROBOT_MODEL", "joints[0]"); }),
            "channel ROBOT_MODEL: joints[0].type: 2 is not allowed; expected 0 or 1");
}

TEST(TranslatePairs, ToMessageFillsEveryCountFromItsArray) {
  const sirupp::servo_setpoint_t s = ToMessage(SampleSetpoint());
  EXPECT_EQ(s.num_joints, 2);
  EXPECT_EQ(s.status.size(), 2u);
  const sirupp::sim_status_t st = ToMessage(SampleSimStatus());
  EXPECT_EQ(st.num_participants, 2);
  EXPECT_EQ(st.num_refused, 1);
  const sirupp::image_t image = ToMessage(SampleImage());
  EXPECT_EQ(image.size, 6);
  EXPECT_EQ(image.nmetadata, 2);
  EXPECT_EQ(image.metadata[0].n, 2);
  const sirupp::heartbeat_t hb = ToMessage(SampleHeartbeat());
  EXPECT_EQ(hb.num_channels, 2);
  const sirupp::sim_reset_t reset = ToMessage(SimReset{0, 0, "", {1, 2}, {}, false});
  EXPECT_EQ(reset.num_joints, 2);
  EXPECT_EQ(reset.num_velocities, 0);
}

}  // namespace
}  // namespace sirupp::core
