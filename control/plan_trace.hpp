#pragma once
// The set-points a plan makes the virtual PIC-SERVOs send, without an arm or a bus: the plan's
// steps run as the sequencer runs them (every move line until a wait starts in the same tick;
// `wait done` until every joint's move is done; `wait T` for T of servo ticks) on a ServoBank of
// the model whose measured positions are its own set-points (an arm that tracks exactly). What
// `sirupp plan check --env` sweeps for collisions (planning/sweep.hpp).

#include <cstdint>
#include <functional>
#include <vector>

#include "control/plan.hpp"
#include "core/robot_model.hpp"

namespace sirupp::control {

// Called after every servo tick with the index of the plan step whose move is the latest started
// (-1 before the first), the set-points (SI, one per joint) and the time since the plan started
// (s). Returns false to stop the trace.
using SetpointVisitor =
    std::function<bool(int step, const std::vector<double>& setpoint, double time_s)>;

struct TraceSummary {
  int64_t ticks = 0;
  double duration_s = 0;
  bool stopped = false;   // the visitor stopped it
  bool finished = false;  // every step ran and every move is done (false: max_ticks reached)
};

// Runs `plan` from `start` (SI, one per joint). max_ticks bounds the trace (default: one hour of
// servo ticks). Throws std::invalid_argument for a start of the wrong size.
TraceSummary TracePlanSetpoints(const core::RobotModel& model, const Plan& plan,
                                const std::vector<double>& start, const SetpointVisitor& visit,
                                int64_t max_ticks = 0);

}  // namespace sirupp::control
