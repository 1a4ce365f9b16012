#include "tools/class_commands.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <ostream>
#include <stdexcept>
#include <thread>

#include "class/class_config.hpp"
#include "class/class_server.hpp"
#include "class/hub_api.hpp"
#include "core/errors.hpp"
#include "grade/notebook_assignment.hpp"
#include "runtime/args.hpp"
#include "runtime/data_path.hpp"
#include "runtime/process_main.hpp"
#include "tools/launch_commands.hpp"

namespace sirupp::tools {
namespace {

const char* const kServeAbout =
    "Serves a class on this computer: a private rig per student (sim, control, logger and the\n"
    "panel's page), started on the student's first visit, stopped after the class file's idle\n"
    "timeout; the teacher's page at /teacher/. Issues missing tokens first and appends their\n"
    "addresses to DATA/tokens.csv. Ctrl-C stops every rig. See docs/class.md.\n";

runtime::Flag ClassFileFlag() {
  return runtime::Flag("class-file", "the class file (docs/class.md)").Positional("CLASS.yaml");
}

const char* const kNotebooksAbout =
    "Runs the class's notebooks hub: JupyterHub (Debian's /usr/bin/jupyterhub) as the current\n"
    "user, its proxy on 127.0.0.1:notebooks.hub_port (the hub's API on hub_port+1, the proxy's\n"
    "API on hub_port+2), each student's notebook server in a sandbox of its own wired to their\n"
    "rig. Writes the hub's configuration into DATA/hub/ first. The class server (sirupp class\n"
    "serve) must run beside it: the hub asks it who a browser is and where the rig is.\n"
    "Ctrl-C stops the hub; running notebook servers stay and a restarted hub finds them again\n"
    "(each stops itself after notebooks.idle_timeout_s). See docs/notebooks.md.\n";

// Whether 127.0.0.1:port can be bound now (nothing listens there).
bool PortFree(int port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return false;
  // As a server binds: a port a stopped hub left in TIME_WAIT is free.
  const int reuse = 1;
  ::setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &reuse, sizeof reuse);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(static_cast<uint16_t>(port));
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  const bool free = ::bind(fd, reinterpret_cast<const sockaddr*>(&address), sizeof address) == 0;
  ::close(fd);
  return free;
}

// The folder of the Python module `sirupp`: the build tree's build/python, or the installed one.
std::string SiruppPythonDir() {
  namespace fs = std::filesystem;
  const fs::path built = fs::path(ProgramDir()).parent_path() / "python";
  if (fs::exists(built / "sirupp" / "__init__.py")) return built.string();
  const fs::path installed =
      fs::path(runtime::DataDir()).parent_path().parent_path() / "lib/python3/dist-packages";
  if (fs::exists(installed / "sirupp" / "__init__.py")) return installed.string();
  throw core::UsageError("the Python module sirupp is in neither " + built.string() + " nor " +
                         installed.string() + "; build it (sirupp_python_module) or install it");
}

// The folder holding the hub's Python package sirupp_hub (hub/ of the tree, or installed).
std::string HubPackageDir() {
  namespace fs = std::filesystem;
  const fs::path dir = fs::absolute(fs::path(runtime::DataDir()) / "hub").lexically_normal();
  if (!fs::exists(dir / "sirupp_hub" / "spawner.py")) {
    throw core::UsageError(dir.string() +
                           "/sirupp_hub is missing (the hub's authenticator and "
                           "spawner); reinstall the package");
  }
  return dir.string();
}

// The refusals of `sirupp class notebooks`, each one line naming what to change.
void CheckHubCanRun(const classroom::ClassConfig& config,
                    const classroom::NotebooksConfig& notebooks, const std::string& jupyterhub) {
  if (notebooks.hub_url.empty()) {
    throw core::UsageError(config.file +
                           ": notebooks.hub_url is not set: the hub needs the address browsers "
                           "reach it at (its own hostname, docs/notebooks.md)");
  }
  if (config.port == 0) {
    throw core::UsageError(config.file +
                           ": server.port is 0 (any free port): the hub must know the class "
                           "server's port; give it a fixed one");
  }
  if (::access(jupyterhub.c_str(), X_OK) != 0) {
    throw core::UsageError(jupyterhub +
                           ": not installed (JupyterHub 3.0 from Debian 12: apt-get install "
                           "jupyterhub, or scripts/install-deps.sh --services)");
  }
  if (::access("/usr/bin/configurable-http-proxy", X_OK) != 0) {
    throw core::UsageError(
        "/usr/bin/configurable-http-proxy: not installed (apt-get install "
        "node-configurable-http-proxy)");
  }
  const std::pair<int, const char*> ports[] = {{notebooks.hub_port, "the hub's proxy"},
                                               {notebooks.hub_port + 1, "the hub's API"},
                                               {notebooks.hub_port + 2, "the proxy's API"}};
  for (const auto& [port, what] : ports) {
    if (port > 65535 || !PortFree(port)) {
      throw core::UsageError(config.file + ": notebooks.hub_port " +
                             std::to_string(notebooks.hub_port) + ": port " + std::to_string(port) +
                             " (" + what +
                             ") is in use on 127.0.0.1 (a hub already running, or another "
                             "program); the hub takes hub_port, hub_port+1 and hub_port+2");
    }
  }
}

// DATA/hub/hub.json: what hub/sirupp_hub reads (config.py, spawner.py).
nlohmann::json HubSettings(const classroom::ClassConfig& config,
                           const classroom::NotebooksConfig& notebooks, const std::string& hub_dir,
                           double poll) {
  const std::string listen =
      config.listen == "0.0.0.0" || config.listen == "::" ? "127.0.0.1" : config.listen;
  const std::string host = listen.find(':') != std::string::npos ? "[" + listen + "]" : listen;
  return nlohmann::json{{"class_name", config.name},
                        {"class_url", std::string(config.tls_cert.empty() ? "http" : "https") +
                                          "://" + host + ":" + std::to_string(config.port)},
                        {"hub_secret_file", classroom::HubSecretFile(config)},
                        {"data_dir", config.data_dir},
                        {"students_dir", config.data_dir + "/students"},
                        {"run_dir", hub_dir + "/run"},
                        {"notebooks_dir", notebooks.folder},
                        {"idle_timeout_s", notebooks.idle_timeout_s},
                        {"memory_mb", notebooks.memory_mb},
                        {"processes", notebooks.processes},
                        {"hub_url", notebooks.hub_url},
                        {"hub_port", notebooks.hub_port},
                        {"hub_api_host", "127.0.0.1"},
                        {"hub_api_port", notebooks.hub_port + 1},
                        {"proxy_api_port", notebooks.hub_port + 2},
                        {"poll_interval_s", poll},
                        {"bin_dir", ProgramDir()},
                        {"python_dir", SiruppPythonDir()},
                        {"hub_dir", HubPackageDir()},
                        {"user_header", config.front ? config.front->user_header : ""}};
}

// Becomes /usr/bin/jupyterhub in DATA/hub (throws only when it cannot).
void ExecHub(const std::string& jupyterhub, const std::string& hub_dir,
             const std::string& config_file) {
  // Debian's proxy finds its modules only with NODE_PATH when another node is first on PATH
  // (NodeSource's); the classic notebook server, even when jupyter-server is installed.
  const char* node_path = std::getenv("NODE_PATH");
  const std::string nodes = std::string("/usr/share/nodejs:/usr/lib/nodejs") +
                            (node_path && *node_path ? std::string(":") + node_path : "");
  ::setenv("NODE_PATH", nodes.c_str(), 1);
  ::setenv("JUPYTERHUB_SINGLEUSER_APP", "notebook.notebookapp.NotebookApp", 1);
  if (::chdir(hub_dir.c_str()) != 0) {
    throw core::UsageError(hub_dir + ": cannot enter: " + std::strerror(errno));
  }
  std::vector<std::string> argv_text = {jupyterhub, "-f", config_file};
  std::vector<char*> argv;
  for (std::string& word : argv_text) argv.push_back(word.data());
  argv.push_back(nullptr);
  ::execv(jupyterhub.c_str(), argv.data());
  throw core::UsageError(jupyterhub + ": cannot run: " + std::strerror(errno));
}

}  // namespace

