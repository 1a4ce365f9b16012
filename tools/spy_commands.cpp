#include "tools/spy_commands.hpp"

#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <ostream>

#include "core/errors.hpp"
#include "launch/supervisor.hpp"
#include "runtime/args.hpp"
#include "runtime/data_path.hpp"
#include "tools/launch_commands.hpp"

namespace sirupp::tools {

namespace fs = std::filesystem;

const char* const kSpyAbout =
    "Starts lcm-spy with this build's types (build/java/sirupp_lcmtypes.jar), so every SIRUPP\n"
    "channel decodes by name. Needs a display (DISPLAY; over ssh use ssh -X, on a server\n"
    "xvfb-run). Channels show with their rig prefix.\n"
    "  --lcm-url URL     the bus to watch (default: LCM's default URL, or $LCM_DEFAULT_URL)\n"
    "  --jar FILE        another types jar (e.g. a student's own types, colon-separated list)\n"
    "  --check           no window: list the LCM types lcm-spy will find, exit 0 if ours are "
    "there\n"
    "  --print-command   print the Java command line instead of running it\n";

namespace {

constexpr const char* kLcmJar = "/usr/share/java/lcm.jar";
constexpr const char* kChartJar = "/usr/share/java/jchart2d.jar";

// The jars lcm-spy needs: LCM's, jchart2d's and each of `jar` (a colon-separated list); false
// with what to install or build on `err` if one is missing.
bool JarsPresent(const std::string& jar, std::ostream& err) {
  for (const std::string& file : {std::string(kLcmJar), std::string(kChartJar)}) {
    if (!fs::exists(file)) {
      err << "sirupp spy: " << file
          << " is missing; install liblcm-java and libjchart2d-java (scripts/install-deps.sh)\n";
      return false;
    }
  }
  size_t start = 0;
  while (start <= jar.size()) {
    const size_t end = jar.find(':', start);
    const std::string one = jar.substr(start, end == std::string::npos ? end : end - start);
    if (!fs::exists(one)) {
      err << "sirupp spy: types jar " << one
          << " not found; build the project (scripts/build.sh) or give --jar FILE\n";
      return false;
    }
    if (end == std::string::npos) break;
    start = end + 1;
  }
  return true;
}

// Runs `argv` (Java's class discovery) and returns what it printed and its wait status.
std::string OutputOf(std::vector<char*>& argv, int& status) {
  int fds[2];
  if (::pipe(fds) != 0) throw std::runtime_error("spy --check: pipe failed");
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::dup2(fds[1], STDOUT_FILENO);
    ::close(fds[0]);
    ::close(fds[1]);
    ::execv(argv[0], argv.data());
    ::_exit(127);
  }
  ::close(fds[1]);
  std::string text;
  char buffer[4096];
  for (ssize_t n; (n = ::read(fds[0], buffer, sizeof buffer)) > 0;) {
    text.append(buffer, static_cast<size_t>(n));
  }
  ::close(fds[0]);
  status = 0;
  ::waitpid(pid, &status, 0);
  return text;
}

// --check: lists the LCM types of ours that Java's class discovery finds in `jar` (it prints
// "JAR class NAME" per class found), and our lcm-spy plugins; exit 1 if it failed or found none.
int CheckTypes(std::vector<char*>& argv, const std::string& jar, std::ostream& out,
               std::ostream& err) {
  int status = 0;
  const std::string text = OutputOf(argv, status);
  int found = 0;
  std::vector<std::string> plugins;  // sirupp.spy.*: lcm-spy plugins, not message types
  size_t at = 0;
  while ((at = text.find(" class sirupp.", at)) != std::string::npos) {
    at += 14;
    const size_t end = text.find('\n', at);
    const std::string name = text.substr(at, end - at);
    if (name.rfind("spy.", 0) == 0) {
      if (name.find('$') == std::string::npos) plugins.push_back("sirupp." + name);
      continue;
    }
    out << "  sirupp." << name << "\n";
    ++found;
  }
  out << "lcm-spy finds " << found << " sirupp types in " << jar << "\n";
  for (const std::string& plugin : plugins) out << "  plugin " << plugin << "\n";
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0 || found == 0) {
    err << "sirupp spy --check: Java's class discovery failed or found none of our types\n";
    return 1;
  }
  return 0;
}

