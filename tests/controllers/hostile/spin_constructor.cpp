// Spins forever in its constructor. The load limit (IsolationOptions::load_limit_s) kills its
// host; the sandbox's CPU limit (RLIMIT_CPU: SIGXCPU) would too.
#include "hostile.hpp"

namespace {

class SpinConstructor : public hostile::Hostile {
 public:
  explicit SpinConstructor(const std::string& /*args*/) {
    for (volatile unsigned long spins = 0;; spins = spins + 1) {
    }
  }

 protected:
  void Act() override {}
};

}  // namespace

SIRUPP_EXPORT_CONTROLLER(SpinConstructor)
