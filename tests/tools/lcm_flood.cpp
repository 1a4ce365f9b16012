// lcm_flood: malformed LCM traffic for the fault tests (tests/cli/fault_flood.sh), and a reader of
// the traffic counters every process sends on HEARTBEAT.
//
//   lcm_flood flood [--lcm-url URL] [--prefix P] [--seconds S] [--rate HZ] [--joints N] [--seed N]
//     Sends, round robin over every channel of core's ChannelTable(), at RATE messages per second
//     in all (default 2000) for S seconds (default 3):
//       random   random bytes, 0 to 300 of them (almost never a valid fingerprint);
//       foreign  a well-formed message of another channel's type (wrong fingerprint);
//       badhash  a well-formed message of the channel's own type with its fingerprint altered;
//       cut      the channel's own type, right fingerprint, cut short (decode fails);
//       typed    the channel's own type, decodable, with a bad value: NaN or infinite numbers,
//                a joint count other than --joints (default 6), an enum out of range.
//     ESTOP gets no "typed" messages: every decodable estop_t is obeyed (engaged = stop), by
//     design. Nothing sent here is a valid command: the rig must refuse all of it.
//     Prints what it sent per channel and kind. Exit 0, 2 on bad arguments.
//
//   lcm_flood check --processes NAME,NAME.. [--lcm-url URL] [--prefix P] [--seconds S]
//     Listens to HEARTBEAT for S seconds (default 2.5; then up to 10 s more until every named
//     process was heard) and prints, per process and channel it receives, the counters of its
//     newest heartbeat. Exit 1 (with "FAIL" lines) unless every named process was heard and, on
//     every channel it receives, counted decode errors and, where the flood sends typed messages
//     (all but ESTOP), rejected messages. Exit 0 otherwise.
//     --newest-only NAME,NAME..: processes that read the per-tick channels newest-only
//     (core/tick_reader.hpp: the viewer, the panel; the older messages of a batch are never
//     decoded, so which bad ones they meet is chance): on those channels one decode error or one
//     rejected message is enough.

#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <limits>
#include <map>
#include <random>
#include <set>
#include <sirupp/arm_command_t.hpp>
#include <sirupp/arm_state_t.hpp>
#include <sirupp/controller_status_t.hpp>
#include <sirupp/environment_t.hpp>
#include <sirupp/estop_t.hpp>
#include <sirupp/hardware_command_t.hpp>
#include <sirupp/hardware_status_t.hpp>
#include <sirupp/heartbeat_t.hpp>
#include <sirupp/image_t.hpp>
#include <sirupp/joint_target_t.hpp>
#include <sirupp/plan_command_t.hpp>
#include <sirupp/pose_target_t.hpp>
#include <sirupp/robot_model_t.hpp>
#include <sirupp/servo_gains_t.hpp>
#include <sirupp/servo_move_t.hpp>
#include <sirupp/servo_setpoint_t.hpp>
#include <sirupp/sim_reset_t.hpp>
#if __has_include(<sirupp/viewer_camera_t.hpp>)
#include <sirupp/viewer_camera_t.hpp>  // the viewer's camera channel, new with issue 8
#endif
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "core/bus.hpp"
#include "core/channels.hpp"

