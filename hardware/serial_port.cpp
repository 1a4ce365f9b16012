#include "hardware/serial_port.hpp"

#include <fcntl.h>
#include <limits.h>
#include <poll.h>
#include <signal.h>
#include <sys/file.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <termios.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>

#include "hardware/nmc_protocol.hpp"

namespace sirupp::hardware {
namespace {

std::string Reason() { return std::strerror(errno); }

speed_t SpeedFor(int baud, const std::string& device) {
  switch (baud) {
    case 9600:
      return B9600;
    case 19200:
      return B19200;
    case 57600:
      return B57600;
    case 115200:
      return B115200;
    case 230400:
      return B230400;
    default:
      throw SerialError(device + ": baud " + std::to_string(baud) +
                        " is not allowed; allowed: " + nmc::SupportedBauds());
  }
}

void MakeRaw(int fd, speed_t speed, const std::string& device) {
  termios t{};
  if (tcgetattr(fd, &t) != 0) {
    throw SerialError(device + ": not a serial device (tcgetattr: " + Reason() + ")");
  }
  cfmakeraw(&t);
  t.c_cflag |= CLOCAL | CREAD;
  t.c_cflag &= ~static_cast<tcflag_t>(CSTOPB | PARENB | CRTSCTS);
  t.c_iflag &= ~static_cast<tcflag_t>(IXON | IXOFF | IXANY);
  t.c_cc[VMIN] = 0;
  t.c_cc[VTIME] = 0;
  cfsetispeed(&t, speed);
  cfsetospeed(&t, speed);
  if (tcsetattr(fd, TCSANOW, &t) != 0) {
    throw SerialError(device + ": cannot set raw 8N1 (tcsetattr: " + Reason() + ")");
  }
}

std::string RealPath(const std::string& path) {
  char resolved[PATH_MAX];
  if (::realpath(path.c_str(), resolved) == nullptr) return "";
  return resolved;
}

bool IsPseudoTerminal(const std::string& real_path) { return real_path.rfind("/dev/pts/", 0) == 0; }

// The pid a lock file names (UUCP: ten digits and a newline), 0 if none.
pid_t LockHolder(int fd) {
  char text[32] = {};
  const ssize_t n = ::pread(fd, text, sizeof text - 1, 0);
  if (n <= 0) return 0;
  return static_cast<pid_t>(std::strtol(text, nullptr, 10));
}

// "pid 1234 (sirupp-hardware)"
std::string DescribeProcess(pid_t pid) {
  std::string name;
  std::ifstream comm("/proc/" + std::to_string(pid) + "/comm");
  std::getline(comm, name);
  return "pid " + std::to_string(pid) + (name.empty() ? "" : " (" + name + ")");
}

bool Alive(pid_t pid) { return ::kill(pid, 0) == 0 || errno == EPERM; }

sockaddr_un UnixAddress(const std::string& path) {
  sockaddr_un address{};
  address.sun_family = AF_UNIX;
  if (path.size() >= sizeof address.sun_path) {
    throw SerialError(path + ": a socket path may have at most " +
                      std::to_string(sizeof address.sun_path - 1) + " characters");
  }
  std::memcpy(address.sun_path, path.c_str(), path.size() + 1);
  return address;
}

// A connected non-blocking Unix stream socket, or -1 with errno set.
int ConnectUnix(const std::string& path) {
  if (path.size() >= sizeof(sockaddr_un::sun_path)) {
    errno = ENAMETOOLONG;
    return -1;
  }
  const sockaddr_un address = UnixAddress(path);
  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return -1;
  if (::connect(fd, reinterpret_cast<const sockaddr*>(&address), sizeof address) != 0) {
    const int error = errno;
    ::close(fd);
    errno = error;
    return -1;
  }
  ::fcntl(fd, F_SETFL, ::fcntl(fd, F_GETFL) | O_NONBLOCK);
  return fd;
}

}  // namespace

std::string SerialLockPath(const std::string& device) {
  const std::string real = RealPath(device);
  if (real.empty()) return "";
  std::string name = real.rfind("/dev/", 0) == 0 ? real.substr(5) : real.substr(1);
  for (char& c : name) {
    if (c == '/') c = '_';
  }
  const std::string dir = ::access("/run/lock", W_OK | X_OK) == 0 ? "/run/lock" : "/tmp";
  return dir + "/LCK.." + name;
}

SerialPort::SerialPort(const std::string& device, int baud) : device_(device) {
  const speed_t speed = SpeedFor(baud, device);
  const std::string real = RealPath(device);
  const std::string shown = real.empty() || real == device ? device : device + " (" + real + ")";
  // The lock first: a port in use is refused before it is opened (opening may toggle its lines).
  lock_path_ = SerialLockPath(device);
  for (int attempt = 0; !lock_path_.empty() && lock_fd_ < 0; ++attempt) {
    const int fd = ::open(lock_path_.c_str(), O_RDWR | O_CREAT | O_CLOEXEC | O_NOFOLLOW, 0644);
    if (fd < 0) {
      throw SerialError(shown + ": cannot create the lock file " + lock_path_ + " (" + Reason() +
                        ")");
    }
    if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
      const pid_t holder = LockHolder(fd);
      ::close(fd);
      throw SerialError(shown + ": in use by " +
                        (holder > 0 ? DescribeProcess(holder) : std::string("another process")) +
                        ", lock " + lock_path_ + "; stop it first");
    }
    // The file locked must still be the one at the path: a holder that just exited removes it.
    struct stat held {};
    struct stat named {};
    if (::fstat(fd, &held) != 0 || ::stat(lock_path_.c_str(), &named) != 0 ||
        held.st_ino != named.st_ino || held.st_dev != named.st_dev) {
      ::close(fd);
      if (attempt < 5) continue;
      throw SerialError(shown + ": the lock file " + lock_path_ + " keeps changing");
    }
    // A lock of another program in the UUCP way (a live pid, no flock) is respected too; a pid
    // that is gone is a stale lock (a killed process) and is taken over.
    const pid_t holder = LockHolder(fd);
    if (holder > 0 && holder != ::getpid() && Alive(holder)) {
      ::close(fd);
      throw SerialError(shown + ": in use by " + DescribeProcess(holder) + ", lock " + lock_path_ +
                        " (remove the file if that process does not use the port)");
    }
    char text[16];
    std::snprintf(text, sizeof text, "%10d\n", static_cast<int>(::getpid()));
    if (::ftruncate(fd, 0) != 0 || ::pwrite(fd, text, std::strlen(text), 0) < 0) {
      ::close(fd);
      throw SerialError(shown + ": cannot write the lock file " + lock_path_ + " (" + Reason() +
                        ")");
    }
    lock_fd_ = fd;
  }
  struct stat kind {};
  socket_ = ::stat(device.c_str(), &kind) == 0 && S_ISSOCK(kind.st_mode);
  fd_ = socket_ ? ConnectUnix(device)
                : ::open(device.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
  if (fd_ < 0) {
    const int error = errno;
    const std::string reason = std::strerror(error);
    if (lock_fd_ >= 0) {
      ::unlink(lock_path_.c_str());
      ::close(lock_fd_);
      lock_fd_ = -1;
    }
    if (error == EBUSY) {
      throw SerialError(shown +
                        ": in use: another process has it open exclusively (TIOCEXCL) "
                        "without the lock file; find it with: fuser -v " +
                        (real.empty() ? device : real));
    }
    throw SerialError(device + ": cannot open (" + reason + ")");
  }
  if (socket_) {
    baud_ = baud;
    DiscardInput();
    return;
  }
  try {
    MakeRaw(fd_, speed, device);
    if (!IsPseudoTerminal(real) && ::ioctl(fd_, TIOCEXCL) != 0) {
      throw SerialError(shown + ": cannot make it exclusive (TIOCEXCL: " + Reason() + ")");
    }
  } catch (...) {
    ::close(fd_);
    fd_ = -1;
    if (lock_fd_ >= 0) {
      ::unlink(lock_path_.c_str());
      ::close(lock_fd_);
      lock_fd_ = -1;
    }
    throw;
  }
  baud_ = baud;
  tcflush(fd_, TCIOFLUSH);
}

SerialPort::~SerialPort() {
  if (fd_ >= 0) {
    ::ioctl(fd_, TIOCNXCL);
    ::close(fd_);
  }
  if (lock_fd_ >= 0) {
    ::unlink(lock_path_.c_str());  // while still holding it (see the inode check above)
    ::close(lock_fd_);
  }
}

void SerialPort::Write(const uint8_t* bytes, size_t n) {
  size_t done = 0;
  while (done < n) {
    const ssize_t w = socket_ ? ::send(fd_, bytes + done, n - done, MSG_NOSIGNAL)
                              : ::write(fd_, bytes + done, n - done);
    if (w > 0) {
      done += static_cast<size_t>(w);
      continue;
    }
    if (w < 0 && errno != EAGAIN && errno != EINTR) {
      throw SerialError(device_ + ": write failed (" + Reason() + ")");
    }
    pollfd p{fd_, POLLOUT, 0};
    if (::poll(&p, 1, 1000) == 0) throw SerialError(device_ + ": write blocked for 1 s");
  }
}

size_t SerialPort::Read(uint8_t* bytes, size_t max, std::chrono::microseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  for (;;) {
    const ssize_t r = ::read(fd_, bytes, max);
    if (r > 0) return static_cast<size_t>(r);
    if (r == 0 && socket_) throw SerialError(device_ + ": the other end hung up");
    if (r < 0 && errno != EAGAIN && errno != EINTR) {
      throw SerialError(device_ + ": read failed (" + Reason() + ")");
    }
    const auto left = std::chrono::duration_cast<std::chrono::microseconds>(
        deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0) return 0;
    // poll's resolution is a millisecond; round up so short waits are not busy loops.
    pollfd p{fd_, POLLIN, 0};
    const int ms = static_cast<int>((left.count() + 999) / 1000);
    const int ready = ::poll(&p, 1, ms);
    if (ready < 0 && errno != EINTR)
      throw SerialError(device_ + ": poll failed (" + Reason() + ")");
    if (ready > 0 && (p.revents & (POLLERR | POLLNVAL))) {
      throw SerialError(device_ + ": the device went away");
    }
    if (ready > 0 && (p.revents & POLLHUP) && !(p.revents & POLLIN)) {
      throw SerialError(device_ + ": the other end hung up");
    }
  }
}

void SerialPort::SetBaud(int baud) {
  const speed_t speed = SpeedFor(baud, device_);
  if (socket_) {
    baud_ = baud;
    return;
  }
  termios t{};
  if (tcgetattr(fd_, &t) != 0) throw SerialError(device_ + ": tcgetattr: " + Reason());
  cfsetispeed(&t, speed);
  cfsetospeed(&t, speed);
  if (tcsetattr(fd_, TCSADRAIN, &t) != 0) {
    throw SerialError(device_ + ": cannot switch to " + std::to_string(baud) + " baud (" +
                      Reason() + ")");
  }
  baud_ = baud;
}

void SerialPort::DiscardInput() {
  if (!socket_) {
    tcflush(fd_, TCIFLUSH);
    return;
  }
  uint8_t scrap[256];
  while (::read(fd_, scrap, sizeof scrap) > 0) {
  }
}

SocketLine::SocketLine(const std::string& path) : path_(path) {
  const sockaddr_un address = UnixAddress(path);
  struct stat st {};
  if (::lstat(path.c_str(), &st) == 0) {
    if (!S_ISSOCK(st.st_mode)) {
      throw SerialError(path + ": exists and is not a socket; not replacing it");
    }
    ::unlink(path.c_str());
  }
  listen_ = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
  if (listen_ < 0) throw SerialError(path + ": cannot make a socket (" + Reason() + ")");
  if (::bind(listen_, reinterpret_cast<const sockaddr*>(&address), sizeof address) != 0 ||
      ::listen(listen_, 2) != 0) {
    const std::string reason = Reason();
    ::close(listen_);
    throw SerialError(path + ": cannot listen (" + reason + ")");
  }
}

SocketLine::~SocketLine() {
  Drop();
  if (listen_ >= 0) {
    ::close(listen_);
    ::unlink(path_.c_str());
  }
}

bool SocketLine::Accept() {
  const int fd = ::accept4(listen_, nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
  if (fd < 0) return false;
  if (client_ >= 0) {  // one line, one client: the bridge's lock file keeps a second away
    ::close(fd);
    return false;
  }
  client_ = fd;
  return true;
}

void SocketLine::Drop() {
  if (client_ >= 0) ::close(client_);
  client_ = -1;
}

bool SocketLine::Send(const uint8_t* bytes, size_t n) {
  size_t done = 0;
  while (done < n) {
    const ssize_t w = ::send(client_, bytes + done, n - done, MSG_NOSIGNAL);
    if (w > 0) {
      done += static_cast<size_t>(w);
      continue;
    }
    if (w < 0 && errno == EINTR) continue;
    if (w < 0 && errno == EAGAIN) return true;  // nobody reads: the rest is lost, as on a line
    return false;
  }
  return true;
}

PseudoTerminal::PseudoTerminal() {
  master_ = ::posix_openpt(O_RDWR | O_NOCTTY | O_CLOEXEC);
  if (master_ < 0) throw SerialError("cannot open a pseudo-terminal (" + Reason() + ")");
  if (::grantpt(master_) != 0 || ::unlockpt(master_) != 0) {
    ::close(master_);
    throw SerialError("cannot unlock the pseudo-terminal (" + Reason() + ")");
  }
  char name[128];
  if (::ptsname_r(master_, name, sizeof name) != 0) {
    ::close(master_);
    throw SerialError("cannot name the pseudo-terminal (" + Reason() + ")");
  }
  slave_path_ = name;
  slave_ = ::open(name, O_RDWR | O_NOCTTY | O_CLOEXEC);
  if (slave_ < 0) {
    ::close(master_);
    throw SerialError(slave_path_ + ": cannot open (" + Reason() + ")");
  }
  MakeRaw(slave_, B19200, slave_path_);
  const int flags = ::fcntl(master_, F_GETFL);
  ::fcntl(master_, F_SETFL, flags | O_NONBLOCK);
}

PseudoTerminal::~PseudoTerminal() {
  if (!link_.empty()) ::unlink(link_.c_str());
  if (slave_ >= 0) ::close(slave_);
  if (master_ >= 0) ::close(master_);
}

void PseudoTerminal::LinkTo(const std::string& link) {
  struct stat st {};
  if (::lstat(link.c_str(), &st) == 0) {
    if (!S_ISLNK(st.st_mode)) {
      throw SerialError(link + ": exists and is not a symbolic link; not replacing it");
    }
    ::unlink(link.c_str());
  }
  if (::symlink(slave_path_.c_str(), link.c_str()) != 0) {
    throw SerialError(link + ": cannot link to " + slave_path_ + " (" + Reason() + ")");
  }
  link_ = link;
}

}  // namespace sirupp::hardware
