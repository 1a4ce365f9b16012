// bench_senders: what 100 000 distinct senders on SIM_ARM_COMMAND cost sirupp-sim's tick (issue
// 23: bounded state per sender). In this process, on a memq:// bus: SimNode in lockstep with one
// registered participant ("bench", a PD law answering every state), stepping the PUMA 260.
//
//  (a) before: T ticks, the wall time of each;
//  (b) during: the same, with S / T commands from new, never-seen senders published before each
//      tick (S = 100 000 in all), each refused as "not a registered participant" and counted;
//  (c) after: T ticks again with no extra traffic.
//
// Prints the median and p99 tick time of each phase, the ratios (b)/(a) and (c)/(a), the sim's
// refusal count, and the process's resident memory before and after. Goal: (c)/(a) about 1 (the
// sim's state per sender is bounded, so 100 000 senders leave nothing that slows later ticks).
// Usage: bench_senders [--ticks T] [--senders S] [--model FILE]

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <optional>
#include <sirupp/arm_command_t.hpp>
#include <sirupp/arm_state_t.hpp>
#include <string>
#include <vector>

#include "core/bus.hpp"
#include "core/model_loader.hpp"
#include "sim/arm_world.hpp"
#include "sim/sim_node.hpp"

namespace {

using Clock = std::chrono::steady_clock;

long ResidentKiB() {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind("VmRSS:", 0) == 0) return std::stol(line.substr(6));
  }
  return -1;
}

struct Figures {
  double median_us = 0;
  double p99_us = 0;
};

Figures Summarise(std::vector<double> us) {
  std::sort(us.begin(), us.end());
  Figures f;
  f.median_us = us[us.size() / 2];
  f.p99_us = us[std::min(us.size() - 1, us.size() * 99 / 100)];
  return f;
}

constexpr const char* kUsage = "usage: bench_senders [--ticks T] [--senders S] [--model FILE]\n";

struct Options {
  int ticks = 4000;
  int senders = 100000;
  std::string model_path = "config/robots/puma260.yaml";
};

// The options, or nullopt after a message on stderr.
std::optional<Options> ParseOptions(int argc, char** argv) {
  Options options;
  for (int i = 1; i < argc; ++i) {
    const bool has_value = i + 1 < argc;
    if (std::strcmp(argv[i], "--ticks") == 0 && has_value) {
      options.ticks = std::atoi(argv[++i]);
    } else if (std::strcmp(argv[i], "--senders") == 0 && has_value) {
      options.senders = std::atoi(argv[++i]);
    } else if (std::strcmp(argv[i], "--model") == 0 && has_value) {
      options.model_path = argv[++i];
    } else {
      std::fprintf(stderr, "bench_senders: unknown argument '%s'\n%s", argv[i], kUsage);
      return std::nullopt;
    }
  }
  if (options.ticks < 100 || options.senders < 0) {
    std::fprintf(stderr, "bench_senders: allowed --ticks >= 100, --senders >= 0\n%s", kUsage);
    return std::nullopt;
  }
  return options;
}

// A lockstep sim with one participant, "bench", that answers every state with a PD effort.
class LockstepRig {
 public:
  explicit LockstepRig(const sirupp::core::RobotModel& model)
      : bus_("memq://"),
        world_(model, sirupp::core::Environment{}),
        node_(bus_, world_, sirupp::core::Environment{}, Lockstep()) {
    bus_.Subscribe<sirupp::arm_state_t>(
        "SIM_ARM_STATE", [this](const sirupp::arm_state_t& state,
                                const sirupp::core::ReceiveInfo&) { Answer(state); });
    stranger_.mode = sirupp::arm_command_t::MODE_EFFORT;
    stranger_.num_joints = model.num_joints();
    stranger_.effort.assign(static_cast<size_t>(model.num_joints()), 0.0);
  }

