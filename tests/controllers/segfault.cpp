// A controller that writes through a null pointer (SIGSEGV) when its trigger fires
// (misbehave.hpp): sirupp-control must survive, brake the arm and name the crash.
#include "misbehave.hpp"

namespace {

// Not instrumented by UBSan in sanitizer builds: its null check would report the store and exit,
// where the point is the real SIGSEGV that sirupp-control must name.
__attribute__((no_sanitize("undefined"))) void Crash() {
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
