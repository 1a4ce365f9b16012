#include "control/plan_trace.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

#include "control/servo_bank.hpp"

namespace sirupp::control {

TraceSummary TracePlanSetpoints(const core::RobotModel& model, const Plan& plan,
                                const std::vector<double>& start, const SetpointVisitor& visit,
                                int64_t max_ticks) {
  const int n = model.num_joints();
  if (static_cast<int>(start.size()) != n) {
    throw std::invalid_argument("plan trace: start has " + std::to_string(start.size()) +
                                " joint values; model " + model.name + " has " + std::to_string(n));
  }
  const double tick_s = model.servo_tick_s;
  if (max_ticks <= 0) max_ticks = static_cast<int64_t>(3600 / tick_s);
  ServoBank bank(model);
  bank.ServoOn(start);
  std::vector<double> setpoint = start;
  TraceSummary summary;
  int step = 0;
  int latest_move = -1;
  int64_t wait_until = -1;
  const auto steps = static_cast<int>(plan.steps.size());
  for (int64_t tick = 0; tick < max_ticks; ++tick) {
    // The plan advances at the start of a tick, as the sequencer does on each arm state.
    while (step < steps) {
      const PlanStep& s = plan.steps[static_cast<size_t>(step)];
      if (s.kind == PlanStep::Kind::kWaitDone) {
        if (!bank.AllDone()) break;
      } else if (s.kind == PlanStep::Kind::kWaitTime) {
        if (wait_until < 0) wait_until = tick + std::llround(s.wait_s / tick_s);
        if (tick < wait_until) break;
        wait_until = -1;
      } else {
        bank.Load(s.moves);
        latest_move = step;
      }
      ++step;
    }
    if (step >= steps && bank.AllDone()) {
      summary.finished = true;
      break;
    }
    bank.Tick(setpoint);
    for (int j = 0; j < n; ++j) setpoint[static_cast<size_t>(j)] = bank.SetpointPosition(j);
    summary.ticks = tick + 1;
    summary.duration_s = static_cast<double>(summary.ticks) * tick_s;
    if (!visit(latest_move, setpoint, summary.duration_s)) {
      summary.stopped = true;
      break;
    }
  }
  return summary;
}

}  // namespace sirupp::control
