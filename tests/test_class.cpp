// The class server (class/): the class file's strict reading, tokens stored hashed and checked,
// the bad-token throttle on an injected clock, and the HTTP server itself on 127.0.0.1 with a real
// rig (sirupp-sim, sirupp-control, sirupp-logger on a leased udpm port, ttl=0): a student's token
// opens that student's rig and no other, the teacher's opens every rig read-only, bad requests
// are 4xx with a message, the rig's processes end when it stops.

#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <regex>
#include <sstream>
#include <thread>

#include "class/class_config.hpp"
#include "class/class_server.hpp"
#include "class/real_arm.hpp"
#include "class/rig_spawner.hpp"
#include "class/tokens.hpp"
#include "core/errors.hpp"
#include "panel/httplib_include.hpp"
#include "tests/class_server_harness.hpp"

namespace sirupp::classroom {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;

using testing::TempDir;

const char* const kGood = testing::kClassOfTwo;
const auto ErrorOf = testing::ClassFileError;

TEST(ClassConfigTest, ReadsAGoodFile) {
  const ClassConfig c = ParseClassConfig(kGood, "c.yaml", "/tmp/x");
  EXPECT_EQ(c.name, "robotics-1");
  EXPECT_EQ(c.students, (std::vector<std::string>{"alice", "bob"}));
  EXPECT_EQ(c.data_dir, "/tmp/x/class-data");
  EXPECT_EQ(c.max_rigs, 2);
  EXPECT_EQ(c.idle_timeout_s, 60);
  EXPECT_EQ(c.listen, "127.0.0.1");
  EXPECT_FALSE(c.pin_rigs) << "the scheduler places the rigs unless the class file says otherwise";
  EXPECT_EQ(c.pace_ticks, 4);
  EXPECT_TRUE(fs::path(c.robot).is_absolute());
  EXPECT_EQ(BaseUrl(c, 8800), "http://127.0.0.1:8800");
}

TEST(ClassConfigTest, BadFilesNameLineKeyAndWhatIsAllowed) {
  {
    const std::string e = ErrorOf(std::string(kGood) + "colour: red\n");
    EXPECT_NE(e.find("c.yaml:7"), std::string::npos) << e;
    EXPECT_NE(e.find("colour"), std::string::npos) << e;
  }
  {
    const std::string e =
        ErrorOf("class: a\nrobot: config/robots/puma260.yaml\nstudents: [alice, alice]\ndata: d\n");
    EXPECT_NE(e.find("c.yaml:3"), std::string::npos) << e;
    EXPECT_NE(e.find("listed twice"), std::string::npos) << e;
  }
  {
    const std::string e =
        ErrorOf("class: a\nrobot: config/robots/puma260.yaml\nstudents: [teacher]\ndata: d\n");
    EXPECT_NE(e.find("reserved"), std::string::npos) << e;
  }
  {
    const std::string e =
        ErrorOf("class: a\nrobot: config/robots/puma260.yaml\nstudents: [../x]\ndata: d\n");
    EXPECT_NE(e.find("'../x' is not a valid student name"), std::string::npos) << e;
  }
  {
    const std::string e = ErrorOf("class: a\nrobot: nowhere.yaml\nstudents: [a]\ndata: d\n");
    EXPECT_NE(e.find("c.yaml:2"), std::string::npos) << e;
    EXPECT_NE(e.find("no such file"), std::string::npos) << e;
  }
  {
    const std::string e = ErrorOf(std::string(kGood) + "rigs: {port_count: 1}\n");
    EXPECT_NE(e.find("each rig needs a port"), std::string::npos) << e;
  }
  {
    const std::string e = ErrorOf(
        "class: a\nrobot: config/robots/puma260.yaml\nstudents: [a]\ndata: d\n"
        "limits: {idle_timeout_s: -5}\n");
    EXPECT_NE(e.find("c.yaml:5"), std::string::npos) << e;
    EXPECT_NE(e.find("-5"), std::string::npos) << e;
  }
  {
    const std::string e = ErrorOf(
        "class: a\nrobot: config/robots/puma260.yaml\nstudents: [a]\ndata: d\n"
        "server: {tls_cert: x.pem}\n");
    EXPECT_NE(e.find("go together"), std::string::npos) << e;
  }
  {
    const std::string e = ErrorOf(
        "class: a\nrobot: config/robots/puma260.yaml\nstudents: [a]\ndata: d\n"
        "limits: {pin_rigs: sometimes}\n");
    EXPECT_NE(e.find("c.yaml:5"), std::string::npos) << e;
    EXPECT_NE(e.find("sometimes"), std::string::npos) << e;
  }
  {
    const std::string e = ErrorOf(std::string(kGood) + "rigs: {pace_ticks: 0}\n");
    EXPECT_NE(e.find("c.yaml:7"), std::string::npos) << e;
    EXPECT_NE(e.find("pace_ticks"), std::string::npos) << e;
  }
  EXPECT_TRUE(ParseClassConfig("class: a\nrobot: config/robots/puma260.yaml\nstudents: [a]\n"
                               "data: d\nlimits: {pin_rigs: true}\n",
                               "c.yaml", "/tmp/x")
                  .pin_rigs);
}

TEST(ClassConfigTest, NotebooksNameTheHubAndTheAssignments) {
  const ClassConfig none = ParseClassConfig(kGood, "c.yaml", "/tmp/x");
  EXPECT_FALSE(none.notebooks.has_value());
  const ClassConfig c =
      ParseClassConfig(std::string(kGood) +
                           "notebooks:\n"
                           "  hub_url: https://notebooks.example.edu/\n"
                           "  hub_port: 8811\n"
                           "  idle_timeout_s: 600\n"
                           "  assignments:\n"
                           "    - {name: fk3, notebook: notebooks/01_forward_kinematics.ipynb,\n"
                           "       tests: config/grading/planning_rrt.py, timeout_s: 60}\n",
                       "c.yaml", "/tmp/x");
  ASSERT_TRUE(c.notebooks.has_value());
  EXPECT_EQ(c.notebooks->hub_url, "https://notebooks.example.edu");
  EXPECT_EQ(c.notebooks->hub_port, 8811);
  EXPECT_EQ(c.notebooks->idle_timeout_s, 600);
  EXPECT_TRUE(fs::is_directory(c.notebooks->folder)) << c.notebooks->folder;
  ASSERT_EQ(c.notebooks->assignments.size(), 1u);
  EXPECT_EQ(c.notebooks->assignments[0].name, "fk3");
  EXPECT_TRUE(fs::is_regular_file(c.notebooks->assignments[0].notebook));
  EXPECT_TRUE(fs::is_regular_file(c.notebooks->assignments[0].tests));
  EXPECT_EQ(c.notebooks->assignments[0].timeout_s, 60);
  {
    const std::string e =
        ErrorOf(std::string(kGood) + "notebooks: {hub_url: notebooks.example.edu}\n");
    EXPECT_NE(e.find("c.yaml:7"), std::string::npos) << e;
    EXPECT_NE(e.find("not an address"), std::string::npos) << e;
  }
  {
    const std::string e = ErrorOf(std::string(kGood) +
                                  "notebooks:\n  assignments:\n    - {name: fk3, notebook: "
                                  "nowhere.ipynb, tests: config/grading/planning_rrt.py}\n");
    EXPECT_NE(e.find("c.yaml:9"), std::string::npos) << e;
    EXPECT_NE(e.find("nowhere.ipynb"), std::string::npos) << e;
  }
  {
    const std::string e = ErrorOf(std::string(kGood) + "notebooks: {hub_port: 80}\n");
    EXPECT_NE(e.find("hub_port"), std::string::npos) << e;
  }
}

TEST(TokenStoreTest, StoresOnlySaltedHashes) {
  const std::string dir = TempDir("sirupp-class-tokens");
  const std::string file = dir + "/tokens.json";
  std::string alice;
  {
    TokenStore store(file);
    alice = store.Issue("alice");
    store.Issue("bob");
  }
  EXPECT_EQ(alice.size(), 48u);
  std::ifstream in(file);
  std::stringstream buffer;
  buffer << in.rdbuf();
  const std::string text = buffer.str();
  EXPECT_EQ(text.find(alice), std::string::npos) << "the token itself is not stored";
  EXPECT_EQ(fs::status(file).permissions() & fs::perms::others_read, fs::perms::none);
  TokenStore again(file);  // as a restarted server reads it
  EXPECT_TRUE(again.Check("alice", alice));
  EXPECT_FALSE(again.Check("bob", alice));
  EXPECT_FALSE(again.Check("alice", alice.substr(1)));
  EXPECT_FALSE(again.Check("alice", ""));
  EXPECT_FALSE(again.Check("carol", alice));
  const std::string reissued = again.Issue("alice");
  EXPECT_FALSE(again.Check("alice", alice)) << "a reissued token replaces the old one";
  EXPECT_TRUE(again.Check("alice", reissued));
  // The hash is SHA-256: the standard test vector.
  EXPECT_EQ(Sha256Hex("abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  fs::remove_all(dir);
}

TEST(TokenStoreTest, ABrokenFileIsAConfigError) {
  const std::string dir = TempDir("sirupp-class-tokens");
  std::ofstream(dir + "/tokens.json") << "[1, 2";
  EXPECT_THROW(TokenStore(dir + "/tokens.json"), core::ConfigError);
  fs::remove_all(dir);
}

TEST(BadTokenThrottleTest, LocksOutAfterFiveFailuresForAGrowingTime) {
  BadTokenThrottle throttle;
  const auto t0 = BadTokenThrottle::Clock::time_point{} + std::chrono::hours(10);
  for (int i = 0; i < BadTokenThrottle::kFreeFailures - 1; ++i) {
    throttle.Failed("10.0.0.1", t0);
    EXPECT_EQ(throttle.WaitFor("10.0.0.1", t0), 0) << i;
  }
  throttle.Failed("10.0.0.1", t0);  // the fifth: 1 s
  EXPECT_NEAR(throttle.WaitFor("10.0.0.1", t0), 1.0, 1e-6);
  EXPECT_EQ(throttle.WaitFor("10.0.0.2", t0), 0) << "other addresses are not slowed";
  const auto t1 = t0 + std::chrono::seconds(2);
  EXPECT_EQ(throttle.WaitFor("10.0.0.1", t1), 0);
  throttle.Failed("10.0.0.1", t1);  // the sixth: 2 s
  EXPECT_NEAR(throttle.WaitFor("10.0.0.1", t1), 2.0, 1e-6);
  for (int i = 0; i < 20; ++i) throttle.Failed("10.0.0.1", t1);
  EXPECT_NEAR(throttle.WaitFor("10.0.0.1", t1), BadTokenThrottle::kMaxLockoutS, 1e-6);
  throttle.Succeeded("10.0.0.1");
  EXPECT_EQ(throttle.WaitFor("10.0.0.1", t1), 0);
}

TEST(BadTokenThrottleTest, AGoodTokenForgivesOnlyTheFailuresOnItsOwnPage) {
  BadTokenThrottle throttle;
  auto t = BadTokenThrottle::Clock::time_point{} + std::chrono::hours(10);
  // Guesses at bob's token, alice's own good token after every fourth (issue 51).
  int guesses = 0;
  while (throttle.WaitFor("10.0.0.1", t) == 0 && guesses < 40) {
    throttle.Failed("10.0.0.1", "bob", t);
    if (++guesses % 4 == 0) throttle.Succeeded("10.0.0.1", "alice");
    t += std::chrono::milliseconds(10);
  }
  EXPECT_EQ(guesses, BadTokenThrottle::kFreeFailures) << "alice's token cleared bob's count";
  EXPECT_NEAR(throttle.WaitFor("10.0.0.1", t), 1.0 - 0.01, 1e-6);
  // The doubling stays: the next failure after the lock-out locks for 2 s.
  t += std::chrono::seconds(1);
  throttle.Failed("10.0.0.1", "bob", t);
  EXPECT_NEAR(throttle.WaitFor("10.0.0.1", t), 2.0, 1e-6);
  // Failures on alice's page are forgiven by alice's token, bob's stay.
  throttle.Failed("10.0.0.1", "alice", t);
  throttle.Succeeded("10.0.0.1", "alice");
  t += std::chrono::seconds(3);
  throttle.Failed("10.0.0.1", "bob", t);
  EXPECT_NEAR(throttle.WaitFor("10.0.0.1", t), 4.0, 1e-6) << "seven of bob's: 4 s";
  throttle.Succeeded("10.0.0.1", "bob");
  t += std::chrono::seconds(5);
  EXPECT_EQ(throttle.WaitFor("10.0.0.1", t), 0);
  for (int i = 0; i < BadTokenThrottle::kFreeFailures - 1; ++i) throttle.Failed("10.0.0.1", "x", t);
  EXPECT_EQ(throttle.WaitFor("10.0.0.1", t), 0) << "bob's own token cleared bob's count";
}

// The server on 127.0.0.1 with a class of two; rigs only where a test starts one.
class ClassServerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const char* bin = std::getenv("SIRUPP_BIN_DIR");
    if (bin == nullptr) GTEST_SKIP() << "SIRUPP_BIN_DIR not set (ctest sets it)";
    dir_ = TempDir("sirupp-class-test");
    config_ = ParseClassConfig(kGood, "class.yaml", dir_);
    config_.pin_rigs = true;  // off by default; its placement is checked here
    harness_ = std::make_unique<testing::TestClassServer>(config_, bin, 20);
    tokens_ = harness_->tokens;
    client_ = harness_->client.get();
    port_ = harness_->port;
  }
  void TearDown() override {
    harness_.reset();
    if (!dir_.empty()) fs::remove_all(dir_);
  }
  httplib::Result Get(const std::string& path, const std::string& token) {
    httplib::Headers headers;
    if (!token.empty()) headers.emplace("X-Sirupp-Token", token);
    return client_->Get(path.c_str(), headers);
  }
  httplib::Result Post(const std::string& path, const std::string& token,
                       const std::string& body = "{}") {
    httplib::Headers headers{{"X-Sirupp-Client", "test"}};
    if (!token.empty()) headers.emplace("X-Sirupp-Token", token);
    return client_->Post(path.c_str(), headers, body, "application/json");
  }
  static std::string Error(const httplib::Result& r) {
    const Json body = Json::parse(r->body, nullptr, false);
    if (!body.is_object() || !body.contains("error") || !body.at("error").is_string()) {
      return "(no error)";
    }
    return body.at("error").get<std::string>();
  }

  std::string dir_;
  ClassConfig config_;
  std::unique_ptr<testing::TestClassServer> harness_;
  int port_ = 0;
  std::map<std::string, std::string> tokens_;
  httplib::Client* client_ = nullptr;  // harness_'s
};

TEST_F(ClassServerTest, TokensFileAndHandout) {
  EXPECT_EQ(tokens_.size(), 3u);  // teacher, alice, bob
  std::ifstream in(HandoutFile(config_));
  std::string header;
  std::getline(in, header);
  EXPECT_EQ(header, "student,address");
  EXPECT_TRUE(IssueMissingTokens(config_, port_).empty()) << "only missing tokens are issued";
  const auto row = ReissueToken(config_, port_, "bob");
  EXPECT_NE(row.second.find("/s/bob/?token="), std::string::npos);
  EXPECT_THROW(ReissueToken(config_, port_, "mallory"), core::UsageError);
}

TEST_F(ClassServerTest, RefusesWithoutTheRightTokenAndSlowsRepeatedBadOnes) {
  auto r = Get("/s/alice/api/state", "");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 403);
  EXPECT_NE(Error(r).find("no token"), std::string::npos) << Error(r);
  r = Get("/s/alice/api/state", tokens_["bob"]);
  EXPECT_EQ(r->status, 403);
  EXPECT_NE(Error(r).find("does not open /s/alice/"), std::string::npos) << Error(r);
  r = Get("/teacher/api/rigs", tokens_["alice"]);
  EXPECT_EQ(r->status, 403);
  r = Get("/s/nobody/", tokens_["alice"]);
  EXPECT_EQ(r->status, 403);
  r = Get("/nothing-here", "");
  EXPECT_EQ(r->status, 404);
  // The fifth bad token locks the address out; even a good token waits (429, Retry-After).
  r = Get("/s/alice/api/state", "0123");
  EXPECT_EQ(r->status, 403);
  r = Get("/s/alice/api/state", "4567");
  EXPECT_EQ(r->status, 403);
  r = Get("/s/alice/api/state", tokens_["alice"]);
  EXPECT_EQ(r->status, 429) << r->body;
  EXPECT_TRUE(r->has_header("Retry-After"));
  std::this_thread::sleep_for(std::chrono::milliseconds(1100));
  r = Get("/s/alice/api/state", tokens_["alice"]);
  EXPECT_EQ(r->status, 503) << r->body;  // the right token: alice's rig is not started yet
  EXPECT_NE(Error(r).find("reload the page"), std::string::npos) << Error(r);
}

