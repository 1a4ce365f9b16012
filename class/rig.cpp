#include "class/rig.hpp"

#include <fcntl.h>
#include <sched.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/resource.h>
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

ProcessLauncher::ProcessLauncher() : thread_([this] { Loop(); }) {}

ProcessLauncher::~ProcessLauncher() {
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  thread_.join();
}

void ProcessLauncher::Loop() {
  std::unique_lock<std::mutex> lock(mutex_);
  while (true) {
    wake_.wait(lock, [this] { return stop_ || !tasks_.empty(); });
    if (tasks_.empty()) return;
    std::packaged_task<pid_t()> task = std::move(tasks_.front());
    tasks_.pop_front();
    lock.unlock();
    task();
    lock.lock();
  }
}

pid_t ProcessLauncher::Spawn(const std::vector<std::string>& argv, const std::string& log_file,
                             pid_t pgid, const ChildLimits& limits) {
  std::packaged_task<pid_t()> task([&argv, &log_file, pgid, limits] {
    // Everything the child needs is made before fork: after it only async-signal-safe calls.
    std::vector<std::string> words = argv;
    std::vector<char*> args;
    for (std::string& word : words) args.push_back(word.data());
    args.push_back(nullptr);
    const pid_t parent = ::getpid();
    cpu_set_t cpus;
    CPU_ZERO(&cpus);
    if (limits.cpu >= 0) CPU_SET(limits.cpu, &cpus);
    rlimit memory{};
    memory.rlim_cur = memory.rlim_max = static_cast<rlim_t>(limits.memory_mb) * 1024 * 1024;
#if defined(__SANITIZE_ADDRESS__)
    const bool limit_memory = false;
#else
    const bool limit_memory = limits.memory_mb > 0;
#endif
    const pid_t child = ::fork();
    if (child < 0) throw std::runtime_error("cannot start " + argv[0] + ": fork failed");
    if (child == 0) {
      ::setpgid(0, pgid);
      ::prctl(PR_SET_PDEATHSIG, SIGTERM);
      if (::getppid() != parent) ::_exit(111);  // the server died before prctl
      const int fd = ::open(log_file.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
      if (fd >= 0) {
        ::dup2(fd, 1);
        ::dup2(fd, 2);
        ::close(fd);
      }
      const int null_fd = ::open("/dev/null", O_RDONLY);
      if (null_fd >= 0) ::dup2(null_fd, 0);
      ::setpriority(PRIO_PROCESS, 0, limits.nice);
      if (limits.cpu >= 0) ::sched_setaffinity(0, sizeof cpus, &cpus);
      if (limit_memory) ::setrlimit(RLIMIT_AS, &memory);
      ::execv(args[0], args.data());
      ::_exit(127);
    }
    ::setpgid(child, pgid == 0 ? child : pgid);  // both sides, so no race with a quick kill
    return child;
  });
  std::future<pid_t> result = task.get_future();
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    tasks_.push_back(std::move(task));
  }
  wake_.notify_all();
  return result.get();
}

RigPanel::~RigPanel() {
  if (hub) hub->Stop();
  api.reset();
  hub.reset();
  bus.reset();
}

std::string RigUrl(int port) { return "udpm://239.255.76.67:" + std::to_string(port) + "?ttl=0"; }

Rig::Rig(RigSpec spec, ProcessLauncher& launcher) : spec_(std::move(spec)), launcher_(launcher) {}

Rig::~Rig() { Stop(); }

std::string Rig::url() const { return RigUrl(spec_.port); }

void Rig::Launch(const std::string& name, std::vector<std::string> argv) {
  argv.insert(argv.begin(), spec_.bin_dir + "/" + name);
  const std::string log = spec_.folder + "/logs/" + name + ".log";
  {
    std::ofstream note(log, std::ios::app);
    note << "--- sirupp class: starting " << name << " on " << url() << "\n";
  }
  const pid_t pid = launcher_.Spawn(argv, log, pgid_, spec_.limits);
  if (pgid_ == 0) pgid_ = pid;
  children_.push_back(Child{name, pid, false, 0});
}

std::string Rig::LogTail(const std::string& name) const {
  std::ifstream in(spec_.folder + "/logs/" + name + ".log");
  std::string line;
  std::string last;
  while (std::getline(in, line)) {
    if (!line.empty()) last = line;
  }
  return last;
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
    Launch("sirupp-sim", {"--mode", "realtime", "--pace-ticks", std::to_string(spec_.pace_ticks),
                          "--model", spec_.robot, "--lcm-url", url()});
    std::vector<std::string> control{"--model", spec_.robot, "--lcm-url", url()};
    double ready_s = spec_.ready_timeout_s;
    if (!spec_.controller.empty()) {
      control.insert(control.end(), {"--controller", spec_.controller});
      ready_s += 15;  // past the host's 10 s load limit, so its reason is the one given
    }
    Launch("sirupp-control", control);
    Launch("sirupp-logger",
           {"--out", spec_.folder + "/results", "--model", spec_.robot, "--lcm-url", url()});
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
    if (child.ended) continue;
    int status = 0;
    if (::waitpid(child.pid, &status, WNOHANG) == child.pid) {
      child.ended = true;
      child.status = status;
      if (ended.empty()) {
        std::ostringstream text;
        text << child.name << " ended ("
             << (WIFSIGNALED(status) ? "signal " + std::to_string(WTERMSIG(status))
                                     : "exit status " + std::to_string(WEXITSTATUS(status)))
             << "): " << LogTail(child.name);
        ended = text.str();
      }
    }
  }
  return ended;
}

std::vector<pid_t> Rig::pids() const {
  std::vector<pid_t> out;
  for (const Child& child : children_) {
    if (!child.ended) out.push_back(child.pid);
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
    ::kill(-pgid_, SIGINT);
    const auto start = Clock::now();
    while (!pids().empty() && Since(start) < spec_.stop_grace_s) {
      CheckProcesses();
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    if (!pids().empty()) ::kill(-pgid_, SIGKILL);
    for (Child& child : children_) {
      if (!child.ended) {
        ::waitpid(child.pid, &child.status, 0);
        child.ended = true;
      }
    }
    // What the rig's processes started in their group ends too, before the port is given back:
    // nothing of this rig may talk on it when the next rig starts there.
    const auto killed = Clock::now();
    while (::kill(-pgid_, 0) == 0 && Since(killed) < spec_.stop_grace_s) {
      ::kill(-pgid_, SIGKILL);
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    pgid_ = 0;
  }
  children_.clear();
  if (panel_) {
    panel_->hub->Stop();  // open event streams end; the objects go with the last of them
    panel_.reset();
  }
}

}  // namespace sirupp::classroom
