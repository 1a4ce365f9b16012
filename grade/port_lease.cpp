#include "grade/port_lease.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <stdexcept>
#include <system_error>

namespace sirupp::grade {

// A udpm port is the machine's, so its locks are too: one folder for every process, whatever its
// TMPDIR (the Python tests give each test a TMPDIR of its own; with the locks under it, a
// notebook's rig and another test's rig leased the same port at once, and the notebook's move got
// no reply).
std::string DefaultPortLockDirectory() { return "/tmp/sirupp-grade-ports"; }

PortLease PortLease::Acquire(int first, int count, int start_offset, const std::string& directory) {
  if (count < 1 || first < 1 || first + count - 1 > 65535) {
    throw std::invalid_argument("port range " + std::to_string(first) + " + " +
                                std::to_string(count) + ": allowed within 1..65535");
  }
  const std::string dir = directory.empty() ? DefaultPortLockDirectory() : directory;
  std::error_code ignored;
  if (std::filesystem::create_directories(dir, ignored)) {
    // Shared by every user's graders: anyone may add a lock file, nobody removes another's.
    ::chmod(dir.c_str(), 01777);
  }
  std::string last_error;
  const int start = ((start_offset % count) + count) % count;
  for (int k = 0; k < count; ++k) {
    const int port = first + (start + k) % count;
    const std::string file = dir + "/" + std::to_string(port) + ".lock";
    const int fd = ::open(file.c_str(), O_RDONLY | O_CREAT | O_CLOEXEC, 0666);
    if (fd < 0) {
      last_error = file + ": " + std::strerror(errno);
      continue;
    }
    ::fchmod(fd, 0666);  // the umask must not lock other users out (fails harmlessly if not ours)
    if (::flock(fd, LOCK_EX | LOCK_NB) == 0) {
      PortLease lease;
      lease.port_ = port;
      lease.fd_ = fd;
      return lease;
    }
    ::close(fd);
  }
  throw std::runtime_error("no free grading port in " + std::to_string(first) + ".." +
                           std::to_string(first + count - 1) + " (locks in " + dir + ")" +
                           (last_error.empty() ? "" : ": " + last_error));
}

PortLease::PortLease(PortLease&& other) noexcept : port_(other.port_), fd_(other.fd_) {
  other.port_ = 0;
  other.fd_ = -1;
}

PortLease& PortLease::operator=(PortLease&& other) noexcept {
  if (this != &other) {
    Release();
    port_ = other.port_;
    fd_ = other.fd_;
    other.port_ = 0;
    other.fd_ = -1;
  }
  return *this;
}

PortLease::~PortLease() { Release(); }

void PortLease::Release() {
  if (fd_ >= 0) ::close(fd_);  // closing drops the flock
  fd_ = -1;
  port_ = 0;
}

}  // namespace sirupp::grade
