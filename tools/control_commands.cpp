#include "tools/control_commands.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
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

#include "control/plan.hpp"
#include "control/pose_goal.hpp"
#include "control/servo_bank.hpp"
#include "core/channels.hpp"
#include "core/errors.hpp"
#include "core/geometry.hpp"
#include "core/heartbeat.hpp"
#include "servo/chip_gains.hpp"
#include "servo/picservo.hpp"
#include "tools/args.hpp"
#include "tools/cli.hpp"
#include "tools/rig_args.hpp"

namespace sirupp::tools {
namespace {

using Clock = std::chrono::steady_clock;
using Status = sirupp::controller_status_t;
constexpr double kDeg = 3.14159265358979323846 / 180;
constexpr double kFirstStatusS = 1.5;
// CONTROLLER_STATUS comes at 10 Hz: silent this long, the controller is gone.
constexpr double kControllerSilentS =
    1.5;  // CONTROLLER_STATUS comes at 10 Hz: wait this long for one
constexpr int kExitFailed = 1;

const char* ModeName(int8_t mode) {
  return mode == Status::MODE_AUTOMATIC ? "automatic" : "manual";
}

const char* StateName(int8_t state) {
  switch (state) {
    case Status::STATE_IDLE:
      return "idle";
    case Status::STATE_MOVING:
      return "moving";
    case Status::STATE_WAITING:
      return "waiting";
    case Status::STATE_PAUSED:
      return "paused";
    case Status::STATE_FAULT:
      return "fault";
    case Status::STATE_OFF:
      return "off";
    default:
      return "unknown";
  }
}

// What the rig reports, kept up to date while Until() handles messages.
class RigWatch {
 public:
  RigWatch(core::Bus& bus, bool joints) : bus_(bus) {
    const core::Channels channels;
    bus_.Subscribe<Status>(channels.controller_status,
                           [this](const Status& message, const core::ReceiveInfo&) {
                             status = message;
                             ++statuses;
                             last_status_at = std::chrono::steady_clock::now();
                           });
    bus_.Subscribe<sirupp::sim_status_t>(
        channels.sim_status,
        [this](const sirupp::sim_status_t& message, const core::ReceiveInfo&) { sim = message; });
    bus_.Subscribe<sirupp::servo_gains_t>(
        channels.controller_gains, [this](const sirupp::servo_gains_t& message,
                                          const core::ReceiveInfo&) { virtual_gains = message; });
    bus_.Subscribe<sirupp::servo_gains_t>(
        channels.real_arm_gains, [this](const sirupp::servo_gains_t& message,
                                        const core::ReceiveInfo&) { real_gains = message; });
    bus_.Subscribe<sirupp::heartbeat_t>(
        channels.heartbeat, [this](const sirupp::heartbeat_t& message, const core::ReceiveInfo&) {
          heartbeats[message.process + "@" + message.host] = message;
        });
    if (joints) ListenToJoints(true);
  }

  // Per-tick channels (ARM_SETPOINT, SIM_ARM_STATE), newest message only. A command that waits
  // long turns them off, so it does not take CPU from the loop it watches.
  void ListenToJoints(bool on) {
    if (!on) {
      for (core::Subscription* subscription : joint_subscriptions_) subscription->Unsubscribe();
      joint_subscriptions_.clear();
      return;
    }
    if (!joint_subscriptions_.empty()) return;
    const core::Channels channels;
    joint_subscriptions_.push_back(&bus_.Subscribe<sirupp::servo_setpoint_t>(
        channels.arm_setpoint,
        [this](const sirupp::servo_setpoint_t& message, const core::ReceiveInfo&) {
          setpoint = message;
        },
        2));
    joint_subscriptions_.push_back(&bus_.Subscribe<sirupp::arm_state_t>(
        channels.sim_arm_state,
        [this](const sirupp::arm_state_t& message, const core::ReceiveInfo&) { state = message; },
        2));
  }

  // Handles messages until done() holds or timeout_s passed; returns done().
  bool Until(const std::function<bool()>& done, double timeout_s) {
    return HandleUntil(bus_, done, timeout_s);
  }

