// sirupp-panel: the lab panel in the browser. Thin main over panel/: the hub on the bus, the API
// and the HTTP server; prints the address (with the token when one is in force) and serves until
// Ctrl-C or SIGTERM.

#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <random>
#include <sstream>
#include <thread>

#include "core/bus.hpp"
#include "core/errors.hpp"
#include "core/model_loader.hpp"
#include "panel/panel_api.hpp"
#include "panel/panel_hub.hpp"
#include "panel/panel_server.hpp"
#include "runtime/args.hpp"
#include "runtime/data_path.hpp"
#include "runtime/process_main.hpp"

namespace {

using sirupp::runtime::Flag;

using sirupp::core::UsageError;
using sirupp::runtime::Args;

// The address shown when the panel listens on every interface.
std::string HostName() {
  char name[256] = {};
  if (::gethostname(name, sizeof name - 1) != 0) return "localhost";
  return name;
}
namespace panel = sirupp::panel;

constexpr const char* kAbout =
    "Serves the lab panel in the browser: the 3D view, joints, tool, plans, gains, plots, the\n"
    "real arm, processes, model and environment, live from the bus. Binds 127.0.0.1:8765 by\n"
    "default (this computer only). --listen ADDR (e.g. 0.0.0.0) opens it to a lab network; a\n"
    "token is then printed and every request that changes anything must carry it (open the\n"
    "printed address); --require-token asks for it on 127.0.0.1 too. --port 0: any free port.\n"
    "--rate HZ: the fastest live stream a page may ask for (60). --results DIR: a folder the\n"
    "page may read besides config/. --model FILE: drawn until ROBOT_MODEL arrives. --open\n"
    "starts a browser (xdg-open) when there is a display. See panel/README.md.\n";

std::string MakeToken() {
  std::random_device random;
  std::ostringstream text;
  text << std::hex;
  for (int i = 0; i < 4; ++i) text << random();
  return text.str();
}

int Run(const std::vector<std::string>& argv) {
  const Args args(
      argv, "sirupp-panel",
      {Flag("port", "0: any free port").Takes("N").Integer(0, 65535),
       Flag("listen", "address to bind (default 127.0.0.1; others need the token)").Takes("ADDR"),
       Flag("require-token", "ask for the printed token even on 127.0.0.1").Switch(),
       Flag("rate", "at most this many live updates per second to each page (0 < HZ <= 240)")
           .Takes("HZ"),
       Flag("results", "folder of recorded runs and reports").Takes("DIR"),
       sirupp::runtime::ModelFlag(),
       Flag("open", "open the page in a browser when there is a display").Switch(),
       Flag("duration", "exit after S seconds").Takes("S"),
       Flag("lcm-ticks",
            "the per-tick channels through LCM (one wake-up per datagram) instead of the panel's "
            "batched reader: for comparison")
           .Switch(),
       Flag("lcm-url", "LCM URL").Takes("URL"),
       Flag("prefix", "channel prefix of the rig").Takes("PREFIX")},
      kAbout);
  panel::ServerOptions server_options;
  server_options.port = static_cast<int>(args.Integer("port", server_options.port));
  if (args.Has("listen")) server_options.listen = args.String("listen");
  if (args.Has("rate")) {
    const double rate = args.Numbers("rate", 1)[0];
    if (!(rate > 0 && rate <= 240)) {
      throw UsageError("sirupp-panel: --rate " + sirupp::core::FormatNumber(rate) +
                       ": allowed > 0 and <= 240 frames per second");
    }
    server_options.max_rate_hz = rate;
  }
  const double duration_s = args.Has("duration") ? args.Numbers("duration", 1)[0] : 0;
  if (args.Has("duration") && !(duration_s > 0)) {
    throw UsageError("sirupp-panel: --duration " + sirupp::core::FormatNumber(duration_s) +
                     ": must be > 0 seconds");
  }
  server_options.web_dir = sirupp::runtime::ResolveDataPath("panel/web");

  panel::HubOptions hub_options;
  hub_options.batch_ticks = !args.Switch("lcm-ticks");
  if (args.Has("model")) {
    hub_options.fallback_model =
        sirupp::core::LoadRobotModel(sirupp::runtime::ResolveDataPath(args.String("model")));
  }
  panel::ApiOptions api_options;
  api_options.root = std::filesystem::path(sirupp::runtime::ResolveDataPath("config/plans"))
                         .parent_path()
                         .parent_path()
                         .string();
  if (api_options.root.empty()) api_options.root = ".";
  if (args.Has("results")) api_options.results_dir = args.String("results");
  api_options.require_token =
      args.Switch("require-token") || !panel::IsLoopback(server_options.listen);
  if (api_options.require_token) api_options.token = MakeToken();

  sirupp::core::Bus bus(args.Has("lcm-url") ? args.String("lcm-url") : "",
                        args.Has("prefix") ? args.String("prefix") : "");
  panel::PanelHub hub(bus, hub_options);
  panel::PanelApi api(hub, api_options);
  panel::PanelServer server(hub, api, server_options);
  const int port = server.Bind();
  const std::string host = server_options.listen == "0.0.0.0" ? HostName() : server_options.listen;
  std::string address = "http://" + host + ":" + std::to_string(port) + "/";
  if (api_options.require_token) address += "?token=" + api_options.token;
  std::cout << "sirupp-panel: " << address << std::endl;
  std::cerr << "sirupp-panel: on " << hub.url()
            << (hub.batching_ticks() ? " (per-tick channels read in 5 ms batches)" : "")
            << ", page files " << server_options.web_dir
            << (api_options.require_token ? "; changes need the token in the address" : "")
            << std::endl;
  hub.Start();
  std::thread serving([&] { server.Serve(); });
  if (args.Switch("open") && std::getenv("DISPLAY") != nullptr) {
    const pid_t child = fork();
    if (child == 0) {
      execlp("xdg-open", "xdg-open", address.c_str(), static_cast<char*>(nullptr));
      _exit(127);
    }
  }
  const auto start = std::chrono::steady_clock::now();
  sirupp::runtime::ServiceUntilSignal([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    return duration_s <= 0 ||
           std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() <
               duration_s;
  });
  hub.Stop();  // ends the event streams
  server.Stop();
  serving.join();
  std::cerr << "sirupp-panel: stopped; " << hub.states_received() << " arm states received\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return sirupp::runtime::ProcessMain(argc, argv, "sirupp-panel", Run);
}
