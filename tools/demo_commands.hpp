#pragma once
// `sirupp demo`: the main job. Runs the paper's experiment headless on this PC: physics, the
// virtual servos, the hardware bridge on the emulated PIC-SERVO boards, the logger and the viewer
// (the layout config/labs/demo.yaml) run movement sets I..VII, then the Table II report is written.

#include <iosfwd>
#include <string>
#include <vector>

namespace sirupp::tools {

extern const char* const kDemoAbout;

// Exit 0 when every set ran and every process stopped cleanly, 1 otherwise, 2 for bad arguments.
int RunDemo(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

}  // namespace sirupp::tools
