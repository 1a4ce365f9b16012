// proc/child.hpp: a child process started, watched and stopped: its exit code, its log, its
// environment, a program that cannot run, its process group ended with what it started (a
// grandchild too), the death signal when its parent dies (and the Launcher that keeps it from
// firing when a short-lived thread started the child), its limits applied, the command line.

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>

#include "proc/child.hpp"
#include "proc/rig.hpp"
#include "tests/helpers.hpp"

namespace sirupp::proc {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
using sirupp::testing::Alive;
using sirupp::testing::GoneWithin;

class ProcTest : public ::testing::Test {
 protected:
  void SetUp() override {
    std::string pattern = (fs::temp_directory_path() / "sirupp-proc-test-XXXXXX").string();
    ASSERT_NE(::mkdtemp(pattern.data()), nullptr);
    dir_ = pattern;
  }
  void TearDown() override { fs::remove_all(dir_); }

  static std::string Read(const std::string& path) {
    std::ifstream in(path);
    std::stringstream text;
    text << in.rdbuf();
    return text.str();
  }
  // Waits up to timeout_s for the child to end by itself.
  static bool WaitEnd(Child& child, double timeout_s = 10) {
    const auto until = Clock::now() + std::chrono::milliseconds(static_cast<int>(timeout_s * 1000));
    while (child.Running()) {
      if (Clock::now() > until) return false;
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    return true;
  }
  // Waits up to timeout_s for a file to hold a whole line; returns it.
  static std::string WaitLine(const std::string& path, double timeout_s = 10) {
    const auto until = Clock::now() + std::chrono::milliseconds(static_cast<int>(timeout_s * 1000));
    while (Clock::now() < until) {
      const std::string text = Read(path);
      if (text.find('\n') != std::string::npos) return text.substr(0, text.find('\n'));
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    return "";
  }
  ProcessSpec Shell(const std::string& script, const std::string& log = "log.txt") const {
    ProcessSpec spec;
    spec.argv = {"sh", "-c", script};
    spec.log_path = dir_ + "/" + log;
    return spec;
  }

  std::string dir_;
};

TEST_F(ProcTest, StartsAndSaysHowItEnded) {
  Child child;
  child.Start(Shell("exit 3"));
  EXPECT_GT(child.pid(), 0);
  EXPECT_EQ(child.group(), child.pid()) << "a group of its own";
  ASSERT_TRUE(WaitEnd(child));
  EXPECT_EQ(child.HowEnded(), "exit code 3");
  EXPECT_FALSE(child.EndedCleanly());
  Child crash;
  crash.Start(Shell("kill -SEGV $$"));
  ASSERT_TRUE(WaitEnd(crash));
  EXPECT_EQ(crash.HowEnded().rfind("crashed with SIGSEGV", 0), 0u) << crash.HowEnded();
  Child clean;
  clean.Start(Shell("true"));
  ASSERT_TRUE(WaitEnd(clean));
  EXPECT_TRUE(clean.EndedCleanly());
  EXPECT_EQ(clean.HowEnded(), "exit code 0");
}

TEST_F(ProcTest, ItsOutputIsAppendedToItsLogWithItsEnvironment) {
  fs::create_directories(dir_ + "/logs");
  { std::ofstream(dir_ + "/logs/log.txt") << "before\n"; }
  ProcessSpec spec = Shell("echo out $SIRUPP_PROC_TEST; echo err >&2; read line; echo \"[$line]\"",
                           "logs/log.txt");
  spec.env = {"SIRUPP_PROC_TEST=hello world", "HOME=/nowhere"};
  Child child;
  child.Start(spec);
  ASSERT_TRUE(WaitEnd(child));
  EXPECT_EQ(Read(dir_ + "/logs/log.txt"), "before\nout hello world\nerr\n[]\n")
      << "appended, stderr too, stdin empty";
  EXPECT_EQ(child.LogTail(2), "err | []");
  // A log in a folder that does not exist yet: made.
  Child nested;
  nested.Start(Shell("echo here", "a/b/log.txt"));
  ASSERT_TRUE(WaitEnd(nested));
  EXPECT_EQ(Read(dir_ + "/a/b/log.txt"), "here\n");
}

TEST_F(ProcTest, AProgramThatCannotRunEndsWith127AndTheReasonInItsLog) {
  ProcessSpec spec;
  spec.argv = {"sirupp-no-such-program-here"};
  spec.log_path = dir_ + "/log.txt";
  Child child;
  child.Start(spec);
  ASSERT_TRUE(WaitEnd(child));
  EXPECT_EQ(child.HowEnded(), "exit code 127");
  EXPECT_NE(child.LogTail().find("sirupp-no-such-program-here: no such program"), std::string::npos)
      << child.LogTail();
  ProcessSpec unwritable = spec;
  unwritable.log_path = "/proc/no/such/folder/log.txt";
  Child refused;
  EXPECT_THROW(refused.Start(unwritable), std::runtime_error);
}

TEST_F(ProcTest, StopEndsTheWholeGroupGrandchildrenToo) {
  // The child starts a grandchild in its group and ignores SIGTERM: the grace runs out, SIGKILL
  // ends both.
  Child stubborn;
  stubborn.Start(Shell("trap '' TERM; sleep 300 & echo $! > " + dir_ + "/grandchild; wait; wait"));
  const pid_t grandchild = std::atoi(WaitLine(dir_ + "/grandchild").c_str());
  ASSERT_GT(grandchild, 0);
  EXPECT_EQ(::getpgid(grandchild), stubborn.group());
  const auto start = Clock::now();
  EXPECT_FALSE(stubborn.Stop(0.3)) << "it ignored SIGTERM";
  EXPECT_GE(Clock::now() - start, std::chrono::milliseconds(290));
  EXPECT_TRUE(stubborn.ended());
  EXPECT_FALSE(Alive(grandchild)) << "the grandchild outlived the stop";
  EXPECT_TRUE(GroupGone(stubborn.group()));
  // One that ends on SIGTERM: within the grace.
  Child polite;
  polite.Start(Shell("sleep 300 & echo $! > " + dir_ + "/second; wait"));
  const pid_t second = std::atoi(WaitLine(dir_ + "/second").c_str());
  ASSERT_GT(second, 0);
  EXPECT_TRUE(polite.Stop(5.0));
  EXPECT_FALSE(Alive(second));
  // SIGINT first (the rigs' and the launcher's way).
  Child interrupted;
  interrupted.Start(Shell("trap 'exit 7' INT; while :; do sleep 0.01; done"));
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  EXPECT_TRUE(interrupted.Stop(5.0, SIGINT));
  EXPECT_EQ(interrupted.HowEnded(), "exit code 7");
}

TEST_F(ProcTest, AGroupLeaderThatEndsTakesItsGroupWhenAsked) {
  // The grader's children: what is left of the group ends with the leader.
  Child leader;
  ProcessSpec spec = Shell("sleep 300 & echo $! > " + dir_ + "/left; exit 0");
  spec.group_ends_with_it = true;
  leader.Start(spec);
  const pid_t left = std::atoi(WaitLine(dir_ + "/left").c_str());
  ASSERT_GT(left, 0);
  ASSERT_TRUE(WaitEnd(leader));
  EXPECT_TRUE(GoneWithin(left, 5)) << "the leader's helper outlived it";
  // By default (a rig's shared group) the others go on.
  Child first;
  first.Start(Shell("sleep 300 & echo $! > " + dir_ + "/kept; exit 0"));
  const pid_t kept = std::atoi(WaitLine(dir_ + "/kept").c_str());
  ASSERT_GT(kept, 0);
  ASSERT_TRUE(WaitEnd(first));
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  EXPECT_TRUE(Alive(kept));
  EXPECT_FALSE(GroupGone(first.group()));
  EXPECT_TRUE(KillGroup(first.group(), 5));
  EXPECT_FALSE(Alive(kept));
}

TEST_F(ProcTest, ChildrenShareAGroupWhenToldTo) {
  Child a;
  a.Start(Shell("sleep 300", "a.txt"));
  Child b;
  b.Start(Shell("sleep 300", "b.txt"), a.group());
  EXPECT_EQ(::getpgid(b.pid()), a.pid());
  EXPECT_EQ(b.group(), a.pid());
  ::kill(-a.group(), SIGTERM);
  EXPECT_TRUE(WaitEnd(a));
  EXPECT_TRUE(WaitEnd(b));
  EXPECT_TRUE(GroupGone(a.group()));
}

// A parent (forked here) starts a child and dies without stopping it; reports the child's pid.
pid_t OrphanOf(int death_signal) {
  int fds[2];
  if (::pipe(fds) != 0) return -1;
  const pid_t parent = ::fork();
  if (parent == 0) {
    ::close(fds[0]);
    ProcessSpec spec;
    spec.argv = {"sleep", "300"};
    spec.death_signal = death_signal;
    Child child;
    child.Start(spec);
    const pid_t pid = child.pid();
    ssize_t ignored = ::write(fds[1], &pid, sizeof pid);
    (void)ignored;
    ::_exit(0);  // no destructor: the child is left behind
  }
  ::close(fds[1]);
  pid_t child = -1;
  if (::read(fds[0], &child, sizeof child) != sizeof child) child = -1;
  ::close(fds[0]);
  ::waitpid(parent, nullptr, 0);
  return child;
}

TEST_F(ProcTest, TheDeathSignalEndsAChildWhoseParentDied) {
  const pid_t with = OrphanOf(SIGKILL);
  ASSERT_GT(with, 0);
  EXPECT_TRUE(GoneWithin(with, 5)) << "the child outlived its parent";
  // Without it, the same child lives on (so the signal, not the parent's end, ended it above).
  const pid_t without = OrphanOf(0);
  ASSERT_GT(without, 0);
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  EXPECT_TRUE(Alive(without));
  ::kill(-without, SIGKILL);
  EXPECT_TRUE(GoneWithin(without, 5));
}

TEST_F(ProcTest, ALauncherKeepsAChildOfAShortLivedThreadAlive) {
  ProcessSpec spec;
  spec.argv = {"sleep", "300"};
  spec.death_signal = SIGKILL;
  // Started from a thread that ends: the death signal fires with the thread.
  Child from_thread;
  std::thread([&] {
    from_thread.Start(spec);
    std::this_thread::sleep_for(std::chrono::milliseconds(300));  // past the child's prctl
  }).join();
  EXPECT_TRUE(WaitEnd(from_thread, 5));
  EXPECT_EQ(from_thread.HowEnded().rfind("crashed with SIGKILL", 0), 0u) << from_thread.HowEnded();
  // Through a Launcher: it runs until stopped.
  Launcher launcher;
  Child launched;
  std::thread([&] { launched.Start(spec, 0, &launcher); }).join();
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  EXPECT_TRUE(launched.Running());
  EXPECT_TRUE(launched.Stop(2.0));
}

TEST_F(ProcTest, LimitsAreApplied) {
  ProcessSpec spec =
      Shell("ulimit -v; nice; grep Cpus_allowed_list /proc/self/status | tr -d ' \\t'");
  spec.limits.nice = 7;
  spec.limits.memory_mb = 1024;
  spec.limits.cpu = 0;
  Child child;
  child.Start(spec);
  ASSERT_TRUE(WaitEnd(child));
  std::istringstream lines(Read(spec.log_path));
  std::string memory, nice, cpus;
  std::getline(lines, memory);
  std::getline(lines, nice);
  std::getline(lines, cpus);
#if defined(__SANITIZE_ADDRESS__)
  EXPECT_EQ(memory, "unlimited") << "not under AddressSanitizer";
#else
  EXPECT_EQ(memory, "1048576");  // KiB
#endif
  EXPECT_GE(std::atoi(nice.c_str()), 7) << nice;
  EXPECT_EQ(cpus, "Cpus_allowed_list:0");
}

TEST(ProcCommandLineTest, WritesTheSpecAsOneLineOfSh) {
  ProcessSpec spec;
  spec.argv = {"/opt/sirupp/bin/sirupp-sim", "--lcm-url", "udpm://239.255.76.67:7901?ttl=0",
               "it's"};
  spec.env = {"LCM_DEFAULT_URL=udpm://239.255.76.67:7901?ttl=0"};
  spec.log_path = "/data/alice logs/sim.log";
  EXPECT_EQ(CommandLine(spec),
            "LCM_DEFAULT_URL='udpm://239.255.76.67:7901?ttl=0' /opt/sirupp/bin/sirupp-sim "
            "--lcm-url 'udpm://239.255.76.67:7901?ttl=0' 'it'\\''s' >> '/data/alice logs/sim.log' "
            "2>&1");
}

TEST_F(ProcTest, AnExecLineReplacesTheScriptsShellAndKeepsItsEnvironment) {
  // As a job script's last line (cluster/class_job.cpp): the program takes the shell's pid, so
  // scancel's signal reaches it, and sees the spec's NAME=VALUE words.
  ProcessSpec spec;
  spec.argv = {"/bin/sh", "-c", "echo $$ $GREETING"};
  spec.env = {"GREETING=hello there"};
  spec.log_path = dir_ + "/inner.log";
  EXPECT_EQ(ExecLine(spec), "GREETING='hello there' exec /bin/sh -c 'echo $$ $GREETING' >> " +
                                dir_ + "/inner.log 2>&1");
  const std::string script = "echo $$ > '" + dir_ + "/outer.log'\n" + ExecLine(spec) + "\n";
  ProcessSpec job;  // the job's shell running the script
  job.argv = {"/bin/sh", "-c", script};
  ASSERT_EQ(std::system(CommandLine(job).c_str()), 0);
  const std::string outer = WaitLine(dir_ + "/outer.log");
  ASSERT_FALSE(outer.empty());
  EXPECT_EQ(WaitLine(dir_ + "/inner.log"), outer + " hello there");
}

// proc/rig.hpp: a private rig's processes and address, as plain data.
TEST(ProcRigTest, ARigIsItsProcessesWithTheirFlagsOnOneAddress) {
  EXPECT_EQ(RigUrl(7901), "udpm://239.255.76.67:7901?ttl=0");
  EXPECT_EQ(RigUrl(7901, "recv_buf_size=4194304"),
            "udpm://239.255.76.67:7901?ttl=0&recv_buf_size=4194304");
  RigSpec rig;
  rig.port = 7901;
  rig.bin_dir = "/b";
  rig.model = "m.yaml";
  rig.pace_ticks = 4;
  rig.controller = "c.so";
  rig.results_dir = "/r";
  rig.log_dir = "/l";
  rig.limits.nice = 5;
  const std::vector<RigProcess> processes = RigProcesses(rig);
  ASSERT_EQ(processes.size(), 3u);
  const std::string url = "udpm://239.255.76.67:7901?ttl=0";
  EXPECT_EQ(processes[0].name, "sirupp-sim");
  EXPECT_EQ(processes[0].spec.argv,
            (std::vector<std::string>{"/b/sirupp-sim", "--mode", "realtime", "--pace-ticks", "4",
                                      "--model", "m.yaml", "--lcm-url", url}));
  EXPECT_EQ(processes[0].spec.log_path, "/l/sirupp-sim.log");
  EXPECT_EQ(processes[0].spec.limits.nice, 5);
  EXPECT_EQ(processes[0].spec.death_signal, SIGTERM);
  EXPECT_EQ(processes[1].spec.argv,
            (std::vector<std::string>{"/b/sirupp-control", "--model", "m.yaml", "--lcm-url", url,
                                      "--controller", "c.so"}));
  EXPECT_EQ(processes[2].spec.argv,
            (std::vector<std::string>{"/b/sirupp-logger", "--out", "/r", "--model", "m.yaml",
                                      "--lcm-url", url}));
  // Lockstep with its participants and more flags; no logger, no logs, programs on PATH.
  RigSpec lockstep;
  lockstep.port = 20001;
  lockstep.model = "m.yaml";
  lockstep.sim_mode = "lockstep";
  lockstep.participants = {"sirupp-control", "grader"};
  lockstep.sim_args = {"--duration", "2"};
  lockstep.control_args = {"--sim-timeout", "5"};
  const std::vector<RigProcess> two = RigProcesses(lockstep);
  ASSERT_EQ(two.size(), 2u);
  EXPECT_EQ(CommandLine(two[0].spec),
            "sirupp-sim --mode lockstep --participants sirupp-control grader --model m.yaml "
            "--lcm-url 'udpm://239.255.76.67:20001?ttl=0' --duration 2");
  EXPECT_EQ(CommandLine(two[1].spec),
            "sirupp-control --model m.yaml --lcm-url 'udpm://239.255.76.67:20001?ttl=0' "
            "--sim-timeout 5");
  // Bad fields: named, with what is allowed.
  const auto error = [](RigSpec bad) {
    try {
      RigProcesses(bad);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  RigSpec bad = lockstep;
  bad.port = 70000;
  EXPECT_EQ(error(bad), "rig port 70000: allowed 1..65535");
  bad = lockstep;
  bad.sim_mode = "slow";
  EXPECT_EQ(error(bad), "rig sim_mode 'slow': allowed realtime, lockstep or fast");
  bad = lockstep;
  bad.pace_ticks = 0;
  EXPECT_EQ(error(bad), "rig pace_ticks 0: allowed a whole number >= 1");
  bad = lockstep;
  bad.model.clear();
  EXPECT_EQ(error(bad), "rig model: none given; a model file needed");
}

}  // namespace
}  // namespace sirupp::proc
