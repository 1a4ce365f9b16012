// A controller that computes forever (an endless loop, no blocking call) when its trigger fires
// (misbehave.hpp): sirupp-control must tell it from a host waiting for a CPU, end it after its
// call limit and one limit more of CPU time, brake the arm and name the hang.
#include <atomic>

#include "misbehave.hpp"

namespace {

[[noreturn]] void SpinForever() {
  std::atomic<unsigned long> turns{0};
  for (;;) turns.fetch_add(1, std::memory_order_relaxed);
}

class Spins : public test_controllers::Tracking {
 public:
  explicit Spins(const std::string& args) : trigger_(args) {}
  void Update(const sirupp::State& state, double* effort) override {
    if (trigger_.Now(state)) SpinForever();
    Track(state, effort);
  }

 private:
  test_controllers::Trigger trigger_;
};

}  // namespace

SIRUPP_EXPORT_CONTROLLER(Spins)
