// Writes one file without end (args: its path), 1 MB at a time, and reports how far it got. The
// sandbox's file-size limit (RLIMIT_FSIZE: SIGXFSZ) stops it; its /tmp is private.
#include <fcntl.h>
#include <unistd.h>

#include <vector>

#include "hostile.hpp"

namespace {

class HugeFile : public hostile::Hostile {
 public:
  explicit HugeFile(const std::string& args) : path_(args) {}

 protected:
  void Act() override {
    const int fd = ::open(path_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (fd < 0) throw std::runtime_error("cannot create " + path_ + ": " + hostile::Errno());
    const std::vector<char> block(1u << 20, 'x');
    for (long megabytes = 0;; ++megabytes) {
      if (::write(fd, block.data(), block.size()) < 0) {
        const std::string error = hostile::Errno();
        ::close(fd);
        throw std::runtime_error("write to " + path_ + " failed after " +
                                 std::to_string(megabytes) + " MB: " + error);
      }
    }
  }

 private:
  std::string path_;
};

}  // namespace

SIRUPP_EXPORT_CONTROLLER(HugeFile)
