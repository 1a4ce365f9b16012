// Lab layouts (strict reading, host choice, variables) and the supervisor (start order, readiness,
// restarts, clean and forced stops, critical processes), with plain shell commands as processes.
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <thread>
#include <vector>

#include "core/errors.hpp"
#include "launch/layout.hpp"
#include "launch/supervisor.hpp"

namespace sirupp::launch {
namespace {

namespace fs = std::filesystem;

std::string ErrorOf(const std::string& text) {
  try {
    ParseLayout(text, "lab.yaml");
  } catch (const core::ConfigError& e) {
    return e.what();
  }
  return "";
}

TEST(LaunchLayout, ReadsProcessesHostsAndDefaults) {
  const Layout l = ParseLayout(
      "lab: two-pc\n"
      "lcm_url: udpm://239.255.76.67:7667?ttl=1\n"
      "prefix: RIG2_\n"
      "processes:\n"
      "  - name: sim\n"
      "    host: server\n"
      "    run: sirupp-sim --mode realtime\n"
      "    restart: on-failure\n"
      "  - name: emu\n"
      "    host: robot\n"
      "    run: [sirupp-picservo-emu, --link, '${RUN_DIR}/a b']\n"
      "    lcm: false\n"
      "    ready: file\n"
      "    ready_file: ${RUN_DIR}/a b\n"
      "  - name: control\n"
      "    host: server\n"
      "    run: sirupp-control\n",
      "lab.yaml");
  EXPECT_EQ(l.lab, "two-pc");
  EXPECT_EQ(l.prefix, "RIG2_");
  ASSERT_EQ(l.hosts, (std::vector<std::string>{"server", "robot"}));
  ASSERT_EQ(l.processes.size(), 3u);
  EXPECT_EQ(l.processes[0].command, (std::vector<std::string>{"sirupp-sim", "--mode", "realtime"}));
  EXPECT_EQ(l.processes[0].restart, Restart::kOnFailure);
  EXPECT_EQ(l.processes[0].ready, Ready::kHeartbeat);
  EXPECT_EQ(l.processes[0].line, 5);
  EXPECT_EQ(l.processes[1].command.back(), "${RUN_DIR}/a b");
  EXPECT_EQ(l.processes[1].ready, Ready::kFile);
  EXPECT_FALSE(l.processes[1].lcm);
  EXPECT_EQ(l.processes[2].restart, Restart::kNever);
  const std::vector<ProcessSpec> server = l.ProcessesOn("server");
  ASSERT_EQ(server.size(), 2u);
  EXPECT_EQ(server[1].name, "control");
}

TEST(LaunchLayout, ShippedLayoutsLoad) {
  for (const char* file :
       {"config/labs/single-pc.yaml", "config/labs/multi-pc.yaml", "config/labs/demo.yaml"}) {
    const Layout l = LoadLayout(file);
    EXPECT_FALSE(l.processes.empty()) << file;
  }
  EXPECT_EQ(LoadLayout("config/labs/multi-pc.yaml").hosts.size(), 3u);
}

TEST(LaunchLayout, BadFilesNameLineKeyValueAndWhatIsAllowed) {
  const std::string head = "lab: x\nprocesses:\n  - name: a\n    run: prog\n";
  EXPECT_EQ(
      ErrorOf(head + "    restart: sometimes\n"),
      "lab.yaml:5:14: processes[0].restart: 'sometimes' is not allowed; expected one of: never, "
      "on-failure, always");
  EXPECT_NE(ErrorOf(head + "    colour: red\n").find("lab.yaml:5:5: processes[0].colour"),
            std::string::npos)
      << ErrorOf(head + "    colour: red\n");
  EXPECT_NE(ErrorOf(head + "  - name: a\n    run: other\n").find("'a' is used twice"),
            std::string::npos);
  EXPECT_NE(ErrorOf(head + "    lcm: false\n    ready: heartbeat\n").find("needs lcm: true"),
            std::string::npos);
  EXPECT_NE(ErrorOf(head + "    ready_file: /tmp/x\n").find("only used with ready: file"),
            std::string::npos);
  EXPECT_NE(ErrorOf(head + "    ready: file\n").find("ready_file"), std::string::npos);
  EXPECT_NE(ErrorOf("lab: x\nprefix: RIG-1\nprocesses:\n  - name: a\n    run: p\n")
                .find("'RIG-1' is not a channel prefix"),
            std::string::npos);
  EXPECT_NE(ErrorOf("lab: x\nlcm_url: tcp://1.2.3.4\nprocesses:\n  - name: a\n    run: p\n")
                .find("lab.yaml:2:10: lcm_url"),
            std::string::npos);
  EXPECT_NE(ErrorOf("lab: x\nprocesses: []\n").find("processes"), std::string::npos);
  EXPECT_NE(ErrorOf(head + "    max_restarts: -1\n").find("max_restarts"), std::string::npos);
  EXPECT_NE(ErrorOf("lab: x\nprocesses:\n  - name: a b\n    run: p\n").find("'a b'"),
            std::string::npos);
}

TEST(LaunchLayout, HostChoice) {
  const Layout two = ParseLayout(
      "lab: x\nprocesses:\n  - {name: a, host: pc1, run: p}\n  - {name: b, host: pc2, run: p}\n",
      "lab.yaml");
  EXPECT_EQ(ChooseHost(two, "pc2", "whatever"), "pc2");
  EXPECT_EQ(ChooseHost(two, "", "pc1"), "pc1");
  try {
    ChooseHost(two, "", "laptop");
    ADD_FAILURE() << "no host fits";
  } catch (const core::UsageError& e) {
    EXPECT_NE(std::string(e.what()).find("(pc1, pc2)"), std::string::npos) << e.what();
  }
  EXPECT_THROW(ChooseHost(two, "pc3", "pc1"), core::UsageError);
  const Layout one = ParseLayout("lab: x\nprocesses:\n  - {name: a, run: p}\n", "lab.yaml");
  EXPECT_EQ(ChooseHost(one, "", "laptop"), "local");
}

TEST(LaunchLayout, Variables) {
  EXPECT_EQ(Expand("${A}/x-${B}", {{"A", "1"}, {"B", "two"}}), "1/x-two");
  EXPECT_EQ(Expand("plain", {}), "plain");
  EXPECT_THROW(Expand("${C}", {{"A", "1"}}), std::invalid_argument);
  EXPECT_THROW(Expand("${A", {{"A", "1"}}), std::invalid_argument);
}

// A supervisor over shell commands; its own bus is in-process (memq://), the children use none.
class SupervisorTest : public ::testing::Test {
 protected:
  void SetUp() override {
    run_dir_ = fs::temp_directory_path() /
               ("sirupp-launch-test-" + std::to_string(::getpid()) + "-" +
                ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(run_dir_);
  }
  void TearDown() override { fs::remove_all(run_dir_); }

  std::unique_ptr<Supervisor> Make(const std::string& processes) {
    const Layout layout =
        ParseLayout("lab: test\nlcm_url: memq://\nprocesses:\n" + processes, "test.yaml");
    SupervisorOptions o;
    o.host = "local";
    o.machine = "test-machine";
    o.run_dir = run_dir_.string();
    o.events = &events_;
    o.restart_delay_s = 0.1;
    return std::make_unique<Supervisor>(layout, o);
  }
  static void ServiceFor(Supervisor& s, double seconds) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
    while (std::chrono::steady_clock::now() < end) s.Service(20);
  }
  static std::string StateOf(const Supervisor& s, const std::string& name) {
    for (const ProcessRow& r : s.Table()) {
      if (r.name == name) return r.state;
    }
    return "(none)";
  }

