#include "grade/runner.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <sirupp/arm_command_t.hpp>
#include <sirupp/arm_state_t.hpp>
#include <sirupp/servo_setpoint_t.hpp>

#include "core/bus.hpp"
#include "core/channels.hpp"
#include "core/errors.hpp"
#include "core/units.hpp"
#include "grade/driver.hpp"
#include "grade/reference.hpp"
#include "proc/child.hpp"
#include "proc/rig.hpp"

namespace sirupp::grade {
namespace {

using Clock = std::chrono::steady_clock;
constexpr const char* kGraderName = "sirupp-grade";
// A task's rig: a large receive buffer (the grader hears every tick of a lockstep run).
constexpr const char* kTaskUrlOptions = "recv_buf_size=4194304";

double Since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// Degrees (mm) for placeholders.
std::string Degrees(const core::RobotModel& model, size_t j, double si) {
  return core::FormatNumber(model.joints[j].type == core::JointType::kRevolute ? si * 180 / kPi
                                                                               : si * 1000);
}

}  // namespace

std::vector<std::string> ExpandCommand(const std::vector<std::string>& command,
                                       const core::RobotModel& model, const Task& task,
                                       const std::string& url, const std::string& name,
                                       const std::string& reference_file) {
  std::vector<std::string> out;
  for (const std::string& word : command) {
    if (word == "{goal_deg}" || word == "{start_deg}") {
      const std::vector<double>& values = word == "{goal_deg}" ? task.goal : task.start;
      for (size_t j = 0; j < values.size(); ++j) out.push_back(Degrees(model, j, values[j]));
      continue;
    }
    std::string text = word;
    const auto replace = [&text](const std::string& key, const std::string& value) {
      for (size_t at = text.find(key); at != std::string::npos;
           at = text.find(key, at + value.size())) {
        text.replace(at, key.size(), value);
      }
    };
    replace("{url}", url);
    replace("{name}", name);
    replace("{duration_s}", core::FormatNumber(task.duration_s));
    replace("{reference_csv}", reference_file);
    out.push_back(text);
  }
  return out;
}

namespace {

// The messages of a task by tick (row), filled as they come: n values a row.
struct TickRows {
  TickRows(size_t ticks, size_t n)
      : position(ticks * n, 0.0),
        reference(ticks * n, 0.0),
        goal(ticks * n, 0.0),
        effort(ticks * n, 0.0),
        have_state(ticks, 0),
        have_command(ticks, 0),
        have_setpoint(ticks, 0) {}
  std::vector<double> position, reference, goal, effort;
  std::vector<char> have_state, have_command, have_setpoint;
};

// The grader's answer to the state of `tick`, as the sim's other participant: zero effort, but
// the task's disturbance while it lasts.
sirupp::arm_command_t GraderAnswer(const core::RobotModel& model, const Task& task, int64_t tick) {
  const auto n = static_cast<size_t>(model.num_joints());
  sirupp::arm_command_t command{};
  command.utime =
      static_cast<int64_t>(std::llround(static_cast<double>(tick) * model.servo_tick_s * 1e6));
  command.seq = tick;
  command.tick = tick;
  command.sender = kGraderName;
  command.mode = sirupp::arm_command_t::MODE_EFFORT;
  command.num_joints = model.num_joints();
  command.effort.assign(n, 0.0);
  const double t = static_cast<double>(tick) * model.servo_tick_s;
  if (task.disturbance && t >= task.disturbance->from_s && t < task.disturbance->to_s) {
    command.effort[static_cast<size_t>(task.disturbance->joint)] = task.disturbance->effort;
  }
  return command;
}

// The task's private rig (proc/rig.hpp): sirupp-sim in lockstep with the participant and the
// grader, at the task's start pose and arm, and sirupp-control with the library controller or the
// baseline (unused when the participant is the student's own process). Logs: work_dir/NAME.log.
proc::RigSpec TaskRig(const Suite& suite, const core::RobotModel& model, const Task& task,
                      const ControllerSpec& controller, const RunOptions& options,
                      const std::string& participant) {
  proc::RigSpec rig;
  rig.port = options.port;
  rig.url_options = kTaskUrlOptions;
  rig.bin_dir = options.bin_dir;
  rig.model = suite.model_file;
  rig.sim_mode = "lockstep";
  rig.participants = {participant, kGraderName};
  rig.log_dir = options.work_dir;
  rig.sim_args = {"--duration", core::FormatNumber(task.duration_s), "--lockstep-timeout", "1",
                  "--rad"};  // SI: revolute rad, prismatic m
  for (size_t j = 0; j < static_cast<size_t>(model.num_joints()); ++j) {
    rig.sim_args.push_back(core::FormatNumber(task.start[j]));
  }
  if (task.arm.payload_kg > 0) {
    rig.sim_args.insert(rig.sim_args.end(),
                        {"--payload-kg", core::FormatNumber(task.arm.payload_kg)});
  }
  if (task.arm.friction_scale != 1) {
    rig.sim_args.insert(rig.sim_args.end(),
                        {"--friction-scale", core::FormatNumber(task.arm.friction_scale)});
  }
  if (task.arm.gravity_off) rig.sim_args.push_back("--gravity-off");
  if (!task.environment.empty()) {
    rig.sim_args.insert(rig.sim_args.end(), {"--environment", task.environment});
  }
  // The harness records sirupp-control's per-tick answers and set-points (the baseline's too):
  // its boards run in it, answering every tick, as with a student's library.
  rig.control_args = {"--sim-timeout", "3600", "--boards", "control"};
  if (controller.kind == ControllerSpec::Kind::kLibrary) {
    rig.controller = controller.library;
    rig.control_args.insert(rig.control_args.end(),
                            {"--controller-tick-limit", core::FormatNumber(suite.limits.tick_s)});
    if (!controller.args.empty()) {
      rig.control_args.insert(rig.control_args.end(), {"--controller-args", controller.args});
    }
    if (!controller.sandbox) rig.control_args.emplace_back("--no-sandbox");
  }
  return rig;
}

// Why the task is given up while its processes run, or "" to go on: no answer to the first
// state within the start limit, a tick not answered within the per-tick limit (`grace_s`), the
// plan not taken, or the task over its wall-time limit.
std::string StallFailure(const Limits& limits, int64_t controller_tick, int64_t last_state,
                         int64_t answered, double stalled, double grace_s, double elapsed) {
  if (controller_tick < 0 && stalled > limits.start_s) {
    return "never answered: no answer to the first state within " +
           core::FormatNumber(limits.start_s) + " s (the start limit)";
  } else if (controller_tick >= 0 && controller_tick < last_state && stalled > grace_s) {
    return "did not answer tick " + std::to_string(last_state) + " within " +
           core::FormatNumber(limits.tick_s) + " s (the per-tick limit): a hang?";
  } else if (answered < 0 && stalled > limits.start_s) {
    return "the plan was not taken within " + core::FormatNumber(limits.start_s) + " s";
  } else if (elapsed > limits.task_s) {
    return "took longer than " + core::FormatNumber(limits.task_s) +
           " s of wall time (the per-task limit) at tick " + std::to_string(last_state);
  }
  return "";
}

// The record of a run that ended cleanly: ticks 0..last_state, each with its state; a row without
// the controller's command (or set-point) repeats the row before and counts as missing.
void FillRecord(TickRows& tick_rows, int64_t last_state, bool via_control,
                const core::RobotModel& model, const Task& task, const ReferenceTable& offered,
                TaskRecord& record) {
  const auto n = static_cast<size_t>(model.num_joints());
  std::vector<double>& position = tick_rows.position;
  std::vector<double>& reference = tick_rows.reference;
  std::vector<double>& goal = tick_rows.goal;
  std::vector<double>& effort = tick_rows.effort;
  const std::vector<char>& have_state = tick_rows.have_state;
  const std::vector<char>& have_command = tick_rows.have_command;
  const std::vector<char>& have_setpoint = tick_rows.have_setpoint;
  // The run: ticks 0..last_state, each with its state.
  const auto rows = static_cast<size_t>(last_state + 1);
  record.completed = true;
  for (size_t row = 0; row < rows; ++row) {
    if (have_state[row] == 0) {
      record.completed = false;
      record.failure = "the grader missed the state of tick " + std::to_string(row);
      return;
    }
    const bool command = have_command[row] != 0;
    const bool setpoint = !via_control || have_setpoint[row] != 0;
    if (!command || !setpoint) ++record.missing_rows;
    record.time_s.push_back(static_cast<double>(row) * model.servo_tick_s);
    for (size_t j = 0; j < n; ++j) {
      const size_t at = row * n + j;
      const size_t before = row > 0 ? at - n : at;
      record.position.push_back(position[at]);
      if (via_control && !setpoint && row > 0) {
        reference[at] = reference[before];
        goal[at] = goal[before];
      }
      if (task.track || !via_control) {
        // A track task: every controller is measured against the path and the task's goal (the
        // path ends where it starts, so no joint makes a step); the chip's set-point is kept
        // apart. A process controller: against the set-points it was given.
        const ReferencePoint& given = offered.At(row, j);
        record.reference.push_back(given.position);
        record.goal.push_back(given.goal);
        if (task.track && via_control && setpoint && task.track->path.joint(j).moves()) {
          record.setpoint_deviation =
              std::max(record.setpoint_deviation, std::abs(reference[at] - given.position));
        }
      } else {
        record.reference.push_back(setpoint || row > 0 ? reference[at] : position[at]);
        record.goal.push_back(setpoint || row > 0 ? goal[at] : position[at]);
      }
      if (!command && row > 0) effort[at] = effort[before];
      record.effort.push_back(effort[at]);
    }
  }
  if (rows * model.servo_tick_s + 2 * model.servo_tick_s < task.duration_s) {
    record.completed = false;
    record.failure = "the sim ended after " + std::to_string(rows) + " ticks, before the task's " +
                     core::FormatNumber(task.duration_s) + " s";
  }
}

// One task's run, step by step: what the grader hears on the task's bus (every state, the
// controller's commands, sirupp-control's set-points, by tick), the processes it starts and the
// watch over them until the sim ends or the task is given up.
class TaskRun {
 public:
  TaskRun(const Suite& suite, const core::RobotModel& model, const Task& task,
          const ControllerSpec& controller, const RunOptions& options)
      : suite_(suite),
        model_(model),
        task_(task),
        controller_(controller),
        options_(options),
        n_(static_cast<size_t>(model.num_joints())),
        via_control_(controller.kind != ControllerSpec::Kind::kProcess),
        participant_(via_control_ ? "sirupp-control" : "student"),
        expected_(static_cast<size_t>(std::ceil(task.duration_s / model.servo_tick_s)) + 4),
        rows_(expected_, n_),
        progress_(Clock::now()),
        bus_(RigUrl()),
        driver_(bus_, suite.limits.start_s),
        offered_(0, n_) {
    Listen();
  }

