#include "runtime/data_path.hpp"

#include <dlfcn.h>
#include <link.h>

#include <cstdlib>
#include <filesystem>
#include <system_error>
#include <utility>

#ifndef SIRUPP_SOURCE_DIR
#define SIRUPP_SOURCE_DIR "."
#endif
#ifndef SIRUPP_BINARY_DIR
#define SIRUPP_BINARY_DIR ""
#endif
#ifndef SIRUPP_INSTALL_DATA_DIR
#define SIRUPP_INSTALL_DATA_DIR "/usr/share/sirupp"
#endif

namespace sirupp::runtime {
namespace {

namespace fs = std::filesystem;

// The file this code was loaded from: the shared object holding it (the Python module) when it is
// one, else the running program.
fs::path ThisObjectPath() {
  Dl_info info{};
  link_map* map = nullptr;
  std::error_code error;
  if (::dladdr1(reinterpret_cast<void*>(&ThisObjectPath), &info, reinterpret_cast<void**>(&map),
                RTLD_DL_LINKMAP) != 0 &&
      map != nullptr && map->l_name != nullptr && map->l_name[0] == '/') {
    const fs::path object = fs::canonical(map->l_name, error);
    if (!error) return object;
  }
  const fs::path self = fs::canonical("/proc/self/exe", error);
  return error ? fs::path() : self;
}

bool IsInside(const fs::path& file, const fs::path& folder) {
  if (file.empty() || folder.empty()) return false;
  auto f = file.begin();
  for (auto d = folder.begin(); d != folder.end(); ++d, ++f) {
    if (d->empty()) continue;  // a trailing separator
    if (f == file.end() || *f != *d) return false;
  }
  return true;
}

// The installed data folder: <prefix>/share/sirupp for the nearest prefix above `object` that has
// one with a config/ folder in it.
fs::path InstalledDataDir(const fs::path& object) {
  std::error_code error;
  for (fs::path folder = object.parent_path(); !folder.empty(); folder = folder.parent_path()) {
    const fs::path candidate = folder / "share" / "sirupp";
    if (fs::is_directory(candidate / "config", error)) return candidate;
    if (folder == folder.root_path()) break;
  }
  return SIRUPP_INSTALL_DATA_DIR;
}

std::pair<std::string, std::string> ChooseDataDir() {
  if (const char* dir = std::getenv("SIRUPP_DATA_DIR"); dir != nullptr && *dir != '\0') {
    return {dir, "SIRUPP_DATA_DIR"};
  }
  const fs::path object = ThisObjectPath();
  std::error_code error;
  const fs::path build = fs::weakly_canonical(SIRUPP_BINARY_DIR, error);
  if (object.empty() || (!error && IsInside(object, build))) {
    return {SIRUPP_SOURCE_DIR, "build tree"};
  }
  return {InstalledDataDir(object).string(), "installed"};
}

const std::pair<std::string, std::string>& Chosen() {
  static const std::pair<std::string, std::string> chosen = ChooseDataDir();
  return chosen;
}

}  // namespace

std::string DataDir() { return Chosen().first; }

std::string DataDirOrigin() { return Chosen().second; }

std::string ResolveDataPath(const std::string& path) {
  std::error_code error;
  if (fs::path(path).is_absolute() || fs::exists(path, error)) return path;
  const fs::path in_data = fs::path(DataDir()) / path;
  return fs::exists(in_data, error) ? in_data.string() : path;
}

Flag ModelFlag() {
  return Flag("model", std::string("robot model file (default ") + kDefaultModelFile + ")")
      .Takes("FILE");
}

std::string ModelFileArg(const Args& args) {
  return ResolveDataPath(args.Has("model") ? args.String("model") : kDefaultModelFile);
}

}  // namespace sirupp::runtime