int RunClassNotebooks(const std::vector<std::string>& args, std::ostream& out) {
  namespace fs = std::filesystem;
  const runtime::Args parsed(
      args, "class notebooks",
      {ClassFileFlag(),
       runtime::Flag("jupyterhub", "the hub's program (default /usr/bin/jupyterhub)").Takes("PATH"),
       runtime::Flag("poll-interval",
                     "seconds between the hub's checks of each server (default: "
                     "a quarter of notebooks.idle_timeout_s, 2 to 30)")
           .Takes("S")
           .Range(0.5, 300),
       runtime::Flag("idle-timeout",
                     "override notebooks.idle_timeout_s (tests: below its 60 s "
                     "minimum)")
           .Takes("S")
           .Range(1, 604800)},
      kNotebooksAbout);
  const classroom::ClassConfig config = classroom::LoadClassConfig(parsed.String("class-file"));
  if (!config.notebooks) {
    throw core::UsageError(config.file +
                           ": no notebooks: key; add one with hub_url and hub_port "
                           "(docs/notebooks.md) to give the class notebooks");
  }
  classroom::NotebooksConfig notebooks = *config.notebooks;
  if (parsed.Has("idle-timeout")) notebooks.idle_timeout_s = parsed.Number("idle-timeout", 0);
  const std::string jupyterhub =
      parsed.Has("jupyterhub") ? parsed.String("jupyterhub") : "/usr/bin/jupyterhub";
  CheckHubCanRun(config, notebooks, jupyterhub);
  classroom::EnsureHubSecret(config);
  const std::string hub_dir = config.data_dir + "/hub";
  fs::create_directories(hub_dir + "/run");
  fs::permissions(hub_dir, fs::perms::owner_all, fs::perm_options::replace);
  const double poll = parsed.Has("poll-interval")
                          ? parsed.Number("poll-interval", 30)
                          : std::max(2.0, std::min(30.0, notebooks.idle_timeout_s / 4));
  const nlohmann::json settings = HubSettings(config, notebooks, hub_dir, poll);
  const std::string settings_file = hub_dir + "/hub.json";
  std::ofstream(settings_file) << settings.dump(2) << "\n";
  const std::string config_file = hub_dir + "/jupyterhub_config.py";
  std::ofstream(config_file) << "# Written by `sirupp class notebooks` for the class "
                             << config.name
                             << " (docs/notebooks.md); the settings are in hub.json beside it.\n"
                             << "import sys\nsys.path.insert(0, "
                             << nlohmann::json(settings["hub_dir"]).dump()
                             << ")\nfrom sirupp_hub.config import configure\nconfigure(c, "
                             << nlohmann::json(settings_file).dump() << ")\n";
  out << "sirupp class notebooks: " << config.name
      << ": the hub on http://127.0.0.1:" << notebooks.hub_port
      << " (browsers: " << notebooks.hub_url << "), the class server at "
      << settings["class_url"].get<std::string>() << ", configuration " << config_file << std::endl;
  ExecHub(jupyterhub, hub_dir, config_file);
  return 1;  // ExecHub returns only by throwing
}