  // What a process controller is given ({reference_csv}) and a track task is measured against.
  // "" or why it could not be made.
  std::string MakeReference() {
    if (via_control_ && !task_.track) return "";
    try {
      offered_ = TaskReference(model_, task_, expected_);
    } catch (const std::exception& error) {
      return std::string("could not make the reference: ") + error.what();
    }
    return "";
  }

  // The task's LCM address (its private port).
  std::string RigUrl() const { return proc::RigUrl(options_.port, kTaskUrlOptions); }

  // The controller first (it must hear the first state), then the sim. "" or why not.
  std::string StartProcesses() {
    std::vector<proc::RigProcess> rig;
    try {
      rig = proc::RigProcesses(TaskRig(suite_, model_, task_, controller_, options_, participant_));
    } catch (const std::exception& error) {
      return std::string("could not describe the task's processes: ") + error.what();
    }
    // Nothing outlives a killed grader, and what a controller starts ends with it.
    for (proc::RigProcess& process : rig) {
      process.spec.death_signal = SIGKILL;
      process.spec.group_ends_with_it = true;
    }
    proc::ProcessSpec sim = rig[0].spec;
    proc::ProcessSpec control = rig[1].spec;
    if (!via_control_) {
      const std::string reference_file = options_.work_dir + "/reference.csv";
      control.argv =
          ExpandCommand(controller_.command, model_, task_, RigUrl(), participant_, reference_file);
      control.log_path = options_.work_dir + "/controller.log";
      const bool wants_reference = std::any_of(
          controller_.command.begin(), controller_.command.end(), [](const std::string& word) {
            return word.find("{reference_csv}") != std::string::npos;
          });
      if (wants_reference) {
        try {
          WriteReferenceCsv(reference_file, model_, offered_);
        } catch (const std::exception& error) {
          return std::string("could not write the reference: ") + error.what();
        }
      }
    }
    start_ = Clock::now();
    try {
      control_.Start(control);  // the controller first: it must hear the first state
      sim_.Start(sim);
    } catch (const std::exception& error) {
      return std::string("could not start the task's processes: ") + error.what();
    }
    progress_ = Clock::now();
    return "";
  }

