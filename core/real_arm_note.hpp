#pragma once
// How a controller status's last_error begins when it is about the real arm's half of the run,
// not a fault of the virtual arm: "real arm: sirupp-hardware lost at t = 12.3 s ...".
// sirupp-control writes it (control_node.hpp); a plan's outcome (client/client.hpp), `sirupp
// status`, the panel and a data file's end line (logger) name it.

namespace sirupp::core {

inline constexpr const char* kRealArmLost = "real arm: ";

}  // namespace sirupp::core