TEST_F(ClassServerTest, TheTeachersViewListsEveryRigAndRefusesBadCommands) {
  auto r = Get("/teacher/api/rigs", tokens_["teacher"]);
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 200) << r->body;
  const Json rigs = Json::parse(r->body);
  EXPECT_EQ(rigs["class"], "robotics-1");
  ASSERT_EQ(rigs["rigs"].size(), 2u);
  EXPECT_EQ(rigs["rigs"][0]["state"], "stopped");
  EXPECT_EQ(Post("/teacher/api/estop", tokens_["teacher"], "[1")->status, 400);
  EXPECT_EQ(Post("/teacher/api/estop", tokens_["teacher"], "{\"engaged\": 3}")->status, 400);
  EXPECT_EQ(Post("/teacher/api/rigs/mallory/stop", tokens_["teacher"])->status, 404);
  EXPECT_EQ(Post("/teacher/api/rigs/alice/explode", tokens_["teacher"])->status, 404);
  // Without the page's header a POST is refused (another site cannot send it).
  httplib::Headers headers{{"X-Sirupp-Token", tokens_["teacher"]}};
  EXPECT_EQ(client_->Post("/teacher/api/estop", headers, "{}", "application/json")->status, 400);
}

// This process's children (the rigs' processes, since the server runs in the test).
std::vector<int> Children() {
  std::vector<int> out;
  for (const auto& entry : fs::directory_iterator("/proc")) {
    const std::string name = entry.path().filename().string();
    if (name.find_first_not_of("0123456789") != std::string::npos) continue;
    std::ifstream stat(entry.path() / "stat");
    std::string text;
    std::getline(stat, text);
    const size_t close = text.rfind(')');
    if (close == std::string::npos) continue;
    std::istringstream fields(text.substr(close + 2));
    std::string state;
    int ppid = 0;
    fields >> state >> ppid;
    if (ppid == ::getpid() && state != "Z") out.push_back(std::stoi(name));
  }
  return out;
}