  // Handles the bus until the sim ends or the task is given up; ends both processes. "" when the
  // sim ran to its end, else why the task ended.
  std::string Watch() {
    bool plan_sent = false;
    bool sim_done = false;
    const double grace_s = via_control_ ? suite_.limits.tick_s + 5 : suite_.limits.tick_s;
    while (failure_.empty()) {
      bus_.Handle(10);
      bus_.HandleAvailable();
      if (via_control_ && !plan_sent && controller_tick_ >= 0) {
        // Waits for the controller's reply; the bus is handled meanwhile (tick 0 is held until
        // the plan is taken).
        plan_sent = true;
        failure_ = driver_.RunPlan(task_.plan_name, task_.plan_text);
        if (!failure_.empty()) break;
      }
      if (last_state_ == 0 && answered_ < 0 && MayAnswer(0)) Answer(0);
      if (via_control_ && !driver_.Fault().empty()) {
        failure_ = "fault: " + driver_.Fault();
        break;
      }
      if (!sim_.Running()) {
        sim_done = true;
        // Messages still queued belong to the run.
        while (bus_.Handle(50) > 0) {
        }
        if (!sim_.EndedCleanly()) {
          failure_ = "sirupp-sim ended (" + sim_.HowEnded() + "): " + sim_.LogTail();
        }
        break;
      }
      if (!control_.Running()) {
        const std::string who = via_control_ ? "sirupp-control" : "the controller process";
        failure_ = who + " ended (" + control_.HowEnded() + ") at tick " +
                   std::to_string(std::max<int64_t>(last_state_, 0)) + ": " + control_.LogTail(2);
        break;
      }
      failure_ = StallFailure(suite_.limits, controller_tick_, last_state_, answered_,
                              Since(progress_), grace_s, Since(start_));
    }
    sim_.Stop(1.0);
    control_.Stop(1.0);
    if (failure_.empty() && !sim_done) failure_ = "stopped before the sim ended";
    return failure_;
  }

