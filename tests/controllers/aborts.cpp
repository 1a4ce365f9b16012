// A controller that calls std::abort() (SIGABRT, as a failed assert does) when its trigger fires
// (misbehave.hpp): sirupp-control must survive, brake the arm and name the abort.
#include <cstdlib>

#include "misbehave.hpp"

namespace {

class Aborts : public test_controllers::Tracking {
 public:
  explicit Aborts(const std::string& args) : trigger_(args) {
    if (trigger_.in_constructor()) std::abort();
  }
  void Update(const sirupp::State& state, double* effort) override {
    if (trigger_.Now(state)) std::abort();
    Track(state, effort);
  }

 private:
  test_controllers::Trigger trigger_;
};

}  // namespace

SIRUPP_EXPORT_CONTROLLER(Aborts)
