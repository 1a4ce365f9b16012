// bench_nmc_poll: full status polls of the six PUMA modules per second that sirupp-hardware's
// bus master achieves, at 115200 and 230400 baud, against what the serial line's byte rate allows,
// measured in the same run.
//
// The arm is sirupp-picservo-emu's Emulator in this process, on a real pseudo-terminal, with its
// line timing on: a reply leaves no earlier than the command's and its own transmission time at the
// present baud (10 bits a byte), as on an RS-485 line. The bridge side is the real ArmLink: the
// vendor start-up at each baud, then ArmLink::Poll() (one NOP per module, reply = status, position,
// aux, position error) in a tight loop for S seconds.
//
// One poll = 6 x (4 command bytes + 9 reply bytes) = 78 bytes, so the line allows baud / 10 / 78
// polls per second (147.7 at 115200, 295.4 at 230400). Ratio = achieved / allowed; what is lost
// goes to the turnaround of each exchange (pty, two thread wake-ups, the emulator's tick loop).
// A second figure polls with the line timing off, i.e. the software alone.
//
// Usage: bench_nmc_poll [--seconds S] [--rounds R] [--model FILE]   (defaults 3, 3)

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "core/model_loader.hpp"
#include "hardware/arm_link.hpp"
#include "hardware/emulator.hpp"
#include "hardware/serial_port.hpp"

namespace {

using namespace sirupp;
using Clock = std::chrono::steady_clock;

struct Result {
  double polls_per_s = 0;
  double exchange_us = 0;
};

Result Measure(const core::RobotModel& model, int baud, double seconds, bool line_timing) {
  hardware::EmulatorOptions eo;
  eo.model = model;
  eo.line_timing = line_timing;
  hardware::Emulator emu(eo);
  emu.Start();
  hardware::BridgeSettings settings = hardware::DefaultBridgeSettings(model);
  settings.baud = baud;
  settings.reply_margin_ms = 50;
  hardware::SerialPort port(emu.device(), hardware::nmc::kPowerUpBaud);
  hardware::ArmLink link(model, settings, port);
  link.Connect();
  for (int i = 0; i < 20; ++i) link.Poll();  // warm-up
  const int64_t exchanges_before = link.bus().counters().exchanges;
  const auto start = Clock::now();
  int64_t polls = 0;
  int64_t failed = 0;
  while (std::chrono::duration<double>(Clock::now() - start).count() < seconds) {
    const hardware::ArmReading r = link.Poll();
    for (bool ok : r.answered) failed += ok ? 0 : 1;
    ++polls;
  }
  const double elapsed = std::chrono::duration<double>(Clock::now() - start).count();
  const int64_t exchanges = link.bus().counters().exchanges - exchanges_before;
  emu.Stop();
  if (failed > 0 || link.bus().counters().timeouts > 0) {
    std::printf("  warning: %lld failed exchanges, %lld timeouts during the run\n",
                static_cast<long long>(failed),
                static_cast<long long>(link.bus().counters().timeouts));
  }
  return {polls / elapsed, elapsed / static_cast<double>(exchanges) * 1e6};
}

}  // namespace

int main(int argc, char** argv) {
  double seconds = 3;
  int rounds = 3;
  std::string model_file = "config/robots/puma260.yaml";
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--seconds" && i + 1 < argc) {
      seconds = std::atof(argv[++i]);
    } else if (a == "--rounds" && i + 1 < argc) {
      rounds = std::atoi(argv[++i]);
    } else if (a == "--model" && i + 1 < argc) {
      model_file = argv[++i];
    } else {
      std::fprintf(stderr,
                   "usage: bench_nmc_poll [--seconds S] [--rounds R] [--model FILE]\n"
                   "bench_nmc_poll: unknown or incomplete argument '%s'\n",
                   a.c_str());
      return 2;
    }
  }
  if (!(seconds > 0) || rounds < 1) {
    std::fprintf(stderr, "bench_nmc_poll: --seconds must be > 0 and --rounds >= 1\n");
    return 2;
  }
  const core::RobotModel model = core::LoadRobotModel(model_file);
  const int n = model.num_joints();
  const double poll_bytes =
      n * (4.0 + static_cast<double>(hardware::nmc::ReplyLength(hardware::kPollItems)));
  std::printf("bench_nmc_poll: %s, %d modules, %.0f bytes per full poll, %d round(s) of %.1f s\n",
              model.name.c_str(), n, poll_bytes, rounds, seconds);
  for (int baud : {115200, 230400}) {
    const double allowed = baud / 10.0 / poll_bytes;
    std::vector<double> achieved;
    double exchange_us = 0;
    for (int r = 0; r < rounds; ++r) {
      const Result res = Measure(model, baud, seconds, true);
      achieved.push_back(res.polls_per_s);
      exchange_us = res.exchange_us;
    }
    std::sort(achieved.begin(), achieved.end());
    const double median = achieved[achieved.size() / 2];
    std::printf(
        "%6d baud: line allows %.1f polls/s; achieved %.1f polls/s (median of %d; range "
        "%.1f-%.1f), "
        "%.0f us per exchange (line time %.0f us)  ratio %.2f\n",
        baud, allowed, median, rounds, achieved.front(), achieved.back(), exchange_us,
        poll_bytes / n * 10.0 / baud * 1e6, median / allowed);
  }
  const Result software = Measure(model, 230400, seconds, false);
  std::printf("without line timing (software and pty only): %.1f polls/s, %.0f us per exchange\n",
              software.polls_per_s, software.exchange_us);
  return 0;
}
