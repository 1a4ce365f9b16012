// bench_loop: the sim-controller loop over LCM udpm on this machine, in lockstep, against the limit
// set by its two unavoidable costs, all measured in one run:
//
//  (a) the LCM round trip: this program and a copy of itself in the "pong" role (fork + exec) swap
//      an arm_state_t and an arm_command_t of the model's joints over udpm (ttl=0, a port of this
//      run's own) through core::Bus, as sirupp-sim and sirupp-control do; median and mean after a
//      warm-up. A second series, where the pong also publishes a servo_setpoint_t after each
//      answer (as sirupp-control does), is a diagnostic only.
//  (b) the physics step: sim::ArmWorld::Step for the model with sirupp-sim's default options
//      (friction on, the model's servo tick), driven in this process by the same PIC-SERVO bank
//      sirupp-control runs, so it follows the very trajectory of the loop in (c): holding the home
//      pose, and moving towards the "ready" pose. Mean per step.
//  (c) the loop itself: sirupp-control and sirupp-sim --mode lockstep --duration D started as
//      separate processes on the same URL, with and without ARM_SETPOINT. Ticks per second of wall
//      time = the sim's step count / the time from the sim's start line on stderr (printed after
//      set-up, just before the first state goes out) to its exit (end of its stderr). This program
//      has no LCM socket open meanwhile, so it neither receives nor slows the loop's traffic.
//
// The three are measured in R rounds, each with all of them, so that a burst of other work on the
// machine falls on a round rather than on one figure. Per round: limit = 1 / (mean round trip +
// mean step), ratio = loop ticks/s / limit; the ratio printed is the median over rounds, goal >=
// 0.7 (issue item 7). The stricter ratio against the median round trip is printed too. The replica
// in (b) must end where the sim ends (the sim's printed final joint positions); the program says so
// if it does not.
//
//  (d) afterwards, what isolating a student's controller library costs per tick: the Update of
//      examples/02_pd_gravity called in this process (PluginEffortLaw) against the same call
//      through sirupp-controller-host (IsolatedEffortLaw, as sirupp-control --controller runs it):
//      median and p99 of C calls each, in alternating blocks of 1000.
//
//  (e) alone, with --scale K1,K2,...: the exchange of (a) as a class server's rigs make it, with
//      nothing else: K pairs at once, each on a port of its own, a ping paced like `sirupp-sim
//      --pace-ticks P` (a state per servo tick in real time) and a pong answering like
//      sirupp-control (command + ARM_SETPOINT), both reading directly (Bus::ReadDirectly). Prints
//      their real-time factor and CPU time per tick, and the pairs one core could hold: the ceiling
//      this machine puts on rigs per core for any rig whose sim and controller are processes that
//      exchange every tick (issue 32; compare bench/rig_cpu.py's cost of a whole rig).
//
// Usage: bench_loop [--port P] [--round-trips N] [--warmup W] [--duration D] [--rounds R]
//                   [--model FILE] [--bin DIR] [--dump FILE] [--law-calls C] [--law-only]
//        bench_loop --scale K1,K2,... [--scale-seconds S] [--pace-ticks P] [--port P]
//   K: pairs at once, 1..64, one run each; S: wall seconds per run (10); P: 1..64 (4).
//   P: udpm port (default 20000 + pid % 10000); N: timed round trips per round (10000) after W
//   (1000); D: simulated seconds per loop run (2); R: rounds (5); DIR: where sirupp-sim and
//   sirupp-control are (default: this program's directory); FILE: every timed round trip, in us;
//   C: timed Update calls of each kind in (d) (20000); --law-only: only (d).
// Internal: bench_loop --pong URL [--setpoint] [--direct] answers round trips (see RunPong);
// bench_loop --ping URL --scale-seconds S --pace-ticks P is a paced ping of (e) (RunPacedPing).

#include <signal.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <numeric>
#include <sirupp/arm_command_t.hpp>
#include <sirupp/arm_state_t.hpp>
#include <sirupp/joint_target_t.hpp>
#include <sirupp/servo_setpoint_t.hpp>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "control/isolated_law.hpp"
#include "control/plugin_controller.hpp"
#include "control/servo_bank.hpp"
#include "core/arm_state.hpp"
#include "core/bus.hpp"
#include "core/channels.hpp"
#include "core/environment.hpp"
#include "core/errors.hpp"
#include "core/model_loader.hpp"
#include "core/translate.hpp"
#include "proc/child.hpp"
#include "proc/rig.hpp"
#include "sim/arm_world.hpp"

namespace {

using sirupp::core::RobotModel;
using Clock = std::chrono::steady_clock;

constexpr double kGoal = 0.7;
const char kPongReady[] = "pong ready";
const char kParticipant[] = "sirupp-control";

double Seconds(Clock::duration duration) { return std::chrono::duration<double>(duration).count(); }

double Median(std::vector<double> values) {
  if (values.empty()) return 0;
  std::sort(values.begin(), values.end());
  const size_t middle = values.size() / 2;
  return values.size() % 2 == 1 ? values[middle] : 0.5 * (values[middle - 1] + values[middle]);
}

double Mean(const std::vector<double>& values) {
  if (values.empty()) return 0;
  return std::accumulate(values.begin(), values.end(), 0.0) / static_cast<double>(values.size());
}

double Percentile(std::vector<double> values, double fraction) {
  if (values.empty()) return 0;
  std::sort(values.begin(), values.end());
  const auto index = static_cast<size_t>(fraction * static_cast<double>(values.size() - 1));
  return values[index];
}

std::string FindModel(const std::string& path) {
  namespace fs = std::filesystem;
  for (const fs::path& base : {fs::path("."), fs::path(".."), fs::path("../..")}) {
    if (fs::exists(base / path)) return fs::absolute(base / path).string();
  }
  return path;
}

// ---- Child processes ----------------------------------------------------------------------------

// A program started with fork + exec, its stdout and stderr into one pipe read here. The child gets
// SIGKILL if this process dies, and the destructor ends it (SIGTERM, then SIGKILL), so no path out
// of main leaves a process behind.
// A process started with proc::Child, its output in a log file of this run's own folder, read for
// the lines it prints.
class Child {
 public:
  explicit Child(const std::vector<std::string>& argv) : Child(Spec(argv)) {}
  explicit Child(sirupp::proc::ProcessSpec spec) : name_(spec.argv.at(0)) {
    static int count = 0;
    spec.log_path = LogFolder() + "/" + std::to_string(++count) + "-" +
                    std::filesystem::path(name_).filename().string() + ".log";
    spec.death_signal = SIGKILL;
    spec.group_ends_with_it = true;
    log_path_ = spec.log_path;
    child_.Start(spec);
  }
  ~Child() {
    Terminate();
    std::error_code ignored;
    std::filesystem::remove(log_path_, ignored);
  }
  Child(const Child&) = delete;
  Child& operator=(const Child&) = delete;

