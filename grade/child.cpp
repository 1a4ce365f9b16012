#include "grade/child.hpp"

#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <deque>
#include <fstream>
#include <regex>
#include <stdexcept>
#include <thread>

#include "core/signal_name.hpp"

namespace sirupp::grade {

Child::~Child() {
  if (pid_ > 0 && !ended_) Stop(0.2);
}

void Child::Start(const std::vector<std::string>& argv, const std::string& log_file) {
  if (argv.empty()) throw std::runtime_error("no program to start");
  log_file_ = log_file;
  const int log = ::open(log_file.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
  if (log < 0) throw std::runtime_error("cannot open " + log_file + ": " + std::strerror(errno));
  std::vector<std::string> words = argv;
  std::vector<char*> pointers;
  for (std::string& word : words) pointers.push_back(word.data());
  pointers.push_back(nullptr);
  const pid_t parent = ::getpid();
  const pid_t pid = ::fork();
  if (pid == 0) {
    // In the child: only async-signal-safe calls until exec.
    ::setpgid(0, 0);
    ::prctl(PR_SET_PDEATHSIG, SIGKILL);  // nothing outlives a killed grader
    if (::getppid() != parent) ::_exit(126);
    const int null = ::open("/dev/null", O_RDONLY);
    if (null >= 0) ::dup2(null, STDIN_FILENO);
    ::dup2(log, STDOUT_FILENO);
    ::dup2(log, STDERR_FILENO);
    ::close_range(3, ~0U, 0);
    sigset_t none;
    sigemptyset(&none);
    ::sigprocmask(SIG_SETMASK, &none, nullptr);
    ::signal(SIGINT, SIG_DFL);
    ::signal(SIGTERM, SIG_DFL);
    ::signal(SIGPIPE, SIG_DFL);
    ::execvp(pointers[0], pointers.data());
    const char message[] = "sirupp grade: exec failed: no such program or not executable\n";
    ssize_t ignored = ::write(STDERR_FILENO, message, sizeof message - 1);
    (void)ignored;
    ::_exit(127);
  }
  ::close(log);
  if (pid < 0) throw std::runtime_error("fork failed: " + std::string(std::strerror(errno)));
  ::setpgid(pid, pid);  // also from here: the group exists before we might signal it
  pid_ = pid;
  ended_ = false;
}

bool Child::Running() {
  if (pid_ <= 0 || ended_) return false;
  int status = 0;
  const pid_t got = ::waitpid(pid_, &status, WNOHANG);
  if (got == pid_) {
    ended_ = true;
    status_ = status;
    ::kill(-pid_, SIGKILL);  // helpers left in its group (a controller host) end with it
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

void Child::Stop(double grace_s) {
  if (pid_ <= 0) return;
  if (!Running()) {
    ::kill(-pid_, SIGKILL);
    return;
  }
  ::kill(-pid_, SIGTERM);
  const auto deadline = std::chrono::steady_clock::now() +
                        std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                            std::chrono::duration<double>(grace_s));
  while (Running() && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  ::kill(-pid_, SIGKILL);
  if (!ended_) {
    int status = 0;
    if (::waitpid(pid_, &status, 0) == pid_) {
      ended_ = true;
      status_ = status;
    }
  }
}

std::string Child::LogTail(int lines) const {
  std::ifstream in(log_file_);
  std::deque<std::string> tail;
  std::string line;
  while (std::getline(in, line)) {
    // Without the log prefix's timestamp (tools/log_prefix.hpp): reasons must not change from run
    // to run.
    static const std::regex stamp(R"(^\d{4}-\d\d-\d\dT[0-9:.]+ )");
    line = std::regex_replace(line, stamp, "");
    if (line.empty()) continue;
    tail.push_back(line);
    if (static_cast<int>(tail.size()) > lines) tail.pop_front();
  }
  std::string text;
  for (const std::string& l : tail) text += (text.empty() ? "" : " | ") + l;
  return text;
}

}  // namespace sirupp::grade
