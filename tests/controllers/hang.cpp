// A controller that never returns (sleeps forever) when its trigger fires (misbehave.hpp):
// sirupp-control must end it after its call limit, brake the arm and name the hang.
#include <chrono>
#include <thread>

#include "misbehave.hpp"

namespace {

[[noreturn]] void SleepForever() {
  for (;;) std::this_thread::sleep_for(std::chrono::seconds(1));
}

class Hang : public test_controllers::Tracking {
 public:
  explicit Hang(const std::string& args) : trigger_(args) {
    if (trigger_.in_constructor()) SleepForever();
  }
  void Update(const sirupp::State& state, double* effort) override {
    if (trigger_.Now(state)) SleepForever();
    Track(state, effort);
  }

 private:
  test_controllers::Trigger trigger_;
};

}  // namespace

SIRUPP_EXPORT_CONTROLLER(Hang)