  // Reads output until a line containing `needle` is complete; returns that line. Throws naming
  // the program and what it printed if it ends first or timeout_s passes.
  std::string WaitForLine(const std::string& needle, double timeout_s) {
    const Clock::time_point deadline = Deadline(timeout_s);
    while (true) {
      const bool ended = !child_.Running();  // before the read: nothing comes after it
      Read();
      const size_t found = output_.find(needle);
      if (found != std::string::npos) {
        const size_t end = output_.find('\n', found);
        if (end != std::string::npos) {
          const size_t begin = output_.rfind('\n', found);
          const size_t from = begin == std::string::npos ? 0 : begin + 1;
          return output_.substr(from, end - from);
        }
      }
      if (ended || Clock::now() > deadline) {
        throw std::runtime_error(name_ + " did not print '" + needle + "' (" +
                                 (ended ? "it ended" : "timed out") + "); its output:\n" + output_);
      }
      usleep(1000);
    }
  }

  // Waits for the child to end by itself. False on timeout.
  bool WaitForEnd(double timeout_s) {
    const Clock::time_point deadline = Deadline(timeout_s);
    while (child_.Running()) {
      if (Clock::now() > deadline) return false;
      usleep(500);
    }
    return true;
  }

  // Waits for the child to exit by itself within timeout_s; returns its exit status, or -1 (and
  // ends it) if it did not.
  int Wait(double timeout_s) {
    if (!WaitForEnd(timeout_s)) {
      Terminate();
      return -1;
    }
    const int status = child_.status();
    return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  }

  // SIGTERM, up to 2 s to exit (the processes print their summary then), then SIGKILL.
  void Terminate() {
    if (child_.started() && !child_.ended()) child_.Stop(2.0);
  }

  // Everything it printed so far.
  const std::string& output() {
    Read();
    return output_;
  }

 private:
  static sirupp::proc::ProcessSpec Spec(const std::vector<std::string>& argv) {
    sirupp::proc::ProcessSpec spec;
    spec.argv = argv;
    return spec;
  }
  static Clock::time_point Deadline(double timeout_s) {
    return Clock::now() +
           std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(timeout_s));
  }
  // This run's folder for the logs (removed when the bench ends).
  static const std::string& LogFolder() {
    struct Folder {
      Folder() {
        std::string pattern = (std::filesystem::temp_directory_path() / "sirupp-loop-bench-XXXXXX");
        if (mkdtemp(pattern.data()) == nullptr) {
          throw std::runtime_error("cannot make a folder for the processes' logs: " + pattern);
        }
        path = pattern;
      }
      ~Folder() {
        std::error_code ignored;
        std::filesystem::remove_all(path, ignored);
      }
      std::string path;
    };
    static const Folder folder;
    return folder.path;
  }
  // Appends what the log gained since the last read.
  void Read() {
    std::FILE* file = std::fopen(log_path_.c_str(), "rb");
    if (file == nullptr) return;
    if (std::fseek(file, static_cast<long>(read_), SEEK_SET) == 0) {
      char buffer[4096];
      size_t got = 0;
      while ((got = std::fread(buffer, 1, sizeof buffer, file)) > 0) {
        output_.append(buffer, got);
        read_ += got;
      }
    }
    std::fclose(file);
  }

  std::string name_;
  std::string log_path_;
  sirupp::proc::Child child_;
  size_t read_ = 0;
  std::string output_;
};

std::string SelfPath() { return std::filesystem::read_symlink("/proc/self/exe").string(); }

// This process's CPU time (every thread, user + system), exact (not sampled at the timer tick).
double ProcessCpuSeconds() {
  timespec now{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &now);
  return static_cast<double>(now.tv_sec) + static_cast<double>(now.tv_nsec) * 1e-9;
}

// ---- Messages -----------------------------------------------------------------------------------

// An arm state of the model's size with plausible values (sizes are what matter on the wire).
sirupp::core::ArmState SampleState(const RobotModel& model) {
  sirupp::core::ArmState state;
  for (const sirupp::core::Joint& joint : model.joints) {
    state.position.push_back(joint.home + 0.1);
    state.velocity.push_back(0.25);
    state.effort.push_back(1.5);
    state.flags.push_back(0);
  }
  return state;
}

sirupp::core::ArmCommand SampleCommand(const RobotModel& model) {
  sirupp::core::ArmCommand command;
  command.sender = kParticipant;
  command.mode = sirupp::core::CommandMode::kEffort;
  command.effort.assign(static_cast<size_t>(model.num_joints()), 1.5);
  return command;
}

sirupp::servo_setpoint_t SampleSetpoint(int joints) {
  sirupp::servo_setpoint_t setpoint{};
  setpoint.num_joints = joints;
  const auto n = static_cast<size_t>(joints);
  setpoint.position.assign(n, 0.1);
  setpoint.velocity.assign(n, 0.2);
  setpoint.goal.assign(n, 0.3);
  setpoint.position_error.assign(n, 0.001);
  setpoint.effort.assign(n, 1.5);
  setpoint.status.assign(n, 2);
  return setpoint;
}

// ---- (a) round trip -----------------------------------------------------------------------------

// The pong role: answers each arm_state_t on SIM_ARM_STATE with an arm_command_t of the same tick
// on SIM_ARM_COMMAND (and, with `setpoint`, then a servo_setpoint_t on ARM_SETPOINT, as
// sirupp-control does). A negative tick ends it.
int RunPong(const std::string& url, bool setpoint, bool direct, const RobotModel& model) {
  const sirupp::core::Channels channels;
  sirupp::core::Bus bus(url);
  sirupp::arm_command_t answer = sirupp::core::ToMessage(SampleCommand(model), 0);
  sirupp::servo_setpoint_t extra = SampleSetpoint(model.num_joints());
  bool quit = false;
  bus.Subscribe<sirupp::arm_state_t>(
      channels.sim_arm_state,
      [&](const sirupp::arm_state_t& message, const sirupp::core::ReceiveInfo&) {
        if (message.tick < 0) {
          quit = true;
          return;
        }
        answer.tick = message.tick;
        answer.utime = message.utime;
        ++answer.seq;
        bus.Publish(channels.sim_arm_command, answer);
        if (setpoint) {
          extra.tick = message.tick;
          extra.utime = message.utime;
          ++extra.seq;
          bus.Publish(channels.arm_setpoint, extra);
        }
      },
      1000);
  // As sirupp-control reads its states: from a socket of its own, in this thread (core/bus.hpp).
  if (direct) bus.ReadDirectly({bus.FullName(channels.sim_arm_state)}, kParticipant);
  std::printf("%s\n", kPongReady);
  std::fflush(stdout);
  const double cpu_start = ProcessCpuSeconds();
  while (!quit) {
    if (bus.Handle(1000) == 0 && getppid() == 1) break;  // the benchmark is gone
  }
  std::printf("pong cpu %.6f s\n", ProcessCpuSeconds() - cpu_start);
  return 0;
}

