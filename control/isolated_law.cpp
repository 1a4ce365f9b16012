#include "control/isolated_law.hpp"

#include <fcntl.h>
#include <poll.h>
#include <sched.h>
#include <signal.h>
#include <spawn.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <memory>
#include <sirupp/robot_model_t.hpp>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "control/plugin_controller.hpp"
#include "core/errors.hpp"
#include "core/signal_name.hpp"
#include "core/translate.hpp"

namespace sirupp::control {
namespace {

using Clock = std::chrono::steady_clock;

// The shared block: a Header, then kArrays arrays of num_joints doubles (the call's inputs, then
// the answer's efforts), then the encoded robot_model_t.
constexpr uint32_t kMagic = 0x53434831;  // "SCH1"
constexpr uint32_t kLayout = 1;
constexpr int32_t kOpReset = 1;
constexpr int32_t kOpUpdate = 2;
constexpr int32_t kOutcomeOk = 0;
constexpr int32_t kOutcomeThrew = 1;
constexpr size_t kErrorSize = 2048;
// The bytes on the socket: parent -> host "go", host -> parent "done", "ready", "load error".
constexpr char kGo = 'G';
constexpr char kDone = 'D';
constexpr char kReady = 'R';
constexpr char kLoadError = 'E';

struct Header {
  uint32_t magic;
  uint32_t layout;
  int32_t num_joints;
  uint32_t model_size;
  uint64_t request_seq;
  uint64_t reply_seq;
  int32_t op;
  int32_t outcome;
  int64_t tick;
  double time_s;
  char error[kErrorSize];  // the library's exception or load problem, NUL-terminated
};

enum Array {
  kPosition,
  kVelocity,
  kAppliedEffort,
  kSetpoint,
  kSetpointVelocity,
  kSetpointAcceleration,
  kGoal,
  kEffortOut,
  kArrays
};

constexpr size_t kArraysOffset = (sizeof(Header) + 7) / 8 * 8;

size_t SharedSize(int num_joints, size_t model_size) {
  return kArraysOffset + kArrays * static_cast<size_t>(num_joints) * sizeof(double) + model_size;
}

Header* HeaderOf(void* shared) { return static_cast<Header*>(shared); }

double* ArrayOf(void* shared, int num_joints, Array array) {
  return reinterpret_cast<double*>(static_cast<char*>(shared) + kArraysOffset) +
         static_cast<size_t>(array) * static_cast<size_t>(num_joints);
}

uint8_t* ModelOf(void* shared, int num_joints) {
  return reinterpret_cast<uint8_t*>(ArrayOf(shared, num_joints, kArrays));
}

void SetError(Header* header, const std::string& text) {
  std::snprintf(header->error, kErrorSize, "%s", text.c_str());
}

// The error text as the other side left it, bounded (the host may have scribbled on the block).
std::string ErrorOf(const Header* header) {
  const char* end = static_cast<const char*>(std::memchr(header->error, '\0', kErrorSize));
  return std::string(header->error, end != nullptr ? end : header->error + kErrorSize);
}

bool SendByte(int socket_fd, char byte) {
  std::atomic_thread_fence(std::memory_order_seq_cst);  // the block is written before the byte
  for (;;) {
    const ssize_t sent = ::send(socket_fd, &byte, 1, MSG_NOSIGNAL);
    if (sent == 1) return true;
    if (sent < 0 && errno == EINTR) continue;
    return false;
  }
}

std::string ErrnoText(const std::string& what) { return what + ": " + std::strerror(errno); }

// How a host process ended, from waitpid's status, while running `where` ("in Update",
// "while loading ..."): "crashed with SIGSEGV (Segmentation fault) in Update".
std::string DescribeEnd(int status, const std::string& where) {
  if (WIFSIGNALED(status)) {
    const int signal_number = WTERMSIG(status);
    std::string text = "crashed with " + core::SignalDescription(signal_number) + " " + where;
    if (signal_number == SIGABRT) text += ": abort(), a failed assert() or std::terminate";
    return text;
  }
  if (WIFEXITED(status)) {
    return "ended its host process with exit code " + std::to_string(WEXITSTATUS(status)) + " " +
           where + " (exit() or quick_exit() called?)";
  }
  return "ended its host process (wait status " + std::to_string(status) + ") " + where;
}

// Moves a descriptor above 4, so that the spawn's dup2 onto 3 and 4 never meets itself.
int AboveFour(int fd) {
  if (fd > 4) return fd;
  const int moved = ::fcntl(fd, F_DUPFD_CLOEXEC, 5);
  const int saved = errno;
  ::close(fd);
  errno = saved;
  return moved;
}

std::string DefaultHostProgram(const std::string& library) {
  std::error_code error;
  const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe", error);
  return (error ? std::filesystem::path(".") : self.parent_path()) / HostProgramName(library);
}

// The numbers of /proc/PID/stat (or a task's) after the name, which may hold spaces and
// parentheses: field 3 (state) is fields[0], field 14 (utime) fields[11]. Empty when it is gone.
std::vector<std::string> StatFields(const std::string& path) {
  std::FILE* file = std::fopen(path.c_str(), "r");
  if (file == nullptr) return {};
  char line[1024];
  const size_t n = std::fread(line, 1, sizeof line - 1, file);
  std::fclose(file);
  line[n] = '\0';
  const char* after_name = std::strrchr(line, ')');
  std::vector<std::string> fields;
  if (after_name == nullptr) return fields;
  std::istringstream words(after_name + 1);
  for (std::string word; words >> word;) fields.push_back(word);
  return fields;
}

// The tasks (threads) of a process, by number; empty when it is gone.
std::vector<std::string> TasksOf(pid_t pid) {
  std::vector<std::string> tasks;
  std::error_code error;
  std::filesystem::directory_iterator it("/proc/" + std::to_string(pid) + "/task", error);
  for (; !error && it != std::filesystem::directory_iterator(); it.increment(error)) {
    tasks.push_back(it->path().filename().string());
  }
  return tasks;
}

// `pid` and its descendants (the sandbox's processes and the host), from the tasks' children
// lists; each once, at most kMaxTree (a fork bomb inside is the sandbox's limit to stop).
std::vector<pid_t> ProcessTree(pid_t pid) {
  constexpr size_t kMaxTree = 256;
  std::vector<pid_t> tree = {pid};
  for (size_t i = 0; i < tree.size() && tree.size() < kMaxTree; ++i) {
    for (const std::string& task : TasksOf(tree[i])) {
      std::FILE* file = std::fopen(
          ("/proc/" + std::to_string(tree[i]) + "/task/" + task + "/children").c_str(), "r");
      if (file == nullptr) continue;
      for (int child = 0; std::fscanf(file, "%d", &child) == 1 && tree.size() < kMaxTree;) {
        if (std::find(tree.begin(), tree.end(), child) == tree.end()) tree.push_back(child);
      }
      std::fclose(file);
    }
  }
  return tree;
}

// Gives `pid` and its descendants the scheduling policy.
void SetSchedulerOfTree(pid_t pid, int policy, const sched_param& param) {
  for (pid_t member : ProcessTree(pid)) ::sched_setscheduler(member, policy, &param);
}

// What the host's process tree is doing: its CPU time so far (each process's own, with the
// threads that ended and the children it waited for) and whether one of its threads is running,
// waiting for a CPU (R) or in a short uninterruptible wait such as a page-in (D), rather than
// asleep.
struct TreeActivity {
  double cpu_s = 0;
  bool runnable = false;
};

TreeActivity ActivityOfTree(pid_t pid) {
  TreeActivity activity;
  const double ticks_per_s = static_cast<double>(::sysconf(_SC_CLK_TCK));
  for (pid_t member : ProcessTree(pid)) {
    const std::string proc = "/proc/" + std::to_string(member);
    const std::vector<std::string> fields = StatFields(proc + "/stat");
    if (fields.size() > 14) {  // utime stime cutime cstime
      double ticks = 0;
      for (size_t f = 11; f <= 14; ++f) ticks += std::strtod(fields[f].c_str(), nullptr);
      activity.cpu_s += ticks / ticks_per_s;
    }
    for (const std::string& task : TasksOf(member)) {
      const std::vector<std::string> task_fields = StatFields(proc + "/task/" + task + "/stat");
      if (!task_fields.empty() && (task_fields[0] == "R" || task_fields[0] == "D")) {
        activity.runnable = true;
      }
    }
  }
  return activity;
}

}  // namespace

std::string HostProgramName(const std::string& library) {
  const std::string python = ".py";
  const bool is_python =
      library.size() > python.size() &&
      library.compare(library.size() - python.size(), python.size(), python) == 0;
  return is_python ? "sirupp-python-controller-host" : "sirupp-controller-host";
}

IsolatedEffortLaw::IsolatedEffortLaw(const std::string& library, const std::string& args,
                                     const core::RobotModel& model, IsolationOptions options)
    : library_(library),
      args_(args),
      host_program_(options.host_program.empty() ? DefaultHostProgram(library)
                                                 : options.host_program),
      options_(options),
      num_joints_(model.num_joints()) {
  const size_t slash = library.find_last_of('/');
  name_ = slash == std::string::npos ? library : library.substr(slash + 1);
  sirupp::robot_model_t message = core::ToMessage(model, 0, 0);
  model_bytes_.resize(static_cast<size_t>(message.getEncodedSize()));
  message.encode(model_bytes_.data(), 0, static_cast<int>(model_bytes_.size()));
  StartHost();
}

IsolatedEffortLaw::~IsolatedEffortLaw() { StopHost(); }

namespace {

// The host's descriptors and the block it shares with sirupp-control.
struct HostLink {
  int shared_fd = -1;
  void* shared = MAP_FAILED;
  int pair[2] = {-1, -1};  // [0] stays here, [1] becomes the host's descriptor 3
};

// The shared block (size bytes, holding the header and the model) and the socket pair; throws
// ControllerLoadError after closing what it opened.
HostLink MakeHostLink(const std::string& library, size_t size, int num_joints,
                      const std::vector<uint8_t>& model_bytes) {
  HostLink link;
  link.shared_fd = AboveFour(::memfd_create("sirupp-controller", MFD_CLOEXEC));
  if (link.shared_fd < 0 || ::ftruncate(link.shared_fd, static_cast<off_t>(size)) != 0) {
    const std::string problem = ErrnoText("cannot make the shared memory for its host process");
    if (link.shared_fd >= 0) ::close(link.shared_fd);
    throw ControllerLoadError(library, problem);
  }
  link.shared = ::mmap(nullptr, size, PROT_READ | PROT_WRITE, MAP_SHARED, link.shared_fd, 0);
  if (link.shared == MAP_FAILED ||
      ::socketpair(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0, link.pair) != 0 ||
      (link.pair[1] = AboveFour(link.pair[1])) < 0) {
    const std::string problem = ErrnoText("cannot connect to its host process");
    if (link.shared != MAP_FAILED) ::munmap(link.shared, size);
    for (int fd : {link.pair[0], link.pair[1], link.shared_fd}) {
      if (fd >= 0) ::close(fd);
    }
    throw ControllerLoadError(library, problem);
  }
  Header* header = HeaderOf(link.shared);
  header->magic = kMagic;
  header->layout = kLayout;
  header->num_joints = num_joints;
  header->model_size = static_cast<uint32_t>(model_bytes.size());
  std::copy(model_bytes.begin(), model_bytes.end(), ModelOf(link.shared, num_joints));
  return link;
}

// The host's command line `program library args`, in the sandbox unless options.sandbox is off
// (the host program and the library visible read-only, nothing else of the student's folder or
// anyone's). Throws ControllerLoadError when the sandbox cannot be had.
std::vector<std::string> HostCommand(const std::string& program, const std::string& library,
                                     const std::string& args, const IsolationOptions& options) {
  std::vector<std::string> command = {program, library, args};
  if (!options.sandbox) return command;
  // As posix_spawn would say without the sandbox (bwrap itself starts).
  if (::access(program.c_str(), X_OK) != 0) {
    throw ControllerLoadError(library, ErrnoText("cannot start its host process " + program));
  }
  sandbox::Policy policy;
  // A relative library is found from the same working folder inside.
  if (!library.empty() && library.front() != '/') {
    policy.chdir = std::filesystem::current_path().string();
  }
  policy.limits = options.sandbox_limits;
  policy.read_only = {std::filesystem::absolute(library).string()};
  // The Python host imports this build's module `sirupp` (build/python beside build/bin); numpy
  // and the interpreter are under /usr.
  if (std::filesystem::path(program).filename() == HostProgramName("controller.py")) {
    const std::filesystem::path module_dir =
        std::filesystem::path(program).parent_path().parent_path() / "python";
    std::error_code error;
    if (std::filesystem::is_directory(module_dir, error)) {
      policy.read_only.push_back(std::filesystem::canonical(module_dir, error).string());
    }
  }
  policy.read_only.insert(policy.read_only.end(), options.sandbox_read_only.begin(),
                          options.sandbox_read_only.end());
  policy.read_write = options.sandbox_read_write;
  try {
    return sandbox::Wrap(policy, command);
  } catch (const std::runtime_error& error) {
    throw ControllerLoadError(library, std::string(error.what()) +
                                           " (docs/sandbox.md; --no-sandbox runs the library "
                                           "unconfined, for your own code only)");
  }
}

// Starts `command` with the socket as descriptor 3 and the block as 4, no signal blocked and
// SIGPIPE at its default; with `own_group` in a process group of its own (the sandbox: bwrap does
// not ignore the Ctrl-C and SIGTERM sent to sirupp-control's group as the host does, and would
// take the host down before sirupp-control closes it). Returns posix_spawn's answer (0: started,
// *pid set).
int SpawnHost(const std::vector<std::string>& command, const HostLink& link, bool own_group,
              pid_t* pid) {
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, link.pair[1], 3);
  posix_spawn_file_actions_adddup2(&actions, link.shared_fd, 4);
  posix_spawnattr_t attributes;
  posix_spawnattr_init(&attributes);
  sigset_t none, defaults;
  sigemptyset(&none);
  sigemptyset(&defaults);
  sigaddset(&defaults, SIGPIPE);
  posix_spawnattr_setsigmask(&attributes, &none);
  posix_spawnattr_setsigdefault(&attributes, &defaults);
  short flags = POSIX_SPAWN_SETSIGMASK | POSIX_SPAWN_SETSIGDEF;
  if (own_group) {
    posix_spawnattr_setpgroup(&attributes, 0);
    flags = static_cast<short>(flags | POSIX_SPAWN_SETPGROUP);
  }
  posix_spawnattr_setflags(&attributes, flags);
  std::vector<char*> argv;
  for (const std::string& word : command) argv.push_back(const_cast<char*>(word.c_str()));
  argv.push_back(nullptr);
  const int spawned = ::posix_spawn(pid, argv[0], &actions, &attributes, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  posix_spawnattr_destroy(&attributes);
  return spawned;
}

}  // namespace

void IsolatedEffortLaw::StartHost() {
  const std::vector<std::string> command = HostCommand(host_program_, library_, args_, options_);
  const size_t size = SharedSize(num_joints_, model_bytes_.size());
  const HostLink link = MakeHostLink(library_, size, num_joints_, model_bytes_);
  pid_t pid = -1;
  const int spawned = SpawnHost(command, link, options_.sandbox, &pid);
  ::close(link.pair[1]);
  ::close(link.shared_fd);
  if (spawned != 0) {
    ::munmap(link.shared, size);
    ::close(link.pair[0]);
    throw ControllerLoadError(
        library_, "cannot start its host process " + host_program_ + ": " + std::strerror(spawned));
  }
  pid_ = pid;
  socket_ = link.pair[0];
  shared_ = link.shared;
  shared_size_ = size;
  ++hosts_started_;
  AwaitLoad(link.shared);
}

void IsolatedEffortLaw::AwaitLoad(const void* shared) {
  char byte = 0;
  const int answer = WaitForHost(options_.load_limit_s, &byte);
  if (answer == 1 && byte == kReady) {
    fresh_ = true;
    return;
  }
  std::string problem;
  if (answer == 1 && byte == kLoadError) {
    problem = ErrorOf(static_cast<const Header*>(shared));
    ReapHost(false, "");
  } else if (answer == 0) {
    ReapHost(true, "");
    problem = "did not finish loading within " + core::FormatNumber(options_.load_limit_s) +
              " s (a static initializer or the constructor hangs?); its host process was killed";
  } else {
    problem = ReapHost(false, "while loading (in a static initializer or the constructor)");
  }
  StopHost();
  throw ControllerLoadError(library_, problem);
}

void IsolatedEffortLaw::StopHost() {
  if (socket_ >= 0) {
    ::close(socket_);  // the host's recv sees end of file and it ends
    socket_ = -1;
  }
  if (pid_ > 0) {
    const Clock::time_point deadline = Clock::now() + std::chrono::seconds(1);
    int status = 0;
    while (::waitpid(pid_, &status, WNOHANG) == 0) {
      if (Clock::now() > deadline) {
        ::kill(pid_, SIGKILL);  // its destructor hangs
        ::waitpid(pid_, &status, 0);
        break;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    pid_ = -1;
  }
  if (shared_ != nullptr) {
    ::munmap(shared_, shared_size_);
    shared_ = nullptr;
  }
  fresh_ = false;
}

std::string IsolatedEffortLaw::ReapHost(bool kill_first, const std::string& where) {
  if (pid_ <= 0) return "its host process is gone " + where;
  if (kill_first) ::kill(pid_, SIGKILL);
  int status = 0;
  // After end of file the host is ending; a host that closed its socket and runs on is killed.
  const Clock::time_point deadline = Clock::now() + std::chrono::seconds(2);
  pid_t reaped = 0;
  while ((reaped = ::waitpid(pid_, &status, WNOHANG)) == 0 && Clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::microseconds(200));
  }
  if (reaped == 0) {
    ::kill(pid_, SIGKILL);
    reaped = ::waitpid(pid_, &status, 0);
  }
  const pid_t pid = pid_;
  pid_ = -1;
  if (socket_ >= 0) {
    ::close(socket_);
    socket_ = -1;
  }
  if (reaped != pid) {
    return "its host process " + std::to_string(pid) + " ended " + where + " (not reaped)";
  }
  // bwrap reports its command's signal as exit code 128 + N.
  return DescribeEnd(options_.sandbox ? sandbox::UnwrapStatus(status) : status, where);
}

int IsolatedEffortLaw::WaitForHost(double limit_s, char* byte) {
  const Clock::time_point deadline = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                                        std::chrono::duration<double>(limit_s));
  for (;;) {
    const auto remaining =
        std::chrono::duration_cast<std::chrono::nanoseconds>(deadline - Clock::now()).count();
    if (remaining <= 0) return 0;
    pollfd wait_for{socket_, POLLIN, 0};
    const timespec timeout{static_cast<time_t>(remaining / 1000000000),
                           static_cast<long>(remaining % 1000000000)};
    const int ready = ::ppoll(&wait_for, 1, &timeout, nullptr);
    if (ready < 0 && errno != EINTR) return -1;
    if (ready <= 0) continue;
    const ssize_t got = ::recv(socket_, byte, 1, MSG_DONTWAIT);
    if (got == 1) {
      std::atomic_thread_fence(std::memory_order_seq_cst);
      return 1;
    }
    if (got == 0 || (errno != EAGAIN && errno != EINTR)) return -1;
  }
}

int IsolatedEffortLaw::WaitWhileStarved(double limit_s, char* byte) {
  past_limit_.clear();
  const Clock::time_point limit_passed = Clock::now();
  const double patience_s = std::max(kStarvedPatienceS, 10 * limit_s);
  const Clock::time_point give_up = limit_passed + std::chrono::duration_cast<Clock::duration>(
                                                       std::chrono::duration<double>(patience_s));
  const TreeActivity at_limit = ActivityOfTree(pid_);
  bool asleep_before = !at_limit.runnable;
  for (;;) {
    const int answer = WaitForHost(std::min(kStarvedLookS, limit_s), byte);
    if (answer != 0) return answer;
    const TreeActivity now = ActivityOfTree(pid_);
    const Clock::time_point at = Clock::now();
    const double waited_s = std::chrono::duration<double>(at - limit_passed).count();
    const double computed_s = now.cpu_s - at_limit.cpu_s;
    // Why it is not waited for any longer: asleep at two looks in a row (a blocking call); given
    // half a CPU or more and still no answer, or a whole limit of CPU time more (computing, an
    // endless loop); runnable and starved past all patience. Else it waits for a CPU: wait on.
    const char* why = nullptr;
    if (!now.runnable && asleep_before) {
      why = "it was asleep (a blocking call?)";
    } else if (computed_s >= limit_s || (now.runnable && computed_s >= 0.5 * waited_s)) {
      why = "it was computing (an endless loop?)";
    } else if (at >= give_up) {
      why = "it was still waiting for a CPU (the machine is overloaded)";
    }
    asleep_before = !now.runnable;
    if (why == nullptr) continue;
    if (waited_s >= kStarvedLookS * 2) {  // it was given more time: say what it did with it
      char text[200];
      std::snprintf(text, sizeof text,
                    "; past the limit it was waited for %.2f s more, in which it computed for "
                    "%.2f s: %s",
                    waited_s, computed_s, why);
      past_limit_ = text;
    }
    return WaitForHost(kLastLookS, byte);  // one last look: an answer as it went to sleep
  }
}

void IsolatedEffortLaw::Call(int32_t op, const ControlInput& input, const char* what) {
  if (pid_ <= 0) throw std::runtime_error(std::string("no host process to run ") + what);
  fresh_ = false;
  const int n = num_joints_;
  const core::ArmState& measured = *input.state;
  auto put = [this, n](Array array, const std::vector<double>& values) {
    std::copy_n(values.begin(), std::min<size_t>(values.size(), static_cast<size_t>(n)),
                ArrayOf(shared_, n, array));
  };
  put(kPosition, measured.position);
  put(kVelocity, measured.velocity);
  put(kAppliedEffort, measured.effort);
  put(kSetpoint, input.setpoint_position);
  put(kSetpointVelocity, input.setpoint_velocity);
  put(kSetpointAcceleration, input.setpoint_acceleration);
  put(kGoal, input.goal);
  Header* header = HeaderOf(shared_);
  header->op = op;
  header->tick = input.tick;
  header->time_s = input.time_s;
  header->request_seq = ++seq_;
  if (!SendByte(socket_, kGo)) {
    throw std::runtime_error(ReapHost(false, std::string("before ") + what));
  }
  char byte = 0;
  int answer = WaitForHost(options_.tick_limit_s, &byte);
  if (answer == 0) answer = WaitWhileStarved(options_.tick_limit_s, &byte);
  if (answer == 0) {
    const pid_t pid = pid_;
    ReapHost(true, "");
    throw std::runtime_error(std::string("did not return from ") + what + " within " +
                             core::FormatNumber(options_.tick_limit_s) +
                             " s (the per-tick limit, --controller-tick-limit; an endless loop or "
                             "a blocking call?): its host process " +
                             std::to_string(pid) + " was killed" + past_limit_);
  }
  if (answer < 0) throw std::runtime_error(ReapHost(false, std::string("in ") + what));
  if (byte != kDone || header->reply_seq != seq_) {
    ReapHost(true, "");
    throw std::runtime_error(std::string("its host process answered ") + what +
                             " out of turn (the library wrote over the shared memory?); it was "
                             "killed");
  }
  if (header->outcome != kOutcomeOk) throw std::runtime_error(ErrorOf(header));
}

void IsolatedEffortLaw::Reset(const ControlInput& input) {
  if (pid_ <= 0 || !fresh_) {
    StopHost();
    StartHost();
  }
  // sirupp-control waits for the host every tick, so the host runs at its scheduling priority:
  // `--rt-priority` is granted after the first host started (a restarted one inherits it). Best
  // effort, like the request itself. In the sandbox the host is a descendant of pid_.
  sched_param param{};
  const int policy = ::sched_getscheduler(0);
  if (policy >= 0 && ::sched_getparam(0, &param) == 0) SetSchedulerOfTree(pid_, policy, param);
  Call(kOpReset, input, "Reset");
}

void IsolatedEffortLaw::Update(const ControlInput& input, std::vector<double>& effort) {
  Call(kOpUpdate, input, "Update");
  const double* out = ArrayOf(shared_, num_joints_, kEffortOut);
  effort.assign(out, out + num_joints_);
}

namespace {

// The host's side of the shared block, mapped and checked; nullptr (after a message) when
// descriptor shared_fd does not hold one from sirupp-control.
void* MapSharedBlock(int shared_fd) {
  struct stat file {};
  if (::fstat(shared_fd, &file) != 0 || static_cast<size_t>(file.st_size) < sizeof(Header)) {
    std::fprintf(stderr, "sirupp-controller-host: no shared block on descriptor %d\n", shared_fd);
    return nullptr;
  }
  const auto size = static_cast<size_t>(file.st_size);
  void* shared = ::mmap(nullptr, size, PROT_READ | PROT_WRITE, MAP_SHARED, shared_fd, 0);
  if (shared == MAP_FAILED) {
    std::fprintf(stderr, "sirupp-controller-host: cannot map the shared block: %s\n",
                 std::strerror(errno));
    return nullptr;
  }
  const Header* header = HeaderOf(shared);
  const int n = header->num_joints;
  if (header->magic != kMagic || header->layout != kLayout || n < 1 ||
      SharedSize(n, header->model_size) != size) {
    std::fprintf(stderr, "sirupp-controller-host: the shared block is not from sirupp-control\n");
    return nullptr;
  }
  return shared;
}

// Loads the library with the model from the block; on failure leaves the problem in the block,
// sends "load error" and returns nullptr.
std::unique_ptr<EffortLaw> LoadLaw(int socket_fd, void* shared, const std::string& library,
                                   const std::string& args, const EffortLawFactory& make_law) {
  Header* header = HeaderOf(shared);
  const int n = header->num_joints;
  try {
    sirupp::robot_model_t message;
    if (message.decode(ModelOf(shared, n), 0, static_cast<int>(header->model_size)) < 0) {
      throw std::runtime_error("the robot model from sirupp-control does not decode");
    }
    const core::RobotModel model = core::RobotModelFromMessage(message, "controller host");
    return make_law(library, args, model);
  } catch (const ControllerLoadError& error) {
    SetError(header, error.problem());
  } catch (const std::exception& error) {
    SetError(header, error.what());
  }
  SendByte(socket_fd, kLoadError);
  return nullptr;
}

// Answers sirupp-control's calls until it closes its end: each "go" byte runs Reset or Update on
// the block's inputs and answers "done".
int ServeCalls(int socket_fd, void* shared, EffortLaw& law) {
  Header* header = HeaderOf(shared);
  const int n = header->num_joints;
  core::ArmState state;
  state.position.resize(static_cast<size_t>(n));
  state.velocity.resize(static_cast<size_t>(n));
  state.effort.resize(static_cast<size_t>(n));
  state.flags.assign(static_cast<size_t>(n), 0);
  ControlInput input;
  input.state = &state;
  std::vector<double> effort(static_cast<size_t>(n), 0.0);
  auto take = [shared, n](Array array, std::vector<double>& values) {
    const double* from = ArrayOf(shared, n, array);
    values.assign(from, from + n);
  };
  for (;;) {
    char byte = 0;
    const ssize_t got = ::recv(socket_fd, &byte, 1, 0);
    if (got == 0) return 0;  // sirupp-control closed its end: done
    if (got < 0) {
      if (errno == EINTR) continue;
      return 0;
    }
    std::atomic_thread_fence(std::memory_order_seq_cst);
    input.tick = header->tick;
    input.time_s = header->time_s;
    state.tick = header->tick;
    take(kPosition, state.position);
    take(kVelocity, state.velocity);
    take(kAppliedEffort, state.effort);
    take(kSetpoint, input.setpoint_position);
    take(kSetpointVelocity, input.setpoint_velocity);
    take(kSetpointAcceleration, input.setpoint_acceleration);
    take(kGoal, input.goal);
    header->outcome = kOutcomeOk;
    header->error[0] = '\0';
    try {
      if (header->op == kOpReset) {
        law.Reset(input);
      } else {
        law.Update(input, effort);
        std::copy_n(effort.begin(), std::min<size_t>(effort.size(), static_cast<size_t>(n)),
                    ArrayOf(shared, n, kEffortOut));
      }
    } catch (const std::exception& error) {
      header->outcome = kOutcomeThrew;
      SetError(header, error.what());
    }
    header->reply_seq = header->request_seq;
    if (!SendByte(socket_fd, kDone)) return 0;
  }
}

}  // namespace

bool PrepareHostProcess(int argc, const char* program, const char* file_kind) {
  ::prctl(PR_SET_PDEATHSIG, SIGKILL);
  ::signal(SIGINT, SIG_IGN);
  ::signal(SIGTERM, SIG_IGN);
  int type = 0;
  socklen_t length = sizeof type;
  if (argc != 3 || ::getsockopt(3, SOL_SOCKET, SO_TYPE, &type, &length) != 0 ||
      type != SOCK_SEQPACKET) {
    std::fprintf(stderr,
                 "usage: %s %s ARGS (descriptor 3: socket, 4: shared block)\nStarted by "
                 "sirupp-control --controller %s; not for use by hand.\n",
                 program, file_kind, file_kind);
    return false;
  }
  ::close_range(5, ~0U, 0);  // nothing of sirupp-control's (its LCM sockets) stays open here
  return true;
}

int RunControllerHost(int socket_fd, int shared_fd, const std::string& library,
                      const std::string& args) {
  return RunControllerHost(
      socket_fd, shared_fd, library, args,
      [](const std::string& file, const std::string& text, const core::RobotModel& model) {
        return std::make_unique<PluginEffortLaw>(file, text, model);
      });
}

int RunControllerHost(int socket_fd, int shared_fd, const std::string& library,
                      const std::string& args, const EffortLawFactory& make_law) {
  void* shared = MapSharedBlock(shared_fd);
  if (shared == nullptr) return 2;
  const std::unique_ptr<EffortLaw> law = LoadLaw(socket_fd, shared, library, args, make_law);
  if (law == nullptr) return 2;
  if (!SendByte(socket_fd, kReady)) return 0;
  return ServeCalls(socket_fd, shared, *law);
}

}  // namespace sirupp::control
