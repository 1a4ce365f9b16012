#pragma once
// `sirupp fit-emulator` and `sirupp identify`: the paper's experiment in one process, the fit of
// the emulated real arm to the paper's Table II, and the identification of a model's friction and
// armature from real-arm data (lab/, docs/emulator-fit.md).

#include <iosfwd>
#include <string>
#include <vector>

namespace sirupp::runtime {
class Args;
}

namespace sirupp::tools {

extern const char* const kFitEmulatorAbout;
extern const char* const kIdentifyAbout;

int RunFitEmulator(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);
int RunIdentify(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

// --sets (1 to 7 or I to VII, several) as set numbers; all seven without it. Throws
// core::UsageError naming a value that is not a movement set.
std::vector<int> MovementSetsArg(const runtime::Args& args);

}  // namespace sirupp::tools
