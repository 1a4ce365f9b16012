// sim_probe: a minimal lockstep participant for process tests. Answers every SIM_ARM_STATE with a
// PD effort towards a fixed pose until it has seen the state of tick --ticks, then prints the
// number of states and an FNV-1a hash of their bytes (positions, velocities, efforts, flags), so
// two runs can be compared for bit-identical output. Exit 0 on success, 1 on timeout, 2 on bad
// arguments. As a broken student controller (--fault): `joints` sends one effort too few, `nan`
// sends NaN for joint 1; (--name gives a misspelled sender name).

#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <sirupp/arm_command_t.hpp>
#include <sirupp/arm_state_t.hpp>
#include <string>

#include "core/bus.hpp"

namespace {

uint64_t Fnv(uint64_t hash, const void* data, size_t size) {
  const auto* bytes = static_cast<const unsigned char*>(data);
  for (size_t i = 0; i < size; ++i) {
    hash ^= bytes[i];
    hash *= 1099511628211ULL;
  }
  return hash;
}

}  // namespace

int main(int argc, char** argv) {
  std::string url;
  std::string name = "probe";
  long ticks = 500;
  std::string fault;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string flag = argv[i];
    if (flag == "--lcm-url") {
      url = argv[i + 1];
    } else if (flag == "--name") {
      name = argv[i + 1];
    } else if (flag == "--ticks") {
      ticks = std::stol(argv[i + 1]);
    } else if (flag == "--fault" &&
               (std::strcmp(argv[i + 1], "joints") == 0 || std::strcmp(argv[i + 1], "nan") == 0)) {
      fault = argv[i + 1];
    } else {
      std::fprintf(stderr, "sim_probe: unknown flag %s\n", flag.c_str());
      return 2;
    }
  }
  sirupp::core::Bus bus(url);
  uint64_t hash = 14695981039346656037ULL;
  long states = 0;
  int64_t next_tick = 0;
  int64_t seq = 0;
  bool done = false;
  bus.Subscribe<sirupp::arm_state_t>(
      "SIM_ARM_STATE", [&](const sirupp::arm_state_t& state, const sirupp::core::ReceiveInfo&) {
        if (state.tick < next_tick) return;  // a state sent again while the sim waited
        next_tick = state.tick + 1;
        ++states;
        for (int j = 0; j < state.num_joints; ++j) {
          hash = Fnv(hash, &state.position[static_cast<size_t>(j)], sizeof(double));
          hash = Fnv(hash, &state.velocity[static_cast<size_t>(j)], sizeof(double));
          hash = Fnv(hash, &state.effort[static_cast<size_t>(j)], sizeof(double));
          hash = Fnv(hash, &state.flags[static_cast<size_t>(j)], 1);
        }
        if (state.tick >= ticks) {
          done = true;
          return;
        }
        sirupp::arm_command_t command{};
        command.utime = state.utime;
        command.seq = seq++;
        command.tick = state.tick;
        command.sender = name;
        command.mode = sirupp::arm_command_t::MODE_EFFORT;
        command.num_joints = state.num_joints;
        for (int j = 0; j < state.num_joints; ++j) {
          const double target = 0.3 * (j % 2 == 0 ? 1 : -1);
          command.effort.push_back(8.0 * (target - state.position[static_cast<size_t>(j)]) -
                                   0.4 * state.velocity[static_cast<size_t>(j)]);
        }
        if (fault == "joints") {
          command.effort.pop_back();
          command.num_joints = static_cast<int32_t>(command.effort.size());
        }
        if (fault == "nan") command.effort[0] = std::nan("");
        bus.Publish("SIM_ARM_COMMAND", command);
      });
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (!done && std::chrono::steady_clock::now() < deadline) bus.Handle(100);
  std::printf("states %ld hash %016llx\n", states, static_cast<unsigned long long>(hash));
  return done ? 0 : 1;
}
