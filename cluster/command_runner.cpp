#include "cluster/command_runner.hpp"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>

namespace sirupp::cluster {
namespace {

using Clock = std::chrono::steady_clock;

std::string FirstLine(const std::string& text) {
  const size_t start = text.find_first_not_of(" \n\t");
  if (start == std::string::npos) return "";
  const size_t end = text.find('\n', start);
  return text.substr(start, end == std::string::npos ? std::string::npos : end - start);
}

void CloseBoth(int fds[2]) {
  for (int i = 0; i < 2; ++i) {
    if (fds[i] >= 0) ::close(fds[i]);
    fds[i] = -1;
  }
}

}  // namespace

std::string CommandResult::Describe(const std::string& program) const {
  if (!started) return program + ": could not be run: " + FirstLine(err);
  if (timed_out) return program + ": no answer in time (killed): " + FirstLine(err);
  if (exit_code != 0) {
    const std::string line = FirstLine(err).empty() ? FirstLine(out) : FirstLine(err);
    return program + ": " +
           (exit_code < 0 ? std::string("ended by a signal")
                          : "exit " + std::to_string(exit_code)) +
           (line.empty() ? "" : ": " + line);
  }
  return program + ": ok";
}

CommandResult SystemRunner::Run(const std::vector<std::string>& argv, const std::string& input,
                                double timeout_s) {
  CommandResult result;
  if (argv.empty()) {
    result.err = "no command";
    return result;
  }
  // Everything the child needs is made before fork: after it only async-signal-safe calls.
  std::vector<std::string> words = argv;
  std::vector<char*> args;
  for (std::string& word : words) args.push_back(word.data());
  args.push_back(nullptr);
  int in_pipe[2] = {-1, -1};
  int out_pipe[2] = {-1, -1};
  int err_pipe[2] = {-1, -1};
  int exec_pipe[2] = {-1, -1};  // closed by a successful exec; carries errno when it fails
  if (::pipe2(in_pipe, O_CLOEXEC) != 0 || ::pipe2(out_pipe, O_CLOEXEC) != 0 ||
      ::pipe2(err_pipe, O_CLOEXEC) != 0 || ::pipe2(exec_pipe, O_CLOEXEC) != 0) {
    result.err = std::string("pipe: ") + std::strerror(errno);
    CloseBoth(in_pipe);
    CloseBoth(out_pipe);
    CloseBoth(err_pipe);
    CloseBoth(exec_pipe);
    return result;
  }
  const pid_t child = ::fork();
  if (child < 0) {
    result.err = std::string("fork: ") + std::strerror(errno);
    CloseBoth(in_pipe);
    CloseBoth(out_pipe);
    CloseBoth(err_pipe);
    CloseBoth(exec_pipe);
    return result;
  }
  if (child == 0) {
    ::setpgid(0, 0);
    ::dup2(in_pipe[0], 0);
    ::dup2(out_pipe[1], 1);
    ::dup2(err_pipe[1], 2);
    sigset_t none;
    sigemptyset(&none);
    ::sigprocmask(SIG_SETMASK, &none, nullptr);
    ::execvp(args[0], args.data());
    const int error = errno;
    (void)!::write(exec_pipe[1], &error, sizeof error);
    ::_exit(127);
  }
  ::setpgid(child, child);
  ::close(in_pipe[0]);
  ::close(out_pipe[1]);
  ::close(err_pipe[1]);
  ::close(exec_pipe[1]);
  int exec_error = 0;
  const bool exec_failed = ::read(exec_pipe[0], &exec_error, sizeof exec_error) ==
                           static_cast<ssize_t>(sizeof exec_error);
  ::close(exec_pipe[0]);
  if (exec_failed) {
    ::close(in_pipe[1]);
    ::close(out_pipe[0]);
    ::close(err_pipe[0]);
    ::waitpid(child, nullptr, 0);
    result.err = argv[0] + ": " + std::strerror(exec_error);
    return result;
  }
  result.started = true;
  // Standard input: written whole before reading (the engines' inputs are a few kB, well under a
  // pipe's buffer), then closed so the program sees its end.
  size_t written = 0;
  ::fcntl(in_pipe[1], F_SETFL, O_NONBLOCK);
  while (written < input.size()) {
    const ssize_t n = ::write(in_pipe[1], input.data() + written, input.size() - written);
    if (n <= 0) break;
    written += static_cast<size_t>(n);
  }
  ::close(in_pipe[1]);
  const auto deadline =
      Clock::now() + std::chrono::milliseconds(static_cast<int64_t>(timeout_s * 1000));
  pollfd fds[2] = {{out_pipe[0], POLLIN, 0}, {err_pipe[0], POLLIN, 0}};
  std::string* sinks[2] = {&result.out, &result.err};
  int open_fds = 2;
  char buffer[4096];
  while (open_fds > 0) {
    const auto left =
        std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
    if (left <= 0) {
      result.timed_out = true;
      break;
    }
    const int ready = ::poll(fds, 2, static_cast<int>(left));
    if (ready < 0 && errno != EINTR) break;
    for (int i = 0; i < 2; ++i) {
      if (fds[i].fd < 0 || fds[i].revents == 0) continue;
      const ssize_t n = ::read(fds[i].fd, buffer, sizeof buffer);
      if (n > 0) {
        sinks[i]->append(buffer, static_cast<size_t>(n));
      } else if (n == 0 || errno != EINTR) {
        ::close(fds[i].fd);
        fds[i].fd = -1;
        --open_fds;
      }
    }
  }
  for (pollfd& fd : fds) {
    if (fd.fd >= 0) ::close(fd.fd);
  }
  int status = 0;
  if (result.timed_out) {
    ::kill(-child, SIGKILL);
    ::waitpid(child, &status, 0);
    return result;
  }
  // Output closed: the program is ending; wait for it within what is left of the time limit.
  while (true) {
    const pid_t done = ::waitpid(child, &status, WNOHANG);
    if (done == child) break;
    if (Clock::now() >= deadline) {
      result.timed_out = true;
      ::kill(-child, SIGKILL);
      ::waitpid(child, &status, 0);
      return result;
    }
    ::usleep(2000);
  }
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return result;
}

}  // namespace sirupp::cluster
