// Forks without end: every child forks on too (each named by the args, at most 15 characters,
// default sirupp-forkbomb, so a test can look for survivors); the first process reports how many
// forks it got before the kernel said no. The
// sandbox's process limit (RLIMIT_NPROC in its own user namespace) stops it; its pid namespace
// ends every child with the host.
#include <sys/prctl.h>
#include <unistd.h>

#include "hostile.hpp"

namespace {

[[noreturn]] void ForkForever(const std::string& name) {
  ::prctl(PR_SET_NAME, name.c_str());
  for (;;) {
    if (::fork() < 0) ::usleep(1000);
  }
}

class ForkBomb : public hostile::Hostile {
 public:
  explicit ForkBomb(const std::string& args) : name_(args.empty() ? "sirupp-forkbomb" : args) {}

 protected:
  void Act() override {
    for (long forks = 0;; ++forks) {
      const pid_t pid = ::fork();
      if (pid == 0) ForkForever(name_);
      if (pid < 0) {
        throw std::runtime_error("fork failed after " + std::to_string(forks) +
                                 " forks: " + hostile::Errno());
      }
    }
  }

 private:
  std::string name_;
};

}  // namespace

SIRUPP_EXPORT_CONTROLLER(ForkBomb)
