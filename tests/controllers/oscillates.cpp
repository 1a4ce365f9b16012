// A test controller for `sirupp grade` that never settles: a stiff spring towards the set-point
// with negative damping, so every joint that is disturbed rings ever larger until its effort
// limit holds it in a limit cycle. Built against include/sirupp/controller.h alone.
#include <sirupp/controller.h>

class Oscillates : public sirupp::Controller {
 public:
  explicit Oscillates(const std::string& /*args*/) {}
  void Reset(const sirupp::ArmInfo& /*arm*/, const sirupp::State& /*state*/) override {}
  void Update(const sirupp::State& s, double* effort) override {
    const int n = s.num_joints;
    for (int j = 0; j < n; ++j) {
      const double inertia = s.mass_matrix[j * n + j];
      effort[j] = s.gravity_effort[j] +
                  inertia * (2500 * (s.setpoint_position[j] - s.position[j]) + 20 * s.velocity[j]);
    }
  }
};

SIRUPP_EXPORT_CONTROLLER(Oscillates)
