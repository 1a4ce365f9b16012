// Allocates without end in its constructor (16 MB blocks, each written so that it is really
// used) and reports how much it got. The sandbox's memory limit (RLIMIT_AS; in sanitizer builds
// ASan's hard_rss_limit_mb) stops it.
#include <cstdlib>
#include <vector>

#include "hostile.hpp"

namespace {

class Allocate : public hostile::Hostile {
 public:
  explicit Allocate(const std::string& /*args*/) {
    constexpr size_t kBlock = 16u << 20;
    for (size_t megabytes = 0;; megabytes += 16) {
      void* block = std::malloc(kBlock);
      if (block == nullptr) {
        throw std::runtime_error("allocation failed after " + std::to_string(megabytes) + " MB");
      }
      std::memset(block, 1, kBlock);
      blocks_.push_back(block);
    }
  }

 protected:
  void Act() override {}

 private:
  std::vector<void*> blocks_;
};

}  // namespace

SIRUPP_EXPORT_CONTROLLER(Allocate)
