// A controller that returns NaN for joint 2 when its trigger fires (misbehave.hpp; default: at
// tick 200): sirupp-control must hold the arm and report the fault naming the controller.
#include <limits>

#include "misbehave.hpp"

namespace {

class NanEffort : public test_controllers::Tracking {
 public:
  explicit NanEffort(const std::string& args) : trigger_(args) {}
  void Update(const sirupp::State& state, double* effort) override {
    Track(state, effort);
    if (trigger_.Now(state)) effort[1] = std::numeric_limits<double>::quiet_NaN();
  }

 private:
  test_controllers::Trigger trigger_;
};

}  // namespace

SIRUPP_EXPORT_CONTROLLER(NanEffort)
