// bench_physics: physics steps per second of the PUMA 260 in sirupp's ODE world at the default
// step (the PIC-SERVO tick, 0.512 ms), with joint friction, with and without publishing every
// state on LCM; and, when MuJoCo (libmujoco-dev) is installed, the same arm in MuJoCo (same masses,
// inertias, armature, viscous damping, Coulomb friction as frictionloss, contacts off, same step),
// stepped in the same run. Both engines follow the same reference motion (reference_motion.hpp).
//
// Usage: bench_physics [--seconds S] [--rounds N] [--model FILE] [--static-only]
//   S: simulated seconds per timed run (default 4); N: rounds, engines alternating, best kept (3).
// Figures are printed as steps per second and as a ratio ours / MuJoCo (goal: >= 1.0).
// Then the cost of static environment objects: the same motion among 0, 1000, 10 000 and
// core::kMaxStaticObjects static boxes on the floor, microseconds per step against the 512 us of
// real time (--static-only: this part alone).

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <optional>
#include <sirupp/arm_state_t.hpp>
#include <string>
#include <vector>

#include "bench/reference_motion.hpp"
#include "core/bus.hpp"
#include "core/model_loader.hpp"
#include "core/translate.hpp"
#include "proc/rig.hpp"
#include "sim/arm_world.hpp"
#ifdef SIRUPP_HAVE_MUJOCO
#include "bench/mujoco_arm.hpp"
#endif