// The ping side on `bus`: `answered` follows the newest tick answered on SIM_ARM_COMMAND (read
// directly, as sirupp-sim does, with `direct`), and a first exchange is made with `ping` at tick 0,
// sent again until answered: it may race with the sockets joining the group.
void StartPinging(sirupp::core::Bus& bus, sirupp::arm_state_t& ping, int64_t& answered,
                  bool direct) {
  const sirupp::core::Channels channels;
  bus.Subscribe<sirupp::arm_command_t>(
      channels.sim_arm_command,
      [&answered](const sirupp::arm_command_t& message, const sirupp::core::ReceiveInfo&) {
        answered = std::max(answered, message.tick);
      },
      1000);
  if (direct) bus.ReadDirectly({bus.FullName(channels.sim_arm_command)}, "sirupp-sim");
  ping.tick = 0;
  for (int attempt = 0; answered < 0; ++attempt) {
    if (attempt == 50) throw std::runtime_error("the pong process never answered on " + bus.url());
    bus.Publish(channels.sim_arm_state, ping);
    while (bus.Handle(100) > 0 && answered < 0) {
    }
  }
}

struct RoundTrips {
  std::vector<double> us;  // one per timed round trip
  double median_us = 0;
  double mean_us = 0;
  double p99_us = 0;
};

RoundTrips MeasureRoundTrips(const std::string& url, const std::string& model_file,
                             const RobotModel& model, int count, int warmup, bool setpoint) {
  std::vector<std::string> argv = {SelfPath(), "--pong", url, "--model", model_file};
  if (setpoint) argv.push_back("--setpoint");
  Child pong(argv);
  pong.WaitForLine(kPongReady, 10);

  const sirupp::core::Channels channels;
  RoundTrips result;
  {
    sirupp::core::Bus bus(url);
    int64_t answered = -1;
    sirupp::arm_state_t ping = sirupp::core::ToMessage(SampleState(model), 0);
    StartPinging(bus, ping, answered, false);
    result.us.reserve(static_cast<size_t>(count));
    for (int64_t k = 1; k <= warmup + count; ++k) {
      ping.tick = k;
      ping.seq = k;
      ping.utime = k * 512;
      const Clock::time_point start = Clock::now();
      bus.Publish(channels.sim_arm_state, ping);
      while (answered < k) {
        if (bus.Handle(2000) == 0) {
          throw std::runtime_error("no answer to round trip " + std::to_string(k) +
                                   " within 2 s on " + url);
        }
      }
      const double us = Seconds(Clock::now() - start) * 1e6;
      if (k > warmup) result.us.push_back(us);
    }
    ping.tick = -1;
    bus.Publish(channels.sim_arm_state, ping);
  }
  if (pong.Wait(5) != 0) {
    throw std::runtime_error("the pong process failed; its output:\n" + pong.output());
  }
  result.median_us = Median(result.us);
  result.mean_us = Mean(result.us);
  result.p99_us = Percentile(result.us, 0.99);
  return result;
}

// ---- (b) physics step, on the loop's own trajectory ---------------------------------------------

struct Scenario {
  std::string name;                               // "hold" or "move"
  std::vector<sirupp::control::JointMove> moves;  // empty: hold the start pose
  std::vector<double> goal;                       // the move's goal positions (for ARM_TARGET)
};

struct PhysicsRun {
  long steps = 0;
  double step_us = 0;     // ArmWorld::Step, mean
  double state_us = 0;    // ArmWorld::State, mean
  double control_us = 0;  // ServoBank::Tick, mean
  double rows = 0;        // constraint rows per step, mean
  std::vector<double> final_position;
};

// sirupp-sim's world and sirupp-control's servo bank in one loop, without LCM: what the two
// processes compute, in the same order, for the same number of ticks.
PhysicsRun RunPhysics(const RobotModel& model, const Scenario& scenario, double duration_s) {
  sirupp::sim::ArmWorld world(model, sirupp::core::Environment{}, sirupp::sim::WorldOptions{});
  sirupp::control::ServoBank bank(model);
  sirupp::core::ArmCommand command;
  command.mode = sirupp::core::CommandMode::kEffort;
  double step_s = 0, state_s = 0, control_s = 0;
  long rows = 0;
  PhysicsRun run;
  bool servos_on = false;
  while (world.time_s() < duration_s - 0.5 * world.step_s()) {
    const Clock::time_point t0 = Clock::now();
    const sirupp::core::ArmState state = world.State();
    const Clock::time_point t1 = Clock::now();
    if (!servos_on) {
      bank.ServoOn(state.position);
      if (!scenario.moves.empty()) bank.Load(scenario.moves);
      servos_on = true;
    }
    command.effort = bank.Tick(state.position);
    const Clock::time_point t2 = Clock::now();
    world.Step(command);
    const Clock::time_point t3 = Clock::now();
    state_s += Seconds(t1 - t0);
    control_s += Seconds(t2 - t1);
    step_s += Seconds(t3 - t2);
    rows += world.LastStepRows();
    ++run.steps;
  }
  const double n = static_cast<double>(std::max(run.steps, 1L));
  run.step_us = step_s / n * 1e6;
  run.state_us = state_s / n * 1e6;
  run.control_us = control_s / n * 1e6;
  run.rows = static_cast<double>(rows) / n;
  run.final_position = world.State().position;
  return run;
}

// Per tick, what the two processes do with messages besides sending them: translate and encode the
// state, decode and check it, translate and encode the command, decode and check it, and (with
// set-points) fill and encode a servo_setpoint_t. Mean microseconds per tick.
double MessageWorkUs(const RobotModel& model, bool setpoint, int ticks) {
  const sirupp::core::ArmState state = SampleState(model);
  const sirupp::core::ArmCommand command = SampleCommand(model);
  std::vector<uint8_t> buffer(4096);
  long checksum = 0;
  const Clock::time_point start = Clock::now();
  for (int k = 0; k < ticks; ++k) {
    sirupp::arm_state_t state_message = sirupp::core::ToMessage(state, k);
    const int state_bytes = state_message.encode(buffer.data(), 0, state_message.getEncodedSize());
    sirupp::arm_state_t state_in{};
    state_in.decode(buffer.data(), 0, state_bytes);
    checksum += sirupp::core::ArmStateFromMessage(state_in, "SIM_ARM_STATE", model.num_joints())
                    .num_joints();
    sirupp::arm_command_t command_message = sirupp::core::ToMessage(command, k);
    const int command_bytes =
        command_message.encode(buffer.data(), 0, command_message.getEncodedSize());
    sirupp::arm_command_t command_in{};
    command_in.decode(buffer.data(), 0, command_bytes);
    checksum += static_cast<long>(
        sirupp::core::ArmCommandFromMessage(command_in, "SIM_ARM_COMMAND", model.num_joints())
            .effort.size());
    if (setpoint) {
      sirupp::servo_setpoint_t extra{};
      extra.num_joints = model.num_joints();
      for (int j = 0; j < model.num_joints(); ++j) {
        extra.position.push_back(0.1 * j);
        extra.velocity.push_back(0.2);
        extra.goal.push_back(0.3);
        extra.position_error.push_back(0.001);
        extra.effort.push_back(1.5);
        extra.status.push_back(2);
      }
      checksum += extra.encode(buffer.data(), 0, extra.getEncodedSize());
    }
  }
  const double us = Seconds(Clock::now() - start) * 1e6 / ticks;
  // Uses what the loop computed (so it is not optimised away) and checks that it did something.
  if (checksum <= 0) throw std::logic_error("message translation produced no joints");
  return us;
}