namespace {

using Bytes = std::vector<uint8_t>;
using Clock = std::chrono::steady_clock;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();
const char* const kSender = "lcm_flood";

int64_t WallMicros() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

template <class Msg>
Bytes Encode(const Msg& message) {
  Bytes bytes(static_cast<size_t>(message.getEncodedSize()));
  if (message.encode(bytes.data(), 0, static_cast<int>(bytes.size())) < 0) {
    std::fprintf(stderr, "lcm_flood: cannot encode a %s\n", Msg::getTypeName());
    std::exit(1);
  }
  return bytes;
}

// A channel's type: one well-formed message (the body of "foreign", "badhash" and "cut") and the
// decodable messages with bad values ("typed").
struct TypeSamples {
  Bytes good;
  std::vector<Bytes> typed;
};

std::vector<double> Filled(int n, double value) {
  return std::vector<double>(static_cast<size_t>(n), value);
}

sirupp::arm_state_t ArmState(int n, int8_t source) {
  sirupp::arm_state_t m{};
  m.utime = source == sirupp::arm_state_t::SOURCE_SIM ? 0 : WallMicros();
  m.source = source;
  m.num_joints = n;
  m.position = Filled(n, 0);
  m.velocity = Filled(n, 0);
  m.effort = Filled(n, 0);
  m.flags.assign(static_cast<size_t>(n), 0);
  return m;
}

TypeSamples ArmStates(int n, int8_t source) {
  TypeSamples s;
  s.good = Encode(ArmState(n, source));
  auto nan = ArmState(n, source);
  nan.position[0] = kNaN;
  s.typed.push_back(Encode(nan));
  auto inf = ArmState(n, source);
  inf.velocity[static_cast<size_t>(n - 1)] = kInf;
  s.typed.push_back(Encode(inf));
  s.typed.push_back(Encode(ArmState(n + 1, source)));
  s.typed.push_back(Encode(ArmState(n - 1, source)));
  auto bad_source = ArmState(n, source);
  bad_source.source = 9;
  s.typed.push_back(Encode(bad_source));
  return s;
}

sirupp::arm_command_t ArmCommand(int n) {
  sirupp::arm_command_t m{};
  m.sender = kSender;
  m.mode = sirupp::arm_command_t::MODE_EFFORT;
  m.num_joints = n;
  m.effort = Filled(n, 0);
  return m;
}

TypeSamples ArmCommands(int n) {
  TypeSamples s;
  s.good = Encode(ArmCommand(n));
  auto nan = ArmCommand(n);
  nan.effort[1] = kNaN;
  s.typed.push_back(Encode(nan));
  s.typed.push_back(Encode(ArmCommand(n + 1)));
  auto bad_mode = ArmCommand(n);
  bad_mode.mode = 9;
  s.typed.push_back(Encode(bad_mode));
  return s;
}

sirupp::sim_reset_t SimReset(int n) {
  sirupp::sim_reset_t m{};
  m.sender = kSender;
  m.num_joints = n;
  m.position = Filled(n, 0);
  return m;
}

TypeSamples SimResets(int n) {
  TypeSamples s;
  s.good = Encode(SimReset(n));
  auto nan = SimReset(n);
  nan.position[2] = kNaN;
  s.typed.push_back(Encode(nan));
  s.typed.push_back(Encode(SimReset(n - 1)));
  return s;
}

sirupp::servo_move_t ServoMove(int n) {
  sirupp::servo_move_t m{};
  m.command = sirupp::servo_move_t::COMMAND_MOVE;
  m.move_id = 1000000;
  m.num_joints = n;
  m.goal = Filled(n, 0);
  m.max_velocity = Filled(n, 0.5);
  m.acceleration = Filled(n, 1.0);
  m.flags.assign(static_cast<size_t>(n), sirupp::servo_move_t::FLAG_ACTIVE);
  return m;
}

TypeSamples ServoMoves(int n) {
  TypeSamples s;
  s.good = Encode(ServoMove(n));
  auto nan = ServoMove(n);
  nan.goal[0] = kNaN;
  s.typed.push_back(Encode(nan));
  auto inf = ServoMove(n);
  inf.max_velocity[1] = kInf;
  s.typed.push_back(Encode(inf));
  s.typed.push_back(Encode(ServoMove(n + 1)));
  auto bad_command = ServoMove(n);
  bad_command.command = 9;
  s.typed.push_back(Encode(bad_command));
  return s;
}

sirupp::servo_setpoint_t Setpoint(int n) {
  sirupp::servo_setpoint_t m{};
  m.num_joints = n;
  m.position = Filled(n, 0);
  m.velocity = Filled(n, 0);
  m.goal = Filled(n, 0);
  m.position_error = Filled(n, 0);
  m.effort = Filled(n, 0);
  m.status.assign(static_cast<size_t>(n), sirupp::servo_setpoint_t::STATUS_MOVE_DONE);
  return m;
}

TypeSamples Setpoints(int n) {
  TypeSamples s;
  s.good = Encode(Setpoint(n));
  auto nan = Setpoint(n);
  nan.position[0] = kNaN;
  s.typed.push_back(Encode(nan));
  auto inf = Setpoint(n);
  inf.effort[1] = -kInf;
  s.typed.push_back(Encode(inf));
  s.typed.push_back(Encode(Setpoint(n + 2)));
  return s;
}

sirupp::servo_gains_t Gains(int n) {
  sirupp::servo_gains_t m{};
  m.num_joints = n;
  m.kp = Filled(n, 100);
  m.kd = Filled(n, 1000);
  m.ki = Filled(n, 0);
  m.integration_limit = Filled(n, 0);
  m.output_limit = Filled(n, 255);
  m.current_limit = Filled(n, 0);
  m.error_limit = Filled(n, 4000);
  m.servo_rate_divisor = Filled(n, 1);
  m.deadband = Filled(n, 0);
  return m;
}

TypeSamples GainsSamples(int n) {
  TypeSamples s;
  s.good = Encode(Gains(n));
  auto nan = Gains(n);
  nan.kp[0] = kNaN;
  s.typed.push_back(Encode(nan));
  s.typed.push_back(Encode(Gains(n + 1)));
  return s;
}

sirupp::joint_target_t Target(int n) {
  sirupp::joint_target_t m{};
  m.num_joints = n;
  m.position = Filled(n, 0);
  m.max_velocity = Filled(n, 0);
  m.acceleration = Filled(n, 0);
  m.active.assign(static_cast<size_t>(n), 1);
  return m;
}

TypeSamples Targets(int n) {
  TypeSamples s;
  s.good = Encode(Target(n));
  auto nan = Target(n);
  nan.position[0] = kNaN;
  s.typed.push_back(Encode(nan));
  auto inf = Target(n);
  inf.max_velocity[2] = kInf;
  s.typed.push_back(Encode(inf));
  s.typed.push_back(Encode(Target(n + 1)));
  return s;
}

sirupp::pose_target_t PoseTarget() {
  sirupp::pose_target_t m{};
  m.position[0] = 0.2;
  m.position[2] = 0.4;
  m.orientation[0] = 1;
  return m;
}

TypeSamples PoseTargets() {
  TypeSamples s;
  s.good = Encode(PoseTarget());
  auto nan = PoseTarget();
  nan.position[1] = kNaN;
  s.typed.push_back(Encode(nan));
  auto bad_quaternion = PoseTarget();
  bad_quaternion.orientation[0] = kNaN;
  s.typed.push_back(Encode(bad_quaternion));
  auto bad_elbow = PoseTarget();
  bad_elbow.elbow = 9;
  s.typed.push_back(Encode(bad_elbow));
  return s;
}

TypeSamples PlanCommands() {
  TypeSamples s;
  sirupp::plan_command_t m{};
  m.command = sirupp::plan_command_t::COMMAND_ABORT;
  m.name = "flood";
  s.good = Encode(m);
  m.command = 42;
  s.typed.push_back(Encode(m));
  m.command = sirupp::plan_command_t::COMMAND_RUN;
  m.text = "units deg\nmove j1=nan\n";
  s.typed.push_back(Encode(m));
  return s;
}

TypeSamples ControllerStatuses() {
  TypeSamples s;
  sirupp::controller_status_t m{};
  m.plan_step = -1;
  s.good = Encode(m);
  m.state = 99;
  s.typed.push_back(Encode(m));
  m.state = sirupp::controller_status_t::STATE_IDLE;
  m.mode = 7;
  s.typed.push_back(Encode(m));
  return s;
}

sirupp::hardware_status_t HardwareStatus(int n) {
  sirupp::hardware_status_t m{};
  m.num_joints = n;
  m.module_status.assign(static_cast<size_t>(n), 0);
  m.module_aux_status.assign(static_cast<size_t>(n), 0);
  m.position_counts.assign(static_cast<size_t>(n), 0);
  m.position_error_counts.assign(static_cast<size_t>(n), 0);
  return m;
}

TypeSamples HardwareStatuses(int n) {
  TypeSamples s;
  s.good = Encode(HardwareStatus(n));
  auto bad_state = HardwareStatus(n);
  bad_state.state = 99;
  s.typed.push_back(Encode(bad_state));
  s.typed.push_back(Encode(HardwareStatus(n + 1)));
  return s;
}

TypeSamples HardwareCommands() {
  TypeSamples s;
  sirupp::hardware_command_t m{};
  m.command = sirupp::hardware_command_t::COMMAND_UNLINK;
  m.sender = kSender;
  s.good = Encode(m);
  m.command = 99;
  s.typed.push_back(Encode(m));
  m.command = -1;
  s.typed.push_back(Encode(m));
  return s;
}

TypeSamples Estops() {
  TypeSamples s;
  sirupp::estop_t m{};
  m.engaged = 1;
  m.sender = kSender;
  m.reason = "flood";
  s.good = Encode(m);  // only ever sent with a bad fingerprint or cut short
  return s;
}

TypeSamples Heartbeats() {
  TypeSamples s;
  sirupp::heartbeat_t m{};
  m.process = kSender;
  m.host = "nowhere";
  s.good = Encode(m);
  m.uptime_s = kNaN;
  s.typed.push_back(Encode(m));
  m.uptime_s = 1;
  m.state = 99;
  s.typed.push_back(Encode(m));
  return s;
}

sirupp::robot_model_t RobotModel() {
  sirupp::robot_model_t m{};
  m.name = "flood";
  m.file_length_unit = "m";
  m.file_length_unit_m = 1;
  m.file_angle_unit = "rad";
  m.base_orientation[0] = 1;
  m.tool_orientation[0] = 1;
  m.gravity[2] = -9.81;
  m.servo_tick_s = 0.000512;
  return m;
}

TypeSamples RobotModels() {
  TypeSamples s;
  s.good = Encode(RobotModel());
  auto nan = RobotModel();
  nan.servo_tick_s = kNaN;
  s.typed.push_back(Encode(nan));
  s.typed.push_back(Encode(RobotModel()));  // no joints at all
  return s;
}

TypeSamples Environments() {
  TypeSamples s;
  sirupp::environment_t m{};
  m.name = "flood";
  s.good = Encode(m);
  sirupp::environment_object_t object{};
  object.name = "nan_box";
  object.shape.orientation[0] = 1;
  object.shape.size[0] = kNaN;
  object.mass = kNaN;
  m.num_objects = 1;
  m.objects.push_back(object);
  s.typed.push_back(Encode(m));
  return s;
}

TypeSamples Images() {
  TypeSamples s;
  sirupp::image_t m{};
  m.width = 2;
  m.height = 2;
  m.row_stride = 2;
  m.pixelformat = sirupp::image_t::PIXEL_FORMAT_GRAY;
  m.size = 4;
  m.data.assign(4, 128);
  s.good = Encode(m);
  m.width = -5;
  s.typed.push_back(Encode(m));
  m.width = 2;
  m.pixelformat = 12345;
  s.typed.push_back(Encode(m));
  return s;
}

#if __has_include(<sirupp/viewer_camera_t.hpp>)
TypeSamples ViewerCameras() {
  TypeSamples s;
  sirupp::viewer_camera_t m{};
  m.distance = 1.5;
  s.good = Encode(m);  // keeps the camera: only ever sent with a bad fingerprint or cut short
  m.set_camera = 1;
  m.azimuth = kNaN;
  s.typed.push_back(Encode(m));
  m.azimuth = 30;
  m.distance = -kInf;
  s.typed.push_back(Encode(m));
  m.distance = 1.5;
  m.set_camera = 7;
  s.typed.push_back(Encode(m));
  return s;
}
#endif

TypeSamples SamplesFor(const std::string& channel, const std::string& type, int n) {
  if (type == "sirupp.arm_state_t") {
    return ArmStates(n, channel == "SIM_ARM_STATE" ? sirupp::arm_state_t::SOURCE_SIM
                                                   : sirupp::arm_state_t::SOURCE_EMULATED);
  }
  if (type == "sirupp.arm_command_t") return ArmCommands(n);
  if (type == "sirupp.sim_reset_t") return SimResets(n);
  if (type == "sirupp.servo_move_t") return ServoMoves(n);
  if (type == "sirupp.servo_setpoint_t") return Setpoints(n);
  if (type == "sirupp.servo_gains_t") return GainsSamples(n);
  if (type == "sirupp.joint_target_t") return Targets(n);
  if (type == "sirupp.pose_target_t") return PoseTargets();
  if (type == "sirupp.plan_command_t") return PlanCommands();
  if (type == "sirupp.controller_status_t") return ControllerStatuses();
  if (type == "sirupp.hardware_status_t") return HardwareStatuses(n);
  if (type == "sirupp.hardware_command_t") return HardwareCommands();
  if (type == "sirupp.estop_t") return Estops();
  if (type == "sirupp.heartbeat_t") return Heartbeats();
  if (type == "sirupp.robot_model_t") return RobotModels();
  if (type == "sirupp.environment_t") return Environments();
  if (type == "sirupp.image_t") return Images();
#if __has_include(<sirupp/viewer_camera_t.hpp>)
  if (type == "sirupp.viewer_camera_t") return ViewerCameras();
#endif
  // A type this tool does not know yet (a channel added since): random and foreign bytes only.
  std::fprintf(stderr, "lcm_flood: note: channel %s has type %s, unknown here: random bytes only\n",
               channel.c_str(), type.c_str());
  return {};
}

struct Options {
  std::string mode;
  std::string url;
  std::string prefix;
  double seconds = -1;
  double rate = 2000;
  int joints = 6;
  unsigned seed = 1;
  std::vector<std::string> processes;
  std::vector<std::string> newest_only;
};

[[noreturn]] void Usage(const std::string& problem) {
  std::fprintf(stderr,
               "lcm_flood: %s\n"
               "usage: lcm_flood flood [--lcm-url URL] [--prefix P] [--seconds S] [--rate HZ]"
               " [--joints N] [--seed N]\n"
               "       lcm_flood check --processes NAME,NAME.. [--lcm-url URL] [--prefix P]"
               " [--seconds S] [--newest-only NAME,NAME..]\n",
               problem.c_str());
  std::exit(2);
}

Options Parse(int argc, char** argv) {
  Options o;
  if (argc < 2) Usage("no mode");
  o.mode = argv[1];
  if (o.mode != "flood" && o.mode != "check") Usage("mode '" + o.mode + "': allowed flood, check");
  for (int i = 2; i < argc; i += 2) {
    const std::string flag = argv[i];
    if (i + 1 >= argc) Usage(flag + " needs a value");
    const std::string value = argv[i + 1];
    try {
      if (flag == "--lcm-url") {
        o.url = value;
      } else if (flag == "--prefix") {
        o.prefix = value;
      } else if (flag == "--seconds") {
        o.seconds = std::stod(value);
      } else if (flag == "--rate") {
        o.rate = std::stod(value);
      } else if (flag == "--joints") {
        o.joints = std::stoi(value);
      } else if (flag == "--seed") {
        o.seed = static_cast<unsigned>(std::stoul(value));
      } else if (flag == "--processes" || flag == "--newest-only") {
        std::stringstream list(value);
        std::string name;
        while (std::getline(list, name, ',')) {
          if (!name.empty()) (flag == "--processes" ? o.processes : o.newest_only).push_back(name);
        }
      } else {
        Usage("unknown flag " + flag);
      }
    } catch (const std::logic_error&) {
      Usage(flag + " " + value + ": not a number");
    }
  }
  if (o.seconds < 0) o.seconds = o.mode == "flood" ? 3.0 : 2.5;
  if (!(o.rate > 0) || o.joints < 2) Usage("--rate must be > 0 and --joints at least 2");
  if (o.mode == "check" && o.processes.empty()) Usage("check needs --processes");
  return o;
}

enum Kind { kRandom, kForeign, kBadHash, kCut, kTyped, kKinds };
const char* const kKindNames[kKinds] = {"random", "foreign", "badhash", "cut", "typed"};

int Flood(const Options& o) {
  sirupp::core::Bus bus(o.url, o.prefix);
  lcm::LCM& lcm = bus.raw_lcm();
  struct Target {
    std::string channel;  // without prefix
    std::string full;
    TypeSamples samples;
    long sent[kKinds] = {};
    long failed = 0;
  };
  std::vector<Target> targets;
  for (const sirupp::core::ChannelInfo& info : sirupp::core::ChannelTable()) {
    Target t;
    t.channel = info.name;
    t.full = bus.FullName(info.name);
    t.samples = SamplesFor(info.name, info.lcm_type, o.joints);
    targets.push_back(std::move(t));
  }
  std::mt19937 random(o.seed);
  auto pick = [&random](size_t n) {
    return static_cast<size_t>(std::uniform_int_distribution<size_t>(0, n - 1)(random));
  };
  const auto period =
      std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / o.rate));
  const Clock::time_point start = Clock::now();
  const Clock::time_point end =
      start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(o.seconds));
  Clock::time_point next = start;
  long total = 0;
  Bytes bytes;
  while (Clock::now() < end) {
    Target& t = targets[static_cast<size_t>(total) % targets.size()];
    auto kind = static_cast<Kind>((static_cast<size_t>(total) / targets.size()) % kKinds);
    if (kind == kTyped && t.samples.typed.empty()) kind = kRandom;
    if ((kind == kBadHash || kind == kCut) && t.samples.good.empty()) kind = kRandom;
    switch (kind) {
      case kRandom:
        bytes.resize(pick(301));
        for (uint8_t& b : bytes) b = static_cast<uint8_t>(pick(256));
        break;
      case kForeign: {
        const Target& other =
            targets[(pick(targets.size() - 1) + 1 + static_cast<size_t>(&t - targets.data())) %
                    targets.size()];
        bytes = other.samples.good;
        if (bytes.size() >= 8 && t.samples.good.size() >= 8 &&
            std::memcmp(bytes.data(), t.samples.good.data(), 8) == 0) {
          bytes[0] ^= 0x80;  // two channels of one type: make it foreign anyway
        }
        break;
      }
      case kBadHash:
        bytes = t.samples.good;
        bytes[pick(8)] ^= static_cast<uint8_t>(1 + pick(255));
        break;
      case kCut:
        bytes = t.samples.good;
        bytes.resize(8 + pick(bytes.size() - 8));  // the fingerprint and part of the body
        break;
      case kTyped:
        bytes = t.samples.typed[pick(t.samples.typed.size())];
        break;
      case kKinds:
        break;
    }
    if (lcm.publish(t.full, bytes.data(), static_cast<unsigned>(bytes.size())) == 0) {
      ++t.sent[kind];
    } else {
      ++t.failed;
    }
    ++total;
    next += period;
    const Clock::time_point now = Clock::now();
    if (next > now) {
      std::this_thread::sleep_until(next);
    } else if (now - next > std::chrono::milliseconds(100)) {
      next = now;  // fell behind (a loaded machine): no burst to catch up
    }
  }
  const double elapsed = std::chrono::duration<double>(Clock::now() - start).count();
  std::printf("lcm_flood: %ld messages on %zu channels in %.2f s (%.0f per second)\n", total,
              targets.size(), elapsed, static_cast<double>(total) / elapsed);
  for (const Target& t : targets) {
    std::printf("  %-20s", t.full.c_str());
    for (int k = 0; k < kKinds; ++k) std::printf(" %s %ld", kKindNames[k], t.sent[k]);
    if (t.failed > 0) std::printf(" (publish failed %ld)", t.failed);
    std::printf("\n");
  }
  return 0;
}

