#pragma once
// `sirupp panel [FLAGS]`: starts sirupp-panel (panel/), which prints the address, and opens a
// browser on it when there is a display.

#include <iosfwd>
#include <string>
#include <vector>

namespace sirupp::tools {

extern const char* const kPanelAbout;

// Replaces this process with sirupp-panel (found beside `sirupp`); returns only when that fails.
int RunPanel(const std::vector<std::string>& args, std::ostream& err);

}  // namespace sirupp::tools
