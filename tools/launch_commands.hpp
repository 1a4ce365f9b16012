#pragma once
// `sirupp launch LAYOUT [--host NAME]`: runs this host's share of a lab layout (launch/) with a
// live status table from the heartbeats; Ctrl-C stops it cleanly.

#include <iosfwd>
#include <string>
#include <vector>

namespace sirupp::tools {

extern const char* const kLaunchAbout;

// Exit 0 when every process ran and stopped cleanly, 1 when one failed (crash, non-zero exit, not
// ready in time, killed at stop), 2 for a bad layout or bad arguments.
int RunLaunch(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

// This machine's host name; the directory of the running program (where sirupp-* are looked up).
std::string MachineName();
std::string ProgramDir();
// Local time as YYYYmmdd-HHMMSS, for the names of run and results folders.
std::string LocalTimestamp();

}  // namespace sirupp::tools
