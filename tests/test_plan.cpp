// The movement-plan parser (control/plan.hpp): the shipped plans parse into the steps they say,
// units and rates convert as documented, tool moves land on their target, and every file in
// tests/data/bad_plans/ fails with exactly the message on its first line ("# expect: ...").

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include "control/plan.hpp"
#include "core/errors.hpp"
#include "core/kinematics.hpp"
#include "core/model_loader.hpp"
#include "core/printable.hpp"
#include "tests/helpers.hpp"

namespace sirupp::control {
namespace {

constexpr double kDeg = M_PI / 180;

const core::RobotModel& Puma() {
  static const core::RobotModel model = core::LoadRobotModel("config/robots/puma260.yaml");
  return model;
}

Plan Parse(const std::string& text) {
  return ParsePlan(text, "test.plan", Puma(), HomePositions(Puma()));
}

std::string ParseError(const std::string& text) {
  return testing::ErrorText<core::ConfigError>([&] { Parse(text); });
}

TEST(Plan, TheSevenMovementSetsOfTableTwo) {
  const std::vector<std::vector<int>> joints = {{1}, {2}, {3}, {1, 2}, {1, 3}, {2, 3}, {1, 2, 3}};
  for (size_t set = 0; set < joints.size(); ++set) {
    const std::string path = "config/plans/set" + std::to_string(set + 1) + ".plan";
    SCOPED_TRACE(path);
    const Plan plan = LoadPlan(path, Puma(), HomePositions(Puma()));
    EXPECT_EQ(plan.name, path);
    ASSERT_EQ(plan.moves(), 2);
    // move pose zero; wait done; wait 0.2; move ...; wait done; wait 0.5
    ASSERT_EQ(plan.steps.size(), 6u);
    EXPECT_EQ(plan.steps[0].kind, PlanStep::Kind::kMove);
    EXPECT_EQ(plan.steps[1].kind, PlanStep::Kind::kWaitDone);
    EXPECT_EQ(plan.steps[2].kind, PlanStep::Kind::kWaitTime);
    EXPECT_DOUBLE_EQ(plan.steps[2].wait_s, 0.2);
    const PlanStep& move = plan.steps[3];
    ASSERT_EQ(move.kind, PlanStep::Kind::kMove);
    EXPECT_EQ(move.text.rfind("move j1=90", 0) == 0, joints[set].front() == 1) << move.text;
    for (int j = 0; j < 6; ++j) {
      const bool moves =
          std::find(joints[set].begin(), joints[set].end(), j + 1) != joints[set].end();
      const JointMove& joint_move = move.moves[static_cast<size_t>(j)];
      EXPECT_EQ(joint_move.active, moves) << "joint " << j + 1;
      EXPECT_NEAR(plan.final_goal[static_cast<size_t>(j)], moves ? 90 * kDeg : 0, 1e-12);
      if (moves) {
        const core::Joint& joint = Puma().joints[static_cast<size_t>(j)];
        EXPECT_NEAR(joint_move.goal, 90 * kDeg, 1e-12);
        EXPECT_DOUBLE_EQ(joint_move.velocity, joint.servo.default_velocity);
        EXPECT_DOUBLE_EQ(joint_move.acceleration, joint.servo.default_acceleration);
      }
    }
    EXPECT_EQ(plan.steps[5].kind, PlanStep::Kind::kWaitTime);
  }
}

TEST(Plan, UnitsRatesNamesAndComments) {
  const Plan plan = Parse(
      "# a comment line\n"
      "\n"
      "   units rad mm   # trailing comment\n"
      "speed 50%\n"
      "accel 2\n"
      "move j1=0.5 shoulder=-0.25 speed=0.1\n"
      "wait 2s\n"
      "move pose ready accel=25%\n"
      "wait done\n"
      "move pose home\n");
  ASSERT_EQ(plan.steps.size(), 5u);
  const PlanStep& first = plan.steps[0];
  EXPECT_EQ(first.line, 6);
  EXPECT_EQ(first.text, "move j1=0.5 shoulder=-0.25 speed=0.1");
  EXPECT_TRUE(first.moves[0].active);
  EXPECT_TRUE(first.moves[1].active);
  EXPECT_FALSE(first.moves[2].active);
  EXPECT_DOUBLE_EQ(first.moves[0].goal, 0.5);
  EXPECT_DOUBLE_EQ(first.moves[1].goal, -0.25);
  EXPECT_DOUBLE_EQ(first.moves[0].velocity, 0.1);      // rad/s as written
  EXPECT_DOUBLE_EQ(first.moves[0].acceleration, 2.0);  // the plan-wide accel, rad/s^2
  EXPECT_DOUBLE_EQ(plan.steps[1].wait_s, 2.0);
  const PlanStep& ready = plan.steps[2];
  const core::NamedPose* pose = Puma().FindNamedPose("ready");
  ASSERT_NE(pose, nullptr);
  for (size_t j = 0; j < 6; ++j) {
    const core::Joint& joint = Puma().joints[j];
    EXPECT_TRUE(ready.moves[j].active);
    EXPECT_DOUBLE_EQ(ready.moves[j].goal, pose->position[j]);
    EXPECT_DOUBLE_EQ(ready.moves[j].velocity, joint.servo.default_velocity * 0.5);
    EXPECT_DOUBLE_EQ(ready.moves[j].acceleration, joint.servo.default_acceleration * 0.25);
    EXPECT_DOUBLE_EQ(plan.steps[4].moves[j].goal, joint.home);
  }
}

TEST(Plan, ToolMovesReachTheirTargetInTheAskedConfiguration) {
  const Plan plan = Parse(
      "units deg inch\n"
      "move tool 10 -5.6 16 0 90 0 config=right-down-noflip\n"
      "move tool 8 -5.6 14\n");
  ASSERT_EQ(plan.steps.size(), 2u);
  core::JointVector q(6);
  for (int j = 0; j < 6; ++j) q[j] = plan.steps[0].moves[static_cast<size_t>(j)].goal;
  const Eigen::Isometry3d tool = core::ToolPose(Puma(), q);
  EXPECT_NEAR((tool.translation() - Eigen::Vector3d(0.254, -0.14224, 0.4064)).norm(), 0, 1e-9);
  // pitch 90: the tool's z axis points along world x
  EXPECT_NEAR((tool.linear().col(2) - Eigen::Vector3d(1, 0, 0)).norm(), 0, 1e-9);
  EXPECT_GT(q[1], 0);  // right-down: the shoulder leans forward (cf. `sirupp ik`)
  for (int j = 0; j < 6; ++j) q[j] = plan.steps[1].moves[static_cast<size_t>(j)].goal;
  EXPECT_NEAR(
      (core::ToolPose(Puma(), q).translation() - Eigen::Vector3d(0.2032, -0.14224, 0.3556)).norm(),
      0, 1e-9);
  // Position only, nearest the previous step: the shoulder stays on the same side.
  EXPECT_GT(q[1], 0);
}

TEST(Plan, LimitsAreCheckedInThePlansOwnUnits) {
  EXPECT_EQ(ParseError("units rad\nmove j2=3\n"),
            "test.plan:2:9: move: joint j2 (shoulder) goal 3 rad is outside its limits "
            "[-2.74889, 2.74889] rad");
  EXPECT_EQ(ParseError("speed 1000%\nmove j1=1\n"),
            "test.plan:2:1: move: joint j1 (waist) speed 450 deg/s is above its maximum 90 deg/s");
}

TEST(Plan, AFileThatCannotBeOpenedIsNamed) {
  EXPECT_EQ(testing::ErrorText<core::ConfigError>(
                [] { LoadPlan("no/such.plan", Puma(), HomePositions(Puma())); }),
            "no/such.plan: cannot open the plan file");
}

TEST(Plan, AByteOrderMarkAtTheStartIsSkipped) {
  const Plan plan = Parse("\xEF\xBB\xBFmove j1=10\nwait done\n");
  ASSERT_EQ(plan.steps.size(), 2u);
  EXPECT_EQ(plan.steps[0].text, "move j1=10");
  EXPECT_EQ(
      ParseError("\xEF\xBB\xBFgoto 5\n"),
      "test.plan:1:1: goto: unknown statement 'goto'; allowed: move, wait, speed, accel, units "
      "(lines starting with # are comments)");
  // Only at the start: anywhere else it is part of a token.
  EXPECT_EQ(ParseError("move j1=10\n\xEF\xBB\xBFwait done\n")
                .rfind("test.plan:2:1: \\xEF\\xBB\\xBFwait: unknown statement", 0),
            0u);
}

TEST(Plan, ControlCharactersAndBytesThatAreNotUtf8AreEscapedInMessages) {
  const std::string error = ParseError("move j1=10\n\x1b]0;owned\x07\x80\x01 5\n");
  EXPECT_EQ(error,
            "test.plan:2:1: \\x1B]0;owned\\x07\\x80\\x01: unknown statement "
            "'\\x1B]0;owned\\x07\\x80\\x01'; allowed: move, wait, speed, accel, units (lines "
            "starting with # are comments)");
  EXPECT_TRUE(core::IsPrintable(error));
  // UTF-8 is shown as written.
  EXPECT_EQ(ParseError("move j1=10\nbewege j1=5°\n")
                .rfind("test.plan:2:1: bewege: unknown statement 'bewege'", 0),
            0u);
  EXPECT_EQ(ParseError("move j1=5°\n"),
            "test.plan:1:9: move: joint j1 value '5°' is not a finite number");
  // A very long token is cut in the message.
  const std::string long_word(5000, 'x');
  const std::string cut = ParseError(long_word + "\n");
  EXPECT_LT(cut.size(), 400u);
  EXPECT_NE(cut.find("'" + std::string(64, 'x') + "...'"), std::string::npos);
  // The step text kept for display is one line of plain text.
  const Plan plan = Parse("move j1=10 # \x01 comment\nwait\t\tdone\n");
  EXPECT_EQ(plan.steps[1].text, "wait  done");
}

TEST(Plan, APlanOverTheSizeLimitIsRefusedNamingTheLimit) {
  // The largest plan accepted parses; one byte more is refused before any line is read.
  std::string text = "move j1=10\n#";
  text += std::string(kMaxPlanBytes - text.size() - 1, '-') + "\n";
  ASSERT_EQ(text.size(), kMaxPlanBytes);
  EXPECT_EQ(Parse(text).moves(), 1);
  EXPECT_EQ(ParseError(text + "\n"),
            "test.plan: the plan has 262145 bytes; allowed at most 262144 (256 KiB, so that it "
            "travels in one ARM_PLAN message); split it into several plans");
}

TEST(Plan, APlanFileOverTheSizeLimitIsRefusedWhenRead) {
  const std::string path =
      (std::filesystem::temp_directory_path() / "sirupp_test_plan_420k.plan").string();
  {
    std::ofstream file(path, std::ios::binary);
    for (int i = 0; i < 30000; ++i) file << "move j1=10 speed=50%\n";  // 630 000 bytes
  }
  EXPECT_EQ(testing::ErrorText<core::ConfigError>([&] { ReadPlanText(path); }),
            path +
                ": the plan file has 630000 bytes; allowed at most 262144 (256 KiB, so that it "
                "travels in one ARM_PLAN message); split it into several plans");
  std::filesystem::remove(path);
}

TEST(Plan, EveryBadPlanFailsWithItsExpectedMessage) {
  int checked = 0;
  for (const auto& entry : std::filesystem::directory_iterator("tests/data/bad_plans")) {
    const std::string path = entry.path().string();
    if (entry.path().extension() != ".plan") continue;
    std::ifstream file(path);
    std::string first;
    std::getline(file, first);
    const std::string prefix = "# expect: ";
    ASSERT_EQ(first.rfind(prefix, 0), 0u) << path << " lacks its '# expect: ' line";
    const std::string expected = path + ":" + first.substr(prefix.size());
    EXPECT_EQ(testing::ErrorText<core::ConfigError>(
                  [&] { LoadPlan(path, Puma(), HomePositions(Puma())); }),
              expected);
    ++checked;
  }
  EXPECT_GE(checked, 15);
}

}  // namespace
}  // namespace sirupp::control
