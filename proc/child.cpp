#include "proc/child.hpp"

#include <dirent.h>
#include <fcntl.h>
#include <sched.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <filesystem>
#include <fstream>
#include <future>
#include <regex>
#include <stdexcept>

#include "core/signal_name.hpp"

extern char** environ;

namespace sirupp::proc {
namespace {

using Clock = std::chrono::steady_clock;

Clock::time_point After(double seconds) {
  return Clock::now() +
         std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(seconds));
}

// The program's path: argv[0] itself when it has a '/', else the first executable of that name
// on PATH, else argv[0] (exec then fails and says so in the log).
std::string ProgramPath(const std::string& name) {
  if (name.find('/') != std::string::npos) return name;
  const char* path = std::getenv("PATH");
  std::string dirs = path != nullptr ? path : "/usr/local/bin:/usr/bin:/bin";
  size_t start = 0;
  while (start <= dirs.size()) {
    size_t end = dirs.find(':', start);
    if (end == std::string::npos) end = dirs.size();
    const std::string dir = end > start ? dirs.substr(start, end - start) : ".";
    const std::string candidate = dir + "/" + name;
    if (::access(candidate.c_str(), X_OK) == 0) return candidate;
    start = end + 1;
  }
  return name;
}

// The parent's environment with `overrides` ("NAME=VALUE") set over it.
std::vector<std::string> Environment(const std::vector<std::string>& overrides) {
  std::vector<std::string> env;
  for (char** e = environ; e != nullptr && *e != nullptr; ++e) {
    const std::string entry = *e;
    const std::string name = entry.substr(0, entry.find('='));
    bool replaced = false;
    for (const std::string& o : overrides) replaced = replaced || o.substr(0, o.find('=')) == name;
    if (!replaced) env.push_back(entry);
  }
  for (const std::string& o : overrides) env.push_back(o);
  return env;
}

// Everything the child needs, made before fork.
struct Prepared {
  std::vector<std::string> words;
  std::vector<char*> argv;
  std::vector<std::string> env_words;
  std::vector<char*> envp;
  std::string program;
  std::string exec_failed;
  int log_fd = -1;
  int null_fd = -1;
  pid_t group = 0;
  int death_signal = 0;
  int nice = 0;
  bool limit_memory = false;
  rlimit memory{};
  bool pin = false;
  cpu_set_t cpus{};
};

pid_t ForkExec(const Prepared& p) {
  const pid_t parent = ::getpid();
  const pid_t pid = ::fork();
  if (pid != 0) return pid;
  // In the child: only async-signal-safe calls until exec.
  ::setpgid(0, p.group);
  if (p.death_signal != 0) {
    ::prctl(PR_SET_PDEATHSIG, p.death_signal);
    if (::getppid() != parent) ::_exit(126);  // the parent died before prctl took effect
  }
  if (p.null_fd >= 0) ::dup2(p.null_fd, STDIN_FILENO);
  if (p.log_fd >= 0) {
    ::dup2(p.log_fd, STDOUT_FILENO);
    ::dup2(p.log_fd, STDERR_FILENO);
  }
  ::close_range(3, ~0U, 0);  // the parent's sockets and files stay with the parent
  sigset_t none;
  sigemptyset(&none);
  ::sigprocmask(SIG_SETMASK, &none, nullptr);
  ::signal(SIGINT, SIG_DFL);
  ::signal(SIGTERM, SIG_DFL);
  ::signal(SIGPIPE, SIG_DFL);
  if (p.nice != 0) ::setpriority(PRIO_PROCESS, 0, p.nice);
  if (p.pin) ::sched_setaffinity(0, sizeof p.cpus, &p.cpus);
  if (p.limit_memory) ::setrlimit(RLIMIT_AS, &p.memory);
  ::execve(p.program.c_str(), p.argv.data(), p.envp.data());
  ssize_t ignored = ::write(STDERR_FILENO, p.exec_failed.data(), p.exec_failed.size());
  (void)ignored;
  ::_exit(127);
}

// A word as sh reads it: unchanged when it is made of safe characters only, else in '...'.
std::string Quoted(const std::string& word) {
  if (!word.empty() && word.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ"
                                              "0123456789_-./:=@%+,") == std::string::npos) {
    return word;
  }
  std::string out = "'";
  for (const char c : word) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

// Whether a live (not zombie) process of group `group` is left, from /proc.
bool LiveMemberInProc(pid_t group) {
  DIR* dir = ::opendir("/proc");
  if (dir == nullptr) return true;
  bool found = false;
  while (dirent* entry = ::readdir(dir)) {
    const char* name = entry->d_name;
    if (name[0] < '0' || name[0] > '9') continue;
    std::ifstream in(std::string("/proc/") + name + "/stat");
    std::string text;
    std::getline(in, text);
    const size_t close = text.rfind(')');
    if (close == std::string::npos || close + 2 >= text.size()) continue;
    // After the name: state, ppid, pgrp.
    char state = 0;
    long ppid = 0;
    long pgrp = 0;
    if (std::sscanf(text.c_str() + close + 2, "%c %ld %ld", &state, &ppid, &pgrp) != 3) continue;
    if (pgrp == group && state != 'Z' && state != 'X') {
      found = true;
      break;
    }
  }
  ::closedir(dir);
  return found;
}

}  // namespace

