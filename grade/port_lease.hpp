#pragma once
// A private udpm port for one task, collision-free between every grader on the machine.
//
// LCM binds its udpm port with SO_REUSEADDR, so two processes can bind one port and then hear
// each other: trying to bind a port says nothing about whether another grader uses it. Instead a
// grader takes a lock per port: an flock on DIR/PORT.lock (DIR: the system's temporary folder's
// sirupp-grade-ports/), held while its task runs. Ports are tried in turn from a start that
// differs per process, wrapping around the range, so two graders (or two jobs of one grader)
// never get the same port at once. The kernel drops an flock when its holder ends, so a killed
// grader leaves no stale lock behind.

#include <string>

namespace sirupp::grade {

class PortLease {
 public:
  // The first free port of [first, first + count), trying first + start_offset % count first.
  // Throws std::runtime_error naming the folder when every port is taken or the locks cannot be
  // made. `directory`: where the lock files go ("" = the default above).
  static PortLease Acquire(int first, int count, int start_offset,
                           const std::string& directory = "");

  PortLease() = default;
  PortLease(PortLease&& other) noexcept;
  PortLease& operator=(PortLease&& other) noexcept;
  PortLease(const PortLease&) = delete;
  PortLease& operator=(const PortLease&) = delete;
  ~PortLease();

  int port() const { return port_; }  // 0: none held
  // Gives the port back (the destructor does too).
  void Release();

 private:
  int port_ = 0;
  int fd_ = -1;
};

// The default folder of the lock files: /tmp/sirupp-grade-ports for every process, whatever its
// TMPDIR (a udpm port is the machine's). A service with PrivateTmp has a /tmp of its own: its
// class rigs also check that a port is quiet before they take it (proc/udpm_listen.hpp).
std::string DefaultPortLockDirectory();

}  // namespace sirupp::grade
