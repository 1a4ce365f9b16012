#include "runtime/data_path.hpp"

#include <filesystem>

#ifndef SIRUPP_SOURCE_DIR
#define SIRUPP_SOURCE_DIR "."
#endif

namespace sirupp::runtime {

std::string ResolveDataPath(const std::string& path) {
  namespace fs = std::filesystem;
  if (fs::exists(path) || fs::path(path).is_absolute()) return path;
  const fs::path in_source = fs::path(SIRUPP_SOURCE_DIR) / path;
  return fs::exists(in_source) ? in_source.string() : path;
}

Flag ModelFlag() {
  return Flag("model", std::string("robot model file (default ") + kDefaultModelFile + ")")
      .Takes("FILE");
}

std::string ModelFileArg(const Args& args) {
  return ResolveDataPath(args.Has("model") ? args.String("model") : kDefaultModelFile);
}

}  // namespace sirupp::runtime