  // Waits for the first CONTROLLER_STATUS; false (and a message on `out`) if none came.
  bool FirstStatus(std::ostream& out) {
    if (Until([this] { return status.has_value(); }, kFirstStatusS)) return true;
    out << "no " << bus_.FullName(core::Channels{}.controller_status) << " within " << kFirstStatusS
        << " s on " << bus_.url() << ": is sirupp-control running (same --lcm-url and --prefix)?\n";
    return false;
  }

  // True when sirupp-control has sent no status for `seconds` (it sends at 10 Hz): it crashed or
  // was stopped. `out` gets the reason.
  bool ControllerSilent(double seconds, std::ostream& out) const {
    const double silent =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - last_status_at).count();
    if (!status || silent < seconds) return false;
    out << "sirupp-control stopped answering: no "
        << bus_.FullName(core::Channels{}.controller_status) << " for "
        << core::FormatApprox(silent) << " s (it crashed or was stopped; its log says why)\n";
    return true;
  }

  std::optional<Status> status;
  int64_t statuses = 0;
  std::chrono::steady_clock::time_point last_status_at;
  std::optional<sirupp::sim_status_t> sim;
  std::optional<sirupp::servo_gains_t> virtual_gains;
  std::optional<sirupp::servo_gains_t> real_gains;
  std::optional<sirupp::servo_setpoint_t> setpoint;
  std::optional<sirupp::arm_state_t> state;
  std::map<std::string, sirupp::heartbeat_t> heartbeats;

