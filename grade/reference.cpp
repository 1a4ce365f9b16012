#include "grade/reference.hpp"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <stdexcept>

#include "control/sequencer.hpp"
#include "core/errors.hpp"
#include "core/units.hpp"

namespace sirupp::grade {
namespace {

// Degrees (mm for a prismatic joint) per SI unit.
double PerSiUnit(const core::RobotModel& model, size_t joint) {
  return model.joints[joint].type == core::JointType::kRevolute ? 180 / kPi : 1000;
}

// 9 significant digits.
std::string NineDigits(double value) {
  char buffer[40];
  std::snprintf(buffer, sizeof buffer, "%.9g", value);
  return buffer;
}

}  // namespace

ReferenceTable ChipProfile(const core::RobotModel& model, const Task& task, size_t ticks) {
  const auto n = static_cast<size_t>(model.num_joints());
  ReferenceTable table(ticks, n);
  control::Sequencer sequencer(model, control::SequencerOptions{});
  core::ArmState state;
  state.position = task.start;
  state.velocity.assign(n, 0.0);
  state.effort.assign(n, 0.0);
  state.flags.assign(n, 0);
  for (size_t tick = 0; tick < ticks; ++tick) {
    state.tick = static_cast<int64_t>(tick);
    // As sirupp-sim stamps its states (sim/arm_world.cpp).
    state.utime =
        static_cast<int64_t>(std::llround(static_cast<double>(tick) * model.servo_tick_s * 1e6));
    sequencer.OnState(state);
    sequencer.TakeOutputs();  // statuses and log lines: not needed here
    if (!sequencer.fault().empty()) {
      throw std::runtime_error("the plan faulted on an arm following it at tick " +
                               std::to_string(tick) + ": " + sequencer.fault());
    }
    const control::ServoBank& bank = sequencer.servos();
    for (size_t j = 0; j < n; ++j) {
      const int joint = static_cast<int>(j);
      ReferencePoint& point = table.At(tick, j);
      point.position = bank.SetpointPosition(joint);
      point.velocity = bank.SetpointVelocity(joint);
      point.acceleration = bank.SetpointAcceleration(joint);
      point.goal = bank.Goal(joint);
      // The arm is where its set-point was at the end of this tick.
      state.position[j] = point.position;
      state.velocity[j] = point.velocity;
    }
    if (tick == 0) {
      // The grader hands sirupp-control the plan once it answered tick 0 (RunTask).
      control::PlanCommand plan;
      plan.source = "sirupp grade";
      plan.action = control::PlanAction::kRun;
      plan.name = task.plan_name;
      plan.text = task.plan_text;
      try {
        sequencer.Plan(plan);
      } catch (const std::exception& error) {
        throw std::runtime_error(std::string("the plan was refused: ") + error.what());
      }
    }
  }
  return table;
}

ReferenceTable TaskReference(const core::RobotModel& model, const Task& task, size_t ticks) {
  if (!task.track) return ChipProfile(model, task, ticks);
  const auto n = static_cast<size_t>(model.num_joints());
  ReferenceTable table(ticks, n);
  for (size_t tick = 0; tick < ticks; ++tick) {
    for (size_t j = 0; j < n; ++j) {
      ReferencePoint& point = table.At(tick, j);
      point.goal = task.goal[j];
      const JointPath::Sample sample =
          task.track->path.joint(j).At(static_cast<double>(tick) * model.servo_tick_s);
      point.position = sample.position;
      point.velocity = sample.velocity;
      point.acceleration = sample.acceleration;
    }
  }
  return table;
}

void WriteReferenceCsv(const std::string& file, const core::RobotModel& model,
                       const ReferenceTable& table) {
  std::ofstream out(file);
  if (!out) throw core::ConfigError({file, 0, 0}, "", "cannot write the reference file");
  const size_t n = table.num_joints();
  out << "tick,time_s";
  for (size_t j = 0; j < n; ++j) {
    const std::string unit = model.joints[j].type == core::JointType::kRevolute ? "deg" : "mm";
    const std::string number = std::to_string(j + 1);
    out << ",q" << number << "_" << unit << ",v" << number << "_" << unit << "_s,a" << number << "_"
        << unit << "_s2";
  }
  out << "\n";
  for (size_t tick = 0; tick < table.ticks(); ++tick) {
    out << tick << "," << core::FormatNumber(static_cast<double>(tick) * model.servo_tick_s);
    for (size_t j = 0; j < n; ++j) {
      const double scale = PerSiUnit(model, j);
      const ReferencePoint& point = table.At(tick, j);
      out << "," << NineDigits(point.position * scale) << "," << NineDigits(point.velocity * scale)
          << "," << NineDigits(point.acceleration * scale);
    }
    out << "\n";
  }
  if (!out.flush()) throw core::ConfigError({file, 0, 0}, "", "cannot write the reference file");
}

}  // namespace sirupp::grade
