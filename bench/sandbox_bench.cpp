// What the sandbox (sandbox/, docs/sandbox.md) costs: starting sirupp-controller-host with
// example 02 loaded (IsolatedEffortLaw's constructor, as sirupp-control --controller and every
// grading task do) sandboxed and not, the per-tick call in both, and building example 02 from
// source (grade::BuildController, as `sirupp grade FILE.cpp` does) sandboxed and not. Prints
// medians; run from the source root:  build/bin/bench_sandbox [ROUNDS]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "control/isolated_law.hpp"
#include "core/model_loader.hpp"
#include "grade/build_controller.hpp"

namespace {

using Clock = std::chrono::steady_clock;

double Median(std::vector<double> values) {
  std::sort(values.begin(), values.end());
  return values[values.size() / 2];
}

double Since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

}  // namespace

int main(int argc, char** argv) {
  const int rounds = argc > 1 ? std::max(1, std::atoi(argv[1])) : 5;
  const sirupp::core::RobotModel model = sirupp::core::LoadRobotModel("config/robots/puma260.yaml");
  std::printf("%s\n", sirupp::sandbox::Describe(sirupp::sandbox::ProbeMachine(),
                                                sirupp::control::IsolationOptions{}.sandbox_limits)
                          .c_str());
  for (const bool sandboxed : {false, true}) {
    sirupp::control::IsolationOptions options;
    options.sandbox = sandboxed;
    std::vector<double> start_s, tick_us;
    for (int round = 0; round < rounds; ++round) {
      const Clock::time_point start = Clock::now();
      sirupp::control::IsolatedEffortLaw law(SIRUPP_PD_GRAVITY_LIB, "", model, options);
      start_s.push_back(Since(start));
      sirupp::core::ArmState state;
      state.position.assign(6, 0.1);
      state.velocity.assign(6, 0.0);
      state.effort.assign(6, 0.0);
      state.flags.assign(6, 0);
      sirupp::control::ControlInput input;
      input.state = &state;
      input.setpoint_position = state.position;
      input.setpoint_velocity = state.velocity;
      input.setpoint_acceleration = state.velocity;
      input.goal = state.position;
      std::vector<double> effort;
      law.Reset(input);
      const Clock::time_point ticks = Clock::now();
      for (int tick = 0; tick < 2000; ++tick) {
        input.tick = tick;
        law.Update(input, effort);
      }
      tick_us.push_back(Since(ticks) / 2000 * 1e6);
    }
    std::printf("host start with example 02 %-12s median %.3f s, one Update %.1f us (%d rounds)\n",
                sandboxed ? "sandboxed:" : "unconfined:", Median(start_s), Median(tick_us), rounds);
  }
  const std::filesystem::path out = std::filesystem::temp_directory_path() / "sirupp-bench-sandbox";
  for (const bool sandboxed : {false, true}) {
    sirupp::grade::BuildOptions options;
    options.include_dir = SIRUPP_INCLUDE_DIR;
    options.sandbox = sandboxed;
    std::vector<double> build_s;
    for (int round = 0; round < std::min(rounds, 3); ++round) {
      const sirupp::grade::BuildResult built = sirupp::grade::BuildController(
          {"examples/02_pd_gravity/pd_gravity.cpp"}, out.string(), "pd", options);
      if (!built.built) {
        std::fprintf(stderr, "bench_sandbox: the build failed: %s\n", built.problem.c_str());
        return 1;
      }
      build_s.push_back(built.seconds);
    }
    std::printf("build of example 02 %-12s median %.2f s\n",
                sandboxed ? "sandboxed:" : "unconfined:", Median(build_s));
  }
  std::filesystem::remove_all(out);
  return 0;
}