// ---- (c) the loop -------------------------------------------------------------------------------

struct LoopRun {
  long steps = 0;
  long accepted = 0;
  long timeouts = 0;
  double wall_s = 0;
  double ticks_per_s = 0;
  std::string final_line;  // the sim's "final joint positions" values
};

long NumberBefore(const std::string& text, const std::string& label) {
  const size_t at = text.find(label);
  if (at == std::string::npos) return -1;
  size_t begin = at;
  while (begin > 0 && text[begin - 1] == ' ') --begin;
  size_t digits = begin;
  while (digits > 0 && std::isdigit(static_cast<unsigned char>(text[digits - 1])) != 0) --digits;
  if (digits == begin) return -1;
  return std::atol(text.substr(digits, begin - digits).c_str());
}

struct LoopSetup {
  std::string bin_dir;
  int port = 0;
  std::string url;  // proc::RigUrl(port)
  std::string model_file;
  int joints = 0;
};

LoopRun RunLoop(const LoopSetup& setup, const Scenario& scenario, bool setpoints,
                double duration_s) {
  // The private rig as proc/rig.hpp describes it (no logger): the controller first, then the sim.
  sirupp::proc::RigSpec rig;
  rig.port = setup.port;
  rig.bin_dir = setup.bin_dir;
  rig.model = setup.model_file;
  rig.sim_mode = "lockstep";
  rig.participants = {kParticipant};
  char duration[32];
  std::snprintf(duration, sizeof duration, "%.9g", duration_s);
  rig.sim_args = {"--duration", duration};
  if (!setpoints) rig.control_args.push_back("--no-setpoints");
  const std::vector<sirupp::proc::RigProcess> processes = sirupp::proc::RigProcesses(rig);
  Child control(processes.at(1).spec);
  control.WaitForLine("participant", 10);
  if (!scenario.moves.empty()) {
    // Kept by sirupp-control and loaded with the first state, as `sirupp move joints` does. This
    // Bus is gone before the sim starts, so nothing in this process listens during the run.
    sirupp::core::Bus bus(setup.url);
    sirupp::joint_target_t target{};
    target.num_joints = setup.joints;
    target.position = scenario.goal;
    target.max_velocity.assign(scenario.goal.size(), 0.0);
    target.acceleration.assign(scenario.goal.size(), 0.0);
    target.active.assign(scenario.goal.size(), 1);
    bus.Publish(sirupp::core::Channels{}.arm_target, target);
  }
  Child sim(processes.at(0).spec);
  sim.WaitForLine(" mode, step ", 20);
  const Clock::time_point start = Clock::now();
  const double deadline_s = 30 + 20 * duration_s;
  if (!sim.WaitForEnd(deadline_s)) {
    sim.Terminate();
    throw std::runtime_error("sirupp-sim did not finish within " + std::to_string(deadline_s) +
                             " s; its output:\n" + sim.output());
  }
  LoopRun run;
  run.wall_s = Seconds(Clock::now() - start);
  const int status = sim.Wait(10);
  control.Terminate();
  const std::string& text = sim.output();
  const size_t summary = text.find("stopped at tick");
  if (status != 0 || summary == std::string::npos) {
    throw std::runtime_error("sirupp-sim exited with status " + std::to_string(status) +
                             "; its output:\n" + text + "\nsirupp-control's:\n" + control.output());
  }
  const std::string tail = text.substr(summary);
  run.steps = NumberBefore(tail, " steps,");
  run.accepted = NumberBefore(tail, " commands accepted");
  run.timeouts = NumberBefore(tail, " lockstep timeouts");
  const std::string final_label = "final joint positions (rad or m):";
  const size_t final_at = text.find(final_label);
  if (final_at != std::string::npos) {
    const size_t begin = final_at + final_label.size();
    run.final_line = text.substr(begin, text.find('\n', begin) - begin);
  }
  if (run.steps <= 0) throw std::runtime_error("no step count in sirupp-sim's summary:\n" + text);
  run.ticks_per_s = static_cast<double>(run.steps) / run.wall_s;
  return run;
}

std::string FormatPositions(const std::vector<double>& position) {
  std::string line;
  for (double q : position) line += " " + sirupp::core::FormatApprox(q);
  return line;
}

// ---- Controller library isolation
// ----------------------------------------------------------------

// (d) What running a student's controller library in its own process costs per tick: Update of
// examples/02_pd_gravity called in this process (PluginEffortLaw: dynamics + the library's Update)
// and through sirupp-controller-host (IsolatedEffortLaw: the same, plus the copy into shared memory
// and one socket byte each way, i.e. two wake-ups of a sleeping process). Each sample is one
// Update, wall time; the two kinds alternate in blocks, so load on the machine falls on both.
struct LawTimes {
  std::vector<double> in_process_us, isolated_us;
};

void TimeLawCalls(sirupp::control::EffortLaw& law, const RobotModel& model, int calls,
                  std::vector<double>* us) {
  const int n = model.num_joints();
  sirupp::core::ArmState state;
  state.position.assign(static_cast<size_t>(n), 0.1);
  state.velocity.assign(static_cast<size_t>(n), 0.0);
  state.effort.assign(static_cast<size_t>(n), 0.0);
  state.flags.assign(static_cast<size_t>(n), 0);
  sirupp::control::ControlInput input;
  input.state = &state;
  input.setpoint_position.assign(static_cast<size_t>(n), 0.1);
  input.setpoint_velocity.assign(static_cast<size_t>(n), 0.0);
  input.setpoint_acceleration.assign(static_cast<size_t>(n), 0.0);
  input.goal = input.setpoint_position;
  std::vector<double> effort;
  for (int k = 0; k < calls; ++k) {
    state.tick = input.tick = k;
    state.position[0] = 0.1 + 1e-4 * (k % 100);  // a different state each tick
    const Clock::time_point start = Clock::now();
    law.Update(input, effort);
    if (us != nullptr) us->push_back(Seconds(Clock::now() - start) * 1e6);
  }
}