// The CPUs a process may run on, as /proc/PID/status lists them ("0-1", "1").
std::string CpusAllowed(int pid) {
  std::ifstream status("/proc/" + std::to_string(pid) + "/status");
  for (std::string line; std::getline(status, line);) {
    if (line.rfind("Cpus_allowed_list:", 0) == 0) {
      return line.substr(line.find_first_not_of(" \t", sizeof "Cpus_allowed_list:" - 1));
    }
  }
  return "";
}

// Counts the live processes among `pids`.
int Alive(const std::vector<int>& pids) {
  int alive = 0;
  for (const int pid : pids) {
    if (::kill(pid, 0) == 0) {
      std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
      std::string text;
      std::getline(stat, text);
      if (text.find(") Z") == std::string::npos) ++alive;
    }
  }
  return alive;
}

TEST_F(ClassServerTest, AStudentsRigStartsOnTheFirstVisitAndIsTheirsAlone) {
  // The page starts the rig (and answers once it is ready).
  auto r = Get("/s/alice/", tokens_["alice"]);
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 200) << r->body;
  EXPECT_NE(r->body.find("id=\"class-bar\""), std::string::npos);
  EXPECT_NE(r->body.find("id=\"real-arm-queue\""), std::string::npos);
  r = Get("/s/alice/api/state", tokens_["alice"]);
  ASSERT_EQ(r->status, 200) << r->body;
  EXPECT_TRUE(Json::parse(r->body).contains("virtual")) << r->body;
  // Bob's token does not open it, whatever the path (four tries: the fifth would lock this
  // address out for a second).
  for (const char* path : {"/s/alice/api/state", "/s/alice/api/files?dir=results",
                           "/s/alice/panel.js", "/s/alice/class/status"}) {
    EXPECT_EQ(Get(path, tokens_["bob"])->status, 403) << path;
  }
  // A question of the page reaches the rig's API; a command moves it (with the lock).
  r = Post("/s/alice/api/lock", tokens_["alice"], R"({"name": "alice"})");
  EXPECT_EQ(r->status, 200) << r->body;
  r = Post("/s/alice/api/move/joints", tokens_["alice"],
           R"({"targets": [10, null, null, null, null, null]})");
  EXPECT_EQ(r->status, 200) << r->body;
  // The teacher's token reads it, but may not command it.
  EXPECT_EQ(Get("/s/alice/api/state", tokens_["teacher"])->status, 200);
  r = Post("/s/alice/api/move/joints", tokens_["teacher"],
           R"({"targets": [0, null, null, null, null, null]})");
  EXPECT_EQ(r->status, 403);
  EXPECT_NE(Error(r).find("read-only"), std::string::npos) << Error(r);
  // Static files and the JavaScript libraries under the prefix; no escape from them.
  EXPECT_EQ(Get("/s/alice/panel.js", tokens_["alice"])->status, 200);
  EXPECT_EQ(Get("/s/alice/js/three/three.min.js", tokens_["alice"])->status, 200);
  EXPECT_EQ(Get("/s/alice/js/three/../../../../etc/passwd", tokens_["alice"])->status, 404);
  EXPECT_EQ(Get("/s/alice/api/file?path=../../tokens.json", tokens_["alice"])->status / 100, 4);
  // The teacher's list shows the rig running with its processes; stopping it ends them.
  Json rigs = Json::parse(Get("/teacher/api/rigs", tokens_["teacher"])->body);
  EXPECT_EQ(rigs["running"], 1);
  EXPECT_EQ(rigs["rigs"][0]["state"], "running");
  const std::string log = StudentFolder(config_, "alice") + "/logs/sirupp-sim.log";
  EXPECT_TRUE(fs::exists(log));
  const std::vector<int> rig = Children();
  EXPECT_EQ(rig.size(), 3u) << "sim, control and logger";
  // limits.pin_rigs (on in this fixture): where the server may use two CPUs or more, the rig's
  // three processes share the one the page names.
  const int on_cpu = rigs["rigs"][0]["on_cpu"].get<int>();
  if (CpusAllowed(::getpid()).find_first_of(",-") != std::string::npos) {
    EXPECT_GE(on_cpu, 0);
    for (const int pid : rig) EXPECT_EQ(CpusAllowed(pid), std::to_string(on_cpu)) << pid;
    // A second rig goes on another CPU: the one with the fewest rigs.
    r = Post("/s/bob/class/start", tokens_["bob"]);
    ASSERT_EQ(r->status, 200) << r->body;
    const Json both = Json::parse(Get("/teacher/api/rigs", tokens_["teacher"])->body);
    EXPECT_GE(both["rigs"][1]["on_cpu"].get<int>(), 0);
    EXPECT_NE(both["rigs"][1]["on_cpu"].get<int>(), on_cpu);
    EXPECT_EQ(Post("/teacher/api/rigs/bob/stop", tokens_["teacher"])->status, 200);
  } else {
    EXPECT_EQ(on_cpu, -1) << "one CPU: nothing to choose";
  }
  r = Post("/teacher/api/rigs/alice/stop", tokens_["teacher"]);
  EXPECT_EQ(r->status, 200) << r->body;
  EXPECT_EQ(Alive(rig), 0) << "the stopped rig's processes ended";
  rigs = Json::parse(Get("/teacher/api/rigs", tokens_["teacher"])->body);
  EXPECT_EQ(rigs["rigs"][0]["state"], "stopped");
  EXPECT_EQ(rigs["rigs"][0]["last_stop"], "stopped by the teacher");
  r = Get("/s/alice/api/state", tokens_["alice"]);
  EXPECT_EQ(r->status, 503);
  // The student's folder stays; the next visit starts a rig on it again.
  EXPECT_TRUE(fs::exists(StudentFolder(config_, "alice") + "/config/robots/puma260.yaml"));
  r = Post("/s/alice/class/start", tokens_["alice"]);
  EXPECT_EQ(r->status, 200) << r->body;
  const Json status = Json::parse(Get("/s/alice/class/status", tokens_["alice"])->body);
  EXPECT_EQ(status["state"], "running");
  EXPECT_EQ(status["starts"], 2);
  EXPECT_EQ(status["last_stop"], "stopped by the teacher");
}

