// Example 5: a controller in its own process, in C++, taking sirupp-control's place on the bus.
//
// It learns the arm from ROBOT_MODEL (the joint count, each joint's name, position limits and
// effort limit, as sirupp-sim loaded them), subscribes to SIM_ARM_STATE and answers every state
// with an arm_command_t on SIM_ARM_COMMAND that carries the same tick, so sirupp-sim can run in
// lockstep with it as the only participant. It answers no state before ROBOT_MODEL has come: in
// lockstep the sim waits for it (and sends the state again), in realtime the sim brakes the arm for
// a participant it has not heard yet. So the law starts at the first state whenever the model
// arrives, and the efforts are a function of the states alone: the same states give the same
// efforts, bit for bit (answering hold until the model comes would start the law at a tick that
// depends on when the model happened to arrive, and `sirupp grade` would see different numbers).
//
// The law is a PID per joint with no model of the arm's dynamics: the integral term learns the
// gravity and friction efforts. The reference moves from where the arm starts towards the target at
// a limited speed, so the PID never sees a large step. Or, with --reference FILE, the reference is
// read from a file, one row per tick (what `sirupp grade` hands a process controller as
// {reference_csv}: the set-points a controller library gets, or the path of a tracking task;
// docs/grading.md): the row of each state's tick gives the position and velocity to follow. The
// gains are for the PUMA 260 (each joint's inertia at home times 60^2, 60 rad/s of bandwidth);
// another robot is refused. Efforts are clamped to the model's effort limits, and a target outside
// a joint's limits is refused. When the states stop (the sim ended), it prints the final joint
// positions and exits.
//
// Build it without the project's build tree (docs/student-controllers.md, "B. A controller
// process"):
//   lcm-gen -x --cpp-hpath types $SIRUPP/lcmtypes/*.lcm
//   g++ -std=c++17 -O2 -I types joint_pid.cpp -o joint_pid $(pkg-config --cflags --libs lcm)
// Run it:
//   build/bin/sirupp-sim --participants cpp-pid --duration 4 &
//   ./joint_pid --deg 30 -20 40 25 -30 45
//
// Options: --deg Q1 .. QN (target, degrees) or --reference FILE (one of them required)
//          --name NAME (participant, default cpp-pid) --lcm-url URL --prefix PREFIX (channel
//          prefix of the rig) --speed DEG_PER_S (default 30)

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <lcm/lcm-cpp.hpp>
#include <sirupp/arm_command_t.hpp>
#include <sirupp/arm_state_t.hpp>
#include <sirupp/robot_model_t.hpp>
#include <sstream>
#include <string>
#include <vector>

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180;
// PUMA 260 gains (N*m/rad, N*m/(rad*s), N*m*s/rad), as examples/04_java_controller.
const std::vector<double> kKp = {680, 640, 170, 11, 9.4, 5.5};
const std::vector<double> kKi = {8200, 7700, 2000, 130, 110, 66};
const std::vector<double> kKd = {23, 21, 5.8, 0.36, 0.31, 0.18};
constexpr double kStaleSeconds = 1.0;  // no state for this long after the first: the sim has ended

using Clock = std::chrono::steady_clock;

// A reference file: row k is tick k; per joint position (rad or m) and velocity (per s).
struct Reference {
  std::vector<std::vector<double>> position, velocity;
  size_t joints = 0;
  bool empty() const { return position.empty(); }
};

struct Options {
  std::vector<double> target;  // rad
  Reference reference;         // --reference: followed in place of the ramp to the target
  std::string name = "cpp-pid";
  std::string url;
  std::string prefix;
  double speed = 30 * kDeg;  // rad/s
};

[[noreturn]] void Usage(const std::string& problem) {
  std::fprintf(stderr,
               "JointPid: %s\nusage: joint_pid (--deg Q1 .. QN | --reference FILE) [--name NAME] "
               "[--lcm-url URL] [--prefix PREFIX] [--speed DEG_PER_S]\n",
               problem.c_str());
  std::exit(2);
}

