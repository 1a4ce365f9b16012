// Example 2: PD control with gravity compensation, as a controller library for sirupp-control.
//
//   effort_j = G_j(q) + Kp_j (q_set_j - q_j) + Kd_j (qd_set_j - qd_j)
//
// G(q) comes from the host each tick; q_set and qd_set are the profile generators' set-points, so
// `sirupp move joints ...` drives this controller like the PID it replaces. With gravity
// cancelled, each joint behaves like a mass on a spring and damper. One stiffness for every joint
// would be far too soft for the heavy shoulder or far too stiff for the light wrist, so the gains
// are chosen per joint from a single bandwidth wn (rad/s) and damping ratio zeta, using the joint's
// own inertia M_jj at the start pose (held fixed afterwards):
//
//   Kp_j = M_jj wn^2        Kd_j = 2 zeta wn M_jj
//
// Static friction is not compensated: a joint stops where the spring effort Kp_j * error falls
// below its break-away effort, so a stiffer wn leaves a smaller final error.
//
// Arguments (--controller-args): "wn=100 zeta=1" (the defaults).
// Build by hand against the header in the project's include/ folder (SIRUPP: the project's folder):
//   g++ -std=c++17 -O2 -shared -fPIC -I $SIRUPP/include pd_gravity.cpp -o pd_gravity.so

#include <sirupp/controller.h>

#include <string>
#include <vector>

namespace {

class PdGravity : public sirupp::Controller {
 public:
  explicit PdGravity(const std::string& args) {
    sirupp::Params params(args);
    wn_ = params.Positive("wn", 100);
    zeta_ = params.Positive("zeta", 1);
    params.Finish();
  }

  void Reset(const sirupp::ArmInfo& arm, const sirupp::State& state) override {
    const int n = arm.num_joints;
    kp_.assign(static_cast<size_t>(n), 0.0);
    kd_.assign(static_cast<size_t>(n), 0.0);
    for (int j = 0; j < n; ++j) {
      const double inertia = state.mass_matrix[j * n + j];  // M_jj, row-major
      kp_[static_cast<size_t>(j)] = inertia * wn_ * wn_;
      kd_[static_cast<size_t>(j)] = 2 * zeta_ * wn_ * inertia;
    }
  }

  void Update(const sirupp::State& state, double* effort) override {
    for (int j = 0; j < state.num_joints; ++j) {
      const size_t i = static_cast<size_t>(j);
      effort[j] = state.gravity_effort[j] +
                  kp_[i] * (state.setpoint_position[j] - state.position[j]) +
                  kd_[i] * (state.setpoint_velocity[j] - state.velocity[j]);
    }
  }

 private:
  double wn_;
  double zeta_;
  std::vector<double> kp_, kd_;
};

}  // namespace

SIRUPP_EXPORT_CONTROLLER(PdGravity)