int RunClassCheck(const std::vector<std::string>& args, std::ostream& out) {
  const runtime::Args parsed(args, "class check", {ClassFileFlag()},
                             "Checks a class file; prints what it sets up.\n");
  const classroom::ClassConfig config = classroom::LoadClassConfig(parsed.String("class-file"));
  // Notebook assignments: each one's hidden tests read as the server will (names, points).
  std::string notebook_lines;
  if (config.notebooks) {
    for (const classroom::NotebookAssignment& assignment : config.notebooks->assignments) {
      std::vector<grade::NotebookTest> tests;
      try {
        tests = grade::ReadNotebookTests(assignment.tests);
      } catch (const std::runtime_error& error) {
        throw core::UsageError(config.file + ": notebooks: assignments: " + assignment.name + ": " +
                               error.what());
      }
      const std::string exposed = grade::HiddenTestsExposed(assignment.tests, ProgramDir());
      if (!exposed.empty()) {
        throw core::UsageError(config.file + ": notebooks: assignments: " + assignment.name +
                               ": tests: " + exposed);
      }
      double points = 0;
      for (const grade::NotebookTest& test : tests) points += test.points;
      notebook_lines += "  notebook assignment " + assignment.name + ": " + assignment.notebook +
                        ", " + std::to_string(tests.size()) + " hidden tests, " +
                        core::FormatApprox(points) + " points\n";
    }
  }
  out << config.file << ": ok: class " << config.name << ", " << config.students.size()
      << " students, robot " << config.robot << ", at most " << config.max_rigs << " rigs ("
      << (config.pin_rigs ? "each on one CPU, " : "") << "sims pacing " << config.pace_ticks
      << " ticks per sleep), idle timeout " << config.idle_timeout_s << " s, data "
      << config.data_dir << ", listens on " << config.listen << ":" << config.port
      << (config.tls_cert.empty() ? "" : " (HTTPS)") << "\n";
  if (config.real_arm) {
    out << "  real arm: the bridge on " << config.real_arm->lcm_url << ", turns of "
        << core::FormatApprox(config.real_arm->turn_s) << " s\n";
  }
  if (!config.grading_suite.empty()) {
    out << "  grading: " << config.grading_suite << "\n";
  }
  out << notebook_lines;
  return 0;
}