double Number(const std::string& text, const std::string& flag) {
  char* end = nullptr;
  const double value = std::strtod(text.c_str(), &end);
  if (text.empty() || *end != '\0' || !std::isfinite(value)) {
    Usage(flag + ": '" + text + "' is not a number");
  }
  return value;
}

// Reads a reference file ({reference_csv}): the header `tick,time_s,q1_deg,v1_deg_s,a1_deg_s2,...`
// (mm for a prismatic joint), then one row per tick from 0. Any problem exits 2 naming FILE:LINE.
Reference ReadReference(const std::string& file) {
  std::ifstream in(file);
  if (!in) Usage("--reference: cannot read '" + file + "'");
  const auto fail = [&file](int line, const std::string& problem) {
    Usage("--reference: " + file + ":" + std::to_string(line) + ": " + problem);
  };
  const auto split = [](const std::string& line) {
    std::vector<std::string> cells;
    std::istringstream fields(line);
    for (std::string cell; std::getline(fields, cell, ',');) cells.push_back(cell);
    return cells;
  };
  std::string line;
  if (!std::getline(in, line)) fail(1, "empty; expected the header tick,time_s,q1_deg,...");
  const std::vector<std::string> header = split(line);
  if (header.size() < 5 || (header.size() - 2) % 3 != 0 || header[0] != "tick" ||
      header[1] != "time_s") {
    fail(1, "header '" + line + "'; expected tick,time_s and then q,v,a per joint");
  }
  Reference reference;
  reference.joints = (header.size() - 2) / 3;
  std::vector<double> scale;  // SI per unit of the file, per joint
  for (size_t j = 0; j < reference.joints; ++j) {
    const std::string& name = header[2 + 3 * j];
    const std::string unit = name.substr(name.find('_') + 1);
    if (name.rfind("q" + std::to_string(j + 1) + "_", 0) != 0 || (unit != "deg" && unit != "mm")) {
      fail(1, "column " + std::to_string(3 + 3 * j) + " is '" + name + "'; expected q" +
                  std::to_string(j + 1) + "_deg or q" + std::to_string(j + 1) + "_mm");
    }
    scale.push_back(unit == "deg" ? kDeg : 0.001);
  }
  for (int number = 2; std::getline(in, line); ++number) {
    const std::vector<std::string> cells = split(line);
    if (cells.size() != header.size()) {
      fail(number, std::to_string(cells.size()) + " values; the header has " +
                       std::to_string(header.size()));
    }
    std::vector<double> values;
    for (const std::string& cell : cells) {
      char* end = nullptr;
      const double value = std::strtod(cell.c_str(), &end);
      if (cell.empty() || *end != '\0' || !std::isfinite(value)) {
        fail(number, "'" + cell + "' is not a finite number");
      }
      values.push_back(value);
    }
    if (values[0] != static_cast<double>(number - 2)) {
      fail(number, "tick " + cells[0] + "; expected " + std::to_string(number - 2));
    }
    std::vector<double> q, v;
    for (size_t j = 0; j < reference.joints; ++j) {
      q.push_back(values[2 + 3 * j] * scale[j]);
      v.push_back(values[3 + 3 * j] * scale[j]);
    }
    reference.position.push_back(q);
    reference.velocity.push_back(v);
  }
  if (reference.empty()) fail(2, "no rows after the header");
  return reference;
}

Options Parse(int argc, char** argv) {
  Options options;
  for (int i = 1; i < argc; ++i) {
    const std::string flag = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) Usage(flag + " needs a value");
      return argv[++i];
    };
    if (flag == "--deg") {
      while (i + 1 < argc && std::string(argv[i + 1]).rfind("--", 0) != 0) {
        options.target.push_back(Number(argv[++i], flag) * kDeg);
      }
    } else if (flag == "--name") {
      options.name = value();
    } else if (flag == "--lcm-url") {
      options.url = value();
    } else if (flag == "--prefix") {
      options.prefix = value();
    } else if (flag == "--speed") {
      options.speed = Number(value(), flag) * kDeg;
    } else if (flag == "--reference") {
      options.reference = ReadReference(value());
    } else {
      Usage("unknown argument '" + flag + "'");
    }
  }
  if (!options.reference.empty()) {
    // The target (for the limits check and the final error) is where the reference ends.
    const std::vector<double>& last = options.reference.position.back();
    if (!options.target.empty() && options.target.size() != last.size()) {
      Usage("--deg gave " + std::to_string(options.target.size()) + " joints, --reference " +
            std::to_string(last.size()));
    }
    options.target = last;
  }
  if (options.target.empty()) Usage("give the target with --deg, or --reference FILE");
  if (!(options.speed > 0)) Usage("--speed must be > 0");
  return options;
}

