// sirupp-notebook-bridge: one side of the bus bridge between a student's rig and their notebook
// sandbox (class/notebook_bridge.hpp). Started by the hub's spawner (hub/sirupp_hub), one line:
//   outside: sirupp-notebook-bridge --lcm udpm://239.255.76.67:7901?ttl=0 --listen RUN/bus.sock
//   inside:  sirupp-notebook-bridge --lcm udpm://239.255.76.67:7667?ttl=0 --connect RUN/bus.sock
// Ends on SIGTERM or SIGINT; the connecting side also when the connection ends and cannot be made
// again within --wait.

#include <iostream>

#include "class/notebook_bridge.hpp"
#include "core/errors.hpp"
#include "runtime/args.hpp"
#include "runtime/process_main.hpp"

namespace {

using sirupp::core::UsageError;
using sirupp::runtime::Args;
using sirupp::runtime::Flag;

constexpr const char* kAbout =
    "Carries every LCM message of one bus both ways over a Unix socket to its peer, which does\n"
    "the same on another bus: a student's rig bus outside their notebook sandbox (--listen) and\n"
    "the sandbox's own bus inside it (--connect). What a side publishes is not sent back.\n";

int Run(const std::vector<std::string>& argv) {
  const Args args(
      argv, "sirupp-notebook-bridge",
      {Flag("lcm", "the bus this side joins (udpm://...?ttl=0 or memq://)").Takes("URL"),
       Flag("listen", "listen on this Unix socket (the outer side)").Takes("PATH"),
       Flag("connect", "connect to this Unix socket (the inner side)").Takes("PATH"),
       Flag("wait", "--connect: seconds to wait for the socket (default 10)")
           .Takes("S")
           .Range(0.1, 600)},
      kAbout);
  if (!args.Has("lcm")) throw UsageError("sirupp-notebook-bridge: --lcm is required");
  if (args.Has("listen") == args.Has("connect")) {
    throw UsageError("sirupp-notebook-bridge: give one of --listen PATH and --connect PATH");
  }
  sirupp::classroom::BridgeOptions options;
  options.lcm_url = args.String("lcm");
  options.listen = args.Has("listen");
  options.socket_path = args.String(options.listen ? "listen" : "connect");
  options.connect_wait_s = args.Number("wait", 10);
  options.keep_running = [] { return !sirupp::runtime::StopRequested(); };
  options.log = [](const std::string& line) {
    std::cerr << "sirupp-notebook-bridge: " << line << std::endl;
  };
  sirupp::runtime::InstallStopHandlers();
  const auto [out, in] = sirupp::classroom::RunBridge(options);
  std::cerr << "sirupp-notebook-bridge: stopped (" << out << " message(s) to the peer, " << in
            << " from it)" << std::endl;
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return sirupp::runtime::ProcessMain(argc, argv, "sirupp-notebook-bridge", Run);
}
