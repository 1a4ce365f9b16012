#include "tools/control_commands.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <iostream>
#include <map>
#include <optional>
#include <ostream>
#include <sirupp/arm_state_t.hpp>
#include <sirupp/controller_status_t.hpp>
#include <sirupp/heartbeat_t.hpp>
#include <sirupp/joint_target_t.hpp>
#include <sirupp/plan_command_t.hpp>
#include <sirupp/pose_target_t.hpp>
#include <sirupp/servo_gains_t.hpp>
#include <sirupp/servo_setpoint_t.hpp>
#include <sirupp/sim_status_t.hpp>
#include <sstream>

#include "client/client.hpp"
#include "control/plan.hpp"
#include "control/pose_goal.hpp"
#include "control/servo_bank.hpp"
#include "core/channels.hpp"
#include "core/errors.hpp"
#include "core/geometry.hpp"
#include "core/heartbeat.hpp"
#include "runtime/args.hpp"
#include "servo/chip_gains.hpp"
#include "servo/picservo.hpp"
#include "tools/cli.hpp"
#include "tools/planning_commands.hpp"
#include "tools/rig_args.hpp"

namespace sirupp::tools {
namespace {

using Status = sirupp::controller_status_t;
using client::ControllerModeName;
using client::ControllerStateName;
constexpr double kDeg = 3.14159265358979323846 / 180;
constexpr double kFirstStatusS = 1.5;  // CONTROLLER_STATUS comes at 10 Hz: wait this long for one
constexpr int kExitFailed = 1;

// The commands' client: what it waits for before sending (a bridge's start guard) on stderr.
client::Options ClientOptions() {
  client::Options options;
  options.notice = [](const std::string& line) { std::cerr << "sirupp: " << line << "\n"; };
  return options;
}

// Waits for the first CONTROLLER_STATUS; false (and a message on `out`) if none came.
bool FirstStatus(client::Client& rig, std::ostream& out) {
  if (rig.WaitForController(kFirstStatusS)) return true;
  out << "no " << rig.bus().FullName(rig.channels().controller_status) << " within "
      << kFirstStatusS << " s on " << rig.bus().url()
      << ": is sirupp-control running (same --lcm-url and --prefix)?\n";
  return false;
}

// Prints the controller's answer to a request; returns the exit code (0 accepted, 1 otherwise).
int Report(const client::Answer& answer, std::ostream& out) {
  switch (answer.result) {
    case client::Result::kAccepted:
      return 0;
    case client::Result::kRefused:
      out << "refused by sirupp-control: " << answer.error << "\n";
      return kExitFailed;
    case client::Result::kNoAnswer:
      out << "sirupp-control did not confirm: " << answer.error << "\n";
      return kExitFailed;
  }
  return kExitFailed;
}

// A move or plan that ended well on the virtual arm, but whose real arm's half was lost (the
// bridge fell silent while linked): says so; true then (the command exits 1).
bool RealArmIncomplete(const client::Outcome& outcome, std::ostream& out) {
  if (outcome.real_arm_lost.empty()) return false;
  out << "INCOMPLETE for the real arm: " << outcome.real_arm_lost << "\n";
  return true;
}

// After an accepted move: follows it to its end.
int WaitForMove(client::Client& rig, const client::Answer& answer, double timeout_s,
                std::ostream& out) {
  const client::Outcome outcome = rig.WaitForMove(answer.move_id, timeout_s, answer.status_seq);
  out << outcome.detail << (outcome.end == client::End::kTimeout ? " (--timeout)" : "") << "\n";
  if (!outcome.ok()) return kExitFailed;
  return RealArmIncomplete(outcome, out) ? kExitFailed : 0;
}

// The joints' present goals from ARM_SETPOINT (where a new plan starts), or home when none came.
std::vector<double> PresentGoals(client::Client& rig, const core::RobotModel& model,
                                 std::string& source) {
  rig.WatchJoints(true);
  rig.Until([&] { return rig.snapshot().setpoint.has_value(); }, 0.5);
  const auto& setpoint = rig.snapshot().setpoint;
  if (setpoint && setpoint->num_joints == model.num_joints()) {
    source = "the arm's present goals";
    return setpoint->goal;
  }
  source = "the home pose (no ARM_SETPOINT heard)";
  return control::HomePositions(model);
}

std::string Degrees(const core::RobotModel& model, const std::vector<double>& q) {
  std::ostringstream text;
  for (size_t j = 0; j < q.size() && j < model.joints.size(); ++j) {
    const bool revolute = model.joints[j].type == core::JointType::kRevolute;
    text << (j ? " " : "") << core::FormatApprox(revolute ? q[j] / kDeg : q[j]);
  }
  return text.str();
}

double ScaleFrom(const runtime::Args& parsed, const std::string& /*command*/) {
  return parsed.Number("scale", 1.0);  // (0, 1]: declared with the flag
}

int MoveJoints(const std::vector<std::string>& args, std::ostream& out) {
  const runtime::Args parsed(
      args, "move joints",
      WithRigFlags(WithJointFlags(
          {runtime::ModelFlag(),
           runtime::Flag("scale", "fraction of each joint's default speed").Takes("F").Above(0, 1),
           runtime::Flag("wait", "wait until the move is done").Switch(),
           TimeoutFlag("seconds to wait")})),
      kMoveAbout);
  const core::RobotModel model = ModelFromArgs(parsed);
  const double scale = ScaleFrom(parsed, "move joints");
  const bool wait = parsed.Switch("wait");
  const double timeout = TimeoutFrom(parsed, 60);
  client::JointTarget target;
  target.position = PositionsFromArgs(parsed, model, "move joints");
  for (const core::Joint& joint : model.joints) {
    target.max_velocity.push_back(joint.servo.default_velocity * scale);
  }

  core::Bus bus = BusFromArgs(parsed);
  client::Client rig(bus, ClientOptions());
  if (!FirstStatus(rig, out)) return kExitFailed;
  PrintSent(out, bus, rig.channels().arm_target, model, target.position);
  out << "\n";
  const client::Answer answer = rig.MoveJoints(target);
  if (const int code = Report(answer, out); code != 0) return code;
  out << "accepted as move " << answer.move_id << "\n";
  return wait ? WaitForMove(rig, answer, timeout, out) : 0;
}

// What `move pose` asks for: --pose (or --position, orientation free) and --config.
struct PoseArgs {
  std::vector<double> v;  // X Y Z (m) ROLL PITCH YAW (deg; 0 with --position)
  bool position_only = false;
  Eigen::Quaterniond orientation;
  control::PoseRequest request;  // the same, as sirupp-control checks it
};

PoseArgs PoseFromArgs(const runtime::Args& parsed) {
  if (parsed.Has("pose") == parsed.Has("position")) {
    throw core::UsageError(
        "move pose: give exactly one of --pose X Y Z ROLL PITCH YAW or "
        "--position X Y Z");
  }
  PoseArgs pose;
  pose.position_only = parsed.Has("position");
  pose.v = parsed.Numbers(pose.position_only ? "position" : "pose", pose.position_only ? 3 : 6);
  const std::vector<double>& v = pose.v;
  pose.v.resize(6, 0.0);
  pose.request.target.translation() << v[0], v[1], v[2];
  pose.orientation = core::QuaternionFromRpy(v[3] * kDeg, v[4] * kDeg, v[5] * kDeg);
  pose.request.target.linear() = pose.orientation.toRotationMatrix();
  pose.request.position_only = pose.position_only;
  const std::string config_text = parsed.Has("config") ? parsed.String("config") : "nearest";
  if (config_text != "nearest") {
    const std::optional<core::IkConfiguration> config = core::IkConfiguration::Parse(config_text);
    if (!config) {
      throw core::UsageError("move pose: --config '" + config_text +
                             "' is not allowed; expected nearest or SHOULDER-ELBOW-WRIST with "
                             "left|right, up|down, noflip|flip (e.g. right-up-noflip)");
    }
    pose.request.SetConfig(*config);
  }
  return pose;
}

client::PoseTarget PoseTargetOf(const PoseArgs& pose, double scale) {
  client::PoseTarget target;
  for (int i = 0; i < 3; ++i) target.position[i] = pose.v[static_cast<size_t>(i)];
  target.orientation[0] = pose.orientation.w();
  target.orientation[1] = pose.orientation.x();
  target.orientation[2] = pose.orientation.y();
  target.orientation[3] = pose.orientation.z();
  target.position_only = pose.position_only;
  target.shoulder_left = pose.request.shoulder_left;
  target.elbow_up = pose.request.elbow_up;
  target.wrist_flip = pose.request.wrist_flip;
  target.speed_scale = scale;
  return target;
}

// The joints the pose asks for, solved from the arm's present joints as sirupp-control will (from
// home if no arm state comes within 0.5 s). Throws core::UsageError if there is no solution.
control::PoseGoal PoseGoalFromPresent(client::Client& rig, const core::RobotModel& model,
                                      const control::PoseRequest& request) {
  rig.WatchJoints(true);
  rig.Until([&] { return rig.snapshot().sim_arm.has_value(); }, 0.5);
  const auto& state = rig.snapshot().sim_arm;
  const std::vector<double> reference = state && state->num_joints == model.num_joints()
                                            ? state->position
                                            : control::HomePositions(model);
  control::PoseGoal goal = control::SolvePoseGoal(model, request, core::ToJointVector(reference));
  if (!goal.ok) throw core::UsageError("move pose: no joint solution: " + goal.reason);
  rig.WatchJoints(false);
  return goal;
}

int MovePose(const std::vector<std::string>& args, std::ostream& out) {
  const runtime::Args parsed(
      args, "move pose",
      WithRigFlags(
          {runtime::ModelFlag(),
           runtime::Flag("pose", "tool pose: metres and degrees").Takes("X Y Z ROLL PITCH YAW", 6),
           runtime::Flag("position", "tool position in metres, orientation free").Takes("X Y Z", 3),
           runtime::Flag("config", "SHOULDER-ELBOW-WRIST or nearest").Takes("NAME"),
           runtime::Flag("scale", "fraction of each joint's default speed").Takes("F").Above(0, 1),
           runtime::Flag("wait", "wait until the move is done").Switch(),
           TimeoutFlag("seconds to wait")}),
      kMoveAbout);
  const core::RobotModel model = ModelFromArgs(parsed);
  const PoseArgs pose = PoseFromArgs(parsed);
  const double scale = ScaleFrom(parsed, "move pose");
  const bool wait = parsed.Switch("wait");
  const double timeout = TimeoutFrom(parsed, 60);

  core::Bus bus = BusFromArgs(parsed);
  client::Client rig(bus, ClientOptions());
  const control::PoseGoal goal = PoseGoalFromPresent(rig, model, pose.request);
  if (!FirstStatus(rig, out)) return kExitFailed;

  const std::vector<double>& v = pose.v;
  out << "sent " << bus.FullName(rig.channels().arm_pose_target) << ": tool to [" << v[0] << " "
      << v[1] << " " << v[2] << "] m"
      << (pose.position_only
              ? ""
              : ", rpy [" + core::FormatApprox(v[3]) + " " + core::FormatApprox(v[4]) + " " +
                    core::FormatApprox(v[5]) + "] deg")
      << "; expected joints ["
      << Degrees(model, std::vector<double>(goal.q.data(), goal.q.data() + goal.q.size()))
      << "] deg" << (goal.config_name.empty() ? "" : " (" + goal.config_name + ")") << "\n";
  const client::Answer answer = rig.MovePose(PoseTargetOf(pose, scale));
  if (const int code = Report(answer, out); code != 0) return code;
  out << "accepted as move " << answer.move_id << "\n";
  return wait ? WaitForMove(rig, answer, timeout, out) : 0;
}

void PrintPlan(std::ostream& out, const core::RobotModel& model, const control::Plan& plan) {
  out << plan.name << ": ok: " << plan.steps.size() << " steps, " << plan.moves()
      << " moves; ends at [" << Degrees(model, plan.final_goal) << "] deg\n";
}

std::vector<runtime::Flag> WithSweepFlags(std::vector<runtime::Flag> flags) {
  for (runtime::Flag& flag : SweepFlags()) flags.push_back(std::move(flag));
  return flags;
}

int PlanCheck(const std::vector<std::string>& args, std::ostream& out) {
  const runtime::Args parsed(
      args, "plan check",
      WithSweepFlags(
          {runtime::Flag("files", "plan files").Positional("FILE", -1), runtime::ModelFlag()}),
      kPlanAbout);
  const std::vector<std::string>& files = parsed.Values("files", -1);
  const core::RobotModel model = ModelFromArgs(parsed);
  const std::vector<double> start = CheckStart(parsed, model);
  bool all_free = true;
  for (const std::string& file : files) {
    const control::Plan plan = control::ParsePlan(control::ReadPlanText(file), file, model, start);
    PrintPlan(out, model, plan);
    if (parsed.Has("env")) all_free = SweepPlan(parsed, model, plan, start, out) && all_free;
  }
  return all_free ? 0 : kExitFailed;
}

int PlanRun(const std::vector<std::string>& args, std::ostream& out) {
  const runtime::Args parsed(
      args, "plan run",
      WithRigFlags({runtime::Flag("file", "plan file").Positional("FILE"), runtime::ModelFlag(),
                    runtime::Flag("wait", "follow the plan to its end").Switch(),
                    TimeoutFlag("seconds to wait")}),
      kPlanAbout);
  const core::RobotModel model = ModelFromArgs(parsed);
  const bool wait = parsed.Switch("wait");
  const double timeout = TimeoutFrom(parsed, 3600);
  core::Bus bus = BusFromArgs(parsed);
  client::Client rig(bus, ClientOptions());
  return RunPlanFile(rig, model, parsed.String("file"), wait ? timeout : 0, out);
}

int PlanControl(client::PlanCommand command, const std::string& word,
                const std::vector<std::string>& args, std::ostream& out) {
  const bool clear_fault = word == "clear-fault";
  const runtime::Args parsed(args, clear_fault ? word : "plan " + word, WithRigFlags({}),
                             clear_fault ? kClearFaultAbout : kPlanAbout);
  core::Bus bus = BusFromArgs(parsed);
  client::Client rig(bus, ClientOptions());
  if (!FirstStatus(rig, out)) return kExitFailed;
  const client::Answer answer = rig.Plan(command);
  if (const int code = Report(answer, out); code != 0) return code;
  // The status the reply names shows the command's effect.
  const Status& s = *rig.snapshot().controller;
  out << word << ": done; controller " << ControllerModeName(s.mode) << ", "
      << ControllerStateName(s.state) << "\n";
  return 0;
}

}  // namespace

const char* const kMoveAbout =
    "  joints: every joint to the given positions (ARM_TARGET), one trapezoidal move per joint.\n"
    "  pose: the tool to a pose in the world frame, metres and degrees (ARM_POSE_TARGET);\n"
    "  sirupp-control solves the IK and takes the configuration asked (e.g. right-up-noflip) or\n"
    "  the solution nearest the present joints. --scale: fraction of the joints' default speeds.\n"
    "  Targets outside the limits or out of reach are refused here (exit 2) and nothing is sent.\n"
    "  Then the controller's answer is shown: accepted (exit 0) or refused (exit 1, with why);\n"
    "  --wait follows the move until it is done.\n";

const char* const kPlanAbout =
    "  check: validates plans completely (from the model's home pose); exit 2 naming file:line.\n"
    "  With --env FILE it also sweeps every move (the set-points the controller sends, at --step\n"
    "  rad) against the environment and the arm itself: the first touch of a static object or of\n"
    "  the arm is named by file:line, links, object and where (exit 1); touching a free object is "
    "a\n"
    "  note. --from: the start (degrees or a pose name; default home).\n"
    "  run: validates from the arm's present goals, sends the plan text on ARM_PLAN and confirms\n"
    "  it started; --wait prints each step and exits 0 when the plan finished, 1 if it was\n"
    "  aborted or a servo faulted. pause finishes the present move, then waits; abort stops\n"
    "  the arm smoothly (also with no plan running); automatic locks out manual targets until\n"
    "  manual. Format: docs/plan-format.md; examples: config/plans/.\n"
    "  A fault (a tripped servo, a failing student controller, another robot in the sim) holds\n"
    "  the arm and refuses targets and plans, naming its first cause, until `sirupp "
    "clear-fault`.\n";

const char* const kClearFaultAbout =
    "Clears sirupp-control's latched fault (a tripped servo, a failing student controller, "
    "another robot in the sim): the servos go on, holding the arm where it is, and targets and "
    "plans are taken again. The fault's first cause is in `sirupp status`. Exit 0 when the "
    "controller confirms, 1 when no controller answers or it refuses (with why).\n";

const char* const kGainsAbout =
    "  Sets the servo filter gains of sirupp-control live (ARM_GAINS), in PIC-SERVO units\n"
    "  (docs/servo-units.md): Kp, Kd, Ki, integration limit, output limit (PWM 0..255), error\n"
    "  limit (counts) and deadband. Only what is named changes: the rest is taken from the live\n"
    "  gains (CONTROLLER_GAINS); --joint N (1-based) changes one joint, otherwise every joint.\n"
    "  With no value, prints the live gains of the virtual servos and, when a bridge runs, of\n"
    "  the real boards (REAL_ARM_GAINS); the bridge loads ARM_GAINS into the boards too.\n"
    "  Out-of-range values exit 2; nothing is sent.\n";

const char* const kStatusAbout =
    "  What the rig reports over about one second (--timeout, default 1.5): sirupp-control's\n"
    "  mode, state, move, plan step and last error; the arm's joints and set-points; and every\n"
    "  process heard on HEARTBEAT with its refused messages and decode errors per channel; the\n"
    "  sim's timing mode, real-time factor, participants and refused senders (SIM_STATUS).\n"
    "  Exit 1 if no controller status was heard.\n";

// How long `plan run` waits for the virtual arm to come to rest before it sends the plan.
constexpr double kPlanRestWaitS = 3.0;

int RunPlanFile(client::Client& rig, const core::RobotModel& model, const std::string& file,
                double wait_s, std::ostream& out) {
  const std::string text = control::ReadPlanText(file);
  std::string start_source;
  const std::vector<double> start = PresentGoals(rig, model, start_source);
  const control::Plan plan = control::ParsePlan(text, file, model, start);  // exit 2 if bad
  out << "checked from " << start_source << ": ";
  PrintPlan(out, model, plan);
  if (!FirstStatus(rig, out)) return kExitFailed;
  // A plan starts from rest, so that its motion does not depend on the tick it lands on.
  if (rig.WaitVirtualAtRest(kPlanRestWaitS) == client::Client::Rest::kNotAtRest) {
    std::cerr << "sirupp plan run: the virtual arm is not at rest after "
              << core::FormatNumber(kPlanRestWaitS)
              << " s; the plan starts anyway (its virtual motion then depends on the tick it "
                 "starts at: docs/physics.md, Rest)\n";
  }
  rig.WatchJoints(false);  // a long wait must not take CPU from the loop it watches
  const client::Answer answer = rig.RunPlan(file, text);
  if (const int code = Report(answer, out); code != 0) return code;
  out << "running " << file << "\n";
  if (wait_s <= 0) return 0;
  const auto steps = static_cast<int>(plan.steps.size());
  const client::Outcome outcome = rig.WaitForPlan(
      file, steps, wait_s,
      [&](int k) {
        const control::PlanStep& step = plan.steps[static_cast<size_t>(k)];
        out << "  step " << k + 1 << "/" << steps << " (line " << step.line << "): " << step.text
            << "\n";
      },
      answer.status_seq);
  if (!outcome.ok()) {
    out << outcome.detail << (outcome.end == client::End::kTimeout ? " (--timeout)" : "") << "\n";
    return kExitFailed;
  }
  rig.WatchJoints(true);
  if (rig.Until([&] { return rig.snapshot().sim_arm.has_value(); }, 0.5)) {
    out << "finished; joints [" << Degrees(model, rig.snapshot().sim_arm->position) << "] deg\n";
  } else {
    out << "finished\n";
  }
  return RealArmIncomplete(outcome, out) ? kExitFailed : 0;
}

int RunMove(const std::vector<std::string>& args, std::ostream& out) {
  if (args.empty() || (args[0] != "joints" && args[0] != "pose")) {
    throw core::UsageError("move: expected 'joints' or 'pose'; see sirupp move --help");
  }
  const std::vector<std::string> rest(args.begin() + 1, args.end());
  return args[0] == "joints" ? MoveJoints(rest, out) : MovePose(rest, out);
}

int RunPlan(const std::vector<std::string>& args, std::ostream& out) {
  if (args.empty()) throw core::UsageError("plan: expected a subcommand; see sirupp plan --help");
  const std::vector<std::string> rest(args.begin() + 1, args.end());
  const std::string& word = args[0];
  using Command = client::PlanCommand;
  if (word == "check") return PlanCheck(rest, out);
  if (word == "make") return PlanMake(rest, out);
  if (word == "run") return PlanRun(rest, out);
  if (const std::optional<Command> command = client::PlanCommandFromName(word)) {
    return PlanControl(*command, word, rest, out);
  }
  throw core::UsageError("plan: unknown subcommand '" + word +
                         "'; allowed: check, make, run, pause, resume, abort, manual, automatic");
}

namespace {

void PrintGains(std::ostream& out, const std::string& title, const sirupp::servo_gains_t& g) {
  out << title << "\n  joint     Kp     Kd     Ki     IL   OL     EL   DB\n";
  for (int j = 0; j < g.num_joints; ++j) {
    const auto i = static_cast<size_t>(j);
    char line[96];
    std::snprintf(line, sizeof line, "  %5d %6.0f %6.0f %6.0f %6.0f %4.0f %6.0f %4.0f\n", j + 1,
                  g.kp[i], g.kd[i], g.ki[i], g.integration_limit[i], g.output_limit[i],
                  g.error_limit[i], g.deadband[i]);
    out << line;
  }
}

}  // namespace

namespace {

// The gain flags and the servo_gains_t field each sets.
struct GainFlag {
  const char* name;
  std::vector<double> sirupp::servo_gains_t::*field;
};
const GainFlag kGainFlags[] = {
    {"kp", &sirupp::servo_gains_t::kp},           {"kd", &sirupp::servo_gains_t::kd},
    {"ki", &sirupp::servo_gains_t::ki},           {"il", &sirupp::servo_gains_t::integration_limit},
    {"ol", &sirupp::servo_gains_t::output_limit}, {"el", &sirupp::servo_gains_t::error_limit},
    {"db", &sirupp::servo_gains_t::deadband}};

// A gain flag: a whole number in the chip's range (servo::ChipGainsFromMessage's).
runtime::Flag GainFlagOf(const char* name, const std::string& help, long max) {
  return runtime::Flag(name, help).Takes("N").Integer(0, max);
}

// --joint as a 0-based index; -1 (every joint) without it. Whole and >= 1 by its declaration;
// the model's joint count is known only here.
int OnlyJointFrom(const runtime::Args& parsed, int n) {
  const long joint = parsed.Integer("joint", 0);
  if (joint > n) {
    throw core::UsageError("gains: --joint: '" + std::to_string(joint) +
                           "' is not allowed; allowed: a whole number from 1 to " +
                           std::to_string(n));
  }
  return static_cast<int>(joint) - 1;
}

// Whether any gain is named (each a whole number in range by its declaration).
bool GainsNamed(const runtime::Args& parsed) {
  bool change = false;
  for (const GainFlag& flag : kGainFlags) change = change || parsed.Has(flag.name);
  return change;
}

// Sets the named gains of joint `only` (every joint if -1) in `message`, then checks the result
// against the chip's ranges: core::UsageError (exit 2) if out of range.
void ApplyGainFlags(const runtime::Args& parsed, const core::RobotModel& model, int only,
                    sirupp::servo_gains_t& message) {
  for (const GainFlag& flag : kGainFlags) {
    if (!parsed.Has(flag.name)) continue;
    const double v = parsed.Numbers(flag.name, 1)[0];
    for (int j = 0; j < model.num_joints(); ++j) {
      if (only < 0 || only == j) (message.*flag.field)[static_cast<size_t>(j)] = v;
    }
  }
  try {
    servo::ChipGainsFromMessage(message, model, "gains");
  } catch (const core::MessageError& error) {
    throw core::UsageError(std::string("gains: ") + error.what());
  }
}

// `sirupp gains` without a value: the live gains of the virtual servos and of the real boards.
int PrintLiveGains(const client::Client& rig, const core::Bus& bus, std::ostream& out) {
  const client::Snapshot& seen = rig.snapshot();
  const core::Channels& channels = rig.channels();
  if (!seen.virtual_gains) {
    out << "no " << bus.FullName(channels.controller_gains) << " within 1.5 s\n";
    return kExitFailed;
  }
  PrintGains(out, "virtual servos (sirupp-control):", *seen.virtual_gains);
  if (seen.real_gains) {
    PrintGains(out, "real boards (sirupp-hardware):", *seen.real_gains);
  } else {
    out << "real boards: no " << bus.FullName(channels.real_arm_gains)
        << " heard (no bridge running)\n";
  }
  return 0;
}

// After `message` was accepted: waits until the virtual servos (and the real boards, if a bridge
// was heard) run it, and says which do.
int ConfirmGains(client::Client& rig, const sirupp::servo_gains_t& message, bool had_real,
                 std::ostream& out) {
  const client::Snapshot& seen = rig.snapshot();
  const bool taken = rig.WaitGainsShown(message, had_real, client::Client::kGainsShownS);
  out << "virtual servos: "
      << (seen.virtual_gains && client::Client::SameFilterGains(*seen.virtual_gains, message)
              ? "running the new gains"
              : "not confirmed")
      << "\n";
  if (had_real) {
    out << "real boards: "
        << (client::Client::SameFilterGains(*seen.real_gains, message)
                ? "running the new gains (read back)"
                : "not confirmed")
        << "\n";
  }
  return taken ? 0 : kExitFailed;
}

}  // namespace

int RunGains(const std::vector<std::string>& args, std::ostream& out) {
  const runtime::Args parsed(
      args, "gains",
      WithRigFlags(
          {runtime::ModelFlag(),
           runtime::Flag("joint", "joint number, 1-based")
               .Takes("J")
               .Integer(1, runtime::Flag::kMany),
           GainFlagOf("kp", "position gain", 32767), GainFlagOf("kd", "derivative gain", 32767),
           GainFlagOf("ki", "integral gain", 32767), GainFlagOf("il", "integration limit", 32767),
           GainFlagOf("ol", "output limit", 255),
           GainFlagOf("el", "position-error limit, counts", 16383),
           GainFlagOf("db", "deadband", 255)}),
      kGainsAbout);
  const core::RobotModel model = ModelFromArgs(parsed);
  const int n = model.num_joints();
  const int only = OnlyJointFrom(parsed, n);
  const bool change = GainsNamed(parsed);
  const sirupp::servo_gains_t from_model = servo::GainsMessage(servo::ChipGainsFromModel(model));
  if (change) {  // out-of-range values exit 2 before anything is sent
    sirupp::servo_gains_t check = from_model;
    ApplyGainFlags(parsed, model, only, check);
  }
  core::Bus bus = BusFromArgs(parsed);
  client::Client rig(bus, ClientOptions());
  if (!FirstStatus(rig, out)) return kExitFailed;
  const client::Snapshot& seen = rig.snapshot();
  // The live gains: the controller sends them at 1 Hz; the bridge too when it runs.
  rig.Until([&] { return seen.virtual_gains.has_value() && seen.real_gains.has_value(); }, 1.5);
  if (!change) return PrintLiveGains(rig, bus, out);
  // Only what is named changes; the rest stays as the controller has it now.
  const core::Channels& channels = rig.channels();
  sirupp::servo_gains_t message{};
  if (seen.virtual_gains && seen.virtual_gains->num_joints == n) {
    message = *seen.virtual_gains;
  } else {
    out << "no live gains heard on " << bus.FullName(channels.controller_gains)
        << ": starting from the model's\n";
    message = from_model;
  }
  ApplyGainFlags(parsed, model, only, message);
  PrintGains(out, "sending:", message);
  const bool had_real = seen.real_gains.has_value();
  const client::Answer answer = rig.SetGains(message);
  out << "sent " << bus.FullName(channels.arm_gains) << "\n";
  if (const int code = Report(answer, out); code != 0) return code;
  if (had_real) {  // the bridge answers too, on its own reply channel
    const client::Answer bridge = rig.AwaitHardwareAnswer(answer.request, 2.0);
    if (bridge.result == client::Result::kRefused) {
      out << "refused by sirupp-hardware: " << bridge.error << "\n";
      return kExitFailed;
    }
  }
  return ConfirmGains(rig, message, had_real, out);
}

namespace {

void PrintController(const client::Snapshot& watch, const core::Bus& bus, std::ostream& out) {
  if (!watch.controller) {
    out << "controller: no " << bus.FullName(core::Channels{}.controller_status) << " heard\n";
    return;
  }
  const Status& s = *watch.controller;
  out << "controller: " << ControllerModeName(s.mode) << ", " << ControllerStateName(s.state)
      << ", move " << s.move_id;
  if (!s.plan_name.empty()) {
    const bool running = s.state == Status::STATE_MOVING || s.state == Status::STATE_WAITING ||
                         s.state == Status::STATE_PAUSED;
    out << ", plan " << s.plan_name;
    if (s.plan_step >= s.plan_steps) {
      out << " finished";
    } else {
      out << (running && s.mode == Status::MODE_AUTOMATIC ? " at" : " ended at") << " step "
          << s.plan_step + 1 << "/" << s.plan_steps << " (line " << s.plan_line << ")";
    }
  }
  out << "\n  last error: " << (s.last_error.empty() ? "none" : s.last_error) << "\n";
}

void PrintSim(const sirupp::sim_status_t& sim, std::ostream& out) {
  static const char* const kModes[] = {"lockstep", "realtime", "fast", "freerun"};
  out << "sim: " << (sim.mode >= 0 && sim.mode <= 3 ? kModes[sim.mode] : "?") << ", tick "
      << sim.tick << ", realtime factor " << core::FormatApprox(sim.realtime_factor)
      << " (since start " << core::FormatApprox(sim.realtime_factor_run) << "), slipped "
      << core::FormatApprox(sim.slipped_s) << " s"
      << (sim.estop ? ", E-STOP: " + sim.estop_reason : std::string()) << "\n";
  static const char* const kPresence[] = {"answering", "not seen yet", "silent: arm braked"};
  for (int32_t i = 0; i < sim.num_participants; ++i) {
    const auto k = static_cast<size_t>(i);
    const int8_t p = sim.participant_state[k];
    out << "  participant " << sim.participant[k] << ": "
        << (p >= 0 && p <= 2 ? kPresence[p] : "?");
    if (sim.answer_mean_ms[k] >= 0) {
      out << ", answers in " << core::FormatApprox(sim.answer_mean_ms[k]) << " ms (max "
          << core::FormatApprox(sim.answer_max_ms[k]) << ")";
    }
    out << "\n";
  }
  for (int32_t i = 0; i < sim.num_refused; ++i) {
    const auto k = static_cast<size_t>(i);
    out << "  refused from '" << sim.refused_sender[k] << "': " << sim.refused_count[k] << " ("
        << sim.refused_reason[k] << ")\n";
  }
  if (sim.refused_others > 0) out << "  refused from other senders: " << sim.refused_others << "\n";
}

void PrintHeartbeats(const client::Snapshot& watch, std::ostream& out) {
  for (const auto& [who, beat] : watch.heartbeats) {
    out << "process " << who << " pid " << beat.pid << ": "
        << core::ProcessStateName(static_cast<core::ProcessState>(beat.state))
        << (beat.detail.empty() ? "" : " (" + beat.detail + ")") << ", up "
        << core::FormatApprox(beat.uptime_s) << " s\n";
    for (const sirupp::channel_stats_t& c : beat.channels) {
      if (c.rejected == 0 && c.decode_errors == 0) continue;
      out << "  " << c.channel << ": " << c.rejected << " rejected, " << c.decode_errors
          << " decode errors\n";
    }
  }
}

}  // namespace

int RunStatus(const std::vector<std::string>& args, std::ostream& out) {
  const runtime::Args parsed(args, "status",
                             WithRigFlags({TimeoutFlag("seconds to listen"), runtime::ModelFlag()}),
                             kStatusAbout);
  const double listen = TimeoutFrom(parsed, 1.5);
  const core::RobotModel model = ModelFromArgs(parsed);
  core::Bus bus = BusFromArgs(parsed);
  client::Client rig(bus, ClientOptions());
  rig.WatchJoints(true);
  rig.Listen(listen);
  const client::Snapshot& watch = rig.snapshot();
  out << "rig on " << bus.url() << (bus.prefix().empty() ? "" : ", prefix " + bus.prefix())
      << ", listened " << listen << " s\n";
  PrintController(watch, bus, out);
  if (watch.sim_arm && watch.sim_arm->num_joints == model.num_joints()) {
    out << "joints (deg): [" << Degrees(model, watch.sim_arm->position) << "] at tick "
        << watch.sim_arm->tick << ", sim time " << static_cast<double>(watch.sim_arm->utime) * 1e-6
        << " s\n";
  }
  if (watch.setpoint && watch.setpoint->num_joints == model.num_joints()) {
    out << "set-points (deg): [" << Degrees(model, watch.setpoint->position) << "], goals ["
        << Degrees(model, watch.setpoint->goal) << "]\n";
  }
  if (watch.sim) PrintSim(*watch.sim, out);
  PrintHeartbeats(watch, out);
  return watch.controller ? 0 : kExitFailed;
}

}  // namespace sirupp::tools