class JointPid {
 public:
  JointPid(lcm::LCM& bus, Options options) : bus_(bus), options_(std::move(options)) {}

  // ROBOT_MODEL: the first one tells the joint count and limits; later ones are the same robot.
  void OnModel(const lcm::ReceiveBuffer*, const std::string&, const sirupp::robot_model_t* model) {
    if (num_joints_ > 0 || !failure_.empty()) return;
    const int n = model->num_joints;
    if (n != static_cast<int>(options_.target.size())) {
      failure_ = "the arm (" + model->name + ") has " + std::to_string(n) +
                 " joints, the target has " + std::to_string(options_.target.size());
      return;
    }
    if (model->name != "puma260") {
      failure_ = "the gains are for the PUMA 260; the sim runs " + model->name;
      return;
    }
    for (int j = 0; j < n; ++j) {
      const sirupp::joint_model_t& joint = model->joints[static_cast<size_t>(j)];
      const double goal = options_.target[static_cast<size_t>(j)];
      if (goal < joint.position_min || goal > joint.position_max) {
        char text[200];
        std::snprintf(text, sizeof text, "joint %d (%s): target %.1f deg is outside [%.1f, %.1f]",
                      j + 1, joint.name.c_str(), goal / kDeg, joint.position_min / kDeg,
                      joint.position_max / kDeg);
        failure_ = text;
        return;
      }
      effort_max_.push_back(joint.effort_max);
    }
    num_joints_ = n;
    std::fprintf(stderr, "JointPid: %s, %d joints, from %sROBOT_MODEL\n", model->name.c_str(), n,
                 options_.prefix.c_str());
  }

  void OnState(const lcm::ReceiveBuffer*, const std::string&, const sirupp::arm_state_t* state) {
    last_state_ = Clock::now();
    seen_state_ = true;
    // Lockstep rule: answer every state with its own tick. The sim sends a state again when an
    // answer went missing; answer it with the same command instead of stepping the PID twice.
    if (state->tick == last_tick_ && have_command_) {
      Publish(last_command_);
      return;
    }
    if (state->tick < last_tick_) return;  // older than what was answered already
    sirupp::arm_command_t command{};
    command.utime = state->utime;
    command.tick = state->tick;
    command.sender = options_.name;
    command.num_joints = state->num_joints;
    command.effort.assign(static_cast<size_t>(state->num_joints), 0.0);
    // Not before the arm is known: the sim waits (lockstep) or brakes (realtime) meanwhile, and
    // the law starts at the first state, whenever ROBOT_MODEL came.
    if (num_joints_ == 0) return;
    if (state->num_joints != num_joints_) {
      command.mode = sirupp::arm_command_t::MODE_HOLD;  // another arm than the model's: brakes on
      Publish(command);
      return;
    }
    const auto n = static_cast<size_t>(num_joints_);
    if (reference_.empty()) {
      reference_ = state->position;  // start the reference where the arm is
      integral_.assign(n, 0.0);
      std::fprintf(stderr, "JointPid: the law starts at tick %lld\n",
                   static_cast<long long>(state->tick));
    }
    const double dt = last_tick_ < 0 || last_utime_ == 0
                          ? 0
                          : static_cast<double>(state->utime - last_utime_) * 1e-6;
    command.mode = sirupp::arm_command_t::MODE_EFFORT;
    const Reference& given = options_.reference;
    // After the last row, the last row.
    const size_t row = given.empty()
                           ? 0
                           : std::min(static_cast<size_t>(std::max<int64_t>(state->tick, 0)),
                                      given.position.size() - 1);
    for (size_t j = 0; j < n; ++j) {
      double reference_speed = 0;
      if (!given.empty()) {  // the row of this tick
        reference_[j] = given.position[row][j];
        reference_speed = given.velocity[row][j];
      } else {  // a ramp towards the target
        const double step = std::clamp(options_.target[j] - reference_[j], -options_.speed * dt,
                                       options_.speed * dt);
        reference_[j] += step;
        reference_speed = dt > 0 ? step / dt : 0;
      }
      const double error = reference_[j] - state->position[j];
      integral_[j] += error * dt;
      const double effort =
          kKp[j] * error + kKi[j] * integral_[j] + kKd[j] * (reference_speed - state->velocity[j]);
      command.effort[j] = std::clamp(effort, -effort_max_[j], effort_max_[j]);
    }
    Publish(command);
    last_utime_ = state->utime;
    position_ = state->position;
  }