// A student's page lists the real arm's events about them: bob's does not list bobby's (issue 41:
// the events were picked by a substring of the name).
TEST(RealArmTest, AStudentSeesTheirEventsNotThoseOfALongerNameBeginningLikeTheirs) {
  const std::string dir = TempDir("sirupp-class-real-arm");
  ClassConfig config;
  config.robot = fs::absolute("config/robots/puma260.yaml").string();
  config.students = {"bob", "bobby"};
  config.real_arm = RealArmConfig{};
  config.real_arm->lcm_url = "memq://";
  {
    RealArm arm(config, dir + "/turns.jsonl", [](const std::string&) { return std::string(); });
    arm.StudentCommand("bobby", "join");
    arm.RigStopped("bobby", "stopped by the teacher");
    const Json bobby = arm.StudentJson("bobby")["events"];
    ASSERT_GE(bobby.size(), 2u) << bobby.dump();
    EXPECT_TRUE(arm.StudentJson("bob")["events"].empty()) << arm.StudentJson("bob").dump();
    arm.StudentCommand("bob", "join");
    const Json bob = arm.StudentJson("bob")["events"];
    ASSERT_FALSE(bob.empty());
    for (const Json& line : bob) {
      EXPECT_EQ(line.get<std::string>().find("bobby"), std::string::npos) << bob.dump();
    }
    EXPECT_EQ(arm.StudentJson("bobby")["events"], bobby) << "bob's events are not bobby's";
  }
  fs::remove_all(dir);
}