int RunClassTokens(const std::vector<std::string>& args, std::ostream& out) {
  const runtime::Args parsed(
      args, "class tokens",
      {ClassFileFlag(),
       runtime::Flag("reissue",
                     "a new token for NAME (a student, or teacher); the old one stops "
                     "working")
           .Takes("NAME")},
      "Issues the missing tokens (or, with --reissue, a new one), appends each address to\n"
      "DATA/tokens.csv and prints it. Tokens are stored hashed: an address cannot be shown again,\n"
      "only reissued. Takes effect in a running server at once.\n");
  const classroom::ClassConfig config = classroom::LoadClassConfig(parsed.String("class-file"));
  std::vector<std::pair<std::string, std::string>> rows;
  if (parsed.Has("reissue")) {
    rows.push_back(classroom::ReissueToken(config, config.port, parsed.String("reissue")));
  } else {
    rows = classroom::IssueMissingTokens(config, config.port);
  }
  for (const auto& [name, address] : rows) out << name << "," << address << "\n";
  out << rows.size() << " token(s) issued; every address so far: " << classroom::HandoutFile(config)
      << "\n";
  return 0;
}

int RunClassServe(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  const runtime::Args parsed(args, "class serve",
                             {ClassFileFlag(),
                              runtime::Flag("port", "override the class file's port (0: any free)")
                                  .Takes("N")
                                  .Integer(0, 65535),
                              runtime::Flag("duration", "stop after S seconds (tests)").Takes("S")},
                             kServeAbout);
  classroom::ClassConfig config = classroom::LoadClassConfig(parsed.String("class-file"));
  if (parsed.Has("port")) config.port = static_cast<int>(parsed.Integer("port", config.port));
  const double duration = parsed.Number("duration", 0);
  if (parsed.Has("duration") && !(duration > 0)) {
    throw core::UsageError("--duration " + parsed.String("duration") + ": expected seconds > 0");
  }
  classroom::ServeOptions options;
  options.bin_dir = ProgramDir();
  options.panel_web_dir = runtime::ResolveDataPath("panel/web");
  options.class_web_dir = runtime::ResolveDataPath("class/web");
  options.config_dir = runtime::ResolveDataPath("config");
  options.log = &err;
  runtime::InstallStopHandlers();
  classroom::ClassServer server(config, options);
  const int port = server.Bind();
  for (const auto& [name, address] : classroom::IssueMissingTokens(config, port)) {
    out << "new token: " << name << "," << address << "\n";
  }
  out << "sirupp class: " << config.name << " at " << classroom::BaseUrl(config, port)
      << "/ (teacher: " << classroom::BaseUrl(config, port)
      << "/teacher/?token=...; every address: " << classroom::HandoutFile(config) << ")"
      << std::endl;
  std::thread serving([&] { server.Serve(); });
  const auto start = std::chrono::steady_clock::now();
  while (!runtime::StopRequested() &&
         (duration <= 0 ||
          std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() <
              duration)) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  err << "sirupp class: stopping every rig\n";
  server.Stop();
  serving.join();
  return 0;
}

}  // namespace sirupp::tools
