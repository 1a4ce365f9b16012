#include "class/rig.hpp"

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "core/bus.hpp"
#include "core/model_loader.hpp"
#include "panel/panel_api.hpp"
#include "panel/panel_hub.hpp"
#include "proc/rig.hpp"

namespace sirupp::classroom {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

double Since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// utime + stime of a process in clock ticks; 0 when it is gone.
double ProcessTicks(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/stat");
  std::string text;
  std::getline(in, text);
  const size_t close = text.rfind(')');
  if (close == std::string::npos) return 0;
  std::istringstream fields(text.substr(close + 2));
  std::string field;
  double ticks = 0;
  // After the name: state is field 3; utime and stime are fields 14 and 15.
  for (int i = 3; i <= 15 && fields >> field; ++i) {
    if (i == 14 || i == 15) ticks += std::strtod(field.c_str(), nullptr);
  }
  return ticks;
}

}  // namespace

RigPanel::~RigPanel() {
  if (hub) hub->Stop();
  api.reset();
  hub.reset();
  bus.reset();
}

std::string RigUrl(int port) { return proc::RigUrl(port); }

Rig::Rig(RigSpec spec, ProcessLauncher& launcher) : spec_(std::move(spec)), launcher_(launcher) {}

Rig::~Rig() { Stop(); }

std::string Rig::url() const { return RigUrl(spec_.port); }

void Rig::Launch(const std::string& name, const proc::ProcessSpec& process) {
  {
    std::ofstream note(process.log_path, std::ios::app);
    note << "--- sirupp class: starting " << name << " on " << url() << "\n";
  }
  children_.push_back(Child{name, proc::Child()});
  children_.back().process.Start(process, pgid_, &launcher_);
  if (pgid_ == 0) pgid_ = children_.back().process.group();
}

void Rig::Start() {
  const auto start = Clock::now();
  fs::create_directories(spec_.folder + "/logs");
  fs::create_directories(spec_.folder + "/results");
  auto rig_panel = std::make_shared<RigPanel>();
  rig_panel->bus = std::make_unique<core::Bus>(url(), "");
  panel::HubOptions hub_options;
  hub_options.fallback_model = core::LoadRobotModel(spec_.robot);
  rig_panel->hub = std::make_unique<panel::PanelHub>(*rig_panel->bus, hub_options);
  panel::ApiOptions api_options;
  api_options.root = spec_.folder;
  api_options.results_dir = spec_.folder + "/results";
  rig_panel->api = std::make_unique<panel::PanelApi>(*rig_panel->hub, api_options);
  rig_panel->hub->Start();
  panel_ = rig_panel;
  try {
    proc::RigSpec rig;
    rig.port = spec_.port;
    rig.bin_dir = spec_.bin_dir;
    rig.model = spec_.robot;
    rig.pace_ticks = spec_.pace_ticks;
    rig.controller = spec_.controller;
    rig.results_dir = spec_.folder + "/results";
    rig.log_dir = spec_.folder + "/logs";
    rig.limits = spec_.limits;
    rig.death_signal = SIGTERM;
    double ready_s = spec_.ready_timeout_s;
    // Past the controller host's 10 s load limit, so its reason is the one given.
    if (!spec_.controller.empty()) ready_s += 15;
    for (const proc::RigProcess& process : proc::RigProcesses(rig)) {
      Launch(process.name, process.spec);
    }
    while (true) {
      const std::string ended = CheckProcesses();
      if (!ended.empty()) throw std::runtime_error(ended);
      if (rig_panel->hub->VirtualJoints() && rig_panel->hub->ControllerStatus()) break;
      if (Since(start) > ready_s) {
        throw std::runtime_error("the rig was not ready within " +
                                 std::to_string(static_cast<int>(ready_s)) +
                                 " s (no arm state or controller status on " + url() + ")");
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
  } catch (...) {
    Stop();
    throw;
  }
  start_s_ = Since(start);
  cpu_at_ = Clock::now();
  cpu_ticks_ = 0;
  for (const pid_t pid : pids()) cpu_ticks_ += ProcessTicks(pid);
}

std::string Rig::CheckProcesses() {
  std::string ended;
  for (Child& child : children_) {
    if (child.process.ended() || child.process.Running()) continue;
    if (ended.empty()) {
      const int status = child.process.status();
      std::ostringstream text;
      text << child.name << " ended ("
           << (WIFSIGNALED(status) ? "signal " + std::to_string(WTERMSIG(status))
                                   : "exit status " + std::to_string(WEXITSTATUS(status)))
           << "): " << child.process.LogTail(1);
      ended = text.str();
    }
  }
  return ended;
}

std::vector<pid_t> Rig::pids() const {
  std::vector<pid_t> out;
  for (const Child& child : children_) {
    if (!child.process.ended()) out.push_back(child.process.pid());
  }
  return out;
}

double Rig::CpuPercent() {
  double ticks = 0;
  for (const pid_t pid : pids()) ticks += ProcessTicks(pid);
  const auto now = Clock::now();
  const double seconds = std::chrono::duration<double>(now - cpu_at_).count();
  const double used = (ticks - cpu_ticks_) / static_cast<double>(::sysconf(_SC_CLK_TCK));
  cpu_ticks_ = ticks;
  cpu_at_ = now;
  return seconds > 0 && used >= 0 ? 100.0 * used / seconds : 0.0;
}

void Rig::Stop() {
  if (pgid_ != 0) {
    // SIGINT to the group: each process ends its own way (the logger closes its files).
    ::kill(-pgid_, SIGINT);
    const auto start = Clock::now();
    while (!pids().empty() && Since(start) < spec_.stop_grace_s) {
      CheckProcesses();
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    // Then SIGKILL to the group, each child reaped, and back only when nothing of the group (what
    // the rig's processes started in it too) is left: the port is given back after this.
    for (Child& child : children_) child.process.Stop(0);
    proc::KillGroup(pgid_);
    pgid_ = 0;
  }
  children_.clear();
  if (panel_) {
    panel_->hub->Stop();  // open event streams end; the objects go with the last of them
    panel_.reset();
  }
}

}  // namespace sirupp::classroom