LawTimes MeasureLawIsolation(const RobotModel& model, const std::string& library, int calls,
                             int warmup) {
  sirupp::control::PluginEffortLaw in_process(library, "", model);
  sirupp::control::IsolatedEffortLaw isolated(library, "", model);
  sirupp::core::ArmState state;
  state.position.assign(static_cast<size_t>(model.num_joints()), 0.1);
  state.velocity = state.effort = std::vector<double>(state.position.size(), 0.0);
  sirupp::control::ControlInput input;
  input.state = &state;
  input.setpoint_position = state.position;
  input.setpoint_velocity = input.setpoint_acceleration = state.velocity;
  input.goal = state.position;
  in_process.Reset(input);
  isolated.Reset(input);
  TimeLawCalls(in_process, model, warmup, nullptr);
  TimeLawCalls(isolated, model, warmup, nullptr);
  LawTimes times;
  constexpr int kBlock = 1000;
  for (int done = 0; done < calls; done += kBlock) {
    const int block = std::min(kBlock, calls - done);
    TimeLawCalls(in_process, model, block, &times.in_process_us);
    TimeLawCalls(isolated, model, block, &times.isolated_us);
  }
  return times;
}

void PrintLawIsolation(const LawTimes& times, const std::string& library) {
  std::printf(
      "\n(d) a controller library's Update (%s), per call: in sirupp-control's process vs in its "
      "host process (sirupp-controller-host), %zu calls each\n",
      std::filesystem::path(library).filename().c_str(), times.in_process_us.size());
  const double in_median = Median(times.in_process_us);
  const double iso_median = Median(times.isolated_us);
  std::printf("  %-34s median %6.2f us  p99 %7.2f us  mean %6.2f us\n", "in-process call",
              in_median, Percentile(times.in_process_us, 0.99), Mean(times.in_process_us));
  std::printf("  %-34s median %6.2f us  p99 %7.2f us  mean %6.2f us\n",
              "host round trip (shm + socket)", iso_median, Percentile(times.isolated_us, 0.99),
              Mean(times.isolated_us));
  std::printf("  isolation costs %.2f us per tick (median), %.2f us at p99\n",
              iso_median - in_median,
              Percentile(times.isolated_us, 0.99) - Percentile(times.in_process_us, 0.99));
}

// ---- (e) the exchange alone, at a class's scale ------------------------------------------------

// The sim role without the sim: sends an arm_state_t each servo tick and waits for its answer,
// paced as `sirupp-sim --mode realtime --pace-ticks P` (sleeps until P ticks are due, then
// exchanges them back to back; never ahead of the wall clock), reading the answers directly as
// sirupp-sim does. For `seconds` of wall time after a first exchange; then prints the ticks, the
// wall time and its CPU time, and ends the pong.
int RunPacedPing(const std::string& url, double seconds, int pace, const RobotModel& model) {
  const sirupp::core::Channels channels;
  sirupp::core::Bus bus(url);
  int64_t answered = -1;
  sirupp::arm_state_t state = sirupp::core::ToMessage(SampleState(model), 0);
  StartPinging(bus, state, answered, true);
  std::printf("ping ready\n");
  std::fflush(stdout);
  const double step = model.servo_tick_s;
  const auto at_tick = [step](int64_t ticks) {
    return std::chrono::duration_cast<Clock::duration>(
        std::chrono::duration<double>(static_cast<double>(ticks) * step));
  };
  const double cpu_start = ProcessCpuSeconds();
  const Clock::time_point start = Clock::now();
  const Clock::time_point end = start + at_tick(static_cast<int64_t>(seconds / step));
  int64_t tick = 0;
  while (Clock::now() < end) {
    const auto due = static_cast<int64_t>(std::floor(Seconds(Clock::now() - start) / step));
    if (due - tick < pace) {
      std::this_thread::sleep_until(start + at_tick(tick + pace));
      continue;
    }
    while (tick < due) {
      state.tick = ++tick;
      state.seq = tick;
      state.utime = tick * 512;
      bus.Publish(channels.sim_arm_state, state);
      while (answered < tick) {
        if (bus.Handle(2000) == 0) {
          throw std::runtime_error("no answer to tick " + std::to_string(tick) + " on " + url);
        }
      }
    }
  }
  const double wall = Seconds(Clock::now() - start);
  const double cpu = ProcessCpuSeconds() - cpu_start;
  state.tick = -1;
  bus.Publish(channels.sim_arm_state, state);
  std::printf("ping done %lld ticks %.6f s cpu %.6f s\n", static_cast<long long>(tick), wall, cpu);
  return 0;
}

struct ScaleRun {
  int pairs = 0;
  double factor_min = 0, factor_mean = 0;  // ticks x step / wall time, over the pairs
  double ping_us = 0, pong_us = 0;         // CPU per tick, mean over the pairs
};

// K pairs at once, each on a port of its own (as the class server's rigs): a pong (the control
// role: answer + ARM_SETPOINT each tick, states read directly) and a paced ping.
ScaleRun MeasureScale(const std::string& model_file, const RobotModel& model, int port, int pairs,
                      double seconds, int pace) {
  std::vector<std::unique_ptr<Child>> pongs, pings;
  for (int k = 0; k < pairs; ++k) {
    const std::string url = sirupp::proc::RigUrl(port + k);
    pongs.push_back(std::make_unique<Child>(std::vector<std::string>{
        SelfPath(), "--pong", url, "--setpoint", "--direct", "--model", model_file}));
    pongs.back()->WaitForLine(kPongReady, 10);
  }
  for (int k = 0; k < pairs; ++k) {
    const std::string url = sirupp::proc::RigUrl(port + k);
    pings.push_back(std::make_unique<Child>(std::vector<std::string>{
        SelfPath(), "--ping", url, "--scale-seconds", std::to_string(seconds), "--pace-ticks",
        std::to_string(pace), "--model", model_file}));
  }
  ScaleRun run;
  run.pairs = pairs;
  std::vector<double> factors;
  double ping_cpu = 0, pong_cpu = 0;
  int64_t ticks = 0;
  for (int k = 0; k < pairs; ++k) {
    const std::string done = pings[k]->WaitForLine("ping done", seconds + 30);
    long long n = 0;
    double wall = 0, cpu = 0;
    if (std::sscanf(done.c_str(), "ping done %lld ticks %lf s cpu %lf s", &n, &wall, &cpu) != 3 ||
        n <= 0 || !(wall > 0)) {
      throw std::runtime_error("pair " + std::to_string(k) + ": cannot read '" + done + "'");
    }
    factors.push_back(static_cast<double>(n) * model.servo_tick_s / wall);
    ticks += n;
    ping_cpu += cpu;
    const std::string pong = pongs[k]->WaitForLine("pong cpu", 10);
    double pong_seconds = 0;
    if (std::sscanf(pong.c_str(), "pong cpu %lf s", &pong_seconds) != 1) {
      throw std::runtime_error("pair " + std::to_string(k) + ": cannot read '" + pong + "'");
    }
    pong_cpu += pong_seconds;
  }
  for (auto& child : pings) child->Wait(5);
  for (auto& child : pongs) child->Wait(5);
  run.factor_min = *std::min_element(factors.begin(), factors.end());
  run.factor_mean = Mean(factors);
  run.ping_us = ping_cpu / static_cast<double>(ticks) * 1e6;
  run.pong_us = pong_cpu / static_cast<double>(ticks) * 1e6;
  return run;
}

