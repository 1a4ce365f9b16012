// arm_watch: watches both arms for the fault tests. Listens for --seconds (default 1) to
// SIM_ARM_STATE (the virtual arm) and REAL_ARM_STATE (the real or emulated arm) and prints, per
// arm, one line with the number of states and, per joint in degrees, the newest position and the
// lowest and highest seen:
//
//   virtual 1890 states: last 10.000 -90.000 ... min 9.998 -90.010 ... max 10.002 -89.990 ...
//   real 98 states: last ... min ... max ...
//
// An arm that sent nothing prints "virtual 0 states". Every joint is treated as revolute
// (radians on the wire, degrees here): enough for the PUMA 260 the tests run.
// Usage: arm_watch [--lcm-url URL] [--prefix P] [--seconds S]. Exit 0; 2 on bad arguments.

#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <sirupp/arm_state_t.hpp>
#include <string>
#include <vector>

#include "core/bus.hpp"

namespace {

struct Watch {
  long states = 0;
  std::vector<double> last, low, high;

  void Add(const sirupp::arm_state_t& m) {
    if (m.num_joints < 1 || m.position.size() != static_cast<size_t>(m.num_joints)) return;
    if (last.size() != m.position.size()) {
      last.assign(m.position.size(), 0.0);
      low.assign(m.position.size(), std::numeric_limits<double>::infinity());
      high.assign(m.position.size(), -std::numeric_limits<double>::infinity());
    }
    for (size_t j = 0; j < m.position.size(); ++j) {
      const double deg = m.position[j] * 180.0 / M_PI;
      if (!std::isfinite(deg)) return;
      last[j] = deg;
      low[j] = std::min(low[j], deg);
      high[j] = std::max(high[j], deg);
    }
    ++states;
  }

  void Print(const char* name) const {
    std::printf("%s %ld states:", name, states);
    if (states > 0) {
      const char* labels[3] = {"last", "min", "max"};
      const std::vector<double>* rows[3] = {&last, &low, &high};
      for (int r = 0; r < 3; ++r) {
        std::printf(" %s", labels[r]);
        for (double v : *rows[r]) std::printf(" %.3f", v);
      }
    }
    std::printf("\n");
  }
};

}  // namespace

int main(int argc, char** argv) {
  std::string url, prefix;
  double seconds = 1.0;
  for (int i = 1; i < argc; i += 2) {
    const std::string flag = argv[i];
    if (i + 1 >= argc) {
      std::fprintf(stderr, "arm_watch: %s needs a value\n", flag.c_str());
      return 2;
    }
    if (flag == "--lcm-url") {
      url = argv[i + 1];
    } else if (flag == "--prefix") {
      prefix = argv[i + 1];
    } else if (flag == "--seconds") {
      seconds = std::atof(argv[i + 1]);
    } else {
      std::fprintf(stderr, "arm_watch: unknown flag %s\n", flag.c_str());
      return 2;
    }
  }
  try {
    sirupp::core::Bus bus(url, prefix);
    Watch virtual_arm, real_arm;
    bus.Subscribe<sirupp::arm_state_t>(
        "SIM_ARM_STATE",
        [&virtual_arm](const sirupp::arm_state_t& m, const sirupp::core::ReceiveInfo&) {
          virtual_arm.Add(m);
        },
        10000);
    bus.Subscribe<sirupp::arm_state_t>(
        "REAL_ARM_STATE",
        [&real_arm](const sirupp::arm_state_t& m, const sirupp::core::ReceiveInfo&) {
          real_arm.Add(m);
        },
        10000);
    const auto end = std::chrono::steady_clock::now() +
                     std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                         std::chrono::duration<double>(seconds));
    while (std::chrono::steady_clock::now() < end) {
      bus.Handle(20);
      bus.HandleAvailable();
    }
    virtual_arm.Print("virtual");
    real_arm.Print("real");
  } catch (const std::exception& error) {
    std::fprintf(stderr, "arm_watch: %s\n", error.what());
    return 1;
  }
  return 0;
}