// Another program talking on a port of the rigs' range (a lab's `sirupp launch` there, a test's
// rig, a rig that did not end): LCM shares its port, so a rig started on it would share a bus
// with it (issue 41: a sim's tick "went back" when two sims met on one bus). The server listens
// before it starts a rig and takes a quiet port, or refuses with what it heard.
class Talker {
 public:
  explicit Talker(int port) : port_(port), thread_([this] { Run(); }) {}
  ~Talker() {
    stop_ = true;
    thread_.join();
  }

 private:
  void Run() {
    const int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
    const unsigned char ttl = 0;
    ::setsockopt(fd, IPPROTO_IP, IP_MULTICAST_TTL, &ttl, sizeof ttl);
    sockaddr_in to{};
    to.sin_family = AF_INET;
    to.sin_port = htons(static_cast<uint16_t>(port_));
    ::inet_pton(AF_INET, "239.255.76.67", &to.sin_addr);
    // An LCM short message's header (magic "LC02", sequence number, channel) and a payload.
    const char datagram[] = "LC02\0\0\0\1HEARTBEAT\0another program";
    while (!stop_) {
      ::sendto(fd, datagram, sizeof datagram, 0, reinterpret_cast<const sockaddr*>(&to), sizeof to);
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    ::close(fd);
  }
  int port_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

TEST(ClassServerPortTest, ARigDoesNotStartOnAPortWhereAnotherProgramTalks) {
  const char* bin = std::getenv("SIRUPP_BIN_DIR");
  if (bin == nullptr) GTEST_SKIP() << "SIRUPP_BIN_DIR not set (ctest sets it)";
  const std::string dir = TempDir("sirupp-class-port");
  const int first = 60000 + 2 * (::getpid() % 2500);  // two ports no other test uses
  const Talker talker(first);
  const auto post = [](testing::TestClassServer& server, const std::string& path,
                       const std::string& token) {
    return server.client->Post(
        path.c_str(), httplib::Headers{{"X-Sirupp-Client", "test"}, {"X-Sirupp-Token", token}},
        "{}", "application/json");
  };
  {
    // Two ports, one talked on: every start takes the other.
    const ClassConfig config = ParseClassConfig(
        std::string(kGood) + "rigs: {first_port: " + std::to_string(first) + ", port_count: 2}\n",
        "class.yaml", dir);
    testing::TestClassServer server(config, bin, 30);
    for (int i = 0; i < 4; ++i) {
      auto r = post(server, "/s/alice/class/start", server.tokens["alice"]);
      ASSERT_TRUE(r);
      ASSERT_EQ(r->status, 200) << r->body;
      r = server.client->Get("/s/alice/class/status", {{"X-Sirupp-Token", server.tokens["alice"]}});
      ASSERT_TRUE(r);
      EXPECT_EQ(Json::parse(r->body)["port"], first + 1) << "start " << i << ": " << r->body;
      r = post(server, "/teacher/api/rigs/alice/stop", server.tokens["teacher"]);
      ASSERT_TRUE(r);
      EXPECT_EQ(r->status, 200) << r->body;
    }
  }
  {
    // The only port talked on: refused, naming what was heard.
    fs::create_directories(dir + "/one-port");
    ClassConfig config = ParseClassConfig(
        std::string(kGood) + "rigs: {first_port: " + std::to_string(first) + ", port_count: 2}\n",
        "class.yaml", dir + "/one-port");
    config.port_count = 1;
    config.max_rigs = 1;
    testing::TestClassServer server(config, bin, 30);
    const auto r = post(server, "/s/alice/class/start", server.tokens["alice"]);
    ASSERT_TRUE(r);
    EXPECT_EQ(r->status, 503) << r->body;
    EXPECT_NE(r->body.find("something else talks"), std::string::npos) << r->body;
    EXPECT_NE(r->body.find("HEARTBEAT"), std::string::npos) << r->body;
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace sirupp::classroom

namespace sirupp::classroom {
namespace {

// HTTPS when the class file names a certificate and key (a self-signed pair made here by the
// openssl command); a key that does not match is refused at start with both paths named.
// Stop() may come before Serve() has started its loop (a test that ends at once, a server told to
// stop while starting): Serve() then returns, and a Stop() while it starts ends it. httplib's own
// stop() does nothing before its loop runs; CI once waited 900 s on that (panel::ListenGate).
TEST(ClassServerStopTest, AStopBeforeOrWhileServingStartsEndsIt) {
  const std::string dir = TempDir("sirupp-class-stop");
  const ClassConfig config = ParseClassConfig(kGood, "class.yaml", dir);
  ServeOptions options;
  options.class_web_dir = fs::absolute("class/web").string();
  {
    ClassServer server(config, options);
    server.Bind();
    server.Stop();
    const auto start = std::chrono::steady_clock::now();
    server.Serve();  // returns at once
    EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(5));
  }
  for (int i = 0; i < 20; ++i) {  // Stop() racing the loop's start
    ClassServer server(config, options);
    server.Bind();
    std::thread serving([&] { server.Serve(); });
    if (i % 2 == 1) std::this_thread::sleep_for(std::chrono::microseconds(200 * i));
    server.Stop();
    serving.join();  // the test's timeout is the failure
  }
  fs::remove_all(dir);
}

TEST(ClassServerTlsTest, ServesHttpsWithTheGivenCertificate) {
  const std::string dir = TempDir("sirupp-class-tls");
  const std::string make =
      "openssl req -x509 -newkey rsa:2048 -nodes -days 1 -subj /CN=localhost"
      " -keyout " +
      dir + "/key.pem -out " + dir + "/cert.pem 2>/dev/null";
  if (std::system(make.c_str()) != 0) GTEST_SKIP() << "no openssl command";
  ClassConfig config =
      ParseClassConfig(std::string(kGood) + "rigs: {first_port: 7900}\n", "class.yaml", dir);
  config.tls_cert = dir + "/cert.pem";
  config.tls_key = dir + "/key.pem";
  ServeOptions options;
  options.class_web_dir = fs::absolute("class/web").string();
  ClassServer server(config, options);
  const int port = server.Bind();
  const auto rows = IssueMissingTokens(config, port);
  EXPECT_EQ(rows[0].second.rfind("https://127.0.0.1:", 0), 0u) << rows[0].second;
  const std::string teacher = rows[0].second.substr(rows[0].second.find("token=") + 6);
  std::thread serving([&] { server.Serve(); });
  httplib::SSLClient client("127.0.0.1", port);
  client.enable_server_certificate_verification(false);  // self-signed
  const auto r = client.Get("/teacher/api/rigs", {{"X-Sirupp-Token", teacher}});
  ASSERT_TRUE(r) << httplib::to_string(r.error());
  EXPECT_EQ(r->status, 200);
  httplib::Client plain("127.0.0.1", port);
  plain.set_read_timeout(2, 0);
  const auto answer = plain.Get("/teacher/api/rigs");
  EXPECT_TRUE(!answer || answer->status != 200) << "plain HTTP got a page";
  server.Stop();
  serving.join();
  // A key of another pair: refused at start.
  (void)std::system(("openssl req -x509 -newkey rsa:2048 -nodes -days 1 -subj /CN=x -keyout " +
                     dir + "/other.pem -out " + dir + "/other-cert.pem 2>/dev/null")
                        .c_str());
  config.tls_key = dir + "/other.pem";
  try {
    ClassServer refused(config, options);
    ADD_FAILURE() << "a mismatched key was accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("other.pem"), std::string::npos) << e.what();
  }
  fs::remove_all(dir);
}

// The rig job's script, run by sh as Slurm runs it: sirupp-rig-job gets each word as it was, also
// a folder with a space and a quote in it (here a stand-in that prints its arguments).
TEST(RigJobScriptTest, ShExecsTheRigJobWithEachWordAsItWas) {
  const fs::path dir =
      fs::temp_directory_path() / ("sirupp-rig-script-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  {
    std::ofstream stand_in(dir / "sirupp-rig-job");
    stand_in << "#!/bin/sh\nfor word in \"$@\"; do printf '[%s]\\n' \"$word\"; done\n";
  }
  fs::permissions(dir / "sirupp-rig-job", fs::perms::owner_all);
  RigJobSpec spec;
  spec.student = "alice";
  spec.folder = "/srv/class one/alice's";
  spec.robot = "/srv/robots/puma260.yaml";
  spec.bin_dir = dir.string();
  spec.secret_file = "/srv/class one/.secrets/alice";
  spec.report_url = "http://10.0.0.1:8080/cluster/report";
  spec.controller = "ctl.so";
  spec.memory_mb = 512;
  const std::string script = RigJobScript(spec);
  EXPECT_EQ(script.rfind("#!/bin/sh\n# alice's rig (sirupp class serve, cluster:)\nexec ", 0), 0u)
      << script;
  const fs::path script_file = dir / "job.sh";
  std::ofstream(script_file) << script;
  const fs::path out_file = dir / "out.txt";
  ASSERT_EQ(std::system(("sh " + script_file.string() + " > " + out_file.string()).c_str()), 0);
  std::ifstream out(out_file);
  std::stringstream words;
  words << out.rdbuf();
  EXPECT_EQ(words.str(),
            "[--student]\n[alice]\n[--folder]\n[/srv/class one/alice's]\n[--robot]\n"
            "[/srv/robots/puma260.yaml]\n[--secret-file]\n[/srv/class one/.secrets/alice]\n"
            "[--report-url]\n[http://10.0.0.1:8080/cluster/report]\n[--pace-ticks]\n[4]\n"
            "[--memory-mb]\n[512]\n[--controller]\n[ctl.so]\n");
  fs::remove_all(dir);
}

}  // namespace
}  // namespace sirupp::classroom