  // Runs `n` ticks, publishing `per_tick` strangers' commands (up to `senders` in all) before
  // each; the wall time of each.
  Figures Phase(int n, int per_tick, int senders) {
    std::vector<double> us;
    us.reserve(static_cast<size_t>(n));
    for (int k = 0; k < n; ++k) {
      for (int s = 0; s < per_tick && next_sender_ < senders; ++s, ++next_sender_) {
        stranger_.sender = "stranger-" + std::to_string(next_sender_);
        stranger_.seq = next_sender_;
        stranger_.tick = world_.tick();
        bus_.Publish("SIM_ARM_COMMAND", stranger_);
      }
      const int64_t before = world_.tick();
      const auto t0 = Clock::now();
      while (world_.tick() == before) node_.Service(0);
      us.push_back(std::chrono::duration<double, std::micro>(Clock::now() - t0).count());
    }
    return Summarise(us);
  }

  int senders_used() const { return next_sender_; }
  const sirupp::sim::SimNode& node() const { return node_; }

 private:
  static sirupp::sim::NodeOptions Lockstep() {
    sirupp::sim::NodeOptions options;
    options.mode = sirupp::sim::TimingMode::kLockstep;
    options.participants = {"bench"};
    return options;
  }

  void Answer(const sirupp::arm_state_t& state) {
    sirupp::arm_command_t command{};
    command.tick = state.tick;
    command.utime = state.utime;
    command.seq = seq_++;
    command.sender = "bench";
    command.mode = sirupp::arm_command_t::MODE_EFFORT;
    command.num_joints = state.num_joints;
    for (int j = 0; j < state.num_joints; ++j) {
      const auto u = static_cast<size_t>(j);
      command.effort.push_back(-20.0 * state.position[u] - 0.5 * state.velocity[u]);
    }
    bus_.Publish("SIM_ARM_COMMAND", command);
  }

  sirupp::core::Bus bus_;
  sirupp::sim::ArmWorld world_;
  sirupp::sim::SimNode node_;
  sirupp::arm_command_t stranger_{};
  int64_t seq_ = 0;
  int next_sender_ = 0;
};

}  // namespace

int main(int argc, char** argv) {
  const std::optional<Options> options = ParseOptions(argc, argv);
  if (!options) return 2;
  const int ticks = options->ticks;
  const int senders = options->senders;
  const sirupp::core::RobotModel model = sirupp::core::LoadRobotModel(options->model_path);
  LockstepRig rig(model);
  rig.Phase(500, 0, senders);  // warm-up
  const long rss_before = ResidentKiB();
  const Figures a = rig.Phase(ticks, 0, senders);
  const Figures b = rig.Phase(ticks, (senders + ticks - 1) / ticks, senders);
  const Figures c = rig.Phase(ticks, 0, senders);
  const long rss_after = ResidentKiB();
  const auto& counters = rig.node().counters();
  std::printf("bench_senders: %d ticks per phase, %d distinct senders in phase (b), model %s\n",
              ticks, rig.senders_used(), model.name.c_str());
  std::printf("  (a) before:  median %.1f us, p99 %.1f us per tick\n", a.median_us, a.p99_us);
  std::printf("  (b) during:  median %.1f us, p99 %.1f us per tick (with the refusals)\n",
              b.median_us, b.p99_us);
  std::printf("  (c) after:   median %.1f us, p99 %.1f us per tick\n", c.median_us, c.p99_us);
  std::printf("  ratio (b)/(a) %.2f, (c)/(a) %.2f (goal for (c): about 1)\n",
              b.median_us / a.median_us, c.median_us / a.median_us);
  std::printf("  lockstep timeouts (a state sent again for want of an answer): %lld\n",
              static_cast<long long>(counters.lockstep_timeouts));
  std::printf("  commands refused: %lld; resident memory %ld KiB before, %ld KiB after\n",
              static_cast<long long>(counters.commands_rejected), rss_before, rss_after);
  return 0;
}