void PrintScale(const RobotModel& model, const std::vector<ScaleRun>& runs, int pace) {
  const double rate = 1.0 / model.servo_tick_s;
  std::printf(
      "\n(e) the exchange alone at a class's scale: K pairs at once, each a paced ping (the sim's "
      "part: a state per tick, --pace-ticks %d) and a pong (the controller's: answer + "
      "ARM_SETPOINT), no physics and no control law, on ports of their own; CPU time of both per "
      "tick\n",
      pace);
  std::printf("  %5s %9s %9s %10s %10s %10s %14s\n", "pairs", "rtf min", "rtf mean", "ping us",
              "pong us", "pair us", "pairs per core");
  for (const ScaleRun& run : runs) {
    const double pair_us = run.ping_us + run.pong_us;
    std::printf("  %5d %9.3f %9.3f %10.1f %10.1f %10.1f %14.1f\n", run.pairs, run.factor_min,
                run.factor_mean, run.ping_us, run.pong_us, pair_us, 1e6 / (pair_us * rate));
  }
  std::printf(
      "  pairs per core = 1 / (pair us x %.1f ticks/s): the most rigs one core could hold if a "
      "rig cost nothing but this exchange (no physics, no controller, no logger, no page). A rig "
      "costs more: compare bench/rig_cpu.py; goal of issue 32: 6 rigs per core\n",
      rate);
}

// ---- main ---------------------------------------------------------------------------------------

struct Options {
  int port = 0;
  int round_trips = 10000;
  int warmup = 1000;
  double duration_s = 2;
  int rounds = 5;
  std::string model = "config/robots/puma260.yaml";
  std::string bin_dir;
  std::string dump;      // file for the round-trip samples, one per line (us)
  std::string pong_url;  // internal role
  bool pong_setpoint = false;
  int law_calls = 20000;      // (d): timed Update calls of each kind
  bool law_only = false;      // only (d)
  std::vector<int> scale;     // (e) alone: pairs per run
  double scale_seconds = 10;  // (e): wall seconds per run
  int pace_ticks = 4;         // (e): the pings' pacing, as the class server's rigs
  std::string ping_url;       // internal role of (e)
  bool pong_direct = false;   // internal: the pong reads its states directly
};

Options ParseOptions(int argc, char** argv) {
  Options options;
  for (int i = 1; i < argc; ++i) {
    const std::string flag = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw std::invalid_argument(flag + " needs a value");
      return argv[++i];
    };
    if (flag == "--port") {
      options.port = std::atoi(value().c_str());
    } else if (flag == "--round-trips") {
      options.round_trips = std::atoi(value().c_str());
    } else if (flag == "--warmup") {
      options.warmup = std::atoi(value().c_str());
    } else if (flag == "--duration") {
      options.duration_s = std::atof(value().c_str());
    } else if (flag == "--rounds") {
      options.rounds = std::atoi(value().c_str());
    } else if (flag == "--model") {
      options.model = value();
    } else if (flag == "--bin") {
      options.bin_dir = value();
    } else if (flag == "--dump") {
      options.dump = value();
    } else if (flag == "--pong") {
      options.pong_url = value();
    } else if (flag == "--setpoint") {
      options.pong_setpoint = true;
    } else if (flag == "--law-calls") {
      options.law_calls = std::atoi(value().c_str());
    } else if (flag == "--law-only") {
      options.law_only = true;
    } else if (flag == "--scale") {
      std::string list = value();
      for (size_t at = 0; at <= list.size();) {
        const size_t comma = std::min(list.find(',', at), list.size());
        const int pairs = std::atoi(list.substr(at, comma - at).c_str());
        if (pairs < 1 || pairs > 64) {
          throw std::invalid_argument("--scale " + list + ": each count must be 1..64");
        }
        options.scale.push_back(pairs);
        at = comma + 1;
      }
    } else if (flag == "--scale-seconds") {
      options.scale_seconds = std::atof(value().c_str());
    } else if (flag == "--pace-ticks") {
      options.pace_ticks = std::atoi(value().c_str());
    } else if (flag == "--ping") {
      options.ping_url = value();
    } else if (flag == "--direct") {
      options.pong_direct = true;
    } else {
      throw std::invalid_argument("unknown flag " + flag);
    }
  }
  if (options.port == 0) options.port = 20000 + static_cast<int>(getpid() % 10000);
  if (options.port < 1024 || options.port > 65535 || options.round_trips < 1 ||
      options.warmup < 0 || !(options.duration_s > 0) || options.rounds < 1 ||
      options.law_calls < 1 || !(options.scale_seconds > 0) || options.pace_ticks < 1 ||
      options.pace_ticks > 64) {
    throw std::invalid_argument(
        "allowed: --port 1024..65535, --round-trips >= 1, --warmup >= 0, --duration > 0, "
        "--rounds >= 1, --law-calls >= 1, --scale-seconds > 0, --pace-ticks 1..64");
  }
  return options;
}

void PrintRoundTrips(const char* label, const std::vector<RoundTrips>& rounds) {
  std::vector<double> pooled;
  std::string means;
  for (const RoundTrips& round : rounds) {
    pooled.insert(pooled.end(), round.us.begin(), round.us.end());
    char figure[32];
    std::snprintf(figure, sizeof figure, "%s%.1f", means.empty() ? "" : " ", round.mean_us);
    means += figure;
  }
  std::printf("  %-48s median %5.1f us  mean %5.1f us  p99 %6.1f us  (round means: %s)\n", label,
              Median(pooled), Mean(pooled), Percentile(pooled, 0.99), means.c_str());
}

std::string LoadAverage() {
  FILE* file = std::fopen("/proc/loadavg", "r");
  if (file == nullptr) return "unknown";
  char text[64] = {0};
  const bool read = std::fgets(text, sizeof text, file) != nullptr;
  std::fclose(file);
  if (!read) return "unknown";
  std::string line = text;
  return line.substr(0, line.find(' '));
}

std::string Join(const std::vector<double>& values, int decimals) {
  std::string joined;
  for (double value : values) {
    char figure[32];
    std::snprintf(figure, sizeof figure, "%.*f", decimals, value);
    joined += (joined.empty() ? "" : " ") + std::string(figure);
  }
  return joined;
}

// One loop case: a scenario with or without set-points, over the rounds.
struct Case {
  size_t scenario = 0;
  bool setpoints = true;
  std::vector<double> rates;   // ticks/s per round
  std::vector<double> limits;  // 1 / (that round's mean round trip + step) per round
  std::vector<double> ratios;  // rate / limit per round
  long steps = 0;
  long timeouts = 0;
  bool same_trajectory = true;
  std::string sim_final, replica_final;
};