int Check(const Options& o) {
  sirupp::core::Bus bus(o.url, o.prefix);
  std::map<std::string, sirupp::heartbeat_t> newest;  // "process@host pid"
  bus.Subscribe<sirupp::heartbeat_t>(
      "HEARTBEAT",
      [&newest](const sirupp::heartbeat_t& beat, const sirupp::core::ReceiveInfo&) {
        newest[beat.process + "@" + beat.host + " pid " + std::to_string(beat.pid)] = beat;
      },
      1000);
  // At least S seconds (the heartbeats after the flood carry its counts), then until every named
  // process was heard, up to 10 s more: a starved process may skip a beat.
  const Clock::time_point start = Clock::now();
  auto after = [start](double s) {
    return start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(s));
  };
  auto all_heard = [&] {
    for (const std::string& process : o.processes) {
      bool heard = false;
      for (const auto& entry : newest) heard = heard || entry.second.process == process;
      if (!heard) return false;
    }
    return true;
  };
  while (Clock::now() < after(o.seconds) ||
         (!all_heard() && Clock::now() < after(o.seconds + 10))) {
    bus.Handle(50);
  }

  // Channels the flood sends decodable bad messages on (all but ESTOP): full names.
  std::map<std::string, bool> typed;
  for (const sirupp::core::ChannelInfo& info : sirupp::core::ChannelTable()) {
    typed[bus.FullName(info.name)] = !SamplesFor(info.name, info.lcm_type, 6).typed.empty();
  }
  const std::set<std::string> sampled(o.newest_only.begin(), o.newest_only.end());
  std::set<std::string> per_tick;
  for (const std::string& name : sirupp::core::Channels().PerTick()) {
    per_tick.insert(bus.FullName(name));
  }
  int failures = 0;
  for (const std::string& process : o.processes) {
    bool heard = false;
    for (const auto& [who, beat] : newest) {
      if (beat.process != process) continue;
      heard = true;
      std::printf("%s (%s):\n", who.c_str(), beat.detail.c_str());
      int receiving = 0;
      for (const sirupp::channel_stats_t& c : beat.channels) {
        if (c.publishing) continue;
        ++receiving;
        std::printf("  %-20s %8ld messages %6ld decode errors %6ld rejected %4ld late %6ld gaps\n",
                    c.channel.c_str(), static_cast<long>(c.messages),
                    static_cast<long>(c.decode_errors), static_cast<long>(c.rejected),
                    static_cast<long>(c.late), static_cast<long>(c.gaps));
        if (sampled.count(process) > 0 && per_tick.count(c.channel) > 0) {
          if (c.decode_errors + c.rejected < 1) {
            std::printf("FAIL %s: no decode error or rejected message counted on %s\n", who.c_str(),
                        c.channel.c_str());
            ++failures;
          }
          continue;
        }
        if (c.decode_errors < 1) {
          std::printf("FAIL %s: no decode errors counted on %s\n", who.c_str(), c.channel.c_str());
          ++failures;
        }
        if (typed[c.channel] && c.rejected < 1) {
          std::printf("FAIL %s: no rejected messages counted on %s\n", who.c_str(),
                      c.channel.c_str());
          ++failures;
        }
      }
      if (receiving == 0) {
        std::printf("FAIL %s: its heartbeat lists no channel it receives\n", who.c_str());
        ++failures;
      }
    }
    if (!heard) {
      std::printf("FAIL %s: no heartbeat within %.1f s\n", process.c_str(), o.seconds + 10);
      ++failures;
    }
  }
  return failures == 0 ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  const Options options = Parse(argc, argv);
  try {
    return options.mode == "flood" ? Flood(options) : Check(options);
  } catch (const std::exception& error) {
    std::fprintf(stderr, "lcm_flood: %s\n", error.what());
    return 1;
  }
}