  // Handles messages until the states stop (or a failure); exit code of the program.
  int Run() {
    while (failure_.empty()) {
      if (bus_.handleTimeout(100) < 0) {
        failure_ = "LCM failed while waiting for messages";
        break;
      }
      if (seen_state_ &&
          std::chrono::duration<double>(Clock::now() - last_state_).count() > kStaleSeconds) {
        break;
      }
    }
    if (!failure_.empty()) {
      std::fprintf(stderr, "JointPid: %s\n", failure_.c_str());
      return 2;
    }
    if (position_.empty()) {
      std::fprintf(stderr, "JointPid: no state after ROBOT_MODEL; nothing was driven\n");
      return 1;
    }
    double worst = 0;
    std::printf(
        "JointPid: answered %lld ticks, last tick %lld\nJointPid: final joint positions (deg):",
        static_cast<long long>(answered_), static_cast<long long>(last_tick_));
    for (size_t j = 0; j < position_.size(); ++j) {
      std::printf(" %.3f", position_[j] / kDeg);
      worst = std::max(worst, std::abs(position_[j] - options_.target[j]) / kDeg);
    }
    std::printf("\nJointPid: largest error %.3f deg\n", worst);
    return 0;
  }

 private:
  // Every message gets the next seq, a repeated answer too (the sim counts gaps per sender).
  void Publish(sirupp::arm_command_t& command) {
    if (command.tick != last_tick_ || !have_command_) ++answered_;
    command.seq = seq_++;
    bus_.publish(options_.prefix + "SIM_ARM_COMMAND", &command);
    last_command_ = command;
    have_command_ = true;
    last_tick_ = command.tick;
  }

  lcm::LCM& bus_;
  Options options_;
  int num_joints_ = 0;  // 0 until ROBOT_MODEL came
  std::vector<double> effort_max_;
  std::vector<double> reference_, integral_, position_;
  int64_t last_tick_ = -1;
  int64_t last_utime_ = 0;
  int64_t seq_ = 0;
  int64_t answered_ = 0;  // states answered (each tick once)
  sirupp::arm_command_t last_command_{};
  bool have_command_ = false;
  bool seen_state_ = false;
  Clock::time_point last_state_;
  std::string failure_;
};

}  // namespace

int main(int argc, char** argv) {
  Options options = Parse(argc, argv);
  lcm::LCM bus(options.url);  // "" = LCM_DEFAULT_URL, else LCM's default
  if (!bus.good()) {
    std::fprintf(stderr, "JointPid: cannot start LCM with URL '%s'\n", options.url.c_str());
    return 2;
  }
  const std::string prefix = options.prefix;
  const std::string name = options.name;
  JointPid controller(bus, std::move(options));
  bus.subscribe(prefix + "ROBOT_MODEL", &JointPid::OnModel, &controller);
  bus.subscribe(prefix + "SIM_ARM_STATE", &JointPid::OnState, &controller);
  std::fprintf(stderr,
               "JointPid: participant '%s', waiting for %sROBOT_MODEL and %sSIM_ARM_STATE\n",
               name.c_str(), prefix.c_str(), prefix.c_str());
  return controller.Run();
}
