// A controller that holds the arm with its gravity efforts and then, from the tick given as its
// argument on (default 200), returns NaN for joint 2, for tests/test_plugin_controller.cpp:
// sirupp-control must hold the arm and report the fault naming the controller.
#include <sirupp/controller.h>

#include <limits>
#include <string>

namespace {

class NanEffort : public sirupp::Controller {
 public:
  explicit NanEffort(const std::string& args)
      : bad_from_tick_(args.empty() ? 200 : std::stol(args)) {}

  void Reset(const sirupp::ArmInfo& /*arm*/, const sirupp::State& /*state*/) override {}

  void Update(const sirupp::State& state, double* effort) override {
    for (int j = 0; j < state.num_joints; ++j) effort[j] = state.gravity_effort[j];
    if (state.tick >= bad_from_tick_) effort[1] = std::numeric_limits<double>::quiet_NaN();
  }

 private:
  long bad_from_tick_;
};

}  // namespace

SIRUPP_EXPORT_CONTROLLER(NanEffort)