  fs::path run_dir_;
  std::ostringstream events_;
};

TEST_F(SupervisorTest, StartsInOrderWaitsForReadinessAndStopsCleanly) {
  auto s = Make(
      "  - name: first\n"
      "    run: [sh, -c, 'sleep 0.3; touch ${RUN_DIR}/first-ready; exec sleep 60']\n"
      "    lcm: false\n"
      "    ready: file\n"
      "    ready_file: ${RUN_DIR}/first-ready\n"
      "  - name: second\n"
      "    run: [sh, -c, 'test -e ${RUN_DIR}/first-ready && echo saw it && exec sleep 60']\n"
      "    lcm: false\n");
  ASSERT_TRUE(s->Start(nullptr)) << events_.str();
  ServiceFor(*s, 0.3);
  EXPECT_EQ(StateOf(*s, "first"), "running");
  EXPECT_EQ(StateOf(*s, "second"), "running") << events_.str();  // it started after first was ready
  const pid_t second = s->PidOf("second");
  ASSERT_GT(second, 0);
  s->Stop();
  EXPECT_EQ(::kill(second, 0), -1);  // gone
  EXPECT_EQ(s->ExitCode(), 0) << events_.str();
  // The log: the launcher's timestamped line, the process's own output, how it ended.
  std::ifstream log(run_dir_ / "logs" / "second.log");
  std::vector<std::string> lines;
  for (std::string line; std::getline(log, line);) lines.push_back(line);
  ASSERT_EQ(lines.size(), 3u);
  const std::regex stamp(R"(^\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d\.\d{3} sirupp-launch info: )");
  EXPECT_TRUE(std::regex_search(lines[0], stamp)) << lines[0];
  EXPECT_NE(lines[0].find(" -c test -e "), std::string::npos) << lines[0];
  EXPECT_EQ(lines[1], "saw it");
  EXPECT_TRUE(std::regex_search(lines[2], stamp)) << lines[2];
  EXPECT_NE(lines[2].find("second (pid " + std::to_string(second) + ") ended: "), std::string::npos)
      << lines[2];
  // Every event line carries the same prefix as the processes' log lines.
  std::istringstream events(events_.str());
  int count = 0;
  for (std::string line; std::getline(events, line); ++count) {
    EXPECT_TRUE(std::regex_search(line, stamp)) << line;
    EXPECT_NE(line.find(" info: [local] "), std::string::npos) << line;
  }
  EXPECT_GE(count, 4);
}

TEST_F(SupervisorTest, LayoutsSeeTheBusAsVariables) {
  const Layout layout = ParseLayout(
      "lab: test\nlcm_url: udpm://239.255.76.67:7999?ttl=0\nprefix: RIG2_\nprocesses:\n"
      "  - name: rec\n"
      "    run: [sh, -c, 'echo ${LCM_URL} ${PREFIX} ${LAB}']\n"
      "    lcm: false\n",
      "test.yaml");
  SupervisorOptions o;
  o.host = "local";
  o.run_dir = run_dir_.string();
  const Supervisor s(layout, o);
  const std::vector<std::string> command = s.CommandOf(layout.processes[0]);
  ASSERT_EQ(command.size(), 3u);
  EXPECT_EQ(command[2], "echo udpm://239.255.76.67:7999?ttl=0 RIG2_ test");
}

TEST_F(SupervisorTest, RestartsOnFailureUpToTheLimitAndReportsIt) {
  auto s = Make(
      "  - name: flaky\n"
      "    run: [sh, -c, 'echo attempt; exit 3']\n"
      "    lcm: false\n"
      "    restart: on-failure\n"
      "    max_restarts: 2\n"
      "  - name: steady\n"
      "    run: [sleep, '60']\n"
      "    lcm: false\n");
  ASSERT_TRUE(s->Start(nullptr)) << events_.str();
  ServiceFor(*s, 1.5);
  EXPECT_EQ(StateOf(*s, "flaky"), "failed") << events_.str();
  EXPECT_EQ(StateOf(*s, "steady"), "running");
  for (const ProcessRow& r : s->Table()) {
    if (r.name == "flaky") {
      EXPECT_EQ(r.restarts, 2);
    }
  }
  EXPECT_EQ(s->failures().size(), 3u);  // the first run and both restarts
  EXPECT_NE(events_.str().find("flaky ended (exit code 3); restart 1 of 2"), std::string::npos)
      << events_.str();
  EXPECT_NE(events_.str().find("| attempt"), std::string::npos);  // the log's tail is shown
  s->Stop();
  EXPECT_EQ(s->ExitCode(), 1);
}

TEST_F(SupervisorTest, ACleanExitIsDoneAndAlwaysRestartsAnyEnd) {
  auto s = Make(
      "  - name: once\n"
      "    run: [true]\n"
      "    lcm: false\n"
      "    restart: on-failure\n"
      "  - name: again\n"
      "    run: [sh, -c, 'sleep 0.1']\n"
      "    lcm: false\n"
      "    restart: always\n"
      "    max_restarts: 1000\n");
  ASSERT_TRUE(s->Start(nullptr)) << events_.str();
  ServiceFor(*s, 1.0);
  EXPECT_EQ(StateOf(*s, "once"), "done");
  for (const ProcessRow& r : s->Table()) {
    if (r.name == "again") {
      EXPECT_GE(r.restarts, 2);
    }
  }
  s->Stop();
  EXPECT_EQ(s->ExitCode(), 0) << events_.str();
}

TEST_F(SupervisorTest, AProcessIgnoringSigintIsKilledAfterItsTimeout) {
  auto s = Make(
      "  - name: stubborn\n"
      "    run: [sh, -c, 'trap \"\" INT; while true; do sleep 0.05; done']\n"
      "    lcm: false\n"
      "    stop_timeout_s: 0.3\n");
  ASSERT_TRUE(s->Start(nullptr));
  ServiceFor(*s, 0.2);
  const auto t0 = std::chrono::steady_clock::now();
  s->Stop();
  const double took = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_GE(took, 0.25);
  EXPECT_EQ(s->ExitCode(), 1);
  ASSERT_FALSE(s->failures().empty());
  EXPECT_NE(s->failures().back().find("did not stop within 0.3 s of SIGINT; killed"),
            std::string::npos);
}

TEST_F(SupervisorTest, NotReadyInTimeStopsWhatStartedAndSaysWhy) {
  auto s = Make(
      "  - name: first\n"
      "    run: [sleep, '60']\n"
      "    lcm: false\n"
      "  - name: never\n"
      "    run: [sh, -c, 'echo waiting for nothing; exec sleep 60']\n"
      "    lcm: false\n"
      "    ready: file\n"
      "    ready_file: ${RUN_DIR}/never\n"
      "    ready_timeout_s: 0.4\n"
      "  - name: third\n"
      "    run: [sleep, '60']\n"
      "    lcm: false\n");
  EXPECT_FALSE(s->Start(nullptr));
  EXPECT_EQ(s->PidOf("first"), 0);  // stopped again
  EXPECT_EQ(StateOf(*s, "third"), "waiting");
  ASSERT_FALSE(s->failures().empty());
  EXPECT_NE(s->failures().front().find("never: not ready within 0.4 s (no file"), std::string::npos)
      << s->failures().front();
}

TEST_F(SupervisorTest, TheEndOfACriticalProcessEndsTheService) {
  auto s = Make(
      "  - name: bus\n"
      "    run: [sh, -c, 'sleep 0.3; exit 1']\n"
      "    lcm: false\n"
      "    critical: true\n"
      "  - name: user\n"
      "    run: [sleep, '60']\n"
      "    lcm: false\n");
  ASSERT_TRUE(s->Start(nullptr));
  bool ended = false;
  const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while (!ended && std::chrono::steady_clock::now() < end) ended = !s->Service(20);
  EXPECT_TRUE(ended);
  s->Stop();
  EXPECT_EQ(s->ExitCode(), 1);
}

TEST_F(SupervisorTest, AMissingProgramIsAConfigErrorAtItsLine) {
  try {
    Make("  - name: a\n    run: [no-such-program-here]\n    lcm: false\n");
    ADD_FAILURE() << "expected an error";
  } catch (const core::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("test.yaml:4"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("'no-such-program-here' not found"), std::string::npos);
  }
  EXPECT_THROW(Make("  - name: a\n    run: [sleep, '${NOPE}']\n    lcm: false\n"),
               core::ConfigError);
}

}  // namespace
}  // namespace sirupp::launch
