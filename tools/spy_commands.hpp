#pragma once
// `sirupp spy`: LCM's lcm-spy with the types jar of this build on its class path, so every channel
// decodes by name. Debian's /usr/bin/lcm-spy (LCM 1.3.1) passes -Xincgc, which Java 9 and later
// refuse, so this starts Java itself (see /work/shared/reference/lcm.md and docs/launch.md).

#include <iosfwd>
#include <string>
#include <vector>

namespace sirupp::tools {

extern const char* const kSpyAbout;

// Replaces this process with Java running lcm.spy.Spy (exit 1 if it cannot), or with --check lists
// the types lcm-spy will find, or with --print-command prints the command line.
int RunSpy(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

}  // namespace sirupp::tools
