// The panel's request handling (panel/panel_api.cpp) on an in-process memq:// bus, without HTTP:
// routes and bad requests, the control lock, the token rule, file access limited to config/,
// what each command puts on the bus (or that nothing goes out when it is refused), and that the
// reply naming the request (command_reply_t, through the client library) is the HTTP answer: a
// stand-in controller and bridge here answer as sirupp-control and sirupp-hardware do.

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sirupp/estop_t.hpp>
#include <sirupp/hardware_command_t.hpp>
#include <sirupp/hardware_status_t.hpp>
#include <sirupp/heartbeat_t.hpp>
#include <sirupp/joint_target_t.hpp>
#include <sirupp/logger_command_t.hpp>
#include <sirupp/plan_command_t.hpp>
#include <sirupp/pose_target_t.hpp>
#include <sirupp/servo_gains_t.hpp>
#include <sirupp/sim_command_t.hpp>
#include <sstream>

#include "control/control_node.hpp"
#include "core/bus.hpp"
#include "core/command_reply.hpp"
#include "core/environment.hpp"
#include "core/kinematics.hpp"
#include "core/model_loader.hpp"
#include "core/translate.hpp"
#include "core/units.hpp"
#include "logger/recorder.hpp"
#include "panel/panel_api.hpp"
#include "panel/panel_hub.hpp"
#include "servo/chip_gains.hpp"
#include "sim/arm_world.hpp"
#include "sim/sim_node.hpp"

namespace sirupp::panel {
namespace {

constexpr double kPi = 3.14159265358979323846;

class PanelApiTest : public ::testing::Test {
 protected:
  PanelApiTest() {
    bus_.Subscribe<sirupp::joint_target_t>(
        "ARM_TARGET", [this](const sirupp::joint_target_t& m, const core::ReceiveInfo& info) {
          targets_.push_back(m);
          Answer(controller_, m, info, 7);
        });
    bus_.Subscribe<sirupp::pose_target_t>(
        "ARM_POSE_TARGET", [this](const sirupp::pose_target_t& m, const core::ReceiveInfo& info) {
          poses_.push_back(m);
          Answer(controller_, m, info, 8);
        });
    bus_.Subscribe<sirupp::estop_t>(
        "ESTOP",
        [this](const sirupp::estop_t& m, const core::ReceiveInfo&) { estops_.push_back(m); });
    bus_.Subscribe<sirupp::plan_command_t>(
        "ARM_PLAN", [this](const sirupp::plan_command_t& m, const core::ReceiveInfo& info) {
          plans_.push_back(m);
          Answer(controller_, m, info, m.command == sirupp::plan_command_t::COMMAND_RUN ? 9 : -1);
        });
    bus_.Subscribe<sirupp::servo_gains_t>(
        "ARM_GAINS", [this](const sirupp::servo_gains_t& m, const core::ReceiveInfo& info) {
          gains_.push_back(m);
          Answer(controller_, m, info, -1);
        });
    bus_.Subscribe<sirupp::hardware_command_t>(
        "HARDWARE_COMMAND",
        [this](const sirupp::hardware_command_t& m, const core::ReceiveInfo& info) {
          hardware_.push_back(m);
          Answer(bridge_, m, info, -1);
        });
  }

  // The stand-in replier answers as the real one does: accepted, or refused with refuse_ (as the
  // real one throws); nothing at all while silent_.
  template <class Msg>
  void Answer(core::Replier& replier, const Msg& m, const core::ReceiveInfo& info,
              int64_t move_id) {
    if (silent_) return;
    replier.Answer(
        m, info,
        [this] {
          if (!refuse_.empty()) throw std::invalid_argument(refuse_);
        },
        [&] {
          return core::ReplyFacts{refuse_.empty() ? move_id : -1, -1};
        });
  }

  // The sim's model and the controller's gains arrive on the bus.
  void PublishRig() {
    bus_.Publish("ROBOT_MODEL", core::ToMessage(model_, 0, 0));
    sirupp::servo_gains_t gains = servo::GainsMessage(servo::ChipGainsFromModel(model_));
    bus_.Publish("CONTROLLER_GAINS", gains);
    Pump();
  }
  void Pump() {
    for (int i = 0; i < 5; ++i) hub_.ServiceOnce(0);
  }

  Response Post(const std::string& path, const std::string& body, const std::string& client = "a",
                const std::string& token = "") {
    Request r{"POST", path, {}, body, "127.0.0.1", client, token};
    Response out = api_.Handle(r);
    Pump();
    return out;
  }
  Response Get(const std::string& path, std::map<std::string, std::string> query = {}) {
    return api_.Handle(Request{"GET", path, std::move(query), "", "127.0.0.1", "a", ""});
  }
  static Json Body(const Response& r) { return Json::parse(r.body); }