  void Fill(TaskRecord& record) {
    FillRecord(rows_, last_state_, via_control_, model_, task_, offered_, record);
  }

 private:
  // The grader's answer to `tick` as the sim's second participant.
  void Answer(int64_t tick) {
    bus_.Publish(channels_.sim_arm_command, GraderAnswer(model_, task_, tick));
    answered_ = std::max(answered_, tick);
  }
  // Tick 0 is held until sirupp-control has taken the plan.
  bool MayAnswer(int64_t tick) const { return tick > 0 || !via_control_ || driver_.PlanAccepted(); }
  bool InRange(int64_t tick) const { return tick >= 0 && static_cast<size_t>(tick) < expected_; }

  void Listen() {
    bus_.Subscribe<sirupp::arm_state_t>(
        channels_.sim_arm_state,
        [this](const sirupp::arm_state_t& m, const core::ReceiveInfo&) { OnState(m); });
    bus_.Subscribe<sirupp::arm_command_t>(
        channels_.sim_arm_command,
        [this](const sirupp::arm_command_t& m, const core::ReceiveInfo&) { OnCommand(m); });
    bus_.Subscribe<sirupp::servo_setpoint_t>(
        channels_.arm_setpoint,
        [this](const sirupp::servo_setpoint_t& m, const core::ReceiveInfo&) { OnSetpoint(m); });
  }

