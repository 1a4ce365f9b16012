#pragma once
// Names of POSIX signals for the lines people read when a child process ended by one (the
// grader's task processes, the launcher's supervised processes, a controller's host process).

#include <string>

namespace sirupp::core {

// "SIGSEGV"; "signal 99" for a number the C library does not name.
std::string SignalName(int signal_number);
// "SIGSEGV (Segmentation fault)": the name and the C library's description when it has one.
std::string SignalDescription(int signal_number);

}  // namespace sirupp::core