namespace {

std::string ShellLine(const ProcessSpec& spec, bool exec) {
  std::string line;
  for (const std::string& e : spec.env) {
    const size_t equals = e.find('=');  // NAME=VALUE: the name bare, or sh takes it for a command
    line += (line.empty() ? "" : " ") +
            (equals == std::string::npos ? Quoted(e)
                                         : e.substr(0, equals + 1) + Quoted(e.substr(equals + 1)));
  }
  if (exec) line += line.empty() ? "exec" : " exec";  // after the NAME=VALUE words: sh exports them
  for (const std::string& w : spec.argv) line += (line.empty() ? "" : " ") + Quoted(w);
  if (!spec.log_path.empty()) line += " >> " + Quoted(spec.log_path) + " 2>&1";
  return line;
}

}  // namespace

std::string CommandLine(const ProcessSpec& spec) { return ShellLine(spec, false); }

std::string ExecLine(const ProcessSpec& spec) { return ShellLine(spec, true); }

Launcher::Launcher() : thread_([this] { Loop(); }) {}

Launcher::~Launcher() {
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  thread_.join();
}

void Launcher::Loop() {
  std::unique_lock<std::mutex> lock(mutex_);
  while (true) {
    wake_.wait(lock, [this] { return stop_ || !tasks_.empty(); });
    if (tasks_.empty()) return;
    std::function<void()> task = std::move(tasks_.front());
    tasks_.pop_front();
    lock.unlock();
    task();
    lock.lock();
  }
}

pid_t Launcher::Run(const std::function<pid_t()>& fork_exec) {
  std::packaged_task<pid_t()> task(fork_exec);
  std::future<pid_t> result = task.get_future();
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    tasks_.emplace_back([&task] { task(); });
  }
  wake_.notify_all();
  return result.get();
}

Child::~Child() {
  if (pid_ > 0 && !ended_) Stop(0.2);
}

Child::Child(Child&& other) noexcept { *this = std::move(other); }

Child& Child::operator=(Child&& other) noexcept {
  if (this != &other) {
    if (pid_ > 0 && !ended_) Stop(0.2);
    pid_ = other.pid_;
    group_ = other.group_;
    ended_ = other.ended_;
    group_ends_with_it_ = other.group_ends_with_it_;
    status_ = other.status_;
    log_path_ = std::move(other.log_path_);
    other.pid_ = -1;
    other.ended_ = false;
  }
  return *this;
}

