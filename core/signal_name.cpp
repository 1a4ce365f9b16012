#include "core/signal_name.hpp"

#include <string.h>  // sigabbrev_np, sigdescr_np (glibc 2.32+)

namespace sirupp::core {

std::string SignalName(int signal_number) {
  const char* abbreviation = sigabbrev_np(signal_number);
  return abbreviation != nullptr ? std::string("SIG") + abbreviation
                                 : "signal " + std::to_string(signal_number);
}

std::string SignalDescription(int signal_number) {
  std::string name = SignalName(signal_number);
  const char* description = sigdescr_np(signal_number);
  if (description != nullptr) name += std::string(" (") + description + ")";
  return name;
}

}  // namespace sirupp::core