  void OnState(const sirupp::arm_state_t& m) {
    if (!InRange(m.tick) || m.num_joints != model_.num_joints()) return;
    const auto row = static_cast<size_t>(m.tick);
    if (m.tick > last_state_) {
      last_state_ = m.tick;
      progress_ = Clock::now();
      rows_.have_state[row] = 1;
      std::copy(m.position.begin(), m.position.end(),
                rows_.position.begin() + static_cast<long>(row * n_));
    }
    // A state sent again (the sim's lockstep timeout) is answered again.
    if (m.tick == last_state_ && MayAnswer(m.tick)) Answer(m.tick);
  }

  void OnCommand(const sirupp::arm_command_t& m) {
    if (m.sender != participant_ || !InRange(m.tick)) return;
    const auto row = static_cast<size_t>(m.tick);
    controller_tick_ = std::max(controller_tick_, m.tick);
    if (rows_.have_command[row] != 0) return;
    rows_.have_command[row] = 1;
    if (m.mode != sirupp::arm_command_t::MODE_EFFORT || m.num_joints != model_.num_joints()) return;
    for (size_t j = 0; j < n_; ++j) {
      const double e = m.effort[j];
      if (!std::isfinite(e) && failure_.empty()) {
        failure_ = "returned effort " + core::FormatNumber(e) + " for joint " +
                   std::to_string(j + 1) + " at tick " + std::to_string(m.tick) +
                   " (allowed: finite values)";
      }
      const double limit = model_.joints[j].effort_max;
      rows_.effort[row * n_ + j] = std::isfinite(e) ? std::clamp(e, -limit, limit) : 0.0;
    }
  }

  void OnSetpoint(const sirupp::servo_setpoint_t& m) {
    if (!InRange(m.tick) || m.num_joints != model_.num_joints()) return;
    const auto row = static_cast<size_t>(m.tick);
    if (rows_.have_setpoint[row] != 0) return;
    rows_.have_setpoint[row] = 1;
    std::copy(m.position.begin(), m.position.end(),
              rows_.reference.begin() + static_cast<long>(row * n_));
    std::copy(m.goal.begin(), m.goal.end(), rows_.goal.begin() + static_cast<long>(row * n_));
  }

  const Suite& suite_;
  const core::RobotModel& model_;
  const Task& task_;
  const ControllerSpec& controller_;
  const RunOptions& options_;
  const size_t n_;
  const bool via_control_;
  const std::string participant_;
  const size_t expected_;         // rows: the task's ticks and a few more
  TickRows rows_;                 // filled as the messages come
  int64_t last_state_ = -1;       // newest tick whose state arrived
  int64_t answered_ = -1;         // newest tick the grader answered
  int64_t controller_tick_ = -1;  // newest tick the controller answered
  std::string failure_;
  Clock::time_point progress_;  // when the newest state came
  Clock::time_point start_;     // when the processes started
  core::Bus bus_;
  PlanDriver driver_;
  const core::Channels channels_;
  ReferenceTable offered_;
  proc::Child control_, sim_;
};

}  // namespace

TaskRecord RunTask(const Suite& suite, const core::RobotModel& model, const Task& task,
                   const ControllerSpec& controller, const RunOptions& options) {
  TaskRecord record;
  record.num_joints = model.num_joints();
  record.tick_s = model.servo_tick_s;
  record.has_reference = true;  // every controller is given one (grade/reference.hpp)
  record.track = task.track.has_value();
  TaskRun run(suite, model, task, controller, options);
  std::string failure = run.MakeReference();
  if (failure.empty()) failure = run.StartProcesses();
  if (failure.empty()) failure = run.Watch();
  if (!failure.empty()) {
    record.failure = failure;
    return record;
  }
  run.Fill(record);
  return record;
}

}  // namespace sirupp::grade