 private:
  core::Bus& bus_;
  std::vector<core::Subscription*> joint_subscriptions_;
};

// The controller's answer to what was just sent on `channel`: accepted() on a newer status, or a
// new last_error naming the channel (refused). Prints the outcome; returns the exit code.
// With no `accepted` (a message that leaves no trace when taken), silence for timeout_s is taken.
int Confirm(RigWatch& watch, const core::Bus& bus, const std::string& channel,
            const std::function<bool(const Status&)>& accepted, std::ostream& out,
            double timeout_s = 2.0) {
  const int64_t base_seq = watch.status->seq;
  const std::string base_error = watch.status->last_error;
  const std::string prefix = "channel " + bus.FullName(channel) + ":";
  bool refused = false;
  const bool answered = watch.Until(
      [&] {
        if (watch.status->seq <= base_seq) return false;
        const std::string& error = watch.status->last_error;
        if (error.rfind(prefix, 0) == 0 && error != base_error) return refused = true;
        return accepted && accepted(*watch.status);
      },
      timeout_s);
  if (refused) {
    out << "refused by sirupp-control: " << watch.status->last_error << "\n";
    return kExitFailed;
  }
  if (!answered && accepted) {
    out << "sirupp-control did not confirm within " << timeout_s << " s (last error: "
        << (watch.status->last_error.empty() ? "none" : watch.status->last_error) << ")\n";
    return kExitFailed;
  }
  return 0;
}

// After an accepted move: waits until the controller is idle with this move (or a fault).
int WaitForMove(RigWatch& watch, int64_t move_id, double timeout_s, std::ostream& out) {
  bool silent = false;
  const bool ended = watch.Until(
      [&] {
        const Status& s = *watch.status;
        silent = watch.ControllerSilent(kControllerSilentS, out);
        return silent || s.state == Status::STATE_FAULT || s.move_id != move_id ||
               s.state == Status::STATE_IDLE;
      },
      timeout_s);
  if (silent) return kExitFailed;
  const Status& s = *watch.status;
  if (!ended) {
    out << "still " << StateName(s.state) << " after " << timeout_s << " s (--timeout)\n";
    return kExitFailed;
  }
  if (s.state == Status::STATE_FAULT) {
    out << "fault: " << s.last_error << "\n";
    return kExitFailed;
  }
  if (s.move_id != move_id) {
    out << "superseded by move " << s.move_id << "\n";
    return kExitFailed;
  }
  out << "move " << move_id << " done\n";
  return 0;
}

// The joints' present goals from ARM_SETPOINT (where a new plan starts), or home when none came.
std::vector<double> PresentGoals(RigWatch& watch, const core::RobotModel& model,
                                 std::string& source) {
  watch.Until([&] { return watch.setpoint.has_value(); }, 0.5);
  if (watch.setpoint && watch.setpoint->num_joints == model.num_joints()) {
    source = "the arm's present goals";
    return watch.setpoint->goal;
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

double ScaleFrom(const Args& parsed, const std::string& command) {
  if (!parsed.Has("scale")) return 1.0;
  const double scale = parsed.Numbers("scale", 1)[0];
  if (!(scale > 0) || scale > 1) {
    throw core::UsageError(command + ": --scale " + core::FormatNumber(scale) +
                           ": allowed (0, 1], a fraction of each joint's default speed");
  }
  return scale;
}

int MoveJoints(const std::vector<std::string>& args, std::ostream& out) {
  const Args parsed(args, "move joints",
                    WithRigFlags({{"model", "robot model file"},
                                  {"pose", "named pose"},
                                  {"deg", "joint positions in degrees"},
                                  {"rad", "joint positions in radians"},
                                  {"scale", "fraction of the default speeds"},
                                  {"wait", "wait until the move is done"},
                                  {"timeout", "seconds to wait"}}));
  const core::RobotModel model = ModelFromArgs(parsed);
  const double scale = ScaleFrom(parsed, "move joints");
  const bool wait = parsed.Switch("wait");
  const double timeout = TimeoutFrom(parsed, 60);
  sirupp::joint_target_t target{};
  target.utime = WallMicros();
  target.num_joints = model.num_joints();
  target.position = PositionsFromArgs(parsed, model, "move joints");
  for (const core::Joint& joint : model.joints) {
    target.max_velocity.push_back(joint.servo.default_velocity * scale);
    target.acceleration.push_back(0.0);  // 0 = the model's default
  }
  target.active.assign(target.position.size(), 1);

  core::Bus bus = BusFromArgs(parsed);
  RigWatch watch(bus, false);
  if (!watch.FirstStatus(out)) return kExitFailed;
  const int64_t base_move = watch.status->move_id;
  bus.Publish(core::Channels{}.arm_target, target);
  PrintSent(out, bus, core::Channels{}.arm_target, model, target.position);
  out << "\n";
  const int code = Confirm(
      watch, bus, core::Channels{}.arm_target,
      [&](const Status& s) { return s.move_id > base_move; }, out);
  if (code != 0) return code;
  out << "accepted as move " << watch.status->move_id << "\n";
  return wait ? WaitForMove(watch, watch.status->move_id, timeout, out) : 0;
}

int MovePose(const std::vector<std::string>& args, std::ostream& out) {
  const Args parsed(args, "move pose",
                    WithRigFlags({{"model", "robot model file"},
                                  {"pose", "X Y Z ROLL PITCH YAW (m, deg)"},
                                  {"position", "X Y Z (m), orientation free"},
                                  {"config", "SHOULDER-ELBOW-WRIST or nearest"},
                                  {"scale", "fraction of the default speeds"},
                                  {"wait", "wait until the move is done"},
                                  {"timeout", "seconds to wait"}}));
  const core::RobotModel model = ModelFromArgs(parsed);
  if (parsed.Has("pose") == parsed.Has("position")) {
    throw core::UsageError(
        "move pose: give exactly one of --pose X Y Z ROLL PITCH YAW or "
        "--position X Y Z");
  }
  const bool position_only = parsed.Has("position");
  std::vector<double> v =
      parsed.Numbers(position_only ? "position" : "pose", position_only ? 3 : 6);
  v.resize(6, 0.0);
  control::PoseRequest request;
  request.target.translation() << v[0], v[1], v[2];
  const Eigen::Quaterniond orientation =
      core::QuaternionFromRpy(v[3] * kDeg, v[4] * kDeg, v[5] * kDeg);
  request.target.linear() = orientation.toRotationMatrix();
  request.position_only = position_only;
  const std::string config_text = parsed.Has("config") ? parsed.String("config") : "nearest";
  if (config_text != "nearest") {
    const std::optional<core::IkConfiguration> config = core::IkConfiguration::Parse(config_text);
    if (!config) {
      throw core::UsageError("move pose: --config '" + config_text +
                             "' is not allowed; expected nearest or SHOULDER-ELBOW-WRIST with "
                             "left|right, up|down, noflip|flip (e.g. right-up-noflip)");
    }
    request.SetConfig(*config);
  }
  const double scale = ScaleFrom(parsed, "move pose");
  const bool wait = parsed.Switch("wait");
  const double timeout = TimeoutFrom(parsed, 60);

  core::Bus bus = BusFromArgs(parsed);
  RigWatch watch(bus, true);
  // Checked here from the arm's present joints, as sirupp-control will.
  watch.Until([&] { return watch.state.has_value(); }, 0.5);
  const std::vector<double> reference = watch.state && watch.state->num_joints == model.num_joints()
                                            ? watch.state->position
                                            : control::HomePositions(model);
  const control::PoseGoal goal =
      control::SolvePoseGoal(model, request, core::ToJointVector(reference));
  if (!goal.ok) throw core::UsageError("move pose: no joint solution: " + goal.reason);
  if (!watch.FirstStatus(out)) return kExitFailed;

  sirupp::pose_target_t target{};
  target.utime = WallMicros();
  for (int i = 0; i < 3; ++i) target.position[i] = v[static_cast<size_t>(i)];
  target.orientation[0] = orientation.w();
  target.orientation[1] = orientation.x();
  target.orientation[2] = orientation.y();
  target.orientation[3] = orientation.z();
  target.position_only = position_only ? 1 : 0;
  using Pose = sirupp::pose_target_t;
  if (request.shoulder_left) {
    target.shoulder = *request.shoulder_left ? Pose::SHOULDER_LEFT : Pose::SHOULDER_RIGHT;
  }
  if (request.elbow_up) target.elbow = *request.elbow_up ? Pose::ELBOW_UP : Pose::ELBOW_DOWN;
  if (request.wrist_flip)
    target.wrist = *request.wrist_flip ? Pose::WRIST_FLIP : Pose::WRIST_NO_FLIP;
  target.speed_scale = scale;
  const int64_t base_move = watch.status->move_id;
  bus.Publish(core::Channels{}.arm_pose_target, target);
  out << "sent " << bus.FullName(core::Channels{}.arm_pose_target) << ": tool to [" << v[0] << " "
      << v[1] << " " << v[2] << "] m"
      << (position_only ? ""
                        : ", rpy [" + core::FormatApprox(v[3]) + " " + core::FormatApprox(v[4]) +
                              " " + core::FormatApprox(v[5]) + "] deg")
      << "; expected joints ["
      << Degrees(model, std::vector<double>(goal.q.data(), goal.q.data() + goal.q.size()))
      << "] deg" << (goal.config_name.empty() ? "" : " (" + goal.config_name + ")") << "\n";
  const int code = Confirm(
      watch, bus, core::Channels{}.arm_pose_target,
      [&](const Status& s) { return s.move_id > base_move; }, out);
  if (code != 0) return code;
  out << "accepted as move " << watch.status->move_id << "\n";
  return wait ? WaitForMove(watch, watch.status->move_id, timeout, out) : 0;
}

void PrintPlan(std::ostream& out, const core::RobotModel& model, const control::Plan& plan) {
  out << plan.name << ": ok: " << plan.steps.size() << " steps, " << plan.moves()
      << " moves; ends at [" << Degrees(model, plan.final_goal) << "] deg\n";
}

int PlanCheck(const std::vector<std::string>& args, std::ostream& out) {
  std::vector<std::string> files;
  std::vector<std::string> flags;
  for (const std::string& arg : args) {
    (arg.rfind("--", 0) == 0 || !flags.empty() ? flags : files).push_back(arg);
  }
  const Args parsed(flags, "plan check", {{"model", "robot model file"}});
  if (files.empty()) throw core::UsageError("plan check: missing FILE");
  const core::RobotModel model = ModelFromArgs(parsed);
  for (const std::string& file : files) {
    PrintPlan(out, model,
              control::ParsePlan(control::ReadPlanText(file), file, model,
                                 control::HomePositions(model)));
  }
  return 0;
}

int PlanRun(const std::vector<std::string>& args, std::ostream& out) {
  if (args.empty() || args[0].rfind("--", 0) == 0) throw core::UsageError("plan run: missing FILE");
  const std::string file = args[0];
  const Args parsed(std::vector<std::string>(args.begin() + 1, args.end()), "plan run",
                    WithRigFlags({{"model", "robot model file"},
                                  {"wait", "follow the plan to its end"},
                                  {"timeout", "seconds to wait"}}));
  const core::RobotModel model = ModelFromArgs(parsed);
  const bool wait = parsed.Switch("wait");
  const double timeout = TimeoutFrom(parsed, 3600);
  const std::string text = control::ReadPlanText(file);
  core::Bus bus = BusFromArgs(parsed);
  RigWatch watch(bus, true);
  std::string start_source;
  const std::vector<double> start = PresentGoals(watch, model, start_source);
  const control::Plan plan = control::ParsePlan(text, file, model, start);  // exit 2 if bad
  out << "checked from " << start_source << ": ";
  PrintPlan(out, model, plan);
  if (!watch.FirstStatus(out)) return kExitFailed;

  sirupp::plan_command_t command{};
  command.utime = WallMicros();
  command.command = sirupp::plan_command_t::COMMAND_RUN;
  command.name = file;
  command.text = text;
  const int64_t base_move = watch.status->move_id;
  bus.Publish(core::Channels{}.arm_plan, command);
  const int code = Confirm(
      watch, bus, core::Channels{}.arm_plan,
      [&](const Status& s) { return s.plan_name == file && s.move_id > base_move; }, out);
  if (code != 0) return code;
  out << "running " << file << "\n";
  if (!wait) return 0;
  watch.ListenToJoints(false);

  int shown_step = -1;
  const auto steps = static_cast<int>(plan.steps.size());
  bool silent = false;
  const bool ended = watch.Until(
      [&] {
        const Status& s = *watch.status;
        if ((silent = watch.ControllerSilent(kControllerSilentS, out))) return true;
        if (s.plan_name != file) return true;  // another plan replaced it
        if (s.plan_step != shown_step && s.plan_step < steps) {
          shown_step = s.plan_step;
          const control::PlanStep& step = plan.steps[static_cast<size_t>(shown_step)];
          out << "  step " << shown_step + 1 << "/" << steps << " (line " << step.line
              << "): " << step.text << "\n";
        }
        return s.state == Status::STATE_FAULT || s.state == Status::STATE_IDLE;
      },
      timeout);
  if (silent) return kExitFailed;
  const Status& s = *watch.status;
  if (!ended) {
    out << "still " << StateName(s.state) << " after " << timeout << " s (--timeout)\n";
    return kExitFailed;
  }
  if (s.state == Status::STATE_FAULT || !s.last_error.empty()) {
    out << "plan failed: " << s.last_error << "\n";
    return kExitFailed;
  }
  if (s.plan_name != file || s.plan_step < steps) {
    out << "plan ended at step " << s.plan_step + 1 << " of " << steps << " (aborted)\n";
    return kExitFailed;
  }
  watch.state.reset();
  watch.ListenToJoints(true);
  if (watch.Until([&] { return watch.state.has_value(); }, 0.5)) {
    out << "finished; joints [" << Degrees(model, watch.state->position) << "] deg\n";
  } else {
    out << "finished\n";
  }
  return 0;
}

int PlanControl(int8_t command, const std::string& word, const std::vector<std::string>& args,
                std::ostream& out) {
  const Args parsed(args, "plan " + word, WithRigFlags({}));
  core::Bus bus = BusFromArgs(parsed);
  RigWatch watch(bus, false);
  if (!watch.FirstStatus(out)) return kExitFailed;
  sirupp::plan_command_t message{};
  message.utime = WallMicros();
  message.command = command;
  bus.Publish(core::Channels{}.arm_plan, message);
  const int code = Confirm(
      watch, bus, core::Channels{}.arm_plan,
      [&](const Status& s) {
        switch (command) {
          case sirupp::plan_command_t::COMMAND_PAUSE:
            return s.state == Status::STATE_PAUSED;
          case sirupp::plan_command_t::COMMAND_RESUME:
            return s.state != Status::STATE_PAUSED;
          case sirupp::plan_command_t::COMMAND_MANUAL:
            return s.mode == Status::MODE_MANUAL;
          case sirupp::plan_command_t::COMMAND_AUTOMATIC:
            return s.mode == Status::MODE_AUTOMATIC;
          case sirupp::plan_command_t::COMMAND_CLEAR_FAULT:
            return s.state != Status::STATE_FAULT;
          case sirupp::plan_command_t::COMMAND_ABORT:
            // A status sent before the controller took the abort may still be on its way: the
            // plan has ended once the controller is manual again (or, locked in automatic, once
            // the arm is at rest with no plan waiting or paused).
            return s.mode == Status::MODE_MANUAL ||
                   (s.state != Status::STATE_MOVING && s.state != Status::STATE_WAITING &&
                    s.state != Status::STATE_PAUSED);
          default:
            return true;
        }
      },
      out);
  if (code != 0) return code;
  out << word << ": done; controller " << ModeName(watch.status->mode) << ", "
      << StateName(watch.status->state) << "\n";
  return 0;
}

}  // namespace

const char* const kMoveUsage =
    "usage: sirupp move joints (--pose NAME | --deg Q1 .. QN | --rad Q1 .. QN) [--scale F]\n"
    "       sirupp move pose (--pose X Y Z ROLL PITCH YAW | --position X Y Z)\n"
    "                        [--config SHOULDER-ELBOW-WRIST | --config nearest] [--scale F]\n"
    "  common: [--wait] [--timeout S] [--model FILE] [--lcm-url URL] [--prefix PREFIX]\n"
    "  joints: every joint to the given positions (ARM_TARGET), one trapezoidal move per joint.\n"
    "  pose: the tool to a pose in the world frame, metres and degrees (ARM_POSE_TARGET);\n"
    "  sirupp-control solves the IK and takes the configuration asked (e.g. right-up-noflip) or\n"
    "  the solution nearest the present joints. --scale: fraction of the joints' default speeds.\n"
    "  Targets outside the limits or out of reach are refused here (exit 2) and nothing is sent.\n"
    "  Then the controller's answer is shown: accepted (exit 0) or refused (exit 1, with why);\n"
    "  --wait follows the move until it is done.\n";

const char* const kPlanUsage =
    "usage: sirupp plan check FILE... [--model FILE]\n"
    "       sirupp plan run FILE [--wait] [--timeout S] [--model FILE]\n"
    "       sirupp plan pause | resume | abort | manual | automatic\n"
    "  common: [--lcm-url URL] [--prefix PREFIX]\n"
    "  check: validates plans completely (from the model's home pose); exit 2 naming file:line.\n"
    "  run: validates from the arm's present goals, sends the plan text on ARM_PLAN and confirms\n"
    "  it started; --wait prints each step and exits 0 when the plan finished, 1 if it was\n"
    "  aborted or a servo faulted. pause finishes the present move, then waits; abort stops\n"
    "  the arm smoothly (also with no plan running); automatic locks out manual targets until\n"
    "  manual. Format: docs/plan-format.md; examples: config/plans/.\n"
    "  A fault (a tripped servo, a failing student controller, another robot in the sim) holds\n"
    "  the arm and refuses targets and plans, naming its first cause, until `sirupp "
    "clear-fault`.\n";

const char* const kGainsUsage =
    "usage: sirupp gains [--joint N] [--kp V] [--kd V] [--ki V] [--il V] [--ol V] [--el V]\n"
    "                    [--db V] [--model FILE] [--lcm-url URL] [--prefix PREFIX]\n"
    "  Sets the servo filter gains of sirupp-control live (ARM_GAINS), in PIC-SERVO units\n"
    "  (docs/servo-units.md): Kp, Kd, Ki, integration limit, output limit (PWM 0..255), error\n"
    "  limit (counts) and deadband. Only what is named changes: the rest is taken from the live\n"
    "  gains (CONTROLLER_GAINS); --joint N (1-based) changes one joint, otherwise every joint.\n"
    "  With no value, prints the live gains of the virtual servos and, when a bridge runs, of\n"
    "  the real boards (REAL_ARM_GAINS); the bridge loads ARM_GAINS into the boards too.\n"
    "  Out-of-range values exit 2; nothing is sent.\n";

const char* const kStatusUsage =
    "usage: sirupp status [--timeout S] [--lcm-url URL] [--prefix PREFIX]\n"
    "  What the rig reports over about one second (--timeout, default 1.5): sirupp-control's\n"
    "  mode, state, move, plan step and last error; the arm's joints and set-points; and every\n"
    "  process heard on HEARTBEAT with its refused messages and decode errors per channel; the\n"
    "  sim's timing mode, real-time factor, participants and refused senders (SIM_STATUS).\n"
    "  Exit 1 if no controller status was heard.\n";

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
  using Command = sirupp::plan_command_t;
  if (word == "check") return PlanCheck(rest, out);
  if (word == "run") return PlanRun(rest, out);
  if (word == "pause") return PlanControl(Command::COMMAND_PAUSE, word, rest, out);
  if (word == "resume") return PlanControl(Command::COMMAND_RESUME, word, rest, out);
  if (word == "abort") return PlanControl(Command::COMMAND_ABORT, word, rest, out);
  if (word == "manual") return PlanControl(Command::COMMAND_MANUAL, word, rest, out);
  if (word == "automatic") return PlanControl(Command::COMMAND_AUTOMATIC, word, rest, out);
  if (word == "clear-fault") return PlanControl(Command::COMMAND_CLEAR_FAULT, word, rest, out);
  throw core::UsageError("plan: unknown subcommand '" + word +
                         "'; allowed: check, run, pause, resume, abort, manual, automatic");
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

bool SameFilterGains(const sirupp::servo_gains_t& a, const sirupp::servo_gains_t& b) {
  return a.num_joints == b.num_joints && a.kp == b.kp && a.kd == b.kd && a.ki == b.ki &&
         a.integration_limit == b.integration_limit && a.output_limit == b.output_limit &&
         a.error_limit == b.error_limit && a.deadband == b.deadband;
}

}  // namespace

int RunGains(const std::vector<std::string>& args, std::ostream& out) {
  const Args parsed(args, "gains",
                    WithRigFlags({{"model", "robot model file"},
                                  {"joint", "joint number, 1-based"},
                                  {"kp", "position gain 0..32767"},
                                  {"kd", "derivative gain 0..32767"},
                                  {"ki", "integral gain 0..32767"},
                                  {"il", "integration limit 0..32767"},
                                  {"ol", "output limit 0..255"},
                                  {"el", "position-error limit 0..16383 counts"},
                                  {"db", "deadband 0..255"}}));
  const core::RobotModel model = ModelFromArgs(parsed);
  const int n = model.num_joints();
  int only = -1;
  if (parsed.Has("joint")) {
    const double joint = parsed.Numbers("joint", 1)[0];
    if (joint != std::floor(joint) || joint < 1 || joint > n) {
      throw core::UsageError("gains: --joint " + core::FormatNumber(joint) + ": allowed 1.." +
                             std::to_string(n));
    }
    only = static_cast<int>(joint) - 1;
  }
  struct Flag {
    const char* name;
    std::vector<double> sirupp::servo_gains_t::*field;
  };
  const Flag flags[] = {{"kp", &sirupp::servo_gains_t::kp},
                        {"kd", &sirupp::servo_gains_t::kd},
                        {"ki", &sirupp::servo_gains_t::ki},
                        {"il", &sirupp::servo_gains_t::integration_limit},
                        {"ol", &sirupp::servo_gains_t::output_limit},
                        {"el", &sirupp::servo_gains_t::error_limit},
                        {"db", &sirupp::servo_gains_t::deadband}};
  bool change = false;
  for (const Flag& flag : flags) {
    if (!parsed.Has(flag.name)) continue;
    change = true;
    const double v = parsed.Numbers(flag.name, 1)[0];
    if (v != std::floor(v) || std::abs(v) > 1e9) {
      throw core::UsageError(std::string("gains: --") + flag.name + " " + core::FormatNumber(v) +
                             ": allowed whole numbers");
    }
  }
  const sirupp::servo_gains_t from_model = servo::GainsMessage(servo::ChipGainsFromModel(model));
  const auto apply_flags = [&](sirupp::servo_gains_t& message) {
    for (const Flag& flag : flags) {
      if (!parsed.Has(flag.name)) continue;
      const double v = parsed.Numbers(flag.name, 1)[0];
      for (int j = 0; j < n; ++j) {
        if (only < 0 || only == j) (message.*flag.field)[static_cast<size_t>(j)] = v;
      }
    }
    try {
      servo::ChipGainsFromMessage(message, model, "gains");
    } catch (const core::MessageError& error) {
      throw core::UsageError(std::string("gains: ") + error.what());
    }
  };
  if (change) {  // out-of-range values exit 2 before anything is sent
    sirupp::servo_gains_t check = from_model;
    apply_flags(check);
  }
  core::Bus bus = BusFromArgs(parsed);
  RigWatch watch(bus, false);
  if (!watch.FirstStatus(out)) return kExitFailed;
  // The live gains: the controller sends them at 1 Hz; the bridge too when it runs.
  watch.Until([&] { return watch.virtual_gains.has_value() && watch.real_gains.has_value(); }, 1.5);
  const core::Channels channels;
  if (!change) {
    if (!watch.virtual_gains) {
      out << "no " << bus.FullName(channels.controller_gains) << " within 1.5 s\n";
      return kExitFailed;
    }
    PrintGains(out, "virtual servos (sirupp-control):", *watch.virtual_gains);
    if (watch.real_gains) {
      PrintGains(out, "real boards (sirupp-hardware):", *watch.real_gains);
    } else {
      out << "real boards: no " << bus.FullName(channels.real_arm_gains)
          << " heard (no bridge running)\n";
    }
    return 0;
  }
  // Only what is named changes; the rest stays as the controller has it now.
  sirupp::servo_gains_t message{};
  if (watch.virtual_gains && watch.virtual_gains->num_joints == n) {
    message = *watch.virtual_gains;
  } else {
    out << "no live gains heard on " << bus.FullName(channels.controller_gains)
        << ": starting from the model's\n";
    message = from_model;
  }
  message.utime = WallMicros();
  message.seq = 0;
  apply_flags(message);
  PrintGains(out, "sending:", message);
  bus.Publish(channels.arm_gains, message);
  out << "sent " << bus.FullName(channels.arm_gains) << "\n";
  const int code = Confirm(watch, bus, channels.arm_gains, nullptr, out, 0.3);
  if (code != 0) return code;
  const bool had_real = watch.real_gains.has_value();
  const bool taken = watch.Until(
      [&] {
        return watch.virtual_gains && SameFilterGains(*watch.virtual_gains, message) &&
               (!had_real || SameFilterGains(*watch.real_gains, message));
      },
      2.5);
  out << "virtual servos: "
      << (watch.virtual_gains && SameFilterGains(*watch.virtual_gains, message)
              ? "running the new gains"
              : "not confirmed")
      << "\n";
  if (had_real) {
    out << "real boards: "
        << (SameFilterGains(*watch.real_gains, message) ? "running the new gains (read back)"
                                                        : "not confirmed")
        << "\n";
  }
  return taken ? 0 : kExitFailed;
}

int RunStatus(const std::vector<std::string>& args, std::ostream& out) {
  const Args parsed(
      args, "status",
      WithRigFlags({{"timeout", "seconds to listen"}, {"model", "robot model file"}}));
  const double listen = TimeoutFrom(parsed, 1.5);
  const core::RobotModel model = ModelFromArgs(parsed);
  core::Bus bus = BusFromArgs(parsed);
  RigWatch watch(bus, true);
  watch.Until([] { return false; }, listen);
  out << "rig on " << bus.url() << (bus.prefix().empty() ? "" : ", prefix " + bus.prefix())
      << ", listened " << listen << " s\n";
  if (watch.status) {
    const Status& s = *watch.status;
    out << "controller: " << ModeName(s.mode) << ", " << StateName(s.state) << ", move "
        << s.move_id;
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
  } else {
    out << "controller: no " << bus.FullName(core::Channels{}.controller_status) << " heard\n";
  }
  if (watch.state && watch.state->num_joints == model.num_joints()) {
    out << "joints (deg): [" << Degrees(model, watch.state->position) << "] at tick "
        << watch.state->tick << ", sim time " << static_cast<double>(watch.state->utime) * 1e-6
        << " s\n";
  }
  if (watch.setpoint && watch.setpoint->num_joints == model.num_joints()) {
    out << "set-points (deg): [" << Degrees(model, watch.setpoint->position) << "], goals ["
        << Degrees(model, watch.setpoint->goal) << "]\n";
  }
  if (watch.sim) {
    const sirupp::sim_status_t& sim = *watch.sim;
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
    if (sim.refused_others > 0)
      out << "  refused from other senders: " << sim.refused_others << "\n";
  }
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
  return watch.status ? 0 : kExitFailed;
}

}  // namespace sirupp::tools
