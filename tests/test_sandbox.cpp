// The sandbox (sandbox/sandbox.hpp, docs/sandbox.md) around sirupp-controller-host, through
// IsolatedEffortLaw, the code sirupp-control --controller runs: the example gives the same
// efforts sandboxed and not; each hostile controller (tests/controllers/hostile/) ends its own
// run with a named reason and leaves the machine as it was: no datagram reaches another rig's
// port, another student's file is not read, a fork bomb stays under the process limit and leaves
// no process behind, endless allocation and an endless file are stopped by their limits, a
// constructor that spins is ended by the load limit (and by the CPU limit). net_publish and
// read_other also run unsandboxed, where they succeed: the checks can fail.

#include <arpa/inet.h>
#include <dirent.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "control/isolated_law.hpp"
#include "control/plugin_controller.hpp"
#include "core/errors.hpp"
#include "core/model_loader.hpp"
#include "grade/grade.hpp"
#include "grade/port_lease.hpp"
#include "sandbox/sandbox.hpp"

namespace sirupp::control {
namespace {
namespace fs = std::filesystem;

const std::string kHostile = SIRUPP_HOSTILE_DIR;

std::string Hostile(const std::string& name) { return kHostile + "/" + name + "/" + name + ".so"; }

IsolationOptions Sandboxed(bool sandbox = true) {
  IsolationOptions options;
  options.host_program = SIRUPP_CONTROLLER_HOST;
  options.tick_limit_s = 5;  // generous under load: the limits, not the clock, must stop them
  options.load_limit_s = 20;
  options.sandbox = sandbox;
  return options;
}

core::RobotModel Puma() { return core::LoadRobotModel("config/robots/puma260.yaml"); }

// Reset and one Update at the home pose; the effort, or what the law threw.
std::string RunOneTick(EffortLaw& law, std::vector<double>* effort = nullptr) {
  core::ArmState state;
  state.position.assign(6, 0.1);
  state.velocity.assign(6, 0.0);
  state.effort.assign(6, 0.0);
  state.flags.assign(6, 0);
  ControlInput input;
  input.state = &state;
  input.setpoint_position = state.position;
  input.setpoint_velocity = state.velocity;
  input.setpoint_acceleration = state.velocity;
  input.goal = state.position;
  std::vector<double> out;
  try {
    law.Reset(input);
    law.Update(input, out);
  } catch (const std::exception& error) {
    return error.what();
  }
  if (effort != nullptr) *effort = out;
  return "";
}

// What the law says: the load error, or what its first tick threw.
std::string Outcome(const std::string& library, const std::string& args,
                    const IsolationOptions& options) {
  try {
    IsolatedEffortLaw law(library, args, Puma(), options);
    return RunOneTick(law);
  } catch (const ControllerLoadError& error) {
    return error.what();
  }
}

// The reason, printed: the measured table of docs/sandbox.md is taken from this output.
void Report(const std::string& what, const std::string& reason) {
  std::printf("measured: %s: %s\n", what.c_str(), reason.c_str());
}

bool Contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

// Processes whose name is `comm` (as prctl(PR_SET_NAME) set it).
int CountProcessesNamed(const std::string& comm) {
  int count = 0;
  for (const fs::directory_entry& entry : fs::directory_iterator("/proc")) {
    std::ifstream in(entry.path() / "comm");
    std::string name;
    if (in && std::getline(in, name) && name == comm) ++count;
  }
  return count;
}

class Sandbox : public ::testing::Test {
 protected:
  void SetUp() override {
    const sandbox::Probe& probe = sandbox::ProbeMachine();
    // Where bubblewrap cannot work the sandbox refuses (checked below); nothing else to test.
    if (!probe.usable) GTEST_SKIP() << "no sandbox on this machine: " << probe.problem;
  }
};

TEST_F(Sandbox, TheProbeNamesWhatHolds) {
  const std::string text = sandbox::Describe(sandbox::ProbeMachine(), sandbox::Limits{});
  EXPECT_TRUE(Contains(text, "bubblewrap")) << text;
  EXPECT_TRUE(Contains(text, "32 processes")) << text;
}

TEST_F(Sandbox, TheExampleGivesTheSameEffortsSandboxedAndNot) {
  IsolatedEffortLaw sandboxed(SIRUPP_PD_GRAVITY_LIB, "", Puma(), Sandboxed(true));
  IsolatedEffortLaw plain(SIRUPP_PD_GRAVITY_LIB, "", Puma(), Sandboxed(false));
  std::vector<double> a, b;
  ASSERT_EQ(RunOneTick(sandboxed, &a), "");
  ASSERT_EQ(RunOneTick(plain, &b), "");
  EXPECT_EQ(a, b);
  EXPECT_EQ(a.size(), 6u);
}

TEST_F(Sandbox, ACrashIsStillNamedByItsSignal) {
  // bwrap reports a signal as exit code 128 + N; the law names the signal as without it.
  const std::string what = Outcome(Hostile("huge_file"), "/tmp/sirupp-hostile-huge", Sandboxed());
  EXPECT_TRUE(Contains(what, "crashed with SIGXFSZ")) << what;
}

// A UDP listener on the LCM group and `port` (this machine only), like another rig's bus.
class Listener {
 public:
  explicit Listener(int port) {
    fd_ = ::socket(AF_INET, SOCK_DGRAM, 0);
    const int yes = 1;
    ::setsockopt(fd_, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_port = htons(static_cast<uint16_t>(port));
    address.sin_addr.s_addr = htonl(INADDR_ANY);
    bound_ = ::bind(fd_, reinterpret_cast<const sockaddr*>(&address), sizeof address) == 0;
    ip_mreq group{};
    ::inet_pton(AF_INET, "239.255.76.67", &group.imr_multiaddr);
    group.imr_interface.s_addr = htonl(INADDR_ANY);  // as LCM joins
    joined_ = ::setsockopt(fd_, IPPROTO_IP, IP_ADD_MEMBERSHIP, &group, sizeof group) == 0;
  }
  ~Listener() { ::close(fd_); }
  bool ready() const { return bound_ && joined_; }
  // Datagrams heard within `wait_ms`.
  int Heard(int wait_ms) {
    int heard = 0;
    pollfd wait_for{fd_, POLLIN, 0};
    while (::poll(&wait_for, 1, wait_ms) > 0) {
      char buffer[256];
      if (::recv(fd_, buffer, sizeof buffer, 0) > 0) ++heard;
    }
    return heard;
  }

 private:
  int fd_ = -1;
  bool bound_ = false, joined_ = false;
};

TEST_F(Sandbox, NoDatagramReachesAnotherRigsPort) {
  grade::PortLease lease = grade::PortLease::Acquire(grade::kPortBase, grade::kPortCount, ::getpid() % 9000);
  Listener listener(lease.port());
  ASSERT_TRUE(listener.ready());
  const std::string args = std::to_string(lease.port());
  const std::string sandboxed = Outcome(Hostile("net_publish"), args, Sandboxed(true));
  Report("net_publish", sandboxed);
  EXPECT_TRUE(Contains(sandboxed, "socket(AF_INET, SOCK_DGRAM): Permission denied")) << sandboxed;
  EXPECT_EQ(listener.Heard(300), 0);
  // Unsandboxed the same library reaches the listener: the check above can fail.
  const std::string plain = Outcome(Hostile("net_publish"), args, Sandboxed(false));
  Report("net_publish --no-sandbox", plain);
  EXPECT_TRUE(Contains(plain, "sent 20 bytes")) << plain;
  EXPECT_EQ(listener.Heard(1000), 1);
}

TEST_F(Sandbox, AnotherStudentsFileIsNotThere) {
  // Another student's folder, readable by everyone on the machine (mode 755/644).
  const fs::path other = fs::temp_directory_path() / ("sirupp-other-" + std::to_string(::getpid()));
  fs::create_directories(other);
  ::chmod(other.c_str(), 0755);
  const fs::path secret = other / "controller.cpp";
  std::ofstream(secret) << "the other student's secret gains";
  ::chmod(secret.c_str(), 0644);
  const std::string sandboxed = Outcome(Hostile("read_other"), secret.string(), Sandboxed(true));
  Report("read_other", sandboxed);
  EXPECT_TRUE(Contains(sandboxed, "cannot open " + secret.string() + ": No such file")) << sandboxed;
  EXPECT_FALSE(Contains(sandboxed, "secret gains")) << sandboxed;
  const std::string plain = Outcome(Hostile("read_other"), secret.string(), Sandboxed(false));
  Report("read_other --no-sandbox", plain);
  EXPECT_TRUE(Contains(plain, "secret gains")) << plain;
  // Nor can it write outside: its own folder is read-only, so the file cannot be made.
  fs::remove_all(other);
}

TEST_F(Sandbox, AForkBombStopsAtTheProcessLimitAndLeavesNothing) {
  IsolationOptions options = Sandboxed();
  const std::string name = "sirupp-fb" + std::to_string(::getpid() % 100000);
  const std::string what = Outcome(Hostile("fork_bomb"), name, options);
  Report("fork_bomb", what);
  EXPECT_TRUE(Contains(what, "fork failed after")) << what;
  EXPECT_TRUE(Contains(what, "Resource temporarily unavailable")) << what;
  const long forks = std::stol(what.substr(what.find("after ") + 6));
  EXPECT_LT(forks, options.sandbox_limits.processes) << what;
  // The host is stopped with the law: its pid namespace takes every child with it.
  for (int wait = 0; wait < 50 && CountProcessesNamed(name) > 0; ++wait) ::usleep(20000);
  EXPECT_EQ(CountProcessesNamed(name), 0);
}

TEST_F(Sandbox, EndlessAllocationStopsAtTheMemoryLimit) {
  IsolationOptions options = Sandboxed();
  options.sandbox_limits.memory_mb = 256;
  const std::string what = Outcome(Hostile("allocate"), "", options);
  Report("allocate (256 MB limit)", what);
  if (sandbox::Policy::kSanitizedBuild) {
    // ASan's hard_rss_limit_mb ends the host.
    EXPECT_TRUE(Contains(what, "while loading")) << what;
  } else {
    EXPECT_TRUE(Contains(what, "allocation failed after")) << what;
    const long megabytes = std::stol(what.substr(what.find("after ") + 6));
    EXPECT_LT(megabytes, 256) << what;
  }
}

TEST_F(Sandbox, AnEndlessFileStopsAtTheFileSizeLimitInAPrivateTmp) {
  const std::string path = "/tmp/sirupp-hostile-huge-" + std::to_string(::getpid());
  const std::string what = Outcome(Hostile("huge_file"), path, Sandboxed());
  Report("huge_file in /tmp", what);
  EXPECT_TRUE(Contains(what, "crashed with SIGXFSZ (File size limit exceeded) in Update")) << what;
  EXPECT_FALSE(fs::exists(path));  // its /tmp was its own
  // Nor next to its library: only the library file itself is there (bwrap's folders above it are
  // not writable, or, in a user namespace, are its own and vanish with it).
  const std::string own = kHostile + "/huge_file/written-by-the-controller";
  const std::string in_own = Outcome(Hostile("huge_file"), own, Sandboxed());
  Report("huge_file beside its library", in_own);
  EXPECT_TRUE(Contains(in_own, "cannot create") || Contains(in_own, "SIGXFSZ")) << in_own;
  EXPECT_FALSE(fs::exists(own));
}

TEST_F(Sandbox, AConstructorThatSpinsIsEndedByTheLoadLimitOrTheCpuLimit) {
  IsolationOptions options = Sandboxed();
  options.load_limit_s = 2;
  const std::string by_clock = Outcome(Hostile("spin_constructor"), "", options);
  Report("spin_constructor (load limit 2 s)", by_clock);
  EXPECT_TRUE(Contains(by_clock, "did not finish loading within 2 s")) << by_clock;
  options.load_limit_s = 60;
  options.sandbox_limits.cpu_s = 1;
  const std::string by_cpu = Outcome(Hostile("spin_constructor"), "", options);
  Report("spin_constructor (CPU limit 1 s)", by_cpu);
  EXPECT_TRUE(Contains(by_cpu, "crashed with SIGXCPU")) << by_cpu;
}

TEST(SandboxStatus, BwrapsExitCodeOfASignalIsTheSignal) {
  const int status = sandbox::UnwrapStatus(139 << 8);  // exit code 139
  EXPECT_TRUE(WIFSIGNALED(status));
  EXPECT_EQ(WTERMSIG(status), 11);
  EXPECT_EQ(sandbox::UnwrapStatus(2 << 8), 2 << 8);
}

}  // namespace
}  // namespace sirupp::control
