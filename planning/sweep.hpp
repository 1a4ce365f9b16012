#pragma once
// Sweeping a motion given as a stream of joint states (e.g. the set-points of a plan, from
// control::TracePlanSetpoints): each state is checked once some joint has moved `step_rad` since
// the last checked state, and whenever the caller forces it (the end of a move), so no joint moves
// more than step_rad between two checks. Static objects and self-contacts are errors; free objects
// are notes (each one once: after the arm touches it, it may have moved, which the model cannot
// know). What `sirupp plan check --env` and the panel's plan view use.

#include <optional>
#include <string>
#include <vector>

#include "planning/collision_model.hpp"

namespace sirupp::planning {

struct SweepFinding {
  Contact contact;
  JointVector state;
  double time_s = 0;
  int step = -1;  // the caller's step index given with the state
};

class SetpointSweep {
 public:
  // step_rad > 0; throws std::invalid_argument otherwise.
  SetpointSweep(CollisionModel& model, double step_rad);

  // Feeds the next state. Returns the first error (a static object or self) found at this state;
  // free objects touched here are added to free_touches(). After an error the sweep keeps
  // answering it (the caller stops).
  std::optional<SweepFinding> Feed(const JointVector& state, double time_s, int step,
                                   bool force = false);

  const std::vector<SweepFinding>& free_touches() const { return free_touches_; }
  int states_checked() const { return checked_; }

 private:
  CollisionModel& model_;
  double step_;
  JointVector last_;
  std::optional<SweepFinding> error_;
  std::vector<SweepFinding> free_touches_;
  std::vector<bool> free_reported_;
  int checked_ = 0;
};

}  // namespace sirupp::planning
