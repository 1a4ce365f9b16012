// sirupp-controller-host: runs one student controller library for sirupp-control, in a process of
// its own, so that a crash in the library cannot take sirupp-control down
// (control/isolated_law.hpp). Started by sirupp-control for `--controller LIB.so`, never by hand:
//
//   sirupp-controller-host LIBRARY ARGS     with descriptor 3: the call socket, 4: the shared block
//
// It ends when sirupp-control closes the socket or dies (parent-death signal SIGKILL); SIGINT and
// SIGTERM, which a terminal's Ctrl-C and the launcher send to the whole process group, are
// ignored, so that only sirupp-control decides when its library stops.

#include <signal.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cstdio>
#include <string>

#include "control/isolated_law.hpp"

// In sanitizer builds: a crash in the library must end the host by its signal, which
// sirupp-control names, not by the sanitizer's report and exit code 1.
extern "C" const char* __asan_default_options();
extern "C" const char* __asan_default_options() {
  return "handle_segv=0:handle_sigbus=0:handle_sigfpe=0:handle_abort=0:handle_sigill=0";
}

int main(int argc, char** argv) {
  ::prctl(PR_SET_PDEATHSIG, SIGKILL);
  ::signal(SIGINT, SIG_IGN);
  ::signal(SIGTERM, SIG_IGN);
  int type = 0;
  socklen_t length = sizeof type;
  if (argc != 3 || ::getsockopt(3, SOL_SOCKET, SO_TYPE, &type, &length) != 0 ||
      type != SOCK_SEQPACKET) {
    std::fprintf(stderr,
                 "usage: sirupp-controller-host LIBRARY ARGS (descriptor 3: socket, 4: shared "
                 "block)\nStarted by sirupp-control --controller LIBRARY; not for use by hand.\n");
    return 2;
  }
  ::close_range(5, ~0U, 0);  // nothing of sirupp-control's (its LCM sockets) stays open here
  return sirupp::control::RunControllerHost(3, 4, argv[1], argv[2]);
}
