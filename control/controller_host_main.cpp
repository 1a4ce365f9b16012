// sirupp-controller-host: runs one student controller library for sirupp-control, in a process of
// its own, so that a crash in the library cannot take sirupp-control down
// (control/isolated_law.hpp). Started by sirupp-control for `--controller LIB.so`, never by hand:
//
//   sirupp-controller-host LIBRARY ARGS     with descriptor 3: the call socket, 4: the shared block
//
// It ends when sirupp-control closes the socket or dies (parent-death signal SIGKILL); SIGINT and
// SIGTERM, which a terminal's Ctrl-C and the launcher send to the whole process group, are
// ignored, so that only sirupp-control decides when its library stops.

#include <string>

#include "control/isolated_law.hpp"

// In sanitizer builds: a crash in the library must end the host by its signal, which
// sirupp-control names, not by the sanitizer's report and exit code 1.
extern "C" const char* __asan_default_options();
extern "C" const char* __asan_default_options() {
  return "handle_segv=0:handle_sigbus=0:handle_sigfpe=0:handle_abort=0:handle_sigill=0";
}

int main(int argc, char** argv) {
  if (!sirupp::control::PrepareHostProcess(argc, "sirupp-controller-host", "LIBRARY")) return 2;
  return sirupp::control::RunControllerHost(3, 4, argv[1], argv[2]);
}
