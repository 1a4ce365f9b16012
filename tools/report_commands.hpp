#pragma once
// `sirupp report FILE...`: the Table II report of data files written by sirupp-logger and of LCM
// log files written by lcm-logger (logger/report.hpp).

#include <iosfwd>
#include <string>
#include <vector>

#include "logger/report.hpp"

namespace sirupp::tools {

extern const char* const kReportAbout;

// The SIRUPP paper's Table II as a reference column (`--reference paper`, and sirupp demo).
logger::ReferenceColumn PaperReference();

// `--compare`'s section: per set and joint the virtual-vs-real means of `other` (A) and `ours`
// (B), the mean over the transient and steady means both have and its change in %.
std::string CompareSection(const std::vector<logger::ReferenceRow>& ours,
                           const std::vector<logger::ReferenceRow>& other,
                           const std::string& ours_name, const std::string& other_name);

// Prints the Markdown report and writes it with the CSV tables and the plots. Bad input files
// throw core::ConfigError (exit 2), bad arguments core::UsageError (exit 2).
int RunReport(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

}  // namespace sirupp::tools