namespace {

using sirupp::core::RobotModel;
using Clock = std::chrono::steady_clock;

std::string FindModel(const std::string& path) {
  namespace fs = std::filesystem;
  for (const fs::path& base : {fs::path("."), fs::path(".."), fs::path("../..")}) {
    if (fs::exists(base / path)) return (base / path).string();
  }
  return path;
}

struct Figure {
  double steps_per_s = 0;
  double mean_rows = 0;
};

// Steps the ODE arm through `seconds` of the reference motion; publishes each state on `bus` if
// given.
Figure RunOde(const RobotModel& model, bool friction, double seconds, sirupp::core::Bus* bus) {
  sirupp::sim::WorldOptions options;
  options.friction = friction;
  sirupp::sim::ArmWorld world(model, sirupp::core::Environment{}, options);
  world.SetJointState(sirupp::bench::ReferencePosition(model, 0));
  sirupp::core::ArmCommand command;
  command.mode = sirupp::core::CommandMode::kEffort;
  const auto steps = static_cast<long>(seconds / world.step_s());
  long rows = 0;
  int64_t seq = 0;
  const Clock::time_point start = Clock::now();
  for (long k = 0; k < steps; ++k) {
    const sirupp::core::ArmState state = world.State();
    if (bus != nullptr) bus->Publish("SIM_ARM_STATE", sirupp::core::ToMessage(state, seq++));
    command.effort =
        sirupp::bench::ReferenceEffort(model, world.time_s(), state.position, state.velocity);
    world.Step(command);
    rows += world.LastStepRows();
  }
  const double wall = std::chrono::duration<double>(Clock::now() - start).count();
  return {static_cast<double>(steps) / wall,
          static_cast<double>(rows) / static_cast<double>(steps)};
}

#ifdef SIRUPP_HAVE_MUJOCO
Figure RunMujoco(const RobotModel& model, bool friction, double seconds) {
  sirupp::bench::MujocoArm arm(model, model.servo_tick_s, friction);
  arm.SetPositions(sirupp::bench::ReferencePosition(model, 0));
  const auto steps = static_cast<long>(seconds / model.servo_tick_s);
  const Clock::time_point start = Clock::now();
  for (long k = 0; k < steps; ++k) {
    arm.Step(sirupp::bench::ReferenceEffort(model, arm.time(), arm.Positions(), arm.Velocities()));
  }
  const double wall = std::chrono::duration<double>(Clock::now() - start).count();
  return {static_cast<double>(steps) / wall, 0};
}
#endif

// `count` static 2 cm cubes on the floor in front of the arm, 4 cm apart in rows of 100 (4 m wide).
sirupp::core::Environment StaticBoxes(int count) {
  sirupp::core::Environment environment;
  environment.name = "boxes";
  for (int i = 0; i < count; ++i) {
    sirupp::core::EnvironmentObject box;
    box.name = "box" + std::to_string(i);
    box.shape.type = sirupp::core::ShapeType::kBox;
    box.shape.size_m = {0.02, 0.02, 0.02};
    box.shape.pose.position_m = {0.35 + 0.04 * (i / 100), -2.0 + 0.04 * (i % 100), 0.01};
    environment.objects.push_back(box);
  }
  return environment;
}

// `count` free 2 cm cubes of 20 g resting on a static floor slab in front of the arm, 5 cm apart.
sirupp::core::Environment FreeBoxes(int count) {
  sirupp::core::Environment environment;
  environment.name = "free boxes";
  sirupp::core::EnvironmentObject floor;
  floor.name = "floor";
  floor.shape.type = sirupp::core::ShapeType::kBox;
  floor.shape.size_m = {4.0, 4.0, 0.02};
  floor.shape.pose.position_m = {2.5, 0, -0.01};
  environment.objects.push_back(floor);
  for (int i = 0; i < count; ++i) {
    sirupp::core::EnvironmentObject box;
    box.name = "free" + std::to_string(i);
    box.is_static = false;
    box.mass_kg = 0.02;
    box.shape.type = sirupp::core::ShapeType::kBox;
    box.shape.size_m = {0.02, 0.02, 0.02};
    box.shape.pose.position_m = {0.6 + 0.05 * (i / 20), -0.5 + 0.05 * (i % 20), 0.01};
    environment.objects.push_back(box);
  }
  return environment;
}

// Microseconds per step of the reference motion among `count` static boxes: at least `min_steps`
// steps and `min_wall_s` of wall time (after building the world), best of `rounds`.
double StepMicros(const RobotModel& model, const sirupp::core::Environment& environment,
                  int min_steps, double min_wall_s, int rounds, double* build_s) {
  double best = 1e300;
  for (int round = 0; round < rounds; ++round) {
    const Clock::time_point built = Clock::now();
    sirupp::sim::ArmWorld world(model, environment);
    if (build_s != nullptr) *build_s = std::chrono::duration<double>(Clock::now() - built).count();
    world.SetJointState(sirupp::bench::ReferencePosition(model, 0));
    sirupp::core::ArmCommand command;
    command.mode = sirupp::core::CommandMode::kEffort;
    const Clock::time_point start = Clock::now();
    long steps = 0;
    double wall = 0;
    while (steps < min_steps || wall < min_wall_s) {
      const sirupp::core::ArmState state = world.State();
      command.effort =
          sirupp::bench::ReferenceEffort(model, world.time_s(), state.position, state.velocity);
      world.Step(command);
      ++steps;
      wall = std::chrono::duration<double>(Clock::now() - start).count();
    }
    best = std::min(best, wall * 1e6 / static_cast<double>(steps));
  }
  return best;
}

void PrintStaticObjects(const RobotModel& model, int rounds) {
  std::printf("Static objects (2 cm boxes on the floor), same motion, best of %d rounds:\n",
              rounds);
  const double tick_us = model.servo_tick_s * 1e6;
  const double base = StepMicros(model, StaticBoxes(0), 2000, 0.5, rounds, nullptr);
  std::vector<int> counts = {0, 1000, 10000};
  const auto static_limit = static_cast<int>(sirupp::core::kMaxStaticObjects);
  if (static_limit != counts.back()) counts.push_back(static_limit);
  for (const int count : counts) {
    double build_s = 0;
    const double us =
        count == 0 ? base : StepMicros(model, StaticBoxes(count), 200, 0.5, rounds, &build_s);
    std::printf("  %6d boxes: %9.2f us/step  %6.1fx real time  %5.2fx the empty world's step",
                count, us, tick_us / us, us / base);
    if (count > 0) std::printf("  (built in %.3f s)", build_s);
    std::printf("\n");
  }
  std::printf("Free objects (2 cm cubes resting on a static floor slab), same motion:\n");
  const auto free_limit = static_cast<int>(sirupp::core::kMaxFreeObjects);
  for (const int count : {10, free_limit, 4 * free_limit}) {
    const double us = StepMicros(model, FreeBoxes(count), 200, 0.5, rounds, nullptr);
    std::printf("  %6d cubes: %9.2f us/step  %6.1fx real time  %5.2fx the empty world's step\n",
                count, us, tick_us / us, us / base);
  }
}

void Print(const char* label, const Figure& figure, double step_s) {
  std::printf("  %-46s %9.0f steps/s  %6.2f us/step  %6.0fx real time", label, figure.steps_per_s,
              1e6 / figure.steps_per_s, figure.steps_per_s * step_s);
  if (figure.mean_rows > 0) std::printf("  %4.1f rows", figure.mean_rows);
  std::printf("\n");
}

void KeepBest(Figure& best, const Figure& figure) {
  if (figure.steps_per_s > best.steps_per_s) best = figure;
}

struct Options {
  double seconds = 4;
  int rounds = 3;
  std::string model_file = "config/robots/puma260.yaml";
  bool static_only = false;
};

// The options, or nullopt after a message on stderr.
std::optional<Options> ParseOptions(int argc, char** argv) {
  Options options;
  for (int i = 1; i < argc; i += 2) {
    const std::string flag = argv[i];
    if (flag == "--static-only") {
      options.static_only = true;
      --i;
      continue;
    }
    if (i + 1 >= argc) {
      std::fprintf(stderr, "bench_physics: %s needs a value\n", flag.c_str());
      return std::nullopt;
    }
    if (flag == "--seconds") {
      options.seconds = std::atof(argv[i + 1]);
    } else if (flag == "--rounds") {
      options.rounds = std::atoi(argv[i + 1]);
    } else if (flag == "--model") {
      options.model_file = argv[i + 1];
    } else {
      std::fprintf(stderr, "bench_physics: unknown flag %s\n", flag.c_str());
      return std::nullopt;
    }
  }
  if (!(options.seconds > 0) || options.rounds < 1) {
    std::fprintf(stderr, "bench_physics: --seconds must be > 0 and --rounds >= 1\n");
    return std::nullopt;
  }
  return options;
}

// LCM: multicast on this machine only (ttl=0); memq:// if multicast cannot be used here. Sets
// `url` to the one used.
std::unique_ptr<sirupp::core::Bus> OpenBus(std::string& url) {
  url = sirupp::proc::RigUrl(7799);
  std::unique_ptr<sirupp::core::Bus> bus;
  try {
    bus = std::make_unique<sirupp::core::Bus>(url);
    bus->Publish("SIM_ARM_STATE", sirupp::core::ToMessage(sirupp::core::ArmState{}, 0));
  } catch (const std::exception& error) {
    std::printf("(udpm unusable here: %s; publishing to memq:// instead)\n", error.what());
    url = "memq://";
    bus = std::make_unique<sirupp::core::Bus>(url);
  }
  return bus;
}

// Our ODE world with and without friction and with LCM publishing, and MuJoCo when built with
// it: the best of the rounds of each, printed with the ratios.
void CompareEngines(const RobotModel& model, const Options& options) {
  const double step = model.servo_tick_s;
  std::string url;
  const std::unique_ptr<sirupp::core::Bus> bus = OpenBus(url);
  const double seconds = options.seconds;
  std::printf("Physics benchmark: %s, step %.3f ms, %.1f simulated s per run, best of %d rounds\n",
              model.name.c_str(), step * 1e3, seconds, options.rounds);
  std::printf("Reference motion: bench/reference_motion.hpp (clamped PD on slow sinusoids)\n");
  Figure ode_friction, ode_publish, ode_plain, mj_friction, mj_plain;
  for (int round = 0; round < options.rounds; ++round) {
    KeepBest(ode_friction, RunOde(model, true, seconds, nullptr));
#ifdef SIRUPP_HAVE_MUJOCO
    KeepBest(mj_friction, RunMujoco(model, true, seconds));
#endif
    KeepBest(ode_plain, RunOde(model, false, seconds, nullptr));
#ifdef SIRUPP_HAVE_MUJOCO
    KeepBest(mj_plain, RunMujoco(model, false, seconds));
#endif
    KeepBest(ode_publish, RunOde(model, true, seconds, bus.get()));
  }
  Print("sirupp ODE, friction", ode_friction, step);
  const std::string publish_label = "sirupp ODE, friction, state on LCM (" +
                                    std::string(url.rfind("udpm", 0) == 0 ? "udpm" : "memq") + ")";
  Print(publish_label.c_str(), ode_publish, step);
  Print("sirupp ODE, no friction", ode_plain, step);
#ifdef SIRUPP_HAVE_MUJOCO
  const std::string mj = "MuJoCo " + sirupp::bench::MujocoVersion();
  Print((mj + ", frictionloss").c_str(), mj_friction, step);
  Print((mj + ", no friction").c_str(), mj_plain, step);
  std::printf("Ratio ours / MuJoCo, friction:    %.2f (goal >= 1.0)\n",
              ode_friction.steps_per_s / mj_friction.steps_per_s);
  std::printf("Ratio ours / MuJoCo, no friction: %.2f\n",
              ode_plain.steps_per_s / mj_plain.steps_per_s);
  std::printf("Ratio with LCM publishing / MuJoCo (friction): %.2f\n",
              ode_publish.steps_per_s / mj_friction.steps_per_s);
#else
  std::printf(
      "MuJoCo not installed (scripts/install-deps.sh --peers adds libmujoco-dev): no ratio\n");
#endif
}

}  // namespace

int main(int argc, char** argv) {
  const std::optional<Options> options = ParseOptions(argc, argv);
  if (!options) return 2;
  const RobotModel model = sirupp::core::LoadRobotModel(FindModel(options->model_file));
  if (!options->static_only) CompareEngines(model, *options);
  PrintStaticObjects(model, options->rounds);
  return 0;
}
