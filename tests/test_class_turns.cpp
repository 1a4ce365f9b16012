// The real arm by turns through the class server (class/real_arm.hpp, issue 33): a class of three
// whose rigs are real processes (sirupp-sim realtime, sirupp-control, sirupp-logger on leased
// udpm ports, ttl=0), the bridge on the emulated boards on a udpm bus of its own (class file
// real_arm.lcm_url), every command over HTTP as the pages send it. The students join from their
// page and take turns; the arm is homed within 1 deg and disarmed between the turns; a student out
// of turn is refused the bridge's commands with the reason; an e-stop from a student without a
// turn stops the real arm; the handover that follows cannot finish and the teacher's page says why.

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <sirupp/arm_state_t.hpp>
#include <sirupp/hardware_status_t.hpp>
#include <thread>
#include <vector>

#include "class/class_config.hpp"
#include "class/class_server.hpp"
#include "core/bus.hpp"
#include "core/channels.hpp"
#include "core/model_loader.hpp"
#include "grade/port_lease.hpp"
#include "panel/httplib_include.hpp"
#include "tests/class_server_harness.hpp"
#include "tests/emulated_bridge.hpp"

namespace sirupp::classroom {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;
using Status = sirupp::hardware_status_t;
constexpr double kDeg = 3.14159265358979323846 / 180;

// The bridge on its own udpm bus, serviced by a thread; what it said, kept for the test.
class ArmOnItsBus {
 public:
  explicit ArmOnItsBus(const std::string& url)
      : model_(core::LoadRobotModel("config/robots/puma260.yaml")), bus_(url, "") {
    arm_ = std::make_unique<testing::EmulatedBridge>(bus_, model_);
    bus_.Subscribe<Status>(
        core::Channels{}.hardware_status,
        [this](const Status& s, const core::ReceiveInfo&) {
          const std::lock_guard<std::mutex> lock(mutex_);
          if (states_.empty() || states_.back() != s.state) states_.push_back(s.state);
        },
        100);
    bus_.Subscribe<sirupp::arm_state_t>(
        core::Channels{}.real_arm_state,
        [this](const sirupp::arm_state_t& s, const core::ReceiveInfo&) {
          const std::lock_guard<std::mutex> lock(mutex_);
          real_ = s.position;
        },
        2);
    thread_ = std::thread([this] {
      while (!stop_) arm_->bridge->Service(2);
    });
  }
  ~ArmOnItsBus() {
    stop_ = true;
    thread_.join();
  }
  std::vector<int8_t> States() const {
    const std::lock_guard<std::mutex> lock(mutex_);
    return states_;
  }
  int8_t State() const {
    const std::lock_guard<std::mutex> lock(mutex_);
    return states_.empty() ? int8_t{-1} : states_.back();
  }
  double RealDeg(size_t joint) const {
    const std::lock_guard<std::mutex> lock(mutex_);
    return joint < real_.size() ? real_[joint] / kDeg : NAN;
  }

