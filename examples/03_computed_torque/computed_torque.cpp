// Example 3: computed-torque control, as a controller library for sirupp-control.
//
//   a      = qdd_set + Kp (q_set - q) + Kd (qd_set - qd)
//   effort = M(q) a + C(q, qd) qd + G(q)
//
// The host hands over M(q) (mass_matrix, row-major) and C(q, qd) qd + G(q) (bias_effort) at the
// measured state every tick. If the model is right, the arm's dynamics cancel and every joint's
// error obeys e'' + Kd e' + Kp e = 0, the same for the heavy shoulder and the light wrist: one
// bandwidth wn (rad/s) and damping ratio zeta set Kp = wn^2 and Kd = 2 zeta wn for all joints.
// The set-point acceleration qdd_set feeds the profile forward, so the arm follows a trapezoidal
// move with almost no lag. Joint friction is not in the model and acts as a disturbance.
//
// Arguments (--controller-args): "wn=100 zeta=1" (the defaults).
// Build by hand against the header in the project's include/ folder (SIRUPP: the project's folder):
//   g++ -std=c++17 -O2 -shared -fPIC -I $SIRUPP/include computed_torque.cpp -o computed_torque.so

#include <sirupp/controller.h>

#include <string>
#include <vector>

namespace {

class ComputedTorque : public sirupp::Controller {
 public:
  explicit ComputedTorque(const std::string& args) {
    sirupp::Params params(args);
    wn_ = params.Positive("wn", 100);
    zeta_ = params.Positive("zeta", 1);
    params.Finish();
  }

  void Reset(const sirupp::ArmInfo& arm, const sirupp::State& /*state*/) override {
    acceleration_.assign(static_cast<size_t>(arm.num_joints), 0.0);
  }

  void Update(const sirupp::State& state, double* effort) override {
    const int n = state.num_joints;
    const double kp = wn_ * wn_;
    const double kd = 2 * zeta_ * wn_;
    for (int j = 0; j < n; ++j) {
      acceleration_[static_cast<size_t>(j)] =
          state.setpoint_acceleration[j] + kp * (state.setpoint_position[j] - state.position[j]) +
          kd * (state.setpoint_velocity[j] - state.velocity[j]);
    }
    for (int row = 0; row < n; ++row) {
      double sum = state.bias_effort[row];
      for (int col = 0; col < n; ++col) {
        sum += state.mass_matrix[row * n + col] * acceleration_[static_cast<size_t>(col)];
      }
      effort[row] = sum;
    }
  }

 private:
  double wn_;
  double zeta_;
  std::vector<double> acceleration_;  // the commanded joint acceleration a
};

}  // namespace

SIRUPP_EXPORT_CONTROLLER(ComputedTorque)