void Child::Start(const ProcessSpec& spec, pid_t group, Launcher* launcher) {
  if (spec.argv.empty()) throw std::runtime_error("no program to start");
  if (pid_ > 0 && !ended_) throw std::runtime_error("already running: " + spec.argv[0]);
  Prepared p;
  p.words = spec.argv;
  for (std::string& word : p.words) p.argv.push_back(word.data());
  p.argv.push_back(nullptr);
  p.env_words = Environment(spec.env);
  for (std::string& word : p.env_words) p.envp.push_back(word.data());
  p.envp.push_back(nullptr);
  p.program = ProgramPath(spec.argv[0]);
  p.exec_failed = spec.exec_failed_line.empty()
                      ? "exec failed: " + spec.argv[0] + ": no such program or not executable\n"
                      : spec.exec_failed_line + "\n";
  p.group = group;
  p.death_signal = spec.death_signal;
  p.nice = spec.limits.nice;
#if defined(__SANITIZE_ADDRESS__)
  p.limit_memory = false;
#else
  p.limit_memory = spec.limits.memory_mb > 0;
#endif
  p.memory.rlim_cur = p.memory.rlim_max = static_cast<rlim_t>(spec.limits.memory_mb) * 1024 * 1024;
  p.pin = spec.limits.cpu >= 0;
  CPU_ZERO(&p.cpus);
  if (p.pin) CPU_SET(spec.limits.cpu, &p.cpus);
  if (!spec.log_path.empty()) {
    std::error_code ignored;
    const std::filesystem::path parent = std::filesystem::path(spec.log_path).parent_path();
    if (!parent.empty()) std::filesystem::create_directories(parent, ignored);
    p.log_fd = ::open(spec.log_path.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
    if (p.log_fd < 0) {
      throw std::runtime_error("cannot start " + spec.argv[0] + ": cannot open its log " +
                               spec.log_path + ": " + std::strerror(errno));
    }
  }
  p.null_fd = ::open("/dev/null", O_RDONLY | O_CLOEXEC);
  int fork_errno = 0;
  const auto fork_exec = [&p, &fork_errno] {
    const pid_t pid = ForkExec(p);
    fork_errno = errno;
    // Also from here: the group exists before anyone might signal it.
    if (pid > 0) ::setpgid(pid, p.group == 0 ? pid : p.group);
    return pid;
  };
  const pid_t pid = launcher != nullptr ? launcher->Run(fork_exec) : fork_exec();
  if (p.log_fd >= 0) ::close(p.log_fd);
  if (p.null_fd >= 0) ::close(p.null_fd);
  if (pid < 0) {
    throw std::runtime_error("cannot start " + spec.argv[0] +
                             ": fork failed: " + std::strerror(fork_errno));
  }
  pid_ = pid;
  group_ = group == 0 ? pid : group;
  ended_ = false;
  status_ = 0;
  group_ends_with_it_ = spec.group_ends_with_it && group == 0;
  log_path_ = spec.log_path;
}

bool Child::Running() {
  if (pid_ <= 0 || ended_) return false;
  int status = 0;
  const pid_t got = ::waitpid(pid_, &status, WNOHANG);
  if (got == pid_ || (got < 0 && errno == ECHILD)) {
    ended_ = true;
    status_ = got == pid_ ? status : 0;
    if (group_ends_with_it_) ::kill(-group_, SIGKILL);
    return false;
  }
  return true;
}

std::string Child::HowEnded() const {
  if (!ended_) return "";
  if (WIFSIGNALED(status_)) return "crashed with " + core::SignalDescription(WTERMSIG(status_));
  if (WIFEXITED(status_)) return "exit code " + std::to_string(WEXITSTATUS(status_));
  return "wait status " + std::to_string(status_);
}

bool Child::EndedCleanly() const {
  return ended_ && WIFEXITED(status_) && WEXITSTATUS(status_) == 0;
}

bool Child::Stop(double grace_s, int first) {
  if (pid_ <= 0) return true;
  bool in_grace = !Running();
  if (!in_grace && first != 0 && grace_s > 0) {
    ::kill(-group_, first);
    const auto deadline = After(grace_s);
    while (Running() && Clock::now() < deadline) {
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    in_grace = ended_;
  }
  ::kill(-group_, SIGKILL);
  if (!ended_) {
    int status = 0;
    if (::waitpid(pid_, &status, 0) == pid_) status_ = status;
    ended_ = true;
  }
  KillGroup(group_, kGroupGoneS);
  return in_grace;
}

std::string Child::LogTail(int lines) const {
  std::ifstream in(log_path_);
  std::deque<std::string> tail;
  std::string line;
  static const std::regex stamp(R"(^\d{4}-\d\d-\d\dT[0-9:.]+ )");
  while (std::getline(in, line)) {
    line = std::regex_replace(line, stamp, "");
    if (line.empty()) continue;
    tail.push_back(line);
    if (static_cast<int>(tail.size()) > lines) tail.pop_front();
  }
  std::string text;
  for (const std::string& l : tail) text += (text.empty() ? "" : " | ") + l;
  return text;
}

bool GroupGone(pid_t group) {
  if (group <= 0) return true;
  if (::kill(-group, 0) != 0 && errno == ESRCH) return true;
  return !LiveMemberInProc(group);
}

bool KillGroup(pid_t group, double timeout_s) {
  if (group <= 0) return true;
  const auto deadline = After(timeout_s);
  while (!GroupGone(group)) {
    if (Clock::now() >= deadline) return false;
    ::kill(-group, SIGKILL);
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return true;
}

}  // namespace sirupp::proc