 private:
  core::RobotModel model_;
  core::Bus bus_;
  std::unique_ptr<testing::EmulatedBridge> arm_;
  mutable std::mutex mutex_;
  std::vector<int8_t> states_;  // each change
  std::vector<double> real_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

bool Eventually(const std::function<bool()>& done, double seconds) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (std::chrono::steady_clock::now() < end) {
    if (done()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  return done();
}

class ClassTurnsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const char* bin = std::getenv("SIRUPP_BIN_DIR");
    if (bin == nullptr) GTEST_SKIP() << "SIRUPP_BIN_DIR not set (ctest sets it)";
    char pattern[] = "/tmp/sirupp-class-turns-XXXXXX";
    ASSERT_NE(::mkdtemp(pattern), nullptr);
    dir_ = pattern;
    // The arm's bus: a port of its own, outside the rigs' range (7900..8099 below).
    arm_lease_ = grade::PortLease::Acquire(7600, 200, static_cast<int>(::getpid() % 200));
    const std::string arm_url =
        "udpm://239.255.76.67:" + std::to_string(arm_lease_.port()) + "?ttl=0";
    arm_ = std::make_unique<ArmOnItsBus>(arm_url);
    const std::string text =
        "class: turns-test\n"
        "robot: config/robots/puma260.yaml\n"
        "students: [alice, bob, carol]\n"
        "data: data\n"
        "limits: {max_rigs: 3, idle_timeout_s: 600}\n"
        "server: {port: 0}\n"
        "rigs: {first_port: 7900, port_count: 200}\n"
        "real_arm: {lcm_url: \"" +
        arm_url + "\", turn_s: 60, warn_before_s: [10]}\n";
    config_ = ParseClassConfig(text, "class.yaml", dir_);
    harness_ = std::make_unique<testing::TestClassServer>(config_, bin, 30);
    tokens_ = harness_->tokens;
    client_ = harness_->client.get();
  }
  void TearDown() override {
    harness_.reset();
    arm_.reset();
    if (!dir_.empty()) fs::remove_all(dir_);
  }
  httplib::Result Get(const std::string& path, const std::string& who) {
    return client_->Get(path.c_str(), httplib::Headers{{"X-Sirupp-Token", tokens_[who]}});
  }
  httplib::Result Post(const std::string& path, const std::string& who, const Json& body = {}) {
    return client_->Post(
        path.c_str(), httplib::Headers{{"X-Sirupp-Token", tokens_[who]}, {"X-Sirupp-Client", who}},
        body.is_null() ? "{}" : body.dump(), "application/json");
  }
  Json Turns(const std::string& student) {
    const auto r = Get("/s/" + student + "/class/turns", student);
    if (!r || r->status != 200) return Json::object();
    return Json::parse(r->body);
  }
  Json Teacher() {
    const auto r = Get("/teacher/api/turns", "teacher");
    if (!r || r->status != 200) return Json::object();
    return Json::parse(r->body);
  }
  bool TurnOf(const std::string& student, double seconds = 90) {
    return Eventually(
        [&] {
          const Json t = Turns(student);
          return t.contains("you") && t["you"]["in_turn"] == true;
        },
        seconds);
  }
  static std::string Error(const httplib::Result& r) {
    const Json body = Json::parse(r->body, nullptr, false);
    return body.is_object() && body.contains("error") ? body["error"].get<std::string>() : r->body;
  }
  // The student's virtual arm moved through their panel's API (the lock first, as the page does).
  void Move(const std::string& student, const std::vector<double>& degrees) {
    const std::string base = "/s/" + student + "/api/";
    auto r = Post(base + "lock", student, Json{{"name", student}});
    ASSERT_TRUE(r);
    ASSERT_EQ(r->status, 200) << r->body;
    r = Post(base + "move/joints", student, Json{{"targets", degrees}});
    ASSERT_TRUE(r);
    ASSERT_EQ(r->status, 200) << r->body;
  }

