#pragma once
// The seam where a student's controller replaces the PIC-SERVO PID filter inside sirupp-control.
// The sequencer and the trapezoidal profile generators keep running (so moves, plans, ARM_SETPOINT
// and CONTROLLER_STATUS work unchanged); each servo tick the law gets the measured state and the
// profiled set-points and returns the joint efforts sent to the sim instead of the PID's.
//
// Implementations: IsolatedEffortLaw (a shared library built against include/sirupp/controller.h,
// run in a child process: `sirupp-control --controller LIB.so`) and PluginEffortLaw (the same
// library loaded into this process: `--controller-in-process`, tests, benchmarks). A failure of
// the law is thrown from Reset or Update; ControlNode turns it into its latched fault. A
// controller in its own process needs none of this: it answers SIM_ARM_STATE itself
// (docs/student-controllers.md).

#include <cstdint>
#include <string>
#include <vector>

#include "core/arm_state.hpp"

namespace sirupp::control {

struct ControlInput {
  double time_s = 0;  // sim time of the state
  int64_t tick = 0;
  const core::ArmState* state = nullptr;  // measured positions, velocities, applied efforts
  // The profile generators' set-points this tick, SI (rad, rad/s, rad/s^2 or m, m/s, m/s^2).
  std::vector<double> setpoint_position;
  std::vector<double> setpoint_velocity;
  std::vector<double> setpoint_acceleration;
  std::vector<double> goal;  // where each joint's present move ends
};

class EffortLaw {
 public:
  virtual ~EffortLaw() = default;
  virtual const std::string& name() const = 0;
  // Called once, on the first arm state, before the first Update.
  virtual void Reset(const ControlInput& input) = 0;
  // Fills `effort` (num_joints entries, N*m or N). Non-finite values are refused by the caller:
  // the arm is held and the fault named in CONTROLLER_STATUS.
  virtual void Update(const ControlInput& input, std::vector<double>& effort) = 0;
};

}  // namespace sirupp::control
