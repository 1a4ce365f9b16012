// What the misbehaving test controllers share (segfault.cpp, hang.cpp, spins.cpp, aborts.cpp,
// throws.cpp, nan_effort.cpp): a well-behaved law until a trigger given as the controller's
// argument, then each library's own misbehaviour. Built against include/sirupp/controller.h
// alone, like a student's library.
//
// Arguments (--controller-args):
//   ""  or "N"    misbehave in the Update of tick N (default 200), that tick only
//   "goal=RAD"    misbehave in every Update while joint 1's goal is above RAD (a move past it)
//   "constructor" misbehave in the constructor (while sirupp-control loads the library)
#pragma once

#include <sirupp/controller.h>

#include <stdexcept>
#include <string>

namespace test_controllers {

class Trigger {
 public:
  explicit Trigger(const std::string& args) {
    if (args == "constructor") {
      in_constructor_ = true;
    } else if (args.rfind("goal=", 0) == 0) {
      by_goal_ = true;
      goal_above_ = std::stod(args.substr(5));
    } else if (!args.empty()) {
      tick_ = std::stol(args);
    }
  }
  bool in_constructor() const { return in_constructor_; }
  bool Now(const sirupp::State& state) const {
    return by_goal_ ? state.goal[0] > goal_above_ : state.tick == tick_;
  }

 private:
  bool in_constructor_ = false;
  bool by_goal_ = false;
  double goal_above_ = 0;
  long tick_ = 200;
};

// The well-behaved part: PD on the profile set-points with gravity compensation, gains from each
// joint's inertia (bandwidth 100 rad/s, critically damped), as examples/02_pd_gravity. Refuses an
// Update before Reset (the host must call Reset first, also after a restart).
class Tracking : public sirupp::Controller {
 public:
  void Reset(const sirupp::ArmInfo& /*arm*/, const sirupp::State& /*state*/) override {
    reset_ = true;
  }

 protected:
  void Track(const sirupp::State& s, double* effort) const {
    if (!reset_) throw std::logic_error("Update before Reset");
    const int n = s.num_joints;
    for (int j = 0; j < n; ++j) {
      const double inertia = s.mass_matrix[j * n + j];
      effort[j] = s.gravity_effort[j] + inertia * (1e4 * (s.setpoint_position[j] - s.position[j]) +
                                                   200 * (s.setpoint_velocity[j] - s.velocity[j]));
    }
  }

 private:
  bool reset_ = false;
};

}  // namespace test_controllers
