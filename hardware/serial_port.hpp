#pragma once
// Byte streams for the NMC bus: the POSIX serial port the bridge opens (a USB-RS485 adapter, or the
// emulator's pseudo-terminal), and the pseudo-terminal the emulator serves. Raw 8N1, no flow
// control, no line discipline. Errors throw SerialError naming the device and the system's reason.

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>

namespace sirupp::hardware {

class SerialError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// What NmcBus talks through; tests may supply their own.
class BytePort {
 public:
  virtual ~BytePort() = default;
  // Writes every byte (blocking until the kernel took them).
  virtual void Write(const uint8_t* bytes, size_t n) = 0;
  // Reads up to `max` bytes, waiting at most `timeout` for the first; returns 0 on timeout.
  virtual size_t Read(uint8_t* bytes, size_t max, std::chrono::microseconds timeout) = 0;
  // Switches the line speed (the host side of SET_BAUD).
  virtual void SetBaud(int baud) = 0;
  virtual int baud() const = 0;
  // Throws away whatever has arrived and not been read.
  virtual void DiscardInput() = 0;
  virtual std::string name() const = 0;
};

// The lock file that makes a serial device one process's: /run/lock/LCK..NAME where /run/lock
// is writable by this user (Debian makes it world-writable), else /tmp/LCK..NAME. NAME is the
// device's real path (symbolic links resolved, so the emulator's link and its /dev/pts/N are one
// device) without "/dev/", with '/' as '_': LCK..ttyUSB0, LCK..pts_3. Empty if the device does
// not exist.
std::string SerialLockPath(const std::string& device);

// A serial device opened raw 8N1 at `baud` (one of 9600, 19200, 57600, 115200, 230400), for this
// process alone: first the lock file (SerialLockPath: flock, and the pid written in it as the
// UUCP convention has it, so that other programs see it too), then the device with TIOCEXCL (no
// further open() of it, except by root). A device in use is refused before it is opened, naming
// the process: "/dev/ttyUSB0: in use by pid 1234 (sirupp-hardware), lock /run/lock/LCK..ttyUSB0".
// Pseudo-terminals get the lock file only: the emulator keeps its slave open, so an exclusive
// flag left by a killed client would never clear. The lock is released (file removed,
// TIOCNXCL) by the destructor, and by the kernel when the process dies. A device that is a Unix
// socket (the emulator's SocketLine) is connected to instead, with the same lock file; SetBaud
// then only records the speed and DiscardInput reads and drops what waits.
class SerialPort : public BytePort {
 public:
  SerialPort(const std::string& device, int baud);
  ~SerialPort() override;
  SerialPort(const SerialPort&) = delete;
  SerialPort& operator=(const SerialPort&) = delete;

  void Write(const uint8_t* bytes, size_t n) override;
  size_t Read(uint8_t* bytes, size_t max, std::chrono::microseconds timeout) override;
  void SetBaud(int baud) override;
  int baud() const override { return baud_; }
  void DiscardInput() override;
  std::string name() const override { return device_; }
  int fd() const { return fd_; }
  // The lock file held (empty if the device path could not be resolved).
  const std::string& lock_path() const { return lock_path_; }

 private:
  std::string device_;
  int fd_ = -1;
  int baud_ = 0;
  int lock_fd_ = -1;
  std::string lock_path_;
  bool socket_ = false;  // the emulator's SocketLine, not a tty
};

// The master side of a new pseudo-terminal, raw. The slave stays open here too, so that the
// master keeps working while no client has the device open (and after a client closes it).
class PseudoTerminal {
 public:
  PseudoTerminal();
  ~PseudoTerminal();
  PseudoTerminal(const PseudoTerminal&) = delete;
  PseudoTerminal& operator=(const PseudoTerminal&) = delete;

  int master_fd() const { return master_; }
  // /dev/pts/N: what a client opens.
  const std::string& slave_path() const { return slave_path_; }
  // Makes `link` a symbolic link to the slave (replacing an old link, never a regular file); it
  // is removed again by the destructor.
  void LinkTo(const std::string& link);
  const std::string& link() const { return link_; }

 private:
  int master_ = -1;
  int slave_ = -1;
  std::string slave_path_;
  std::string link_;
};

// The emulator's other line: a Unix stream socket at `path` that one client at a time connects to
// (SerialPort connects when its device is a socket). Unlike a pseudo-terminal it carries bytes
// without the tty layer, whose poll() and read() wait for a kernel worker at normal priority
// to move the bytes across: on a loaded machine that worker is starved and a process at real-time
// priority waits with it, for up to seconds (measured: docs/hardware-emulator.md). Baud changes
// have no effect on a socket (the emulator times the line itself). The path is removed by the
// destructor.
class SocketLine {
 public:
  // Binds and listens at `path`; an existing socket there (a killed emulator's) is replaced, any
  // other file never.
  explicit SocketLine(const std::string& path);
  ~SocketLine();
  SocketLine(const SocketLine&) = delete;
  SocketLine& operator=(const SocketLine&) = delete;

  const std::string& path() const { return path_; }
  int listen_fd() const { return listen_; }
  // The connected client's descriptor (non-blocking), -1 if none.
  int client_fd() const { return client_; }
  // Takes a waiting client if none is connected; a second client while one is connected is
  // closed at once. True if a client was taken.
  bool Accept();
  // The client went away (read returned 0, or a write failed): ready for the next.
  void Drop();
  // Writes what it can without blocking and without SIGPIPE; false if the client is gone.
  bool Send(const uint8_t* bytes, size_t n);

 private:
  std::string path_;
  int listen_ = -1;
  int client_ = -1;
};

// Seconds one byte takes on the line at `baud`: 10 bits (start, 8 data, stop).
inline double ByteSeconds(int baud) { return 10.0 / baud; }

}  // namespace sirupp::hardware