// Where the processes are and the bus they use; throws when sirupp-sim or sirupp-control is
// missing.
LoopSetup MakeSetup(const Options& options, const std::string& model_file,
                    const RobotModel& model) {
  LoopSetup setup;
  setup.bin_dir = options.bin_dir.empty() ? std::filesystem::path(SelfPath()).parent_path().string()
                                          : options.bin_dir;
  setup.port = options.port;
  setup.url = sirupp::proc::RigUrl(options.port);
  setup.model_file = model_file;
  setup.joints = model.num_joints();
  for (const char* program : {"sirupp-sim", "sirupp-control"}) {
    if (!std::filesystem::exists(setup.bin_dir + "/" + program)) {
      throw std::runtime_error(std::string(program) + " not found in " + setup.bin_dir +
                               " (build the project, or give --bin DIR)");
    }
  }
  return setup;
}

// The scenarios: hold the home pose; move every joint towards the "ready" pose (or, for a model
// without one, half-way to each joint's upper limit) at the model's default speeds.
std::vector<Scenario> MakeScenarios(const RobotModel& model) {
  std::vector<Scenario> scenarios(2);
  scenarios[0].name = "hold";
  scenarios[1].name = "move";
  const sirupp::core::NamedPose* ready = model.FindNamedPose("ready");
  for (int j = 0; j < model.num_joints(); ++j) {
    const sirupp::core::Joint& joint = model.joints[static_cast<size_t>(j)];
    const double goal = ready != nullptr ? ready->position[static_cast<size_t>(j)]
                                         : 0.5 * (joint.home + joint.position_max);
    scenarios[1].goal.push_back(goal);
    scenarios[1].moves.push_back(
        {true, goal, joint.servo.default_velocity, joint.servo.default_acceleration});
  }
  return scenarios;
}

// Each scenario with and without set-points, in that order.
std::vector<Case> MakeCases(size_t scenarios) {
  std::vector<Case> cases;
  for (size_t s = 0; s < scenarios; ++s) {
    for (const bool setpoints : {true, false}) {
      Case one;
      one.scenario = s;
      one.setpoints = setpoints;
      cases.push_back(one);
    }
  }
  return cases;
}

// What the rounds measured: (a) round trips, (b) the physics replica per scenario; (c) goes into
// the cases.
struct Rounds {
  std::vector<RoundTrips> trips, trips_setpoint;
  std::vector<std::vector<double>> step_us, state_us, control_us;  // per scenario, per round
  std::vector<PhysicsRun> physics;                                 // per scenario, last round
};

Rounds MeasureRounds(const Options& options, const LoopSetup& setup, const RobotModel& model,
                     const std::vector<Scenario>& scenarios, std::vector<Case>& cases) {
  Rounds r;
  r.step_us.resize(scenarios.size());
  r.state_us.resize(scenarios.size());
  r.control_us.resize(scenarios.size());
  r.physics.resize(scenarios.size());
  for (int round = 0; round < options.rounds; ++round) {
    r.trips.push_back(MeasureRoundTrips(setup.url, setup.model_file, model, options.round_trips,
                                        options.warmup, false));
    r.trips_setpoint.push_back(MeasureRoundTrips(setup.url, setup.model_file, model,
                                                 options.round_trips, options.warmup, true));
    if (!options.dump.empty()) {
      FILE* file = std::fopen(options.dump.c_str(), round == 0 ? "w" : "a");
      if (file == nullptr) throw std::runtime_error("cannot write " + options.dump);
      for (double us : r.trips.back().us) std::fprintf(file, "%.2f\n", us);
      std::fclose(file);
    }
    for (size_t s = 0; s < scenarios.size(); ++s) {
      r.physics[s] = RunPhysics(model, scenarios[s], options.duration_s);
      r.step_us[s].push_back(r.physics[s].step_us);
      r.state_us[s].push_back(r.physics[s].state_us);
      r.control_us[s].push_back(r.physics[s].control_us);
    }
    for (Case& one : cases) {
      const LoopRun run =
          RunLoop(setup, scenarios[one.scenario], one.setpoints, options.duration_s);
      const double limit = 1e6 / (r.trips.back().mean_us + r.physics[one.scenario].step_us);
      one.rates.push_back(run.ticks_per_s);
      one.limits.push_back(limit);
      one.ratios.push_back(run.ticks_per_s / limit);
      one.steps = run.steps;
      one.timeouts += run.timeouts;
      one.sim_final = run.final_line;
      one.replica_final = FormatPositions(r.physics[one.scenario].final_position);
      one.same_trajectory = one.same_trajectory && one.sim_final == one.replica_final;
    }
  }
  return r;
}

std::string CaseLabel(const std::vector<Scenario>& scenarios, const Case& one) {
  return scenarios[one.scenario].name + (one.setpoints ? ", set-points on " : ", set-points off");
}

// (b): the physics step per scenario, median of rounds; returns those medians.
std::vector<double> PrintSteps(const std::vector<Scenario>& scenarios, const Rounds& r) {
  std::printf(
      "\n(b) physics step (ArmWorld::Step, friction on) on the loop's own trajectory, mean "
      "per step, median of rounds\n");
  std::vector<double> step_median(scenarios.size());
  for (size_t s = 0; s < scenarios.size(); ++s) {
    step_median[s] = Median(r.step_us[s]);
    std::printf(
        "  %-5s step %6.2f us (rounds: %s; %4.1f constraint rows); also per tick: "
        "ArmWorld::State %.2f us, ServoBank::Tick %.2f us\n",
        scenarios[s].name.c_str(), step_median[s], Join(r.step_us[s], 2).c_str(), r.physics[s].rows,
        Median(r.state_us[s]), Median(r.control_us[s]));
  }
  return step_median;
}

// (c): each case's ticks/s against its limit; returns whether every case met the goal.
bool PrintLoop(const std::vector<Scenario>& scenarios, const std::vector<Case>& cases,
               const std::vector<double>& step_median, double rtt_median, const LoopRun& fixed) {
  std::printf(
      "\n(c) the loop: sirupp-sim --mode lockstep + sirupp-control as processes; ticks/s = "
      "steps / wall time from the sim's start line to its exit (includes %.1f ms of "
      "fixed cost, measured with a %ld-tick run)\n",
      fixed.wall_s * 1e3, fixed.steps);
  std::printf(
      "    limit = 1 / (that round's mean round trip + step); ratio = loop / limit, "
      "median of rounds\n");
  bool all_met = true;
  for (const Case& one : cases) {
    const std::string label = CaseLabel(scenarios, one);
    const double ratio = Median(one.ratios);
    const bool met = ratio >= kGoal;
    all_met = all_met && met;
    const double strict_limit = 1e6 / (rtt_median + step_median[one.scenario]);
    std::printf(
        "  %s %6.0f ticks/s (rounds: %s)  limit %6.0f  ratio %.2f (rounds: %s)  goal %.1f: "
        "%s\n",
        label.c_str(), Median(one.rates), Join(one.rates, 0).c_str(), Median(one.limits), ratio,
        Join(one.ratios, 2).c_str(), kGoal, met ? "met" : "NOT met");
    std::printf("  %*s against the median round trip instead: limit %6.0f, ratio %.2f%s\n",
                static_cast<int>(label.size()), "", strict_limit, Median(one.rates) / strict_limit,
                one.timeouts > 0
                    ? ("; " + std::to_string(one.timeouts) + " lockstep timeouts").c_str()
                    : "");
    if (!one.same_trajectory) {
      std::printf(
          "  %*s the sim ended at%s, the replica in (b) at%s: (b) did not time the same "
          "trajectory\n",
          static_cast<int>(label.size()), "", one.sim_final.c_str(), one.replica_final.c_str());
    }
  }
  return all_met;
}