  core::RobotModel model_ = core::LoadRobotModel("config/robots/puma260.yaml");
  core::Bus bus_{"memq://"};
  PanelHub hub_{bus_, HubOptions{0.5, std::nullopt, 0.5}};
  core::Replier controller_{bus_, "CONTROLLER_REPLY", "stand-in sirupp-control"};
  core::Replier bridge_{bus_, "HARDWARE_REPLY", "stand-in sirupp-hardware"};
  std::string refuse_;   // the stand-ins refuse with this text when not empty
  bool silent_ = false;  // the stand-ins do not answer at all
  PanelApi api_{hub_, ApiOptions{".", "", false, "", std::chrono::seconds(30)}};
  std::vector<sirupp::joint_target_t> targets_;
  std::vector<sirupp::pose_target_t> poses_;
  std::vector<sirupp::estop_t> estops_;
  std::vector<sirupp::plan_command_t> plans_;
  std::vector<sirupp::servo_gains_t> gains_;
  std::vector<sirupp::hardware_command_t> hardware_;
};

TEST_F(PanelApiTest, ModelComesFromTheBus) {
  EXPECT_FALSE(Body(Get("/api/model"))["loaded"].get<bool>());
  PublishRig();
  const Json model = Body(Get("/api/model"));
  ASSERT_TRUE(model["loaded"].get<bool>());
  EXPECT_EQ(model["name"], "puma260");
  ASSERT_EQ(model["joints"].size(), 6U);
  EXPECT_EQ(model["joints"][1]["unit"], "deg");
  EXPECT_NEAR(model["joints"][1]["max"].get<double>(), model_.joints[1].position_max * 180 / kPi,
              1e-9);
  EXPECT_EQ(model["links"].size(), 7U);
}

TEST_F(PanelApiTest, BadRequestsGet4xxWithAMessage) {
  PublishRig();
  EXPECT_EQ(Post("/api/move/joints", "{}", "").status, 400);  // no client header
  Response r = Post("/api/move/joints", "{not json", "a");
  EXPECT_EQ(r.status, 400);
  EXPECT_NE(Body(r)["error"].get<std::string>().find("JSON"), std::string::npos);
  EXPECT_EQ(Get("/api/nothing").status, 404);
  EXPECT_EQ(api_.Handle(Request{"DELETE", "/api/lock", {}, "", "127.0.0.1", "a", ""}).status, 405);
  EXPECT_EQ(Post("/api/lock", R"({"name": 5})").status, 400);
  ASSERT_EQ(Post("/api/lock", R"({"name": "ann"})").status, 200);
  EXPECT_EQ(Post("/api/move/joints", R"({"targets": "x"})").status, 400);
  EXPECT_EQ(Post("/api/move/joints", R"({"targets": [1, 2]})").status, 400);  // 2 of 6 joints
  EXPECT_EQ(Post("/api/move/pose", R"({"pose": [0, 0]})").status, 400);
  EXPECT_EQ(Post("/api/gains", R"({"joint": 1.5, "values": {"kp": 1}})").status, 400);
  EXPECT_EQ(Post("/api/hardware/explode", "{}").status, 404);
  Response jump = Post("/api/plan/jump", "{}");
  EXPECT_EQ(jump.status, 404);
  EXPECT_EQ(Body(jump)["error"],
            "plan command 'jump' is unknown; allowed: pause, resume, abort, manual, automatic, "
            "clear-fault");
  EXPECT_EQ(Get("/api/files", {{"dir", "/etc"}}).status, 400);
  EXPECT_TRUE(targets_.empty());
  EXPECT_TRUE(plans_.empty());
}

TEST_F(PanelApiTest, JointMoveNeedsTheLockAndStaysInLimits) {
  PublishRig();
  const std::string move = R"({"targets": [null, 30, null, null, null, null], "speed": 0.5})";
  Response refused = Post("/api/move/joints", move);
  EXPECT_EQ(refused.status, 409);
  EXPECT_NE(Body(refused)["error"].get<std::string>().find("take control"), std::string::npos);
  ASSERT_EQ(Post("/api/lock", R"({"name": "ann"})").status, 200);
  ASSERT_EQ(Post("/api/move/joints", move).status, 200);
  ASSERT_EQ(targets_.size(), 1U);
  const sirupp::joint_target_t& t = targets_[0];
  ASSERT_EQ(t.num_joints, 6);
  EXPECT_EQ(t.active[0], 0);
  EXPECT_EQ(t.active[1], 1);
  EXPECT_NEAR(t.position[1], 30 * kPi / 180, 1e-12);
  EXPECT_NEAR(t.max_velocity[1], model_.joints[1].servo.default_velocity * 0.5, 1e-12);

  Response outside =
      Post("/api/move/joints", R"({"targets": [null, 400, null, null, null, null]})");
  EXPECT_EQ(outside.status, 400);
  EXPECT_NE(Body(outside)["error"].get<std::string>().find("joint 2"), std::string::npos);
  EXPECT_EQ(Post("/api/move/joints", R"({"targets": [1, 0, 0, 0, 0, 0], "speed": 3})").status, 400);
  EXPECT_EQ(targets_.size(), 1U);
}

TEST_F(PanelApiTest, SecondClientIsRefusedUntilItTakesOverAndEstopIsAlwaysAllowed) {
  PublishRig();
  ASSERT_EQ(Post("/api/lock", R"({"name": "ann"})", "a").status, 200);
  Response second = Post("/api/lock", R"({"name": "bob"})", "b");
  EXPECT_EQ(second.status, 409);
  EXPECT_EQ(Body(second)["holder"], "ann");
  EXPECT_EQ(Post("/api/plan/abort", "{}", "b").status, 409);
  EXPECT_TRUE(plans_.empty());
  // Anyone may stop the arm; releasing needs control.
  EXPECT_EQ(Post("/api/estop", R"({"who": "bob"})", "b").status, 200);
  ASSERT_EQ(estops_.size(), 1U);
  EXPECT_EQ(estops_[0].engaged, 1);
  EXPECT_EQ(Post("/api/estop", R"({"engaged": false})", "b").status, 409);
  EXPECT_EQ(estops_.size(), 1U);
  // Explicit take-over; then the first client is the one refused.
  ASSERT_EQ(Post("/api/lock", R"({"name": "bob", "take_over": true})", "b").status, 200);
  EXPECT_EQ(api_.LockHolder(), "bob");
  EXPECT_EQ(Post("/api/plan/abort", "{}", "a").status, 409);
  EXPECT_EQ(Post("/api/plan/abort", "{}", "b").status, 200);
  EXPECT_EQ(plans_.size(), 1U);
}

TEST_F(PanelApiTest, TokenIsRequiredOnChangesWhenInForce) {
  PanelApi guarded(hub_, ApiOptions{".", "", true, "s3cret", std::chrono::seconds(30)});
  PublishRig();
  const auto post = [&](const std::string& path, const std::string& body,
                        const std::string& token) {
    return guarded.Handle(Request{"POST", path, {}, body, "10.0.0.7", "a", token});
  };
  EXPECT_EQ(post("/api/lock", R"({"name": "ann"})", "").status, 403);
  EXPECT_EQ(post("/api/lock", R"({"name": "ann"})", "wrong").status, 403);
  EXPECT_EQ(post("/api/estop", "{}", "").status, 403);
  ASSERT_EQ(post("/api/lock", R"({"name": "ann"})", "s3cret").status, 200);
  EXPECT_EQ(post("/api/plan/abort", "{}", "").status, 403);
  EXPECT_EQ(post("/api/plan/abort", "{}", "s3cret").status, 200);
  // Reading needs no token.
  EXPECT_EQ(guarded.Handle(Request{"GET", "/api/state", {}, "", "10.0.0.7", "", ""}).status, 200);
}

TEST_F(PanelApiTest, FilesOnlyUnderConfig) {
  Response ok = Get("/api/file", {{"path", "config/plans/set7.plan"}});
  ASSERT_EQ(ok.status, 200);
  EXPECT_NE(Body(ok)["text"].get<std::string>().find("move j1=90 j2=90 j3=90"), std::string::npos);
  EXPECT_NE(Body(ok)["text"].get<std::string>().find("\nwait done\n"), std::string::npos);
  EXPECT_EQ(Get("/api/file", {{"path", "config/../CMakeLists.txt"}}).status, 403);
  EXPECT_EQ(Get("/api/file", {{"path", "/etc/passwd"}}).status, 403);
  EXPECT_EQ(Get("/api/file", {{"path", "config/plans/none.plan"}}).status, 404);
  EXPECT_EQ(Get("/api/file", {}).status, 400);
  const Json plans = Body(Get("/api/files", {{"dir", "plans"}}));
  EXPECT_NE(std::find(plans["files"].begin(), plans["files"].end(), "config/plans/set7.plan"),
            plans["files"].end());
}

TEST_F(PanelApiTest, PlanCheckNamesTheLineAndRunSendsTheText) {
  PublishRig();
  Response bad =
      Post("/api/plan/check", R"({"name": "p.plan", "text": "move j1=10\nmove j2=500\n"})");
  EXPECT_EQ(bad.status, 422);
  EXPECT_EQ(Body(bad)["line"], 2);
  EXPECT_GT(Body(bad)["column"].get<int>(), 0);
  ASSERT_EQ(Post("/api/lock", R"({"name": "ann"})").status, 200);
  EXPECT_EQ(Post("/api/plan/run", R"({"name": "p.plan", "text": "move j2=500\n"})").status, 422);
  EXPECT_TRUE(plans_.empty());
  Response good = Post("/api/plan/run", R"({"name": "p.plan", "text": "move j2=20\nwait done\n"})");
  ASSERT_EQ(good.status, 200);
  EXPECT_EQ(Body(good)["steps"].size(), 2U);
  ASSERT_EQ(plans_.size(), 1U);
  EXPECT_EQ(plans_[0].command, sirupp::plan_command_t::COMMAND_RUN);
  EXPECT_EQ(plans_[0].name, "p.plan");
}

TEST_F(PanelApiTest, GainsChangeOneJointWithinRange) {
  PublishRig();
  ASSERT_EQ(Post("/api/lock", R"({"name": "ann"})").status, 200);
  Response range = Post("/api/gains", R"({"joint": 2, "values": {"kp": 40000}})");
  EXPECT_EQ(range.status, 400);
  EXPECT_NE(Body(range)["error"].get<std::string>().find("kp"), std::string::npos);
  EXPECT_EQ(Post("/api/gains", R"({"joint": 2, "values": {"xx": 1}})").status, 400);
  EXPECT_TRUE(gains_.empty());
  ASSERT_EQ(Post("/api/gains", R"({"joint": 2, "values": {"kp": 150}})").status, 200);
  ASSERT_EQ(gains_.size(), 1U);
  EXPECT_EQ(gains_[0].kp[1], 150);
  EXPECT_EQ(gains_[0].kp[0], model_.joints[0].servo.kp);
}

TEST_F(PanelApiTest, EveryPlanWordSendsItsCommand) {
  // The words are client::PlanCommandFromName's, the same as `sirupp plan WORD`; the wire command
  // of each is written out here so that a wrong table in either place shows.
  PublishRig();
  ASSERT_EQ(Post("/api/lock", R"({"name": "ann"})").status, 200);
  const std::pair<const char*, int8_t> kExpected[] = {
      {"pause", sirupp::plan_command_t::COMMAND_PAUSE},
      {"resume", sirupp::plan_command_t::COMMAND_RESUME},
      {"abort", sirupp::plan_command_t::COMMAND_ABORT},
      {"manual", sirupp::plan_command_t::COMMAND_MANUAL},
      {"automatic", sirupp::plan_command_t::COMMAND_AUTOMATIC},
      {"clear-fault", sirupp::plan_command_t::COMMAND_CLEAR_FAULT}};
  for (const auto& [word, command] : kExpected) {
    plans_.clear();
    Response r = Post(std::string("/api/plan/") + word, "{}");
    ASSERT_EQ(r.status, 200) << word << ": " << r.body;
    EXPECT_EQ(Body(r)["message"], std::string("ARM_PLAN: plan ") + word + " accepted");
    ASSERT_EQ(plans_.size(), 1U) << word;
    EXPECT_EQ(plans_[0].command, command) << word;
  }
}

TEST_F(PanelApiTest, IkListsTheConfigurationsAndPoseTargetIsSent) {
  PublishRig();
  // The tool where a reachable joint pose puts it.
  core::JointVector q(6);
  q << 0.3, -0.5, 1.2, 0.1, 0.6, 0.2;
  const Eigen::Isometry3d tool = core::ToolPose(model_, q);
  const Eigen::Vector3d rpy = core::RollPitchYaw(tool.linear()) * 180 / kPi;
  Json pose = Json::array({tool.translation().x(), tool.translation().y(), tool.translation().z(),
                           rpy.x(), rpy.y(), rpy.z()});
  Response ik = Post("/api/ik", Json{{"pose", pose}}.dump());
  ASSERT_EQ(ik.status, 200) << ik.body;
  const Json answer = Body(ik);
  EXPECT_TRUE(answer["ok"].get<bool>());
  EXPECT_EQ(answer["solver"], "closed-form");  // core::ChooseIkSolver on a PUMA-type arm
  ASSERT_EQ(answer["configurations"].size(), 8U);
  int within = 0;
  for (const Json& c : answer["configurations"]) within += c["within_limits"].get<bool>() ? 1 : 0;
  EXPECT_GT(within, 0);
  EXPECT_TRUE(poses_.empty());  // solving sends nothing
  Response far = Post("/api/ik", R"({"pose": [3, 0, 0.2, 0, 0, 0]})");
  EXPECT_FALSE(Body(far)["ok"].get<bool>());
  ASSERT_EQ(Post("/api/lock", R"({"name": "ann"})").status, 200);
  EXPECT_EQ(Post("/api/move/pose", R"({"pose": [3, 0, 0.2, 0, 0, 0]})").status, 400);
  ASSERT_EQ(Post("/api/move/pose", Json{{"pose", pose}, {"config", "nearest"}}.dump()).status, 200);
  ASSERT_EQ(poses_.size(), 1U);
  EXPECT_NEAR(poses_[0].position[0], tool.translation().x(), 1e-12);
}

TEST_F(PanelApiTest, TheReplyToTheRequestIsTheHttpAnswer) {
  PublishRig();
  ASSERT_EQ(Post("/api/lock", R"({"name": "ann"})").status, 200);
  const std::string move = R"({"targets": [null, 30, null, null, null, null]})";
  // Accepted: the channel, the move the controller started, the request it answered.
  Response taken = Post("/api/move/joints", move);
  ASSERT_EQ(taken.status, 200) << taken.body;
  EXPECT_EQ(Body(taken)["message"], "ARM_TARGET: joint target accepted (move 7)");
  EXPECT_EQ(Body(taken)["move_id"], 7);
  ASSERT_EQ(targets_.size(), 1U);
  EXPECT_EQ(Body(taken)["request"]["utime"], targets_[0].utime);
  // Refused: the controller's reason, word for word.
  refuse_ = "channel ARM_TARGET: mode: manual only";
  Response refused = Post("/api/move/joints", move);
  EXPECT_EQ(refused.status, 409);
  EXPECT_EQ(Body(refused)["error"],
            "ARM_TARGET: joint target refused: channel ARM_TARGET: mode: manual only");
  EXPECT_EQ(Post("/api/plan/pause", "{}").status, 409);
  EXPECT_EQ(Post("/api/gains", R"({"joint": 2, "values": {"kp": 150}})").status, 409);
  Response hardware = Post("/api/hardware/arm", "{}");
  EXPECT_EQ(hardware.status, 409);
  EXPECT_NE(Body(hardware)["error"].get<std::string>().find("HARDWARE_COMMAND: hardware arm"),
            std::string::npos);
  ASSERT_EQ(hardware_.size(), 1U);
  EXPECT_EQ(hardware_[0].command, sirupp::hardware_command_t::COMMAND_ARM);
  // No controller: the answer says which reply was not heard.
  refuse_.clear();
  silent_ = true;
  Response none = Post("/api/move/joints", move);
  EXPECT_EQ(none.status, 504);
  EXPECT_NE(Body(none)["error"].get<std::string>().find("no reply on CONTROLLER_REPLY"),
            std::string::npos)
      << none.body;
  EXPECT_EQ(Post("/api/hardware/connect", "{}").status, 504);
  // The e-stop has no reply and goes out regardless.
  EXPECT_EQ(Post("/api/estop", R"({"who": "ann"})").status, 200);
  ASSERT_EQ(estops_.size(), 1U);
  EXPECT_EQ(estops_[0].reason, "panel e-stop (ann)");
  EXPECT_EQ(estops_[0].sender, "sirupp-panel");
}

// A fresh directory, removed at the end of the test.
struct TempDir {
  std::filesystem::path path;
  TempDir() {
    char pattern[] = "/tmp/sirupp_panel_test_XXXXXX";
    path = mkdtemp(pattern);
  }
  ~TempDir() { std::filesystem::remove_all(path); }
};

std::string ReadText(const std::string& path) {
  std::ifstream in(path);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

// The record panel drives a real sirupp-logger recorder on the bus: start a named run, refuse a
// second start, a bad name (nothing sent) and a name already used, stop it; the run's files are
// listed with their sizes and downloadable, and a stop with nothing recorded is refused.
TEST_F(PanelApiTest, RecordStartsAndStopsTheLoggerAndListsTheRun) {
  PublishRig();
  TempDir results;
  logger::LoggerOptions options;
  options.out_dir = results.path.string();
  options.split_per_plan = false;
  logger::Recorder recorder(bus_, model_, options, /*record_now=*/false);
  int commands = 0;
  bus_.Subscribe<sirupp::logger_command_t>(
      "LOGGER_COMMAND",
      [&](const sirupp::logger_command_t&, const core::ReceiveInfo&) { ++commands; });
  PanelApi api(hub_, ApiOptions{".", results.path.string(), false, "", std::chrono::seconds(30)});
  auto post = [&](const std::string& path, const std::string& body) {
    Response out = api.Handle(Request{"POST", path, {}, body, "127.0.0.1", "a", ""});
    Pump();
    return out;
  };
  EXPECT_EQ(post("/api/record/start", R"({"name": "lab1"})").status, 409);  // no control yet
  ASSERT_EQ(post("/api/lock", R"({"name": "ann"})").status, 200);
  Response bad = post("/api/record/start", R"({"name": "../etc"})");
  EXPECT_EQ(bad.status, 400);
  EXPECT_NE(Body(bad)["error"].get<std::string>().find("run name '../etc'"), std::string::npos);
  EXPECT_EQ(commands, 0);
  Response started = post("/api/record/start", R"({"name": "lab1"})");
  ASSERT_EQ(started.status, 200) << started.body;
  EXPECT_TRUE(recorder.recording());
  EXPECT_EQ(recorder.name(), "lab1");
  Response again = post("/api/record/start", R"({"name": "lab2"})");
  EXPECT_EQ(again.status, 409);
  EXPECT_NE(Body(again)["error"].get<std::string>().find("'lab1' is being recorded"),
            std::string::npos)
      << again.body;
  // A few hundred ticks of both streams, then stop: the run's file is closed with its rows.
  for (int64_t tick = 0; tick < 400; ++tick) {
    sirupp::arm_state_t state{};
    state.utime = tick * 512;
    state.seq = tick;
    state.tick = tick;
    state.num_joints = 6;
    state.position.assign(6, 0.01);
    state.velocity.assign(6, 0.0);
    state.effort.assign(6, 0.0);
    state.flags.assign(6, 0);
    bus_.Publish("SIM_ARM_STATE", state);
    if (tick % 50 == 0) recorder.Service(0);
  }
  recorder.Service(0);
  Response stopped = post("/api/record/stop", "{}");
  ASSERT_EQ(stopped.status, 200) << stopped.body;
  recorder.Service(0);
  EXPECT_FALSE(recorder.recording());
  EXPECT_GT(recorder.stats().rows, 100);
  const Json record = Body(api.Handle(Request{"GET", "/api/record", {}, "", "127.0.0.1", "a", ""}));
  ASSERT_FALSE(record["logger"].is_null()) << record.dump();  // its heartbeat
  EXPECT_EQ(record["logger"]["state"], "running");
  ASSERT_EQ(record["runs"].size(), 1U) << record.dump();
  EXPECT_EQ(record["runs"][0]["name"], "lab1");
  EXPECT_FALSE(record["runs"][0]["recording"].get<bool>());
  ASSERT_EQ(record["runs"][0]["files"].size(), 1U);
  const std::string file = record["runs"][0]["files"][0]["path"];
  EXPECT_GT(record["runs"][0]["files"][0]["size"].get<int64_t>(), 1000);
  const Response download =
      api.Handle(Request{"GET", "/api/download", {{"path", file}}, "", "127.0.0.1", "a", ""});
  ASSERT_EQ(download.status, 200);
  EXPECT_EQ(download.content_type, "text/csv");
  EXPECT_EQ(download.body, ReadText(file));
  EXPECT_NE(download.body.find("# end"), std::string::npos);
  // Outside config/ and the results folder: refused.
  EXPECT_EQ(api.Handle(Request{"GET", "/api/download", {{"path", "/etc/passwd"}}, "", "", "a", ""})
                .status,
            403);
  Response used = post("/api/record/start", R"({"name": "lab1"})");
  EXPECT_EQ(used.status, 409);
  EXPECT_NE(Body(used)["error"].get<std::string>().find("has files"), std::string::npos);
  Response idle = post("/api/record/stop", "{}");
  EXPECT_EQ(idle.status, 409);
  EXPECT_NE(Body(idle)["error"].get<std::string>().find("nothing is being recorded"),
            std::string::npos);
  // No logger at all: the answer says which reply was not heard.
  recorder.Close();
}

TEST_F(PanelApiTest, RecordWithoutALoggerSaysNoReply) {
  PublishRig();
  ASSERT_EQ(Post("/api/lock", R"({"name": "ann"})").status, 200);
  Response none = Post("/api/record/start", R"({"name": "lab1"})");
  EXPECT_EQ(none.status, 504);
  EXPECT_NE(Body(none)["error"].get<std::string>().find("no reply on LOGGER_REPLY"),
            std::string::npos)
      << none.body;
}

// The environment panel loads a file into a real SimNode on the bus: the new objects come back on
// ENVIRONMENT with the arm untouched; a bad file is refused at its line before anything is sent;
// an object overlapping the arm and a load while the arm moves are refused by the sim, which
// keeps its objects.
TEST_F(PanelApiTest, EnvironmentLoadsIntoTheRunningSimOrIsRefusedWithTheReason) {
  core::Environment none;
  sim::ArmWorld world(model_, none);
  sim::NodeOptions options;
  options.mode = sim::TimingMode::kFast;
  sim::SimNode sim_node(bus_, world, none, options);
  int commands = 0;
  bus_.Subscribe<sirupp::sim_command_t>(
      "SIM_COMMAND", [&](const sirupp::sim_command_t&, const core::ReceiveInfo&) { ++commands; });
  Pump();
  ASSERT_EQ(Post("/api/lock", R"({"name": "ann"})").status, 200);
  const std::string table = ReadText("config/environments/table.xml");
  Response loaded = Post("/api/environment/load",
                         Json{{"name", "config/environments/table.xml"}, {"text", table}}.dump());
  ASSERT_EQ(loaded.status, 200) << loaded.body;
  EXPECT_EQ(Body(loaded)["message"],
            "SIM_COMMAND: environment config/environments/table.xml accepted");
  Pump();
  const Json env = Body(Get("/api/environment"));
  EXPECT_EQ(env["name"], "table");
  EXPECT_EQ(env["source_file"], "config/environments/table.xml");
  EXPECT_EQ(env["objects"].size(), core::ParseEnvironment(table, "t").objects.size());
  EXPECT_EQ(world.ObjectPoses().size(), env["objects"].size());
  EXPECT_EQ(world.tick(), 0);  // the arm was not stepped or rebuilt
  // A bad file: 422 with the line; the sim is never asked.
  const int sent = commands;
  Response bad = Post("/api/environment/load",
                      Json{{"name", "bad.xml"},
                           {"text",
                            "<environment name=\"x\">\n<box name=\"b\" size=\"1 -1 1\"/>\n"
                            "</environment>\n"}}
                          .dump());
  EXPECT_EQ(bad.status, 422);
  EXPECT_EQ(Body(bad)["line"], 2);
  EXPECT_NE(Body(bad)["error"].get<std::string>().find("bad.xml:2"), std::string::npos);
  EXPECT_EQ(commands, sent);
  // An object through the upper arm (shoulder at 0.33 m, the upper arm along +x): refused.
  const std::string through_arm =
      "<environment name=\"wall\" length_unit=\"m\">\n"
      "  <box name=\"slab\" size=\"0.1 0.3 0.1\" position=\"0.1 0 0.33\"/>\n"
      "</environment>\n";
  Response overlap =
      Post("/api/environment/load", Json{{"name", "wall.xml"}, {"text", through_arm}}.dump());
  EXPECT_EQ(overlap.status, 409);
  EXPECT_NE(Body(overlap)["error"].get<std::string>().find("object 'slab' overlaps link"),
            std::string::npos)
      << overlap.body;
  Pump();
  EXPECT_EQ(Body(Get("/api/environment"))["name"], "table");  // kept
  EXPECT_EQ(world.ObjectPoses().size(), env["objects"].size());
  // The arm moving: refused.
  world.SetJointState(std::vector<double>(6, 0.0), {0, 0.5, 0, 0, 0, 0});
  Response moving =
      Post("/api/environment/load", Json{{"name", "config/environments/empty.xml"},
                                         {"text", ReadText("config/environments/empty.xml")}}
                                        .dump());
  EXPECT_EQ(moving.status, 409);
  EXPECT_NE(Body(moving)["error"].get<std::string>().find("the arm moves (joint 2"),
            std::string::npos)
      << moving.body;
}

// The model panel: the file's editable values with their text; an edit checked by the model
// loader with the error at the field; a valid edit saved as a new file under config/robots (never
// over one), which the loader reads back with the new value.
TEST_F(PanelApiTest, ModelEditsAreCheckedByTheLoaderAndSavedAsANewFile) {
  TempDir root;
  std::filesystem::create_directories(root.path / "config/robots");
  std::filesystem::copy_file("config/robots/puma260.yaml",
                             root.path / "config/robots/puma260.yaml");
  PanelApi api(hub_, ApiOptions{root.path.string(), "", false, "", std::chrono::seconds(30)});
  auto get = [&](const std::string& path, std::map<std::string, std::string> query) {
    return api.Handle(Request{"GET", path, std::move(query), "", "127.0.0.1", "a", ""});
  };
  auto post = [&](const std::string& path, const Json& body) {
    return api.Handle(Request{"POST", path, {}, body.dump(), "127.0.0.1", "a", ""});
  };
  const std::string file = "config/robots/puma260.yaml";
  const Json fields = Body(get("/api/model/fields", {{"path", file}}));
  std::map<std::string, std::string> values;
  for (const Json& field : fields["fields"]) values[field["key"]] = field["value"];
  EXPECT_EQ(values["dh[1].a"], "8");
  EXPECT_EQ(values["dh[0].alpha"], "-90");
  EXPECT_EQ(values["joints[0].limits[1]"], "145");
  EXPECT_EQ(values["joints[0].friction.coulomb"], "[0.7, 0.75]");
  EXPECT_EQ(values["links[1].mass_kg"], "3.0");
  EXPECT_EQ(fields["units"], "{length: inch, angle: deg}");
  EXPECT_EQ(get("/api/model/fields", {{"path", "/etc/passwd"}}).status, 403);

  // A negative mass: the loader's error, at the field.
  Response mass =
      post("/api/model/check", Json{{"path", file}, {"edits", {{"links[1].mass_kg", "-2"}}}});
  ASSERT_EQ(mass.status, 422) << mass.body;
  EXPECT_EQ(Body(mass)["field"], "links[1].mass_kg");
  EXPECT_NE(Body(mass)["error"].get<std::string>().find("links[1].mass_kg"), std::string::npos);
  // A lower limit above the upper one.
  Response limits =
      post("/api/model/check", Json{{"path", file}, {"edits", {{"joints[0].limits[0]", "150"}}}});
  ASSERT_EQ(limits.status, 422) << limits.body;
  EXPECT_EQ(Body(limits)["field"], "joints[0].limits[0]") << limits.body;
  EXPECT_NE(Body(limits)["error"].get<std::string>().find("puma260.yaml:42:"), std::string::npos);
  // Not a number, or not an editable value: 400 naming it.
  EXPECT_EQ(
      post("/api/model/check", Json{{"path", file}, {"edits", {{"dh[1].a", "eight"}}}}).status,
      400);
  EXPECT_EQ(post("/api/model/check", Json{{"path", file}, {"edits", {{"name", "x"}}}}).status, 400);
  // A good edit passes; saving needs control, a new name, and never replaces a file.
  const Json edits{
      {"links[1].mass_kg", "3.5"}, {"joints[0].friction.coulomb", "[0.8, 0.7]"}, {"dh[1].a", 8.5}};
  EXPECT_EQ(post("/api/model/check", Json{{"path", file}, {"edits", edits}}).status, 200);
  EXPECT_EQ(
      post("/api/model/save", Json{{"path", file}, {"edits", edits}, {"name", "heavy"}}).status,
      409);  // no control
  ASSERT_EQ(post("/api/lock", Json{{"name", "ann"}}).status, 200);
  EXPECT_EQ(
      post("/api/model/save", Json{{"path", file}, {"edits", edits}, {"name", "../x"}}).status,
      400);
  Response saved =
      post("/api/model/save", Json{{"path", file}, {"edits", edits}, {"name", "heavy"}});
  ASSERT_EQ(saved.status, 200) << saved.body;
  EXPECT_EQ(Body(saved)["path"], "config/robots/heavy.yaml");
  const core::RobotModel heavy =
      core::LoadRobotModel((root.path / "config/robots/heavy.yaml").string());
  EXPECT_DOUBLE_EQ(heavy.links[1].mass_kg, 3.5);
  EXPECT_DOUBLE_EQ(heavy.joints[0].friction.coulomb_positive, 0.8);
  EXPECT_NEAR(heavy.joints[1].dh.a_m, 8.5 * 0.0254, 1e-12);
  EXPECT_DOUBLE_EQ(heavy.links[2].mass_kg, model_.links[2].mass_kg);  // the rest as it was
  EXPECT_EQ(
      post("/api/model/save", Json{{"path", file}, {"edits", edits}, {"name", "heavy"}}).status,
      409);
  // The source file is untouched.
  EXPECT_EQ(ReadText((root.path / file).string()), ReadText(file));
}

// Apply (the model panel): a saved model file goes into a real SimNode and a real ControlNode on
// the bus, the arm standing still. Afterwards the sim's arm, the controller and the panel all run
// the new file (a wider joint 1 limit: the panel shows it, and a target beyond the old limit is
// taken by the controller). A bad file is refused at its line and a load while a plan runs is
// refused by the controller; the sim keeps its model then.
TEST_F(PanelApiTest, PlansAroundTheSimsObjectsChecksThemAndShowsTheCSpace) {
  PublishRig();
  const core::Environment table = core::LoadEnvironment("config/environments/table.xml");
  bus_.Publish("ENVIRONMENT", core::ToMessage(table, 0, 1));
  Pump();
  // The paper's set II goes into the table: the check says where, as sirupp-control would.
  const std::string set2 = ReadText("config/plans/set2.plan");
  Response into = Post("/api/plan/check", Json{{"name", "set2.plan"}, {"text", set2}}.dump());
  ASSERT_EQ(into.status, 422) << into.body;
  EXPECT_EQ(Body(into)["line"], 9);
  EXPECT_NE(Body(into)["error"].get<std::string>().find(
                "set2.plan:9: move j2=90: collision: link 6 (flange) touches static object "
                "'table_top'"),
            std::string::npos)
      << into.body;
  EXPECT_EQ(Body(into)["contact"]["kind"], "static");
  // Plan around the table from home to a goal low beside it; the plan it gives checks free.
  Response made = Post("/api/plan/make",
                       Json{{"joints", {54.1, 43.3, 39.6, 0, 97.1, 54.1}}, {"seed", 4}}.dump());
  ASSERT_EQ(made.status, 200) << made.body;
  const Json plan = Body(made);
  EXPECT_NE(plan["message"].get<std::string>().find("solved by rrtconnect"), std::string::npos);
  ASSERT_GE(plan["waypoints"].size(), 2u);
  EXPECT_NEAR(plan["waypoints"].back()[1].get<double>(), 43.3, 1e-6);
  EXPECT_GE(plan["tool_path"].size(), plan["waypoints"].size());
  EXPECT_FALSE(plan["tree"]["vertices"].empty());
  EXPECT_EQ(plan["environment"], "table");
  Response checked =
      Post("/api/plan/check", Json{{"name", "around.plan"}, {"text", plan["text"]}}.dump());
  ASSERT_EQ(checked.status, 200) << checked.body;
  EXPECT_NE(Body(checked)["message"].get<std::string>().find("no collision with table"),
            std::string::npos)
      << checked.body;
  EXPECT_TRUE(plans_.empty()) << "making and checking send nothing";
  // The same request gives the same plan.
  Response again = Post("/api/plan/make",
                        Json{{"joints", {54.1, 43.3, 39.6, 0, 97.1, 54.1}}, {"seed", 4}}.dump());
  EXPECT_EQ(Body(again)["waypoints"], plan["waypoints"]);
  // The C-space of joints 2 and 3 at 3 degrees: a grid with the table in it.
  Response slice = Post("/api/cspace", Json{{"joint_a", 2}, {"joint_b", 3}, {"step", 3}}.dump());
  ASSERT_EQ(slice.status, 200) << slice.body;
  const Json c = Body(slice);
  const std::string cells = c["cells"];
  EXPECT_EQ(cells.size(), c["values_a"].size() * c["values_b"].size());
  EXPECT_NE(cells.find('1'), std::string::npos) << "the table is in the slice";
  EXPECT_NE(cells.find('0'), std::string::npos);
  EXPECT_NEAR(c["values_a"].front().get<double>(), model_.joints[1].position_min / sirupp::kDeg,
              1e-6);
  // Bad requests: one line naming the field; nothing sent.
  EXPECT_EQ(Post("/api/cspace", Json{{"joint_a", 0}, {"joint_b", 3}}.dump()).status, 400);
  EXPECT_EQ(Post("/api/cspace", Json{{"joint_a", 2}, {"joint_b", 2}}.dump()).status, 400);
  EXPECT_EQ(Post("/api/cspace", Json{{"joint_a", 2}, {"joint_b", 3}, {"step", 0.01}}.dump()).status,
            400);
  EXPECT_EQ(Post("/api/plan/make", Json{{"joints", {1, 2}}}.dump()).status, 400);
  EXPECT_EQ(Post("/api/plan/make",
                 Json{{"joints", {0, 0, 0, 0, 0, 0}}, {"tool", {0, 0, 0, 0, 0, 0}}}.dump())
                .status,
            400);
  Response planner =
      Post("/api/plan/make", Json{{"joints", {60, 80, 20, 0, 60, 0}}, {"planner", "astar"}}.dump());
  EXPECT_EQ(planner.status, 400);
  EXPECT_NE(Body(planner)["error"].get<std::string>().find("astar"), std::string::npos);
  Response inside = Post("/api/plan/make", Json{{"joints", {0, 90, 0, 0, 0, 0}}}.dump());
  EXPECT_EQ(inside.status, 400) << "a goal in the table: " << inside.body;
  EXPECT_EQ(
      Post("/api/plan/make", Json{{"joints", {0, 0, 0, 0, 0, 0}}, {"seed", -1}}.dump()).status,
      400);
  EXPECT_TRUE(plans_.empty());
}

TEST(PanelModelApply, TheSimTheControllerAndThePanelTakeTheSavedModel) {
  const auto JsonOf = [](const Response& r) { return Json::parse(r.body); };
  TempDir root;
  std::filesystem::create_directories(root.path / "config/robots");
  std::filesystem::copy_file("config/robots/puma260.yaml",
                             root.path / "config/robots/puma260.yaml");
  const core::RobotModel model = core::LoadRobotModel("config/robots/puma260.yaml");
  core::Bus bus("memq://");
  core::Environment none;
  sim::ArmWorld world(model, none);
  control::ControlNode control_node(bus, model, control::ControlOptions{});
  PanelHub hub(bus, HubOptions{0.5, std::nullopt, 2.0});
  PanelApi api(hub, ApiOptions{root.path.string(), "", false, "", std::chrono::seconds(30)});
  // Last: its ROBOT_MODEL at start reaches the controller and the panel.
  sim::SimNode sim_node(bus, world, none, sim::NodeOptions{});  // lockstep with sirupp-control
  const auto spin = [&](int rounds) {
    for (int i = 0; i < rounds; ++i) {
      sim_node.Service(0);
      control_node.Service(0);
      hub.ServiceOnce(0);
    }
  };
  const auto post = [&](const std::string& path, const Json& body) {
    Response out = api.Handle(Request{"POST", path, {}, body.dump(), "127.0.0.1", "a", ""});
    spin(5);
    return out;
  };
  spin(200);
  ASSERT_EQ(post("/api/lock", Json{{"name", "ann"}}).status, 200);
  const std::string file = "config/robots/puma260.yaml";
  Response saved =
      post("/api/model/save",
           Json{{"path", file}, {"edits", {{"joints[0].limits[1]", "150"}}}, {"name", "wide"}});
  ASSERT_EQ(saved.status, 200) << saved.body;
  // Outside config/robots, or a bad file: refused before anything is sent.
  EXPECT_EQ(post("/api/model/apply", Json{{"path", "config/plans/x.plan"}}).status, 400);
  {
    std::ofstream bad(root.path / "config/robots/bad.yaml");
    bad << ReadText("config/robots/puma260.yaml").substr(0, 200) << "\n  : [\n";
  }
  Response bad = post("/api/model/apply", Json{{"path", "config/robots/bad.yaml"}});
  EXPECT_EQ(bad.status, 422) << bad.body;
  EXPECT_NE(JsonOf(bad)["error"].get<std::string>().find("config/robots/bad.yaml:"),
            std::string::npos)
      << bad.body;
  // A plan running (waiting, the arm still: only the controller knows): refused; the sim keeps
  // its model.
  const std::string plan = "units deg\nmove j1=0\nwait done\nwait 30\n";
  Response run = post("/api/plan/run", Json{{"name", "slow.plan"}, {"text", plan}});
  ASSERT_EQ(run.status, 200) << run.body;
  Response busy = post("/api/model/apply", Json{{"path", "config/robots/wide.yaml"}});
  EXPECT_EQ(busy.status, 409) << busy.body;
  EXPECT_NE(JsonOf(busy)["error"].get<std::string>().find("plan 'slow.plan' runs"),
            std::string::npos)
      << busy.body;
  EXPECT_EQ(world.model().source_hash, model.source_hash);
  ASSERT_EQ(post("/api/plan/abort", Json::object()).status, 200);
  // Until the controller is idle and the arm stands still (it settles under its servos).
  const auto still = [&] {
    for (double v : world.State().velocity) {
      if (std::abs(v) > 0.002) return false;
    }
    return control_node.sequencer().state() == control::ControlState::kIdle;
  };
  for (int i = 0; i < 400 && !still(); ++i) spin(50);
  ASSERT_TRUE(still());
  // A sirupp-hardware on the bus with the real arm linked keeps its own model file (puma260):
  // refused before anything is sent, naming the bridge; the sim keeps its model.
  const core::RobotModel wide_model =
      core::LoadRobotModel((root.path / "config/robots/wide.yaml").string());
  const auto bridge_says = [&](const std::string& detail) {
    sirupp::heartbeat_t beat{};
    beat.process = "sirupp-hardware";
    beat.host = "lab-pc";
    beat.pid = 4321;
    beat.state = sirupp::heartbeat_t::STATE_RUNNING;
    beat.detail = detail;
    bus.Publish("HEARTBEAT", beat);
    sirupp::hardware_status_t status{};
    status.state = sirupp::hardware_status_t::STATE_LINKED;
    bus.Publish("HARDWARE_STATUS", status);
    spin(5);
  };
  int sent = 0;  // ARM_PLAN and SIM_COMMAND messages
  bus.Subscribe<sirupp::plan_command_t>(
      "ARM_PLAN", [&](const sirupp::plan_command_t&, const core::ReceiveInfo&) { ++sent; });
  bus.Subscribe<sirupp::sim_command_t>(
      "SIM_COMMAND", [&](const sirupp::sim_command_t&, const core::ReceiveInfo&) { ++sent; });
  bridge_says("model " + model.name + " hash " + model.source_hash);
  Response linked = post("/api/model/apply", Json{{"path", "config/robots/wide.yaml"}});
  EXPECT_EQ(linked.status, 409) << linked.body;
  const std::string why = JsonOf(linked)["error"].get<std::string>();
  EXPECT_NE(why.find("sirupp-hardware on lab-pc (pid 4321) has the real arm linked"),
            std::string::npos)
      << why;
  EXPECT_NE(why.find("hash " + model.source_hash), std::string::npos) << why;
  EXPECT_EQ(world.model().source_hash, model.source_hash);
  // A bridge that does not say which model it keeps: refused as well.
  bridge_says("");
  EXPECT_EQ(post("/api/model/apply", Json{{"path", "config/robots/wide.yaml"}}).status, 409);
  EXPECT_EQ(sent, 0);
  // The bridge's own model (it reports wide.yaml's name and hash, with a last error after it):
  // allowed. Every part now runs wide.yaml.
  bridge_says("model " + wide_model.name + " hash " + wide_model.source_hash +
              "; a refused command");
  const std::vector<double> before = world.State().position;
  Response applied = post("/api/model/apply", Json{{"path", "config/robots/wide.yaml"}});
  ASSERT_EQ(applied.status, 200) << applied.body;
  EXPECT_EQ(JsonOf(applied)["message"], "SIM_COMMAND: model config/robots/wide.yaml accepted");
  spin(20);
  const std::string wide = ReadText((root.path / "config/robots/wide.yaml").string());
  EXPECT_EQ(world.model().source_file, "config/robots/wide.yaml");
  EXPECT_NEAR(world.model().joints[0].position_max, 150 * kPi / 180, 1e-12);
  EXPECT_EQ(hub.Model()->source_hash, world.model().source_hash);
  EXPECT_NEAR(JsonOf(api.Handle(
                  Request{"GET", "/api/model", {}, "", "127.0.0.1", "a", ""}))["joints"][0]["max"]
                  .get<double>(),
              150, 1e-9);
  for (size_t j = 0; j < before.size(); ++j) {
    EXPECT_NEAR(world.State().position[j], before[j], 1e-3) << "joint " << j + 1;
  }
  EXPECT_TRUE(control_node.fault().empty()) << control_node.fault();
  // 148 deg: beyond the old limit, inside the new one; the controller takes it.
  Response far =
      post("/api/move/joints",
           Json{{"targets", {148, nullptr, nullptr, nullptr, nullptr, nullptr}}, {"speed", 1.0}});
  EXPECT_EQ(far.status, 200) << far.body;
  EXPECT_NEAR(control_node.servos().Goal(0), 148 * kPi / 180, 1e-3);
}

}  // namespace
}  // namespace sirupp::panel