  std::string dir_;
  grade::PortLease arm_lease_;
  std::unique_ptr<ArmOnItsBus> arm_;
  ClassConfig config_;
  std::unique_ptr<testing::TestClassServer> harness_;
  std::map<std::string, std::string> tokens_;
  httplib::Client* client_ = nullptr;  // harness_'s
};

TEST_F(ClassTurnsTest, ThreeStudentsTakeTurnsThroughTheirPages) {
  // The rigs start on the students' first visits; the bar has the queue's place.
  for (const char* name : {"alice", "bob", "carol"}) {
    const auto page = Get(std::string("/s/") + name + "/", name);
    ASSERT_TRUE(page);
    ASSERT_EQ(page->status, 200) << page->body;
    EXPECT_NE(page->body.find("id=\"real-arm-queue\""), std::string::npos);
  }
  EXPECT_EQ(Turns("bob")["enabled"], true);

  // Join from the pages; a second join and an unknown verb are refused with the reason.
  ASSERT_EQ(Post("/s/alice/class/turns/join", "alice")->status, 200);
  ASSERT_EQ(Post("/s/bob/class/turns/join", "bob")->status, 200);
  ASSERT_EQ(Post("/s/carol/class/turns/join", "carol")->status, 200);
  auto r = Post("/s/bob/class/turns/join", "bob");
  EXPECT_EQ(r->status, 409);
  EXPECT_NE(Error(r).find("already in the queue"), std::string::npos) << Error(r);
  EXPECT_EQ(Post("/s/bob/class/turns/explode", "bob")->status, 404);
  EXPECT_EQ(Post("/s/alice/class/turns/join", "bob")->status, 403);  // not bob's page

  // Alice's turn: Bob sees his place and wait; Bob's commands for the bridge are refused.
  ASSERT_TRUE(TurnOf("alice")) << Teacher().dump(1);
  const Json bob = Turns("bob");
  EXPECT_EQ(bob["you"]["place"], 1) << bob.dump(1);
  EXPECT_GT(bob["you"]["estimated_wait_s"].get<double>(), 0) << bob.dump(1);
  EXPECT_EQ(bob["holder"], "alice");
  r = Post("/s/bob/api/hardware/arm", "bob");
  EXPECT_EQ(r->status, 409);
  EXPECT_NE(Error(r).find("in alice's turn"), std::string::npos) << Error(r);
  // (The bridge's own status comes back to this test's subscriber a little after the manager's.)
  EXPECT_TRUE(Eventually([&] { return arm_->State() == Status::STATE_LINKED; }, 2));

  // Alice's move reaches the real arm; Bob's moves his own virtual arm only.
  Move("alice", {20, -90, 90, 0, 45, 0});
  EXPECT_TRUE(Eventually([&] { return std::abs(arm_->RealDeg(0) - 20) < 1.5; }, 20))
      << "real joint 1 at " << arm_->RealDeg(0);
  Move("bob", {-30, 0, 0, 0, 0, 0});
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));
  EXPECT_NEAR(arm_->RealDeg(0), 20, 1.5) << "bob's move reached the real arm";

  // Alice ends her turn: the arm is held, homed, checked, disarmed; then Bob's turn; Bob moves
  // and ends his; then Carol's.
  ASSERT_EQ(Post("/s/alice/class/turns/done", "alice")->status, 200);
  ASSERT_TRUE(TurnOf("bob")) << Teacher().dump(1);
  Move("bob", {-15, -90, 90, 0, 45, 0});
  EXPECT_TRUE(Eventually([&] { return std::abs(arm_->RealDeg(0) + 15) < 1.5; }, 20))
      << "real joint 1 at " << arm_->RealDeg(0);
  ASSERT_EQ(Post("/s/bob/class/turns/done", "bob")->status, 200);
  ASSERT_TRUE(TurnOf("carol")) << Teacher().dump(1);
  const Json teacher = Teacher();
  ASSERT_EQ(teacher["history"].size(), 3u) << teacher.dump(1);
  for (int i = 0; i < 2; ++i) {
    EXPECT_EQ(teacher["history"][i]["ended"], "done");
    EXPECT_EQ(teacher["history"][i]["handover"], "ok");
  }
  {
    std::ifstream log(TurnsLogFile(config_));
    std::string line;
    std::vector<std::string> homed;
    while (std::getline(log, line)) {
      const Json entry = Json::parse(line, nullptr, false);
      if (!entry.is_object() || !entry.contains("home_offset_deg")) continue;
      homed.push_back(entry["turn"]);
      EXPECT_LT(entry["home_offset_deg"].get<double>(), 1.0) << line;
    }
    EXPECT_EQ(homed, (std::vector<std::string>{"alice", "bob"})) << TurnsLogFile(config_);
  }
  // Between every two links the bridge was disarmed (connected).
  int links = 0;
  bool disarmed = true;
  for (const int8_t s : arm_->States()) {
    if (s == Status::STATE_LINKED) {
      EXPECT_TRUE(disarmed) << "link " << links + 1 << " without a disarm before it";
      ++links;
      disarmed = false;
    } else if (s == Status::STATE_CONNECTED) {
      disarmed = true;
    }
  }
  EXPECT_EQ(links, 3);

  // Alice, without a turn, e-stops the real arm from her page: it stops at once.
  ASSERT_EQ(Post("/s/alice/class/turns/estop", "alice")->status, 200);
  EXPECT_TRUE(Eventually([&] { return arm_->State() == Status::STATE_ESTOPPED; }, 1.0));
  // The teacher ends Carol's turn: the handover cannot home an e-stopped arm, the queue stops, and
  // the teacher's page says why; nobody gets the arm.
  ASSERT_EQ(Post("/teacher/api/turns/end", "teacher")->status, 200);
  ASSERT_TRUE(Eventually([&] { return Teacher()["phase"] == "stopped"; }, 30)) << Teacher().dump(1);
  const std::string stopped = Teacher()["stopped"];
  EXPECT_NE(stopped.find("handover after carol's turn failed"), std::string::npos) << stopped;
  EXPECT_NE(stopped.find("e-stopped"), std::string::npos) << stopped;
  ASSERT_EQ(Post("/s/alice/class/turns/join", "alice")->status, 200);
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  EXPECT_EQ(Teacher()["phase"], "stopped");
  EXPECT_NE(Turns("alice")["stopped"].get<std::string>().find("e-stopped"), std::string::npos);

  // The teacher sees to the arm: releases the e-stop, skips Alice, resumes.
  ASSERT_EQ(Post("/teacher/api/turns/release", "teacher")->status, 200);
  EXPECT_EQ(Post("/teacher/api/turns/skip", "teacher", Json{{"student", "alice"}})->status, 200);
  EXPECT_EQ(Post("/teacher/api/turns/skip", "teacher", Json{{"student", "alice"}})->status, 409);
  EXPECT_EQ(Post("/teacher/api/turns/skip", "teacher", Json{{"who", 3}})->status, 400);
  ASSERT_EQ(Post("/teacher/api/turns/resume", "teacher")->status, 200);
  EXPECT_EQ(Teacher()["phase"], "idle");
  // The session's log, for the record (handover times, home offsets).
  {
    std::ifstream log(TurnsLogFile(config_));
    std::cout << "the session's log (" << TurnsLogFile(config_) << "):\n";
    for (std::string line; std::getline(log, line);) std::cout << "  " << line << "\n";
  }
  // The class's stream carries the queue too.
  const auto rigs = Get("/teacher/api/rigs", "teacher");
  ASSERT_TRUE(rigs);
  EXPECT_EQ(Json::parse(rigs->body)["real_arm"]["enabled"], true);
}

