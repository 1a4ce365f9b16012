#include "tools/panel_commands.hpp"

#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <ostream>

#include "tools/launch_commands.hpp"

namespace sirupp::tools {

const char* const kPanelAbout =
    "  Starts sirupp-panel, the lab panel in the browser, and prints its address\n"
    "  (http://127.0.0.1:8765/ by default); opens a browser on it when there is a display\n"
    "  (--no-open: do not). --listen ADDR serves a lab network: the printed address then\n"
    "  carries the token that every change needs. Other flags: sirupp-panel --help.\n";

int RunPanel(const std::vector<std::string>& args, std::ostream& err) {
  const std::string program = ProgramDir() + "/sirupp-panel";
  std::vector<std::string> forwarded{program};
  bool open = true;
  for (const std::string& arg : args) {
    if (arg == "--help" || arg == "-h") {
      // This command's own flag, then sirupp-panel's flags (it takes the rest).
      err << "sirupp panel [--no-open] [sirupp-panel flags]\n" << kPanelAbout << std::flush;
    }
    if (arg == "--no-open") {
      open = false;
    } else {
      forwarded.push_back(arg);
    }
  }
  if (open) forwarded.emplace_back("--open");
  std::vector<char*> argv;
  for (std::string& arg : forwarded) argv.push_back(arg.data());
  argv.push_back(nullptr);
  execv(program.c_str(), argv.data());
  err << "sirupp: cannot start " << program << ": " << std::strerror(errno)
      << " (build the sirupp-panel target)\n";
  return 1;
}

}  // namespace sirupp::tools
