// A controller that writes through a null pointer (SIGSEGV) when its trigger fires
// (misbehave.hpp): sirupp-control must survive, brake the arm and name the crash.
#include "misbehave.hpp"

namespace {

void Crash() {
  // volatile: the compiler can neither see that it is null nor drop the store.
  volatile int* volatile pointer = nullptr;
  *pointer = 1;
}

class Segfault : public test_controllers::Tracking {
 public:
  explicit Segfault(const std::string& args) : trigger_(args) {
    if (trigger_.in_constructor()) Crash();
  }
  void Update(const sirupp::State& state, double* effort) override {
    if (trigger_.Now(state)) Crash();
    Track(state, effort);
  }

 private:
  test_controllers::Trigger trigger_;
};

}  // namespace

SIRUPP_EXPORT_CONTROLLER(Segfault)
