// bench_physics: physics steps per second of the PUMA 260 in sirupp's ODE world at the default
// step (the PIC-SERVO tick, 0.512 ms), with joint friction, with and without publishing every
// state on LCM; and, when MuJoCo (libmujoco-dev) is installed, the same arm in MuJoCo (same masses,
// inertias, armature, viscous damping, Coulomb friction as frictionloss, contacts off, same step),
// stepped in the same run. Both engines follow the same reference motion (reference_motion.hpp).
//
// Usage: bench_physics [--seconds S] [--rounds N] [--model FILE]
//   S: simulated seconds per timed run (default 4); N: rounds, engines alternating, best kept (3).
// Figures are printed as steps per second and as a ratio ours / MuJoCo (goal: >= 1.0).

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <sirupp/arm_state_t.hpp>
#include <string>
#include <vector>

#include "bench/reference_motion.hpp"
#include "core/bus.hpp"
#include "core/model_loader.hpp"
#include "core/translate.hpp"
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

void Print(const char* label, const Figure& figure, double step_s) {
  std::printf("  %-46s %9.0f steps/s  %6.2f us/step  %6.0fx real time", label, figure.steps_per_s,
              1e6 / figure.steps_per_s, figure.steps_per_s * step_s);
  if (figure.mean_rows > 0) std::printf("  %4.1f rows", figure.mean_rows);
  std::printf("\n");
}

void KeepBest(Figure& best, const Figure& figure) {
  if (figure.steps_per_s > best.steps_per_s) best = figure;
}

}  // namespace

int main(int argc, char** argv) {
  double seconds = 4;
  int rounds = 3;
  std::string model_file = "config/robots/puma260.yaml";
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string flag = argv[i];
    if (flag == "--seconds") {
      seconds = std::atof(argv[i + 1]);
    } else if (flag == "--rounds") {
      rounds = std::atoi(argv[i + 1]);
    } else if (flag == "--model") {
      model_file = argv[i + 1];
    } else {
      std::fprintf(stderr, "bench_physics: unknown flag %s\n", flag.c_str());
      return 2;
    }
  }
  if (!(seconds > 0) || rounds < 1) {
    std::fprintf(stderr, "bench_physics: --seconds must be > 0 and --rounds >= 1\n");
    return 2;
  }
  const RobotModel model = sirupp::core::LoadRobotModel(FindModel(model_file));
  const double step = model.servo_tick_s;
  // LCM: multicast on this machine only (ttl=0); memq:// if multicast cannot be used here.
  std::string url = "udpm://239.255.76.67:7799?ttl=0";
  std::unique_ptr<sirupp::core::Bus> bus;
  try {
    bus = std::make_unique<sirupp::core::Bus>(url);
    bus->Publish("SIM_ARM_STATE", sirupp::core::ToMessage(sirupp::core::ArmState{}, 0));
  } catch (const std::exception& error) {
    std::printf("(udpm unusable here: %s; publishing to memq:// instead)\n", error.what());
    url = "memq://";
    bus = std::make_unique<sirupp::core::Bus>(url);
  }

  std::printf("Physics benchmark: %s, step %.3f ms, %.1f simulated s per run, best of %d rounds\n",
              model.name.c_str(), step * 1e3, seconds, rounds);
  std::printf("Reference motion: bench/reference_motion.hpp (clamped PD on slow sinusoids)\n");
  Figure ode_friction, ode_publish, ode_plain, mj_friction, mj_plain;
  for (int round = 0; round < rounds; ++round) {
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
  return 0;
}
