// Reads a file outside its own folder (args: the path; another student's file in the tests) and
// reports what it read. In the sandbox the file is not there at all.
#include <fstream>
#include <sstream>

#include "hostile.hpp"

namespace {

class ReadOther : public hostile::Hostile {
 public:
  explicit ReadOther(const std::string& args) : path_(args) {}

 protected:
  void Act() override {
    std::ifstream in(path_);
    if (!in) throw std::runtime_error("cannot open " + path_ + ": " + hostile::Errno());
    std::stringstream text;
    text << in.rdbuf();
    throw std::runtime_error("read " + path_ + ": '" + text.str().substr(0, 200) + "'");
  }

 private:
  std::string path_;
};

}  // namespace

SIRUPP_EXPORT_CONTROLLER(ReadOther)