// Each case's tick split into the physics step and the rest, and what set-points cost.
void PrintPerTick(const RobotModel& model, const std::vector<Scenario>& scenarios,
                  const std::vector<Case>& cases, const Rounds& r,
                  const std::vector<double>& step_median, double rtt_median, double rtt_mean) {
  const double message_us = MessageWorkUs(model, false, 20000);
  const double message_setpoint_us = MessageWorkUs(model, true, 20000);
  std::printf(
      "\nPer tick, us (1 / median ticks/s) = physics step + the rest; the round trip is "
      "median %.1f, mean %.1f\n",
      rtt_median, rtt_mean);
  for (const Case& one : cases) {
    const double loop_us = 1e6 / Median(one.rates);
    const double step = step_median[one.scenario];
    const double cpu_us = Median(r.state_us[one.scenario]) + Median(r.control_us[one.scenario]) +
                          (one.setpoints ? message_setpoint_us : message_us);
    std::printf(
        "  %s %6.1f = %5.1f + %5.1f   (of the rest, %.1f is computing: ArmWorld::State, "
        "ServoBank::Tick, message translation and coding)\n",
        CaseLabel(scenarios, one).c_str(), loop_us, step, loop_us - step, cpu_us);
  }
  for (size_t s = 0; s < scenarios.size(); ++s) {
    const double on = 1e6 / Median(cases[2 * s].rates);
    const double off = 1e6 / Median(cases[2 * s + 1].rates);
    std::printf("  ARM_SETPOINT every tick costs the %s loop %.1f us per tick (%.0f %%)\n",
                scenarios[s].name.c_str(), on - off, 100 * (on - off) / on);
  }
}

int Run(const Options& options) {
  const std::string model_file = FindModel(options.model);
  const RobotModel model = sirupp::core::LoadRobotModel(model_file);
  if (!options.pong_url.empty()) {
    return RunPong(options.pong_url, options.pong_setpoint, options.pong_direct, model);
  }
  if (!options.ping_url.empty()) {
    return RunPacedPing(options.ping_url, options.scale_seconds, options.pace_ticks, model);
  }
  if (!options.scale.empty()) {
    std::printf("Load average at start: %s (%u CPUs)\n", LoadAverage().c_str(),
                std::thread::hardware_concurrency());
    std::vector<ScaleRun> runs;
    for (size_t i = 0; i < options.scale.size(); ++i) {
      runs.push_back(MeasureScale(model_file, model, options.port + static_cast<int>(i) * 64,
                                  options.scale[i], options.scale_seconds, options.pace_ticks));
    }
    PrintScale(model, runs, options.pace_ticks);
    std::printf("Load average at end: %s\n", LoadAverage().c_str());
    return 0;
  }
  if (options.law_only) {
    std::printf("Load average at start: %s (%u CPUs)\n", LoadAverage().c_str(),
                std::thread::hardware_concurrency());
    PrintLawIsolation(
        MeasureLawIsolation(model, SIRUPP_PD_GRAVITY_LIB, options.law_calls, options.warmup),
        SIRUPP_PD_GRAVITY_LIB);
    std::printf("Load average at end: %s\n", LoadAverage().c_str());
    return 0;
  }
  const LoopSetup setup = MakeSetup(options, model_file, model);
  const std::vector<Scenario> scenarios = MakeScenarios(model);
  std::vector<Case> cases = MakeCases(scenarios.size());

  std::printf("Loop benchmark: %s (%d joints), step %.3f ms, on %s\n", model.name.c_str(),
              model.num_joints(), model.servo_tick_s * 1e3, setup.url.c_str());
  std::printf(
      "%d rounds, each: %d round trips (after %d), the physics replica, one loop run of "
      "%.3g simulated s per case\n",
      options.rounds, options.round_trips, options.warmup, options.duration_s);
  std::printf(
      "Load average at start: %s (%u CPUs; other work on the machine inflates every "
      "figure)\n",
      LoadAverage().c_str(), std::thread::hardware_concurrency());

  // The window the loop is timed in also holds a fixed cost (the sim's last messages, summary and
  // exit): measured once with a 1-tick run.
  const LoopRun fixed = RunLoop(setup, scenarios[0], true, model.servo_tick_s);
  const Rounds rounds = MeasureRounds(options, setup, model, scenarios, cases);

  std::vector<double> pooled;
  for (const RoundTrips& round : rounds.trips)
    pooled.insert(pooled.end(), round.us.begin(), round.us.end());
  const double rtt_mean = Mean(pooled);
  const double rtt_median = Median(pooled);
  std::printf(
      "\n(a) LCM round trip over udpm, arm_state_t out, arm_command_t back (%d joints), "
      "rounds pooled\n",
      model.num_joints());
  PrintRoundTrips("state -> command", rounds.trips);
  PrintRoundTrips("state -> command, then ARM_SETPOINT (diagnostic)", rounds.trips_setpoint);
  const std::vector<double> step_median = PrintSteps(scenarios, rounds);
  const bool all_met = PrintLoop(scenarios, cases, step_median, rtt_median, fixed);
  PrintPerTick(model, scenarios, cases, rounds, step_median, rtt_median, rtt_mean);
  PrintLawIsolation(
      MeasureLawIsolation(model, SIRUPP_PD_GRAVITY_LIB, options.law_calls, options.warmup),
      SIRUPP_PD_GRAVITY_LIB);
  const bool all_same =
      std::all_of(cases.begin(), cases.end(), [](const Case& one) { return one.same_trajectory; });
  std::printf("\nThe in-process replica %s the sim's final joint positions (%ld steps per run)\n",
              all_same ? "matches" : "does NOT match", cases.front().steps);
  std::printf("Load average at end: %s\n", LoadAverage().c_str());
  std::printf("Goal loop / limit >= %.1f: %s\n", kGoal, all_met ? "met in every case" : "NOT met");
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return Run(ParseOptions(argc, argv));
  } catch (const std::invalid_argument& error) {
    std::fprintf(stderr, "bench_loop: %s\n", error.what());
    return 2;
  } catch (const std::exception& error) {
    std::fprintf(stderr, "bench_loop: %s\n", error.what());
    return 1;
  }
}
