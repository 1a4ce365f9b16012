// The sim and the planner agree: the sim's contacts come from the collision model's primitive
// tests, so a forearm driven into table.xml's 2 cm top is stopped by it (and goes through without
// contacts); a planned plan, run tick for tick by the virtual PIC-SERVOs on the ODE arm with the
// environment loaded, makes no contact.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "control/plan.hpp"
#include "control/servo_bank.hpp"
#include "core/environment.hpp"
#include "core/model_loader.hpp"
#include "planning/collision_model.hpp"
#include "planning/plan_text.hpp"
#include "planning/planner.hpp"
#include "sim/arm_world.hpp"

namespace sirupp {
namespace {

constexpr double kDeg = 3.14159265358979323846 / 180;

std::vector<double> Deg(std::initializer_list<double> values) {
  std::vector<double> q;
  for (double v : values) q.push_back(v * kDeg);
  return q;
}

// Runs one synchronized move of the servos on the world until done (+ 0.5 s), recording the
// deepest contact of the forearm with a static object the collision model sees at the sim's
// joints, and the sim's arm contacts.
struct DriveResult {
  double deepest_m = 0;
  int contact_steps = 0;
  std::vector<double> final_q;
};

DriveResult Drive(const core::RobotModel& model, const core::Environment& env, bool contacts,
                  const std::vector<double>& from, const std::vector<double>& to) {
  sim::WorldOptions options;
  options.contacts = contacts;
  sim::ArmWorld world(model, env, options);
  world.SetJointState(from);
  control::ServoBank bank(model);
  bank.ServoOn(from);
  std::vector<control::JointMove> moves(from.size());
  for (size_t j = 0; j < from.size(); ++j) {
    const double d = std::abs(to[j] - from[j]);
    if (d < 1e-9) continue;
    moves[j] = {true, to[j], 0.5 * d, 1.0 * d};  // all joints on one normalized trapezoid
  }
  bank.Load(moves);
  planning::CollisionModel cm(model, env);
  DriveResult run;
  core::ArmCommand command;
  command.mode = core::CommandMode::kEffort;
  double done_at = -1;
  for (int k = 0; k < 40000; ++k) {
    command.effort = bank.Tick(world.State().position);
    world.Step(command);
    if (world.LastStepArmContacts() > 0) ++run.contact_steps;
    if (k % 20 == 0) {
      for (const planning::Contact& c :
           cm.Contacts(core::ToJointVector(world.State().position), {true, false, false})) {
        if (c.link == 3) run.deepest_m = std::max(run.deepest_m, c.depth_m);
      }
    }
    if (done_at < 0 && bank.AllDone()) done_at = world.time_s();
    if (done_at >= 0 && world.time_s() > done_at + 0.5) break;
  }
  run.final_q = world.State().position;
  return run;
}

TEST(PlanningSimTest, AForearmDrivenIntoTheTableTopIsStoppedByIt) {
  const core::RobotModel model = core::LoadRobotModel("config/robots/puma260.yaml");
  core::Environment table = core::LoadEnvironment("config/environments/table.xml");
  // Only the table (the free objects would be pushed about).
  table.objects.erase(std::remove_if(table.objects.begin(), table.objects.end(),
                                     [](const core::EnvironmentObject& o) { return !o.is_static; }),
                      table.objects.end());
  // The shoulder lowered with the elbow at 40 deg and the wrist turned up: the collision model says
  // the forearm meets the top first (at j2 = 55 deg, 3 cm inside its back edge), then the wrist.
  const std::vector<double> from = Deg({0, 40, 40, 0, -90, 0});
  const std::vector<double> to = Deg({0, 70, 40, 0, -90, 0});
  planning::CollisionModel cm(model, table);
  ASSERT_TRUE(cm.IsFree(core::ToJointVector(Deg({0, 54.5, 40, 0, -90, 0}))));
  const std::vector<planning::Contact> first =
      cm.Contacts(core::ToJointVector(Deg({0, 55, 40, 0, -90, 0})));
  ASSERT_FALSE(first.empty());
  for (const planning::Contact& c : first) {
    ASSERT_EQ(c.link, 3) << cm.Describe(c);
    ASSERT_EQ(table.objects[static_cast<size_t>(c.object)].name, "table_top");
  }

  const DriveResult without = Drive(model, table, false, from, to);
  const DriveResult with = Drive(model, table, true, from, to);
  std::printf(
      "forearm into the table top: without contacts %.1f mm deep (j2 %.1f deg), with %.1f "
      "mm (j2 %.1f deg, %d steps in contact)\n",
      without.deepest_m * 1000, without.final_q[1] / kDeg, with.deepest_m * 1000,
      with.final_q[1] / kDeg, with.contact_steps);
  EXPECT_GT(without.deepest_m, 0.015);  // through the 2 cm plate when nothing stops it
  EXPECT_LT(with.deepest_m, 0.004);     // stopped at its surface (contacts are soft)
  EXPECT_GT(with.contact_steps, 100);
  EXPECT_LT(with.final_q[1], 57 * kDeg);
}

// A plan from sirupp plan make's path, run as sirupp-control runs it (every move line of a step
// loaded together, `wait done` on the servos' move-done), tick for tick on the ODE arm in
// table.xml: the sim reports no arm contact in any step.
TEST(PlanningSimTest, APlannedPlanRunInTheSimMakesNoContact) {
  const core::RobotModel model = core::LoadRobotModel("config/robots/puma260.yaml");
  const core::Environment table = core::LoadEnvironment("config/environments/table.xml");
  planning::CollisionModel cm(model, table, {0.01, true});
  const core::JointVector start = core::ToJointVector(Deg({54.1, 43.3, 39.6, 0, 97.1, 54.1}));
  const core::JointVector goal = core::ToJointVector(Deg({-9.9, 43.3, 39.6, 0, 97.1, -9.9}));
  ASSERT_FALSE(cm.EdgeFree(start, goal, 0.01));  // the straight way touches
  const planning::PlanResult result = planning::PlanPath(cm, start, goal);
  ASSERT_TRUE(result.solved) << result.message;
  planning::PlanTextOptions text_options;
  text_options.move_to_start = false;
  const std::string text = planning::PathToPlanText(model, result.path, text_options);
  const std::vector<double> start_v(start.data(), start.data() + start.size());
  const control::Plan plan = control::ParsePlan(text, "planned.plan", model, start_v);

  sim::ArmWorld world(model, table);
  world.SetJointState(start_v);
  control::ServoBank bank(model);
  bank.ServoOn(start_v);
  core::ArmCommand command;
  command.mode = core::CommandMode::kEffort;
  size_t step = 0;
  int contact_steps = 0;
  int64_t ticks = 0;
  for (; ticks < 200000; ++ticks) {
    while (step < plan.steps.size()) {
      const control::PlanStep& s = plan.steps[step];
      if (s.kind == control::PlanStep::Kind::kWaitDone && !bank.AllDone()) break;
      if (s.kind == control::PlanStep::Kind::kMove) bank.Load(s.moves);
      ++step;
    }
    if (step == plan.steps.size() && bank.AllDone()) break;
    command.effort = bank.Tick(world.State().position);
    world.Step(command);
    if (world.LastStepArmContacts() > 0) ++contact_steps;
  }
  ASSERT_EQ(step, plan.steps.size());
  const std::vector<double> end = world.State().position;
  std::printf(
      "planned plan in the sim: %lld ticks (%.2f s), %d steps with arm contacts, ends "
      "%.3f deg from the goal\n",
      static_cast<long long>(ticks), static_cast<double>(ticks) * model.servo_tick_s, contact_steps,
      (core::ToJointVector(end) - goal).cwiseAbs().maxCoeff() / kDeg);
  EXPECT_EQ(contact_steps, 0);
  EXPECT_LT((core::ToJointVector(end) - goal).cwiseAbs().maxCoeff(), 2 * kDeg);
}

}  // namespace
}  // namespace sirupp