TEST(ClassTurnsConfigTest, TheRealArmKeyIsCheckedLikeEveryOther) {
  const std::string head =
      "class: a\nrobot: config/robots/puma260.yaml\nstudents: [a]\ndata: d\n"
      "rigs: {first_port: 7900, port_count: 200}\n";
  const auto error = [&](const std::string& tail) {
    try {
      ParseClassConfig(head + tail, "c.yaml", fs::current_path().string());
    } catch (const std::exception& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(error("real_arm: {lcm_url: memq://}\n").find("c.yaml:6"), std::string::npos);
  EXPECT_NE(error("real_arm: {lcm_url: memq://}\n").find("not a udpm address"), std::string::npos);
  EXPECT_NE(error("real_arm: {lcm_url: \"udpm://239.255.76.67:7950?ttl=0\"}\n")
                .find("one the rigs lease"),
            std::string::npos);
  EXPECT_NE(error("real_arm: {lcm_url: \"udpm://239.255.76.67:7700\", turn_s: 2}\n").find("turn_s"),
            std::string::npos);
  EXPECT_NE(
      error("real_arm: {lcm_url: \"udpm://239.255.76.67:7700\", turn_s: 60, warn_before_s: [90]}\n")
          .find("less than turn_s"),
      std::string::npos);
  EXPECT_NE(
      error("real_arm: {lcm_url: \"udpm://239.255.76.67:7700\", colour: red}\n").find("colour"),
      std::string::npos);
  const ClassConfig good = ParseClassConfig(
      head + "real_arm: {lcm_url: \"udpm://239.255.76.67:7700?ttl=0\", turn_s: 300}\n", "c.yaml",
      fs::current_path().string());
  ASSERT_TRUE(good.real_arm.has_value());
  EXPECT_EQ(good.real_arm->turn_s, 300);
  EXPECT_EQ(good.real_arm->warn_before_s, (std::vector<double>{60, 10}));
}

}  // namespace
}  // namespace sirupp::classroom