// lcm-spy is a Swing window: it needs a Java with a GUI (default-jre-headless alone cannot show
// it) and a display; false with what is missing on `err`.
bool CanShowWindow(std::ostream& err) {
  bool headful = false;
  std::error_code ec;
  for (const auto& jvm : fs::directory_iterator("/usr/lib/jvm", ec)) {
    headful = headful || fs::exists(jvm.path() / "lib" / "libawt_xawt.so");
  }
  if (!headful) {
    err << "sirupp spy: the installed Java is headless (no libawt_xawt.so under /usr/lib/jvm), so "
           "lcm-spy cannot open its window; install default-jre (scripts/install-deps.sh)\n";
    return false;
  }
  const char* display = std::getenv("DISPLAY");
  if (!display || !*display) {
    err << "sirupp spy: lcm-spy needs a display and DISPLAY is not set; use ssh -X, or xvfb-run "
           "on a server (sirupp spy --check works without one)\n";
    return false;
  }
  return true;
}

}  // namespace

int RunSpy(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  const runtime::Args parsed(
      args, "spy",
      {runtime::Flag("lcm-url", "LCM URL").Takes("URL"),
       runtime::Flag("jar", "the lcmtypes jar (default: the build's sirupp_lcmtypes.jar)")
           .Takes("FILE"),
       runtime::Flag("check", "no window: list the LCM types lcm-spy finds (exit 0 if ours are)")
           .Switch(),
       runtime::Flag("print-command", "print the Java command line instead of running it")
           .Switch()},
      kSpyAbout);
  // The build's jar beside its bin/, else the installed one (<prefix>/share/sirupp/java).
  std::string jar = (fs::path(ProgramDir()) / ".." / "java" / "sirupp_lcmtypes.jar").string();
  if (!fs::exists(jar)) jar = runtime::ResolveDataPath("java/sirupp_lcmtypes.jar");
  if (parsed.Has("jar")) jar = parsed.String("jar");
  const bool check = parsed.Switch("check");
  const bool print = parsed.Switch("print-command");
  if (check && print) throw core::UsageError("spy: --check and --print-command exclude each other");
  if (!JarsPresent(jar, err)) return 1;
  const std::string java = launch::ResolveProgram("java", "");
  if (java.empty()) {
    err << "sirupp spy: java not found on PATH; install default-jre-headless "
           "(scripts/install-deps.sh)\n";
    return 1;
  }
  const std::string classpath = std::string(kLcmJar) + ":" + kChartJar + ":" + jar;
  std::vector<std::string> command = {java, "-Djava.net.preferIPv4Stack=true", "-cp", classpath};
  if (check) {
    command.push_back("lcm.util.ClassDiscoverer");
  } else {
    command.push_back("lcm.spy.Spy");
    if (parsed.Has("lcm-url")) command.push_back("--lcm-url=" + parsed.String("lcm-url"));
  }
  if (print) {
    std::string line;
    for (const std::string& w : command) line += (line.empty() ? "" : " ") + w;
    out << line << "\n";
    return 0;
  }
  std::vector<char*> argv;
  for (std::string& w : command) argv.push_back(w.data());
  argv.push_back(nullptr);
  if (check) return CheckTypes(argv, jar, out, err);
  if (!CanShowWindow(err)) return 1;
  out << std::flush;
  ::execv(argv[0], argv.data());
  err << "sirupp spy: cannot start " << java << "\n";
  return 1;
}

}  // namespace sirupp::tools
